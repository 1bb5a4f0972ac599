"""grainflow.kernels"""
