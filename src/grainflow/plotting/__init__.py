"""grainflow.plotting"""
