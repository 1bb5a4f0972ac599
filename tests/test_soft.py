"""M3 soft particles (seed 003 "SP"): drag, kinetic friction and harmonic repulsion.

* Drag ``F = -zeta v`` under gravity: ``v(t) = v_T (1 - exp(-zeta t / m))`` with terminal
  velocity ``v_T = m g / zeta``.
* Kinetic friction ``F_m = -mu (v_m - v_n)`` between touching particles: the relative
  velocity decays as ``exp(-mu (1/m_i + 1/m_j) t)`` (``exp(-2 mu t / m)`` for equal masses).
* Repulsion ``U = (eps/2)(1 - r/sigma)^2`` for ``r < sigma = r_i + r_j``: the force on i is
  ``-dU/dx_i`` (checked by finite differences of U).

Velocity Verlet evaluates velocity-dependent forces at the half-step velocity, so a linear
damping rate c is integrated with relative error ~ c dt / 2; the steps below keep that
below 1e-3 over the measured interval.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainflow.engine.forces import Drag, Gravity
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.models.soft import SoftLaw
from grainflow.state import ParticleState

pytestmark = pytest.mark.usefixtures("numba_one_thread")


def _box(dim: int, periodic: bool = False) -> Box:
    return Box(lo=np.full(dim, -20.0), hi=np.full(dim, 20.0), periodic=(periodic,) * dim)


@pytest.mark.parametrize("dim", [2, 3])
def test_terminal_velocity_under_drag(dim):
    m, zeta, g = 2.0, 4.0, 3.0
    tau = m / zeta
    st = ParticleState(dim, _box(dim))
    st.add_particles(np.zeros((1, dim)), 0.5, mass=m)
    dt = 5e-4 * tau
    sim = Simulation(st, dt)  # a lone particle: no pair law needed
    gvec = np.zeros(dim)
    gvec[-1] = -g
    sim.add_force(Gravity(gvec))
    sim.add_force(Drag(zeta))
    v_t = m * g / zeta
    times, vs = [], []
    sim.add_observer(lambda s: (times.append(s.time), vs.append(-s.state.v[0, dim - 1])),
                     every=50)
    sim.run(int(6 * tau / dt))
    t = np.array(times)
    v = np.array(vs)
    # analytic exponential approach: the deficit v_T - v decays as exp(-t/tau)
    deficit = (v_t - v) / v_t
    np.testing.assert_allclose(deficit, np.exp(-t / tau), rtol=5e-3)
    np.testing.assert_allclose(v, v_t * (1 - np.exp(-t / tau)), rtol=5e-3)
    # terminal velocity reached (a further 10 tau; VV's fixed point is exactly v_T for any
    # step, so a coarser step is fine here)
    sim.dt = 0.05 * tau
    sim.run(200)
    assert -st.v[0, dim - 1] == pytest.approx(v_t, rel=5e-3)
    assert np.abs(st.v[0, : dim - 1]).max() == 0.0


@pytest.mark.parametrize("masses", [(1.0, 1.0), (1.0, 3.0)])
@pytest.mark.parametrize("dim", [2, 3])
def test_kinetic_friction_relaxes_relative_velocity(dim, masses):
    """Two slightly overlapping particles sliding past each other perpendicular to their
    branch vector: the relative velocity decays at rate mu (1/m_i + 1/m_j)."""
    m0, m1 = masses
    mu = 5.0
    rate = mu * (1.0 / m0 + 1.0 / m1)
    st = ParticleState(dim, _box(dim))
    x = np.zeros((2, dim))
    x[1, 0] = 0.95  # sigma = 1: overlap 0.05
    u = 0.02  # relative speed along y
    v = np.zeros((2, dim))
    v[0, 1] = u * m1 / (m0 + m1)
    v[1, 1] = -u * m0 / (m0 + m1)
    st.add_particles(x, 0.5, mass=np.array([m0, m1]), v=v)
    law = SoftLaw()
    law.set_all(epsilon=1e-6, mu_k=mu)  # repulsion negligible next to the friction
    dt = 1e-3 / rate
    sim = Simulation(st, dt, law)
    p0 = st.momentum().copy()
    samples = []

    def watch(s):
        i, j = np.argsort(s.state.id)
        samples.append((s.time, s.state.v[i, 1] - s.state.v[j, 1]))

    sim.add_observer(watch, every=10)
    sim.run(int(3.0 / rate / dt))
    t = np.array([a for a, _ in samples])
    dv = np.array([b for _, b in samples])
    np.testing.assert_allclose(dv / u, np.exp(-rate * t), rtol=1e-2)
    # the particles stayed in contact: the decay was due to the pair term throughout
    assert sim.neighbors.n_pairs == 1
    assert np.linalg.norm(st.x[0] - st.x[1]) < 1.0
    np.testing.assert_allclose(st.momentum(), p0, atol=1e-15)


def test_kinetic_friction_absent_without_contact():
    st = ParticleState(3, _box(3))
    st.add_particles(np.array([[0.0, 0, 0], [1.001, 0, 0]]), 0.5, mass=1.0,
                     v=np.array([[0.0, 0.1, 0], [0.0, -0.1, 0]]))
    law = SoftLaw()
    law.set_all(epsilon=1.0, mu_k=5.0)
    sim = Simulation(st, 1e-3, law)
    sim.compute_forces(update=False)
    assert sim.neighbors.n_pairs == 1
    assert np.all(st.force == 0.0)


def _soft_energy(xi, xj, sigma, eps):
    r = np.linalg.norm(xi - xj)
    return 0.5 * eps * (1.0 - r / sigma) ** 2 if r < sigma else 0.0


@pytest.mark.parametrize("dim", [2, 3])
def test_repulsion_is_minus_gradient_of_harmonic_energy(dim):
    rng = np.random.default_rng(3)
    eps = 7.0
    radii = np.array([0.5, 0.7])
    sigma = radii.sum()
    law = SoftLaw()
    law.set_all(epsilon=eps)
    for r in (0.3, 0.8, 1.1, 1.19):
        direction = rng.standard_normal(dim)
        direction /= np.linalg.norm(direction)
        x = np.stack([np.zeros(dim), r * direction]) + rng.uniform(-1, 1, dim)
        st = ParticleState(dim, _box(dim))
        st.add_particles(x, radii, mass=1.0)
        sim = Simulation(st, 1e-3, law)
        sim.compute_forces(update=False)
        f = st.force[np.argsort(st.id), :dim].copy()  # the first build may re-sort
        h = 1e-6
        for p in range(2):
            fd = np.zeros(dim)
            for a in range(dim):
                xp = x.copy()
                xm = x.copy()
                xp[p, a] += h
                xm[p, a] -= h
                fd[a] = -(_soft_energy(xp[0], xp[1], sigma, eps)
                          - _soft_energy(xm[0], xm[1], sigma, eps)) / (2 * h)
            np.testing.assert_allclose(f[p], fd, rtol=1e-6, atol=1e-9 * eps / sigma)
        # magnitude from the docstring and Newton's third law
        assert np.linalg.norm(f[0]) == pytest.approx(eps / sigma * (1 - r / sigma), rel=1e-12)
        np.testing.assert_array_equal(f[0], -f[1])
        assert np.dot(f[0], x[0] - x[1]) > 0  # repulsive
        np.testing.assert_array_equal(st.torque, 0.0)
    # out of range: no force
    st = ParticleState(dim, _box(dim))
    st.add_particles(np.array([[0.0] * dim, [sigma * 1.0001] + [0.0] * (dim - 1)]), radii,
                     mass=1.0)
    sim = Simulation(st, 1e-3, law)
    sim.compute_forces(update=False)
    assert np.all(st.force == 0.0)


def test_soft_contact_time_formula():
    """The time-step check uses the half period of the harmonic contact,
    pi sqrt(meff sigma^2 / eps): a head-on elastic soft collision lasts exactly that."""
    law = SoftLaw()
    law.set_all(epsilon=50.0)
    st = ParticleState(3, _box(3))
    st.add_particles(np.array([[-0.51, 0, 0], [0.51, 0, 0]]), 0.5, mass=1.0,
                     v=np.array([[0.05, 0, 0], [-0.05, 0, 0]]))
    tc = law.contact_time(0, 0, 0.5, 1.0)
    assert tc == pytest.approx(np.pi * np.sqrt(0.5 / 50.0), rel=1e-14)
    sim = Simulation(st, tc / 1000, law)
    assert sim.contact_time() == pytest.approx(tc, rel=1e-14)
    gaps = []
    sim.add_observer(lambda s: gaps.append(
        (s.time, np.linalg.norm(s.state.x[0] - s.state.x[1]) - 1.0)))
    sim.run(3000)
    g = np.array(gaps)
    inside = g[g[:, 1] < 0, 0]
    assert inside.max() - inside.min() == pytest.approx(tc, rel=5e-3)
    # elastic: speeds restored
    np.testing.assert_allclose(np.sort(st.v[:, 0]), [-0.05, 0.05], rtol=1e-3)
