"""grainflow: Discrete Element Method simulation and analysis of granular flows."""

__version__ = "0.1.0"
