"""grainflow.models"""
