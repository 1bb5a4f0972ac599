"""Peer benchmark: LAMMPS's granular chute flow, grainflow against LAMMPS on this machine.

Runs the chute (32,000 spheres, gran/hooke/history, frozen base, gravity tilted 26 degrees;
``in.chute`` and ``data.chute.gz`` shipped in ``grainflow/data/chute``) for ``--steps`` steps
with grainflow on 1 and 2 threads and, in the same run, LAMMPS (Debian's ``lmp``) on 1 and 2
MPI ranks with the same deck; then the cost per particle-step of grainflow at about 8k, 32k
and 128k grains (the chute cut to a quarter, as is, and replicated 2 x 2), the memory held per
particle, and the start-up time (import + compile from numba's cache). Prints a table and, as
its last line, JSON.

Usage::

    python benchmarks/chute.py [--steps 2000] [--repeat 3] [--peers DIR] [--skip-lammps]

``--peers DIR`` takes the files from another folder holding ``in.chute`` and ``data.chute``
(or ``data.chute.gz``); LAMMPS gets the data file decompressed in a temporary folder.

Each grainflow figure is measured in a fresh subprocess (so the thread count is set before
numba starts) after 50 warm-up steps; LAMMPS's figure is its own "Loop time". This
machine's speed drifts by 15-25 % within minutes, so each figure is the median of
``--repeat`` rounds, and each ratio the median of the ratios of a grainflow run and a
LAMMPS run taken back to back (which of the two goes first alternates between rounds).
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

WORKER = r"""
import json, os, sys, time
import numpy as np
from grainflow.scenarios.chute import chute_simulation, chute_cut
data, steps, size = sys.argv[1], int(sys.argv[2]), sys.argv[3]
if size == "quarter":
    sim = chute_cut(0.5, 0.5, data)
else:
    rx, ry = (int(v) for v in size.split("x"))
    sim = chute_simulation(data, replicate=(rx, ry))
sim.threads = int(os.environ["NUMBA_NUM_THREADS"])  # the count measured, not "auto"
sim.fast_path_min_steps = 0  # the warm-up and the measured run use the compiled step loop
sim.run(50)
b0 = sim.neighbors.builds
t0 = time.perf_counter()
sim.run(steps)
wall = time.perf_counter() - t0
mem = sim.memory_bytes()
print(json.dumps({"n": sim.state.n, "steps": steps, "wall": wall,
                  "builds": sim.neighbors.builds - b0,
                  "bytes_per_particle": {k: v / sim.state.n for k, v in mem.items()},
                  "ke": sim.state.kinetic_energy()}))
