"""Coarse-graining speed: 100 frames of 20,000 grains on a 50 x 50 grid (issue 14 asks for
under a minute on 2 cores).

Writes two H5MD trajectories once (gzip, as runs write them) in a temporary folder: 2D, 20,000
disks (a jittered triangular lattice, 1.8 contacts per grain listed once, i.e. a coordination
number of 3.6) and 3D, 20,000 spheres (a jittered fcc lattice, 3.4 contacts per grain,
coordination 6.8), each frame with its contact listing. Then, in a fresh process per case
with the threading layer fixed (``NUMBA_THREADING_LAYER``, ``omp`` by default) and 1 or 2
threads, it times the whole job a user runs: read the 100 frames back and coarse-grain them
(kinetic and contact stress, densities, velocity) on

* 2D: a 50 x 50 Cartesian grid, Heaviside bins (exact branch fractions), Gaussian
  (width = one diameter, cutoff 4) and Lucy (cutoff = two diameters);
* 3D: a 50 x 50 cylindrical r-z grid about the packing's axis and a 50 x 50 Cartesian x-z
  grid (y averaged), Heaviside and Gaussian.

The first call of each kernel compiles (or loads numba's cache); a warm-up on one frame runs
before the clock starts, and the read is inside the timing. Prints the CPU, the layer and the
seconds per case (median of ``--repeat``).

``--load N`` runs N busy processes beside every measurement (a shared machine; the guide's
"busy as well as idle"); ``--only`` keeps the cases whose name (e.g. ``3d-cylindrical-gaussian``)
contains the given text.

Usage::

    python benchmarks/cg.py [--frames 100] [--grains 20000] [--repeat 3] [--load 0]
                            [--only 3d-cylindrical]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from chute import LAYER, cpu_model  # benchmarks/chute.py, beside this script
from shared import busy_processes  # benchmarks/shared.py, beside this script

REPO = Path(__file__).resolve().parents[1]

WORKER = r"""
import json, sys, time
import numpy as np
from grainflow.analysis.cg import Cartesian, Cylindrical, Gaussian, Heaviside, Lucy, coarse_grain
from grainflow.io.h5md import read_frame, read_frames
path, dim, kernel_name, grid_name = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
first = read_frame(path, 0)
lo, hi = first.box.lo, first.box.hi
d = 2 * float(first.radius.max())
kernel = {"heaviside": Heaviside(), "gaussian": Gaussian(d), "lucy": Lucy(2 * d)}[kernel_name]
if dim == 2:
    grid = Cartesian.uniform(lo, hi, (50, 50))
elif grid_name == "cartesian":  # x-z map, y averaged
    grid = Cartesian.uniform(lo, hi, (50, 1, 50))
else:
    centre = 0.5 * (lo + hi)
    radius = 0.5 * float(min(hi[0] - lo[0], hi[1] - lo[1]))
    grid = Cylindrical(np.linspace(0, radius, 51), np.linspace(lo[2], hi[2], 51),
                       origin=(centre[0], centre[1], 0.0))
coarse_grain([first], grid, kernel)  # compile / load the cache
t0 = time.perf_counter()
fields = coarse_grain(read_frames(path), grid, kernel, blocks=4)
wall = time.perf_counter() - t0
print(json.dumps({"seconds": wall, "frames": fields.n_frames,
                  "mean_pressure": float(np.nanmean(fields.pressure))}))
