"""Peer benchmark: a wall-dominated 3D hopper discharge, grainflow against LAMMPS.

About 20,000 slightly polydisperse spheres (diameters uniform in [0.9, 1.1], density 6/pi so a
grain of diameter 1 has mass 1; LAMMPS ``lj``-like units, gravity 1 along -z) discharge from
a vertical cylinder (radius 11) through a cone (half angle 30 degrees from the axis) ending in
a circular orifice of diameter 6 at z = 0. Grain-grain contacts are LAMMPS's
``pair gran/hooke/history`` and grain-wall contacts ``fix wall/gran/region hooke/history``
with the same coefficients (kn = 1e4, kt = 2/7 kn, gamma_n = 50, gamma_t = gamma_n / 2,
mu = 0.5, dampflag 1), dt = 1e-3 (about 19 steps per contact of the smallest pair), skin 0.1,
the neighbour list checked every step (LAMMPS ``neigh_modify every 1 delay 0 check yes``).

Usage::

    python3 benchmarks/hopper3d.py [--steps N] [--skip-lammps] [--threads 1,2]
                                   [--workdir DIR] [--profile STEPS]

What runs:

1. The start state, built by grainflow (once; cached in ``--workdir``, default a folder in
   the system's temporary directory, keyed by the parameters): an fcc lattice of the grains
   inside the hopper (lattice spacing 1.11, jittered), the orifice closed by a plane at z = 0,
   settled under gravity until the kinetic energy is below 1e-4 per grain (``m g d`` units);
   written as a LAMMPS ``atom_style sphere`` data file (positions, diameters, densities,
   velocities and spins to full precision, by grainflow's ``write_lammps_data``) that *both*
   codes read back.
2. The orifice opened: for each worker count, grainflow (a fresh process, ``NUMBA_NUM_THREADS``
   and ``NUMBA_THREADING_LAYER=omp`` set before numba starts, the simulation's ``threads``
   fixed to that count rather than ``"auto"``) and LAMMPS (``lmp``, 1 rank, and
   ``mpirun -np 2 lmp``, deck ``benchmarks/lammps/in.hopper3d``) run 50 warm-up steps, then
   ``--steps`` measured steps. grainflow's figure is the measured steps' particle-steps over
   their wall time, LAMMPS's the same over its own "Loop time" of the second ``run``. The
   particle count falls as grains leave, so both count particle-steps as the sum of the
   particle count over the steps (grainflow's own counter; LAMMPS: from its thermo rows,
   every 100 steps).
3. A physics check: the number of grains discharged (centre below the orifice plane, deleted
   or not yet) and the translational kinetic energy after the same 50 + ``--steps`` steps in
   both codes (chaotic flow: they agree statistically, within ~10-20 %, not bitwise), and
   grainflow's particle-wall contact count at the start.

The same work in both codes:

* Walls. One unbounded cylinder (LAMMPS: ``region cylinder ... INF INF``, whose end caps never
  touch a grain; grainflow: :class:`~grainflow.walls.Cylinder` with no axial range) and the
  cone, built in grainflow by :meth:`~grainflow.walls.Cone.from_lammps` from the deck's
  ``region cone`` arguments, both ends open (LAMMPS ``open 1 open 2``). Each wall keeps its
  own contact history per grain in both codes. LAMMPS's ``fix wall/gran`` uses the grain's
  mass as the effective mass (the wall is infinitely heavy) and the pair's formulas with the
  wall as the second body of radius 0; grainflow's wall contact is the same (``meff = m_i``,
  the same hooke + viscous + history law as the pairs, which matches ``gran/hooke/history``
  statement by statement).
* Geometry details that match: the cone's side is the generatrix segment between its two rim
  circles in both codes; an open rim acts on grains on either side of it (LAMMPS: an open
  region computes its interior *and* exterior contacts, and for a point outside the cone's
  z range the nearest point of that segment is the rim; grainflow: open rims act from every
  side). What differs: LAMMPS's open cone also pushes a grain whose centre got *behind* the
  cone's side (outside the region) back outwards, where grainflow's side acts only on the
  inside; no grain gets there (it would take an overlap of a full radius), so the runs do
  the same work.
* Deletion. A grain is deleted once it has fallen ``sink`` = 3 diameters below the orifice:
  LAMMPS's box ends there (``boundary f``, ``thermo_modify lost ignore``; a grain outside the
  box is dropped at the next re-neighbouring, which the falling grains cause every ~15
  steps), grainflow's :class:`~grainflow.insertion.DeleteRegion` runs every 100 steps on the
  same plane. The falling stream below the orifice is a few tens of grains out of 20,000
  either way, free-falling, without contacts. Why not every 15 steps: each deletion costs
  grainflow a list rebuild and an extra read-only force evaluation (its engine re-evaluates
  the forces after the particle set changes; ~20 ms at 20,000 grains, some 5 steps), where
  LAMMPS drops lost grains for free while re-neighbouring; every 20 steps made grainflow's
  run ~7 % slower than every 200 (67 against 13 deletions in 4050 steps).
* Contact histories are not in a data file: both codes start the run with none (the same).
* What is not the same work, by design of the codes: LAMMPS's two wall fixes test every grain
  at every step (region match and surface distance), grainflow's wall loop visits only the
  grains within reach + skin of a wall (listed at each neighbour-list build).
* The flow starts from rest at step 0 (the orifice opens): the first grains leave after
  ~2.5 time units; with the default 4000 + 50 steps (4.05 time units) about 85 have left.
* LAMMPS is given its usual help: ``balance 1.1 shift z`` once after reading the data (the two
  ranks split the tall box along z), ``newton off`` as its chute benchmark.

Each grainflow measurement runs in a fresh subprocess; LAMMPS's figure is its own "Loop time".
``--profile STEPS`` also runs grainflow under cProfile on one thread for that many steps and
prints the functions with the largest own time, twice: as measured (runs of steps between
two events go through grainflow's compiled step loop, one call), and with that loop switched
off, where each numba kernel appears as the Python call that launches it. The last line
printed is JSON.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chute import cpu_model, print_speed_table  # benchmarks/chute.py, beside this script

HERE = Path(__file__).resolve().parent
DECK = HERE / "lammps" / "in.hopper3d"

#: numba's threading layer for every measurement, set in each worker's environment (Debian's
#: lammps package brings libtbb, which numba would otherwise pick).
LAYER = "omp"

#: Steps between the discharged counts both codes record for the physics check (LAMMPS's
#: thermo interval; grainflow's observer runs with its deletion, every 100 steps as well).
SERIES_EVERY = 100


@dataclass(frozen=True)
class Hopper:
    """The benchmark's parameters (lengths in grain diameters, ``g = 1``, mass ~ 1)."""

    n: int = 20_000  #: grains
    radius: float = 11.0  #: cylinder radius R
    orifice: float = 6.0  #: orifice diameter D
    half_angle: float = 30.0  #: cone half angle from the axis, degrees
    dmin: float = 0.9  #: grain diameters uniform in [dmin, dmax]
    dmax: float = 1.1
    density: float = 6.0 / math.pi  #: a grain of diameter 1 has mass 1
    kn: float = 1.0e4
    kt: float = 2.0 / 7.0 * 1.0e4
    gamma_n: float = 50.0
    gamma_t: float = 25.0
    mu: float = 0.5
    dampflag: int = 1  #: LAMMPS's dampflag (0: gamma_t = 0)
    dt: float = 1.0e-3
    skin: float = 0.1
    sink: float = 3.0  #: grains are deleted this far below the orifice
    spacing: float = 1.11  #: fcc nearest-neighbour distance of the initial lattice
    seed: int = 2024
    settle_max_steps: int = 40_000
    settle_quiet: float = 1.0e-4  #: settled when the kinetic energy per grain is below this

    @property
    def r_orifice(self) -> float:
        return 0.5 * self.orifice

    @property
    def z_orifice(self) -> float:
        return 0.0

    @property
    def z_junction(self) -> float:
        """Height where the cone meets the cylinder."""
        return (self.radius - self.r_orifice) / math.tan(math.radians(self.half_angle))

    @property
    def gamma_t_used(self) -> float:
        """gamma_t as both codes apply it (LAMMPS zeroes it when dampflag is 0)."""
        return self.gamma_t if self.dampflag else 0.0

    def key(self) -> str:
        """A short hash of every parameter (the cache key of the start state)."""
        text = json.dumps(dataclasses.asdict(self), sort_keys=True)
        return hashlib.sha1(text.encode()).hexdigest()[:12]

    def lammps_region_cone(self) -> tuple[str, float, float, float, float, float, float]:
        """The deck's ``region cone`` arguments: ``dim c1 c2 radlo radhi lo hi``."""
        return ("z", 0.0, 0.0, self.r_orifice, self.radius, self.z_orifice, self.z_junction)

    def lammps_vars(self) -> dict[str, str]:
        """``-var`` values for ``in.hopper3d`` (17 significant digits)."""
        g = "{:.17g}".format
        return {"kn": g(self.kn), "kt": g(self.kt), "gamman": g(self.gamma_n),
                "gammat": g(self.gamma_t), "mu": g(self.mu), "dampflag": str(self.dampflag),
                "dt": g(self.dt), "skin": g(self.skin), "R": g(self.radius),
                "ro": g(self.r_orifice), "zo": g(self.z_orifice), "zj": g(self.z_junction)}


