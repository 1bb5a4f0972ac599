"""Analytic walls (SPEC M4): shapes, and their contacts through the particles' contact law."""

from grainflow.walls.force import WallForce
from grainflow.walls.geometry import (
    Cone,
    Cylinder,
    Hopper2D,
    Plane,
    PlateWithHole,
    Segment,
    Wall,
    closest_point,
)

__all__ = ["Cone", "Cylinder", "Hopper2D", "Plane", "PlateWithHole", "Segment", "Wall",
           "WallForce", "closest_point"]
