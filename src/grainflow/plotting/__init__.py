"""Figures written by grainflow: snapshot images of frames (:mod:`grainflow.plotting.snapshot`)
and the plots of the analyses. Everything renders off-screen with matplotlib's Agg canvas.
"""