# ----------------------------------------------------------------------------- grainflow side
def hopper_law(h: Hopper):
    """``gran/hooke/history`` (and ``wall/gran hooke/history``) with the deck's coefficients,
    for type 0 (grains) and type 1 (the walls)."""
    from grainflow.models.base import ContactLaw

    law = ContactLaw(n_types=2, normal="hooke", damping="viscous", tangential="history")
    law.set_all(kn=h.kn, kt=h.kt, gamma_n=h.gamma_n, gamma_t=h.gamma_t_used, mu=h.mu)
    return law


def hopper_walls(h: Hopper, closed: bool = False) -> list:
    """The cylinder and the cone (``Cone.from_lammps`` on the deck's ``region cone``
    arguments), plus the plane closing the orifice when ``closed``."""
    from grainflow.walls.geometry import Cone, Cylinder, Plane

    walls = [Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), h.radius),
             Cone.from_lammps(*h.lammps_region_cone())]
    if closed:
        walls.append(Plane((0.0, 0.0, h.z_orifice), (0.0, 0.0, 1.0)))
    return walls


def lattice_start(h: Hopper) -> tuple[np.ndarray, np.ndarray]:
    """The ``h.n`` lowest sites of a jittered fcc lattice (nearest-neighbour distance
    ``h.spacing``) that lie inside the closed hopper with a grain of the largest diameter
    clear of every wall, and the grains' diameters: ``(x (n, 3), diameter (n,))``."""
    rng = np.random.default_rng(h.seed)
    rmax = 0.5 * h.dmax
    jitter = 0.2 * (h.spacing - h.dmax)
    clear = rmax + jitter + 0.01  # centre to wall, at least
    a = h.spacing * math.sqrt(2.0)  # conventional cell
    basis = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]]) * a
    tan_a = math.tan(math.radians(h.half_angle))
    cos_a = math.cos(math.radians(h.half_angle))
    height = h.z_junction + 2.0 * h.n * h.spacing**3 / math.sqrt(2.0) / (math.pi * h.radius**2)
    while True:
        m = int(math.ceil(2.0 * h.radius / a)) + 1
        k = int(math.ceil(height / a)) + 1
        grid = np.stack(np.meshgrid(np.arange(m), np.arange(m), np.arange(k), indexing="ij"),
                        -1).reshape(-1, 3) * a
        pts = (grid[:, None, :] + basis[None, :, :]).reshape(-1, 3)
        pts[:, :2] -= 0.5 * (m - 1) * a
        pts[:, 2] += clear
        rho = np.hypot(pts[:, 0], pts[:, 1])
        cone_r = h.r_orifice + (pts[:, 2] - h.z_orifice) * tan_a
        inside = (rho <= h.radius - clear) & (pts[:, 2] >= h.z_orifice + clear)
        inside &= (pts[:, 2] >= h.z_junction) | ((cone_r - rho) * cos_a >= clear)
        pts = pts[inside]
        if len(pts) >= h.n:
            break
        height *= 1.5
    order = np.lexsort((pts[:, 1], pts[:, 0], pts[:, 2]))  # lowest first, deterministic
    x = pts[order[: h.n]] + rng.uniform(-jitter, jitter, (h.n, 3))
    diameter = rng.uniform(h.dmin, h.dmax, h.n)
    return x, diameter


