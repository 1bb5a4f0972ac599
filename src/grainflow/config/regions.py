"""The regions of a configuration (``region`` tables of fills and insertion updaters) as
:mod:`grainflow.insertion.regions` objects: one conversion for validation and building."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

__all__ = ["region_of"]


def region_of(region: Any, box_lo: Sequence[float] | None = None,
              box_hi: Sequence[float] | None = None) -> Any:
    """The region object of a validated ``region`` table; None: the box ``box_lo``-``box_hi``."""
    from grainflow.insertion import regions

    if region is None:
        return regions.BoxRegion(tuple(box_lo), tuple(box_hi))
    if region.shape == "box":
        return regions.BoxRegion(tuple(region.lo), tuple(region.hi))
    if region.shape == "cylinder":
        return regions.CylinderRegion(tuple(region.center), region.radius, region.lo,
                                      region.hi, region.axis)
    if region.shape == "halfspace":
        return regions.HalfSpace(tuple(region.point), tuple(region.normal))
    return regions.DiskRegion(tuple(region.center), region.radius)
