"""The neighbour list's relative validity check (:mod:`grainflow.kernels.list_check`).

* The invariant, by brute force: on random polydisperse packings (2D and 3D, open and
  periodic axes, with reach) moved by a flow (a drift many skins long, a shear, and
  random velocities, some large), as long as the check says the list holds, every pair
  within ``r_i + r_j + reach`` is listed. Runs end when the check asks for a build; they
  must have gone past what the absolute rule allows, or the test shows nothing.
* A whole system translated by ten skins keeps its list (open box); a periodic one
  rebuilds within one cut-off; one particle moving a skin against its neighbours does not
  keep it.
* A small stream (walls, a lid that opens, cohesion, insertion and deletion) runs bitwise
  the same with either check when the particles are never re-sorted (re-sorting at other
  builds changes the order of sums), with far fewer builds; the relative check is bitwise
  the same on the compiled loop and on Python steps, and across a checkpoint.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainflow.engine.list_blocks import BLOCK_CUTS, index_blocks
from grainflow.engine.neighbor_list import ListGeometry, NeighborList
from grainflow.frame import Box
from grainflow.state import ParticleState

pytestmark = pytest.mark.usefixtures("numba_one_thread")

CASES = [
    # dim, periodic, lengths
    (3, (False, False, False), (8.0, 8.0, 8.0)),
    (3, (True, True, False), (9.0, 9.0, 12.0)),
    (3, (False, True, True), (9.0, 3.0, 9.0)),    # y periodic with 2 cells
    (2, (False, False), (14.0, 14.0)),
    (2, (True, False), (3.0, 20.0)),              # short periodic x
]


def _state(dim, periodic, lengths, n, rng) -> ParticleState:
    lengths = np.asarray(lengths, dtype=float)
    box = Box(lo=np.zeros(dim), hi=lengths, periodic=tuple(periodic))
    st = ParticleState(dim, box)
    x = rng.uniform(0.0, 1.0, (n, dim)) * lengths
    st.add_particles(x, rng.uniform(0.2, 0.5, n), mass=1.0)
    return st


def _built(st: ParticleState, skin: float, reach: float) -> tuple[NeighborList, ListGeometry]:
    nl = NeighborList(skin, check="relative")
    geom = ListGeometry.from_state(st)
    nl.wrap(st, geom)
    nl.build(st, geom, nl.cell_order(st, geom, reach))
    return nl, geom


def _listed(nl: NeighborList) -> set[tuple[int, int]]:
    rows = np.repeat(np.arange(nl.row_ptr.shape[0] - 1), np.diff(nl.row_ptr))
    return set(zip(rows.tolist(), nl.nbr.tolist()))


def _interacting(st: ParticleState, geom: ListGeometry, reach: float) -> set[tuple[int, int]]:
    i, j = np.triu_indices(st.n, k=1)
    d = st.x[i] - st.x[j]
    for a in range(3):
        if geom.periodic[a]:
            d[:, a] -= geom.length[a] * np.rint(d[:, a] / geom.length[a])
    close = np.linalg.norm(d, axis=1) < st.radius[i] + st.radius[j] + reach
    return set(zip(i[close].tolist(), j[close].tolist()))


@pytest.mark.parametrize("coherent", [True, False])
@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("dim, periodic, lengths", CASES)
def test_no_interacting_pair_is_missed_while_the_check_holds(dim, periodic, lengths, seed,
                                                             coherent):
    rng = np.random.default_rng([dim, sum(periodic), seed, coherent])
    st = _state(dim, periodic, lengths, 150 if dim == 2 else 300, rng)
    skin, reach = 0.15, 0.05 * (seed % 2)
    nl, geom = _built(st, skin, reach)
    listed = _listed(nl)
    x0 = st.x.copy()
    # a flow: a drift, a shear and a velocity per particle; the incoherent one has a
    # strong shear and a tenth of its particles fast
    drift = np.zeros(3)
    drift[:dim] = rng.normal(0.0, 1.0, dim)
    shear = np.zeros(3)
    shear[0] = (0.01 if coherent else 0.3) * rng.normal()
    velocity = np.zeros((st.n, 3))
    velocity[:, :dim] = rng.normal(0.0, 0.005 if coherent else 0.05, (st.n, dim))
    if not coherent:
        fast = rng.uniform(size=st.n) < 0.1
        velocity[fast, :dim] *= rng.uniform(1.0, 20.0, (int(fast.sum()), 1))
    furthest = 0.0
    for step in range(1, 3000):
        t = 0.01 * step
        st.x[:] = x0 + t * (drift + velocity) + t * np.outer(x0[:, 1], shear)
        if nl.needs_build(st, geom):
            break
        assert _interacting(st, geom, reach) <= listed, f"pair missed at t = {t}"
        furthest = max(furthest, float(np.abs(st.x - x0).max()))
    else:
        pytest.fail("the check never asked for a build")
    if coherent and not any(periodic):
        assert furthest > 4 * skin  # far past the absolute rule's skin/2


@pytest.mark.parametrize("dim, periodic, lengths", CASES)
def test_a_particle_driven_at_its_nearest_unlisted_partner_triggers_a_build_in_time(
        dim, periodic, lengths):
    """Condition 1 at its sharpest: everything else at rest, one particle moves straight
    at the closest pair it is not listed with; the build must come before contact (a
    check at twice the skin misses here)."""
    rng = np.random.default_rng([dim, sum(periodic), 7])
    st = _state(dim, periodic, lengths, 150 if dim == 2 else 300, rng)
    skin = 0.15
    nl, geom = _built(st, skin, 0.0)
    listed = _listed(nl)
    i, j = np.triu_indices(st.n, k=1)
    branch = geom.branch(st.x[j], st.x[i])
    gap = np.linalg.norm(branch, axis=1) - st.radius[i] - st.radius[j]
    unlisted = np.array([(a, b) not in listed for a, b in zip(i.tolist(), j.tolist())])
    tried = 0
    for k in np.argsort(np.where(unlisted, gap, np.inf))[:5]:
        x0 = st.x.copy()
        unit = branch[k] / np.linalg.norm(branch[k])
        for step in range(1, 400):
            st.x[i[k]] = x0[i[k]] + unit * step * skin / 50
            if nl.needs_build(st, geom):
                break
            assert (i[k], j[k]) not in _interacting(st, geom, 0.0) - listed
        else:
            pytest.fail("no build asked for")
        st.x[:] = x0
        tried += gap[k] < 2 * skin  # the pair would be missed by a check at 2 skins
    assert tried >= 1


@pytest.mark.parametrize("dim", [2, 3])
def test_two_rigid_clusters_closing_a_gap_trigger_a_build_in_time(dim):
    """Condition 2: two packed clusters far apart rush at each other without deforming,
    so no block moves against its neighbours; only the spread of all displacements can
    tell (a droplet meeting another in a stream, a jet meeting its target)."""
    rng = np.random.default_rng(dim)
    st = _state(dim, (False,) * dim, (30.0,) + (4.0,) * (dim - 1), 400, rng)
    left = st.x[:, 0] < 10.0
    right = st.x[:, 0] > 20.0
    keep = left | right
    state = ParticleState(dim, st.box)
    state.add_particles(st.x[keep], st.radius[keep], mass=1.0)
    left = left[keep]
    skin = 0.15
    nl, geom = _built(state, skin, 0.0)
    listed = _listed(nl)
    x0 = state.x.copy()
    for step in range(1, 4000):
        shift = np.zeros(3)
        shift[0] = step * skin / 20
        state.x[left] = x0[left] + shift
        state.x[~left] = x0[~left] - shift
        if nl.needs_build(state, geom):
            break
        assert _interacting(state, geom, 0.0) <= listed
    else:
        pytest.fail("no build asked for")
    assert 2 * shift[0] > 4 * skin  # long after the absolute rule would have rebuilt


def test_a_translated_system_keeps_its_list_in_an_open_box_only():
    rng = np.random.default_rng(5)
    open_box = _state(3, (False, False, False), (8.0, 8.0, 8.0), 300, rng)
    skin = 0.15
    nl, geom = _built(open_box, skin, 0.0)
    open_box.x[:] += np.array([10 * skin, -7 * skin, 3 * skin])
    assert not nl.needs_build(open_box, geom)
    absolute = NeighborList(skin)
    absolute.wrap(open_box, geom)
    absolute.build(open_box, geom, absolute.cell_order(open_box, geom, 0.0))
    open_box.x[:] += np.array([0.6 * skin, 0.0, 0.0])
    assert absolute.needs_build(open_box, geom)
    assert not nl.needs_build(open_box, geom)
    # one particle moving a skin against its neighbours
    open_box.x[17] += np.array([0.0, 1.01 * skin, 0.0])
    assert nl.needs_build(open_box, geom)

    periodic = _state(3, (True, True, True), (8.0, 8.0, 8.0), 300, rng)
    nl, geom = _built(periodic, skin, 0.0)
    cut = 2 * periodic.radius.max() + skin
    periodic.x[:] += np.array([0.9 * cut, 0.0, 0.0])
    assert not nl.needs_build(periodic, geom)
    periodic.x[:] += np.array([0.2 * cut, 0.0, 0.0])
    assert nl.needs_build(periodic, geom)


def test_an_unknown_check_is_refused():
    with pytest.raises(ValueError, match="list_check"):
        NeighborList(0.1, check="lazy")


def _small_stream(check: str, sort_every: int = 0, replenish_every: int = 100):
    from grainflow.scenarios.stream import StreamSection, build_stream

    section = StreamSection(hopper_diameter="2.0 mm", aperture_diameter="1.4 mm",
                            fill_height="1.2 mm", contact_time="100 us", open_time="2 ms",
                            stream_depth="6 mm", restitution=0.4, cohesion_force="300 nN",
                            replenish_every=replenish_every, delete_every=replenish_every)
    return build_stream(section, seed=3, sort_every=sort_every, list_check=check)


def _by_id(sim) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    order = np.argsort(sim.state.id)
    return sim.state.x[order], sim.state.v[order], sim.state.omega[order]


def test_a_stream_runs_bitwise_the_same_with_either_check_and_builds_less():
    runs = {}
    for check in ("absolute", "relative"):
        sim = _small_stream(check, replenish_every=400)
        sim.fast_path_min_steps = 0
        sim.run(30000)
        runs[check] = sim
    a, r = runs["absolute"], runs["relative"]
    assert r.state.n == a.state.n and np.sum(r.state.x[:, 2] < -4e-3) > 20  # a stream
    for u, v in zip(_by_id(a), _by_id(r)):
        assert np.array_equal(u, v)
    assert r.rebuilds < 0.6 * a.rebuilds


def test_the_relative_check_is_bitwise_on_python_steps_and_across_a_checkpoint(tmp_path):
    from grainflow.runner import read_checkpoint, write_checkpoint

    compiled, python = _small_stream("relative", 10), _small_stream("relative", 10)
    compiled.fast_path_min_steps = 0
    python.fast_path_min_steps = 10**12
    for sim in (compiled, python):
        sim.run(12000)
    assert compiled._fast_path.steps_done > 8000 and python._fast_path.steps_done == 0
    write_checkpoint(tmp_path / "checkpoint.npz", compiled.state_dict())
    saved = read_checkpoint(tmp_path / "checkpoint.npz")
    assert saved["neighbors"]["allowance_by"]  # the walls' allowances travel with it
    compiled.run(4000)
    python.run(4000)
    resumed = _small_stream("relative", 10)
    resumed.fast_path_min_steps = 0
    resumed.load_state_dict(saved)
    resumed.run(4000)
    for sim in (python, resumed):
        for u, v in zip(_by_id(compiled), _by_id(sim)):
            assert np.array_equal(u, v)
        assert sim.rebuilds == compiled.rebuilds


@pytest.mark.parametrize("seed", range(12))
def test_the_blocks_are_the_cubes_of_the_positions_and_their_neighbours(seed):
    """``index_blocks`` against its definition, on random boxes (2D and 3D, open and
    periodic axes, particles also outside the box, empty sets): each block holds the
    particles of one cube of side G (wrapped on periodic axes), ascending, blocks in the
    order of their linear key; its pairs are the occupied blocks v >= u whose cube indices
    differ by at most one along each axis (cyclically on a periodic one), once each."""
    rng = np.random.default_rng(seed)
    dim = 2 + seed % 2
    n = 0 if seed == 5 else int(rng.integers(1, 250))
    length = np.ones(3)
    length[:dim] = rng.uniform(2.0, 15.0, dim)
    lo = np.zeros(3)
    lo[:dim] = rng.uniform(-3.0, 3.0, dim)
    periodic = np.zeros(3, dtype=bool)
    periodic[:dim] = rng.random(dim) < 0.5
    x = np.zeros((n, 3))
    x[:, :dim] = lo[:dim] + rng.uniform(-0.3, 1.3, (n, dim)) * length[:dim]
    cut, skin = float(rng.uniform(0.2, 1.5)), 0.05
    blocks = index_blocks(x, dim, lo, length, periodic, cut, skin)

    side = BLOCK_CUTS * cut
    size = np.full(3, side)
    nblock = np.ones(3, dtype=np.int64)
    for a in range(dim):
        if periodic[a]:
            nblock[a] = max(1, int(length[a] // side))
            size[a] = length[a] / nblock[a]
    cube = np.zeros((n, 3), dtype=np.int64)
    cube[:, :dim] = np.floor((x[:, :dim] - lo[:dim]) / size[:dim]).astype(np.int64)
    cube[:, periodic] %= nblock[periodic]
    groups: dict[tuple, list[int]] = {}
    for i in range(n):
        groups.setdefault(tuple(cube[i]), []).append(i)
    cmin = cube.min(axis=0) if n else np.zeros(3, dtype=np.int64)
    cmin[periodic] = 0
    extent = (cube.max(axis=0) - cmin + 1) if n else np.ones(3, dtype=np.int64)
    extent[periodic] = nblock[periodic]
    order = sorted(groups, key=lambda c: ((c[0] - cmin[0]) * extent[1] + c[1] - cmin[1])
                   * extent[2] + c[2] - cmin[2])
    members = [groups[c] for c in order]
    assert blocks.block_ptr.tolist() == np.cumsum([0] + [len(m) for m in members]).tolist()
    assert blocks.member.tolist() == [i for m in members for i in m]

    def near(a, b):
        d = np.abs(np.subtract(a, b))
        d = np.where(periodic, np.minimum(d, nblock - d), d)
        return bool(np.all(d <= 1))

    expected = [[v for v in range(u, len(order)) if near(order[u], order[v])]
                for u in range(len(order))]
    got = [blocks.pair_block[blocks.pair_ptr[u]:blocks.pair_ptr[u + 1]].tolist()
           for u in range(len(order))]
    assert got == expected
    assert blocks.spread_sq == pytest.approx((side - (cut - skin)) ** 2)
