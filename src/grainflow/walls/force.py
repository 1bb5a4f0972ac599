"""Particle-wall contacts through the particles' own contact law (SPEC M4).

A wall is an infinite-mass, non-rotating partner of radius 0: for particle ``i`` and wall
``w`` with closest point ``c`` the law's evaluator (:mod:`grainflow.kernels.pair_loop`) is
called with

    ``d = x_i - c``, ``rad_j = 0``, ``vr = v_i - v_wall``, ``omega_j = 0``,
    ``meff = m_i``, parameters ``law.table[type_i, wall_type]``,

so M1/M2 (with the wall as the second body, as LAMMPS's ``fix wall/gran``) and M3's wall
potential ``(eps_w/2)(1 - 2 d_w/sigma_m)^2`` (seed 003 eq. 4 with ``sigma = r_m``) come out
of the same code as particle pairs. Forces act when ``|d| < r_i + reach`` (``reach``: the
law's range beyond contact, e.g. the cohesion shell); torque ``T_i -= r_i c``.

The contact history of each (particle, wall) pair lives in a per-particle state array
``wall_history_<k>`` of shape ``(n_walls, history_size)`` (``k`` counts the wall forces of
the simulation in the order they were added), so it follows re-sorting, insertion and
deletion of particles and is saved in checkpoints with the other particle arrays. Out of
range, a pair's history is cleared, as a particle pair leaving the neighbour list forgets.

Moving walls: the wall's shape at the time of the positions being evaluated. The stepping
force call (``update=True``) sees positions of ``sim.time + dt`` (the clock advances after
the forces, see :mod:`grainflow.engine.simulation`); set-up and diagnostic calls see
positions of ``sim.time``.

Walls are not periodic: a wall acts on particle positions as stored (wrapped into the box on
periodic axes).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Iterable

import numpy as np
from numba import njit, prange

from grainflow.engine.forces import Force
from grainflow.models.base import ContactLaw
from grainflow.walls.geometry import Wall, closest_point

if TYPE_CHECKING:
    from grainflow.engine.simulation import Simulation


@njit(cache=True, parallel=True)
def wall_loop(evaluate, table, wall_type, kinds, params, shift, wall_v, x, v, omega, radius,
              mass, ptype, frozen, hist, reach, dt, update, force, torque, record, out):
    """Add the wall forces and torques of every (particle, wall) pair.

    ``hist`` is ``(N * n_walls, H)`` with slot ``i * n_walls + w``; ``shift`` (n_walls, 3)
    is each wall's displacement now. With ``record`` the force on ``i`` and the branch
    vector ``d`` of every slot go to ``out[slot, 0:3]`` and ``out[slot, 3:6]``.
    """
    nw = kinds.shape[0]
    nh = hist.shape[1]
    for i in prange(x.shape[0]):
        if frozen[i]:
            continue
        ri = radius[i]
        cut = ri + reach
        cutsq = cut * cut
        f0 = 0.0
        f1 = 0.0
        f2 = 0.0
        t0 = 0.0
        t1 = 0.0
        t2 = 0.0
        hit = False
        for w in range(nw):
            slot = i * nw + w
            p0 = x[i, 0] - shift[w, 0]
            p1 = x[i, 1] - shift[w, 1]
            p2 = x[i, 2] - shift[w, 2]
            c0, c1, c2, ok = closest_point(kinds[w], params, w, p0, p1, p2)
            dx = p0 - c0
            dy = p1 - c1
            dz = p2 - c2
            rsq = dx * dx + dy * dy + dz * dz
            if not ok or rsq >= cutsq or rsq == 0.0:
                if update:
                    for h in range(nh):
                        if hist[slot, h] != 0.0:
                            hist[slot, h] = 0.0
                continue
            fx, fy, fz, cx, cy, cz = evaluate(
                table, ptype[i], wall_type, dx, dy, dz, rsq, ri, 0.0,
                v[i, 0] - wall_v[w, 0], v[i, 1] - wall_v[w, 1], v[i, 2] - wall_v[w, 2],
                omega[i, 0], omega[i, 1], omega[i, 2], 0.0, 0.0, 0.0,
                mass[i], hist, slot, dt, update)
            hit = True
            f0 += fx
            f1 += fy
            f2 += fz
            t0 += cx
            t1 += cy
            t2 += cz
            if record:
                out[slot, 0] = fx
                out[slot, 1] = fy
                out[slot, 2] = fz
                out[slot, 3] = dx
                out[slot, 4] = dy
                out[slot, 5] = dz
        if hit:
            force[i, 0] += f0
            force[i, 1] += f1
            force[i, 2] += f2
            torque[i, 0] -= ri * t0
            torque[i, 1] -= ri * t1
            torque[i, 2] -= ri * t2


@njit(cache=True, parallel=True)
def wall_max_overlap(kinds, params, shift, x, radius, frozen):
    """Largest ``r_i - |x_i - c|`` over mobile particles and walls in contact (0 if none)."""
    n = x.shape[0]
    nw = kinds.shape[0]
    best = np.zeros(n)
    for i in prange(n):
        if frozen[i]:
            continue
        b = 0.0
        for w in range(nw):
            p0 = x[i, 0] - shift[w, 0]
            p1 = x[i, 1] - shift[w, 1]
            p2 = x[i, 2] - shift[w, 2]
            c0, c1, c2, ok = closest_point(kinds[w], params, w, p0, p1, p2)
            if ok:
                ov = radius[i] - np.sqrt((p0 - c0) ** 2 + (p1 - c1) ** 2 + (p2 - c2) ** 2)
                if ov > b:
                    b = ov
        best[i] = b
    return best.max() if n else 0.0


class WallForce(Force):
    """Contacts between particles and a set of analytic walls, through one contact law.

    Parameters
    ----------
    walls:
        The wall shapes (:mod:`grainflow.walls.geometry`); any iterable, e.g. a
        :class:`~grainflow.walls.geometry.Hopper2D`.
    law:
        The contact law; usually the simulation's pair law, so walls and pairs share
        parameters and history conventions.
    wall_type:
        The walls' type index: particle-wall parameters are ``law.table[type_i, wall_type]``
        (set them with ``law.set_pair(particle_type, wall_type, ...)``).
    """

    def __init__(self, walls: Iterable[Wall], law: ContactLaw, wall_type: int) -> None:
        self.walls = tuple(walls)
        if not self.walls:
            raise ValueError("walls: the list is empty; give at least one wall shape")
        for w in self.walls:
            if not isinstance(w, Wall):
                raise ValueError(f"walls: {w!r} is not a wall shape; use Plane, Segment, "
                                 "Cylinder, Cone or PlateWithHole")
        if int(wall_type) != wall_type or wall_type < 0:
            raise ValueError(f"wall_type: {wall_type!r} is not valid; expected an integer >= 0")
        self.law = law
        self.wall_type = int(wall_type)
        self.kinds = np.array([w.kind for w in self.walls], dtype=np.int64)
        self.params = np.stack([w.pack() for w in self.walls])
        self.velocity = np.array([w.velocity for w in self.walls], dtype=np.float64)
        self.name = ""
        self._checked = (-1, -1)
        self._no_record = np.zeros((0, 6))

    @property
    def n_walls(self) -> int:
        return len(self.walls)

    def setup(self, sim: "Simulation") -> None:
        """Register the history array and check the walls fit the dimension and the law."""
        if sim.state.dim == 2:
            bad = [k for k, w in enumerate(self.walls) if not w.planar()]
            if bad:
                raise ValueError(f"walls: wall(s) {bad} do not lie in the z = 0 plane of a 2D "
                                 "simulation; use Segment/Plane with zero z components (or a "
                                 "Cylinder along z) and a velocity without z component")
        self._check_types(sim)
        mine = [f for f in sim.forces if isinstance(f, WallForce)]
        k = next((n for n, f in enumerate(mine) if f is self), len(mine))
        self.name = f"wall_history_{k}"
        sim.state.add_array(self.name, (self.n_walls, self.law.history_size))

    def _check_types(self, sim: "Simulation") -> None:
        st = sim.state
        key = (st.generation, self.law.n_types)
        if key == self._checked:
            return
        top = max(self.wall_type, int(st.type.max()) if st.n else 0)
        if top >= self.law.n_types:
            raise ValueError(
                f"wall_type: the law's parameter table covers types 0..{self.law.n_types - 1} "
                f"but the walls (type {self.wall_type}) meet particle types up to "
                f"{int(st.type.max()) if st.n else 0}; call law.set_pair(particle_type, "
                f"{self.wall_type}, ...) for the particle-wall parameters")
        self._checked = key

    def _shift(self, time: float) -> np.ndarray:
        return self.velocity * time

    def _history(self, sim: "Simulation") -> np.ndarray:
        """The history as a ``(N * n_walls, H)`` view (slot ``i * n_walls + w``)."""
        st = sim.state
        arr = st.arrays[self.name]
        if not arr.flags.c_contiguous:  # a reshape would copy and lose the updates
            arr = st.arrays[self.name] = np.ascontiguousarray(arr)
        return arr.reshape(st.n * self.n_walls, self.law.history_size)

    def _run(self, sim: "Simulation", time: float, hist: np.ndarray, force: np.ndarray,
             torque: np.ndarray, update: bool, out: np.ndarray | None) -> None:
        st = sim.state
        law = self.law
        wall_loop(law.evaluator, law.table, self.wall_type, self.kinds, self.params,
                  self._shift(time), self.velocity, st.x, st.v, st.omega, st.radius, st.mass,
                  st.type, st.frozen, hist, law.reach(), sim.dt, update, force, torque,
                  out is not None, self._no_record if out is None else out)

    def compute(self, sim: "Simulation", update: bool) -> None:
        self._check_types(sim)
        st = sim.state
        time = sim.time + sim.dt if update else sim.time
        self._run(sim, time, self._history(sim), st.force, st.torque, update, None)

    def contacts(self, sim: "Simulation") -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                     np.ndarray]:
        """Particle-wall contacts now: particle index, wall index, force on the particle
        (M, 3), branch vector from the wall's contact point to the centre (M, 3).

        Evaluated on copies: histories and particle forces are not touched.
        """
        self._check_types(sim)
        st = sim.state
        out = np.zeros((st.n * self.n_walls, 6))
        self._run(sim, sim.time, self._history(sim).copy(), np.zeros((st.n, 3)),
                  np.zeros((st.n, 3)), False, out)
        slots = np.nonzero(np.any(out[:, :3] != 0.0, axis=1))[0]
        return slots // self.n_walls, slots % self.n_walls, out[slots, :3], out[slots, 3:]

    def max_overlap(self, sim: "Simulation") -> float:
        """Largest particle-wall overlap ``r_i - |x_i - c|`` now (0 if none)."""
        st = sim.state
        return float(wall_max_overlap(self.kinds, self.params, self._shift(sim.time), st.x,
                                      st.radius, st.frozen))
