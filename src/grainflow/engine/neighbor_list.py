"""Verlet-list orchestration: when to rebuild, periodic wrapping, spatial re-sorting.

The list holds every pair whose centre distance is below ``r_i + r_j + reach + skin``
(``reach``: how far beyond contact the pair law acts, e.g. the cohesion shell). It is rebuilt
when some particle has moved more than ``skin / 2`` since the last build, which guarantees
that no interacting pair is missed in between (``check = "absolute"``, the default), or, with
``check = "relative"``, when some pair of particles may have moved ``skin`` against each
other (:mod:`grainflow.kernels.list_check`: a stream or a jet moves as a whole, and its
list then lasts many times longer). Every ``sort_every`` builds the particles are
re-ordered along the cell keys (neighbours in space become neighbours in memory); the
contact history follows through :meth:`PairInteraction.reindex`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from grainflow.engine.list_blocks import Blocks, index_blocks
from grainflow.kernels import neighbors as nk
from grainflow.kernels.list_check import stale_kernel
from grainflow.kernels.specialize import for_threads_now
from grainflow.state import ParticleState


#: The list's validity checks (:mod:`grainflow.kernels.list_check`).
CHECKS = ("absolute", "relative")


@functools.lru_cache(maxsize=64)
def _stencil(dim: int, short: tuple[int, int, int]) -> np.ndarray:
    """Offsets (Q, 3) of the neighbour cells of a cell, itself included: -1, 0, 1 along each
    of the ``dim`` axes, or every cell of a periodic axis holding fewer than three
    (``short[a]`` cells; 0: not short). Shared between builds: not to be written to."""
    per_axis = []
    for a in range(3):
        if a >= dim:
            per_axis.append([0])
        elif short[a]:
            per_axis.append(list(range(short[a])))
        else:
            per_axis.append([-1, 0, 1])
    grid = np.array(np.meshgrid(*per_axis, indexing="ij")).reshape(3, -1).T
    return np.ascontiguousarray(grid, dtype=np.int64)


class Cells(NamedTuple):
    """:meth:`NeighborList.cell_order`'s result: each particle's integer cell ``coords``
    (N, 3) and linear ``keys`` (N,) over a box of ``extent`` cells from ``cmin``, the
    key-sorted ``order``, the periodic cell counts ``ncell``, the stencil ``offsets``, the
    list's ``margin`` (reach + skin), and, when the box is stored densely, ``start``: the
    first sorted position of each key (``extent`` then includes a ghost layer; see
    :func:`~grainflow.kernels.neighbors.ghost_cell_ranges`), else None."""

    coords: np.ndarray
    keys: np.ndarray
    order: np.ndarray
    cmin: np.ndarray
    extent: np.ndarray
    ncell: np.ndarray
    offsets: np.ndarray
    margin: float
    start: np.ndarray | None


@functools.lru_cache(maxsize=64)
def _grid_deltas(dim: int, extent: tuple[int, int, int]) -> np.ndarray:
    """Key offsets of the cell stencil (-1, 0, 1 along each of the ``dim`` axes) in a grid
    of ``extent`` cells, ascending (rows then come out nearly sorted). Shared between
    builds: not to be written to."""
    per_axis = [[-1, 0, 1] if a < dim else [0] for a in range(3)]
    grid = np.array(np.meshgrid(*per_axis, indexing="ij")).reshape(3, -1).T
    deltas = (grid[:, 0] * extent[1] + grid[:, 1]) * extent[2] + grid[:, 2]
    return np.sort(deltas).astype(np.int64)


@dataclass
class ListGeometry:
    """Box data in the 3-component form the kernels take."""

    lo: np.ndarray
    length: np.ndarray
    periodic: np.ndarray

    @classmethod
    def from_state(cls, state: ParticleState) -> "ListGeometry":
        d = state.dim
        lo = np.zeros(3)
        length = np.ones(3)
        periodic = np.zeros(3, dtype=np.bool_)
        lo[:d] = state.box.lo
        length[:d] = state.box.lengths
        periodic[:d] = state.box.periodic
        return cls(lo, length, periodic)

    def branch(self, xi: np.ndarray, xj: np.ndarray) -> np.ndarray:
        """Branch vectors ``xi - xj`` (M, 3), folded to the minimum image on periodic axes."""
        d = xi - xj
        for a in np.nonzero(self.periodic)[0]:
            d[:, a] -= self.length[a] * np.rint(d[:, a] / self.length[a])
        return d


class NeighborList:
    """Half Verlet list built from sparse (hashed) cells.

    Attributes after :meth:`build`: ``row_ptr`` (N+1,), ``nbr`` (P,), ``col_ptr`` (N+1,),
    ``col_pair`` (P,), its inverse ``pair_col`` (P,), ``col_span`` (N, 2), ``builds``
    (count); see :func:`~grainflow.kernels.neighbors.transpose_index`.
    """

    def __init__(self, skin: float, sort_every: int = 1, check: str = "absolute") -> None:
        if skin <= 0:
            raise ValueError("skin: must be positive (a fraction of the diameter, e.g. 0.1 d)")
        if check not in CHECKS:
            raise ValueError(f"list_check: {check!r} is not one of {', '.join(CHECKS)}")
        self.skin = float(skin)
        self.check = check
        #: Relative check: the blocks of the last build, each particle's squared allowance
        #: (how far it may move on its own: infinite unless a force relies on absolute
        #: positions, see :meth:`limit_motion`) and the names of the forces that set it.
        self.blocks = Blocks.one(0)
        self.allowance_sq = np.zeros(0)
        self.allowance_by: set[str] = set()
        self._cut = 0.0
        self.sort_every = int(sort_every)
        self.builds = 0
        self.row_ptr = np.zeros(1, dtype=np.int64)
        self.nbr = np.zeros(0, dtype=np.int64)
        self.col_ptr = np.zeros(1, dtype=np.int64)
        self.col_pair = np.zeros(0, dtype=np.int64)
        self.pair_col = np.zeros(0, dtype=np.int64)
        self.col_span = np.zeros((0, 2), dtype=np.int64)
        #: Per row: some pair of it reaches across a periodic boundary (the pair loop takes
        #: the minimum image only in those rows).
        self.row_wraps = np.zeros(0, dtype=np.uint8)
        self._x_ref = np.zeros((0, 3))
        self._generation = -1
        self._capacity = 16

    def is_current_for(self, state: ParticleState) -> bool:
        """True if the list was built for this particle set (indices unchanged since)."""
        return state.generation == self._generation and self._x_ref.shape[0] == state.n

    @property
    def relative(self) -> bool:
        return self.check == "relative"

    def needs_build(self, state: ParticleState, geom: ListGeometry) -> bool:
        """True if indices changed or the list may miss a pair: some particle moved more
        than skin/2 (absolute check), or some pair may have moved skin against each other
        or some particle beyond its allowance (relative check)."""
        if not self.is_current_for(state):
            return True
        stale = stale_kernel(self.relative, numba.get_num_threads() == 1)
        return bool(stale(self.check_args(state, geom)))

    def check_args(self, state: ParticleState, geom: ListGeometry) -> tuple:
        """The arguments of the check (:func:`~grainflow.kernels.list_check.stale_kernel`)
        on the current positions."""
        if not self.relative:
            return (state.x, self._x_ref, geom.length, geom.periodic,
                    0.25 * self.skin * self.skin)
        b = self.blocks
        return (state.x, self._x_ref, self.allowance_sq, *b.arrays(), self.skin * self.skin,
                b.spread_sq)

    def limit_motion(self, name: str, allowance: np.ndarray) -> None:
        """Relative check: force ``name`` needs each particle ``i`` to rebuild before it
        has moved ``allowance[i]`` since the build (a static wall's distance to the
        particles it does not visit). Taken once per build and force; the tightest wins."""
        if self.relative and name not in self.allowance_by:
            np.minimum(self.allowance_sq, np.square(allowance), out=self.allowance_sq)
            self.allowance_by.add(name)

    def wrap(self, state: ParticleState, geom: ListGeometry) -> None:
        """Fold positions on periodic axes back into the box; count the image shifts."""
        if geom.periodic.any():
            for_threads_now(nk.wrap_periodic)(state.x, state.image, geom.lo, geom.length,
                                              geom.periodic)

    def cut_for(self, state: ParticleState, reach: float) -> float:
        """The list's cut-off, ``2 r_max + reach + skin``: the cell side and the unit of
        the relative check's blocks."""
        rmax = float(state.radius.max()) if state.n else 0.0
        return 2.0 * rmax + reach + self.skin

    def cell_order(self, state: ParticleState, geom: ListGeometry, reach: float) -> Cells:
        """Cell coordinates, linear keys and the key-sorted particle order (:class:`Cells`).

        A box of at most :data:`~grainflow.kernels.neighbors.DENSE_GRID_CELLS_PER_PARTICLE`
        cells per particle (a packing, a flowing pile) is sorted by counting and stored
        densely with ghost cells; a sparse one (a dilute stream, a jet) keeps its occupied
        cells only, sorted and hashed. Both give the same order and the same list."""
        margin = reach + self.skin
        cut = self._cut = self.cut_for(state, reach)
        cell = np.full(3, cut)
        ncell = np.ones(3, dtype=np.int64)
        for a in range(state.dim):
            if geom.periodic[a]:
                if geom.length[a] < 2.0 * cut:
                    raise ValueError(
                        f"box: periodic length {geom.length[a]:g} along axis {a} is shorter than "
                        f"twice the interaction cut-off {cut:g}; enlarge the box")
                ncell[a] = int(geom.length[a] // cut)
                cell[a] = geom.length[a] / ncell[a]
        coords = nk.cell_coordinates(state.x, geom.lo, cell, ncell, geom.periodic)
        if state.n:
            cmin, cmax = nk.coordinate_bounds(coords)
            extent = cmax - cmin + 1
        else:
            cmin = np.zeros(3, dtype=np.int64)
            extent = np.ones(3, dtype=np.int64)
        for a in range(3):
            if geom.periodic[a]:
                cmin[a] = 0
                extent[a] = ncell[a]
        if float(extent[0]) * float(extent[1]) * float(extent[2]) > 2.0**62:
            raise ValueError("neighbour cells: particles spread over too many cells; some "
                             "particle has probably flown away (check the time step)")
        offsets = self._offsets(state.dim, geom.periodic, ncell)
        # a dense grid with a ghost layer on each of the dim axes, where it is small and no
        # periodic axis is short (a ghost would then repeat a neighbour cell)
        pad = np.array([1 if a < state.dim else 0 for a in range(3)], dtype=np.int64)
        padded = extent + 2 * pad
        short = any(geom.periodic[a] and ncell[a] < 3 for a in range(state.dim))
        if (state.n and not short and float(np.prod(padded.astype(float)))
                <= nk.DENSE_GRID_CELLS_PER_PARTICLE * state.n):
            keys = nk.linear_keys(coords, cmin - pad, padded)
            order, start = nk.counting_sort(keys, int(np.prod(padded)))
            return Cells(coords, keys, order, cmin - pad, padded, ncell, offsets, margin, start)
        keys = nk.linear_keys(coords, cmin, extent)
        order = np.argsort(keys, kind="stable")
        return Cells(coords, keys, order, cmin, extent, ncell, offsets, margin, None)

    @staticmethod
    def in_new_order(cells: Cells) -> Cells:
        """:meth:`cell_order`'s result after the particles were re-indexed in its order."""
        order = cells.order
        return cells._replace(coords=np.ascontiguousarray(cells.coords[order]),
                              keys=cells.keys[order],
                              order=np.arange(order.shape[0], dtype=np.int64))

    @staticmethod
    def _offsets(dim: int, periodic: np.ndarray, ncell: np.ndarray) -> np.ndarray:
        """The cell stencil (see :func:`_stencil`; built once per kind of box)."""
        short = tuple(int(ncell[a]) if periodic[a] and ncell[a] < 3 else 0 for a in range(3))
        return _stencil(dim, short)

    def build(self, state: ParticleState, geom: ListGeometry, cells: Cells) -> None:
        """Build the half list and its transpose from :meth:`cell_order`'s result."""
        n = state.n
        order = cells.order.astype(np.int64)
        in_cell_order = bool(np.all(order == np.arange(n)))
        if cells.start is not None:
            first, end = nk.ghost_cell_ranges(cells.start, cells.extent, geom.periodic)
            self.row_ptr, self.nbr, self._capacity = nk.build_half_list_grid(
                state.x, state.radius, state.frozen, state.body, cells.keys, first, end,
                _grid_deltas(state.dim, tuple(int(e) for e in cells.extent)), order,
                geom.length, geom.periodic, cells.margin, self._capacity, in_cell_order,
                numba.get_num_threads())
            self._adopt_rows(state, geom)
            return
        sorted_keys = cells.keys[order]
        if n:
            starts = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
        else:
            starts = np.zeros(0, dtype=np.int64)
        cell_keys = np.ascontiguousarray(sorted_keys[starts])
        cell_start = np.r_[starts, n].astype(np.int64)
        cell_of = np.empty(n, dtype=np.int64)
        cell_of[order] = np.repeat(np.arange(starts.shape[0]), np.diff(cell_start))
        table = nk.cell_neighbor_table(np.ascontiguousarray(cells.coords[order[starts]]),
                                       cell_keys, cells.offsets, cells.cmin, cells.extent,
                                       geom.periodic, cells.ncell)
        self.row_ptr, self.nbr, self._capacity = nk.build_half_list(
            state.x, state.radius, state.frozen, state.body, cell_of, table, cell_start,
            order, geom.length, geom.periodic, cells.margin, self._capacity, in_cell_order)
        self._adopt_rows(state, geom)

    def build_empty(self, state: ParticleState, geom: ListGeometry) -> None:
        """A list of no pairs, for a simulation where nothing reads pairs (grains under
        gravity and drag only, against walls): only the displacement reference is taken,
        which still times the periodic wrap and the walls' choice of the particles to visit.
        Skips the cell sort and scan, which for two free-falling grains cost 0.6 ms a step."""
        self.row_ptr = np.zeros(state.n + 1, dtype=np.int64)
        self.nbr = np.zeros(0, dtype=np.int64)
        self._cut = 0.0
        self._adopt_rows(state, geom)

    def _adopt_rows(self, state: ParticleState, geom: ListGeometry) -> None:
        """Finish a build of ``row_ptr`` and ``nbr``: the displacement reference, the row
        flags, the transpose, the relative check's blocks and allowances, and the particle
        set the list is current for."""
        self._x_ref = state.x.copy()
        self.index_rows(geom)
        self.index_columns()
        if self.relative:
            self.index_blocks(state.dim, geom)
            self.allowance_sq = np.full(state.n, self._periodic_cap(geom))
            self.allowance_by = set()
        self._generation = state.generation
        self.builds += 1

    def index_blocks(self, dim: int, geom: ListGeometry) -> None:
        """Derive the relative check's blocks from the positions of the last build."""
        if self._cut > 0.0:
            self.blocks = index_blocks(self._x_ref, dim, geom.lo, geom.length, geom.periodic,
                                       self._cut, self.skin)
        else:  # no pairs listed: only the allowances count
            self.blocks = Blocks.one(self._x_ref.shape[0])

    def _periodic_cap(self, geom: ListGeometry) -> float:
        """The squared allowance of every particle in a box with a periodic axis: one list
        cell (a cut-off), so that positions, folded into the box only at a build, never
        stray far out of it; infinite otherwise."""
        if geom.periodic.any():
            return max(self._cut, self.skin) ** 2
        return np.inf

    def index_rows(self, geom: ListGeometry) -> None:
        """Derive ``row_wraps`` from the rows and the positions of the last build."""
        self.row_wraps = nk.rows_crossing_periodic(self.row_ptr, self.nbr, self._x_ref,
                                                   geom.length, geom.periodic)

    def index_columns(self) -> None:
        """Derive the transpose (``col_ptr``, ``col_pair``, ``pair_col``, ``col_span``)."""
        n = self.row_ptr.shape[0] - 1
        self.col_ptr, self.col_pair, self.pair_col, self.col_span = nk.transpose_index(
            self.row_ptr, self.nbr, n)

    def sort_due(self) -> bool:
        return self.sort_every > 0 and self.builds % self.sort_every == 0

    @property
    def reference_positions(self) -> np.ndarray:
        """Positions at the last build (the displacement check's reference)."""
        return self._x_ref

    @property
    def n_pairs(self) -> int:
        return int(self.nbr.shape[0])

    def nbytes(self) -> int:
        """Memory held by the list and its transpose."""
        return int(self.row_ptr.nbytes + self.nbr.nbytes + self.row_wraps.nbytes
                   + self.col_ptr.nbytes
                   + self.col_pair.nbytes + self.pair_col.nbytes + self.col_span.nbytes
                   + self._x_ref.nbytes + self.allowance_sq.nbytes + self.blocks.nbytes())
