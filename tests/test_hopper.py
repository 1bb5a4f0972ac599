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
from grainflow.scenarios.hopper_units import AUTHORS_CODE
from grainflow.scenarios.hopper import (
    LIMIT_MU,
    LIMIT_ZETA,
    SIGMA_SMALL,
    HopperSection,
    build_hopper,
    MEAN_GRAIN_MASS,
    Dissipation,
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
    assert dissipation(HopperSection(lam=0.0)) == Dissipation(LIMIT_MU, 0.0, False)
    assert dissipation(HopperSection(lam=math.inf)) == Dissipation(0.0, LIMIT_ZETA, False)
    mid = dissipation(HopperSection(lam=0.05))
    assert mid.drag / mid.mu == pytest.approx(0.05)
    with pytest.raises(ValueError, match="zeta/mu"):
        HopperSection(zeta=1.0)


@pytest.mark.parametrize("dim", [2, 3])
def test_authors_lambda_path(dim: int) -> None:
    """The authors' sweep: mu at its limit while the drag rises to its limit (lambda up to
    lambda* = zeta_l/mu_l, 0.181 in 2D), then the drag at its limit while mu falls; lambda is
    zeta/mu with zeta = gamma M of a sigma_avg grain; both limits as converted."""
    mass = MEAN_GRAIN_MASS[dim]
    mu_l = AUTHORS_CODE.units.mu(10.0)
    gamma_l = AUTHORS_CODE.units.gamma(0.1)
    authors = {"convention": "authors"}
    assert dissipation(HopperSection(lam=0.0, **authors), dim) == Dissipation(mu_l, 0.0, True)
    assert dissipation(HopperSection(lam=math.inf, **authors), dim) == Dissipation(
        0.0, gamma_l, True)
    lam_star = gamma_l * mass / mu_l
    if dim == 2:
        assert lam_star == pytest.approx(0.181, abs=1e-3)
    for lam in (1e-4, 0.5 * lam_star, lam_star, 2 * lam_star, 50.0):
        d = dissipation(HopperSection(lam=lam, **authors), dim)
        assert d.drag * mass / d.mu == pytest.approx(lam)
        if lam <= lam_star:
            assert d.mu == mu_l
        else:
            assert d.drag == gamma_l
    # the grainflow path interpolates both
    d = dissipation(HopperSection(lam=lam_star, convention="authors",
                                  lambda_path="interpolate"), dim)
    assert d.mu == pytest.approx(0.5 * mu_l) and d.drag == pytest.approx(0.5 * gamma_l)


def test_sp_options_reach_the_law_and_the_drag() -> None:
    from grainflow.engine.forces import Drag
    from grainflow.scenarios.hopper import HopperLid
    from grainflow.walls import WallForce

    sim = build_hopper(HopperSection(n=60, width=12.0, orifice_width=4.0, convention="authors",
                                     lam=1.0), 2)
    law = sim.interactions[0].law
    row = law.row(0, 1)
    assert row["epsilon_scales"] == 1.0 and row["kinetic_on"] == 0.0
    assert row["epsilon"] == pytest.approx(AUTHORS_CODE.units.pair_force_scale(10.0))
    wall = law.row(0, 2)
    assert wall["epsilon"] == pytest.approx(2 * AUTHORS_CODE.units.wall_energy(100.0))
    assert wall["mu_k"] == 0.0
    drag = next(f for f in sim.forces if isinstance(f, Drag))
    assert drag.gamma is not None and drag.zeta is None
    lids = [u.owner for u in sim.updaters if isinstance(u.owner, HopperLid)]
    assert len(lids) == 1 and lids[0].open_time == pytest.approx(AUTHORS_CODE.lid_time)
    n_walls = sum(isinstance(f, WallForce) for f in sim.forces)
    prepare(sim)
    sim.run(int(AUTHORS_CODE.lid_time / sim.dt) + 200)
    assert lids[0].opened
    assert sum(isinstance(f, WallForce) for f in sim.forces) == n_walls - 1
    up = hopper_updater(sim)
    assert up.placement == "lanes" and up.count_at == "reinsertion" and up.depth == 2.5


def test_lid_holds_the_grains_until_it_opens() -> None:
    """No grain crosses the orifice plane while the lid is on; they do once it opens."""
    section = HopperSection(n=80, width=10.0, orifice_width=5.0, lid_time=3.0, E_w=1e3, lam=0.0)
    sim = build_hopper(section, 2)
    prepare(sim)
    sim.run(int(2.9 / sim.dt))
    assert sim.state.x[:, 1].min() > -0.5
    sim.run(int(3.0 / sim.dt))
    assert sim.state.x[:, 1].min() < -0.5


def test_option_errors_name_the_field() -> None:
    with pytest.raises(ValueError, match="drag_factor"):
        HopperSection(convention="authors", drag_factor=16.0)
    with pytest.raises(ValueError, match="reinsert_bulk_contacts"):
        HopperSection(reinsertion="lanes", reinsert_bulk_contacts=3)
    for field, bad in (("convention", "paper"), ("friction_on", "normal"), ("drag_on", "volume"),
                       ("stiffness", "mass"), ("lambda_path", "linear"),
                       ("reinsertion", "top"), ("count_at", "exit"), ("lid_time", -1.0),
                       ("mu_limit", 0.0), ("drag_limit", -1.0)):
        with pytest.raises(ValueError, match=field):
            HopperSection(**{field: bad})


def test_geometry_builds_2d_and_3d() -> None:
    sim2 = build_hopper(HopperSection(n=100, width=12.0, orifice_width=4.0, theta_w=60.0), 2)
    walls = [w for f in sim2.forces if hasattr(f, "walls") for w in f.walls]
    assert len(walls) == 4 and all(isinstance(w, Segment) for w in walls)
    st = sim2.state
    assert st.n == 100 and np.all(np.abs(st.x[:, 0]) + st.radius <= 6.0 + 1e-12)
    assert set(np.unique(st.type)) == {0, 1}
    assert np.isclose(np.sort(np.unique(2 * st.radius)), [SIGMA_SMALL, 1.4 * SIGMA_SMALL]).all()
    # grains sit inside the funnel, clear of the slanted walls (60 degrees from vertical)
    t = math.radians(60.0)
    gap = (2.0 + st.x[:, 1] * math.tan(t) - np.abs(st.x[:, 0])) * math.cos(t)
    assert np.all(gap >= st.radius - 1e-9) and st.x[:, 1].min() > 0
    sim3 = build_hopper(HopperSection(n=200, width=8.0, orifice_width=3.0), 3)
    kinds = [type(w) for f in sim3.forces if hasattr(f, "walls") for w in f.walls]
    assert kinds == [Cylinder, PlateWithHole]
    rho = np.hypot(sim3.state.x[:, 0], sim3.state.x[:, 1])
    assert np.all(rho + sim3.state.radius <= 4.0 + 1e-12) and sim3.state.x[:, 2].min() > 0


def test_default_skin_of_2d_3d_and_given() -> None:
    """A 2D hopper of soft disks lists pairs within SKIN_2D mean radii (its rebuilds, not its
    pairs, cost the time); 3D keeps the engine's 0.2; a given skin is used as given."""
    from grainflow.scenarios.hopper import SKIN_2D

    sim2 = build_hopper(HopperSection(n=100, width=12.0, orifice_width=4.0), 2)
    assert sim2.neighbors.skin == pytest.approx(SKIN_2D * sim2.state.radius.mean())
    sim3 = build_hopper(HopperSection(n=200, width=8.0, orifice_width=3.0), 3)
    assert sim3.neighbors.skin == pytest.approx(0.2 * sim3.state.radius.mean())
    given = build_hopper(HopperSection(n=100, width=12.0, orifice_width=4.0), 2, skin=0.05)
    assert given.neighbors.skin == 0.05


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


def test_docs_hopper_table_lists_every_field() -> None:
    """docs/hopper_study.md's `[hopper]` table has one row per field, with its default."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "hopper_study.md").read_text()
    table = text.split("## The `[hopper]` table", 1)[1].split("\n## ", 1)[0]
    rows = {line.split("|")[1].strip().strip("`"): line.split("|")[2].strip()
            for line in table.splitlines() if line.startswith("| `")}
    assert set(rows) == set(HopperSection.model_fields)
    for name, field in HopperSection.model_fields.items():
        assert rows[name] == repr(field.default), name


def test_lid_opened_before_a_checkpoint_stays_open_on_resume() -> None:
    """A run restored from a state written after the lid opened has no lid: it continues
    bitwise like the uninterrupted run."""
    section = HopperSection(n=80, width=10.0, orifice_width=5.0, lid_time=0.5, E_w=1e3, lam=0.0)
    a = build_hopper(section, 2)
    prepare(a)
    a.run(int(1.0 / a.dt))
    saved = a.state_dict()
    b = build_hopper(section, 2)
    b.load_state_dict(saved)
    assert len(b.forces) == len(a.forces)
    a.run(300)
    b.run(300)
    assert np.array_equal(a.state.x, b.state.x)


@pytest.mark.parametrize("theta", [60.0, 30.0, 20.0])
def test_inclined_hopper_is_filled_inside_its_funnel(theta: float) -> None:
    """With sloped walls the initial fill lies inside the funnel (no grain crosses a wall,
    none starts far above the pile), and the funnel region's area is its integral."""
    from grainflow.scenarios.hopper import FunnelRegion

    w, W = 3.0, 20.0
    sim = build_hopper(HopperSection(n=300, width=W, orifice_width=w, theta_w=theta), 2)
    x, r = sim.state.x, sim.state.radius
    t = math.radians(theta)
    slope_gap = (0.5 * w + x[:, 1] * math.tan(t) - np.abs(x[:, 0])) * math.cos(t)
    assert np.all(slope_gap >= r - 1e-9) and np.all(np.abs(x[:, 0]) <= 0.5 * W - r + 1e-9)
    assert x[:, 1].min() < 2.0  # the fill starts at the orifice, not above the funnel
    region = FunnelRegion(W, w, theta, 0.0, 30.0)
    rng = np.random.default_rng(1)
    pts = rng.uniform([-0.5 * W, 0.0], [0.5 * W, 30.0], (200_000, 2))
    assert region.volume() == pytest.approx(region.contains(pts).mean() * W * 30.0, rel=0.01)


def test_authors_study_plan_builds_valid_sweeps() -> None:
    """The second pass's sweeps: every point runs the authors' convention, the hard limit has
    walls as stiff as its grains, the inclined hoppers the authors' mu, the probes change
    one thing each; the report's fits are free, bounded and (at the limits) fixed."""
    from grainflow.studies.hopper_authors import (AUTHORS_FULL, AUTHORS_REDUCED, MU_INCLINED,
                                                  PROBES, REPLICAS, Series, hard_name,
                                                  sweep_specs, three_fits)

    for plan in (AUTHORS_REDUCED, AUTHORS_FULL):
        specs = sweep_specs(plan)
        assert set(specs) == {"q2d", "q3d", "theta2d", REPLICAS, *plan.probes,
                              *(hard_name(E) for E in plan.hard_E_sp)}
        for name, spec in specs.items():
            for point in spec.points():
                config = point.config(spec.base)
                hopper = config["hopper"]
                assert hopper["convention"] == "authors"
                if name.startswith("hard2d"):
                    assert hopper["E_w"] == hopper["E_sp"]
                if name == "theta2d":
                    assert hopper["mu_limit"] == pytest.approx(MU_INCLINED)
                if name in PROBES:
                    assert hopper["lam"] == 0.0
                if name == REPLICAS:  # the q2d lambda sweep (or its limits), other seeds
                    assert hopper["lam"] in (plan.replicate_lambdas or plan.lambdas_2d)
                    assert hopper["orifice_width"] in (plan.replicate_widths or plan.widths_2d)
                    assert config["run"]["seed"] in plan.replicate_seeds
                    assert config["run"]["seed"] != 0
        if plan.replicate_seeds:
            lams = {p.config(specs[REPLICAS].base)["hopper"]["lam"]
                    for p in specs[REPLICAS].points()}
            assert lams == set(plan.replicate_lambdas or plan.lambdas_2d)
    assert set(AUTHORS_REDUCED.replicate_lambdas) == {0.0, math.inf}
    assert AUTHORS_FULL.replicate_lambdas is None  # the whole sweep, each realization's lambda_c
    widths = [3.0, 4.6, 6.2, 7.8, 9.4]
    q = [0.5 * (w - 1.0) ** 1.8 for w in widths]
    series = Series(w=widths, Q=q, Q_err=[0.01 * x for x in q])
    fits = three_fits(series, 2, 0.0)
    assert fits["free"].beta == pytest.approx(1.8, abs=1e-3)
    assert fits["bounded"].beta == pytest.approx(1.58) and "beta" in fits["bounded"].at_bound
    assert fits["fixed"].beta == 1.5 and fits["fixed"].beta_fixed
    assert "fixed" not in three_fits(series, 2, 0.05)


class _PlacementContext:
    """What :meth:`HopperReinsertion._place` reads: a state, a generator and ``relocate``
    (recorded, not applied)."""

    def __init__(self, state: ParticleState, seed: int) -> None:
        self.state = state
        self.rng = np.random.default_rng(seed)
        self.moved = None

    def relocate(self, i, x, v=None, omega=None) -> None:
        self.moved = (int(i), np.array(x, dtype=float), np.array(v, dtype=float))


def _place_one_attempt_at_a_time(u: HopperReinsertion, ctx: _PlacementContext, i: int,
                                 span: float, pool: np.ndarray, check_overlaps: bool) -> bool:
    """The placement rule of the module docstring, drawing and testing one lateral position
    at a time (what ``_place`` did before it evaluated attempts in batches)."""
    st = ctx.state
    ax = u.axis
    lat = [a for a in range(u.dim) if a != ax]
    r = float(st.radius[i])
    idx = np.flatnonzero(pool)
    for _ in range(u.max_attempts if idx.size else 0):
        if u.dim == 2:
            p = u.centre + ctx.rng.uniform(-span, span, 1)
        else:
            rho = span * np.sqrt(ctx.rng.random())
            phi = 2.0 * np.pi * ctx.rng.random()
            p = u.centre + rho * np.array([np.cos(phi), np.sin(phi)])
        reach = r + st.radius[idx]
        l2 = np.sum((st.x[np.ix_(idx, lat)] - p) ** 2, axis=1)
        column = np.flatnonzero(l2 < reach**2)
        if column.size == 0:
            continue
        heights = st.x[idx[column], ax] + np.sqrt(reach[column] ** 2 - l2[column])
        k = int(np.argmax(heights))
        j = idx[column[k]]
        target = np.zeros(st.x.shape[1])
        target[lat] = p
        target[ax] = heights[k]
        if check_overlaps:
            others = np.flatnonzero((np.arange(st.n) != i) & (np.arange(st.n) != j))
            gap = np.linalg.norm(st.x[others] - target, axis=1) - (r + st.radius[others])
            if np.any(gap < 0.0):
                continue
        ctx.relocate(i, target, v=st.v[j])
        return True
    return False


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("check_overlaps", [False, True])
def test_batched_placement_is_the_one_at_a_time_rule(dim: int, check_overlaps: bool) -> None:
    """Placement attempts are evaluated in batches; the grain goes where trying one position
    at a time puts it, and the generator ends where single draws leave it, so runs do not
    change by a bit. The pool is a sparse random pile, so that many attempts fail (empty
    columns, and with the overlap test, grains above the partner)."""
    rng = np.random.default_rng(7 + dim)
    n = 120
    width = 12.0
    hi = [width, width, 20.0] if dim == 3 else [width, 20.0]
    st = ParticleState(dim, Box(np.zeros(dim), np.array(hi), (False,) * dim))
    x = rng.uniform(0.6, width - 0.6, (n, 3))
    x[:, dim - 1] = rng.uniform(1.0, 15.0, n)
    if dim == 2:
        x[:, 2] = 0.0
    st.add_particles(x[:, :dim], rng.uniform(0.4, 0.6, n), density=1.0)
    st.v[:] = rng.normal(size=(n, 3)) * (1.0 if dim == 3 else np.array([1.0, 1.0, 0.0]))
    centre = np.full(dim - 1, 0.5 * width)
    for trial in range(6):
        u = HopperReinsertion(dim, 0.5, centre, width, max_attempts=300)
        i = int(rng.integers(n))
        pool = st.x[:, dim - 1] > 0.5
        pool[i] = False
        pool &= rng.random(n) < 0.5  # a "bulk" subset: many columns without a partner
        span = 0.5 * width - float(st.radius[i])
        batched, single = _PlacementContext(st, 100 + trial), _PlacementContext(st, 100 + trial)
        found = u._place(batched, i, span, pool, check_overlaps=check_overlaps)
        expected = _place_one_attempt_at_a_time(u, single, i, span, pool, check_overlaps)
        assert found == expected
        if found:
            assert batched.moved[0] == single.moved[0]
            assert np.array_equal(batched.moved[1], single.moved[1])
            assert np.array_equal(batched.moved[2], single.moved[2])
        assert batched.rng.bit_generator.state == single.rng.bit_generator.state
        assert batched.rng.random() == single.rng.random()


def test_the_crossing_kernel_follows_the_rule_on_random_flags_and_heights() -> None:
    """``crossings`` gives the grains the module docstring's rule names: crossed = not
    flagged and below the plane; due = flagged (or just crossed) and below the reinsertion
    depth; on random flags and heights, grains exactly on both thresholds included."""
    from grainflow.kernels.placement import crossings

    rng = np.random.default_rng(3)
    orifice, depth = 2.0, 2.5
    for trial in range(300):
        n = int(rng.integers(1, 12))
        radius = rng.choice([0.4, 0.5, 0.7], n)
        flag = rng.choice([0, 1], n).astype(np.int8)
        x = np.zeros((n, 3))
        x[:, 1] = rng.uniform(-3.0, 6.0, n)
        on_edge = rng.random(n) < 0.3  # exactly on the plane or the reinsertion depth
        x[on_edge, 1] = np.where(rng.random(on_edge.sum()) < 0.5, orifice,
                                 orifice - depth * 2.0 * radius[on_edge])
        h = x[:, 1]
        crossed = np.flatnonzero((flag == 0) & (h < orifice))
        after = flag.copy()
        after[crossed] = 1
        due = np.flatnonzero((after == 1) & (h < orifice - depth * 2.0 * radius))
        got_crossed, got_due = crossings(flag, x, 1, orifice, depth * 2.0, radius)
        assert np.array_equal(got_crossed, crossed) and np.array_equal(got_due, due)


def test_replicate_table_gives_each_seed_and_the_spread() -> None:
    """The report's replicate table: q2d's fit as seed 0, each other seed's free fit, and
    the mean and sample standard deviation of beta."""
    from grainflow.studies.hopper_authors import (Series, _replicate_table, realization_fits,
                                                  three_fits)

    widths = [3.0, 4.6, 6.2, 7.8, 9.4, 10.6]

    def series(beta: float) -> Series:
        q = [0.5 * (w - 1.0) ** beta for w in widths]
        return Series(w=widths, Q=q, Q_err=[0.01 * x for x in q])

    fits = {"q2d": {(0.0, None, None): three_fits(series(1.8), 2, 0.0)}}
    replicas = {(0.0, 1.0): series(1.6), (0.0, 2.0): series(1.7)}
    text = "\n".join(_replicate_table(realization_fits(fits, replicas)))
    for seed, beta in ((0, "1.8"), (1, "1.6"), (2, "1.7")):
        assert f"| 0 | {seed} | {beta} ± " in text
    assert "| 0 | mean ± s.d. (3) | 1.7 ± 0.1 |" in text


def test_realizations_give_lambda_c_each_and_pooled() -> None:
    """lambda_c of each realization and pooled: two realizations whose betas follow eq. (14)
    with lambda_c = 0.1 and 0.2 give those back, the pooled fit lies between them with an
    error that holds their spread, and the report's table and seed row carry them."""
    from grainflow.analysis.hopper import beta_sigmoid
    from grainflow.studies.hopper_authors import (AUTHORS_REDUCED, POOLED, Series,
                                                  _realization_table, _seed_table,
                                                  realization_fits, replicate_sigmoids,
                                                  three_fits)

    widths = [3.0, 4.6, 6.2, 7.8, 9.4, 10.6]
    lams = [0.0, 0.005, 0.02, 0.05, 0.181, 1.0, math.inf]

    def series(beta: float) -> Series:
        q = [0.5 * (w - 1.0) ** beta for w in widths]
        return Series(w=widths, Q=q, Q_err=[0.01 * x for x in q])

    def beta(lam: float, lambda_c: float) -> float:
        if lam in (0.0, math.inf):  # the limits d - 1/2 and d - 3/2
            return 1.5 if lam == 0.0 else 0.5
        return float(beta_sigmoid(np.array([lam]), lambda_c, 0.8, 2)[0])

    fits = {"q2d": {(lam, None, None): three_fits(series(beta(lam, 0.1)), 2, lam)
                    for lam in lams}}
    replicas = {(lam, 1.0): series(beta(lam, 0.2)) for lam in lams}
    realizations = realization_fits(fits, replicas)
    replicates = replicate_sigmoids(realizations)
    assert replicates[0]["free"].lambda_c == pytest.approx(0.1, rel=0.02)
    assert replicates[1]["free"].lambda_c == pytest.approx(0.2, rel=0.02)
    pooled = replicates[POOLED]["free"]
    assert 0.1 < pooled.lambda_c < 0.2
    assert pooled.lambda_c_err > 0.1 * pooled.lambda_c  # the spread, not the fits' 1 %
    table = "\n".join(_realization_table(realizations, replicates))
    assert "| λ | seed 0 | seed 1 | mean ± s.d. |" in table
    assert "| λ_c (the free betas) | 0.1 ± " in table
    seed_rows = "\n".join(_seed_table(AUTHORS_REDUCED, fits, {"q2d": {}, "q3d": {}, **{
        t: {} for t in AUTHORS_REDUCED.theta_w}}, replicates))
    assert "| 2D λ_c, 2 realizations pooled (the free betas) | 0.05 | " in seed_rows
    # limits at eq. (14)'s own 3/2 and 1/2: the measured-limits sigmoid is the same fit
    assert replicates[0]["measured"].lambda_c == pytest.approx(0.1, rel=0.02)


def test_lambda_c_between_the_measured_limits() -> None:
    """A realization whose betas run from 1.8 (lambda = 0) to 0.6 (lambda = inf) with their
    midpoint 1.2 at lambda = 0.05: the sigmoid between the measured limits gives 0.05 back,
    eq. (14) with its fixed 3/2 and 1/2 puts lambda_c where beta crosses 1, later; the
    report's seed table carries both rows."""
    from grainflow.analysis.hopper import beta_sigmoid
    from grainflow.studies.hopper_authors import (AUTHORS_REDUCED, _seed_table, _sigmoids,
                                                  three_fits, Series)

    widths = [3.0, 4.6, 6.2, 7.8, 9.4, 10.6]
    lams = [0.0, 0.005, 0.02, 0.05, 0.181, 1.0, math.inf]

    def beta(lam: float) -> float:
        if lam in (0.0, math.inf):
            return 1.8 if lam == 0.0 else 0.6
        return float(beta_sigmoid(np.array([lam]), 0.05, 0.8, 2, (1.8, 0.6))[0])

    def series(b: float) -> Series:
        q = [0.5 * (w - 1.0) ** b for w in widths]
        return Series(w=widths, Q=q, Q_err=[0.01 * x for x in q])

    fits = {(lam, None, None): three_fits(series(beta(lam)), 2, lam) for lam in lams}
    sig = _sigmoids([(key[0], f) for key, f in fits.items()], 2)
    assert sig["measured"].lambda_c == pytest.approx(0.05, rel=0.02)
    assert sig["measured"].levels == pytest.approx((1.8, 1.2, 0.6), abs=0.01)
    assert sig["free"].lambda_c > 1.5 * 0.05
    rows = "\n".join(_seed_table(AUTHORS_REDUCED, {"q2d": fits}, {"q2d": sig, "q3d": {}, **{
        t: {} for t in AUTHORS_REDUCED.theta_w}}, {}))
    assert "| 2D λ_c from the free betas, between their measured limits | 0.05 | 0.05" in rows
    # no limits measured (lambda = 0 or inf missing): no such fit
    assert "measured" not in _sigmoids([(key[0], f) for key, f in fits.items()
                                        if key[0] != math.inf], 2)


def test_height_table_gives_the_ratio_at_each_common_width() -> None:
    from grainflow.studies.hopper_authors import Series, _height_table

    base = Series(w=[3.0, 6.2], Q=[2.0, 8.0], Q_err=[0.1, 0.4])
    tall = Series(w=[3.0, 6.2, 9.4], Q=[4.0, 16.0, 30.0], Q_err=[0.2, 0.8, 1.0])
    text = "\n".join(_height_table({"q2d": {(0.0, None, None): base},
                                    "friction_n3200": {(0.0, None, None): tall}}))
    assert "| 3 | 2 ± 0.1 | 4 ± 0.2 | 2 ± 0.14 |" in text
    assert "| 6.2 |" in text and "| 9.4 |" not in text
    assert _height_table({"q2d": {(0.0, None, None): base}}) == []


def test_regime_table_tells_a_viscous_law_from_beverloo() -> None:
    """Q = 0.2 w^2 (a Stokes slit) fits beta = 2 exactly and beta = 3/2 badly."""
    from grainflow.studies.hopper_authors import Series, _regime_table

    widths = [3.0, 4.6, 6.2, 7.8, 9.4, 10.6]
    q = [0.2 * w**2 for w in widths]
    rows = _regime_table({"q2d": {(0.0, None, None): Series(w=widths, Q=q,
                                                           Q_err=[0.01 * x for x in q])}})
    viscous = next(r for r in rows if "(viscous)" in r)
    beverloo = next(r for r in rows if "(Beverloo)" in r)
    chi = [float(r.rstrip(" |").rsplit("|", 1)[1]) for r in (viscous, beverloo)]
    assert chi[0] < 1e-6 < 1.0 < chi[1]


@pytest.mark.parametrize("dim", [2, 3])
def test_hopper_reads_the_run_sections_integrator_and_list_check(dim):
    """``run.integrator`` and ``run.list_check`` reach the hopper's simulation (they were
    silently ignored), and the defaults stay velocity Verlet and the absolute check."""
    from grainflow.config.build import build_simulation

    shape = ({"n": 60, "width": 10.0, "orifice_width": 4.0} if dim == 2
             else {"n": 200, "width": 8.0, "orifice_width": 3.0})
    hopper = {**shape, "E_sp": 1000.0, "E_w": 1000.0, "lam": math.inf}
    base = {"scenario": f"hopper{dim}d", "dim": dim, "run": {"steps": 50}, "hopper": hopper}
    sim = build_simulation(load_config(base), prepare=False)
    assert sim.integrator.name == "verlet" and sim.neighbors.check == "absolute"
    chosen = {**base, "run": {"steps": 50, "integrator": "adams_bashforth2",
                              "list_check": "relative"}}
    sim = build_simulation(load_config(chosen), prepare=False)
    assert sim.integrator.name == "adams_bashforth2" and sim.neighbors.check == "relative"
    sim.run(50)  # and it steps
    assert sim.step == 50


def test_hopper_refuses_run_dt_fraction_and_its_saved_config_loads_again():
    """``run.dt_fraction`` is not the hopper's time step (``hopper.dt_fraction`` is): a
    config that sets it is refused with the field and the fix, not silently run at another
    dt; the run directory's config (``resolved_dict``) leaves it out and loads again with
    the same time step."""
    from grainflow.config.build import build_simulation
    from grainflow.config.schema import ConfigError, resolved_dict

    hopper = {"n": 60, "width": 10.0, "orifice_width": 4.0, "E_sp": 1000.0, "E_w": 1000.0,
              "lam": math.inf, "dt_fraction": 0.03}
    base = {"scenario": "hopper2d", "dim": 2, "run": {"steps": 10}, "hopper": hopper}
    with pytest.raises(ConfigError) as err:
        load_config({**base, "run": {"steps": 10, "dt_fraction": 0.01}})
    (line,) = err.value.messages
    assert line.startswith("run.dt_fraction: not read by scenario 'hopper2d'")
    assert "set hopper.dt_fraction instead, or run.dt" in line
    config = load_config(base)
    saved = resolved_dict(config)
    assert "dt_fraction" not in saved["run"] and saved["hopper"]["dt_fraction"] == 0.03
    dt = build_simulation(config, prepare=False).dt
    assert build_simulation(load_config(saved), prepare=False).dt == dt
    # the other scenarios still read run.dt_fraction and keep it in their saved config
    generic = resolved_dict(load_config({"run": {"steps": 1, "dt_fraction": 0.01},
                                         "box": {"lo": [0, 0, 0], "hi": [1, 1, 1]}}))
    assert generic["run"]["dt_fraction"] == 0.01


def test_a_hopper_config_saved_before_the_refusal_still_loads_and_matches(tmp_path):
    """Run directories written before the hopper refused ``run.dt_fraction`` carry its
    default (0.02) in ``[run]``: such a saved config still loads (a run resumes) and its
    sweep point still counts as the same configuration; a value other than the default
    written there by hand is refused as in any config."""
    import tomli_w

    from grainflow.config.schema import ConfigError, resolved_dict
    from grainflow.sweep.execute import _same_config

    hopper = {"n": 60, "width": 10.0, "orifice_width": 4.0, "E_sp": 1000.0, "E_w": 1000.0,
              "lam": math.inf}
    config = {"scenario": "hopper2d", "dim": 2, "run": {"steps": 10}, "hopper": hopper}
    old = resolved_dict(load_config(config))
    old["run"]["dt_fraction"] = 0.02  # what resolved_dict wrote before
    path = tmp_path / "config.toml"
    path.write_text(tomli_w.dumps(old))
    assert load_config(path, saved=True).section.dt_fraction == 0.05
    assert _same_config(old, config)
    with pytest.raises(ConfigError):
        load_config(path)  # not as a saved config: refused like a user's
    old["run"]["dt_fraction"] = 0.01
    path.write_text(tomli_w.dumps(old))
    with pytest.raises(ConfigError, match="run.dt_fraction: not read by scenario 'hopper2d'"):
        load_config(path, saved=True)
