"""Building deformable particles (SPEC M6): regular rings of vertex particles.

Seed 003, section 2.4: "we initialize the particles as regular polygons, and set the edge
lengths to be equal to their equilibrium values ``l0 = sqrt(4 a0 tan(pi/N_v)/N_v)``". A
ring of area ``a0`` and mass ``M`` becomes ``N_v`` particles of mass ``M/N_v`` (seed 003
eq. 13) sharing one ``body`` id, numbered counter-clockwise in ``ring_vertex``
(:mod:`grainflow.rings`).

The vertex particle's radius is its contact radius:

* ``"rough"`` DP: a disk of diameter ``l0`` (seed 003 eq. 9, Fig. 1(e)), radius ``l0/2``;
  neighbouring vertices of a ring just touch, which makes the surface bumpy;
* ``"smooth"`` DP: the edges are circulo-lines of thickness ``delta = edge_width * l0``
  (default 0.2, the contact width of the authors' code; docs/dp.md), radius ``delta/2``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainflow.rings import RING_VERTEX, register, regular_polygon, rest_length

#: Vertices per ring in seed 003 ("We choose N_v = 16").
DEFAULT_VERTICES = 16
#: Circulo-line thickness of smooth DP edges in units of l0 (the authors' code).
DEFAULT_EDGE_WIDTH = 0.2
CONTACTS = ("rough", "smooth")


def vertex_radius(area: np.ndarray | float, n_vertices: int, contact: str,
                  edge_width: float = DEFAULT_EDGE_WIDTH) -> np.ndarray:
    """Contact radius of the vertices of a ring of ``area``: ``l0/2`` (rough) or
    ``edge_width l0 / 2`` (smooth)."""
    if contact not in CONTACTS:
        raise ValueError(f"contact: {contact!r} is not one of {CONTACTS}")
    l0 = np.asarray(rest_length(area, n_vertices), dtype=float)
    return 0.5 * l0 if contact == "rough" else 0.5 * edge_width * l0


def add_rings(target: Any, centres: np.ndarray, areas: np.ndarray | float, *,
              n_vertices: int = DEFAULT_VERTICES, density: float = 1.0,
              contact: str = "rough", edge_width: float = DEFAULT_EDGE_WIDTH,
              type: np.ndarray | int = 0, angles: np.ndarray | float | None = None,
              v: np.ndarray | None = None, rng: np.random.Generator | None = None,
              first_body: int | None = None) -> np.ndarray:
    """Add one regular ring per centre to ``target`` (a 2D simulation or state); return the
    (R, N_v) particle indices of their vertices in ring order.

    ``areas``: each ring's preferred area ``a0`` (one value or one per ring); mass
    ``density * a0``, shared equally by the vertices. ``type``: particle type of each
    ring's vertices (one value or one per ring). ``angles``: polar angle of vertex 0 (default
    random from ``rng``, or 0 without one). ``v``: (R, 2) velocity of each ring. Body ids are
    ``first_body, first_body + 1, ...`` (default: one past the largest in use).
    """
    state = getattr(target, "state", target)
    if state.dim != 2:
        raise ValueError("add_rings: deformable rings are 2D; the state is 3D")
    if not (isinstance(n_vertices, (int, np.integer)) and n_vertices >= 3):
        raise ValueError(f"n_vertices: {n_vertices!r} is not valid; expected an integer >= 3")
    if not (density > 0 and np.isfinite(density)):
        raise ValueError(f"density: {density!r} is not valid; expected a positive number")
    if not (0 < edge_width <= 1):
        raise ValueError(f"edge_width: {edge_width!r} is not valid; expected a fraction of "
                         "l0 in (0, 1]")
    centres = np.atleast_2d(np.asarray(centres, dtype=float))[:, :2]
    n_rings = centres.shape[0]
    a0 = np.broadcast_to(np.asarray(areas, dtype=float), (n_rings,))
    if np.any(~np.isfinite(a0)) or np.any(a0 <= 0):
        raise ValueError("areas: every ring area must be a positive finite number")
    if angles is None:
        angles = (rng.uniform(0.0, 2.0 * np.pi / n_vertices, n_rings) if rng is not None
                  else np.zeros(n_rings))
    angles = np.broadcast_to(np.asarray(angles, dtype=float), (n_rings,))
    types = np.broadcast_to(np.asarray(type, dtype=np.int32), (n_rings,))
    radius = vertex_radius(a0, n_vertices, contact, edge_width)
    xy = np.concatenate([centres[r] + regular_polygon(a0[r], n_vertices, angles[r])
                         for r in range(n_rings)]) if n_rings else np.zeros((0, 2))
    vel = None
    if v is not None:
        vel = np.repeat(np.atleast_2d(np.asarray(v, dtype=float))[:, :2], n_vertices, axis=0)
    if first_body is None:
        first_body = int(state.body.max()) + 1 if state.n and state.body.max() >= 0 else 0
    bodies = np.repeat(first_body + np.arange(n_rings, dtype=np.int64), n_vertices)
    register(state)
    idx = target.add_particles(xy, np.repeat(radius, n_vertices),
                               mass=np.repeat(density * a0 / n_vertices, n_vertices),
                               v=vel, type=np.repeat(types, n_vertices), body=bodies)
    state.arrays[RING_VERTEX][idx] = np.tile(np.arange(n_vertices, dtype=np.int32), n_rings)
    return np.asarray(idx, dtype=np.int64).reshape(n_rings, n_vertices)
