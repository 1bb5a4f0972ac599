"""The authors' code units of seed 003 against the study's units
(:mod:`grainflow.scenarios.hopper_units`, docs/hopper_study.md "Conversion").

The same dynamics run twice, once in the authors' code units (mass 16 a0, weight g a0,
g = 0.05, forces spK (1 - r/sigma_mn), kinetic friction -mu v_t, drag -b M v) and once in
ours (sigma_avg = g = rho = 1) with the converted parameters; the converted trajectories must
coincide. Free fall and the terminal drag speed are checked against their analytic forms in
both systems.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainflow.engine.forces import Drag, Gravity
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.models.soft import SoftLaw
from grainflow.scenarios.hopper_units import AUTHORS_CODE, CodeUnits
from grainflow.state import ParticleState

UNITS = CodeUnits()


def test_conversion_reproduces_the_derived_table() -> None:
    """The numbers of docs/hopper_study.md's conversion table, derived here from g, mass_factor and sigma."""
    assert UNITS.time == pytest.approx(math.sqrt(1.2 * 16 / 0.05))  # 19.6
    assert UNITS.mu(10.0) == pytest.approx(8.505, abs=1e-3)
    assert UNITS.gamma(0.1) == pytest.approx(1.960, abs=1e-3)
    assert UNITS.pair_force_scale(10.0) == pytest.approx(138.9, abs=0.1)
    # wall force 100 (1 - 2d/sigma_m): eps_w of the small and large grains 579 and 810
    for sigma_code, expected in ((1.0, 578.7), (1.4, 810.2)):
        eps_w = UNITS.wall_energy(100.0) * sigma_code / UNITS.length
        assert eps_w == pytest.approx(expected, abs=0.1)
    assert UNITS.duration(0.005) == pytest.approx(2.55e-4, rel=1e-2)
    assert UNITS.flow_rate(1.0, 0.005) == pytest.approx(3.16, abs=0.01)
    assert UNITS.lam(1.0, 1.0) == pytest.approx(18.1, abs=0.05)
    assert AUTHORS_CODE.lid_time == pytest.approx(1200 * 0.005 / UNITS.time)


def _pair(dim_scale: float, density: float, g: float, eps: float, mu: float, rate: float,
          dt: float) -> Simulation:
    """Two overlapping disks (radii 0.5 and 0.7 code lengths, scaled by ``dim_scale``) that
    approach and slide, under gravity, drag per unit mass and tangential kinetic friction,
    with the authors' size-proportional stiffness."""
    box = Box(lo=np.array([-50.0, -50.0]) * dim_scale, hi=np.array([50.0, 50.0]) * dim_scale,
              periodic=(False, False))
    st = ParticleState(2, box)
    x = np.array([[0.0, 0.0], [1.1, 0.3]]) * dim_scale
    st.add_particles(x, np.array([0.5, 0.7]) * dim_scale, density=density)
    st.v[:, :2] = np.array([[0.02, 0.01], [-0.02, 0.0]])
    law = SoftLaw()
    law.set_pair(0, 0, epsilon=eps, epsilon_scales="diameter", mu_k=mu,
                 kinetic_on="tangential")
    sim = Simulation(st, dt, law)
    sim.add_force(Gravity([0.0, -g]))
    sim.add_force(Drag(rate, per_mass=True))
    return sim


