"""grainflow.config"""
