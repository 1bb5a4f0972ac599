"""Fast tests of the hopper scenarios (seed 003): geometry, FIRE initialisation, reinsertion,
crossing events, checkpoints and the flow-rate summary."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from grainflow.config.schema import load_config
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.scenarios import get_scenario
from grainflow.scenarios.hopper import (
    LIMIT_MU,
    LIMIT_ZETA,
    SIGMA_SMALL,
    HopperSection,
    build_hopper,
    dissipation,
    hopper_updater,
    prepare,
)
from grainflow.scenarios.hopper_reinsertion import OUT_FLAG, HopperReinsertion, write_events
from grainflow.studies.hopper_results import flow_summary, read_events
from grainflow.state import ParticleState
from grainflow.walls import Cylinder, PlateWithHole, Segment

# lambda -> 0: the friction limit drains a tiny hopper in a few t0 (the drag limit is slower)
TINY = dict(n=200, width=15.0, orifice_width=5.0, E_sp=1000.0, E_w=1000.0, dt_fraction=0.065,
            lam=0.0)


def _tiny(seed: int = 1) -> Simulation:
    sim = build_hopper(HopperSection(**TINY), 2, seed=seed)
    prepare(sim)
    return sim


def _pair_overlaps(st) -> np.ndarray:
    d = st.x[:, None, :] - st.x[None, :, :]
    dist = np.linalg.norm(d, axis=2) + np.eye(st.n) * 1e9
    return (st.radius[:, None] + st.radius[None, :]) - dist


def test_units_and_limits() -> None:
    assert SIGMA_SMALL * (1 + 1.4) / 2 == pytest.approx(1.0)
    assert dissipation(HopperSection(lam=0.0)) == (0.0, LIMIT_MU)
    assert dissipation(HopperSection(lam=math.inf)) == (LIMIT_ZETA, 0.0)
    zeta, mu = dissipation(HopperSection(lam=0.05))
    assert zeta / mu == pytest.approx(0.05)
    with pytest.raises(ValueError, match="zeta/mu"):
        HopperSection(zeta=1.0)


def test_geometry_builds_2d_and_3d() -> None:
    sim2 = build_hopper(HopperSection(n=100, width=12.0, orifice_width=4.0, theta_w=60.0), 2)
    walls = [w for f in sim2.forces if hasattr(f, "walls") for w in f.walls]
    assert len(walls) == 4 and all(isinstance(w, Segment) for w in walls)
    st = sim2.state
    assert st.n == 100 and np.all(np.abs(st.x[:, 0]) + st.radius <= 6.0 + 1e-12)
    assert set(np.unique(st.type)) == {0, 1}
    assert np.isclose(np.sort(np.unique(2 * st.radius)), [SIGMA_SMALL, 1.4 * SIGMA_SMALL]).all()
    # grains sit above the slanted bottom, i.e. above the bottom walls' upper end
    assert st.x[:, 1].min() > 0.5 * (12.0 - 4.0) / math.tan(math.radians(60.0))
    sim3 = build_hopper(HopperSection(n=200, width=8.0, orifice_width=3.0), 3)
    kinds = [type(w) for f in sim3.forces if hasattr(f, "walls") for w in f.walls]
    assert kinds == [Cylinder, PlateWithHole]
    rho = np.hypot(sim3.state.x[:, 0], sim3.state.x[:, 1])
    assert np.all(rho + sim3.state.radius <= 4.0 + 1e-12) and sim3.state.x[:, 2].min() > 0


def test_dt_from_stiffest_contact() -> None:
    sec = HopperSection(**{**TINY, "E_w": 1.0e4})
    sim = build_hopper(sec, 2)
    r_s = 0.5 * SIGMA_SMALL
    wall_tc = math.pi * math.sqrt(math.pi * r_s**2 * r_s**2 / 1.0e4)
    pair_tc = min(s.time for s in sim.interactions[0].time_scales(sim.context)
                  if s.kind == "oscillation")
    assert wall_tc < pair_tc
    assert sim.contact_time() == pytest.approx(wall_tc)
    assert sim.dt == pytest.approx(sec.dt_fraction * wall_tc)


def test_fire_initialisation_removes_overlaps() -> None:
    sim = build_hopper(HopperSection(**TINY), 2, seed=3)
    st = sim.state
    st.x[1] = st.x[0] + np.array([0.5 * (st.radius[0] + st.radius[1]), 0.0, 0.0])
    assert sim.max_overlap() > 0.1
    prepare(sim)
    assert sim.max_overlap() < 1e-6 * 1.0
    assert np.all(st.v == 0.0)


def test_scenarios_registered_and_config_builds(tmp_path) -> None:
    assert get_scenario("hopper2d").section == "hopper"
    assert get_scenario("hopper3d").section == "hopper"
    cfg = load_config({"scenario": "hopper2d", "dim": 2, "run": {"steps": 10},
                       "hopper": {**TINY}})
    from grainflow.config.build import build_simulation

    sim = build_simulation(cfg)
    assert sim.state.n == 200 and sim.dt == pytest.approx(
        build_hopper(HopperSection(**TINY), 2).dt)
    with pytest.raises(Exception, match="dim"):
        build_simulation(load_config({"scenario": "hopper3d", "dim": 2, "run": {"steps": 1},
                                      "hopper": {**TINY}}))


def test_tiny_discharge_records_events_and_keeps_n() -> None:
    sim = _tiny()
    sim.run(3000)
    up = hopper_updater(sim)
    assert up.n_events >= 10 and up.reinserted >= 5
    assert sim.state.n == 200
    # every reinserted grain is back above the orifice; no grain is far below it
    assert np.all(sim.state.x[:, 1] > -2 * 2 * sim.state.radius - 1.0)
    assert np.all(np.diff(up.event_times) >= 0)
    sizes = np.pi * (0.5 * SIGMA_SMALL * np.array([1.0, 1.4])) ** 2
    assert np.all(np.isclose(up.event_sizes[:, None], sizes[None, :]).any(axis=1))


def _toy_sim() -> tuple[Simulation, HopperReinsertion]:
    """Three grains in a 2D 'hopper' of width 10 with the orifice plane at y = 0."""
    st = ParticleState(2, Box(lo=np.array([-5.0, -10.0]), hi=np.array([5.0, 10.0]),
                              periodic=(False, False)))
    st.add_particles(np.array([[0.0, 1.0], [1.0, 1.0], [0.0, 5.0]]), 0.5, density=1.0)
    from grainflow.models.soft import SoftLaw

    law = SoftLaw(n_types=1)
    law.set_pair(0, 0, epsilon=100.0, mu_k=0.0)
    sim = Simulation(st, 1e-3, law, seed=0)
    up = HopperReinsertion(2, 0.0, 0.0, 10.0)
    up.setup_state(sim)
    sim.add_updater(up)
    return sim, up


def test_grain_counted_once_when_bouncing_back() -> None:
    sim, up = _toy_sim()
    st = sim.state
    i = int(np.flatnonzero(st.id == 2)[0])
    st.x[i, 1] = -0.1
    sim.time = 1.0
    up.update(sim)
    assert up.n_events == 1 and st.arrays[OUT_FLAG][i] == 1
    st.x[i, 1] = 0.3  # bounces back above the plane
    up.update(sim)
    st.x[i, 1] = -0.2  # and crosses again
    up.update(sim)
    assert up.n_events == 1 and list(up.event_ids) == [2]
    assert up.event_times[0] == 1.0 and up.event_sizes[0] == pytest.approx(np.pi * 0.25)
    st.x[i, 1] = -2.1  # two diameters (2 x 1.0) below: reinserted on the pile
    st.v[:] = [[0.0, -0.7, 0.0], [0.0, -0.3, 0.0], [0.0, -9.0, 0.0]]
    up.update(sim)
    assert up.reinserted == 1 and st.arrays[OUT_FLAG][i] == 0
    assert st.x[i, 1] > 1.0
    gaps = np.linalg.norm(st.x[i] - st.x, axis=1) - (st.radius[i] + st.radius)
    gaps[i] = np.inf
    assert gaps.min() == pytest.approx(0.0, abs=1e-9)  # touching its partner, no overlap
    partner = int(np.argmin(gaps))
    assert np.array_equal(st.v[i], st.v[partner])


@pytest.mark.parametrize("bulk_contacts", [0, 3])
def test_reinserted_grains_do_not_overlap(bulk_contacts: int) -> None:
    sim = build_hopper(HopperSection(**TINY, reinsert_bulk_contacts=bulk_contacts), 2, seed=2)
    prepare(sim)
    up = hopper_updater(sim)
    gaps: list[float] = []
    partner_contacts: list[int] = []
    place = up._reinsert

    def place_and_measure(sim_: Simulation, i: int, contacts: np.ndarray) -> None:
        place(sim_, i, contacts)
        st = sim_.state
        gap = np.linalg.norm(st.x - st.x[i], axis=1) - (st.radius + st.radius[i])
        gap[i] = np.inf
        gaps.append(float(gap.min()))
        partner_contacts.append(int(contacts[int(np.argmin(gap))]))

    up._reinsert = place_and_measure
    sim.run(3000)
    assert len(gaps) > 5
    # at the moment of reinsertion a grain touches its partner and overlaps nothing
    assert min(gaps) > -1e-9 and max(gaps) < 1e-9
    if bulk_contacts:  # bulk partners where one is free, the column's top grain otherwise
        assert max(partner_contacts) >= bulk_contacts


def test_reinsertion_updater_state_round_trip() -> None:
    sim = _tiny(seed=4)
    sim.run(2000)
    up = hopper_updater(sim)
    copy = HopperReinsertion(2, 0.0, 0.0, 15.0)
    copy.load_state_dict(up.state_dict())
    assert up.n_events > 0 and copy.reinserted == up.reinserted
    for name in ("event_times", "event_ids", "event_sizes"):
        assert np.array_equal(getattr(copy, name), getattr(up, name))


def test_simulation_checkpoint_round_trip() -> None:
    a = _tiny(seed=4)
    a.run(1500)
    saved = a.state_dict()
    b = build_hopper(HopperSection(**TINY), 2, seed=4)
    b.load_state_dict(saved)
    assert np.array_equal(hopper_updater(b).event_times, hopper_updater(a).event_times)
    a.run(800)
    b.run(800)
    ua, ub = hopper_updater(a), hopper_updater(b)
    assert ua.n_events > 0 and np.array_equal(ua.event_ids, ub.event_ids)
    assert np.array_equal(ua.event_times, ub.event_times)
    assert np.array_equal(a.state.x, b.state.x)


def test_flow_summary_on_synthetic_rundir(tmp_path) -> None:
    rng = np.random.default_rng(0)
    rate, t_end = 5.0, 400.0
    times = np.sort(rng.uniform(0.0, t_end, rng.poisson(rate * t_end)))
    sizes = np.where(rng.random(times.size) < 0.5, 0.5, 1.0)
    write_events(tmp_path / "events.csv", times, np.arange(times.size), sizes)
    (tmp_path / "config.toml").write_text('scenario = "hopper2d"\ndim = 2\n[hopper]\n'
                                          'orifice_width = 6.0\n')
    (tmp_path / "summary.json").write_text(json.dumps({"time": t_end, "wall_time_s": 12.0}))
    out = flow_summary(tmp_path)
    assert out["w"] == 6.0 and out["wall_time_s"] == 12.0
    assert out["number_rate"] == pytest.approx(rate, abs=4 * out["number_rate_err"])
    assert out["Q"] == pytest.approx(0.75 * rate, abs=4 * out["Q_err"])
    t, ids, s = read_events(tmp_path)
    assert np.allclose(t, times) and np.array_equal(ids, np.arange(times.size))


def test_flow_summary_is_named_where_it_lives() -> None:
    """The sweep example and the study name the analysis by import path; both resolve."""
    import importlib
    import tomllib
    from pathlib import Path

    from grainflow.studies.hopper_study import REDUCED, sweep_specs

    example = Path(__file__).resolve().parents[1] / "examples" / "hopper_sweep.toml"
    names = set(tomllib.loads(example.read_text())["analyses"])
    names |= {name for spec in sweep_specs(REDUCED).values() for name in spec.analyses}
    assert names == {"grainflow.studies.hopper_results:flow_summary"}
    module, _, attr = names.pop().partition(":")
    assert getattr(importlib.import_module(module), attr) is flow_summary
