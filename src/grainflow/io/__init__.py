"""grainflow.io"""
