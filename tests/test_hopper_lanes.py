"""Fast tests of the authors' reinsertion rule of seed 003 in :class:`HopperReinsertion`:
``placement="lanes"`` (fixed lanes used in turn, ``lift`` above the lane's top grain, raised
only to clear overlaps, velocity along gravity copied plus a lateral kick, a checkpointed lane
counter) and ``count_at="reinsertion"`` (an event when a grain is moved back)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from grainflow.engine.forces import Gravity
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.scenarios.hopper_reinsertion import (
    LANE_LIFT,
    LANE_REACH,
    OUT_FLAG,
    HopperReinsertion,
)
from grainflow.state import ParticleState

SIG_S = 1.0 / 1.2  # small diameter in sigma_avg units
R_S, R_L = 0.5 * SIG_S, 0.7 * SIG_S  # small and large radii (diameter ratio 1.4)


class _Ctx:
    """The part of an UpdateContext the updater uses."""

    def __init__(self, state: ParticleState, seed: int = 0, time: float = 0.0) -> None:
        self.state = state
        self.rng = np.random.default_rng(seed)
        self.time = time

    def relocate(self, index, x, v=None, omega=None) -> None:
        self.state.relocate(index, x, v, omega)


def _state(dim: int, x: np.ndarray, radius: np.ndarray | float) -> ParticleState:
    lo, hi = [-20.0] * dim, [20.0] * dim
    st = ParticleState(dim, Box(lo=np.array(lo), hi=np.array(hi), periodic=(False,) * dim))
    st.add_particles(np.asarray(x, dtype=float), radius, density=1.0)
    return st


def _lanes(dim: int = 2, width: float = 10.0, **kw) -> HopperReinsertion:
    return HopperReinsertion(dim, 0.0, np.zeros(dim - 1), width, placement="lanes", **kw)


def _ready(up: HopperReinsertion, st: ParticleState, seed: int = 0) -> _Ctx:
    ctx = _Ctx(st, seed)
    up.setup_state(ctx)
    return ctx


def _gaps(st: ParticleState, i: int) -> np.ndarray:
    gap = np.linalg.norm(st.x - st.x[i], axis=1) - (st.radius + st.radius[i])
    gap[i] = np.inf
    return gap


def _drop(st: ParticleState, i: int, up: HopperReinsertion) -> None:
    """Put grain ``i`` below the reinsertion depth (it is flagged and due at the next call)."""
    st.x[i, up.axis] = up.orifice_height - up.depth * 2.0 * st.radius[i] - 0.5


# ---------------------------------------------------------------------------- lane order
def test_lane_order_2d() -> None:
    up = HopperReinsertion(2, 0.0, 1.5, 10.0, placement="lanes", lanes=28)
    span = 4.0
    s = 2.0 * span / 28
    pos = up.lane_positions(span)
    assert pos.shape == (28, 1)
    assert pos[:4, 0] == pytest.approx(1.5 + np.array([s / 2, -s / 2, 3 * s / 2, -3 * s / 2]))
    # together: the centres of 28 equal cells of [-span, span], each used once
    cells = 1.5 - span + (np.arange(28) + 0.5) * s
    assert np.sort(pos[:, 0]) == pytest.approx(cells)
    assert np.all(np.diff(np.abs(pos[:, 0] - 1.5)[::2]) > 0)  # centre-out
    odd = HopperReinsertion(2, 0.0, 0.0, 10.0, placement="lanes", lanes=5).lane_positions(span)
    s5 = 2.0 * span / 5
    assert odd[:, 0] == pytest.approx([0.0, s5, -s5, 2 * s5, -2 * s5])
    one = HopperReinsertion(2, 0.0, 2.0, 10.0, placement="lanes", lanes=1).lane_positions(span)
    assert one[:, 0] == pytest.approx([2.0])


def test_lane_order_3d() -> None:
    centre = np.array([0.5, -1.0])
    up = HopperReinsertion(3, 0.0, centre, 10.0, placement="lanes", lanes=28)
    span = 4.0
    pos = up.lane_positions(span)
    assert pos.shape == (28, 2)
    rho = np.linalg.norm(pos - centre, axis=1)
    assert np.all(np.diff(rho) > 0) and rho[-1] < span and rho[-1] > 0.95 * span
    d = np.linalg.norm(pos[:, None] - pos[None, :], axis=2) + np.eye(28) * 1e9
    assert d.min() > 0.5 * span / np.sqrt(28)  # spread over the disk, no two close together
    one = HopperReinsertion(3, 0.0, centre, 10.0, placement="lanes", lanes=1)
    assert one.lane_positions(span) == pytest.approx(centre[None, :])


def test_grains_take_the_lanes_in_turn_2d() -> None:
    # a flat layer of small grains; the largest grain (radius R_L) sets span
    xs = np.arange(-4.5, 4.51, 0.9)
    x = np.column_stack([xs, np.full(xs.size, 1.0)])
    x = np.vstack([x, [[0.0, -5.0]] * 4])
    radius = np.concatenate([np.full(xs.size, R_S), np.full(4, R_L)])
    st = _state(2, x, radius)
    up = _lanes(lanes=28)
    ctx = _ready(up, st)
    span = 5.0 - R_L
    s = 2.0 * span / 28
    up.update(ctx)
    movers = np.arange(xs.size, xs.size + 4)
    assert up.reinserted == 4 and up.lane_counter == 4
    assert st.x[movers, 0] == pytest.approx([s / 2, -s / 2, 3 * s / 2, -3 * s / 2])


# -------------------------------------------------------------------------- placement
def test_lift_above_the_lane_top_when_that_clears() -> None:
    # lane 0 of 2 at x = +span/2; its highest grain sits 0.3 to the side of the lane
    span = 5.0 - R_S
    lane = span / 2
    x = [[lane + 0.3, 2.0], [lane - 0.9, 1.5], [lane + 2.5, 3.0], [-3.0, 4.0], [0.0, -5.0]]
    st = _state(2, x, R_S)
    up = _lanes(lanes=2)
    ctx = _ready(up, st)
    up.update(ctx)
    # the grain at (lane + 2.5, 3) is higher but beyond lane_reach; the grain at -3 is elsewhere
    assert st.x[4, 0] == lane and st.x[4, 1] == 2.0 + LANE_LIFT
    assert _gaps(st, 4).min() > 0


def test_empty_lane_uses_the_top_of_the_pile() -> None:
    x = [[-3.0, 4.0], [-2.0, 1.0], [0.0, -5.0], [-3.0, -1.0]]
    st = _state(2, x, R_S)
    v = np.zeros((4, 3))
    v[0] = [0.0, -0.8, 0.0]
    st.v[:] = v
    up = _lanes(lanes=1, lift=0.5)
    ctx = _ready(up, st)
    up.update(ctx)  # grain 2 due; grain 3 is above its depth, flagged only
    assert up.reinserted == 1 and st.arrays[OUT_FLAG][3] == 1
    assert st.x[2, 0] == 0.0 and st.x[2, 1] == 4.5  # lane at the centre, empty
    assert st.v[2, 1] == -0.8


def test_raised_just_enough_over_a_large_grain() -> None:
    span = 5.0 - R_L
    lane = span / 2
    x = [[lane, 2.0], [lane + 1.0, 1.6], [0.0, -5.0]]
    st = _state(2, x, R_L)
    up = _lanes(lanes=2)
    ctx = _ready(up, st)
    up.update(ctx)
    # lift = sigma_s < 2 R_L: raised to touch the large grain below (relative margin 1e-9)
    assert st.x[2, 1] > 2.0 + LANE_LIFT
    assert st.x[2, 1] == pytest.approx(2.0 + 2 * R_L, rel=1e-8)
    gap = _gaps(st, 2)
    assert gap.min() >= 0 and gap[0] == pytest.approx(0.0, abs=1e-8)


@pytest.mark.parametrize("dim", [2, 3])
def test_lane_grains_never_overlap_random_piles(dim: int) -> None:
    rng = np.random.default_rng(7)
    width = 8.0
    raised = 0
    for trial in range(60):
        n = 40 if dim == 2 else 80
        lateral = rng.uniform(-3.0, 3.0, (n, dim - 1))
        if dim == 3:
            lateral *= 0.7
        x = np.column_stack([lateral, rng.uniform(0.2, 4.0, n)])
        radius = np.where(rng.random(n) < 0.5, R_S, R_L)
        st = _state(dim, x, radius)
        up = _lanes(dim, width, lanes=int(rng.integers(1, 30)), kick=0.1)
        ctx = _ready(up, st, seed=trial)
        for _ in range(6):
            i = int(rng.integers(n))
            _drop(st, i, up)
            up.update(ctx)
            assert st.arrays[OUT_FLAG][i] == 0
            gap = _gaps(st, i)
            assert gap.min() >= 0.0
            # lift above the lane's top grain, or higher only to touch some grain
            pile = st.x[:, dim - 1] > 0.0
            pile[i] = False
            l2 = np.sum((st.x[:, : dim - 1] - st.x[i, : dim - 1]) ** 2, axis=1)
            lane = pile & (l2 < LANE_REACH**2)
            top = np.max(st.x[lane if lane.any() else pile, dim - 1])
            if st.x[i, dim - 1] != top + LANE_LIFT:
                raised += 1
                assert st.x[i, dim - 1] > top + LANE_LIFT
                assert gap.min() < 1e-8  # touching: raised no more than needed
        assert up.lane_counter == 6
    assert raised > 10  # the raise was exercised


def test_empty_lanes_are_passed_over() -> None:
    """A pile only near the centre (an inclined hopper's outer lanes are empty): a grain
    whose lane is empty goes to the next lane in the order that has grains, never to the
    empty lane at the pile's height; the counter moves by one per grain."""
    x = [[0.0, 1.0], [0.9, 1.0], [-0.9, 1.0], [0.0, 3.0], [0.0, 4.0], [0.0, 5.0]]
    st = _state(2, x, R_S)
    up = _lanes(width=10.0, lanes=4)  # span 5 - R_S, lanes at +-s/2 and +-3s/2
    ctx = _ready(up, st)
    s = 2.0 * (5.0 - R_S) / 4
    placed = []
    for i in (3, 4, 5):
        _drop(st, i, up)
        up.update(ctx)
        placed.append(st.x[i, 0])
    # lanes +s/2, -s/2 hold grains; +3s/2 (third grain's turn) is empty: it takes +s/2
    assert placed == pytest.approx([0.5 * s, -0.5 * s, 0.5 * s])
    assert up.lane_counter == 3


# --------------------------------------------------------------------------- velocity
@pytest.mark.parametrize("dim", [2, 3])
def test_velocity_along_gravity_and_lateral_kick(dim: int) -> None:
    # one grain in the pile, at the centre; one lane at the centre
    x = np.zeros((2, dim))
    x[0, -1], x[1, -1] = 1.0, -5.0
    st = _state(dim, x, R_S)
    up = _lanes(dim, lanes=1)
    ctx = _ready(up, st, seed=3)
    directions = []
    for _ in range(40):
        st.v[0] = [0.3, 0.2, -2.0] if dim == 3 else [0.3, -2.0, 0.0]
        st.omega[1] = [0.0, 0.0, 5.0] if dim == 2 else [1.0, 2.0, 3.0]
        _drop(st, 1, up)
        up.update(ctx)
        v = st.v[1]
        assert v[dim - 1] == -2.0  # the top grain's component along gravity
        lateral = v[: dim - 1]
        assert np.linalg.norm(lateral) == pytest.approx(0.1 * 2.0, rel=1e-12)
        assert np.all(st.omega[1] == 0.0)
        if dim == 2:
            assert v[2] == 0.0
        directions.append(np.arctan2(lateral[-1], lateral[0]))
    if dim == 2:
        assert {np.sign(np.cos(a)) for a in directions} == {-1.0, 1.0}
    else:
        assert np.ptp(np.unwrap(np.sort(directions))) > np.pi  # azimuths spread out


def test_no_kick_keeps_lateral_velocity_zero() -> None:
    st = _state(2, [[0.0, 1.0], [0.0, -5.0]], R_S)
    st.v[0] = [0.4, -1.5, 0.0]
    up = _lanes(lanes=1, kick=0.0)
    ctx = _ready(up, st)
    up.update(ctx)
    assert np.array_equal(st.v[1], [0.0, -1.5, 0.0])


# ---------------------------------------------------------------------- lane counter
def _column_pile(dim: int = 2) -> ParticleState:
    rng = np.random.default_rng(11)
    n = 30
    x = np.column_stack([rng.uniform(-3.5, 3.5, (n, dim - 1)), rng.uniform(0.5, 3.0, n)])
    return _state(dim, x, np.where(rng.random(n) < 0.5, R_S, R_L))


def test_lane_counter_cycles() -> None:
    st = _column_pile()
    up = _lanes(lanes=3)
    ctx = _ready(up, st)
    lanes_x = up.lane_positions(5.0 - R_L)[:, 0]
    seen = []
    for k in range(7):
        _drop(st, k, up)
        up.update(ctx)
        seen.append(st.x[k, 0])
    assert up.lane_counter == 7
    assert seen == pytest.approx(lanes_x[np.arange(7) % 3])


@pytest.mark.parametrize("dim", [2, 3])
def test_lane_counter_survives_state_dict_round_trip(dim: int) -> None:
    st = _column_pile(dim)
    up = _lanes(dim, lanes=5, count_at="reinsertion")
    ctx = _ready(up, st, seed=5)
    for k in range(3):
        _drop(st, k, up)
        up.update(ctx)
    saved = up.state_dict()
    assert saved["lane_counter"] == 3
    resumed = _lanes(dim, lanes=5, count_at="reinsertion")
    resumed.load_state_dict(copy.deepcopy(saved))
    assert resumed.lane_counter == 3
    ctx_b = copy.deepcopy(ctx)
    for k in range(3, 9):
        for u, c in ((up, ctx), (resumed, ctx_b)):
            _drop(c.state, k, u)
            u.update(c)
    assert np.array_equal(ctx.state.x, ctx_b.state.x)
    assert np.array_equal(ctx.state.v, ctx_b.state.v)
    assert np.array_equal(up.event_ids, resumed.event_ids) and up.lane_counter == 9
    # a checkpoint from before the lanes existed loads with counter 0
    old = {k: v for k, v in saved.items() if k != "lane_counter"}
    fresh = _lanes(dim, lanes=5)
    fresh.lane_counter = 4
    fresh.load_state_dict(old)
    assert fresh.lane_counter == 0 and fresh.reinserted == 3


def _falling_sim(seed: int = 0) -> Simulation:
    """Grains falling freely (laterally periodic) through the plane y = 0, put back on lanes."""
    st = ParticleState(2, Box(lo=np.array([-5.0, -30.0]), hi=np.array([5.0, 30.0]),
                              periodic=(True, False)))
    rng = np.random.default_rng(3)
    xs = np.arange(-4.0, 4.01, 1.3)
    x = np.array([[a, b] for b in (0.5, 1.8, 3.1) for a in xs]) + rng.uniform(-0.1, 0.1, (21, 2))
    st.add_particles(x, np.where(rng.random(21) < 0.5, R_S, R_L), density=1.0)
    from grainflow.models.soft import SoftLaw

    law = SoftLaw(n_types=1)
    law.set_pair(0, 0, epsilon=100.0, mu_k=0.0)
    sim = Simulation(st, 1e-3, law, seed=seed)
    sim.add_force(Gravity([0.0, -10.0]))
    up = HopperReinsertion(2, 0.0, 0.0, 10.0, placement="lanes", count_at="reinsertion",
                           lanes=4)
    up.setup_state(sim)
    sim.add_updater(up, 5)
    return sim


def test_simulation_checkpoint_resumes_bitwise_with_lanes() -> None:
    a = _falling_sim()
    a.run(1500)
    saved = a.state_dict()
    b = _falling_sim()
    b.load_state_dict(saved)
    a.run(1500)
    b.run(1500)
    ua, ub = a.updaters[0].owner, b.updaters[0].owner
    assert ua.reinserted > 5 and ua.lane_counter == ua.reinserted == ua.n_events
    assert ub.lane_counter == ua.lane_counter
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)
    assert np.array_equal(ua.event_times, ub.event_times)


