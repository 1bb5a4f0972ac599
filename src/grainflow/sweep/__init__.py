"""grainflow.sweep"""
