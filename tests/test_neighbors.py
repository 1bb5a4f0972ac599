"""Neighbour search, contact-history bookkeeping and the time-step check.

* The half Verlet list (sparse hashed cells) equals an O(N^2) all-pairs search with the
  minimum image, for polydisperse 2D/3D configurations with any mix of periodic and open
  axes, short periodic axes (2 cells), interaction reach, and the frozen-frozen and
  same-body exclusions.
* Per-pair history survives a list rebuild, a spatial re-sort and deletions, with the
  vector components changing sign when i and j swap roles.
* Memory stays proportional to the number of particles in a tall, mostly empty column.
* dt above t_c/15 warns, above t_c/4 raises :class:`TimeStepError` naming the type pair.
"""

from __future__ import annotations

import copy
import itertools
import tracemalloc
import warnings

import numpy as np
import pytest

from grainflow.engine.neighbor_list import ListGeometry, NeighborList
from grainflow.engine.simulation import Simulation, TimeStepError
from grainflow.frame import Box
from grainflow.kernels import neighbors as nk
from grainflow.models.granular import GranularLaw, restitution_and_contact_time
from grainflow.state import ParticleState

pytestmark = pytest.mark.usefixtures("numba_one_thread")


def _listed_pairs(nl: NeighborList) -> set[tuple[int, int]]:
    rows = np.repeat(np.arange(nl.row_ptr.shape[0] - 1), np.diff(nl.row_ptr))
    return set(zip(rows.tolist(), nl.nbr.tolist()))


def _brute_force(st: ParticleState, geom: ListGeometry, margin: float) -> set[tuple[int, int]]:
    x = st.x
    n = st.n
    i, j = np.triu_indices(n, k=1)
    d = x[i] - x[j]
    for a in range(3):
        if geom.periodic[a]:
            d[:, a] -= geom.length[a] * np.rint(d[:, a] / geom.length[a])
    dist = np.linalg.norm(d, axis=1)
    keep = dist < st.radius[i] + st.radius[j] + margin
    keep &= ~(st.frozen[i] & st.frozen[j])
    keep &= ~((st.body[i] >= 0) & (st.body[i] == st.body[j]))
    return set(zip(i[keep].tolist(), j[keep].tolist()))


def _build(st: ParticleState, skin: float, reach: float) -> tuple[NeighborList, ListGeometry]:
    nl = NeighborList(skin)
    geom = ListGeometry.from_state(st)
    nl.wrap(st, geom)
    cells = nl.cell_order(st, geom, reach)
    nl.build(st, geom, cells)
    return nl, geom