# -------------------------------------------------------------------- count at reinsertion
@pytest.mark.parametrize("placement", ["pile", "lanes"])
def test_count_at_reinsertion_records_only_when_moved(placement: str) -> None:
    st = _state(2, [[0.0, 1.0], [1.0, 1.0], [0.0, 5.0]], 0.5)
    up = HopperReinsertion(2, 0.0, 0.0, 10.0, count_at="reinsertion", placement=placement)
    ctx = _ready(up, st)
    i = int(np.flatnonzero(st.id == 2)[0])
    st.x[i, 1] = -0.1
    ctx.time = 1.0
    up.update(ctx)
    assert up.n_events == 0 and st.arrays[OUT_FLAG][i] == 1  # below the plane: flagged only
    st.x[i, 1] = 0.3  # comes back up
    ctx.time = 1.5
    up.update(ctx)
    st.x[i, 1] = -1.9  # dips again, not yet two diameters (2 x 1.0) below
    up.update(ctx)
    assert up.n_events == 0 and up.reinserted == 0
    st.x[i, 1] = -2.1
    ctx.time = 2.0
    up.update(ctx)
    assert up.n_events == 1 and up.reinserted == 1 and st.arrays[OUT_FLAG][i] == 0
    assert list(up.event_ids) == [2] and up.event_times[0] == 2.0
    assert up.event_sizes[0] == pytest.approx(np.pi * 0.25)
    assert st.x[i, 1] > 1.0
    # a grain that dips below the plane and returns to the pile is never counted
    j = int(np.flatnonzero(st.id == 0)[0])
    st.x[j, 1] = -0.5
    up.update(ctx)
    st.x[j, 1] = 0.8
    for _ in range(3):
        up.update(ctx)
    assert up.n_events == 1 and up.reinserted == 1


