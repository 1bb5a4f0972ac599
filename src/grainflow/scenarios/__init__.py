"""grainflow.scenarios"""