def _random_state(dim, periodic, lengths, n, rng, *, frozen_frac=0.2, bodies=True):
    lo = -0.3 * np.asarray(lengths, dtype=float)
    box = Box(lo=lo, hi=lo + lengths, periodic=tuple(periodic))
    st = ParticleState(dim, box)
    x = lo + rng.uniform(0.0, 1.0, (n, dim)) * lengths
    # open axes: let some particles stray outside the nominal bounds
    for a in range(dim):
        if not periodic[a]:
            x[: n // 10, a] += rng.uniform(-3.0, 3.0, n // 10)
    radii = rng.uniform(0.2, 0.6, n)  # polydisperse
    frozen = rng.uniform(size=n) < frozen_frac
    body = np.full(n, -1)
    if bodies:
        # rigid pairs: particle 2k+1 sits next to 2k in the same body (k < n/4)
        m = n // 4
        body[0:2 * m:2] = np.arange(m)
        body[1:2 * m:2] = np.arange(m)
        x[1:2 * m:2] = x[0:2 * m:2] + rng.uniform(-0.4, 0.4, (m, dim))
    st.add_particles(x, radii, mass=1.0, frozen=frozen, body=body)
    return st


CASES = [
    # dim, periodic, lengths
    (3, (True, True, True), (9.0, 8.0, 7.5)),
    (3, (False, False, False), (8.0, 8.0, 8.0)),
    (3, (True, True, False), (9.0, 9.0, 12.0)),
    (3, (False, True, True), (9.0, 3.0, 9.0)),    # y periodic with only 2 cells
    (3, (True, True, True), (3.0, 3.2, 9.0)),     # x and y with 2 cells each
    (2, (True, True), (14.0, 12.0)),
    (2, (False, False), (14.0, 14.0)),
    (2, (True, False), (3.0, 20.0)),              # short periodic x: 2 cells
    (2, (False, True), (20.0, 4.4)),              # 3 cells
]


@pytest.mark.parametrize("reach", [0.0, 0.07])
@pytest.mark.parametrize("dim, periodic, lengths", CASES)
def test_half_list_equals_brute_force(dim, periodic, lengths, reach):
    rng = np.random.default_rng([dim, int(sum(periodic)), int(10 * sum(lengths)),
                                 int(100 * reach)])
    n = 150 if dim == 2 else 300
    st = _random_state(dim, periodic, np.array(lengths), n, rng)
    skin = 0.15
    nl, geom = _build(st, skin, reach)
    listed = _listed_pairs(nl)
    expected = _brute_force(st, geom, reach + skin)
    assert len(expected) > 50
    assert listed == expected
    # structure: rows sorted ascending with j > i, no duplicates, transpose consistent
    for i in range(st.n):
        row = nl.nbr[nl.row_ptr[i]:nl.row_ptr[i + 1]]
        assert np.all(row > i) and np.all(np.diff(row) > 0)
    for j in range(st.n):
        slots = nl.col_pair[nl.col_ptr[j]:nl.col_ptr[j + 1]]
        assert np.all(nl.nbr[slots] == j)
    assert nl.col_pair.shape[0] == nl.nbr.shape[0]
    # the 2-cell case really is a 2-cell case
    cut = 2 * st.radius.max() + reach + skin
    cells = nl.cell_order(st, geom, reach)
    ncell = cells[5]
    for a in range(dim):
        if periodic[a]:
            assert ncell[a] == int(lengths[a] // cut)
    del cells


def test_exclusions_are_the_only_difference():
    """Without the exclusions the same configuration lists strictly more pairs: the frozen
    and body filters act (the brute-force comparison above is not vacuous for them)."""
    rng = np.random.default_rng(5)
    st = _random_state(3, (True, True, True), np.array([8.0, 8.0, 8.0]), 300, rng,
                       frozen_frac=0.5)
    nl, geom = _build(st, 0.15, 0.0)
    with_excl = _listed_pairs(nl)
    frozen, body = st.frozen.copy(), st.body.copy()
    st.frozen[:] = False
    st.body[:] = -1
    nl2, _ = _build(st, 0.15, 0.0)
    without = _listed_pairs(nl2)
    assert with_excl < without
    removed = without - with_excl
    kinds = {"frozen": 0, "body": 0}
    for i, j in removed:
        is_frozen = bool(frozen[i] and frozen[j])
        is_body = bool(body[i] >= 0 and body[i] == body[j])
        assert is_frozen or is_body
        kinds["frozen"] += is_frozen
        kinds["body"] += is_body
    assert kinds["frozen"] > 10 and kinds["body"] > 10


def test_periodic_axis_too_short_is_refused():
    st = ParticleState(3, Box(lo=np.zeros(3), hi=np.array([1.5, 10.0, 10.0]),
                              periodic=(True, True, True)))
    st.add_particles(np.array([[0.5, 5, 5], [1.2, 5, 5]]), 0.5, mass=1.0)
    nl = NeighborList(0.1)
    with pytest.raises(ValueError, match="axis 0.*enlarge the box"):
        nl.cell_order(st, ListGeometry.from_state(st), 0.0)


def test_unwrapped_positions_on_periodic_axes():
    """Positions several box lengths outside a periodic box are folded by the list (as the
    simulation does before building): same pairs as for the wrapped positions."""
    rng = np.random.default_rng(9)
    st = _random_state(3, (True, True, True), np.array([8.0, 8.0, 8.0]), 200, rng)
    nl, geom = _build(st, 0.15, 0.0)
    ref = _listed_pairs(nl)
    shift = rng.integers(-3, 4, (st.n, 3)) * geom.length
    image0 = st.image.copy()
    st.x[:] += shift
    nl2, _ = _build(st, 0.15, 0.0)
    assert _listed_pairs(nl2) == ref
    np.testing.assert_array_equal(st.image - image0, shift / geom.length)  # image counts kept


# ------------------------------------------------------------------ history bookkeeping
def _history_value(id_i: np.ndarray, id_j: np.ndarray) -> np.ndarray:
    """A known history row for the pair stored as (i, j): vector part antisymmetric
    under i <-> j, flag symmetric, unique per pair."""
    lo = np.minimum(id_i, id_j).astype(float)
    hi = np.maximum(id_i, id_j).astype(float)
    sign = np.sign(id_i - id_j).astype(float)
    base = 1.0 + lo * 1000.0 + hi
    return np.column_stack([sign * base, sign * (base + 0.25), sign * (base + 0.5),
                            1.0 + lo + hi])


def _dense_sim(sort_every: int, seed: int = 4) -> Simulation:
    """Overlapping grains on a jittered lattice (many touching pairs), randomly ordered."""
    rng = np.random.default_rng(seed)
    g = np.arange(8) * 0.95
    x = np.array(list(itertools.product(g, g, g))) + 0.02 * rng.standard_normal((512, 3))
    x = x[rng.permutation(512)]
    st = ParticleState(3, Box(lo=np.zeros(3), hi=np.full(3, 8 * 0.95),
                              periodic=(True, True, True)))
    st.add_particles(x, 0.5, mass=1.0)
    law = GranularLaw()
    # kt = gamma_t = 0 and mu = 0: evaluating forces (update=False) leaves history alone
    law.set_all(kn=1.0e4, kt=0.0, gamma_t=0.0, mu=0.0, cohesion_force=1.0,
                cohesion_range=0.05)
    return Simulation(st, 1e-4, law, sort_every=sort_every)


def _slots(sim: Simulation):
    nl = sim.neighbors
    rows = np.repeat(np.arange(sim.state.n), np.diff(nl.row_ptr))
    return rows, nl.nbr


def _touching(sim: Simulation, rows, cols) -> np.ndarray:
    st = sim.state
    d = st.x[rows] - st.x[cols]
    L = sim.geometry.length
    d -= L * np.rint(d / L)
    return np.linalg.norm(d, axis=1) < st.radius[rows] + st.radius[cols]


def _set_known_history(sim: Simulation) -> set[tuple[int, int]]:
    rows, cols = _slots(sim)
    touch = _touching(sim, rows, cols)
    ids = sim.state.id
    h = sim.interactions[0].history
    h[:] = 0.0
    h[touch] = _history_value(ids[rows[touch]], ids[cols[touch]])
    return {(min(a, b), max(a, b)) for a, b in zip(ids[rows[touch]].tolist(),
                                                   ids[cols[touch]].tolist())}


def _check_history(sim: Simulation, expected_pairs: set[tuple[int, int]]) -> int:
    rows, cols = _slots(sim)
    ids = sim.state.id
    h = sim.interactions[0].history
    found = set()
    flipped = 0
    for k in range(rows.shape[0]):
        a, b = int(ids[rows[k]]), int(ids[cols[k]])
        key = (min(a, b), max(a, b))
        if key in expected_pairs:
            np.testing.assert_array_equal(h[k], _history_value(np.array([a]), np.array([b]))[0])
            found.add(key)
            flipped += a > b
        else:
            assert np.all(h[k] == 0.0)
    assert found == expected_pairs
    return flipped


def test_history_survives_resort_and_rebuild():
    sim = _dense_sim(sort_every=0)  # first build: no sort, particles stay in random order
    sim.compute_forces(update=False)
    expected = _set_known_history(sim)
    assert len(expected) > 500
    order_before = sim.state.id.copy()
    # re-sort: every build sorts (sort_every = 1); a changed generation forces a build
    sim.neighbors.sort_every = 1
    builds = sim.neighbors.builds
    sim.state.generation += 1
    sim.compute_forces(update=False)
    assert sim.neighbors.builds == builds + 1
    assert not np.array_equal(sim.state.id, order_before)  # the particles really moved
    flipped = _check_history(sim, expected)
    assert flipped > 0  # some pairs now stored with i and j swapped: signs were flipped
    # plain rebuild without re-sort (carry by (i, j) match)
    sim.neighbors.sort_every = 0
    order = sim.state.id.copy()
    sim.state.generation += 1
    sim.compute_forces(update=False)
    assert np.array_equal(sim.state.id, order)
    _check_history(sim, expected)


def test_history_follows_arbitrary_permutation_and_deletion():
    sim = _dense_sim(sort_every=0)
    sim.compute_forces(update=False)
    expected = _set_known_history(sim)
    rng = np.random.default_rng(1)
    perm = rng.permutation(sim.state.n)  # old index -> new index
    sim.state.reindex(perm)
    sim.interactions[0].reindex(perm)
    sim.compute_forces(update=False)
    assert _check_history(sim, expected) > 0
    # delete a quarter of the particles: their pairs go, the others keep their values
    gone = rng.uniform(size=sim.state.n) < 0.25
    gone_ids = set(sim.state.id[gone].tolist())
    sim.remove_particles(gone)
    sim.compute_forces(update=False)
    kept = {p for p in expected if p[0] not in gone_ids and p[1] not in gone_ids}
    assert len(kept) < len(expected)
    _check_history(sim, kept)


def test_history_kernels_directly():
    """reindex_pairs flips the flagged components when i and j swap and drops pairs with a
    deleted member or all-zero history; carry_history matches (i, j) by merge."""
    ptr = np.array([0, 2, 3, 3], dtype=np.int64)  # pairs (0,1) (0,2) (1,2)
    nbr = np.array([1, 2, 2], dtype=np.int64)
    hist = np.array([[1.0, 2.0, 3.0, 7.0], [0.0, 0.0, 0.0, 0.0], [4.0, 5.0, 6.0, 8.0]])
    flip = np.array([-1.0, -1.0, -1.0, 1.0])
    # reverse the order: 0 -> 2, 1 -> 1, 2 -> 0
    p2, n2, h2 = nk.reindex_pairs(ptr, nbr, hist, np.array([2, 1, 0]), flip)
    pairs = set(zip(np.repeat(np.arange(3), np.diff(p2)).tolist(), n2.tolist()))
    assert pairs == {(1, 2), (0, 1)}  # (0,2) had zero history: dropped
    rows = np.repeat(np.arange(3), np.diff(p2))
    for k in range(n2.shape[0]):
        if (rows[k], n2[k]) == (1, 2):    # was (1, 0) -> old (0, 1) swapped
            np.testing.assert_array_equal(h2[k], [-1.0, -2.0, -3.0, 7.0])
        else:                             # (0, 1) was old (2, 1) -> old (1, 2) swapped
            np.testing.assert_array_equal(h2[k], [-4.0, -5.0, -6.0, 8.0])
    # delete particle 1
    p3, n3, h3 = nk.reindex_pairs(ptr, nbr, hist, np.array([0, -1, 1]), flip)
    assert n3.shape[0] == 0  # (0,1) and (1,2) lost a member, (0,2) carried nothing
    # carry: new list (0,1) (0,2) (1,2) from old [(0,1), (1,2)] values
    new_ptr = np.array([0, 2, 3, 3], dtype=np.int64)
    new_nbr = np.array([1, 2, 2], dtype=np.int64)
    out = np.full((3, 4), np.nan)
    nk.carry_history(np.array([0, 1, 2, 2], dtype=np.int64), np.array([1, 2], dtype=np.int64),
                     np.array([[1.0, 1, 1, 1], [2.0, 2, 2, 2]]), new_ptr, new_nbr, out)
    np.testing.assert_array_equal(out, [[1, 1, 1, 1], [0, 0, 0, 0], [2, 2, 2, 2]])


def _random_half_list(rng, n, width):
    """A random half list over ``n`` particles (rows ascending, ``i < j``) as CSR."""
    rows = [np.sort(rng.choice(np.arange(i + 1, n), size=min(width, n - i - 1), replace=False))
            if i < n - 1 else np.zeros(0, dtype=np.int64) for i in range(n)]
    rows = [r[rng.uniform(size=r.shape[0]) < 0.6] for r in rows]
    ptr = np.r_[0, np.cumsum([r.shape[0] for r in rows])].astype(np.int64)
    return ptr, np.concatenate(rows).astype(np.int64)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_history_carried_through_a_resort_matches_a_lookup_of_every_pair(seed):
    """carry_history_permuted (scattered from the old pairs with a history) gives every new
    pair what a dictionary of the old pairs, re-expressed in the new indices, holds: the
    flipped components change sign where the two members swap order, pairs new or with an
    all-zero history get zeros, and ``active`` flags exactly the non-zero ones. The new list
    shares only some pairs with the old one, and stale output buffers are overwritten."""
    rng = np.random.default_rng(seed)
    n = 60
    old_ptr, old_nbr = _random_half_list(rng, n, 8)
    hist = rng.normal(size=(old_nbr.shape[0], 4))
    hist[rng.uniform(size=old_nbr.shape[0]) < 0.4] = 0.0  # out of contact
    flip = np.array([-1.0, -1.0, -1.0, 1.0])
    new_to_old = rng.permutation(n)
    new_ptr, new_nbr = _random_half_list(rng, n, 8)
    old_to_new = np.empty(n, dtype=np.int64)
    old_to_new[new_to_old] = np.arange(n)
    carried = {}
    for p in range(n):
        for s in range(old_ptr[p], old_ptr[p + 1]):
            a, b = old_to_new[p], old_to_new[old_nbr[s]]
            carried[(min(a, b), max(a, b))] = hist[s] if a < b else flip * hist[s]
    new_hist = np.full((new_nbr.shape[0], 4), np.nan)
    active = np.full(new_nbr.shape[0], 7, dtype=np.uint8)
    nk.carry_history_permuted(old_ptr, old_nbr, hist, new_to_old, flip, new_ptr, new_nbr,
                              new_hist, active)
    shared = 0
    for a in range(n):
        for k in range(new_ptr[a], new_ptr[a + 1]):
            want = carried.get((a, int(new_nbr[k])), np.zeros(4))
            shared += (a, int(new_nbr[k])) in carried
            np.testing.assert_array_equal(new_hist[k], want)
            assert active[k] == int(np.any(want != 0.0))
    assert 0 < shared < new_nbr.shape[0] and active.sum() > 0


@pytest.mark.parametrize("dim, periodic, lengths", CASES)
def test_rows_that_reach_across_a_periodic_boundary_are_flagged(dim, periodic, lengths):
    """The pair loop skips the minimum image in rows without a pair across a boundary; a row
    left unflagged would lose that pair's force. Checked against the raw differences, and
    the flags must stay right as particles drift up to half the skin and back inside."""
    st = _random_state(dim, periodic, lengths, 300, np.random.default_rng(11))
    nl, geom = _build(st, 0.1, 0.0)
    rows = np.repeat(np.arange(st.n), np.diff(nl.row_ptr))
    raw = np.abs(st.x[rows] - st.x[nl.nbr])
    across = np.any(geom.periodic & (raw > 0.5 * geom.length), axis=1)
    expected = np.zeros(st.n, dtype=np.uint8)
    expected[rows[across]] = 1
    np.testing.assert_array_equal(nl.row_wraps, expected)
    if np.any(geom.periodic[:dim] & (np.asarray(geom.length[:dim]) > 4.0)):
        assert expected.any()
    # after a drift below half the skin, unflagged rows still need no minimum image
    drift = np.random.default_rng(3).uniform(-0.049, 0.049, st.x.shape) / np.sqrt(3)
    x = st.x + drift * ~st.frozen[:, None]
    d = x[rows] - x[nl.nbr]
    folded = d - geom.length * np.rint(d / geom.length) * geom.periodic
    plain = ~nl.row_wraps[rows].astype(bool)
    np.testing.assert_array_equal(folded[plain], d[plain])


@pytest.mark.parametrize("dim, periodic, lengths", CASES)
def test_dense_and_hashed_cell_lookups_give_the_same_table(dim, periodic, lengths):
    """Compact boxes look cells up in a dense array, sparse ones in a hash table; both must
    name the same occupied neighbour cells (strays outside the box make the box sparse)."""
    st = _random_state(dim, periodic, lengths, 300, np.random.default_rng(7))
    nl = NeighborList(0.1)
    geom = ListGeometry.from_state(st)
    nl.wrap(st, geom)
    coords, keys, order, cmin, extent, ncell, offsets, _, _ = nl.cell_order(st, geom, 0.0)
    cell_keys, first = np.unique(keys, return_index=True)
    cell_coords = np.ascontiguousarray(coords[first])
    args = (cell_coords, cell_keys, offsets, cmin, extent, geom.periodic, ncell)
    dense = nk.cell_neighbor_table(*args, dense_limit=np.inf)
    hashed = nk.cell_neighbor_table(*args, dense_limit=0)
    np.testing.assert_array_equal(dense, hashed)
    assert np.sum(dense >= 0) > cell_keys.size  # cells do have occupied neighbours


@pytest.mark.parametrize("reach", [0.0, 0.07])
@pytest.mark.parametrize("dim, periodic, lengths", CASES)
def test_dense_grid_and_hashed_cells_give_the_same_list(monkeypatch, dim, periodic, lengths,
                                                        reach):
    """The dense grid with ghost cells (counting sort, fixed key offsets) and the hashed
    occupied cells must give the same particle order and the same list, which equals the
    all-pairs search; both before and after the particles are re-sorted in cell order."""
    rng = np.random.default_rng([7, dim, int(sum(periodic)), int(100 * reach)])
    st = _random_state(dim, periodic, np.array(lengths), 150 if dim == 2 else 300, rng)
    skin = 0.15
    built = {}
    for limit in (np.inf, 0):
        monkeypatch.setattr(nk, "DENSE_GRID_CELLS_PER_PARTICLE", limit)
        nl = NeighborList(skin)
        geom = ListGeometry.from_state(st)
        nl.wrap(st, geom)
        cells = nl.cell_order(st, geom, reach)
        short = any(periodic[a] and cells.ncell[a] < 3 for a in range(dim))
        assert (cells.start is not None) == (limit == np.inf and not short)
        nl.build(st, geom, cells)
        unsorted = (nl.row_ptr.copy(), nl.nbr.copy())
        moved = copy.deepcopy(st)
        old_to_new = np.empty(st.n, dtype=np.int64)
        old_to_new[cells.order] = np.arange(st.n)
        moved.reindex(old_to_new)
        nl.build(moved, geom, nl.in_new_order(cells))
        built[limit] = (cells.order, unsorted, (nl.row_ptr, nl.nbr))
        assert _listed_pairs(nl) == _brute_force(moved, geom, reach + skin)
    dense, hashed = built[np.inf], built[0]
    np.testing.assert_array_equal(dense[0], hashed[0])
    for a, b in zip(dense[1] + dense[2], hashed[1] + hashed[2]):
        np.testing.assert_array_equal(a, b)


# ------------------------------------------------------------------ sparse tall column
@pytest.mark.parametrize("height_d", [1.0e3, 1.0e7])
def test_tall_sparse_column_memory_is_order_n(monkeypatch, height_d):
    rng = np.random.default_rng(2)
    n = 400
    d = 1.0
    x = np.column_stack([rng.uniform(0, 4, n), rng.uniform(0, 4, n),
                         np.sort(rng.uniform(0, height_d * d, n))])
    # a few clusters so that some pairs exist
    x[1::4] = x[0::4][: x[1::4].shape[0]] + [0.3, 0.0, 0.6]
    st = ParticleState(3, Box(lo=np.zeros(3), hi=np.array([4.0, 4.0, height_d * d]),
                              periodic=(False, False, False)))
    st.add_particles(x, 0.5, mass=1.0)
    tables = []
    real = nk.cell_neighbor_table

    def spy(*args):
        t = real(*args)
        tables.append(t.shape)
        return t

    monkeypatch.setattr(nk, "cell_neighbor_table", spy)
    tracemalloc.start()
    try:
        nl, geom = _build(st, 0.1, 0.0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(tables) == 1
    n_cells, stencil = tables[0]
    assert n_cells <= n and stencil == 27
    # the occupied cells are O(N); the dense grid would have ~height/cell_size x 16 cells
    cells = nl.cell_order(st, geom, 0.0)
    extent = cells[4]
    assert float(np.prod(extent.astype(float))) > 20 * n
    assert peak < 2_000_000, f"peak Python-side allocation {peak} bytes"
    assert nl.nbytes() < 200 * n + 64 * nl.n_pairs
    assert _listed_pairs(nl) == _brute_force(st, geom, 0.1)
    assert nl.n_pairs >= n // 4


# ------------------------------------------------------------------ time-step check
def _timestep_sim(dt: float) -> tuple[Simulation, float]:
    st = ParticleState(3, Box(lo=np.zeros(3), hi=np.full(3, 10.0), periodic=(False,) * 3))
    st.add_particles(np.array([[1.0, 1, 1], [3.0, 1, 1]]), np.array([0.5, 0.3]), mass=1.0,
                     type=np.array([0, 1]))
    law = GranularLaw(n_types=2)
    law.set_pair(0, 0, kn=1e4, gamma_n=10.0)
    law.set_pair(1, 1, kn=1e4, gamma_n=10.0)
    law.set_pair(0, 1, kn=4e4, gamma_n=10.0)  # stiffest pair sets t_c
    tc = restitution_and_contact_time(4e4, 10.0, 0.5, "mass")[1]
    return Simulation(st, dt, law), tc


def test_time_step_check():
    _, tc = _timestep_sim(1.0)
    sim, _ = _timestep_sim(tc / 16)
    assert sim.contact_time() == pytest.approx(tc, rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.check_time_step()
        sim.run(2)
    sim, _ = _timestep_sim(tc / 14)
    with pytest.warns(UserWarning, match=r"oscillation time .* types \(0, 1\) / 15"):
        sim.check_time_step()
    sim, _ = _timestep_sim(tc / 4.1)
    with pytest.warns(UserWarning):
        sim.check_time_step()
    sim, _ = _timestep_sim(tc / 3.9)
    with pytest.raises(TimeStepError, match=r"exceeds the stability limit .* types \(0, 1\)"):
        sim.check_time_step()
    with pytest.raises(TimeStepError):
        sim.run(1)
    assert sim.step == 0
    assert issubclass(TimeStepError, ValueError)
