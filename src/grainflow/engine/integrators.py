"""Integrator operations (SPEC M7): velocity Verlet, Adams-Bashforth 2, FIRE minimisation.

An integrator splits each step into ``pre_force`` (before forces are evaluated at the new
positions) and ``post_force``. See :mod:`grainflow.kernels.integrate` for the equations.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from grainflow.kernels import integrate as ik

if TYPE_CHECKING:
    from grainflow.engine.simulation import Simulation


class Integrator:
    """Base class: the two halves of a time step."""

    name = "integrator"

    def setup(self, sim: "Simulation") -> None:
        pass

    def pre_force(self, sim: "Simulation") -> None:  # pragma: no cover
        raise NotImplementedError

    def post_force(self, sim: "Simulation") -> None:
        pass


class VelocityVerlet(Integrator):
    """Velocity Verlet for positions, velocities and spins (LAMMPS ``nve/sphere``)."""

    name = "verlet"

    def pre_force(self, sim: "Simulation") -> None:
        st = sim.state
        ik.verlet_first_half(st.x, st.v, st.omega, st.force, st.torque, st.mass, st.inertia,
                             st.frozen, sim.dt)

    def post_force(self, sim: "Simulation") -> None:
        st = sim.state
        ik.verlet_second_half(st.v, st.omega, st.force, st.torque, st.mass, st.inertia,
                              st.frozen, sim.dt)


class AdamsBashforth2(Integrator):
    """AB2 velocities with trapezoidal positions (seed 002, Appendix B.2).

    The previous step's force and torque are per-particle arrays in the state
    (``ab2_force_prev``, ``ab2_torque_prev``), so they follow re-sorting and are saved in
    checkpoints. A particle without a previous force (first step, newly inserted) takes
    its current force, i.e. its first step is an Euler step for the velocity.
    """

    name = "adams_bashforth2"

    def setup(self, sim: "Simulation") -> None:
        sim.state.add_array("ab2_force_prev", (3,), fill=np.nan)
        sim.state.add_array("ab2_torque_prev", (3,), fill=np.nan)

    def pre_force(self, sim: "Simulation") -> None:
        st = sim.state
        fp = st.arrays["ab2_force_prev"]
        tp = st.arrays["ab2_torque_prev"]
        fresh = np.isnan(fp[:, 0])
        if fresh.any():
            fp[fresh] = st.force[fresh]
            tp[fresh] = st.torque[fresh]
        ik.adams_bashforth2_step(st.x, st.v, st.omega, st.force, st.torque, fp, tp, st.mass,
                                 st.inertia, st.frozen, sim.dt)


@dataclass
class FireResult:
    """Outcome of :func:`minimize_fire`."""

    converged: bool
    steps: int
    max_overlap: float
    max_force: float


def minimize_fire(sim: "Simulation", *, overlap_tol: float | None = None,
                  force_tol: float | None = None,
                  max_steps: int = 100_000, dt_max_factor: float = 10.0, n_min: int = 5,
                  f_inc: float = 1.1, f_dec: float = 0.5, alpha_start: float = 0.1,
                  f_alpha: float = 0.99) -> FireResult:
    """Relax overlaps with FIRE (Bitzek et al., PRL 97, 170201 (2006)).

    Translational degrees of freedom only (spins are zeroed). Uses the simulation's forces
    as they are: switch gravity off first for the seed-003 initialisation. Stops when the
    largest pair overlap is below ``overlap_tol`` (default ``1e-6`` of the mean diameter) and,
    if ``force_tol`` is given, the largest force component at most ``force_tol``; or after
    ``max_steps``. (No force criterion by default: velocity-dependent forces such as seed
    003's kinetic friction leave a round-off residual that never reaches exactly zero.) The simulation's time
    step is restored afterwards, velocities are zeroed, and the step counter is not advanced.
    """
    st = sim.state
    if overlap_tol is None:
        overlap_tol = 1e-6 * 2.0 * float(np.mean(st.radius)) if st.n else 0.0
    dt0 = sim.dt
    dt = dt0
    dt_max = dt_max_factor * dt0
    alpha = alpha_start
    since_negative = 0
    mobile = ~st.frozen
    st.v[:] = 0.0
    st.omega[:] = 0.0
    sim.compute_forces(update=False)
    steps = 0
    overlap = sim.max_overlap()
    fmax = float(np.abs(st.force[mobile]).max()) if mobile.any() else 0.0

    def done() -> bool:
        return overlap < overlap_tol and (force_tol is None or fmax <= force_tol)

    try:
        while steps < max_steps and not done():
            sim.dt = dt
            a = st.force / st.mass[:, None]
            st.v[mobile] += 0.5 * dt * a[mobile]
            power = float(np.sum(st.force[mobile] * st.v[mobile]))
            vnorm = np.sqrt(np.sum(st.v[mobile] ** 2))
            fnorm = np.sqrt(np.sum(st.force[mobile] ** 2))
            if fnorm > 0:
                st.v[mobile] = (1 - alpha) * st.v[mobile] + alpha * vnorm * st.force[mobile] / fnorm
            if power > 0:
                since_negative += 1
                if since_negative > n_min:
                    dt = min(dt * f_inc, dt_max)
                    alpha *= f_alpha
            else:
                since_negative = 0
                dt *= f_dec
                alpha = alpha_start
                st.v[:] = 0.0
            st.x[mobile] += dt * st.v[mobile]
            sim.compute_forces(update=False)
            st.v[mobile] += 0.5 * dt * (st.force[mobile] / st.mass[mobile, None])
            steps += 1
            if steps % 10 == 0 or steps == max_steps:
                overlap = sim.max_overlap()
                fmax = float(np.abs(st.force[mobile]).max()) if mobile.any() else 0.0
    finally:
        sim.dt = dt0
        st.v[:] = 0.0
        st.omega[:] = 0.0
    overlap = sim.max_overlap()
    return FireResult(done(), steps, overlap, fmax)


def integrator_by_name(name: str) -> Integrator:
    """Look up an integrator by its config name."""
    table: dict[str, Any] = {c.name: c for c in (VelocityVerlet, AdamsBashforth2)}
    if name not in table:
        raise ValueError(f"integrator: {name!r} is not known; use one of {sorted(table)}")
    return table[name]()
