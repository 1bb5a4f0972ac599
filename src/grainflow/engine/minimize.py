"""FIRE energy minimisation (Bitzek et al., PRL 97, 170201 (2006)) of a simulation's state.

Used to remove overlaps before a run (seed 003's initialisation, ``run.minimize``). Every
force evaluation is read-only (``update=False``): contact histories do not change.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from grainflow.kernels import fire

if TYPE_CHECKING:
    from grainflow.engine.simulation import Simulation


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
    ``max_steps``. The step grows to at most ``dt_max_factor`` times the simulation's and a
    fifth of its shortest oscillation time. (No force criterion by default: velocity-dependent forces such as seed
    003's kinetic friction leave a round-off residual that never reaches exactly zero.) The simulation's time
    step is restored afterwards, velocities are zeroed, and the step counter is not advanced.
    """
    st = sim.state
    if overlap_tol is None:
        overlap_tol = 1e-6 * 2.0 * float(np.mean(st.radius)) if st.n else 0.0
    dt0 = sim.dt
    dt = dt0
    # FIRE's growing step stays below a fifth of the shortest oscillation (half period):
    # ten times a coarse run step (dt_fraction 0.1 of the contact time) would be past
    # velocity Verlet's limit (0.64 of it), and a fill with overlapping contacts explodes
    dt_max = min(dt_max_factor * dt0, sim.stable_time_step(0.2))
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
            power = fire.kick_and_mix(st.v, st.force, st.mass, st.frozen, dt, alpha)
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
            fire.drift(st.x, st.v, st.frozen, dt)
            sim.compute_forces(update=False)
            fire.half_kick(st.v, st.force, st.mass, st.frozen, dt)
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


def relax(sim: "Simulation") -> FireResult:
    """Remove overlaps with FIRE, gravity switched off (seed 003's initialisation; the
    ``run.minimize`` option).

    Drag is switched off too: FIRE descends the potential energy, and a force against every
    velocity damps the velocity FIRE builds up along it. With drag on, 60 rough DP rings took
    more than 100,000 FIRE steps without reaching the overlap tolerance; without it, 20,300.
    (Kinetic friction inside a pair law stays: it is part of the law.)"""
    from grainflow.engine.forces import Drag, Gravity

    forces = sim.forces
    sim.forces = [f for f in forces if not isinstance(f, (Gravity, Drag))]
    try:
        return minimize_fire(sim)
    finally:
        sim.forces = forces
        sim.forces_current = False
