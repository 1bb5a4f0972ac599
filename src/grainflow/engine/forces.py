"""One-body force operations: gravity and the drag of a background fluid.

Every operation implements :meth:`~grainflow.engine.operations.Force.compute`, adding into
``state.force`` and ``state.torque``. Pair interactions are in :mod:`grainflow.engine.pair`,
walls in :mod:`grainflow.walls.force`, tethers in :mod:`grainflow.engine.tethers`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from grainflow.engine.fast_path import StepCall, step_call
from grainflow.engine.operations import Force, ForceContext, TimeScale
from grainflow.kernels.specialize import for_threads_now


@njit(cache=True, parallel=True)
def _add_body_force(force, mass, frozen, g0, g1, g2):
    for i in prange(force.shape[0]):
        if not frozen[i]:
            m = mass[i]
            force[i, 0] += m * g0
            force[i, 1] += m * g1
            force[i, 2] += m * g2


def _gravity_step(a, time, dt, last):
    """:meth:`Gravity.compute` in the compiled step loop (``ADD`` bound)."""
    ADD(a[0], a[1], a[2], a[3], a[4], a[5])  # noqa: F821


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

    def compute(self, ctx: ForceContext, update: bool) -> None:
        st = ctx.state
        for_threads_now(_add_body_force)(st.force, st.mass, st.frozen, self.g[0], self.g[1],
                                         self.g[2])

    def step_call(self, ctx: ForceContext) -> StepCall:
        st = ctx.state
        return step_call(_gravity_step, "gravity", (st.force, st.mass, st.frozen,
                         float(self.g[0]), float(self.g[1]), float(self.g[2])),
                         ADD=_add_body_force)

    def potential_energy(self, ctx: ForceContext) -> float:
        """``-sum m g . x`` over the mobile particles."""
        st = ctx.state
        mobile = ~st.frozen
        return -float(np.sum(st.mass[mobile] * (st.x[mobile] @ self.g)))


@njit(cache=True, parallel=True)
def _add_drag(force, v, zeta_of_type, ptype, frozen):
    for i in prange(force.shape[0]):
        if not frozen[i]:
            z = zeta_of_type[ptype[i]]
            force[i, 0] -= z * v[i, 0]
            force[i, 1] -= z * v[i, 1]
            force[i, 2] -= z * v[i, 2]


def _drag_step(a, time, dt, last):
    """:meth:`Drag.compute` (per grain) in the compiled step loop (``ADD`` bound)."""
    ADD(a[0], a[1], a[2], a[3], a[4])  # noqa: F821


@njit(cache=True, parallel=True)
def _add_mass_drag(force, v, mass, rate_of_type, ptype, frozen):
    """``force_i -= gamma_type m_i v_i`` on every mobile particle (per-unit-mass drag)."""
    for i in prange(force.shape[0]):
        if not frozen[i]:
            c = rate_of_type[ptype[i]] * mass[i]
            force[i, 0] -= c * v[i, 0]
            force[i, 1] -= c * v[i, 1]
            force[i, 2] -= c * v[i, 2]


def _mass_drag_step(a, time, dt, last):
    """:meth:`Drag.compute` (per unit mass) in the compiled step loop (``ADD`` bound)."""
    ADD(a[0], a[1], a[2], a[3], a[4], a[5])  # noqa: F821


class Drag(Force):
    """Viscous drag of a background fluid (SPEC M3), in one of two forms.

    * per grain (default): ``F_i = -zeta v_i``, ``zeta`` a damping coefficient (mass/time):
      seed 003 eq. 5/11 as printed;
    * per unit mass (``per_mass=True``): ``F_i = -gamma m_i v_i``, ``gamma`` a drag *rate*
      (1/time): the form of the seed 003 authors' public code (``-b M v``). Every grain
      then relaxes at the same rate ``gamma`` and falls at the same terminal speed
      ``g / gamma`` whatever its mass (per grain: ``m g / zeta``).

    The coefficient (``zeta`` or ``gamma``) is one number for every particle, or one value
    per particle type (index = type); then every type present must have its value. It is
    kept as :attr:`zeta` (per grain) or :attr:`gamma` (per unit mass); the other is None.
    """

    def __init__(self, zeta: float | np.ndarray, *, per_mass: bool = False) -> None:
        self.per_mass = bool(per_mass)
        name, what = (("drag.gamma (config drag_rate)", "rate (1/time)") if self.per_mass
                      else ("drag.zeta", "number"))
        self._field = name
        z = np.atleast_1d(np.asarray(zeta, dtype=float))
        if z.ndim != 1 or z.size == 0 or np.any(z < 0) or not np.all(np.isfinite(z)):
            raise ValueError(f"{name}: {zeta!r} is not valid; expected a non-negative "
                             f"{what}, or one per particle type")
        self.zeta: np.ndarray | None = None if self.per_mass else z
        self.gamma: np.ndarray | None = z if self.per_mass else None
        self._values = z
        self._per_type = np.asarray(zeta).ndim > 0
        self._types_of: tuple[int, np.ndarray] | None = None  # (state generation, values)

    def _of_types(self, ntypes: int) -> np.ndarray:
        """zeta (or gamma) of types 0 .. ntypes-1; ValueError if a type present has none."""
        if not self._per_type:
            return np.full(ntypes, self._values[0])
        if self._values.size < ntypes:
            symbol = "gamma" if self.per_mass else "zeta"
            raise ValueError(f"{self._field}: {self._values.size} value(s) given but particle "
                             f"types go up to {ntypes - 1}; give one {symbol} per type (0 for "
                             "no drag)")
        return self._values

    def setup(self, ctx: ForceContext) -> None:
        st = ctx.state
        self._of_types(int(st.type.max()) + 1 if st.n else 1)

    def compute(self, ctx: ForceContext, update: bool) -> None:
        st = ctx.state
        if self.per_mass:
            for_threads_now(_add_mass_drag)(st.force, st.v, st.mass, self._values_of_types(st),
                                            st.type, st.frozen)
        else:
            for_threads_now(_add_drag)(st.force, st.v, self._values_of_types(st), st.type,
                                       st.frozen)

    def step_call(self, ctx: ForceContext) -> StepCall:
        st = ctx.state
        if self.per_mass:
            return step_call(_mass_drag_step, "mass_drag", (st.force, st.v, st.mass,
                             self._values_of_types(st), st.type, st.frozen), ADD=_add_mass_drag)
        return step_call(_drag_step, "drag", (st.force, st.v, self._values_of_types(st),
                         st.type, st.frozen), ADD=_add_drag)

    def _values_of_types(self, st) -> np.ndarray:
        """zeta (or gamma) per type, cached per particle-set generation."""
        if self._types_of is None or self._types_of[0] != st.generation:
            # the types present change only when particles are added, removed or re-sorted
            self._types_of = (st.generation, self._of_types(int(st.type.max()) + 1
                                                            if st.n else 1))
        return self._types_of[1]

    def potential_energy(self, ctx: ForceContext) -> float:
        """Drag only dissipates: nothing is stored."""
        return 0.0

    def time_scales(self, ctx: ForceContext) -> list[TimeScale]:
        """Relaxation time of each type present: ``m / zeta`` of its lightest mobile particle
        (per grain), or ``1 / gamma`` (per unit mass: the same for every mass)."""
        st = ctx.state
        if st.n == 0:
            return []
        z = self._of_types(int(st.type.max()) + 1)
        out = []
        for t in np.unique(st.type[~st.frozen]):
            if z[t] > 0:
                if self.per_mass:
                    out.append(TimeScale(float(1.0 / z[t]), "relaxation",
                                         f"per-mass drag on type {t}"))
                    continue
                m = float(st.mass[(st.type == t) & ~st.frozen].min())
                out.append(TimeScale(m / z[t], "relaxation", f"drag on type {t}"))
        return out
