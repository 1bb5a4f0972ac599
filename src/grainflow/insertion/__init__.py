"""Particle insertion and removal (SPEC M8): regions, lattice and random fills, pouring,
deletion and replenishment."""

from grainflow.insertion.lattice import (
    IDEAL_PACKING,
    MAX_LATTICE_SITES,
    lattice_fill,
    lattice_points,
    lattice_site_count,
    thin_to_packing_fraction,
)
from grainflow.insertion.pour import DeleteRegion, Pour, ReplenishTo
from grainflow.insertion.random_fill import random_fill
from grainflow.insertion.regions import BoxRegion, CylinderRegion, DiskRegion, HalfSpace, Region
from grainflow.insertion.sizes import Bidisperse, Monodisperse, UniformDiameter, particle_volume

__all__ = ["IDEAL_PACKING", "MAX_LATTICE_SITES", "Bidisperse", "BoxRegion", "CylinderRegion",
           "DeleteRegion", "DiskRegion", "HalfSpace", "Monodisperse", "Pour", "Region",
           "ReplenishTo", "UniformDiameter", "lattice_fill", "lattice_points",
           "lattice_site_count", "particle_volume", "random_fill", "thin_to_packing_fraction"]
