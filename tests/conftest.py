"""Shared builders and measurements for the physics validation tests.

The builders make small, fully specified systems (two grains on a line, a random gas, a
settling pile) through the public API only, so each test file reads as a physics statement.

Thread count: most validation tests request :func:`numba_one_thread`. The numba kernels use
OpenMP threads, and on a 2-core machine shared with other jobs two spinning threads make a
step of a small system 10-50 times slower; the physics does not depend on the thread count
(``test_determinism.py`` checks bitwise equality of 1- and 2-thread runs separately).
"""

from __future__ import annotations

import os

# The suite runs in two worker processes on two cores (pyproject's addopts): a test that
# runs two numba threads then shares its cores with the other worker, and GNU OpenMP's
# threads, which spin while they wait, make it many times slower (BENCHMARKS.md, "Shared
# machine"). Passive waiting, set before numba loads the OpenMP library, avoids that; results
# do not depend on it. A value set by the caller is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

import contextlib  # noqa: E402
from pathlib import Path

from dataclasses import dataclass

import numba
import numpy as np
import pytest
from scipy.spatial import cKDTree

from grainflow.engine.forces import Gravity
from grainflow.engine.integrators import Integrator
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.models.base import ContactLaw
from grainflow.models.granular import GranularLaw
from grainflow.scenarios.chute import chute_files
from grainflow.state import ParticleState

#: The LAMMPS chute benchmark files shipped with grainflow (``grainflow/data/chute``).
PEERS = chute_files().data.parent


@contextlib.contextmanager
def one_thread():
    """One numba thread inside the block; the previous count restored afterwards."""
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


@pytest.fixture
def numba_one_thread():
    """Run the test with one numba thread; restore the previous count afterwards."""
    with one_thread():
        yield


# --------------------------------------------------------------------------- two grains
def two_grains(dim: int, law: ContactLaw, *, dt: float, v_rel: float, gap: float,
               radii: tuple[float, float] = (0.5, 0.5),
               masses: tuple[float, float] | None = None, density: float | None = None,
               integrator: Integrator | None = None, skin: float | None = None,
               axis: np.ndarray | None = None) -> Simulation:
    """Two grains approaching head-on along ``axis`` (default x) with zero total momentum.

    ``gap`` is the initial surface gap, ``v_rel`` the approach speed (relative normal
    velocity, positive = approaching). Grain 0 sits at the negative side. Give ``masses``
    or ``density`` (default density 1). The box is large and non-periodic.
    """
    box = Box(lo=np.full(dim, -50.0), hi=np.full(dim, 50.0), periodic=(False,) * dim)
    st = ParticleState(dim, box)
    n = np.zeros(dim)
    if axis is None:
        n[0] = 1.0
    else:
        n = np.asarray(axis, dtype=float)[:dim]
        n = n / np.linalg.norm(n)
    r0, r1 = radii
    half = 0.5 * (r0 + r1 + gap)
    x = np.stack([-half * n, half * n])
    kw = {}
    if masses is not None:
        kw["mass"] = np.asarray(masses, dtype=float)
        m0, m1 = masses
    else:
        rho = 1.0 if density is None else density
        kw["density"] = rho
        vol = (lambda r: np.pi * r**2) if dim == 2 else (lambda r: 4.0 / 3.0 * np.pi * r**3)
        m0, m1 = rho * vol(r0), rho * vol(r1)
    v = np.stack([v_rel * m1 / (m0 + m1) * n, -v_rel * m0 / (m0 + m1) * n])
    st.add_particles(x, np.array([r0, r1]), v=v, **kw)
    return Simulation(st, dt, law, integrator=integrator, skin=skin)


def gap_of(sim: Simulation) -> float:
    """Surface gap between particles 0 and 1 (by id: indices may be re-sorted)."""
    st = sim.state
    i, j = np.argsort(st.id)[:2]
    return float(np.linalg.norm(st.x[j] - st.x[i]) - st.radius[i] - st.radius[j])


def approach_speed(sim: Simulation) -> float:
    """Relative normal velocity of the pair, positive when approaching."""
    st = sim.state
    i, j = np.argsort(st.id)[:2]
    d = st.x[j] - st.x[i]
    n = d / np.linalg.norm(d)
    return float(-np.dot(st.v[j] - st.v[i], n))


@dataclass
class Collision:
    v_in: float
    v_out: float
    t_touch: float
    t_sep: float
    momentum_in: np.ndarray
    momentum_out: np.ndarray
    steps: int

    @property
    def restitution(self) -> float:
        return self.v_out / self.v_in

    @property
    def contact_time(self) -> float:
        return self.t_sep - self.t_touch


