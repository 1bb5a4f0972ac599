"""Pair interactions: one contact law over the type pairs it owns, with its pair history.

A simulation may hold several (:meth:`grainflow.engine.simulation.Simulation.
add_interaction`), e.g. a soft law between the vertices of different bodies and a granular
law between grains and tethered wall particles; each type pair belongs to one interaction.
All share the simulation's neighbour list (built for the largest reach) and the compiled
pair loop (:mod:`grainflow.kernels.pair_loop`), each with its own law inlined.

The history array is aligned with the neighbour list; when the list is rebuilt,
:meth:`PairInteraction.attach` carries each pair's history over, and when particles are
re-indexed, :meth:`PairInteraction.reindex` re-expresses it in the new indices.
"""

from __future__ import annotations

from typing import Any, Iterable

import numba
import numpy as np

from grainflow.engine.fast_path import StepCall, step_call
from grainflow.engine.operations import ContactRows, Force, ForceContext, TimeScale
from grainflow.frame import PAIR
from grainflow.kernels import neighbors as nk
from grainflow.kernels.pair_loop import ACTIVE, active_pairs, gather_pair_forces, pair_kernel
from grainflow.kernels.specialize import for_threads_now
from grainflow.models.base import ContactLaw


def _pair_step(a, time, dt, last):
    """:meth:`PairInteraction.compute` (``update=True``) in the compiled step loop, keeping
    every pair's force only on the ``last`` step of the run (:mod:`~grainflow.kernels.
    pair_loop`'s ``keep``); the pair kernel ``KERNEL`` and the gather ``GATHER`` are bound
    by :meth:`PairInteraction.step_call`. ``update`` (true) comes in ``a[27]``: a literal
    ``True`` here would compile the kernel once more, for that constant."""
    KERNEL(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10],  # noqa: F821
           a[11], a[12], a[13], a[14], a[15], a[16], a[17], a[18], a[19], a[20], a[21], dt,
           a[27], last, a[22], a[23], a[26])
    GATHER(a[24], a[25], a[13], a[14], a[16], a[18], a[19], a[6], a[22], a[23])  # noqa: F821


