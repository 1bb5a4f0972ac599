"""The 3D hopper peer benchmark (``benchmarks/hopper3d.py``), at a small size, untimed.

* the start-state builder puts the asked number of grains inside the closed hopper, clear of
  the walls and of each other, with diameters in the asked range;
* the LAMMPS data file the script writes is read back by grainflow's own reader with the same
  positions, diameters, densities, velocities and spins (bit for bit), and the benchmark's
  grainflow simulation reads it with the two walls built from the deck's region arguments;
* with ``lmp`` on PATH: LAMMPS accepts ``benchmarks/lammps/in.hopper3d`` on that file, and
  both codes discharge grains from the same start state, in agreement (same grain count, the
  discharged count and kinetic energy of the same order).
"""

from __future__ import annotations

import dataclasses
import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))
import hopper3d  # noqa: E402

from grainflow.insertion.lammps_data import read_lammps_data  # noqa: E402
from grainflow.walls.geometry import Cone, Cylinder  # noqa: E402

#: A small hopper: 400 grains, cylinder radius 5, orifice diameter 4 (the same law, dt, cone
#: angle and grain sizes as the benchmark's 20,000).
SMALL = dataclasses.replace(hopper3d.Hopper(), n=400, radius=5.0, orifice=4.0,
                            settle_max_steps=3000)


@pytest.fixture(scope="module")
def small_start(tmp_path_factory):
    """The settled small start state, written by the script's own builder."""
    workdir = tmp_path_factory.mktemp("hopper3d")
    path = hopper3d.start_state(SMALL, workdir, log=lambda *a: None)
    return path


def inside_hopper(h: hopper3d.Hopper, x: np.ndarray, clear: np.ndarray) -> np.ndarray:
    """Centres at least ``clear`` from the cylinder, the cone and the orifice plane."""
    rho = np.hypot(x[:, 0], x[:, 1])
    tan_a = math.tan(math.radians(h.half_angle))
    cos_a = math.cos(math.radians(h.half_angle))
    cone_r = h.r_orifice + (x[:, 2] - h.z_orifice) * tan_a
    ok = (rho <= h.radius - clear) & (x[:, 2] >= h.z_orifice + clear)
    return ok & ((x[:, 2] >= h.z_junction) | ((cone_r - rho) * cos_a >= clear))


def test_lattice_start_fills_the_closed_hopper():
    x, diameter = hopper3d.lattice_start(SMALL)
    assert x.shape == (SMALL.n, 3) and diameter.shape == (SMALL.n,)
    assert np.all((diameter >= SMALL.dmin) & (diameter <= SMALL.dmax))
    # every grain clear of the walls and of the closed orifice ...
    assert np.all(inside_hopper(SMALL, x, 0.5 * diameter))
    # ... and of every other grain
    pairs = cKDTree(x).query_pairs(SMALL.dmax, output_type="ndarray")
    gap = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
    assert np.all(gap >= 0.5 * (diameter[pairs[:, 0]] + diameter[pairs[:, 1]]))
    # the cone is filled from the bottom: some grains sit below the junction
    assert np.any(x[:, 2] < SMALL.z_junction)
    # the builder is deterministic
    x2, d2 = hopper3d.lattice_start(SMALL)
    assert np.array_equal(x, x2) and np.array_equal(diameter, d2)


