"""The blocks of the neighbour list's relative validity check
(:mod:`grainflow.kernels.list_check` gives the rule and why it holds).

At a build, particles are grouped by their build positions into cubic blocks of side
``G = BLOCK_CUTS x`` the list's cut-off ``2 r_max + reach + skin`` (on a periodic axis the
box is split into ``floor(L / G)`` equal blocks, so none is shorter than ``G`` and block
indices wrap). Only occupied blocks exist; each knows its members and its neighbouring
blocks (the 3^dim stencil, itself included), listed once per unordered pair.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainflow.kernels.list_check import block_index

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
        nb = 1 if n else 0
        return cls.of(np.arange(n, dtype=np.int64),
                      np.array([0, n] if n else [0], dtype=np.int64),
                      np.zeros(nb + 1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.inf)

    @classmethod
    def of(cls, member: np.ndarray, block_ptr: np.ndarray, pair_ptr: np.ndarray,
           pair_block: np.ndarray, spread_sq: float) -> "Blocks":
        """Blocks from their members and their neighbouring blocks ``v >= u`` in CSR form,
        with the check's work arrays."""
        nb = block_ptr.shape[0] - 1
        return cls(member, block_ptr, pair_ptr, pair_block, spread_sq, np.zeros((nb, 3)),
                   np.zeros((nb, 3)), np.zeros(nb, dtype=np.uint8), np.zeros(nb))

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
    ``cut`` (= ``2 r_max + reach + skin``) in the box ``lo``, ``length``, ``periodic``
    (:func:`~grainflow.kernels.list_check.block_index`)."""
    side = BLOCK_CUTS * cut
    member, block_ptr, pair_ptr, pair_block = block_index(
        np.ascontiguousarray(x_ref, dtype=float), dim, np.asarray(lo, dtype=float),
        np.asarray(length, dtype=float), np.asarray(periodic, dtype=np.bool_), side)
    interacting = cut - skin  # 2 r_max + reach: the farthest apart two particles interact
    return Blocks.of(member, block_ptr, pair_ptr, pair_block, (side - interacting) ** 2)