class PairInteraction(Force):
    """Particle-particle contacts of the type pairs ``types`` through ``law``.

    ``types``: (type_a, type_b) pairs this interaction owns (order does not matter); None
    makes it the simulation's default interaction, owning every type pair that no other
    interaction claims.
    """

    def __init__(self, law: ContactLaw, types: Iterable[tuple[int, int]] | None = None) -> None:
        self.law = law
        if types is None:
            self.types = None
        else:
            pairs = set()
            for pair in types:
                a, b = (int(t) for t in pair)
                if a < 0 or b < 0 or tuple(pair) != (a, b):
                    raise ValueError(f"types: {pair!r} is not a pair of type indices >= 0")
                pairs.add((min(a, b), max(a, b)))
            if not pairs:
                raise ValueError("types: empty; give the (type_a, type_b) pairs this "
                                 "interaction owns, or None for all the others")
            self.types = frozenset(pairs)
        #: use[a, b] = 1 where this interaction owns the type pair (set by the simulation).
        self.use = np.ones((1, 1), dtype=np.uint8)
        self.all_types = True
        h = law.history_size
        self._ptr = np.zeros(1, dtype=np.int64)
        self._nbr = np.zeros(0, dtype=np.int64)
        self.history = np.zeros((0, h))
        #: Per pair slot: force on i (3) and the torque vector c (3), valid where ``ACTIVE``.
        self.fc_pair = np.zeros((0, 6))
        #: Per pair slot: ACTIVE / INACTIVE / STALE (see :mod:`grainflow.kernels.pair_loop`).
        self.active = np.zeros(0, dtype=np.uint8)
        #: ``active == ACTIVE`` in the column order of the list's transpose, for the gather.
        self.active_col = np.zeros(0, dtype=np.uint8)
        self._columns_of: np.ndarray | None = None
        #: Per particle: the j-side sums the pair loop builds directly (zero between calls).
        self.col_sum = np.zeros((0, 6))
        self._kernels: dict[tuple[bool, bool], Any] = {}

    def __repr__(self) -> str:
        owned = "default" if self.types is None else sorted(self.types)
        return f"PairInteraction({self.law!r}, types={owned})"

    def owns(self, use: np.ndarray, all_types: bool) -> None:
        """Set the type pairs this interaction evaluates (the simulation's assignment)."""
        self.use = np.ascontiguousarray(use, dtype=np.uint8)
        self.all_types = bool(all_types)
        self.law.ensure_types(use.shape[0])

    # ----------------------------------------------------------- list bookkeeping
    def reindex(self, old_to_new: np.ndarray) -> None:
        """Follow a permutation/deletion of particles (``old_to_new[i] = -1`` drops i)."""
        self._ptr, self._nbr, self.history = nk.reindex_pairs(
            self._ptr, self._nbr, self.history, old_to_new, self.law.flip)

    def attach(self, row_ptr: np.ndarray, nbr: np.ndarray,
               new_to_old: np.ndarray | None = None) -> None:
        """Adopt a freshly built list, carrying over the history of surviving pairs.

        ``new_to_old``: the particles were re-sorted since the old list was attached
        (``new_to_old[a]`` is the old index of particle ``a``); the history is carried
        through the permutation and the rebuild in one pass.
        """
        new_hist = np.empty((nbr.shape[0], self.law.history_size))
        if new_to_old is None:
            nk.carry_history(self._ptr, self._nbr, self.history, row_ptr, nbr, new_hist)
            self.active = np.any(new_hist != 0.0, axis=1).astype(np.uint8)
        else:
            self.active = np.empty(nbr.shape[0], dtype=np.uint8)
            nk.carry_history_permuted(self._ptr, self._nbr, self.history, new_to_old,
                                      self.law.flip, row_ptr, nbr, new_hist, self.active)
        self._ptr, self._nbr, self.history = row_ptr, nbr, new_hist
        self.fc_pair = np.zeros((nbr.shape[0], 6))
        self._columns_of = None

    def forget(self, index: np.ndarray, ctx: ForceContext) -> None:
        """Clear the history of every listed pair of the particles ``index`` (they were
        moved: their old contacts are over)."""
        nl = ctx.neighbors
        if self.history.shape[1] == 0 or nl.n_pairs != self.history.shape[0]:
            return
        for i in np.atleast_1d(index):
            self.history[nl.row_ptr[i]:nl.row_ptr[i + 1]] = 0.0
            self.history[nl.col_pair[nl.col_ptr[i]:nl.col_ptr[i + 1]]] = 0.0

    # ------------------------------------------------------------------ forces
    def compute(self, ctx: ForceContext, update: bool, first: bool = False) -> None:
        """Evaluate the law over the list; ``first``: set (not add to) force and torque."""
        kernel, a = self._prepare(ctx, first)
        for_threads_now(kernel)(*a[:22], ctx.dt, update, True, a[22], a[23], a[26])
        for_threads_now(gather_pair_forces)(a[24], a[25], a[13], a[14], a[16], a[18], a[19],
                                            a[6], a[22], a[23])

    def step_call(self, ctx: ForceContext, first: bool = False) -> StepCall:
        """``compute(ctx, update=True, first)`` for the compiled step loop."""
        kernel, args = self._prepare(ctx, first)
        return step_call(_pair_step, "pair_step", (*args, True), KERNEL=kernel,
                         GATHER=gather_pair_forces)

    def _prepare(self, ctx: ForceContext, first: bool) -> tuple[Any, tuple]:
        """The pair kernel for ``first`` and its arguments but ``dt`` and ``update`` (the
        layout :func:`_pair_step` reads), with the per-list arrays brought up to date."""
        st = ctx.state
        nl = ctx.neighbors
        g = ctx.geometry
        if self._columns_of is not nl.col_pair:
            self.active_col = (self.active[nl.col_pair] == ACTIVE).astype(np.uint8)
            self._columns_of = nl.col_pair
        if self.col_sum.shape[0] != st.n:
            self.col_sum = np.zeros((st.n, 6))
        chunks = max(1, min(numba.get_num_threads(), st.n))
        key = (self.all_types, first)
        kernel = self._kernels.get(key)
        if kernel is None:
            kernel = self._kernels[key] = pair_kernel(self.law.evaluator, *key)
        return kernel, (self.law.table, self.law.reach(), self.use, st.x, st.v, st.omega,
                        st.radius, st.mass, st.type, st.frozen, nl.row_ptr, nl.nbr,
                        nl.pair_col, nl.col_span, chunks, self.history, self.fc_pair,
                        self.active, self.active_col, self.col_sum, g.length, g.periodic,
                        st.force, st.torque, nl.col_ptr, nl.col_pair, nl.row_wraps)

    def contacts(self, ctx: ForceContext) -> list[ContactRows]:
        """Interacting pairs at the last evaluation: force on i, branch x_i - x_j."""
        nl = ctx.neighbors
        pi, pj, slot = active_pairs(nl.row_ptr, nl.nbr, self.fc_pair, self.active)
        branch = ctx.geometry.branch(ctx.state.x[pi], ctx.state.x[pj])
        return [ContactRows(pi, pj, PAIR, self.fc_pair[slot, :3].copy(), branch)]

    def potential_energy(self, ctx: ForceContext) -> float | None:
        """Contacts store only elastic energy (bounded by the health check from the contact
        list): 0; a cohesive law releases energy when contacts form: None."""
        return None if self.law.cohesive else 0.0

    def time_scales(self, ctx: ForceContext) -> list[TimeScale]:
        """Contact time, kinetic relaxation time and cohesive crossing time of every owned
        type pair present, with the lightest and smallest particle of each type."""
        st = ctx.state
        if st.n == 0:
            return []
        out = []
        present = np.unique(st.type)
        lightest = {int(t): float(st.mass[st.type == t].min()) for t in present}
        smallest = {int(t): float(st.radius[st.type == t].min()) for t in present}
        for a in lightest:
            for b in lightest:
                if b < a or not self._owns(a, b):
                    continue
                ma, mb = lightest[a], lightest[b]
                meff = ma * mb / (ma + mb)
                what = f"pair law {self.law.name}, types ({a}, {b})"
                out.append(TimeScale(self.law.contact_time(a, b, meff, smallest[a] + smallest[b]),
                                     "oscillation", what))
                out += [TimeScale(t, kind, what) for kind, t in self.law.rate_times(a, b, meff)]
        return out

    def _owns(self, a: int, b: int) -> bool:
        if self.all_types:
            return True
        return a < self.use.shape[0] and b < self.use.shape[0] and bool(self.use[a, b])

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict[str, Any]:
        return {"ptr": self._ptr.copy(), "nbr": self._nbr.copy(), "history": self.history.copy(),
                "active": self.active.copy(), "fc_pair": self.fc_pair.copy()}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self._ptr = np.asarray(data["ptr"], dtype=np.int64)
        self._nbr = np.asarray(data["nbr"], dtype=np.int64)
        # one history row per pair slot; explicit row count so a law without history
        # (history_size 0, e.g. SoftLaw) round-trips too
        self.history = np.asarray(data["history"], dtype=np.float64).reshape(
            self._nbr.shape[0], self.law.history_size)
        self.active = np.asarray(data["active"], dtype=np.uint8)
        self._columns_of = None
        self.fc_pair = np.asarray(data["fc_pair"], dtype=np.float64).reshape(-1, 6)

    def nbytes(self) -> int:
        return int(self.history.nbytes + self.fc_pair.nbytes + self.active.nbytes
                   + self.active_col.nbytes + self.col_sum.nbytes)