def test_count_at_reinsertion_sizes_3d() -> None:
    x = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 0.0, -5.0], [0.0, 1.0, -5.0]]
    st = _state(3, x, np.array([R_S, R_S, R_S, R_L]))
    up = HopperReinsertion(3, 0.0, np.zeros(2), 10.0, count_at="reinsertion",
                           placement="lanes")
    ctx = _ready(up, st)
    up.update(ctx)
    assert list(up.event_ids) == [2, 3] and up.lane_counter == 2
    assert up.event_sizes == pytest.approx(4.0 / 3.0 * np.pi * np.array([R_S, R_L]) ** 3)


def test_count_at_orifice_with_lanes_counts_at_the_crossing() -> None:
    st = _state(2, [[0.0, 1.0], [1.0, 1.0], [0.0, 5.0]], 0.5)
    up = _lanes(lanes=2)
    ctx = _ready(up, st)
    st.x[2, 1] = -0.1
    up.update(ctx)
    assert up.n_events == 1 and up.reinserted == 0
    st.x[2, 1] = -2.1
    up.update(ctx)
    assert up.n_events == 1 and up.reinserted == 1 and up.lane_counter == 1


# ------------------------------------------------------------------------- arguments
def test_lane_defaults_are_small_diameters() -> None:
    from grainflow.scenarios.hopper import SIGMA_SMALL

    assert LANE_LIFT == pytest.approx(SIGMA_SMALL) and LANE_LIFT == pytest.approx(SIG_S)
    assert LANE_REACH == pytest.approx(1.5 * SIGMA_SMALL)
    up = _lanes()
    assert (up.lanes, up.lift, up.lane_reach, up.kick) == (28, LANE_LIFT, LANE_REACH, 0.1)
    default = HopperReinsertion(2, 0.0, 0.0, 10.0)
    assert (default.count_at, default.placement) == ("orifice", "pile")


@pytest.mark.parametrize("kw, name", [
    (dict(count_at="exit"), "count_at"),
    (dict(placement="random"), "placement"),
    (dict(lanes=0), "lanes"),
    (dict(lanes=2.5), "lanes"),
    (dict(lift=0.0), "lift"),
    (dict(lift=-1.0), "lift"),
    (dict(lane_reach=0.0), "lane_reach"),
    (dict(kick=-0.1), "kick"),
    (dict(kick=float("nan")), "kick"),
])
def test_bad_arguments_raise_value_errors_naming_them(kw: dict, name: str) -> None:
    with pytest.raises(ValueError, match=rf"^{name}: "):
        HopperReinsertion(2, 0.0, 0.0, 10.0, **kw)


def test_unknown_choices_are_listed() -> None:
    with pytest.raises(ValueError, match="'orifice', 'reinsertion'"):
        HopperReinsertion(2, 0.0, 0.0, 10.0, count_at="exit")
    with pytest.raises(ValueError, match="'pile', 'lanes'"):
        HopperReinsertion(2, 0.0, 0.0, 10.0, placement="random")
