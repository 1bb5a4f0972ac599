"""Engine defects found in review (issue 9), each pinned by a test that failed before its fix.

* kt = 0 with gamma_t > 0 kept no Coulomb cap (the dashpot force fell to ~0);
* relocated (reinserted) grains kept a stale Adams-Bashforth force history;
* the health check ignored wall overlaps;
* ``Drag`` silently used zeta[0] when given fewer values than particle types;
* the time-step check ignored tethers, walls, drag and kinetic friction (it now names the
  interaction that limits dt);
* a grain centred exactly on a wall got no force.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from grainflow.engine.forces import Drag, Gravity
from grainflow.engine.integrators import AdamsBashforth2
from grainflow.engine.simulation import InstabilityError, Simulation, TimeStepError
from grainflow.engine.tethers import Tethers
from grainflow.frame import PAIR, Box
from grainflow.models.granular import GranularLaw
from grainflow.models.soft import SoftLaw
from grainflow.state import ParticleState
from grainflow.walls import Cylinder, Plane, Segment, WallForce

pytestmark = pytest.mark.usefixtures("numba_one_thread")


def _box(dim: int = 3) -> Box:
    return Box(np.full(dim, -10.0), np.full(dim, 10.0), (False,) * dim)


# ------------------------------------------------------------------- kt = 0, gamma_t > 0
@pytest.mark.parametrize("dim", [2, 3])
def test_dashpot_only_tangential_force_is_capped_by_coulomb(dim: int) -> None:
    st = ParticleState(dim, _box(dim))
    # overlap 0.01 (F_n ~ kn 0.01 = 60), fast tangential sliding: the dashpot alone
    # (gamma_t m_eff v_t ~ 1e4) is far above mu F_n
    v = np.zeros((2, dim))
    v[0, 1], v[1, 1] = 5.0, -5.0
    st.add_particles(np.array([[0.0] * dim, [0.99] + [0.0] * (dim - 1)]), 0.5, density=1.0,
                     v=v)
    law = GranularLaw()
    law.set_all(kn=6e3, kt=0.0, gamma_n=0.0, gamma_t=4e3, mu=0.5)
    sim = Simulation(st, 1e-5, law)
    for _ in range(3):
        c = sim.contacts().of_kind(PAIR)
        n = c.branch[0] / np.linalg.norm(c.branch[0])
        fn = c.force[0] @ n
        ft = np.linalg.norm(c.force[0] - fn * n)
        assert fn > 50.0
        assert ft == pytest.approx(0.5 * fn, rel=1e-12)
        sim.run(5)


# ------------------------------------------------------------------ AB2 and relocation
def test_relocated_grain_restarts_its_adams_bashforth_history() -> None:
    st = ParticleState(3, _box())
    st.add_particles([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]], 0.5, density=1.0)
    sim = Simulation(st, 1e-3, GranularLaw(), integrator=AdamsBashforth2())
    sim.interactions[0].law.set_all(kn=1e3)
    sim.add_force(Gravity([0.0, 0.0, -9.81]))
    sim.add_force(Drag(0.5))  # a velocity-dependent force: F(t) changes from step to step
    sim.run(50)
    prev = st.arrays["ab2_force_prev"]
    assert np.isfinite(prev).all()
    sim.relocate(np.array([0]), np.array([[0.0, 0.0, 3.0]]), v=np.array([[0.0, 0.0, 1.0]]))
    assert np.isnan(prev[0]).all() and np.isfinite(prev[1]).all()
    assert st.x[0, 2] == 3.0 and st.v[0, 2] == 1.0
    sim.run(0)
    f0, v0 = st.force[0].copy(), st.v[0].copy()
    sim.run(1)
    # a fresh particle's first AB2 step is an Euler step of the velocity
    np.testing.assert_allclose(st.v[0], v0 + sim.dt * f0 / st.mass[0], rtol=1e-14)


def test_relocation_forgets_the_pair_and_wall_springs() -> None:
    st = ParticleState(3, _box())
    st.add_particles([[0.0, 0.0, 0.5], [0.95, 0.0, 0.5]], 0.5, density=1.0,
                     v=[[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    law = GranularLaw(2)
    law.set_all(kn=1e4, gamma_n=5.0, mu=0.5)
    sim = Simulation(st, 1e-4, law)
    wall = sim.add_force(WallForce([Plane((0, 0, 0.02), (0, 0, 1))], law, 1))
    sim.run(20)
    assert np.any(sim.interactions[0].history != 0.0)
    assert np.any(st.arrays[wall.name][0] != 0.0)
    sim.relocate(np.array([1]), np.array([[3.0, 3.0, 3.0]]))
    assert not np.any(sim.interactions[0].history != 0.0)
    assert not np.any(st.arrays[wall.name][1] != 0.0)
    assert np.any(st.arrays[wall.name][0] != 0.0)


def test_hopper_reinsertion_relocates_through_the_engine() -> None:
    """The seed-003 updater moves grains with relocate: their AB2 memory restarts."""
    from grainflow.scenarios.hopper_reinsertion import HopperReinsertion

    st = ParticleState(2, Box(np.array([-5.0, -20.0]), np.array([5.0, 20.0]), (False, False)))
    x = np.array([[0.0, 0.5], [0.0, 1.5], [1.0, 0.5], [-1.0, 0.5], [0.0, -5.0]])
    st.add_particles(x, 0.5, density=1.0)
    law = SoftLaw()
    law.set_all(epsilon=100.0)
    sim = Simulation(st, 1e-3, law, integrator=AdamsBashforth2(), seed=1)
    up = HopperReinsertion(2, 0.0, 0.0, 10.0, depth=2.0)
    up.setup_state(sim.context)
    sim.add_updater(up)
    sim.add_force(Gravity([0.0, -1.0]))
    sim.run(1)
    assert up.reinserted == 1
    moved = int(np.flatnonzero(st.id == 4)[0])
    assert st.x[moved, 1] > 0.0
    # relocated after this step's force: no previous force yet
    assert np.isnan(st.arrays["ab2_force_prev"][moved]).all()


# -------------------------------------------------------------- health check and walls
def test_health_check_sees_wall_overlaps() -> None:
    st = ParticleState(3, _box())
    st.add_particles([[0.0, 0.0, 0.2]], 0.5, density=1.0)  # 0.3 = 0.6 r into the floor
    law = GranularLaw(2)
    law.set_all(kn=1e3)
    sim = Simulation(st, 1e-4, law, max_overlap_fraction=0.5)
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))], law, 1))
    with pytest.raises(InstabilityError, match="with a wall") as info:
        sim.check_health()
    assert info.value.particle == 0 and "overlap 0.6" in str(info.value)


# ------------------------------------------------------------------------------- drag
def test_drag_refuses_fewer_values_than_types() -> None:
    st = ParticleState(2, _box(2))
    st.add_particles([[0.0, 0.0], [3.0, 0.0]], 0.5, density=1.0, type=np.array([0, 1]))
    sim = Simulation(st, 1e-3)
    with pytest.raises(ValueError, match=r"drag.zeta: 1 value\(s\) given but particle types go "
                                         r"up to 1"):
        sim.add_force(Drag([0.3]))
    drag = sim.add_force(Drag([0.3, 0.0]))  # one per type: fine
    st.v[:] = 1.0
    sim.compute_forces()
    np.testing.assert_array_equal(st.force[:, 0], [-0.3, 0.0])
    sim.remove_particles(np.array([True, False]))
    sim.add_particles([[0.0, 3.0]], 0.5, density=1.0, type=2)  # a type without a value
    with pytest.raises(ValueError, match="drag.zeta"):
        sim.compute_forces()
    assert drag.zeta.tolist() == [0.3, 0.0]
    scalar = Simulation(ParticleState(2, _box(2)), 1e-3)
    scalar.add_particles([[0.0, 0.0], [3.0, 0.0]], 0.5, density=1.0, type=np.array([0, 5]))
    scalar.add_force(Drag(0.3))  # one number: every particle
    scalar.state.v[:] = 1.0
    scalar.compute_forces()
    np.testing.assert_array_equal(scalar.state.force[:, 0], [-0.3, -0.3])


# ------------------------------------------------------------------ time-step sources
def _one_grain(dt: float) -> Simulation:
    st = ParticleState(3, _box())
    st.add_particles([[0.0, 0.0, 1.0], [3.0, 0.0, 1.0]], 0.5, mass=1.0)
    law = GranularLaw(2)
    law.set_pair(0, 0, kn=1e2)  # soft grains: t_c = pi sqrt(0.5/100) = 0.22
    law.set_pair(0, 1, kn=1e2)
    law.set_pair(1, 1, kn=1e2)
    return Simulation(st, dt, law)


def test_time_step_check_names_the_pairs() -> None:
    sim = _one_grain(0.2)
    with pytest.raises(TimeStepError, match=r"pair law hooke/viscous/history/constant, types "
                                            r"\(0, 0\) \(oscillation time 0.222"):
        sim.check_time_step()


@pytest.mark.parametrize("what, add, source", [
    ("walls", lambda sim: (sim.interactions[0].law.set_pair(0, 1, kn=1e6),
                           sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))],
                                                   sim.interactions[0].law, 1))),
     r"walls \(type 1\) on particle type 0 \(oscillation time 0.00314"),
    ("tethers", lambda sim: sim.add_force(Tethers(sim.state.id[:1], k=1e6)),
     r"tethers \(k = 1e\+06\) \(oscillation time 0.00314"),
    ("drag", lambda sim: sim.add_force(Drag(1e3)),
     r"drag on type 0 \(relaxation time 0.001"),
])
def test_time_step_check_sees_every_interaction(what, add, source) -> None:
    ok = _one_grain(1e-3)
    add(ok)
    sim = _one_grain(3e-3)  # fine for the grains (t_c / 74) ...
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.check_time_step()
    add(sim)  # ... not for this interaction
    with pytest.raises(TimeStepError, match=source):
        sim.check_time_step()
    assert sim.stable_time_step() < 3e-3


def test_time_step_check_sees_kinetic_friction() -> None:
    st = ParticleState(2, _box(2))
    st.add_particles([[0.0, 0.0], [3.0, 0.0]], 0.5, mass=1.0)
    law = SoftLaw()
    law.set_all(epsilon=1.0, mu_k=400.0)  # relaxation m_eff/mu_k = 1.25e-3
    sim = Simulation(st, 2e-3, law)
    with pytest.raises(TimeStepError, match=r"harmonic/kinetic/none/none, types \(0, 0\) "
                                            r"\(relaxation time 0.00125"):
        sim.check_time_step()
    sim.dt = 5e-4
    with pytest.warns(UserWarning, match="relaxation time 0.00125"):
        sim.check_time_step()
    assert sim.stable_time_step() == pytest.approx(1.25e-3 / 5)


def test_time_step_check_warns_but_never_refuses_an_unresolved_cohesive_shell() -> None:
    """The constant cohesion reports the time a pair leaving contact at its escape speed
    u_e = sqrt(2 F_c delta / m_eff) takes to cross the shell, for grain pairs and for a
    cohesive wall: a step past half of it warns (the step, not the law, then decides which
    pairs stay bound) and is never refused, since nothing goes unstable; the automatic step
    resolves it."""
    sim = _one_grain(2e-3)  # t_c 0.22: dt = t_c / 111 is fine for the contact
    law = sim.interactions[0].law
    law.set_pair(0, 0, kn=1e2, cohesion_force=2.0, cohesion_range=1e-3)
    crossing = 1e-3 / np.sqrt(2 * 2.0 * 1e-3 / 0.5)  # m_eff = 1/2: 0.0112
    assert law.crossing_time(0, 0, 0.5) == pytest.approx(crossing)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.check_time_step()  # dt < crossing / 2
    sim.dt = 8e-3
    with pytest.warns(UserWarning, match=r"types \(0, 0\) / 2\): the step, not the law, "
                                         r"decides which pairs stay bound"):
        sim.check_time_step()
    sim.dt = 0.05  # four crossing times; t_c / 4.4 is still within the refusal bound
    with pytest.warns(UserWarning, match="crossing time 0.01118"):
        sim.check_time_step()
    assert sim.stable_time_step(0.05) == pytest.approx(crossing / 2)  # t_c / 20 = 0.011
    law.set_pair(0, 1, kn=1e2, cohesion_force=2.0, cohesion_range=1e-4)
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))], law, 1))
    wall_crossing = 1e-4 / np.sqrt(2 * 2.0 * 1e-4 / 1.0)  # against the wall m_eff = m
    assert min(s.time for s in sim.time_scales() if s.kind == "crossing") == \
        pytest.approx(wall_crossing)
    assert sim.stable_time_step(0.05) == pytest.approx(wall_crossing / 2)


def test_time_step_warning_names_every_tight_scale_and_the_users_line() -> None:
    """A step too close to several time scales names each of them, the tightest first, and
    the warning points at the line that called ``run``, not at grainflow's own code."""
    sim = _one_grain(0.03)  # t_c / 15 = 0.0148 < dt: the contact is tight
    law = sim.interactions[0].law
    law.set_pair(0, 0, kn=1e2, cohesion_force=2.0, cohesion_range=1e-3)  # crossing / 2 = 0.0056
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim.run(1)
    tight = [w for w in caught if "is larger than" in str(w.message)]
    assert len(tight) == 1
    message = str(tight[0].message)
    assert "crossing time 0.01118" in message and "oscillation time 0.222" in message
    assert message.index("crossing time") < message.index("oscillation time")
    assert tight[0].filename == __file__