def test_walls_are_the_decks_regions():
    """The cone is ``Cone.from_lammps`` of the deck's ``region cone`` arguments: its surface
    has radius ``ro`` at the orifice and ``R`` at the junction; the cylinder is unbounded."""
    h = hopper3d.Hopper()
    tube, cone = hopper3d.hopper_walls(h)
    assert isinstance(tube, Cylinder) and tube.radius == h.radius
    assert tube.axial_range == (-math.inf, math.inf) and not (tube.lid_lo or tube.lid_hi)
    assert isinstance(cone, Cone) and not (cone.lid_lo or cone.lid_hi)
    assert cone == Cone.from_lammps(*h.lammps_region_cone())
    assert cone.half_angle_deg == pytest.approx(h.half_angle)
    for z, r in ((h.z_orifice, h.r_orifice), (h.z_junction, h.radius),
                 (0.5 * h.z_junction, 0.5 * (h.r_orifice + h.radius))):
        # a point on the axis' side, just inside the surface at height z: closest point at r
        p = np.array([r - 0.3 * math.cos(math.radians(h.half_angle)), 0.0,
                      z + 0.3 * math.sin(math.radians(h.half_angle))])
        cp = cone.closest_point(p)
        assert cp.ok
        if h.z_orifice < z < h.z_junction:
            assert np.allclose(cp.point, [r, 0.0, z], atol=1e-12)
    assert len(hopper3d.hopper_walls(h, closed=True)) == 3
    v = h.lammps_vars()
    assert float(v["zj"]) == h.z_junction and float(v["ro"]) == h.r_orifice


def test_data_file_round_trip(small_start, tmp_path):
    data = read_lammps_data(small_start)
    assert data.id.size == SMALL.n
    assert np.array_equal(data.id, np.arange(1, SMALL.n + 1))
    assert np.all(data.type == 1)
    assert np.all(data.density == SMALL.density)
    assert data.lo[2] == SMALL.z_orifice - SMALL.sink
    # settled: inside the open hopper (overlaps with the walls are tiny) and nearly at rest
    x = data.x
    assert np.all(inside_hopper(SMALL, x, 0.5 * data.diameter - 0.02))
    assert np.all((x >= data.lo) & (x <= data.hi))
    ke = 0.5 * np.sum(SMALL.density * np.pi / 6 * data.diameter**3 * np.sum(data.v**2, axis=1))
    assert ke / SMALL.n < 0.05

    # the writer: what grainflow's reader gives back is what was written, bit for bit
    rng = np.random.default_rng(5)
    n = 37
    x = rng.normal(size=(n, 3)) * 3.0
    d = rng.uniform(0.9, 1.1, n)
    v = rng.normal(size=(n, 3))
    w = rng.normal(size=(n, 3))
    ids = rng.permutation(np.arange(100, 100 + n))
    path = hopper3d.write_lammps_data(tmp_path / "data.test", [-9.0, -9.0, -9.0],
                                      [9.0, 9.0, 9.0], x, d, 6 / np.pi, v, w, ids=ids)
    back = read_lammps_data(path)
    order = np.argsort(ids)
    assert np.array_equal(back.id, ids[order])
    for got, want in ((back.x, x), (back.diameter, d), (back.v, v), (back.omega, w)):
        assert np.array_equal(got, want[order])
    assert np.all(back.density == 6 / np.pi)
    assert np.array_equal(back.lo, [-9.0] * 3) and np.array_equal(back.hi, [9.0] * 3)


def test_benchmark_simulation_reads_the_start_state(small_start):
    sim = hopper3d.hopper_simulation(SMALL, small_start)
    data = read_lammps_data(small_start)
    assert sim.state.n == SMALL.n
    order = np.argsort(sim.state.id)
    assert np.array_equal(sim.state.x[order], data.x)
    assert np.array_equal(2.0 * sim.state.radius[order], data.diameter)
    assert len(sim.walls) == 2
    # the start state is cached: a second call does not settle again
    calls = []
    again = hopper3d.start_state(SMALL, small_start.parent, log=calls.append)
    assert again == small_start and len(calls) == 1 and "cached" in calls[0]


