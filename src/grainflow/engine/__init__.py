"""grainflow.engine"""