def settle(h: Hopper, x: np.ndarray, diameter: np.ndarray, *, max_steps: int | None = None,
           chunk: int = 1000, log=print) -> dict:
    """Settle the grains in the closed hopper (grainflow) until the kinetic energy per grain
    is below ``h.settle_quiet`` (or ``max_steps``); returns the state as arrays."""
    from grainflow.engine.forces import Gravity
    from grainflow.engine.simulation import Simulation
    from grainflow.frame import Box
    from grainflow.state import ParticleState
    from grainflow.walls.force import WallForce

    lo = np.array([-h.radius - 1.0, -h.radius - 1.0, h.z_orifice - h.sink])
    hi = np.array([h.radius + 1.0, h.radius + 1.0, float(x[:, 2].max()) + 2.0])
    st = ParticleState(3, Box(lo=lo, hi=hi, periodic=(False, False, False)))
    st.add_particles(x, 0.5 * diameter, density=h.density, ids=np.arange(1, h.n + 1))
    max_steps = h.settle_max_steps if max_steps is None else max_steps
    law = hopper_law(h)
    # one thread: robust on a shared machine (two threads beside a busy process run far
    # slower than one), and the settled state does not depend on it
    sim = Simulation(st, h.dt, law, skin=h.skin, threads=1)
    sim.add_force(WallForce(hopper_walls(h, closed=True), law, wall_type=1))
    sim.add_force(Gravity([0.0, 0.0, -1.0]))
    t0 = time.perf_counter()
    ke = math.inf
    while sim.step < max_steps:
        sim.run(min(chunk, max_steps - sim.step))
        ke = sim.state.kinetic_energy() / sim.state.n
        log(f"  settling: step {sim.step}, kinetic energy per grain {ke:.3g}, "
            f"top z = {sim.state.x[:, 2].max():.2f} ({time.perf_counter() - t0:.0f} s)")
        if ke < h.settle_quiet and sim.step >= 2 * chunk:
            break
    order = np.argsort(st.id)
    return {"x": st.x[order].copy(), "v": st.v[order].copy(), "omega": st.omega[order].copy(),
            "diameter": 2.0 * st.radius[order], "ids": st.id[order].copy(),
            "steps": sim.step, "ke_per_grain": ke}


