"""Particle insertion and removal (SPEC M8): regions, lattice and random fills, pouring,
deletion and replenishment."""

from grainflow.insertion.lattice import (
    IDEAL_PACKING,
    lattice_fill,
    lattice_points,
    thin_to_packing_fraction,
)
from grainflow.insertion.pour import DeleteRegion, Pour, ReplenishTo
from grainflow.insertion.random_fill import random_fill
from grainflow.insertion.regions import BoxRegion, CylinderRegion, DiskRegion, HalfSpace, Region
from grainflow.insertion.sizes import Bidisperse, Monodisperse, UniformDiameter, particle_volume

__all__ = ["IDEAL_PACKING", "Bidisperse", "BoxRegion", "CylinderRegion", "DeleteRegion",
           "DiskRegion", "HalfSpace", "Monodisperse", "Pour", "Region", "ReplenishTo",
           "UniformDiameter", "lattice_fill", "lattice_points", "particle_volume",
           "random_fill", "thin_to_packing_fraction"]
