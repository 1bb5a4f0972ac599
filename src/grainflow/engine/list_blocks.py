"""The blocks of the neighbour list's relative validity check
(:mod:`grainflow.kernels.list_check` gives the rule and why it holds).

At a build, particles are grouped by their build positions into cubic blocks of side
``G = BLOCK_CUTS x`` the list's cut-off ``2 r_max + reach + skin`` (on a periodic axis the
box is split into ``floor(L / G)`` equal blocks, so none is shorter than ``G`` and block
indices wrap). Only occupied blocks exist; each knows its members and its neighbouring
blocks (the 3^dim stencil, itself included), listed once per unordered pair.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

#: Block side in list cut-offs. A larger block allows the particles more spread as a whole
#: (condition 2: ``G - 2 r_max - reach``) but asks neighbouring blocks, which then span
#: more of a velocity gradient, to move together within the skin (condition 1).
BLOCK_CUTS = 4.0


@dataclass
class Blocks:
    """Each block's particles (``member[block_ptr[b]:block_ptr[b + 1]]``, ascending),
    its neighbours ``v >= u`` in CSR form (``pair_ptr``, ``pair_block``), the squared
    spread limit of condition 2, and the work arrays the check fills each step
    (:func:`~grainflow.kernels.list_check.stale_kernel`)."""

    member: np.ndarray
    block_ptr: np.ndarray
    pair_ptr: np.ndarray
    pair_block: np.ndarray
    spread_sq: float
    lo: np.ndarray
    hi: np.ndarray
    excess: np.ndarray
    worst: np.ndarray

    @classmethod
    def one(cls, n: int) -> "Blocks":
        """Every particle in one block with no pair conditions: only the allowances count
        (a list of no pairs, :meth:`NeighborList.build_empty`)."""
        return cls.of(np.arange(n, dtype=np.int64),
                      np.array([0, n] if n else [0], dtype=np.int64),
                      np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.inf)

    @classmethod
    def of(cls, member: np.ndarray, block_ptr: np.ndarray, first: np.ndarray,
           second: np.ndarray, spread_sq: float) -> "Blocks":
        """Blocks from their members and their neighbouring pairs ``(first, second)``,
        ``first <= second``, each pair once."""
        nb = block_ptr.shape[0] - 1
        order = np.lexsort((second, first))
        pair_ptr = np.zeros(nb + 1, dtype=np.int64)
        np.cumsum(np.bincount(first, minlength=nb), out=pair_ptr[1:])
        return cls(member, block_ptr, pair_ptr,
                   np.ascontiguousarray(second[order], dtype=np.int64), spread_sq,
                   np.zeros((nb, 3)), np.zeros((nb, 3)), np.zeros(nb, dtype=np.uint8),
                   np.zeros(nb))

    def arrays(self) -> tuple[np.ndarray, ...]:
        """``member, block_ptr, lo, hi, excess, pair_ptr, pair_block, worst``: the check's
        arguments after ``allowance_sq``."""
        return (self.member, self.block_ptr, self.lo, self.hi, self.excess, self.pair_ptr,
                self.pair_block, self.worst)

    def nbytes(self) -> int:
        return int(sum(a.nbytes for a in self.arrays()))


def index_blocks(x_ref: np.ndarray, dim: int, lo: np.ndarray, length: np.ndarray,
                 periodic: np.ndarray, cut: float, skin: float) -> Blocks:
    """The blocks of particles at build positions ``x_ref`` (N, 3) for a list of cut-off
    ``cut`` (= ``2 r_max + reach + skin``) in the box ``lo``, ``length``, ``periodic``."""
    n = x_ref.shape[0]
    side = BLOCK_CUTS * cut
    size = np.full(3, side)
    nblock = np.ones(3, dtype=np.int64)
    for a in range(dim):
        if periodic[a]:
            nblock[a] = max(1, int(length[a] // side))
            size[a] = length[a] / nblock[a]
    coords = np.zeros((n, 3), dtype=np.int64)
    coords[:, :dim] = np.floor((x_ref[:, :dim] - lo[:dim]) / size[:dim]).astype(np.int64)
    cmin = coords.min(axis=0) if n else np.zeros(3, dtype=np.int64)
    extent = (coords.max(axis=0) - cmin + 1) if n else np.ones(3, dtype=np.int64)
    for a in range(dim):
        if periodic[a]:
            coords[:, a] %= nblock[a]
            cmin[a], extent[a] = 0, nblock[a]

    def keys_of(c: np.ndarray) -> np.ndarray:
        return ((c[..., 0] - cmin[0]) * extent[1] + (c[..., 1] - cmin[1])) * extent[2] \
            + (c[..., 2] - cmin[2])

    block_keys, block_of = np.unique(keys_of(coords), return_inverse=True)
    nb = block_keys.shape[0]
    block_of = block_of.reshape(-1)
    member = np.argsort(block_of, kind="stable").astype(np.int64)
    block_ptr = np.zeros(nb + 1, dtype=np.int64)
    np.cumsum(np.bincount(block_of, minlength=nb), out=block_ptr[1:])
    # neighbouring occupied blocks: the stencil around each block's coordinates
    stencil = np.array([s + (0,) * (3 - dim)
                        for s in itertools.product((-1, 0, 1), repeat=dim)], dtype=np.int64)
    block_coords = np.zeros((nb, 3), dtype=np.int64)
    block_coords[block_of] = coords
    around = block_coords[:, None, :] + stencil[None, :, :]
    inside = np.ones(around.shape[:2], dtype=bool)
    for a in range(3):
        if periodic[a] and a < dim:
            around[..., a] %= nblock[a]
        else:
            inside &= (around[..., a] >= cmin[a]) & (around[..., a] < cmin[a] + extent[a])
    around_keys = keys_of(around)
    where = np.minimum(np.searchsorted(block_keys, around_keys), max(nb - 1, 0))
    found = inside & (block_keys[where] == around_keys) if nb else inside & False
    first = np.repeat(np.arange(nb, dtype=np.int64), stencil.shape[0])[found.ravel()]
    second = where.ravel()[found.ravel()]
    pair_keys = np.unique(np.minimum(first, second) * max(nb, 1) + np.maximum(first, second))
    interacting = cut - skin  # 2 r_max + reach: the farthest apart two particles interact
    return Blocks.of(member, block_ptr, pair_keys // max(nb, 1), pair_keys % max(nb, 1),
                     (side - interacting) ** 2)