"""

STARTUP = r"""
import time
t0 = time.perf_counter()
import numpy as np
import grainflow
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.models.granular import GranularLaw
from grainflow.state import ParticleState
from grainflow.engine.forces import Gravity
st = ParticleState(3, Box(np.zeros(3), np.full(3, 10.0), (True, True, False)))
st.add_particles([[1, 1, 1], [1, 1, 2.05]], 0.5, density=1.0)
law = GranularLaw(); law.set_all(kn=2e5, gamma_n=50.0, mu=0.5)
sim = Simulation(st, 1e-4, law); sim.add_force(Gravity([0, 0, -1.0]))
sim.run(2)
print(time.perf_counter() - t0)
"""


#: numba's threading layer for every measurement (``--layer``): chosen here, never left to
#: whatever libraries happen to be installed (Debian's lammps brings libtbb, which numba
#: would otherwise pick).
LAYER = "omp"


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``), else what platform reports."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def print_speed_table(results: dict, workers) -> None:
    """The table of ``grainflow_W`` / ``lammps_W`` particle-steps per second (and
    ``ratio_W``) for each worker count ``W``."""
    print(f"{'code':<14}{'workers':>8}{'M particle-steps/s':>22}{'ratio':>8}")
    for code, key in (("grainflow", "grainflow"), ("LAMMPS", "lammps")):
        for w in workers:
            v = results.get(f"{key}_{w}")
            if v is None:
                continue
            ratio = results.get(f"ratio_{w}") if key == "grainflow" else None
            rtxt = f"{ratio:8.2f}" if ratio is not None else ""
            print(f"{code:<14}{w:>8}{v / 1e6:>22.2f}{rtxt}")


def run_grainflow(data: Path, steps: int, threads: int, size: str = "1x1") -> dict:
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads),
               NUMBA_THREADING_LAYER=LAYER)
    out = subprocess.run([sys.executable, "-c", WORKER, str(data), str(steps), size],
                         capture_output=True, text=True, env=env, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["psps"] = res["n"] * res["steps"] / res["wall"]
    return res


def benchmark_files(peers: Path | None) -> tuple[Path, Path]:
    """``(data file, in.chute)``: the shipped copies, or those in ``peers``."""
    if peers is None:
        from grainflow.scenarios.chute import chute_files

        files = chute_files()
        return files.data, files.deck
    data = next((p for p in (peers / "data.chute", peers / "data.chute.gz") if p.is_file()),
                peers / "data.chute")
    return data, peers / "in.chute"


def run_lammps(data: Path, deck_path: Path, steps: int, ranks: int) -> dict:
    lmp = shutil.which("lmp") or shutil.which("lmp_serial")
    if lmp is None:
        raise FileNotFoundError("LAMMPS binary 'lmp' not found: apt-get install lammps")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        with open(data, "rb") as f:
            packed = f.read(2) == b"\x1f\x8b"
        if packed:  # gzip: LAMMPS is given the plain text
            with gzip.open(data, "rb") as src, open(tmp / "data.chute", "wb") as dst:
                shutil.copyfileobj(src, dst)
        else:
            shutil.copy(data, tmp / "data.chute")
        deck = deck_path.read_text()
        deck = re.sub(r"^run\s+\d+", f"run\t\t{steps}", deck, flags=re.M)
        (tmp / "in.chute").write_text(deck)
        cmd = [lmp, "-in", "in.chute", "-log", "none"]
        if ranks > 1:
            cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(ranks)] + cmd
        out = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp, check=True)
    m = re.search(r"Loop time of ([\d.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms",
                  out.stdout)
    if m is None:
        raise RuntimeError("could not read LAMMPS's Loop time:\n" + out.stdout[-2000:])
    wall, _, nsteps, natoms = float(m[1]), int(m[2]), int(m[3]), int(m[4])
    mem = re.search(r"Per MPI rank memory allocation \(min/avg/max\) = [\d.]+ \| ([\d.]+)",
                    out.stdout)
    return {"wall": wall, "psps": natoms * nsteps / wall, "n": natoms,
            "mbytes_per_rank": float(mem[1]) if mem else None}


def startup_seconds() -> float:
    out = subprocess.run([sys.executable, "-c", STARTUP], capture_output=True, text=True,
                         check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--scaling-steps", type=int, default=500)
    ap.add_argument("--peers", type=Path, default=None,
                    help="folder with in.chute and data.chute[.gz] (default: the copies "
                         "shipped in grainflow/data/chute)")
    ap.add_argument("--layer", default="omp", help="numba threading layer (omp, tbb, workqueue)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="rounds of each measurement; the figures are medians, a ratio the "
                         "median of the ratios of runs taken back to back")
    ap.add_argument("--skip-lammps", action="store_true")
    ap.add_argument("--skip-scaling", action="store_true")
    args = ap.parse_args(argv)
    data, deck = benchmark_files(args.peers)
    for path in (data, deck):
        if not path.is_file():
            ap.error(f"--peers: {path} not found (the folder needs in.chute and "
                     "data.chute or data.chute.gz)")

    global LAYER
    LAYER = args.layer
    results: dict = {"date": time.strftime("%Y-%m-%d"), "machine": cpu_model(),
                     "cores": os.cpu_count(), "steps": args.steps, "threading_layer": LAYER}
    results["startup_s"] = startup_seconds()
    runs: dict[str, list[dict]] = {}
    for r in range(args.repeat):
        # each worker count: grainflow and LAMMPS back to back, the first of the two
        # alternating between rounds, so that a drift of the machine's speed hits both
        for w in (1, 2):
            pair = [("grainflow", lambda w=w: run_grainflow(data, args.steps, w))]
            if not args.skip_lammps:
                pair.append(("lammps", lambda w=w: run_lammps(data, deck, args.steps, w)))
            for code, run in (pair if r % 2 == 0 else pair[::-1]):
                runs.setdefault(f"{code}_{w}", []).append(run())
    g1 = runs["grainflow_1"][0]
    for key, values in runs.items():
        results[key] = statistics.median(v["psps"] for v in values)
    results["bytes_per_particle"] = g1["bytes_per_particle"]
    results["list_builds"] = g1["builds"]
    if not args.skip_lammps:
        for w in (1, 2):
            paired = [g["psps"] / lam["psps"] for g, lam in zip(runs[f"grainflow_{w}"],
                                                               runs[f"lammps_{w}"])]
            results[f"ratio_{w}"] = statistics.median(paired)
            results[f"ratios_{w}"] = paired
        results["lammps_mbytes_per_rank"] = runs["lammps_1"][0]["mbytes_per_rank"]
    if not args.skip_scaling:
        scaling = {}
        for label, size in (("8k", "quarter"), ("32k", "1x1"), ("128k", "2x2")):
            r = run_grainflow(data, args.scaling_steps, 2, size)
            scaling[label] = {"n": r["n"], "ns_per_particle_step": 1e9 / r["psps"]}
        costs = [v["ns_per_particle_step"] for v in scaling.values()]
        scaling["spread"] = max(costs) / min(costs) - 1.0
        results["scaling_2_threads"] = scaling

    print(f"chute benchmark, {args.steps} steps, {results['machine']} ({results['cores']} cores), "
          f"numba threading layer {LAYER}")
    print_speed_table(results, (1, 2))
    for w in (1, 2):
        if f"ratios_{w}" in results:
            print(f"ratio on {w} worker(s), each round: "
                  + " ".join(f"{v:.2f}" for v in results[f"ratios_{w}"]))
    if "scaling_2_threads" in results:
        for label, v in results["scaling_2_threads"].items():
            if label != "spread":
                print(f"size {label:>5} (N={v['n']}): {v['ns_per_particle_step']:.1f} ns per "
                      "particle-step (2 threads)")
        print(f"cost spread across sizes: {100 * results['scaling_2_threads']['spread']:.1f} %")
    bpp = results["bytes_per_particle"]
    print("bytes per particle: " + ", ".join(f"{k} {v:.0f}" for k, v in bpp.items())
          + f", total {sum(bpp.values()):.0f}")
    print(f"start-up (import + compile from cache): {results['startup_s']:.2f} s")
    print(json.dumps(results))
    return results


if __name__ == "__main__":
    main()