@pytest.mark.skipif(shutil.which("lmp") is None, reason="LAMMPS ('lmp') is not installed")
def test_lammps_accepts_the_deck_and_agrees(small_start):
    steps = 4000  # the orifice opens at step 0; the first grains leave after ~2.5 time units
    lmp = hopper3d.run_lammps(SMALL, small_start, steps, 1, warmup=10)
    gf = hopper3d.run_grainflow(SMALL, small_start, steps, 1, warmup=10)
    assert lmp["n0"] == gf["n0"] == SMALL.n
    assert lmp["steps"] == steps and lmp["wall"] > 0 and lmp["psps"] > 0
    # the same start state and the same model: the same discharge, roughly (chaotic flow)
    assert lmp["discharged"] > 0 and gf["discharged"] > 0
    # discharged: below the orifice plane; deleted: fallen past the box's bottom as well
    assert lmp["discharged"] >= lmp["deleted"] and gf["discharged"] >= gf["deleted"]
    assert 1 / 3 <= gf["discharged"] / lmp["discharged"] <= 3
    assert 0.5 <= gf["ke"] / lmp["ke"] <= 2.0
    assert gf["wall_contacts_start"] > 0
    # the discharge over time: both codes' counts at every 100th step of the run
    series = hopper3d.discharge_series(gf, lmp)
    every = hopper3d.SERIES_EVERY
    assert series["steps"] == list(range(every, steps + 10 + 1, every))
    assert len(series["grainflow"]) == len(series["lammps"]) == len(series["steps"])
    assert abs(series["grainflow"][-1] - gf["discharged"]) <= 5  # 10 steps before the end
    assert abs(series["lammps"][-1] - lmp["discharged"]) <= 5
    assert 1 / 3 <= series["rate_ratio"] <= 3


@pytest.mark.skipif(shutil.which("lmp") is None, reason="LAMMPS ('lmp') is not installed")
def test_grainflow_steps_as_lammps_does_to_round_off(small_start, tmp_path):
    """From the settled pile at rest, with the orifice open, grainflow and LAMMPS
    (``pair gran/hooke/history``, two ``fix wall/gran/region hooke/history`` walls, gravity,
    ``nve/sphere``) step the same trajectory: after 300 steps every grain's position agrees
    to 1e-11 and velocity to 1e-9 (round-off grows to ~1e-13 here), with grains sliding and
    sticking on the cylinder and the cone. (From a start with velocities the two differ at
    the first force evaluation: for a contact without history whose viscous tangential force
    exceeds mu F_n, LAMMPS sets the tangential force to zero where grainflow caps it at
    mu F_n; and LAMMPS recomputes velocity-dependent forces with the current velocities when
    a second ``run`` starts. Both seed the chaotic parting of the benchmark's long runs.)"""
    from grainflow.frame import WALL

    data = read_lammps_data(small_start)
    rest = hopper3d.write_lammps_data(tmp_path / "data.rest", data.lo, data.hi, data.x,
                                      data.diameter, data.density, ids=data.id)
    dump = tmp_path / "final.dump"
    deck = tmp_path / "in.hopper3d"
    deck.write_text(hopper3d.DECK.read_text() + f"\nwrite_dump all custom {dump} id x y z vx vy "
                    "vz modify format float %.17g sort id\n")
    steps = 300
    hopper3d.run_lammps(SMALL, rest, steps, 1, warmup=0, deck=deck)
    sim = hopper3d.hopper_simulation(SMALL, rest, threads=1)
    sim.run(steps)
    contacts = sim.contacts()
    assert np.sum(contacts.kind == WALL) >= 20  # the walls take part
    rows = np.loadtxt(dump, skiprows=9)
    lammps = np.zeros((int(rows[:, 0].max()) + 1, 6))
    lammps[rows[:, 0].astype(int)] = rows[:, 1:7]
    assert rows.shape[0] == sim.state.n == SMALL.n
    ours = np.hstack([sim.state.x, sim.state.v])
    theirs = lammps[sim.state.id]
    assert np.abs(ours[:, :3] - theirs[:, :3]).max() < 1e-11
    assert np.abs(ours[:, 3:] - theirs[:, 3:]).max() < 1e-9
    assert np.abs(sim.state.v).max() > 0.1  # the grains did move
