"""Analytic walls (SPEC M4): shapes, and their contacts through the particles' contact law.

Several walls combine by superposition: the forces from all walls add; each (particle, wall)
pair keeps its own contact history; walls of one ``type`` share that type's contact
parameters.
"""

from grainflow.walls.force import WallForce
from grainflow.walls.geometry import (
    ClosestPoint,
    Cone,
    Cylinder,
    Hopper2D,
    Plane,
    PlateWithHole,
    Segment,
    Wall,
    closest_point,
)

__all__ = ["ClosestPoint", "Cone", "Cylinder", "Hopper2D", "Plane", "PlateWithHole", "Segment",
           "Wall", "WallForce", "closest_point"]