def test_a_collision_is_the_same_in_both_unit_systems() -> None:
    code = AUTHORS_CODE
    dt_code = 0.005
    a = _pair(1.0, UNITS.mass_factor, UNITS.acceleration, code.spK, 3.0, 0.05, dt_code)
    velocity_unit = UNITS.length / UNITS.time
    b = _pair(1.0 / UNITS.length, 1.0, 1.0, UNITS.pair_force_scale(code.spK), UNITS.mu(3.0),
              UNITS.gamma(0.05), dt_code / UNITS.time)
    b.state.v[:] = a.state.v / velocity_unit
    a.run(4000)
    b.run(4000)
    assert a.time == pytest.approx(b.time * UNITS.time)
    # the grains separated, slid and fell: the test covers every force
    moved = np.linalg.norm(a.state.x[:, :2] - np.array([[0.0, 0.0], [1.1, 0.3]]), axis=1)
    assert np.all(moved > 0.1)
    np.testing.assert_allclose(b.state.x * UNITS.length, a.state.x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(b.state.v * velocity_unit, a.state.v, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("system", ["code", "ours"])
def test_free_fall_and_terminal_drag_speed(system: str) -> None:
    """One grain from rest: v(t) = (g/gamma)(1 - exp(-gamma t)) and the terminal speed g/gamma,
    which is 0.510 sigma_avg/t0 in both systems for the drag limit b = 0.1."""
    if system == "code":
        density, g, rate, length, time = UNITS.mass_factor, UNITS.acceleration, 0.1, 1.0, 1.0
        dt = 0.005
    else:
        density, g, rate = 1.0, 1.0, UNITS.gamma(0.1)
        length, time = UNITS.length, UNITS.time
        dt = 0.005 / UNITS.time
    box = Box(lo=np.array([-1e4, -1e4]), hi=np.array([1e4, 1e4]), periodic=(False, False))
    st = ParticleState(2, box)
    st.add_particles(np.zeros((1, 2)), 0.5 / length, density=density)
    law = SoftLaw()
    law.set_pair(0, 0, epsilon=1.0)  # one grain: never in contact
    sim = Simulation(st, dt, law)
    sim.add_force(Gravity([0.0, -g]))
    sim.add_force(Drag(rate, per_mass=True))
    sim.run(2000)
    t = sim.time
    v = -sim.state.v[0, 1]
    assert v == pytest.approx(g / rate * (1.0 - math.exp(-rate * t)), rel=1e-3)
    sim.run(40000)
    terminal = -sim.state.v[0, 1] * length / time * UNITS.time / UNITS.length
    assert terminal == pytest.approx(1.0 / UNITS.gamma(0.1), rel=1e-6)


def test_3d_branch_units() -> None:
    """The 3D branch (masses pi r^2, g assumed 0.05): our mass unit is 1.5 L^2 code masses,
    its spK = 100 is E_sp = 926 and mu = 10 would be mu/mu0 = 22.7."""
    from grainflow.scenarios.hopper_units import AUTHORS_3D_SPK, AUTHORS_3D_UNITS as U3

    assert U3.time == pytest.approx(math.sqrt(1.2 / 0.05))
    assert U3.mass == pytest.approx(1.5 * 1.2**2)
    # the sigma_avg sphere: code mass pi (0.6)^2 is our pi/6 mass units
    assert math.pi * 0.6**2 / U3.mass == pytest.approx(math.pi / 6.0)
    assert U3.pair_force_scale(AUTHORS_3D_SPK) == pytest.approx(925.9, abs=0.1)
    assert U3.mu(10.0) == pytest.approx(22.68, abs=0.01)


def test_a_3d_collision_of_mean_grains_is_the_same_in_both_unit_systems() -> None:
    """Two sigma_avg spheres (where the 3D branch's mass pi r^2 and our rho pi sigma^3/6
    agree exactly after conversion) collide and slide under gravity, drag and tangential
    friction in the 3D branch's units and in ours."""
    from grainflow.scenarios.hopper_units import AUTHORS_3D_SPK, AUTHORS_3D_UNITS as U3

    def pair(scale: float, mass: float, g: float, eps: float, mu: float, rate: float,
             dt: float) -> Simulation:
        box = Box(lo=np.full(3, -50.0) * scale, hi=np.full(3, 50.0) * scale,
                  periodic=(False, False, False))
        st = ParticleState(3, box)
        x = np.array([[0.0, 0.0, 0.0], [1.15, 0.3, 0.1]]) * scale
        st.add_particles(x, 0.6 * scale, mass=mass)
        st.v[:] = np.array([[0.02, 0.01, 0.0], [-0.02, 0.0, 0.005]])
        law = SoftLaw()
        law.set_pair(0, 0, epsilon=eps, epsilon_scales="diameter", mu_k=mu,
                     kinetic_on="tangential")
        sim = Simulation(st, dt, law)
        sim.add_force(Gravity([0.0, 0.0, -g]))
        sim.add_force(Drag(rate, per_mass=True))
        return sim

    a = pair(1.0, math.pi * 0.6**2, U3.g, AUTHORS_3D_SPK, 3.0, 0.05, 0.005)
    velocity_unit = U3.length / U3.time
    b = pair(1.0 / U3.length, math.pi / 6.0, 1.0, U3.pair_force_scale(AUTHORS_3D_SPK),
             U3.mu(3.0), U3.gamma(0.05), 0.005 / U3.time)
    b.state.v[:] = a.state.v / velocity_unit
    a.run(3000)
    b.run(3000)
    moved = np.linalg.norm(a.state.x - np.array([[0.0, 0.0, 0.0], [1.15, 0.3, 0.1]]), axis=1)
    assert np.all(moved > 0.1)
    np.testing.assert_allclose(b.state.x * U3.length, a.state.x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(b.state.v * velocity_unit, a.state.v, rtol=1e-8, atol=1e-12)