def box_of(h: Hopper, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The box of the benchmark runs: the hopper's width plus a margin, from ``sink`` below
    the orifice (where grains are deleted) to 2 diameters above the top grain."""
    lo = np.array([-h.radius - 1.0, -h.radius - 1.0, h.z_orifice - h.sink])
    hi = np.array([h.radius + 1.0, h.radius + 1.0, float(x[:, 2].max()) + 2.0])
    return lo, hi


def write_lammps_data(path: str | Path, lo, hi, x, diameter, density, v=None, omega=None,
                      ids=None, types=None, title: str = "grainflow hopper3d") -> Path:
    """A LAMMPS ``atom_style sphere`` data file (``Atoms # sphere``: id type diameter density
    x y z ix iy iz; ``Velocities``: id vx vy vz wx wy wz) through grainflow's own writer
    (:func:`grainflow.insertion.lammps_data.write_lammps_data`, every number to full
    precision, so both codes read back the same doubles); written under a temporary name and
    renamed, so an interrupted build never leaves a half-written cache file."""
    from grainflow.insertion.lammps_data import LammpsData
    from grainflow.insertion.lammps_data import write_lammps_data as write

    path = Path(path)
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    data = LammpsData(
        lo=np.asarray(lo, dtype=float), hi=np.asarray(hi, dtype=float),
        id=np.arange(1, n + 1) if ids is None else np.asarray(ids, dtype=np.int64),
        type=np.ones(n, dtype=np.int64) if types is None else np.asarray(types, dtype=np.int64),
        diameter=np.broadcast_to(np.asarray(diameter, dtype=float), (n,)),
        density=np.broadcast_to(np.asarray(density, dtype=float), (n,)), x=x,
        image=np.zeros((n, 3), dtype=np.int64),
        v=np.zeros((n, 3)) if v is None else np.asarray(v, dtype=float),
        omega=np.zeros((n, 3)) if omega is None else np.asarray(omega, dtype=float))
    tmp = path.with_name(path.name + ".tmp")
    write(tmp, data, title=title)
    tmp.replace(path)
    return path


def start_state(h: Hopper, workdir: str | Path | None = None, log=print) -> Path:
    """The settled start state as a LAMMPS data file, built once per parameter set and
    cached in ``workdir`` (default: ``<tmp>/grainflow_hopper3d``)."""
    workdir = Path(workdir) if workdir else Path(tempfile.gettempdir()) / "grainflow_hopper3d"
    workdir.mkdir(parents=True, exist_ok=True)
    path = workdir / f"data.hopper3d.{h.key()}"
    if path.is_file():
        log(f"start state: {path} (cached)")
        return path
    log(f"start state: building {h.n} grains in the closed hopper and settling them "
        "(once; cached)")
    x, diameter = lattice_start(h)
    s = settle(h, x, diameter, log=log)
    lo, hi = box_of(h, s["x"])
    write_lammps_data(path, lo, hi, s["x"], s["diameter"], h.density, s["v"], s["omega"],
                      ids=s["ids"], title=f"grainflow hopper3d start state, settled "
                      f"{s['steps']} steps, {json.dumps(dataclasses.asdict(h))}")
    log(f"start state: {path}")
    return path


def hopper_simulation(h: Hopper, data_path: str | Path, threads: int | str = "auto",
                      sink_every: int = 100):
    """The open hopper read from ``data_path``: grainflow's side of the benchmark
    (``threads``: the simulation's thread count; the benchmark fixes it to the count it
    measures, not ``"auto"``)."""
    from grainflow.engine.forces import Gravity
    from grainflow.engine.simulation import Simulation
    from grainflow.insertion import DeleteRegion, HalfSpace
    from grainflow.insertion.lammps_data import read_lammps_data, state_from_lammps_data
    from grainflow.walls.force import WallForce

    data = read_lammps_data(data_path)
    st = state_from_lammps_data(data, periodic=(False, False, False))
    law = hopper_law(h)
    sim = Simulation(st, h.dt, law, skin=h.skin, threads=threads)
    sim.add_force(WallForce(hopper_walls(h), law, wall_type=1))
    sim.add_force(Gravity([0.0, 0.0, -1.0]))
    sim.add_updater(DeleteRegion(HalfSpace((0.0, 0.0, float(data.lo[2])), (0.0, 0.0, 1.0))),
                    every=sink_every)
    return sim


def warm_up(sim, steps: int) -> None:
    """Run ``steps`` warm-up steps through both code paths the measured run takes: the
    compiled step loop (which runs of at least ``sim.fast_path_min_steps`` steps use;
    compiled or loaded from numba's cache at first use) and the Python path of the steps
    that need a new neighbour list, so every kernel is ready before the clock starts (the
    results are bitwise the same either way)."""
    default = sim.fast_path_min_steps
    sim.fast_path_min_steps = 0
    try:
        sim.run(steps)
    finally:
        sim.fast_path_min_steps = default


WORKER = r"""
import json, os, sys, time
sys.path.insert(0, sys.argv[1])
from hopper3d import Hopper, hopper_simulation, warm_up
from grainflow.frame import WALL
h = Hopper(**json.loads(sys.argv[2]))
data, steps, warmup = sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
# the count measured, not "auto"
sim = hopper_simulation(h, data, threads=int(os.environ["NUMBA_NUM_THREADS"]))
n0 = sim.state.n
in_hopper = []  # (step, grains at or above the orifice plane), as LAMMPS's thermo rows
sim.add_observer(lambda ctx: in_hopper.append(
    (ctx.step, int((ctx.state.x[:, 2] >= h.z_orifice).sum()))), SERIES_EVERY, checked=False)
c = sim.contacts()
wall_contacts = int((c.kind == WALL).sum())
pair_contacts = int(c.i.size) - wall_contacts
warm_up(sim, warmup)
ps0, b0 = sim.particle_steps, sim.neighbors.builds
t0 = time.perf_counter()
sim.run(steps)
wall = time.perf_counter() - t0
wf = sim.forces[0]
print(json.dumps({"n0": n0, "n": sim.state.n, "steps": steps, "wall": wall,
                  "particle_steps": sim.particle_steps - ps0,
                  "builds": sim.neighbors.builds - b0,
                  "wall_contacts_start": wall_contacts, "pair_contacts_start": pair_contacts,
                  "wall_visited_end": len(getattr(wf, "_visit", ())),
                  "deleted": n0 - sim.state.n,
                  "discharged": n0 - int((sim.state.x[:, 2] >= h.z_orifice).sum()),
                  "in_hopper": in_hopper, "ke": sim.state.kinetic_energy()}))
""".replace("SERIES_EVERY", str(SERIES_EVERY))

PROFILE = r"""
import cProfile, json, pstats, sys
sys.path.insert(0, sys.argv[1])
from hopper3d import Hopper, hopper_simulation, warm_up
h = Hopper(**json.loads(sys.argv[2]))
steps = int(sys.argv[4])
out = {}
# "default": the code path of the measured run (the compiled step loop, whatever the profiled
# run's length); "python_path": that loop switched off, so that each kernel is its own
# Python call and shows up in the profile (the same kernels, in the same order; only the
# per-call dispatch differs)
for mode in ("default", "python_path"):
    sim = hopper_simulation(h, sys.argv[3], threads=1)
    warm_up(sim, 50)
    sim.fast_path_min_steps = 0 if mode == "default" else 1 << 62
    pr = cProfile.Profile()
    pr.enable()
    sim.run(steps)
    pr.disable()
    st = pstats.Stats(pr)
    rows = []
    for (f, line, name), (cc, nc, tt, ct, callers) in st.stats.items():
        rows.append({"function": f"{name} ({f.split('/')[-1]}:{line})", "calls": nc,
                     "own_s": tt, "cum_s": ct})
    rows.sort(key=lambda r: -r["own_s"])
    out[mode] = {"total_s": st.total_tt, "top": rows[:15]}
print(json.dumps(out))
"""


def _env(threads: int) -> dict:
    return dict(os.environ, NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads),
                NUMBA_THREADING_LAYER=LAYER)


def run_grainflow(h: Hopper, data: Path, steps: int, threads: int, warmup: int = 50) -> dict:
    out = subprocess.run([sys.executable, "-c", WORKER, str(HERE),
                          json.dumps(dataclasses.asdict(h)), str(data), str(steps), str(warmup)],
                         capture_output=True, text=True, env=_env(threads))
    if out.returncode != 0:
        raise RuntimeError(f"grainflow worker failed:\n{out.stderr[-3000:]}")
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["psps"] = res["particle_steps"] / res["wall"]
    return res


def profile_grainflow(h: Hopper, data: Path, steps: int) -> dict:
    out = subprocess.run([sys.executable, "-c", PROFILE, str(HERE),
                          json.dumps(dataclasses.asdict(h)), str(data), str(steps)],
                         capture_output=True, text=True, env=_env(1))
    if out.returncode != 0:
        raise RuntimeError(f"grainflow profile failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def lammps_command(ranks: int) -> list[str]:
    lmp = shutil.which("lmp") or shutil.which("lmp_serial")
    if lmp is None:
        raise FileNotFoundError("LAMMPS binary 'lmp' not found: apt-get install lammps")
    cmd = [lmp]
    if ranks > 1:
        cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(ranks)] + cmd
    return cmd


def discharge_series(gf: dict, lmp: dict) -> dict:
    """The discharged count of both codes at the steps both recorded (every
    :data:`SERIES_EVERY`), the ratio of their discharge rates over the second half of the
    run (least-squares slopes of the count against the step), and the first step at which
    the counts differ by more than 5 % of LAMMPS's and 3 grains (None: never). A chaotic
    flow makes the two codes part grain by grain; a rate that differs is a difference of
    physics, not of round-off."""
    g = dict(gf["in_hopper"])
    m = dict(lmp["in_hopper"])
    steps = sorted(s for s in set(g) & set(m) if s > 0)
    n0_g, n0_m = gf["n0"], lmp["n0"]
    dg = np.array([n0_g - g[s] for s in steps], dtype=float)
    dm = np.array([n0_m - m[s] for s in steps], dtype=float)
    half = np.array(steps) >= steps[-1] / 2 if steps else np.zeros(0, dtype=bool)
    rate_g = np.polyfit(np.array(steps)[half], dg[half], 1)[0] if half.sum() >= 2 else np.nan
    rate_m = np.polyfit(np.array(steps)[half], dm[half], 1)[0] if half.sum() >= 2 else np.nan
    apart = [s for s, a, b in zip(steps, dg, dm) if abs(a - b) > max(3.0, 0.05 * b)]
    return {"steps": steps, "grainflow": dg.astype(int).tolist(),
            "lammps": dm.astype(int).tolist(),
            "rate_ratio": float(rate_g / rate_m) if rate_m else float("nan"),
            "first_apart": apart[0] if apart else None}


def parse_thermo_blocks(text: str) -> list[list[dict[str, float]]]:
    """Every thermo block of a LAMMPS screen output, as rows of {column: value}."""
    blocks: list[list[dict[str, float]]] = []
    header = None
    for line in text.splitlines():
        words = line.split()
        if words and words[0] == "Step":
            header = words
            blocks.append([])
            continue
        if header is not None:
            if len(words) == len(header) and re.fullmatch(r"-?\d+", words[0]):
                try:
                    blocks[-1].append({k: float(w) for k, w in zip(header, words)})
                except ValueError:
                    header = None
            else:
                header = None
    return blocks


def run_lammps(h: Hopper, data: Path, steps: int, ranks: int, warmup: int = 50,
               thermo: int = SERIES_EVERY, deck: Path = DECK) -> dict:
    """Run the deck on ``data`` and read its last "Loop time", atoms and kinetic energy."""
    cmd = lammps_command(ranks)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        shutil.copy(data, tmp / "data.hopper3d")
        shutil.copy(deck, tmp / "in.hopper3d")
        variables = dict(h.lammps_vars(), datafile="data.hopper3d", warmup=str(warmup),
                         steps=str(steps), thermo=str(thermo))
        cmd = cmd + ["-in", "in.hopper3d", "-log", "none", "-nocite"]
        for k, v in variables.items():
            cmd += ["-var", k, v]
        out = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp)
    if out.returncode != 0:
        raise RuntimeError(f"LAMMPS failed ({out.returncode}):\n{out.stdout[-3000:]}"
                           f"\n{out.stderr[-2000:]}")
    loops = re.findall(r"Loop time of ([\d.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) "
                       r"atoms", out.stdout)
    blocks = parse_thermo_blocks(out.stdout)
    if not loops or len(blocks) < 2:
        raise RuntimeError("could not read LAMMPS's Loop time or thermo:\n" + out.stdout[-3000:])
    wall, _, nsteps, natoms = float(loops[-1][0]), int(loops[-1][1]), int(loops[-1][2]), int(
        loops[-1][3])
    first, last = blocks[0], blocks[-1]
    n0 = int(first[0]["Atoms"])
    # particle-steps of the measured run: the atom count integrated over its steps (thermo
    # rows every `thermo` steps; each interval counted at its end, as grainflow's counter)
    s = np.array([r["Step"] for r in last])
    a = np.array([r["Atoms"] for r in last])
    particle_steps = float(np.sum(np.diff(s) * 0.5 * (a[1:] + a[:-1])))
    # LAMMPS's own breakdown of the measured run: section -> share of the loop time (%)
    tail = out.stdout[out.stdout.rfind("Loop time of"):]
    sections = {m[0]: float(m[1]) for m in re.findall(
        r"^(Pair|Neigh|Comm|Output|Modify|Other)\s*\|.*?\|\s*([\d.]+)\s*$", tail, flags=re.M)}
    in_hopper = sorted({int(r["Step"]): int(r["c_inhopper"]) for block in blocks
                        for r in block}.items())
    return {"wall": wall, "steps": nsteps, "n0": n0, "n": natoms,
            "particle_steps": particle_steps, "psps": particle_steps / wall,
            "deleted": n0 - natoms, "discharged": n0 - int(last[-1]["c_inhopper"]),
            "in_hopper": in_hopper, "ke": last[-1]["KinEng"], "sections": sections}


def machine_load() -> float | None:
    try:
        return os.getloadavg()[0]
    except OSError:
        return None


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=4000,
                    help="measured steps after 50 warm-up steps (default 4000)")
    ap.add_argument("--threads", default="1,2",
                    help="worker counts: grainflow threads and LAMMPS ranks (default 1,2)")
    ap.add_argument("--skip-lammps", action="store_true")
    ap.add_argument("--workdir", type=Path, default=None,
                    help="folder caching the settled start state (default: a folder in the "
                         "system's temporary directory)")
    ap.add_argument("--profile", type=int, default=0, metavar="STEPS",
                    help="also profile grainflow (cProfile, 1 thread) over STEPS steps")
    ap.add_argument("--n", type=int, default=Hopper.n, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    try:
        workers = [int(w) for w in args.threads.split(",") if w.strip()]
    except ValueError:
        ap.error(f"--threads: {args.threads!r} is not a comma-separated list of integers")
    if not workers or min(workers) < 1:
        ap.error("--threads: give worker counts >= 1, e.g. 1,2")
    if args.steps < 1:
        ap.error("--steps: give at least 1 step")

    t_start = time.perf_counter()
    os.environ.setdefault("NUMBA_THREADING_LAYER", LAYER)  # before numba starts (settling)
    load = machine_load()
    if load is not None and load > 0.5:
        print(f"note: load average {load:.2f} > 0.5 (something ran in the last minute or runs "
              "now): the figures may be low and noisy")
    h = dataclasses.replace(Hopper(), n=args.n)
    data = start_state(h, args.workdir)
    results: dict = {"benchmark": "hopper3d", "date": time.strftime("%Y-%m-%d"),
                     "machine": cpu_model(), "cores": os.cpu_count(),
                     "load_before": load, "threading_layer": LAYER,
                     "steps": args.steps, "warmup": 50, "hopper": dataclasses.asdict(h)}
    gf, lm = {}, {}
    for w in workers:
        gf[w] = run_grainflow(h, data, args.steps, w)
        results[f"grainflow_{w}"] = gf[w]["psps"]
    if not args.skip_lammps:
        for w in workers:
            lm[w] = run_lammps(h, data, args.steps, w)
            results[f"lammps_{w}"] = lm[w]["psps"]
            results[f"ratio_{w}"] = gf[w]["psps"] / lm[w]["psps"]
    g1 = gf[workers[0]]
    results["n"] = g1["n0"]
    results["grainflow_wall_contacts_start"] = g1["wall_contacts_start"]
    results["grainflow_pair_contacts_start"] = g1["pair_contacts_start"]
    results["grainflow_list_builds"] = g1["builds"]
    results["grainflow_wall_visited_end"] = g1["wall_visited_end"]
    results["physics"] = {f"grainflow_{w}": {"discharged": r["discharged"],
                                              "deleted": r["deleted"], "ke": r["ke"]}
                          for w, r in gf.items()}
    for w, r in lm.items():
        results["physics"][f"lammps_{w}"] = {"discharged": r["discharged"],
                                             "deleted": r["deleted"], "ke": r["ke"]}
    if lm:
        ref = lm[workers[0]]
        results["physics"]["discharged_rel_diff"] = (
            (g1["discharged"] - ref["discharged"]) / max(ref["discharged"], 1))
        results["physics"]["ke_rel_diff"] = (g1["ke"] - ref["ke"]) / ref["ke"]
        results["physics"]["discharge_series"] = discharge_series(g1, ref)
    for w, r in lm.items():
        results[f"lammps_{w}_sections"] = r["sections"]
    if args.profile:
        results["profile_1_thread"] = profile_grainflow(h, data, args.profile)
    results["wall_s"] = time.perf_counter() - t_start

    print(f"hopper3d benchmark: {g1['n0']} grains, cylinder R = {h.radius:g}, cone half angle "
          f"{h.half_angle:g} deg, orifice D = {h.orifice:g}; {args.steps} steps after 50; "
          f"{results['machine']} ({results['cores']} cores), numba threading layer {LAYER}")
    print_speed_table(results, workers)
    print(f"physics after {50 + args.steps} steps (orifice opened at step 0):")
    for name, p in results["physics"].items():
        if name.startswith(("grainflow_", "lammps_")):
            print(f"  {name:<14} discharged {p['discharged']:>6d} (deleted {p['deleted']:>5d})"
                  f"   kinetic energy {p['ke']:.5g}")
    if lm:
        ph = results["physics"]
        print(f"  grainflow - LAMMPS: discharged {100 * ph['discharged_rel_diff']:+.1f} %, "
              f"kinetic energy {100 * ph['ke_rel_diff']:+.1f} % (the energy is mostly that of "
              f"the few dozen grains falling below the orifice)")
        series = ph["discharge_series"]
        print("  discharged over time (grainflow / LAMMPS, first worker count), step: "
              + ", ".join(f"{s}: {g}/{m}" for s, g, m in zip(series["steps"],
                                                             series["grainflow"],
                                                             series["lammps"])
                          if s % 500 == 0))
        print(f"  discharge rate over the second half: grainflow / LAMMPS "
              f"{series['rate_ratio']:.3f}; counts first differ by more than 5 % (and 3 "
              f"grains) at step {series['first_apart']}")
    print(f"grainflow at the start: {g1['wall_contacts_start']} particle-wall contacts, "
          f"{g1['pair_contacts_start']} pair contacts; {g1['builds']} list builds in "
          f"{args.steps} steps; at the end its wall loop visits {g1['wall_visited_end']} "
          f"grains near a wall (LAMMPS's two region walls test every grain)")
    for w, r in lm.items():
        print(f"LAMMPS {w} rank(s), share of its loop time: "
              + ", ".join(f"{k} {v:.1f} %" for k, v in r["sections"].items()))
    if args.profile:
        for mode, prof in results["profile_1_thread"].items():
            print(f"grainflow profile ({mode}), 1 thread, {args.profile} steps after 50 "
                  f"({prof['total_s']:.2f} s):")
            for r in prof["top"][:10]:
                print(f"  {100 * r['own_s'] / prof['total_s']:5.1f} %  {r['own_s']:7.3f} s  "
                      f"{r['calls']:>7d} calls  {r['function']}")
    print(f"script wall time: {results['wall_s']:.1f} s")
    print(json.dumps(results))
    return results


if __name__ == "__main__":
    main()
