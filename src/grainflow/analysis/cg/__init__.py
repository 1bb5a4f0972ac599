"""Coarse-graining: continuum fields from saved frames (SPEC A1; seed 002 Appendix C).

Three independent choices, as in MercuryCG: *coordinates* (:class:`Cartesian` grids and
slabs, :class:`Cylindrical` r-z, :class:`Polar` r-theta), a *kernel* (:class:`Heaviside`
bins, :class:`Gaussian`, :class:`Lucy`) and the *fields* (:class:`CGFields`: densities,
velocity, temperature, kinetic and contact stress with wall and tether parts, strain rate),
averaged over the frames of a time window by :func:`coarse_grain`, optionally over the
particles of chosen types only (:func:`select_types`). Everything here is a pure
function of :class:`~grainflow.frame.Frame` objects; the engine is never touched.
"""

from grainflow.analysis.cg.coordinates import Cartesian, Coordinates, Cylindrical, Polar
from grainflow.analysis.cg.fields import (FIELDS, CGFields, coarse_grain, coarse_grain_grids,
                                          combine, frame_sums, load_fields, slab_gradient,
                                          strain_rate)
from grainflow.analysis.cg.kernels import Gaussian, Heaviside, Kernel, Lucy
from grainflow.analysis.cg.selection import select_types

__all__ = ["FIELDS", "CGFields", "Cartesian", "Coordinates", "Cylindrical", "Gaussian",
           "Heaviside", "Kernel", "Lucy", "Polar", "coarse_grain", "coarse_grain_grids", "combine", "frame_sums",
           "load_fields", "select_types", "slab_gradient", "strain_rate"]