"""


def packing(dim: int, n: int, rng: np.random.Generator):
    """Jittered lattice of about ``n`` grains of diameter ~1: positions, radii, box."""
    if dim == 2:
        side = int(np.ceil(np.sqrt(n)))
        i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
        pos = np.column_stack([i.ravel() + 0.5 * (j.ravel() % 2), j.ravel() * np.sqrt(3) / 2])
    else:
        cells = int(np.ceil((n / 4) ** (1 / 3)))
        base = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
        grid = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 3)
        pos = (grid[:, None, :] + base[None]).reshape(-1, 3) * np.sqrt(2)
    pos = pos[:n] + rng.normal(scale=0.02, size=(n, dim))
    radius = rng.uniform(0.49, 0.51, n)
    return pos, radius


def contacts_of(pos: np.ndarray, radius: np.ndarray, rng: np.random.Generator):
    from grainflow.frame import Contacts
    pairs = cKDTree(pos).query_pairs(1.02, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    branch = pos[i] - pos[j]
    touching = np.linalg.norm(branch, axis=1) < radius[i] + radius[j] + 0.01
    i, j, branch = i[touching], j[touching], branch[touching]
    force = branch * rng.uniform(0.5, 1.5, (i.size, 1)) + rng.normal(scale=0.1, size=branch.shape)
    return Contacts(i.astype(np.int64), j.astype(np.int64), force, branch)


def write_trajectory(path: Path, dim: int, n: int, frames: int) -> float:
    """The trajectory a run would leave; returns contacts per grain."""
    from grainflow.frame import Box, Frame
    from grainflow.io.h5md import TrajectoryWriter, max_rows_for
    rng = np.random.default_rng(dim)
    pos0, radius = packing(dim, n, rng)
    box = Box(pos0.min(axis=0) - 1, pos0.max(axis=0) + 1, (False,) * dim)
    per_grain = 0.0
    with TrajectoryWriter(path, dim, box, contacts=True, max_rows=max_rows_for(4 * n)) as out:
        for k in range(frames):
            pos = pos0 + rng.normal(scale=0.01, size=pos0.shape)
            c = contacts_of(pos, radius, rng)
            per_grain = c.i.size / n
            out.append(Frame(step=k, time=float(k), box=box, id=np.arange(n, dtype=np.int64),
                             type=np.zeros(n, np.int32), body=-np.ones(n, np.int64),
                             radius=radius, mass=radius**dim, position=pos,
                             velocity=rng.normal(size=(n, dim)), omega=np.zeros((n, 3)),
                             contacts=c))
    return per_grain


def measure(path: Path, dim: int, kernel: str, grid: str, threads: int) -> dict:
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), NUMBA_THREADING_LAYER=LAYER,
               PYTHONPATH=str(REPO / "src"))
    out = subprocess.run([sys.executable, "-c", WORKER, str(path), str(dim), kernel, grid], env=env,
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--grains", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--load", type=int, default=0, help="busy processes beside the runs")
    parser.add_argument("--only", default="", help="cases whose name contains this text")
    args = parser.parse_args()
    print(f"CPU: {cpu_model()}  cores: {os.cpu_count()}  threading layer: {LAYER}  "
          f"busy processes: {args.load}")
    cases = [(2, "cartesian", "heaviside"), (2, "cartesian", "gaussian"),
             (2, "cartesian", "lucy"), (3, "cylindrical", "heaviside"),
             (3, "cylindrical", "gaussian"), (3, "cartesian", "heaviside"),
             (3, "cartesian", "gaussian")]
    cases = [c for c in cases if args.only in f"{c[0]}d-{c[1]}-{c[2]}"]
    if not cases:
        parser.error(f"--only: no case name contains {args.only!r}")
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for dim in sorted({c[0] for c in cases}):
            paths[dim] = Path(tmp) / f"cg{dim}d.h5"
            per_grain = write_trajectory(paths[dim], dim, args.grains, args.frames)
            print(f"{dim}D trajectory: {args.frames} frames x {args.grains} grains, "
                  f"{per_grain:.2f} contacts per grain, "
                  f"{paths[dim].stat().st_size / 1e6:.0f} MB")
        print(f"{'grid':<26}{'kernel':<11}{'threads':>8}{'seconds':>10}")
        with busy_processes(args.load, 3600):
            for dim, grid_kind, kernel in cases:
                for threads in (1, 2):
                    times = [measure(paths[dim], dim, kernel, grid_kind, threads)["seconds"]
                             for _ in range(args.repeat)]
                    grid = {(2, "cartesian"): "2D 50x50 Cartesian x-y",
                            (3, "cartesian"): "3D 50x50 Cartesian x-z",
                            (3, "cylindrical"): "3D 50x50 cylindrical r-z"}[dim, grid_kind]
                    med = statistics.median(times)
                    results.append({"grid": grid, "kernel": kernel, "threads": threads,
                                    "seconds": med, "runs": times})
                    print(f"{grid:<26}{kernel:<11}{threads:>8}{med:>10.1f}", flush=True)
    print(json.dumps({"cpu": cpu_model(), "layer": LAYER, "frames": args.frames,
                      "grains": args.grains, "load": args.load, "results": results}))


if __name__ == "__main__":
    main()
