"""Integrator operations (SPEC M7): velocity Verlet and Adams-Bashforth 2.

An integrator splits each step into ``pre_force`` (before forces are evaluated at the new
positions) and ``post_force`` (:class:`~grainflow.engine.operations.Integrator`). See
:mod:`grainflow.kernels.integrate` for the equations; FIRE energy minimisation is in
:mod:`grainflow.engine.minimize`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainflow.engine.fast_path import StepCall, step_call
from grainflow.engine.operations import ForceContext, Integrator
from grainflow.kernels import integrate as ik
from grainflow.kernels.specialize import for_threads_now


def _first_half_step(a, time, dt):
    """:meth:`VelocityVerlet.pre_force` in the compiled step loop (``FIRST_HALF`` bound)."""
    FIRST_HALF(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], dt)  # noqa: F821


def _second_half_step(a, time, dt):
    """:meth:`VelocityVerlet.post_force` in the compiled step loop (``SECOND_HALF`` bound)."""
    SECOND_HALF(a[0], a[1], a[2], a[3], a[4], a[5], a[6], dt)  # noqa: F821


def _joined_halves_step(a, time, dt):
    """:meth:`VelocityVerlet.post_force`, then the next step's ``pre_force``, in the
    compiled step loop (``JOINED`` bound)."""
    JOINED(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], dt)  # noqa: F821


class VelocityVerlet(Integrator):
    """Velocity Verlet for positions, velocities and spins (LAMMPS ``nve/sphere``)."""

    name = "verlet"

    def pre_force(self, ctx: ForceContext) -> None:
        st = ctx.state
        for_threads_now(ik.verlet_first_half)(st.x, st.v, st.omega, st.force, st.torque,
                                              st.mass, st.inertia, st.frozen, ctx.dt)

    def post_force(self, ctx: ForceContext) -> None:
        st = ctx.state
        for_threads_now(ik.verlet_second_half)(st.v, st.omega, st.force, st.torque, st.mass,
                                               st.inertia, st.frozen, ctx.dt)

    def step_calls(self, ctx: ForceContext) -> tuple[StepCall, StepCall, StepCall]:
        st = ctx.state
        both = (st.x, st.v, st.omega, st.force, st.torque, st.mass, st.inertia, st.frozen)
        return (step_call(_first_half_step, "verlet_first", both,
                          FIRST_HALF=ik.verlet_first_half),
                step_call(_second_half_step, "verlet_second", (st.v, st.omega, st.force,
                          st.torque, st.mass, st.inertia, st.frozen),
                          SECOND_HALF=ik.verlet_second_half),
                step_call(_joined_halves_step, "verlet_joined", both,
                          JOINED=ik.verlet_second_then_first_half))


class AdamsBashforth2(Integrator):
    """AB2 velocities with trapezoidal positions (seed 002, Appendix B.2).

    The previous step's force and torque are per-particle arrays in the state
    (``ab2_force_prev``, ``ab2_torque_prev``), so they follow re-sorting and are saved in
    checkpoints. A particle without a previous force (first step, newly inserted, or
    relocated by an updater: the arrays are ``reset_on_move``) takes its current force, i.e.
    its first step is an Euler step for the velocity.
    """

    name = "adams_bashforth2"

    def setup(self, ctx: ForceContext) -> None:
        ctx.state.add_array("ab2_force_prev", (3,), fill=np.nan, reset_on_move=True)
        ctx.state.add_array("ab2_torque_prev", (3,), fill=np.nan, reset_on_move=True)

    def pre_force(self, ctx: ForceContext) -> None:
        st = ctx.state
        fp = st.arrays["ab2_force_prev"]
        tp = st.arrays["ab2_torque_prev"]
        fresh = np.isnan(fp[:, 0])
        if fresh.any():
            fp[fresh] = st.force[fresh]
            tp[fresh] = st.torque[fresh]
        ik.adams_bashforth2_step(st.x, st.v, st.omega, st.force, st.torque, fp, tp, st.mass,
                                 st.inertia, st.frozen, ctx.dt)


def integrator_by_name(name: str) -> Integrator:
    """Look up an integrator by its config name."""
    table: dict[str, Any] = {c.name: c for c in (VelocityVerlet, AdamsBashforth2)}
    if name not in table:
        raise ValueError(f"integrator: {name!r} is not known; use one of {sorted(table)}")
    return table[name]()