def run_collision(sim: Simulation, max_steps: int, after: int = 3) -> Collision:
    """Run a binary collision and measure it.

    Contact start and end are interpolated linearly in the gap within the step where it
    changes sign; the outgoing speed is read ``after`` steps past separation (free flight).
    """
    v_in = approach_speed(sim)
    p_in = sim.state.momentum().copy()
    rec = {"g": gap_of(sim), "t": sim.time, "touch": None, "sep": None, "left": after}

    def watch(s: Simulation) -> None:
        g = gap_of(s)
        g0, t0 = rec["g"], rec["t"]
        if rec["touch"] is None and g < 0.0 <= g0:
            rec["touch"] = t0 + (s.time - t0) * g0 / (g0 - g)
        elif rec["touch"] is not None and rec["sep"] is None and g >= 0.0 > g0:
            rec["sep"] = t0 + (s.time - t0) * (-g0) / (g - g0)
        elif rec["sep"] is not None:
            rec["left"] -= 1
        rec["g"], rec["t"] = g, s.time

    sim.add_observer(watch, every=1)
    step0 = sim.step
    sim.run(max_steps, until=lambda s: rec["left"] <= 0)
    sim.observers.pop()
    assert rec["touch"] is not None, "the grains never touched"
    assert rec["sep"] is not None, "the grains never separated"
    return Collision(v_in, -approach_speed(sim), rec["touch"], rec["sep"], p_in,
                     sim.state.momentum().copy(), sim.step - step0)


# -------------------------------------------------------------------- random packings
def random_nonoverlapping(dim: int, radii: np.ndarray, length: float,
                          rng: np.random.Generator, max_tries: int = 200_000) -> np.ndarray:
    """Random sequential insertion in a periodic cube of side ``length`` (no overlaps)."""
    n = radii.shape[0]
    x = np.empty((n, dim))
    placed = 0
    tries = 0
    while placed < n:
        tries += 1
        if tries > max_tries:
            raise RuntimeError("random_nonoverlapping: box too full")
        p = rng.uniform(0.0, length, dim)
        if placed:
            d = x[:placed] - p
            d -= length * np.rint(d / length)
            near = np.einsum("ij,ij->i", d, d) < (radii[:placed] + radii[placed]) ** 2
            if near.any():
                continue
        x[placed] = p
        placed += 1
    return x


def overlaps(x: np.ndarray, radii: np.ndarray, lengths: np.ndarray | None) -> np.ndarray:
    """Overlaps ``r_i + r_j - |x_i - x_j|`` > 0 of all pairs, by a k-d tree (independent of
    the engine's neighbour list); ``lengths`` makes every axis periodic."""
    if lengths is not None:
        x = np.mod(x, lengths)
        tree = cKDTree(x, boxsize=lengths)
    else:
        tree = cKDTree(x)
    pairs = tree.query_pairs(2.0 * float(radii.max()), output_type="ndarray")
    if pairs.shape[0] == 0:
        return np.zeros(0)
    d = x[pairs[:, 0]] - x[pairs[:, 1]]
    if lengths is not None:
        d -= lengths * np.rint(d / lengths)
    ov = radii[pairs[:, 0]] + radii[pairs[:, 1]] - np.linalg.norm(d, axis=1)
    return ov[ov > 0]


