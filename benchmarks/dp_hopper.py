"""Deformable-particle hopper against the soft-particle hopper: cost per vertex-step and per
particle-step on the same machine, in one run.

Builds the seed-003 2D hopper of ``n`` bodies (default 1600, the seed's size) on the authors'
convention in the drag limit (lambda = inf), three times: soft particles (``sp``: 1600
disks), rough and smooth deformable rings (``dp_rough`` / ``dp_smooth``: 1600 rings of 16
vertices = 25,600 vertex particles). Each is relaxed (FIRE) and run ``--settle`` t0 once, on
two threads, until the pile has landed and flows (the first t0 are a free fall with almost no
contacts, which would flatter the count); its state is saved. Each measurement then loads that
state in a fresh process with the threading layer fixed (``NUMBA_THREADING_LAYER``, default
``omp``), warms the compiled step loop for 200 steps and times ``--steps`` steps, on 1 and 2
threads, ``--repeat`` times (median). Prints the CPU, the layer, particle-steps (SP) or
vertex-steps (DP) per second, and the cost of a vertex-step over the cost of an SP
particle-step (issue 13 asks <= 2).

Usage::

    python benchmarks/dp_hopper.py [--n 1600] [--settle 6] [--steps 2000] [--repeat 3]
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

from chute import cpu_model  # benchmarks/chute.py, beside this script

REPO = Path(__file__).resolve().parents[1]
KINDS = ("sp", "dp_rough", "dp_smooth")

WORKER = r"""
import json, math, os, pickle, sys, time
from pathlib import Path
from grainflow.scenarios.hopper import HopperSection, build_hopper, prepare
kind, n, settle, steps, saved = (sys.argv[1], int(sys.argv[2]), float(sys.argv[3]),
                                 int(sys.argv[4]), Path(sys.argv[5]))
section = HopperSection(convention="authors", particles=kind, n=n, orifice_width=6.0,
                        lam=math.inf)
sim = build_hopper(section, 2, seed=0)
sim.threads = int(os.environ["NUMBA_NUM_THREADS"])
sim.fast_path_min_steps = 0
if not saved.is_file():  # the settle phase: land the pile, save the state
    prepare(sim)
    sim.run(int(settle / sim.dt))
    saved.write_bytes(pickle.dumps(sim.state_dict()))
    print(json.dumps({"settled": sim.time, "pairs_per_particle": sim.neighbors.n_pairs / sim.state.n}))
    sys.exit()
sim.load_state_dict(pickle.loads(saved.read_bytes()))
sim.run(200)  # compiles (or loads) and warms the step loop
builds = sim.rebuilds
t0 = time.perf_counter()
sim.run(steps)
wall = time.perf_counter() - t0
print(json.dumps({"per_s": sim.state.n * steps / wall, "particles": sim.state.n,
                  "dt": sim.dt, "steps_per_s": steps / wall, "rebuilds": sim.rebuilds - builds,
                  "pairs_per_particle": sim.neighbors.n_pairs / sim.state.n}))
"""


def measure(kind: str, n: int, settle: float, steps: int, threads: int, layer: str,
            saved: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"), NUMBA_NUM_THREADS=str(threads),
               OMP_NUM_THREADS=str(threads), NUMBA_THREADING_LAYER=layer)
    out = subprocess.run([sys.executable, "-c", WORKER, kind, str(n), str(settle), str(steps),
                          str(saved)], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=1600, help="bodies (disks or rings)")
    ap.add_argument("--settle", type=float, default=6.0, help="t0 run before timing")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--layer", default="omp", help="numba threading layer (omp, tbb, workqueue)")
    args = ap.parse_args(argv)
    results: dict = {"cpu": cpu_model(), "layer": args.layer, "n": args.n, "steps": args.steps,
                     "settle_t0": args.settle}
    with tempfile.TemporaryDirectory() as tmp:
        states = {kind: Path(tmp) / f"{kind}.pkl" for kind in KINDS}
        for kind in KINDS:
            results[f"{kind}_settled"] = measure(kind, args.n, args.settle, args.steps, 2,
                                                 args.layer, states[kind])
        for threads in (1, 2):
            for kind in KINDS:
                runs = [measure(kind, args.n, args.settle, args.steps, threads, args.layer,
                                states[kind]) for _ in range(args.repeat)]
                results[f"{kind}_{threads}"] = {
                    "per_s": statistics.median(r["per_s"] for r in runs),
                    "all": [r["per_s"] for r in runs], "particles": runs[0]["particles"],
                    "dt": runs[0]["dt"], "rebuilds": runs[0]["rebuilds"],
                    "pairs_per_particle": runs[0]["pairs_per_particle"]}
    print(f"2D hopper, {args.n} bodies, drag limit, after {args.settle:g} t0, {args.steps} "
          f"timed steps, {results['cpu']}, threading layer {args.layer}, median of "
          f"{args.repeat}")
    print(f"{'model':<11}{'threads':>8}{'particles':>11}{'listed pairs/particle':>23}"
          f"{'M (vertex/particle)-steps/s':>30}{'cost / SP':>11}")
    for threads in (1, 2):
        sp = results[f"sp_{threads}"]["per_s"]
        for kind in KINDS:
            r = results[f"{kind}_{threads}"]
            r["cost_ratio"] = sp / r["per_s"]
            print(f"{kind:<11}{threads:>8}{r['particles']:>11}{r['pairs_per_particle']:>23.2f}"
                  f"{r['per_s'] / 1e6:>30.2f}{r['cost_ratio']:>11.2f}")
    print(json.dumps(results))
    return results


if __name__ == "__main__":
    main()
