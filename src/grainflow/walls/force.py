"""Particle-wall contacts through the particles' own contact law (SPEC M4).

A wall is an infinite-mass, non-rotating partner of radius 0: for particle ``i`` and wall
``w`` with closest point ``c`` the law's evaluator (:mod:`grainflow.kernels.pair_loop`) is
called with

    ``d = x_i - c``, ``rad_j = 0``, ``vr = v_i - v_wall``, ``omega_j = 0``,
    ``meff = m_i``, parameters ``law.table[type_i, wall_type]``,

so M1/M2 (with the wall as the second body, as LAMMPS's ``fix wall/gran``) and M3's wall
potential ``(eps_w/2)(1 - 2 d_w/sigma_m)^2`` (seed 003 eq. 4 with ``sigma = r_m``) come out
of the same code as particle pairs. Forces act when ``|d| < r_i + reach`` (``reach``: the
law's range beyond contact, e.g. the cohesion shell); torque ``T_i -= r_i c``. A centre
lying exactly on the wall (``d = 0``) is pushed along the wall's normal at ``c`` towards its
acting side: ``d = 1e-12 r_i n`` (:data:`ON_WALL`), so it feels the force of an overlap
``r_i``.

Several walls combine by addition: the forces of all walls on a particle add up, and each
(particle, wall) pair keeps its own contact history, so a grain in the corner of two walls
has two independent contacts. Walls of one ``wall_type`` share that type's contact
parameters.

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

Static walls visit only the particles near them: at each neighbour-list build the particles
within ``r_i + reach + skin`` of some wall, or holding a wall contact history, are listed, and
the stepping loop runs over them alone. Until the next build no particle moves more than
``skin/2`` (the list's own rebuild rule), so no other particle can reach a wall; the results
are bitwise those of visiting every particle. Under the list's relative check, which lets
particles move far as long as their neighbours move with them, each unvisited particle is
given its distance to the walls as an allowance instead. Moving walls visit every particle.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np
from numba import prange

from grainflow.engine.fast_path import StepCall, step_call
from grainflow.engine.operations import ContactRows, Force, ForceContext, TimeScale
from grainflow.frame import WALL
from grainflow.kernels.specialize import for_threads_now, specialize
from grainflow.models.base import ContactLaw
from grainflow.walls.geometry import Wall, closest_point

#: Length of the branch vector, in units of the particle radius, given to a particle whose
#: centre lies exactly on a wall (along the wall's normal).
ON_WALL = 1e-12


def wall_kernel(evaluate: Any) -> Any:
    """:func:`_wall_loop` compiled for one law's evaluator (inlined; see
    :mod:`grainflow.kernels.specialize`)."""
    return specialize(_wall_loop, "wall_loop_" + evaluate.py_func.__name__,
                      {"evaluate": evaluate}, parallel=True)


def _wall_loop(table, wall_type, acts_on, kinds, params, shift, wall_v, x, v, omega, radius,
               mass, ptype, frozen, hist, reach, dt, update, force, torque, record, out,
               visit):
    """Add the wall forces and torques of every (particle, wall) pair of the particles
    ``visit`` (indices; the others are known to be out of reach, with no history).

    Template bound to the law's ``evaluate`` by :func:`wall_kernel`. ``hist`` is
    ``(N * n_walls, H)`` with slot ``i * n_walls + w``; ``shift`` (n_walls, 3) is each
    wall's displacement now; ``acts_on[type]`` says which particle types the walls touch.
    History is written only when ``update``. With ``record`` the force on ``i`` and the
    branch vector ``d`` of every slot go to ``out[slot, 0:3]`` and ``out[slot, 3:6]``.
    """
    nw = kinds.shape[0]
    nh = hist.shape[1]
    unw = np.uint64(nw)
    for k in prange(visit.shape[0]):
        # unsigned indices skip numba's wraparound of negative ones at every access
        # (:mod:`grainflow.kernels.pair_loop`); mixed with signed ones numba would give floats
        i = np.uint64(visit[k])
        if frozen[i] or not acts_on[ptype[i]]:
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
            slot = i * unw + np.uint64(w)
            p0 = x[i, 0] - shift[w, 0]
            p1 = x[i, 1] - shift[w, 1]
            p2 = x[i, 2] - shift[w, 2]
            c0, c1, c2, ok, n0, n1, n2 = closest_point(kinds[w], params, w, p0, p1, p2)
            dx = p0 - c0
            dy = p1 - c1
            dz = p2 - c2
            rsq = dx * dx + dy * dy + dz * dz
            if not ok or rsq >= cutsq:
                if update:
                    for h in range(nh):
                        if hist[slot, h] != 0.0:
                            hist[slot, h] = 0.0
                continue
            if rsq == 0.0:  # centre on the surface: push along the normal
                dx = ON_WALL * ri * n0
                dy = ON_WALL * ri * n1
                dz = ON_WALL * ri * n2
                rsq = dx * dx + dy * dy + dz * dz
            fx, fy, fz, cx, cy, cz = evaluate(  # noqa: F821 (bound by wall_kernel)
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


def wall_gaps(kinds, params, shift, x, radius):
    """Per particle, the smallest ``|x_i - c| - r_i`` over the walls, on either side of
    them (:func:`_wall_gaps`)."""
    return specialize(_wall_gaps, "wall_gaps", {}, parallel=True)(kinds, params, shift, x,
                                                                    radius)


def _wall_gaps(kinds, params, shift, x, radius):
    """Per particle, the smallest surface gap ``|x_i - c| - r_i`` to a wall. The side does
    not matter: a particle behind a wall reaches its acting side only through the wall."""
    n = x.shape[0]
    nw = kinds.shape[0]
    gap = np.empty(n)
    for i in prange(n):
        g = np.inf
        for w in range(nw):
            p0 = x[i, 0] - shift[w, 0]
            p1 = x[i, 1] - shift[w, 1]
            p2 = x[i, 2] - shift[w, 2]
            c0, c1, c2, ok, n0, n1, n2 = closest_point(kinds[w], params, w, p0, p1, p2)
            d = np.sqrt((p0 - c0) ** 2 + (p1 - c1) ** 2 + (p2 - c2) ** 2)
            if d < g:
                g = d
        gap[i] = g - radius[i]
    return gap


def wall_overlaps(kinds, params, shift, x, radius, frozen, acts_on, ptype):
    """Per particle, the largest overlap with a wall (:func:`_wall_overlaps`)."""
    return specialize(_wall_overlaps, "wall_overlaps", {}, parallel=True)(
        kinds, params, shift, x, radius, frozen, acts_on, ptype)


def _wall_overlaps(kinds, params, shift, x, radius, frozen, acts_on, ptype):
    """Per particle, the largest ``r_i - |x_i - c|`` over the walls it is on the acting
    side of (0 if none, or if frozen or of a type the walls do not touch)."""
    n = x.shape[0]
    nw = kinds.shape[0]
    best = np.zeros(n)
    for i in prange(n):
        if frozen[i] or not acts_on[ptype[i]]:
            continue
        b = 0.0
        for w in range(nw):
            p0 = x[i, 0] - shift[w, 0]
            p1 = x[i, 1] - shift[w, 1]
            p2 = x[i, 2] - shift[w, 2]
            c0, c1, c2, ok, n0, n1, n2 = closest_point(kinds[w], params, w, p0, p1, p2)
            if ok:
                ov = radius[i] - np.sqrt((p0 - c0) ** 2 + (p1 - c1) ** 2 + (p2 - c2) ** 2)
                if ov > b:
                    b = ov
        best[i] = b
    return best


def _wall_step(a, time, dt, last):
    """:meth:`WallForce.compute` (``update=True``) in the compiled step loop: the walls at
    the end of the step, ``time + dt``; the wall kernel ``KERNEL`` is bound by
    :meth:`WallForce.step_call`. ``update`` (true) and the record flag (false) come in
    ``a[19]`` and ``a[20]``: literal constants here would compile the kernel once more."""
    KERNEL(a[0], a[1], a[2], a[3], a[4], a[5] * (time + dt), a[5], a[6], a[7], a[8],  # noqa: F821
           a[9], a[10], a[11], a[12], a[13], a[14], dt, a[19], a[15], a[16], a[20], a[17],
           a[18])


class WallForce(Force):
    """Contacts between particles and a set of analytic walls, through one contact law.

    The forces of all walls add up; each (particle, wall) pair keeps its own contact
    history; walls of one ``wall_type`` share that type's contact parameters.

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
    particle_types:
        The particle types the walls touch (default: all); other types pass through them.
    """

    def __init__(self, walls: Iterable[Wall], law: ContactLaw, wall_type: int,
                 particle_types: Iterable[int] | None = None) -> None:
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
        self.particle_types = None if particle_types is None else sorted(
            {int(t) for t in particle_types})
        if self.particle_types is not None and (not self.particle_types
                                                or self.particle_types[0] < 0):
            raise ValueError(f"particle_types: {particle_types!r} is not valid; expected "
                             "particle type indices >= 0 (or None for all)")
        self.kinds = np.array([w.kind for w in self.walls], dtype=np.int64)
        self.params = np.stack([w.pack() for w in self.walls])
        self.velocity = np.array([w.velocity for w in self.walls], dtype=np.float64)
        self.name = ""
        self._checked: tuple[int, int] = (-1, -1)
        self._acts_on = np.ones(1, dtype=np.bool_)
        self._no_record = np.zeros((0, 6))
        self._kernel: Any = None
        #: The particles the stepping loop visits, and the (list build, particle set) they
        #: were found for (see the module docstring).
        self._visit = np.zeros(0, dtype=np.int64)
        self._visit_key: tuple[int, int, int] | None = None

    @property
    def n_walls(self) -> int:
        return len(self.walls)

    def setup(self, ctx: ForceContext) -> None:
        """Register the history array and check the walls fit the dimension and the law."""
        st = ctx.state
        if st.dim == 2:
            bad = [k for k, w in enumerate(self.walls) if not w.planar()]
            if bad:
                raise ValueError(f"walls: wall(s) {bad} do not lie in the z = 0 plane of a 2D "
                                 "simulation; use Segment/Plane with zero z components (or a "
                                 "Cylinder along z) and a velocity without z component")
        self._check_types(st)
        k = sum(1 for name in st.arrays if name.startswith("wall_history_"))
        self.name = f"wall_history_{k}"
        st.add_array(self.name, (self.n_walls, self.law.history_size), reset_on_move=True)

    def _check_types(self, st) -> None:
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
        acts_on = np.zeros(top + 1, dtype=np.bool_)
        if self.particle_types is None:
            acts_on[:] = True
        else:
            acts_on[[t for t in self.particle_types if t <= top]] = True
        self._acts_on = acts_on
        self._checked = key

    def _shift(self, time: float) -> np.ndarray:
        return self.velocity * time

    def _history(self, st) -> np.ndarray:
        """The history as a ``(N * n_walls, H)`` view (slot ``i * n_walls + w``)."""
        arr = st.arrays[self.name]
        if not arr.flags.c_contiguous:  # a reshape would copy and lose the updates
            arr = st.arrays[self.name] = np.ascontiguousarray(arr)
        return arr.reshape(st.n * self.n_walls, self.law.history_size)

    def _near(self, ctx: ForceContext) -> np.ndarray:
        """Indices of the particles that may touch a wall before the next list build: within
        ``r_i + reach + skin`` of one, or holding a wall history (every particle when a
        wall moves)."""
        st = ctx.state
        nl = ctx.neighbors
        key = (nl.builds, st.generation, st.n)
        if key == self._visit_key:
            return self._visit
        if np.any(self.velocity):
            self._visit = np.arange(st.n, dtype=np.int64)
        else:
            gap, near = self._within_skin(ctx, ctx.time)
            self._visit = np.nonzero(near)[0].astype(np.int64)
            if nl.relative and nl.is_current_for(st):
                nl.limit_motion(self.name, self._allowance(gap, near, st.x, nl))
        self._visit_key = key
        return self._visit

    def _within_skin(self, ctx: ForceContext, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Each particle's gap to the nearest wall at ``time``, and whether it is within
        ``reach + skin`` of one or holds a wall history."""
        st = ctx.state
        gap = wall_gaps(self.kinds, self.params, self._shift(time), st.x, st.radius)
        near = gap < self.law.reach() + ctx.neighbors.skin
        if st.n and self.law.history_size:
            near |= np.any(self._history(st).reshape(st.n, -1) != 0.0, axis=1)
        return gap, near

    def _touching(self, ctx: ForceContext, time: float) -> np.ndarray:
        """Indices of the particles :meth:`_within_skin` at ``time``, whatever the list (a
        moving wall included): every particle a wall exerts a force on then, which is what
        a record of the contacts needs to visit."""
        return np.nonzero(self._within_skin(ctx, time)[1])[0].astype(np.int64)

    def _allowance(self, gap: np.ndarray, near: np.ndarray, x: np.ndarray,
                   nl: Any) -> np.ndarray:
        """How far each particle may move since the list's build before it could reach a
        wall without being visited (the list's relative check,
        :meth:`~grainflow.engine.neighbor_list.NeighborList.limit_motion`): its gap beyond
        the walls' reach less what it has moved since the build (zero right after a build;
        not after a checkpoint's load). Visited particles are free."""
        moved = np.linalg.norm(x - nl.reference_positions, axis=1)
        allowance = np.maximum(gap - self.law.reach() - moved, 0.0)
        allowance[near] = np.inf
        return allowance

    def _run(self, ctx: ForceContext, time: float, update: bool, force: np.ndarray,
             torque: np.ndarray, out: np.ndarray | None,
             visit: np.ndarray | None = None) -> None:
        """The wall kernel over ``visit`` (default: :meth:`_near`), recording into ``out``
        if given."""
        a = self._arguments(ctx, force, torque, out,
                            self._near(ctx) if visit is None else visit)
        for_threads_now(self._kernel)(*a[:5], self._shift(time), *a[5:15], ctx.dt, update,
                                      a[15], a[16], out is not None, a[17], a[18])

    def _arguments(self, ctx: ForceContext, force: np.ndarray, torque: np.ndarray,
                   out: np.ndarray | None, visit: np.ndarray) -> tuple:
        """The wall kernel's arguments but the shift, ``dt``, ``update`` and the record flag
        (the layout :func:`_wall_step` reads)."""
        st = ctx.state
        self._check_types(st)
        law = self.law
        if self._kernel is None:
            self._kernel = wall_kernel(law.evaluator)
        return (law.table, self.wall_type, self._acts_on, self.kinds, self.params,
                self.velocity, st.x, st.v, st.omega, st.radius, st.mass, st.type, st.frozen,
                self._history(st), law.reach(), force, torque,
                self._no_record if out is None else out, visit)

    def compute(self, ctx: ForceContext, update: bool) -> None:
        st = ctx.state
        self._run(ctx, ctx.time + ctx.dt if update else ctx.time, update, st.force, st.torque,
                  None)

    def step_call(self, ctx: ForceContext) -> StepCall:
        """``compute(ctx, update=True)`` for the compiled step loop."""
        st = ctx.state
        a = self._arguments(ctx, st.force, st.torque, None, self._near(ctx))
        return step_call(_wall_step, "wall_step", (*a, True, False), KERNEL=self._kernel)

    def contacts(self, ctx: ForceContext) -> list[ContactRows]:
        """Particle-wall contacts now: particle index, wall index, force on the particle,
        branch vector from the wall's contact point to the centre. Read-only: the force and
        torque arrays and every history are left as they are."""
        st = ctx.state
        out = np.zeros((st.n * self.n_walls, 6))
        visit = self._touching(ctx, ctx.time)
        self._run(ctx, ctx.time, False, np.zeros((st.n, 3)), np.zeros((st.n, 3)), out, visit)
        slots = (visit[:, None] * self.n_walls + np.arange(self.n_walls)).ravel()
        slots = slots[np.any(out[slots, :3] != 0.0, axis=1)]
        return [ContactRows(slots // self.n_walls, slots % self.n_walls, WALL, out[slots, :3],
                            out[slots, 3:])]

    def potential_energy(self, ctx: ForceContext) -> float | None:
        """Static walls store only contact elastic energy (bounded by the health check from
        the contact list): 0; a moving wall can do work: None."""
        return 0.0 if not np.any(self.velocity) else None

    def max_overlap(self, ctx: ForceContext) -> tuple[float, float, int]:
        """Largest particle-wall overlap ``r_i - |x_i - c|`` now: absolute, relative to the
        radius, and the index of the particle with the latter (``(0, 0, -1)`` if none)."""
        st = ctx.state
        if st.n == 0:
            return 0.0, 0.0, -1
        self._check_types(st)
        ov = wall_overlaps(self.kinds, self.params, self._shift(ctx.time), st.x, st.radius,
                           st.frozen, self._acts_on, st.type)
        rel = ov / st.radius
        i = int(np.argmax(rel))
        if rel[i] <= 0.0:
            return 0.0, 0.0, -1
        return float(ov.max()), float(rel[i]), i

    def time_scales(self, ctx: ForceContext) -> list[TimeScale]:
        """Contact time (and kinetic relaxation and cohesive crossing times) of the lightest
        and smallest mobile particle of each type the walls touch, against an infinitely
        heavy wall."""
        st = ctx.state
        mobile = ~st.frozen
        if not mobile.any():
            return []
        self._check_types(st)
        out = []
        for t in np.unique(st.type[mobile]):
            if not self._acts_on[t]:
                continue
            sel = mobile & (st.type == t)
            m, r = float(st.mass[sel].min()), float(st.radius[sel].min())
            what = f"walls (type {self.wall_type}) on particle type {t}"
            out.append(TimeScale(self.law.contact_time(int(t), self.wall_type, m, r),
                                 "oscillation", what))
            out += [TimeScale(time, kind, what)
                    for kind, time in self.law.rate_times(int(t), self.wall_type, m)]
        return out