def bidisperse_radii(n: int, rng: np.random.Generator, small: float = 0.5,
                     ratio: float = 1.4) -> np.ndarray:
    """50:50 mixture of radii ``small`` and ``ratio * small`` in random order."""
    r = np.where(np.arange(n) < n // 2, small, ratio * small)
    return rng.permutation(r)


# --------------------------------------------------------------------------- a pile
def two_law_disks(half_width: float, periodic_x: bool, trials: int
                  ) -> tuple[ParticleState, GranularLaw, "SoftLaw"]:
    """Unit disks of types 0 and 1 (alternating) dropped at random without overlap in
    ``[-half_width, half_width] x [0, 30]`` (``trials`` tries, x within 5.5 of the axis), a
    granular law for the box and a soft law (type pair (1, 1)), both for 3 types (the
    third for walls)."""
    from grainflow.models.soft import SoftLaw

    st = ParticleState(2, Box(np.array([-half_width, 0.0]), np.array([half_width, 30.0]),
                              (periodic_x, False)))
    rng = np.random.default_rng(4)
    x = np.c_[rng.uniform(-5.5, 5.5, trials), rng.uniform(1, 28, trials)]
    keep = [0]
    for k in range(1, trials):
        if np.min(np.linalg.norm(x[keep] - x[k], axis=1)) > 1.05:
            keep.append(k)
    x = x[keep]
    st.add_particles(x, 0.5, density=1.0, type=(np.arange(len(x)) % 2).astype(np.int32))
    granular = GranularLaw(3)
    granular.set_all(kn=2e3, gamma_n=10.0, mu=0.4)
    soft = SoftLaw(3)
    soft.set_all(epsilon=200.0, mu_k=1.0)
    return st, granular, soft


def build_pile(n_mobile: int = 300, *, seed: int = 7, integrator: Integrator | None = None,
               sort_every: int = 2, cohesion: bool = True) -> Simulation:
    """A small 3D granular pile: polydisperse frictional (optionally cohesive) grains raining
    onto a frozen rough base, periodic in x and y, under gravity. Dense enough for many
    contacts, mobile enough that the list is rebuilt (and re-sorted) during short runs."""
    rng = np.random.default_rng(seed)
    lx = ly = 6.0
    box = Box(lo=np.zeros(3), hi=np.array([lx, ly, 40.0]), periodic=(True, True, False))
    st = ParticleState(3, box)
    # frozen base: a jittered square grid at z ~ 0
    gx, gy = np.meshgrid(np.arange(6) + 0.5, np.arange(6) + 0.5, indexing="ij")
    base = np.column_stack([gx.ravel(), gy.ravel(), 0.1 * rng.standard_normal(36)])
    st.add_particles(base, 0.5, density=1.0, frozen=True, type=1)
    # mobile grains in a loose column above the base (rejection sampling, no overlaps)
    radii = rng.uniform(0.4, 0.5, n_mobile)
    x = np.empty((n_mobile, 3))
    k = 0
    while k < n_mobile:
        p = np.array([rng.uniform(0, lx), rng.uniform(0, ly),
                      rng.uniform(1.2, 1.2 + n_mobile / 20)])
        if k:
            d = x[:k] - p
            d[:, :2] -= np.array([lx, ly]) * np.rint(d[:, :2] / np.array([lx, ly]))
            if np.any(np.einsum("ij,ij->i", d, d) < (radii[:k] + radii[k]) ** 2):
                continue
        x[k] = p
        k += 1
    v = 0.3 * rng.standard_normal((n_mobile, 3))
    omega = 0.3 * rng.standard_normal((n_mobile, 3))
    st.add_particles(x, radii, density=1.0, v=v, omega=omega, type=0)
    law = GranularLaw(n_types=2)
    law.set_all(kn=2.0e4, gamma_n=30.0, mu=0.5,
                cohesion_force=5.0 if cohesion else 0.0,
                cohesion_range=0.02 if cohesion else 0.0)
    sim = Simulation(st, 4.0e-4, law, integrator=integrator, sort_every=sort_every, seed=seed)
    sim.add_force(Gravity([0.0, 0.0, -2.0]))
    return sim


#: A stream scenario small enough for the default suite (about 600 grains in the hopper):
#: a 1.4 mm aperture, soft contacts (t_c = 200 us), the stream followed to 2 cm.
TINY_STREAM = dict(grain_diameter="200 um", aperture_diameter="1.4 mm",
                   hopper_diameter="2.4 mm", fill_height="1.0 mm", contact_time="200 us",
                   open_time="0.03 s", stream_depth="2 cm", stream_radius="1 cm")


@pytest.fixture(scope="session")
def tiny_stream_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A saved cohesionless tiny stream (:data:`TINY_STREAM`), 0.11 s, frames every 1 ms."""
    from grainflow.runner import run_config

    rundir = tmp_path_factory.mktemp("stream") / "run"
    config = {"scenario": "stream", "dim": 3, "run": {"duration": 0.11, "seed": 3},
              "output": {"thermo_every": 5000, "frames_every": 250, "checkpoint_every": 0,
                         "snapshot": False},
              "stream": dict(TINY_STREAM)}
    with one_thread():
        run_config(config, rundir, progress="none")
    return rundir


#: Six disks colliding in a periodic 2D box for 300 steps: the smallest whole run (the CLI and
#: movie tests add their own ``output`` table).
SIX_DISKS: dict = {
    "dim": 2,
    "run": {"steps": 300},
    "box": {"lo": [0, 0], "hi": [8, 8], "periodic": [True, True]},
    "particles": [{"fill": "list", "positions": [[1, 1], [2.2, 1], [4, 4], [5.2, 4.1],
                                                  [1, 6], [2.3, 6]],
                   "velocities": [[1, 0], [-1, 0], [0.5, 0], [-0.5, 0], [0, 0.2], [0, 0]],
                   "radius": [0.5, 0.55]}],
    "contact": {"law": "granular", "restitution": 0.8, "contact_time": 0.05, "mu": 0.5},
}
