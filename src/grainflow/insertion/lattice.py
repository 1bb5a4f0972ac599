"""Lattice fills of a region, thinned at random to a target packing fraction.

Seed 002 initialises its jets on lattices with random vacancies: in 3D "we prepare fcc
crystals and remove particles randomly to reach the desired density" (Chapter 3), in 2D a
triangular lattice of spacing 1.1 d (Chapter 6). ``spacing`` is the nearest-neighbour
distance for every lattice, so grains of diameter ``spacing`` touch; the packing fractions
of touching grains are then :data:`IDEAL_PACKING`.
"""

from __future__ import annotations

import math

import numpy as np

from grainflow.insertion.regions import Region
from grainflow.insertion.sizes import particle_volume

#: Packing fraction of each lattice when the diameter equals the spacing.
IDEAL_PACKING = {
    "square": math.pi / 4.0,
    "triangular": math.pi / (2.0 * math.sqrt(3.0)),
    "simple_cubic": math.pi / 6.0,
    "fcc": math.pi / (3.0 * math.sqrt(2.0)),
}

_DIM = {"square": 2, "triangular": 2, "simple_cubic": 3, "fcc": 3}

#: Most lattice sites one fill may make (each site costs a few hundred bytes while filling):
#: 50 million sites are about 10 GiB; a larger count is almost always a unit slip.
MAX_LATTICE_SITES = 50_000_000


def _cell(kind: str, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Conventional cell edge lengths and basis points of a lattice of spacing ``s``."""
    if kind == "square":
        return np.array([s, s]), np.zeros((1, 2))
    if kind == "triangular":
        h = s * math.sqrt(3.0)
        return np.array([s, h]), np.array([[0.0, 0.0], [0.5 * s, 0.5 * h]])
    if kind == "simple_cubic":
        return np.array([s, s, s]), np.zeros((1, 3))
    a = s * math.sqrt(2.0)
    half = 0.5 * a
    return np.array([a, a, a]), np.array([[0.0, 0.0, 0.0], [half, half, 0.0],
                                          [half, 0.0, half], [0.0, half, half]])


def lattice_site_count(region: Region, spacing: float, kind: str, margin: float = 0.0) -> int:
    """Number of lattice sites in the bounding box of ``region`` (inset by ``margin``): what
    :func:`lattice_points` allocates before keeping the sites inside the region."""
    _check_lattice(region, spacing, kind)
    counts = _cell_counts(region, spacing, kind, margin)
    return 0 if np.any(counts < 1) else int(np.prod(counts.astype(float))) * len(_cell(kind, 1.0)[1])


def _cell_counts(region: Region, spacing: float, kind: str, margin: float) -> np.ndarray:
    """Conventional cells along each axis of the region's bounding box inset by ``margin``
    (as floats: a huge count must not overflow)."""
    lo, hi = region.bounds()
    cell, _ = _cell(kind, spacing)
    return np.floor((hi - margin - (lo + margin)) / cell) + 1


def _check_lattice(region: Region, spacing: float, kind: str) -> None:
    if kind not in _DIM:
        raise ValueError(f"kind: {kind!r} is not a lattice; use one of {sorted(_DIM)}")
    if _DIM[kind] != region.dim:
        raise ValueError(f"kind: a {kind} lattice is {_DIM[kind]}D but the region is "
                         f"{region.dim}D; use {[k for k, d in _DIM.items() if d == region.dim]}")
    if not (spacing > 0 and math.isfinite(spacing)):
        raise ValueError(f"spacing: {spacing!r} is not valid; expected a positive distance")


def lattice_points(region: Region, spacing: float, kind: str, margin: float = 0.0) -> np.ndarray:
    """Lattice sites (M, dim) inside ``region`` and at least ``margin`` from its boundary.

    The lattice starts at the corner ``bounds()[0] + margin`` of the region's bounding box.
    ``kind``: ``"square"``, ``"triangular"`` (2D), ``"simple_cubic"``, ``"fcc"`` (3D).
    More than :data:`MAX_LATTICE_SITES` sites in the bounding box are refused before
    anything is allocated.
    """
    sites = lattice_site_count(region, spacing, kind, margin)
    if sites > MAX_LATTICE_SITES:
        raise ValueError(f"spacing: {spacing!r} would make {sites:.4g} lattice sites in the "
                         f"region; at most {MAX_LATTICE_SITES:,} are allowed "
                         "(MAX_LATTICE_SITES): use a larger spacing or a smaller region")
    if sites == 0:
        return np.zeros((0, region.dim))
    lo, _ = region.bounds()
    cell, basis = _cell(kind, spacing)
    start = lo + margin
    counts = _cell_counts(region, spacing, kind, margin).astype(np.int64)
    grid = np.stack(np.meshgrid(*[np.arange(c) for c in counts], indexing="ij"), axis=-1)
    cells = start + grid.reshape(-1, region.dim) * cell
    pts = (cells[:, None, :] + basis[None, :, :]).reshape(-1, region.dim)
    # a relative tolerance keeps sites that sit on the boundary up to round-off
    return pts[region.contains(pts, margin - 1e-9 * spacing)]


def thin_to_packing_fraction(radius: np.ndarray, dim: int, volume: float, target: float,
                             rng: np.random.Generator) -> np.ndarray:
    """Indices (sorted) of the grains to keep so that their packing fraction in ``volume``
    is as close as possible to ``target``; the removed grains are chosen at random.

    The grains are visited in a random order and the shortest prefix whose volume is
    closest to ``target * volume`` is kept (for equal grains: ``round(target V / v)``).
    """
    radius = np.asarray(radius, dtype=float)
    v = particle_volume(radius, dim)
    have = float(v.sum()) / volume
    if not 0.0 < target <= have * (1.0 + 1e-12):
        raise ValueError(f"packing_fraction: {target!r} is not reachable by removing grains "
                         f"from a fill at {have:.4g}; use 0 < target <= {have:.4g} or a "
                         "smaller spacing")
    order = rng.permutation(radius.size)
    cum = np.concatenate([[0.0], np.cumsum(v[order])])
    k = int(np.argmin(np.abs(cum - target * volume)))
    return np.sort(order[:k])


def lattice_fill(region: Region, spacing: float, kind: str, radius: float, *,
                 packing_fraction: float | None = None,
                 rng: np.random.Generator | None = None) -> np.ndarray:
    """Centres (M, dim) of grains of ``radius`` on a lattice filling ``region``, optionally
    thinned at random (with ``rng``) to ``packing_fraction`` of the region's volume."""
    pts = lattice_points(region, spacing, kind, margin=radius)
    if packing_fraction is None:
        return pts
    if rng is None:
        raise ValueError("rng: thinning needs a numpy Generator (e.g. sim.rng)")
    keep = thin_to_packing_fraction(np.full(len(pts), radius), region.dim, region.volume,
                                    packing_fraction, rng)
    return pts[keep]
