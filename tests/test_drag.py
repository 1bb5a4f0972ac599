"""Background-fluid drag (SPEC M3, :class:`~grainflow.engine.forces.Drag`) in its two forms.

* per grain, ``F = -zeta v`` (seed 003 eq. 5/11 as printed): the terminal speed under
  gravity is ``m g / zeta``, so heavier grains fall faster;
* per unit mass, ``F = -gamma m v`` (the seed 003 authors' code, ``-b M v``): every grain
  relaxes at the rate ``gamma``, ``v(t) = (g / gamma)(1 - exp(-gamma t))``, and falls at the
  same terminal speed ``g / gamma`` whatever its mass.

Velocity Verlet evaluates a velocity-dependent force at the half-step velocity, so it
integrates a linear drag at first order (tests/test_soft.py). For a grain starting at rest
under gravity its velocities are exactly ``v_n = v_T [1 - (1 - h/2)^2 (1 - h)^(n-1)]``,
``h = gamma dt``, whose difference from the analytic curve is
``v_T exp(-gamma t) gamma t h / 2 + O(h^2)``. The test below checks both: the closed form to
rounding, and the analytic curve plus that known first-order term to ``h^2 v_T``, a
tolerance that any other first-order error fails (it checks so itself).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import build_pile
from grainflow.config.build import build_generic, build_simulation
from grainflow.config.schema import ConfigError, load_config
from grainflow.engine.forces import Drag, Gravity, _add_drag, _add_mass_drag
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.state import ParticleState

pytestmark = pytest.mark.usefixtures("numba_one_thread")

MASSES = np.array([1.0, 8.0])


def _falling(drag: Drag, g: float, dt: float, masses=MASSES, types=0
             ) -> tuple[Simulation, list[float], list[np.ndarray]]:
    """Grains of ``masses`` at rest, far apart, under gravity ``-g z`` and ``drag`` (periodic
    in z: they fall for ever); the returned lists fill with (time, downward speed of each
    grain by id) every 10 steps."""
    st = ParticleState(3, Box(lo=np.full(3, -50.0), hi=np.full(3, 50.0),
                              periodic=(False, False, True)))
    x = np.zeros((len(masses), 3))
    x[:, 0] = 20.0 * np.arange(len(masses)) - 10.0
    st.add_particles(x, 0.5, mass=np.asarray(masses), type=types)
    # lone grains: no pair law; no health checks (the wrap in z changes the energy m g z)
    sim = Simulation(st, dt, check_every=0)
    sim.add_force(Gravity([0.0, 0.0, -g]))
    sim.add_force(drag)
    times: list[float] = []
    speeds: list[np.ndarray] = []
    sim.add_observer(lambda s: (times.append(s.time),
                                speeds.append(-s.state.v[np.argsort(s.state.id), 2].copy())),
                     every=10)
    return sim, times, speeds


def test_per_mass_drag_follows_the_analytic_fall_at_the_same_rate_for_any_mass() -> None:
    gamma, g = 2.0, 3.0
    v_t = g / gamma
    dt = 5e-3
    h = gamma * dt
    sim, times, speeds = _falling(Drag(gamma, per_mass=True), g, dt)
    sim.run(round(4.0 / gamma / dt))
    t = np.array(times)
    v = np.array(speeds)  # (samples, grains)
    n = np.rint(t / dt)
    # the velocity Verlet solution in closed form, to rounding, for both masses
    discrete = v_t * (1.0 - (1.0 - h / 2) ** 2 * (1.0 - h) ** (n - 1))
    np.testing.assert_allclose(v, np.repeat(discrete[:, None], 2, axis=1), rtol=1e-12,
                               atol=1e-13 * v_t)
    # the analytic curve, plus VV's known first-order term, to h^2
    analytic = v_t * (1.0 - np.exp(-gamma * t))
    first_order = v_t * np.exp(-gamma * t) * gamma * t * h / 2
    tol = h**2 * v_t
    for k in range(2):
        assert np.abs(v[:, k] - analytic - first_order).max() < tol
        # the tolerance rejects a first-order error: VV's own, left uncorrected, fails it
        assert np.abs(v[:, k] - analytic).max() > 5 * tol
    # terminal speed: VV's fixed point is exactly g / gamma; the same for both masses
    sim.run(round(40.0 / gamma / dt))
    v_end = -sim.state.v[np.argsort(sim.state.id)]
    assert v_end[:, 2] == pytest.approx([v_t, v_t], rel=1e-12)
    assert np.abs(v_end[:, :2]).max() == 0.0


def test_per_grain_drag_terminal_speed_grows_with_mass() -> None:
    zeta, g = 2.0, 3.0
    sim, _, _ = _falling(Drag(zeta), g, 5e-3)
    # the heavier grain relaxes in m / zeta = 4: 40 of those
    sim.run(round(40 * MASSES.max() / zeta / 5e-3))
    v_end = -sim.state.v[np.argsort(sim.state.id), 2]
    np.testing.assert_allclose(v_end, MASSES * g / zeta, rtol=1e-12)
    assert v_end[1] == pytest.approx(8.0 * v_end[0], rel=1e-12)


def test_per_mass_drag_per_type_and_its_time_scales() -> None:
    """One rate per type: terminal speeds g / gamma_type; the relaxation time is 1 / gamma,
    whatever the mass (per grain: m / zeta of the lightest grain)."""
    g = 3.0
    drag = Drag([2.0, 0.5], per_mass=True)
    assert drag.per_mass and drag.zeta is None and drag.gamma.tolist() == [2.0, 0.5]
    sim, _, _ = _falling(drag, g, 5e-3, masses=[1.0, 8.0], types=np.array([1, 0]))
    scales = {s.source: s for s in drag.time_scales(sim.context)}
    assert set(scales) == {"per-mass drag on type 0", "per-mass drag on type 1"}
    assert scales["per-mass drag on type 0"].time == 0.5  # 1 / gamma, not m / ...
    assert scales["per-mass drag on type 1"].time == 2.0
    assert all(s.kind == "relaxation" for s in scales.values())
    sim.run(round(40 / 0.5 / 5e-3))
    v_end = -sim.state.v[np.argsort(sim.state.id), 2]
    np.testing.assert_allclose(v_end, [g / 0.5, g / 2.0], rtol=1e-12)  # type 1, type 0

    per_grain, _, _ = _falling(Drag(2.0), g, 5e-3)
    (scale,) = Drag(2.0).time_scales(per_grain.context)
    assert scale.time == 0.5 and scale.source == "drag on type 0"  # m / zeta, lightest


def test_per_mass_drag_errors_name_gamma() -> None:
    with pytest.raises(ValueError, match=r"drag\.gamma \(config drag_rate\): -1\.0 is not valid; "
                                         r"expected a non-negative rate"):
        Drag(-1.0, per_mass=True)
    with pytest.raises(ValueError, match=r"drag\.zeta: -1\.0 is not valid"):
        Drag(-1.0)
    st = ParticleState(3, Box(lo=np.zeros(3), hi=np.full(3, 10.0), periodic=(False,) * 3))
    st.add_particles(np.array([[2.0, 2, 2], [6.0, 2, 2]]), 0.5, mass=1.0, type=np.array([0, 1]))
    sim = Simulation(st, 1e-3)
    with pytest.raises(ValueError, match=r"drag\.gamma \(config drag_rate\): 1 value\(s\) "
                                         r"given but particle types go up to 1; give one "
                                         r"gamma per type"):
        sim.add_force(Drag([0.3], per_mass=True))


def test_step_call_is_the_per_mass_kernel() -> None:
    sim = build_pile(50)
    per_mass = Drag(1.5, per_mass=True)
    per_grain = Drag(1.5)
    sim.add_force(per_mass)
    sim.add_force(per_grain)
    a = per_mass.step_call(sim.context)
    b = per_grain.step_call(sim.context)
    assert a.adapter is not b.adapter
    assert len(a.args) == 6 and a.args[2] is sim.state.mass
    assert len(b.args) == 5
    # the two kernels: -gamma m v against -zeta v
    st = sim.state
    f_mass, f_grain = np.zeros_like(st.force), np.zeros_like(st.force)
    _add_mass_drag(f_mass, st.v, st.mass, np.array([1.5, 1.5]), st.type, st.frozen)
    _add_drag(f_grain, st.v, np.array([1.5, 1.5]), st.type, st.frozen)
    mobile = ~st.frozen
    np.testing.assert_allclose(f_mass[mobile], -1.5 * st.mass[mobile, None] * st.v[mobile],
                               rtol=1e-15)
    np.testing.assert_allclose(f_grain[mobile], -1.5 * st.v[mobile], rtol=1e-15)
    assert not f_mass[~mobile].any() and not f_grain[~mobile].any()


def _pile_with_mass_drag(fast: bool) -> Simulation:
    sim = build_pile()
    sim.add_force(Drag([1.5, 3.0], per_mass=True))  # type 1 (the base) is frozen
    sim.fast_path_min_steps = 0 if fast else 10**12
    sim.run(2000)
    return sim


def test_compiled_steps_with_per_mass_drag_are_bitwise_python_steps() -> None:
    python = _pile_with_mass_drag(False)
    compiled = _pile_with_mass_drag(True)
    assert python._fast_path.steps_done == 0
    assert compiled._fast_path.steps_done > 1000
    assert compiled.rebuilds > 2
    assert python.step == compiled.step and python.time == compiled.time
    assert np.array_equal(python.state.id, compiled.state.id)
    for name in ("x", "v", "omega", "force", "torque"):
        assert np.array_equal(getattr(python.state, name), getattr(compiled.state, name)), name
    for a, b in zip(python.interactions, compiled.interactions):
        assert np.array_equal(a.history, b.history)
    # the drag did act: the pile is slower than without it
    plain = build_pile()
    plain.run(2000)
    assert compiled.state.kinetic_energy() < plain.state.kinetic_energy()


# ----------------------------------------------------------------------------- config
BASE = {
    "dim": 3,
    "run": {"steps": 10, "dt": 1e-3},
    "box": {"lo": [0, 0, 0], "hi": [10, 10, 10]},
    "particles": [{"fill": "list", "positions": [[1, 1, 1], [3, 1, 1]], "radius": 0.5}],
    "contact": {"law": "granular", "restitution": 0.8, "contact_time": 0.05, "mu": 0.5},
}


def _drags(sim: Simulation) -> list[Drag]:
    return [f for f in sim.forces if isinstance(f, Drag)]


def test_config_drag_rate_builds_a_per_mass_drag() -> None:
    (drag,) = _drags(build_simulation(load_config({**BASE, "drag_rate": "5 1/s"})))
    assert drag.per_mass and drag.gamma.tolist() == [5.0] and drag.zeta is None
    (drag,) = _drags(build_simulation(load_config({**BASE, "drag": "2 kg/s"})))
    assert not drag.per_mass and drag.zeta.tolist() == [2.0] and drag.gamma is None
    (drag,) = _drags(build_simulation(load_config({**BASE, "drag_rate": [1.0, 2.0]})))
    assert drag.per_mass and drag.gamma.tolist() == [1.0, 2.0]
    assert not _drags(build_simulation(load_config(BASE)))


@pytest.mark.parametrize(("extra", "message"), [
    ({"drag": 1.0, "drag_rate": 2.0}, r"^drag and drag_rate: both given; give one"),
    ({"drag_rate": -0.5}, r"^drag_rate\[0\]: -0\.5 is not valid"),
    ({"drag_rate": "2 kg/s"}, r"^drag_rate\[0\]: '2 kg/s' has dimension .*expected frequency"),
])
def test_config_drag_rate_refusals(extra, message) -> None:
    with pytest.raises(ConfigError) as err:
        load_config({**BASE, **extra})
    assert len(err.value.messages) == 1
    assert re.search(message, err.value.messages[0]), err.value.messages


def test_both_drags_set_after_loading_are_refused_by_the_build() -> None:
    config = load_config({**BASE, "drag_rate": 2.0}).model_copy(update={"drag": [1.0]})
    with pytest.raises(ConfigError, match="drag and drag_rate: both given"):
        build_generic(config)


def test_drag_rate_is_refused_where_drag_is_not_read() -> None:
    with pytest.raises(ConfigError, match="drag_rate: not used by scenario 'chute'"):
        load_config({"scenario": "chute", "run": {"steps": 10}, "drag_rate": 1.0})
