"""grainflow.analysis"""