# ------------------------------------------------------------ centred exactly on a wall
@pytest.mark.parametrize("wall, x, normal", [
    (Plane((0, 0, 0), (0, 0, 1)), [1.0, 2.0, 0.0], [0, 0, 1]),
    (Cylinder((0, 0, 0), (0, 0, 1), 3.0, inside=True), [3.0, 0.0, 1.0], [-1, 0, 0]),
    (Cylinder((0, 0, 0), (0, 0, 1), 3.0, inside=False), [0.0, 3.0, 1.0], [0, 1, 0]),
])
def test_grain_centred_on_a_wall_is_pushed_out(wall, x, normal) -> None:
    st = ParticleState(3, _box())
    st.add_particles([x], 0.5, density=1.0)
    law = GranularLaw(2)
    law.set_all(kn=1e3)
    sim = Simulation(st, 1e-4, law)
    sim.add_force(WallForce([wall], law, 1))
    sim.compute_forces(update=False)
    # overlap r = 0.5: F = kn r along the wall's normal
    np.testing.assert_allclose(st.force[0], 1e3 * 0.5 * np.asarray(normal, float), rtol=1e-9,
                               atol=1e-9)


def test_disk_centred_on_a_segment_is_pushed_out() -> None:
    st = ParticleState(2, _box(2))
    st.add_particles([[0.5, 0.0]], 0.5, density=1.0)
    law = GranularLaw(2)
    law.set_all(kn=1e3)
    sim = Simulation(st, 1e-4, law)
    sim.add_force(WallForce([Segment((-2, 0), (2, 0))], law, 1))
    sim.compute_forces(update=False)
    assert np.linalg.norm(st.force[0]) == pytest.approx(500.0, rel=1e-9)
    assert st.force[0, 0] == pytest.approx(0.0, abs=1e-9)
