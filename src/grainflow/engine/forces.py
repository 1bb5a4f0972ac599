"""Force operations: the things a :class:`~grainflow.engine.simulation.Simulation` asks for
forces each step.

Every operation implements ``compute(sim, update)``, adding into ``state.force`` and
``state.torque``; ``update`` is False during set-up evaluations, when contact histories must
not advance (as in LAMMPS's set-up force call). Operations that remember something between
steps implement ``state_dict()`` / ``load_state_dict()`` so checkpoints can hold it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numba
import numpy as np
from numba import njit, prange

from grainflow.kernels import neighbors as nk
from grainflow.kernels.pair_loop import active_pairs, evaluate_pairs, gather_pair_forces
from grainflow.models.base import ContactLaw

if TYPE_CHECKING:
    from grainflow.engine.simulation import Simulation


class Force:
    """Base class of force operations."""

    def compute(self, sim: "Simulation", update: bool) -> None:  # pragma: no cover
        raise NotImplementedError

    def state_dict(self) -> dict[str, Any]:
        return {}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        pass

    def nbytes(self) -> int:
        return 0


class PairForce(Force):
    """Particle-particle contacts with one :class:`ContactLaw` and its pair history.

    The history array is aligned with the simulation's neighbour list; when the list is
    rebuilt, :meth:`attach` carries each pair's history over, and when particles are
    re-indexed, :meth:`reindex` re-expresses it in the new indices.

    :meth:`compute` *sets* ``state.force`` and ``state.torque`` (the pair force is always
    the first force operation of a step, so this replaces zeroing them).
    """

    def __init__(self, law: ContactLaw) -> None:
        self.law = law
        h = law.history_size
        self._ptr = np.zeros(1, dtype=np.int64)
        self._nbr = np.zeros(0, dtype=np.int64)
        self.history = np.zeros((0, h))
        #: Per pair slot: force on i (3) and the torque vector c (3), valid where ``active``.
        self.fc_pair = np.zeros((0, 6))
        #: 1 where the law was evaluated at the last force call (see pair_loop).
        self.active = np.zeros(0, dtype=np.uint8)
        #: ``active`` in the column order of the list's transpose, for the gather; derived
        #: from ``active`` whenever the list or ``active`` is replaced (``_columns_of``).
        self.active_col = np.zeros(0, dtype=np.uint8)
        self._columns_of: np.ndarray | None = None
        #: Per particle: the j-side sums the pair loop builds directly (zero between calls).
        self.col_sum = np.zeros((0, 6))

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

    def compute(self, sim: "Simulation", update: bool) -> None:
        st = sim.state
        nl = sim.neighbors
        g = sim.geometry
        if self._columns_of is not nl.col_pair:
            self.active_col = self.active[nl.col_pair]
            self._columns_of = nl.col_pair
        if self.col_sum.shape[0] != st.n:
            self.col_sum = np.zeros((st.n, 6))
        chunks = max(1, min(numba.get_num_threads(), st.n))
        evaluate_pairs(self.law.evaluator, self.law.table, self.law.reach(), st.x, st.v,
                       st.omega, st.radius, st.mass, st.type, st.frozen, nl.row_ptr, nl.nbr,
                       nl.pair_col, nl.col_span, chunks, self.history, self.fc_pair,
                       self.active, self.active_col, self.col_sum, g.length, g.periodic,
                       sim.dt, update, st.force, st.torque)
        gather_pair_forces(nl.col_ptr, nl.col_pair, nl.col_span, chunks, self.fc_pair,
                           self.active_col, self.col_sum, st.radius, st.force, st.torque)

    def contacts(self, sim: "Simulation") -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                     np.ndarray]:
        """Interacting pairs now: indices i, j, force on i (M, 3), branch x_i - x_j (M, 3)."""
        nl = sim.neighbors
        pi, pj, slot = active_pairs(nl.row_ptr, nl.nbr, self.fc_pair, self.active)
        x = sim.state.x
        g = sim.geometry
        branch = x[pi] - x[pj]
        for a in np.nonzero(g.periodic)[0]:
            branch[:, a] -= g.length[a] * np.rint(branch[:, a] / g.length[a])
        return pi, pj, self.fc_pair[slot, :3].copy(), branch

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


@njit(cache=True, parallel=True)
def _add_body_force(force, mass, frozen, g0, g1, g2):
    for i in prange(force.shape[0]):
        if not frozen[i]:
            m = mass[i]
            force[i, 0] += m * g0
            force[i, 1] += m * g1
            force[i, 2] += m * g2


class Gravity(Force):
    """Uniform gravitational acceleration ``g`` (dim components): ``F_i = m_i g``."""

    def __init__(self, g) -> None:
        g = np.asarray(g, dtype=float).ravel()
        if g.size not in (2, 3) or not np.all(np.isfinite(g)):
            raise ValueError("gravity: give 2 (2D) or 3 (3D) finite components")
        self.g = np.zeros(3)
        self.g[: g.size] = g

    @classmethod
    def chute(cls, magnitude: float, angle_deg: float) -> "Gravity":
        """LAMMPS ``fix gravity ... chute angle``: tilted by ``angle`` towards +x."""
        theta = np.radians(180.0 - angle_deg)
        return cls([magnitude * np.sin(theta), 0.0, magnitude * np.cos(theta)])

    def compute(self, sim: "Simulation", update: bool) -> None:
        st = sim.state
        _add_body_force(st.force, st.mass, st.frozen, self.g[0], self.g[1], self.g[2])


@njit(cache=True, parallel=True)
def _add_drag(force, v, zeta_of_type, ptype, frozen):
    for i in prange(force.shape[0]):
        if not frozen[i]:
            z = zeta_of_type[ptype[i]]
            force[i, 0] -= z * v[i, 0]
            force[i, 1] -= z * v[i, 1]
            force[i, 2] -= z * v[i, 2]


class Drag(Force):
    """Viscous drag of a background fluid, ``F_i = -zeta v_i`` (seed 003 eq. 5/11, M3).

    ``zeta`` is a scalar or one value per particle type.
    """

    def __init__(self, zeta: float | np.ndarray) -> None:
        z = np.atleast_1d(np.asarray(zeta, dtype=float))
        if np.any(z < 0) or not np.all(np.isfinite(z)):
            raise ValueError("drag.zeta: must be a non-negative number (per type)")
        self.zeta = z

    def compute(self, sim: "Simulation", update: bool) -> None:
        st = sim.state
        ntypes = int(st.type.max()) + 1 if st.n else 1
        z = self.zeta if self.zeta.size >= ntypes else np.full(ntypes, self.zeta[0])
        _add_drag(st.force, st.v, z, st.type, st.frozen)
