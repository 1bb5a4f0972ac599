"""Tethered particle walls (SPEC M5, seed 002 Chapter 3): damped oscillation, bonds, bodies."""

from __future__ import annotations

import numpy as np
import pytest

from grainflow.engine.simulation import Simulation
from grainflow.engine.tethers import Tethers, neighbor_bonds
from grainflow.frame import Box
from grainflow.models.granular import GranularLaw
from grainflow.state import ParticleState

K, ETA = 100.0, 6.0


#: one grain or a few gain nothing from threads (see conftest.numba_one_thread)
pytestmark = pytest.mark.usefixtures("numba_one_thread")


def make_sim(x, *, body=-1, law: GranularLaw | None = None, dt: float = 1e-3) -> Simulation:
    x = np.atleast_2d(np.asarray(x, dtype=float))
    st = ParticleState(3, Box(np.full(3, -10.0), np.full(3, 10.0), (False,) * 3))
    st.add_particles(x, 0.5, mass=1.0, body=body)
    return Simulation(st, dt, law)


def peaks_and_crossings(t: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times of downward zero crossings (linear interpolation) and the local maxima of u."""
    k = np.nonzero((u[:-1] > 0) & (u[1:] <= 0))[0]
    crossings = t[k] - u[k] * (t[k + 1] - t[k]) / (u[k + 1] - u[k])
    top = np.nonzero((u[1:-1] > u[:-2]) & (u[1:-1] >= u[2:]))[0] + 1
    return crossings, u[top]


def oscillation(sim: Simulation, i: int, axis: int, steps: int) -> tuple[float, float]:
    """Angular frequency and decay rate of particle i released 0.1 from its start along
    ``axis``. (Velocity Verlet evaluates the dashpot with the half-step velocity, an O(dt)
    error in the decay rate: dt is kept small.)"""
    st = sim.state
    anchor = st.x[i, axis]
    t, u = [0.0], [0.0]

    def record(s: Simulation) -> None:
        t.append(s.time)
        u.append(s.state.x[i, axis] - anchor)

    st.x[i, axis] += 0.1
    sim.add_observer(record)
    sim.run(steps)
    crossings, peaks = peaks_and_crossings(np.array(t), np.array(u))
    omega = 2 * np.pi / np.mean(np.diff(crossings))
    decay = -np.polyfit(np.arange(peaks.size) * (2 * np.pi / omega), np.log(peaks), 1)[0]
    return omega, decay


def test_tethered_particle_oscillates_at_the_damped_frequency():
    sim = make_sim([0.0, 0.0, 0.0], dt=2.5e-4)
    sim.add_force(Tethers(sim.state.id, K, ETA))
    omega, decay = oscillation(sim, 0, 0, 16000)
    m = 1.0
    assert omega == pytest.approx(np.sqrt(K / m - (ETA / (2 * m)) ** 2), rel=1e-2)
    assert decay == pytest.approx(ETA / (2 * m), rel=1e-2)


def test_bonded_pair_antisymmetric_mode():
    """Two tethered, bonded particles displaced apart: each feels 3 k u and 3 eta u'."""
    sim = make_sim([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], body=0, dt=2.5e-4)
    st = sim.state
    sim.add_force(Tethers(st.id, K, ETA, bonds=neighbor_bonds(st, st.id, 1.5)))
    st.x[1, 0] -= 0.1
    omega, decay = oscillation(sim, 0, 0, 12000)
    np.testing.assert_allclose(st.x[0, 0] + st.x[1, 0], 1.0, atol=1e-9)
    assert omega == pytest.approx(np.sqrt(3 * K - (3 * ETA / 2) ** 2), rel=1e-2)
    assert decay == pytest.approx(3 * ETA / 2, rel=1e-2)


def test_wall_particles_of_one_body_do_not_collide_but_grains_do():
    law = GranularLaw(1)
    law.set_all(kn=1e4, gamma_n=5.0)
    sim = make_sim([[0.0, 0.0, 0.0], [0.9, 0.0, 0.0]], body=7, law=law, dt=1e-4)
    st = sim.state
    sim.add_force(Tethers(st.id, K, ETA))
    sim.add_particles([[0.45, 0.0, 1.2]], 0.5, mass=1.0, v=[[0.0, 0.0, -1.0]])
    sim.run(100)
    # the overlapping wall pair feels no contact force: only the grain pushes them down
    np.testing.assert_allclose(st.force[:2], 0.0, atol=1e-9)
    sim.run(4000)
    assert st.v[2, 2] > 0.0  # the grain bounced off the tethered wall
    assert np.all(np.abs(st.x[:2, 2]) < 0.1)


def test_tethers_follow_particles_through_reindexing():
    law = GranularLaw(1)
    law.set_all(kn=1e4)
    sim = make_sim([[5.0, 0.0, 0.0], [0.0, 0.0, 0.0], [-5.0, 0.0, 0.0]], law=law)
    st = sim.state
    wall_id = int(st.id[1])
    sim.add_force(Tethers([wall_id], K, 0.0))
    st.x[1, 1] += 0.1
    sim.remove_particles(np.array([True, False, False]))
    st.reindex(np.array([1, 0]))  # swap the two survivors
    sim.compute_forces(update=False)
    i = int(np.nonzero(st.id == wall_id)[0][0])
    np.testing.assert_allclose(st.force[i], [0.0, -K * 0.1, 0.0], atol=1e-12)
    np.testing.assert_allclose(st.force[1 - i], 0.0)


def test_state_round_trip_and_validation():
    sim = make_sim([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], body=1)
    st = sim.state
    tethers = sim.add_force(Tethers(st.id, K, ETA, bonds=[[0, 1]]))
    data = tethers.state_dict()
    other = Tethers(st.id, K, ETA, anchors=np.ones((2, 3)), bonds=[[0, 1]])
    other.load_state_dict(data)
    np.testing.assert_array_equal(other.anchor, tethers.anchor)
    np.testing.assert_array_equal(other.l0, [1.0])
    loose = make_sim([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="body"):
        loose.add_force(Tethers(loose.state.id, K, ETA))
    with pytest.raises(ValueError, match="ids"):
        sim.add_force(Tethers([5], K, ETA))


def test_time_scales_are_those_of_the_fastest_mode():
    """One tethered particle: k/m and eta/m. A bonded pair: the antisymmetric mode along the
    bond, 3k/m (the mode measured above). A triangular target of 91 wall particles: the
    largest eigenvalue of the linearised coupling (a dense eigensolve of the same matrix
    built independently), below Gershgorin's bound 1 + 2 z = 13."""
    from grainflow.insertion.lattice import lattice_points
    from grainflow.insertion.regions import BoxRegion

    sim = make_sim([[0.0, 0.0, 0.0]], body=0)
    sim.add_force(Tethers(sim.state.id, K, ETA))
    osc, rel = sim.forces[-1].time_scales(sim.context)
    assert osc.time == pytest.approx(np.pi / np.sqrt(K))
    assert rel.time == pytest.approx(1.0 / ETA)
    sim = make_sim([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], body=0)
    sim.add_force(Tethers(sim.state.id, K, ETA, bonds=neighbor_bonds(sim.state, sim.state.id,
                                                                     1.5)))
    osc, rel = sim.forces[-1].time_scales(sim.context)
    assert osc.time == pytest.approx(np.pi / np.sqrt(3 * K))
    assert rel.time == pytest.approx(1.0 / (3 * ETA))

    plane = lattice_points(BoxRegion((-5.0, -5.0), (5.0, 5.0)), 1.0, "triangular")
    plane = plane[np.hypot(*(plane - plane.mean(axis=0)).T) < 5.0]
    x = np.column_stack([plane, np.zeros(len(plane))])
    sim = make_sim(x, body=0)
    ids = sim.state.id
    bonds = neighbor_bonds(sim.state, ids, 1.05)
    sim.add_force(Tethers(ids, K, ETA, bonds=bonds))
    _, rel = sim.forces[-1].time_scales(sim.context)
    n = len(x)
    L = np.eye(3 * n)
    index = {int(i): k for k, i in enumerate(sim.state.id)}
    for a, b in bonds:
        i, j = index[int(a)], index[int(b)]
        d = sim.state.x[i] - sim.state.x[j]
        nn = np.outer(d, d) / d.dot(d)
        for p, q, s in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            L[3 * p:3 * p + 3, 3 * q:3 * q + 3] += s * nn
    lam = np.linalg.eigvalsh(L)[-1]
    assert n > 64  # the sparse (eigsh) path
    assert rel.time == pytest.approx(1.0 / (ETA * lam), rel=1e-5)
    assert 5.0 < lam < 13.0
