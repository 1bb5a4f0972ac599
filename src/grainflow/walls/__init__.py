"""grainflow.walls"""
