"""Random non-overlapping fill of a region by sequential random addition.

Grains are placed one after another at uniformly random positions inside the region (fully
inside: the centre at least one radius from the boundary); a trial position is accepted if
the grain overlaps neither an existing grain nor one placed before it (surface gap >=
``gap``), and otherwise a new trial is drawn. Overlap checks use a dense cell grid over the
region's bounding box, so each trial costs O(1). Sequential addition jams near a packing
fraction of about 0.55 (2D disks) / 0.38 (3D spheres); denser states need a lattice fill or
compression (e.g. FIRE).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from grainflow.insertion.regions import Region
from grainflow.insertion.sizes import SizeDistribution, particle_volume

#: Upper bound on the number of grid cells; coarser cells are used beyond it.
MAX_CELLS = 1 << 22


@njit(cache=True)
def _cell_of(p0, p1, p2, lo, cell, ncell):
    c0 = min(max(int((p0 - lo[0]) / cell), 0), ncell[0] - 1)
    c1 = min(max(int((p1 - lo[1]) / cell), 0), ncell[1] - 1)
    c2 = min(max(int((p2 - lo[2]) / cell), 0), ncell[2] - 1)
    return c0, c1, c2


@njit(cache=True)
def _link(k, x, lo, cell, ncell, head, nxt):
    c0, c1, c2 = _cell_of(x[k, 0], x[k, 1], x[k, 2], lo, cell, ncell)
    key = (c0 * ncell[1] + c1) * ncell[2] + c2
    nxt[k] = head[key]
    head[key] = k


@njit(cache=True)
def _link_all(count, x, lo, cell, ncell, head, nxt):
    for k in range(count):
        _link(k, x, lo, cell, ncell, head, nxt)


@njit(cache=True)
def _place(cands, r, gap, x, rad, count, lo, cell, ncell, head, nxt):
    """Store the first trial in ``cands`` that overlaps no grain as grain ``count``; return
    its row in ``cands`` or -1."""
    for t in range(cands.shape[0]):
        p0 = cands[t, 0]
        p1 = cands[t, 1]
        p2 = cands[t, 2]
        c0, c1, c2 = _cell_of(p0, p1, p2, lo, cell, ncell)
        free = True
        for a in range(max(c0 - 1, 0), min(c0 + 2, ncell[0])):
            for b in range(max(c1 - 1, 0), min(c1 + 2, ncell[1])):
                for c in range(max(c2 - 1, 0), min(c2 + 2, ncell[2])):
                    k = head[(a * ncell[1] + b) * ncell[2] + c]
                    while k >= 0 and free:
                        lim = r + rad[k] + gap
                        d0 = p0 - x[k, 0]
                        d1 = p1 - x[k, 1]
                        d2 = p2 - x[k, 2]
                        if d0 * d0 + d1 * d1 + d2 * d2 < lim * lim:
                            free = False
                        k = nxt[k]
        if free:
            x[count, 0] = p0
            x[count, 1] = p1
            x[count, 2] = p2
            rad[count] = r
            _link(count, x, lo, cell, ncell, head, nxt)
            return t
    return -1


def random_fill(region: Region, n: int, sizes: SizeDistribution | np.ndarray,
                rng: np.random.Generator, *, existing_x: np.ndarray | None = None,
                existing_radius: np.ndarray | None = None, gap: float = 0.0,
                max_attempts: int = 10_000, partial: bool = False,
                batch: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Centres (M, dim) and radii (M,) of ``n`` non-overlapping grains inside ``region``.

    ``sizes`` is a size distribution (drawn with ``rng``) or an explicit (n,) array of radii
    (placed in that order). ``existing_x``/``existing_radius`` are grains already there
    (e.g. ``state.x``, ``state.radius``). A grain that finds no free spot in
    ``max_attempts`` trials raises ValueError, or with ``partial=True`` ends the fill
    (M < n grains are returned).
    """
    dim = region.dim
    if n < 0:
        raise ValueError(f"n: {n!r} is not valid; expected a count >= 0")
    radii = (np.asarray(sizes, dtype=float).ravel() if isinstance(sizes, np.ndarray)
             else sizes.radii(n, rng))
    if radii.size != n or np.any(radii <= 0):
        raise ValueError(f"sizes: expected {n} positive radii, got {radii.size}")
    if max_attempts < 1:
        raise ValueError("max_attempts: must be >= 1")
    if n == 0:
        return np.zeros((0, dim)), np.zeros(0)
    lo, hi = (np.asarray(b, dtype=float) for b in region.bounds())
    if np.any(hi - lo < 2.0 * radii.max()):
        raise ValueError(f"region: its extent {hi - lo} is smaller than the largest grain "
                         f"diameter {2 * radii.max():g}; enlarge the region")
    ex_x = np.zeros((0, 3)) if existing_x is None else np.asarray(existing_x, dtype=float)
    ex_r = np.zeros(0) if existing_radius is None else np.asarray(existing_radius, dtype=float)
    # largest centre distance at which a new grain can overlap a new or existing one
    reach = radii.max() + max(radii.max(), ex_r.max() if ex_r.size else 0.0) + gap
    glo = np.zeros(3)
    ghi = np.zeros(3)
    glo[:dim] = lo - reach
    ghi[:dim] = hi + reach
    if ex_r.size:
        ex3 = np.zeros((ex_x.shape[0], 3))
        ex3[:, : ex_x.shape[1]] = ex_x
        near = np.all((ex3 >= glo) & (ex3 <= ghi), axis=1)
        ex3, ex_r = ex3[near], ex_r[near]
    else:
        ex3 = np.zeros((0, 3))
    cell = reach
    extent = (ghi - glo)[:dim]
    while np.prod(np.ceil(extent / cell)) > MAX_CELLS:
        cell *= 2.0
    ncell = np.ones(3, dtype=np.int64)
    ncell[:dim] = np.maximum(np.ceil(extent / cell), 1).astype(np.int64)
    m0 = ex_r.size
    x = np.zeros((m0 + n, 3))
    rad = np.zeros(m0 + n)
    x[:m0] = ex3
    rad[:m0] = ex_r
    head = np.full(int(np.prod(ncell)), -1, dtype=np.int64)
    nxt = np.full(m0 + n, -1, dtype=np.int64)
    _link_all(m0, x, glo, cell, ncell, head, nxt)
    cands = np.zeros((batch, 3))
    placed = 0
    for k in range(n):
        r = radii[k]
        tries = 0
        while True:
            if tries >= max_attempts:
                if partial:
                    return x[m0:m0 + placed, :dim].copy(), rad[m0:m0 + placed].copy()
                filled = float(particle_volume(rad[m0:m0 + placed], dim).sum()) / region.volume
                raise ValueError(
                    f"random_fill: grain {k + 1} of {n} found no free spot in max_attempts = "
                    f"{max_attempts} trials (packing fraction reached {filled:.3g}); the region "
                    "is too full for sequential random addition: insert fewer grains, enlarge "
                    "the region, or fill a lattice and compress")
            m = min(batch, max_attempts - tries)
            tries += m
            trial = lo + r + rng.random((m, dim)) * (hi - lo - 2.0 * r)
            trial = trial[region.contains(trial, r)]
            cands[: trial.shape[0], :dim] = trial
            if _place(cands[: trial.shape[0]], r, gap, x, rad, m0 + placed, glo, cell, ncell,
                      head, nxt) >= 0:
                placed += 1
                break
    return x[m0:, :dim].copy(), rad[m0:].copy()
