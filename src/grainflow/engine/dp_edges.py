"""Smooth contacts between 2D deformable rings (SPEC M6; seed 003 Appendix A, eq. 9, 12) as
a force operation.

The edges of a "smooth" deformable particle are circulo-lines of thickness ``delta`` (the
vertices' diameter, :func:`grainflow.insertion.dp_bodies.add_rings` with
``contact="smooth"``). A vertex ``p`` of one ring within ``sigma = r_p + r_a`` of an edge
``(a, b)`` of another feels the harmonic repulsion
``U = (epsilon/2)(1 - d/sigma)^2`` (seed 003 eq. 9) and, optionally, kinetic friction
against the edge's velocity at the contact point (seed 003 eq. 12); ``d`` is the distance
to the edge by our reading of seed 003 Appendix A (the perpendicular distance inside the
edge's strip, the distance to the corner in the corner's outer wedge). The rule, its
forces and the deterministic summation are in :mod:`grainflow.kernels.dp_edges`.

Candidates come from the simulation's neighbour list. A vertex within ``sigma`` of an edge
is within ``|b - a| + sigma`` of the edge's start ``a``, so the list must reach the longest
edge beyond touching: :meth:`EdgeContacts.neighbor_reach` is ``reach_factor * l0_max``, with
``l0_max`` the largest rest edge length ``sqrt(4 a tan(pi/N_v)/N_v)`` of the rings present
when the operation is added (from their areas ``a``). Every force evaluation measures the
longest edge (the pass that stores the edge vectors, before the contact terms) and raises a ValueError
naming ``reach_factor`` when it exceeds that reach minus the edge thickness (one thickness
of margin), in Python and in the compiled step loop alike. The reach is fixed at set-up
(and kept in checkpoints): rings inserted later are served as long as their edges pass
that check.

Pairs with a particle in no ring (``ring_vertex < 0``) are ignored: ring vertices meet other
particles through a pair interaction (or not at all), never through this operation.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainflow.engine.fast_path import StepCall, step_call
from grainflow.engine.operations import ContactRows, Force, ForceContext, TimeScale
from grainflow.frame import PAIR
from grainflow.kernels.dp_edges import (add_edge_forces, column_shares, edge_contact_list,
                                        edge_pair_terms, ring_edge_vectors)
from grainflow.kernels.dp_shape import ring_areas
from grainflow.rings import rest_length, state_ring_table

KINETIC_ON = ("full", "tangential")
#: What the compiled step loop raises when an edge outgrows the reach (numba needs a
#: constant message; Python's check gives the numbers).
REACH_ERROR = ("reach_factor: a deformable-ring edge became longer than the neighbour reach "
               "of EdgeContacts minus the edge thickness; raise reach_factor")


def _edge_step(a, time, dt, last):
    """:meth:`EdgeContacts.compute` in the compiled step loop (``EDGES``, ``TERMS``,
    ``COLUMNS`` and ``ADD`` bound)."""
    longest = EDGES(a[3], a[5], a[10], a[11], a[12])  # noqa: F821
    if longest > a[19]:
        raise ValueError(REACH_ERROR)
    TERMS(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10],  # noqa: F821
          a[11], a[12], a[13], a[14])
    COLUMNS(a[3], a[16], a[17], a[13], a[14])  # noqa: F821
    ADD(a[3], a[4], a[15], a[14], a[18])  # noqa: F821


class EdgeContacts(Force):
    """Smooth vertex-edge contacts between deformable rings (seed 003 Appendix A).

    Parameters
    ----------
    epsilon:
        Energy scale of the harmonic repulsion ``U = (epsilon/2)(1 - d/sigma)^2``
        (seed 003 eq. 9); one value for every ring.
    mu_k:
        Kinetic-friction coefficient (force per unit velocity, seed 003 eq. 12); 0: none.
    kinetic_on:
        ``"full"``: friction on the whole velocity difference ``v_p - v_q`` (the seed's
        equation); ``"tangential"``: on its part perpendicular to the contact normal (the
        authors' production setting).
    n_vertices:
        Vertices per ring; every ring must have this many.
    reach_factor:
        The neighbour list reaches ``reach_factor * l0_max`` beyond touching (edges stretch;
        default 1.5).
    """

    def __init__(self, epsilon: float, mu_k: float = 0.0, kinetic_on: str = "full",
                 n_vertices: int = 16, *, reach_factor: float = 1.5) -> None:
        if not (np.isfinite(epsilon) and epsilon > 0):
            raise ValueError(f"epsilon: {epsilon!r} is not valid; expected a positive energy")
        if not (np.isfinite(mu_k) and mu_k >= 0):
            raise ValueError(f"mu_k: {mu_k!r} is not valid; expected a non-negative "
                             "friction coefficient")
        if kinetic_on not in KINETIC_ON:
            raise ValueError(f"kinetic_on: {kinetic_on!r} is not one of {KINETIC_ON}")
        if not (isinstance(n_vertices, (int, np.integer)) and n_vertices >= 3):
            raise ValueError(f"n_vertices: {n_vertices!r} is not valid; expected an "
                             "integer >= 3")
        if not (np.isfinite(reach_factor) and reach_factor > 1):
            raise ValueError(f"reach_factor: {reach_factor!r} is not valid; expected a "
                             "number > 1 (edges are at least l0 long)")
        self.epsilon = float(epsilon)
        self.mu_k = float(mu_k)
        self.kinetic_on = kinetic_on
        self.n_vertices = int(n_vertices)
        self.reach_factor = float(reach_factor)
        #: Largest rest edge length of the rings present at set-up (sizes the reach).
        self.l0_max = 0.0
        self._generation = -1
        self._nxt = np.zeros(0, dtype=np.int64)
        self._prv = np.zeros(0, dtype=np.int64)
        self._thickness = 0.0
        self._slot = np.zeros((0, 6))
        self._edges = np.zeros((0, 2))
        self._shares = np.zeros((0, 8))

    # ----------------------------------------------------------------- rings
    def setup(self, ctx: ForceContext) -> None:
        """Find the rings and size the reach from their areas (``l0_max``)."""
        index = self._refresh(ctx)
        if index.shape[0]:
            g = ctx.geometry
            areas = ring_areas(index, ctx.state.x, g.length, g.periodic)
            self.l0_max = float(np.max(rest_length(np.abs(areas), self.n_vertices)))

    def _refresh(self, ctx: ForceContext) -> np.ndarray:
        """Next/previous vertex of every particle (-1 outside rings) and the edge thickness
        for the current particle order; returns the (R, N_v) ring table."""
        st = ctx.state
        _, index = state_ring_table(st, self.n_vertices)
        nxt = np.full(st.n, -1, dtype=np.int64)
        prv = np.full(st.n, -1, dtype=np.int64)
        nxt[index] = np.roll(index, -1, axis=1)
        prv[index] = np.roll(index, 1, axis=1)
        self._nxt, self._prv = nxt, prv
        self._thickness = 2.0 * float(st.radius[index].max()) if index.size else 0.0
        self._generation = st.generation
        return index

    def neighbor_reach(self) -> float:
        """``reach_factor * l0_max``: the longest edge expected, with margin."""
        return self.reach_factor * self.l0_max

    def _limit(self) -> float:
        """Longest edge allowed: the reach minus the edge thickness."""
        return self.neighbor_reach() - self._thickness

    # ----------------------------------------------------------------- forces
    def _args(self, ctx: ForceContext) -> tuple:
        """The kernels' arguments (the layout :func:`_edge_step` reads)."""
        st = ctx.state
        if st.generation != self._generation:
            self._refresh(ctx)
        nl = ctx.neighbors
        g = ctx.geometry
        if self._slot.shape[0] != nl.n_pairs:
            self._slot = np.zeros((nl.n_pairs, 6))
        if self._edges.shape[0] != st.n:
            self._edges = np.zeros((st.n, 2))
            self._shares = np.zeros((st.n, 8))
        limit = self._limit()  # compared squared, sign kept: a negative limit always fails
        return (self.epsilon, self.mu_k, self.kinetic_on == "tangential", self._nxt,
                self._prv, st.x, st.v, st.radius, nl.row_ptr, nl.nbr, g.length, g.periodic,
                self._edges, self._slot, self._shares, st.frozen, nl.col_ptr, nl.col_pair,
                st.force, limit * abs(limit))

    def compute(self, ctx: ForceContext, update: bool) -> None:
        """Add the edge-contact forces (no history: ``update`` changes nothing); refuse an
        edge longer than the reach allows."""
        a = self._args(ctx)
        longest = ring_edge_vectors(a[3], a[5], a[10], a[11], a[12])
        if longest > a[19]:
            raise ValueError(
                f"reach_factor: an edge of length {np.sqrt(longest):.4g} is longer than the "
                f"neighbour reach {self.neighbor_reach():.4g} (reach_factor "
                f"{self.reach_factor:g} x l0_max {self.l0_max:.4g}, from the rings present "
                f"when EdgeContacts was added) minus the edge thickness "
                f"{self._thickness:.4g}; raise reach_factor, or add the rings before "
                "EdgeContacts")
        edge_pair_terms(*a[:15])
        column_shares(a[3], a[16], a[17], a[13], a[14])
        add_edge_forces(a[3], a[4], a[15], a[14], a[18])

    def step_call(self, ctx: ForceContext) -> StepCall:
        """:meth:`compute` for the compiled step loop (:func:`_edge_step`)."""
        # the parallel kernels on one thread too: the serial twins of the earlier two-pass
        # kernels ran 10x (terms) and 1.7x (gather) slower (a 6400-vertex hopper,
        # BENCHMARKS.md); not remeasured for the four passes
        return step_call(_edge_step, "dp_edges", self._args(ctx), serial_twins=False,
                         EDGES=ring_edge_vectors, TERMS=edge_pair_terms,
                         COLUMNS=column_shares, ADD=add_edge_forces)

    def _contact_list(self, ctx: ForceContext) -> tuple:
        """:func:`~grainflow.kernels.dp_edges.edge_contact_list` now."""
        a = self._args(ctx)
        ring_edge_vectors(a[3], a[5], a[10], a[11], a[12])  # scratch, a function of x alone
        return edge_contact_list(*a[:13])

    # ------------------------------------------------------------ observers
    def potential_energy(self, ctx: ForceContext) -> float:
        """``sum (epsilon/2)(1 - d/sigma)^2`` over the terms in contact (seed 003 eq. 9)."""
        d, sigma = self._contact_list(ctx)[5:7]
        return float(0.5 * self.epsilon * np.sum((1.0 - d / sigma) ** 2))

    def max_overlap(self, ctx: ForceContext) -> tuple[float, float, int]:
        """Largest ``sigma - d`` and largest ``(sigma - d)/r_p`` with its vertex ``p``."""
        p, _, _, _, _, d, sigma = self._contact_list(ctx)[:7]
        if p.size == 0:
            return 0.0, 0.0, -1
        overlap = sigma - d
        rel = overlap / ctx.state.radius[p]
        k = int(np.argmax(rel))
        return float(overlap.max()), float(rel[k]), int(p[k])

    def contacts(self, ctx: ForceContext) -> list[ContactRows]:
        """One row per term in contact, of kind ``PAIR`` between the vertex ``p`` and the
        edge's start ``a``: the force on ``p`` (repulsion and friction) and the branch
        ``r_p - q`` from the contact point ``q`` on the edge (so ``r_p + r_a - |branch|``
        is the overlap ``sigma - d``). The reaction's share on the edge's end ``b`` is not
        listed separately."""
        p, a, _, _, _, _, _, force, branch = self._contact_list(ctx)
        return [ContactRows(p, a, PAIR, force, branch)]

    def time_scales(self, ctx: ForceContext) -> list[TimeScale]:
        """Contact half period ``pi sqrt(m_eff/k)`` with ``k = epsilon/sigma^2`` for the
        thinnest edges and ``m_eff = m/2`` of the lightest vertex (a vertex against an end
        cap, the stiffest case); kinetic relaxation ``m_eff/mu_k``."""
        if ctx.state.generation != self._generation:
            self._refresh(ctx)
        ring = self._nxt >= 0
        if not ring.any():
            return []
        st = ctx.state
        m_eff = 0.5 * float(st.mass[ring].min())
        sigma = 2.0 * float(st.radius[ring].min())
        what = f"edge contacts (epsilon = {self.epsilon:g})"
        out = [TimeScale(float(np.pi * np.sqrt(m_eff * sigma**2 / self.epsilon)),
                         "oscillation", what)]
        if self.mu_k > 0:
            out.append(TimeScale(m_eff / self.mu_k, "relaxation",
                                 f"edge contacts kinetic friction (mu_k = {self.mu_k:g})"))
        return out

    # ----------------------------------------------------------------- checkpoints
    def state_dict(self) -> dict[str, Any]:
        """``l0_max``: measured at set-up from the rings' areas then, it sizes the list."""
        return {"l0_max": self.l0_max}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self.l0_max = float(data.get("l0_max", self.l0_max))

    def nbytes(self) -> int:
        return int(self._slot.nbytes + self._nxt.nbytes + self._prv.nbytes
                   + self._edges.nbytes + self._shares.nbytes)
