"""Deformable-particle rings (SPEC M6; seed 003, section 2.3): which particles are the
vertices of which ring, and in what order.

A 2D deformable particle (DP) is a closed polygon of ``N_v`` vertices, each vertex a particle
of the state. The topology lives in two per-particle arrays, so it follows the particles
through re-sorting, insertion, deletion and output without any id bookkeeping:

* ``body`` (a core array): the ring's id, shared by its vertices. The neighbour list never
  pairs two particles of one body, so no contact acts inside a ring; the ring's own shape
  energy (:class:`grainflow.engine.deformable.ShapeForce`) is its only internal force.
* ``ring_vertex`` (registered by :func:`register`, -1 for particles in no ring): the
  vertex's position ``0 .. N_v - 1`` around the ring, counter-clockwise, so that edge ``i``
  runs from vertex ``i`` to vertex ``i + 1 (mod N_v)``.

This module is data only (numpy, no engine), like :mod:`grainflow.frame`; frames carry
``ring_vertex`` and every writer stores it.
"""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from grainflow.frame import Frame

#: Name of the registered per-particle array holding each vertex's place in its ring.
RING_VERTEX = "ring_vertex"


def register(state) -> np.ndarray:
    """Register (once) the ``ring_vertex`` array of ``state`` (int32, -1 = in no ring)."""
    return state.add_array(RING_VERTEX, (), np.int32, fill=-1)


def ring_table(body: np.ndarray, ring_vertex: np.ndarray,
               n_vertices: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The rings present: ``(ring_body, index)``.

    ``ring_body`` (R,): the body id of each ring, ascending; ``index`` (R, N_v): the particle
    index of each ring's vertices in ring order. ``n_vertices`` (default: the largest
    ``ring_vertex`` + 1) must be the same for every ring. ValueError if a ring lacks a
    vertex, holds one twice, or a ring vertex has no body.
    """
    ring_vertex = np.asarray(ring_vertex)
    sel = np.flatnonzero(ring_vertex >= 0)
    if sel.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, n_vertices or 0), dtype=np.int64)
    nv = int(ring_vertex[sel].max()) + 1 if n_vertices is None else int(n_vertices)
    bodies = np.asarray(body)[sel]
    if np.any(bodies < 0):
        raise ValueError("ring_vertex: a ring vertex has body -1; every vertex of a ring "
                         "carries the ring's body id")
    if np.any(ring_vertex[sel] >= nv):
        raise ValueError(f"ring_vertex: a vertex number is >= n_vertices = {nv}")
    ring_body, ring_of = np.unique(bodies, return_inverse=True)
    index = np.full((ring_body.size, nv), -1, dtype=np.int64)
    index[ring_of, ring_vertex[sel]] = sel
    counts = np.bincount(ring_of, minlength=ring_body.size)
    if np.any(counts != nv) or np.any(index < 0):
        bad = ring_body[(counts != nv) | np.any(index < 0, axis=1)][:5].tolist()
        raise ValueError(f"rings {bad}: not {nv} distinct vertices each; a ring is moved, "
                         "added and removed whole")
    return ring_body.astype(np.int64), index


#: The last ring table of each state: ``{state: ((generation, n_vertices), table)}``.
_TABLES: "weakref.WeakKeyDictionary[Any, tuple[tuple[int, int], tuple]]" = (
    weakref.WeakKeyDictionary())


def state_ring_table(state: Any, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ring_table` of a state's rings, computed once per particle-set ``generation``
    (the shape force, the smooth contacts and the hopper's ring reinsertion all read it;
    indices change only when particles are added, removed or re-sorted). The arrays are
    shared: read them, never write them."""
    key = (state.generation, int(n_vertices))
    hit = _TABLES.get(state)
    if hit is None or hit[0] != key:
        register(state)
        hit = _TABLES[state] = (key, ring_table(state.body, state.arrays[RING_VERTEX],
                                                n_vertices))
    return hit[1]


def frame_rings(frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """The rings of ``frame``: ``(ring_body, index)`` as :func:`ring_table` gives them (none
    when the frame carries no ``ring_vertex``)."""
    if frame.ring_vertex is None:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 0), dtype=np.int64)
    return ring_table(frame.body, frame.ring_vertex)


def ring_outlines(frame: Frame, index: np.ndarray) -> np.ndarray:
    """(R, N_v, dim) vertex positions of the rings ``index`` (from :func:`frame_rings`), each
    ring drawn whole: vertex 0 where it is, each next vertex one minimum-image edge further
    (a ring straddling a periodic boundary is not cut in two; it sticks out of the box)."""
    index = np.asarray(index, dtype=np.int64)
    xy = np.asarray(frame.position, dtype=float)[index]
    if index.size == 0:
        return xy
    periodic = np.asarray(frame.box.periodic, dtype=bool)
    length = np.where(periodic, frame.box.lengths, 1.0)
    edges = np.diff(xy, axis=1)
    edges -= np.where(periodic, length * np.rint(edges / length), 0.0)
    return np.concatenate([xy[:, :1], xy[:, :1] + np.cumsum(edges, axis=1)], axis=1)


def polygon_area(xy: np.ndarray) -> np.ndarray:
    """Signed area of each polygon ``xy`` (..., N_v, 2) by the shoelace formula (positive
    when counter-clockwise)."""
    x = xy[..., 0]
    y = xy[..., 1]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1)


def rest_length(area: np.ndarray | float, n_vertices: int) -> np.ndarray | float:
    """Edge length ``l0 = sqrt(4 a0 tan(pi/N_v) / N_v)`` of the regular ``N_v``-gon of area
    ``a0`` (seed 003, section 2.4)."""
    return np.sqrt(4.0 * np.asarray(area, dtype=float) * np.tan(np.pi / n_vertices)
                   / n_vertices)


def regular_polygon(area: float, n_vertices: int, angle: float = 0.0) -> np.ndarray:
    """(N_v, 2) vertices, counter-clockwise about the origin, of the regular polygon of
    ``area``; vertex 0 at polar angle ``angle``."""
    circumradius = np.sqrt(2.0 * area / (n_vertices * np.sin(2.0 * np.pi / n_vertices)))
    phi = angle + 2.0 * np.pi * np.arange(n_vertices) / n_vertices
    return circumradius * np.column_stack([np.cos(phi), np.sin(phi)])


def shape_parameter(xy: np.ndarray) -> np.ndarray:
    """Dimensionless shape parameter ``A = p^2 / (4 pi a)`` of each polygon (seed 003,
    section 2.3; 1 for a circle, ``(N_v/pi) tan(pi/N_v)`` = 1.0131 for a regular 16-gon)."""
    edges = np.roll(xy, -1, axis=-2) - xy
    perimeter = np.sum(np.linalg.norm(edges, axis=-1), axis=-1)
    return perimeter**2 / (4.0 * np.pi * polygon_area(xy))
