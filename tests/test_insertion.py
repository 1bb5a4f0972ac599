"""Insertion and removal (SPEC M8): lattices, thinning, random fills, pour/delete/replenish."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from grainflow.engine.forces import Gravity
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.insertion import (
    IDEAL_PACKING,
    Bidisperse,
    BoxRegion,
    CylinderRegion,
    DeleteRegion,
    DiskRegion,
    HalfSpace,
    Monodisperse,
    Pour,
    ReplenishTo,
    UniformDiameter,
    lattice_fill,
    lattice_points,
    particle_volume,
    random_fill,
    thin_to_packing_fraction,
)
from grainflow.models.granular import GranularLaw
from grainflow.state import ParticleState
from grainflow.walls import Hopper2D, Plane, WallForce


#: one grain or a few gain nothing from threads (see conftest.numba_one_thread)
pytestmark = pytest.mark.usefixtures("numba_one_thread")


def empty_sim(dim: int, law: GranularLaw | None = None) -> Simulation:
    st = ParticleState(dim, Box(np.full(dim, -20.0), np.full(dim, 20.0), (False,) * dim))
    return Simulation(st, 1e-3, law, skin=0.1)


def assert_no_overlap(x: np.ndarray, r: np.ndarray) -> None:
    pairs = cKDTree(x).query_pairs(2 * r.max(), output_type="ndarray")
    if pairs.size:
        d = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
        assert np.all(d >= r[pairs[:, 0]] + r[pairs[:, 1]] - 1e-12)


@pytest.mark.parametrize("kind, region, spacing, margin, count", [
    ("square", BoxRegion((0, 0), (10, 5)), 1.0, 0.5, 50),
    ("triangular", BoxRegion((0, 0), (10, 10)), 1.0, 0.5, 105),
    ("simple_cubic", BoxRegion((0, 0, 0), (4.5, 4.5, 4.5)), 1.0, 0.5, 64),
    ("fcc", BoxRegion((0, 0, 0), (6.25 * math.sqrt(2),) * 3), 1.0, 0.0, 1099),
])
def test_lattice_counts(kind, region, spacing, margin, count):
    pts = lattice_points(region, spacing, kind, margin)
    assert len(pts) == count
    assert np.all(region.contains(pts, margin - 1e-9))
    nearest = cKDTree(pts).query(pts, k=2)[0][:, 1]
    np.testing.assert_allclose(nearest, spacing, rtol=1e-12)


@pytest.mark.parametrize("kind, cell, basis", [
    ("square", (1.0, 1.0), 1), ("triangular", (1.0, math.sqrt(3)), 2),
    ("simple_cubic", (1.0, 1.0, 1.0), 1), ("fcc", (math.sqrt(2),) * 3, 4)])
def test_lattice_packing_fraction_of_touching_grains(kind, cell, basis):
    """Inside a window of n whole cells the count is n^dim * basis, and grains of diameter
    = spacing fill IDEAL_PACKING of it (pi/4, pi/(2 sqrt 3), pi/6, pi/(3 sqrt 2))."""
    dim, n = len(cell), 4
    cell = np.asarray(cell)
    pts = lattice_points(BoxRegion((0,) * dim, tuple(cell * (n + 4))), 1.0, kind)
    lo = 2 * cell - 1e-6
    hi = lo + n * cell
    inside = np.all((pts >= lo) & (pts < hi), axis=1)
    assert inside.sum() == n**dim * basis
    phi = inside.sum() * particle_volume(0.5, dim) / np.prod(hi - lo)
    assert phi == pytest.approx(IDEAL_PACKING[kind], rel=1e-9)


def test_fcc_jet_thinned_to_target_fraction():
    region = CylinderRegion((0.0, 0.0), 4.5, 0.0, 12.0)
    rng = np.random.default_rng(3)
    x = lattice_fill(region, 1.0, "fcc", 0.5, packing_fraction=0.3, rng=rng)
    v = float(particle_volume(0.5, 3))
    assert abs(len(x) * v / region.volume - 0.3) <= 0.5 * v / region.volume
    assert np.all(region.contains(x, 0.5 - 1e-9))
    again = lattice_fill(region, 1.0, "fcc", 0.5, packing_fraction=0.3,
                         rng=np.random.default_rng(3))
    np.testing.assert_array_equal(x, again)
    other = lattice_fill(region, 1.0, "fcc", 0.5, packing_fraction=0.3,
                         rng=np.random.default_rng(4))
    assert not np.array_equal(x, other)


def test_bidisperse_thinning_and_its_limit():
    rng = np.random.default_rng(0)
    region = BoxRegion((0, 0), (40, 40))
    pts = lattice_points(region, 1.1, "triangular", margin=0.5)
    radius = np.where(rng.random(len(pts)) < 0.5, 0.4, 0.5)
    have = particle_volume(radius, 2).sum() / region.volume
    keep = thin_to_packing_fraction(radius, 2, region.volume, 0.4, rng)
    phi = particle_volume(radius[keep], 2).sum() / region.volume
    assert abs(phi - 0.4) <= particle_volume(0.5, 2) / region.volume
    assert np.all(np.diff(keep) > 0)
    with pytest.raises(ValueError, match="packing_fraction"):
        thin_to_packing_fraction(radius, 2, region.volume, have * 1.01, rng)
    with pytest.raises(ValueError, match="kind"):
        lattice_points(region, 1.0, "fcc")


@pytest.mark.parametrize("region, sizes, n", [
    (BoxRegion((0, 0), (12, 12)), Monodisperse(1.0), 60),
    (DiskRegion((1.0, 2.0), 6.0), Bidisperse(0.8, 1.4), 50),
    (CylinderRegion((0.0, 0.0), 3.0, 0.0, 6.0), UniformDiameter(0.6, 1.0), 60),
    (BoxRegion((0, 0, 0), (5, 5, 5)), Bidisperse(1.0), 31),
])
def test_random_fill_has_no_overlaps(region, sizes, n):
    rng = np.random.default_rng(1)
    x, r = random_fill(region, n, sizes, rng)
    assert x.shape == (n, region.dim) and r.shape == (n,)
    assert np.all(region.contains(x, r.min() - 1e-12))
    assert np.all([region.contains(xi[None], ri - 1e-12)[0] for xi, ri in zip(x, r)])
    assert_no_overlap(x, r)
    if isinstance(sizes, Bidisperse):
        small = np.isclose(r, 0.5 * sizes.small_diameter)
        assert abs(int(small.sum()) - n / 2) <= 0.5
        assert np.allclose(r[~small], 0.5 * sizes.small_diameter * sizes.ratio)
    if isinstance(sizes, UniformDiameter):
        assert np.all((r >= 0.3) & (r <= 0.5))


def test_random_fill_respects_existing_grains_and_gives_up_clearly():
    rng = np.random.default_rng(2)
    region = BoxRegion((0, 0), (6, 6))
    old_x, old_r = random_fill(region, 10, Monodisperse(1.0), rng)
    x, r = random_fill(region, 10, Monodisperse(1.0), rng, existing_x=old_x,
                       existing_radius=old_r)
    assert_no_overlap(np.vstack([old_x, x]), np.concatenate([old_r, r]))
    with pytest.raises(ValueError, match="max_attempts"):
        random_fill(region, 60, Monodisperse(1.0), rng, max_attempts=200)
    x, r = random_fill(region, 60, Monodisperse(1.0), rng, max_attempts=200, partial=True)
    assert 10 < len(r) < 60
    assert_no_overlap(x, r)


def test_pour_owes_what_does_not_fit_and_stops_at_total():
    sim = empty_sim(2)
    pour = Pour(BoxRegion((0, 0), (2.2, 2.2)), Monodisperse(1.0), 3, density=1.0,
                velocity=(0.0, -1.0), total=5, max_attempts=500)
    pour.update(sim)
    assert pour.inserted + pour.owed == 3 and pour.inserted >= 1
    pour.update(sim)  # at most 4 unit disks fit in the 2.2 x 2.2 square
    assert pour.inserted == sim.state.n <= 4 and pour.owed == 5 - pour.inserted
    np.testing.assert_allclose(sim.state.velocities, [[0.0, -1.0]] * sim.state.n)
    for _ in range(10):
        sim.state.x[:, 1] -= 10.0  # the grains have fallen away
        pour.update(sim)
    assert pour.done and sim.state.n == 5 and pour.owed == 0
    fresh = Pour(pour.region, pour.sizes, 3, density=1.0, total=5)
    fresh.load_state_dict(pour.state_dict())
    assert fresh.done


def test_pouring_and_deleting_during_a_run():
    law = GranularLaw(1)
    law.set_all(kn=1e3, gamma_n=10.0)
    sim = empty_sim(2, law)
    sim.add_force(Gravity([0.0, -10.0]))
    pour = Pour(BoxRegion((0, 0), (6, 2)), Monodisperse(1.0), 4, density=1.0, total=12)
    sink = DeleteRegion(HalfSpace((0.0, -3.0), (0.0, 1.0)))
    sim.add_updater(pour, every=100)
    sim.add_updater(sink, every=10)
    sim.run(1200)
    assert pour.inserted == 12
    assert sink.removed > 0 and sim.state.n == pour.inserted - sink.removed
    assert np.all(sim.state.x[:, 1] >= -3.0)


def test_replenish_keeps_the_count_and_delete_counts():
    sim = empty_sim(3)
    hopper = CylinderRegion((0.0, 0.0), 3.0, 0.0, 10.0)
    top = CylinderRegion((0.0, 0.0), 3.0, 6.0, 10.0)
    refill = ReplenishTo(hopper, 12, top, Bidisperse(0.8), density=2.0)
    refill.update(sim)
    assert refill.count(sim) == 12 and refill.inserted == 12
    assert np.all(top.contains(sim.state.x))
    sink = DeleteRegion(BoxRegion((-5, -5, 8.0), (5, 5, 10)), outside=False)
    sink.update(sim)
    refill.update(sim)
    assert refill.count(sim) == 12 and refill.inserted == 12 + sink.removed
    assert sink.state_dict() == {"removed": sink.removed}


def test_removing_particles_keeps_wall_history_aligned():
    law = GranularLaw(2)
    law.set_all(kn=1e4, mu=10.0)
    sim = empty_sim(3, law)
    sim.add_particles([[0, 0, 0.5], [3, 0, 0.5], [6, 0, 0.5]], 0.5, density=1.0,
                      v=[[0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0]])
    sim.state.x[:, 2] -= sim.state.mass * 10.0 / 1e4  # resting on the plane under gravity
    sim.add_force(Gravity([0, 0, -10.0]))
    wall = sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))], law, 1))
    sim.run(20)
    hist = sim.state.arrays[wall.name]
    assert hist.shape == (3, 1, law.history_size)
    before = {int(i): h.copy() for i, h in zip(sim.state.id, hist)}
    assert len({float(h[0, 0]) for h in before.values()}) == 3
    sim.remove_particles(sim.state.id == 1)
    for i, h in zip(sim.state.id, sim.state.arrays[wall.name]):
        np.testing.assert_array_equal(h, before[int(i)])
    assert wall.contacts(sim.context)[0].i.tolist() == [0, 1]


def _hopper_with_pour() -> Simulation:
    law = GranularLaw(2)
    law.set_all(kn=2e3, gamma_n=20.0, mu=0.5)
    st = ParticleState(2, Box(np.full(2, -20.0), np.full(2, 20.0), (False, False)))
    sim = Simulation(st, 1e-3, law, skin=0.1, seed=5)
    sim.add_force(Gravity([0.0, -10.0]))
    sim.add_force(WallForce(Hopper2D(6.0, 60.0, 1.8, height=8.0), law, 1))
    sim.add_updater(Pour(BoxRegion((-2.5, 5), (2.5, 7)), Bidisperse(0.8), 3, density=1.0,
                         total=40), every=50)
    sim.add_updater(DeleteRegion(HalfSpace((0, -3.0), (0, 1.0))), every=20)
    return sim


def test_resume_with_walls_pour_and_delete_is_bitwise_identical():
    whole = _hopper_with_pour()
    whole.run(1200)
    saved = whole.state_dict()
    whole.run(1200)
    resumed = _hopper_with_pour()
    resumed.load_state_dict(saved)
    resumed.run(1200)
    assert whole.updaters[1].owner.removed > 0
    assert resumed.updaters[1].owner.removed == whole.updaters[1].owner.removed
    for name, arr in whole.state.arrays.items():
        np.testing.assert_array_equal(resumed.state.arrays[name], arr, err_msg=name)
