"""Deformable-particle hopper against the soft-particle hopper: cost per vertex-step and per
particle-step on the same machine, in one run.

Builds the seed-003 2D hopper of ``n`` bodies (default 1600, the seed's size) on the authors'
convention in the drag limit (lambda = inf), three times: soft particles (``sp``: 1600
disks), rough and smooth deformable rings (``dp_rough`` / ``dp_smooth``: 1600 rings of 16
vertices = 25,600 vertex particles). Each is relaxed (FIRE) and run ``--settle`` t0 once, on
two threads, and its state is saved (in ``--states DIR`` if given, reused when there). The
bodies start as a loose fill and fall at the drag limit's terminal speed, so after the default
6 t0 few of them touch: the script prints the pairs in contact per particle beside the listed
ones (a dense pile costs more per step in every model). Each measurement then loads that
state in a fresh process with the threading layer fixed (``NUMBA_THREADING_LAYER``, default
``omp``), warms the compiled step loop for 200 steps and times ``--steps`` steps, on each of
``--threads`` (default 1 and 2; ``auto`` lets the engine choose), ``--repeat`` times
(median). Prints the CPU, the layer, particle-steps (SP) or vertex-steps (DP) per second, and
the cost of a vertex-step over the cost of an SP particle-step (issue 13 asks <= 2).
``--load N`` runs N busy processes beside every timed measurement (a shared machine; the
guide's "busy as well as idle").

Usage::

    python benchmarks/dp_hopper.py [--n 1600] [--settle 6] [--steps 2000] [--repeat 3]
                                   [--load 0] [--states DIR] [--threads 1,2,auto]
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
from shared import busy_processes  # benchmarks/shared.py, beside this script

REPO = Path(__file__).resolve().parents[1]
KINDS = ("sp", "dp_rough", "dp_smooth")

WORKER = r"""
import json, math, os, pickle, sys, time
from pathlib import Path
from grainflow.frame import PAIR
from grainflow.scenarios.hopper import HopperSection, build_hopper, prepare
kind, n, settle, steps, saved = (sys.argv[1], int(sys.argv[2]), float(sys.argv[3]),
                                 int(sys.argv[4]), Path(sys.argv[5]))
section = HopperSection(convention="authors", particles=kind, n=n, orifice_width=6.0,
                        lam=math.inf)
sim = build_hopper(section, 2, seed=0)
sim.threads = "auto" if sys.argv[6] == "auto" else int(sys.argv[6])
sim.fast_path_min_steps = 0
if not saved.is_file():  # the settle phase: run the fill --settle t0, save the state
    prepare(sim)
    sim.run(int(settle / sim.dt))
    saved.write_bytes(pickle.dumps(sim.state_dict()))
    print(json.dumps({"settled": sim.time,
                      "pairs_per_particle": sim.neighbors.n_pairs / sim.state.n}))
    sys.exit()
sim.load_state_dict(pickle.loads(saved.read_bytes()))
sim.run(200)  # compiles (or loads) and warms the step loop
touching = int((sim.contacts().kind == PAIR).sum())
builds = sim.rebuilds
t0 = time.perf_counter()
sim.run(steps)
wall = time.perf_counter() - t0
print(json.dumps({"per_s": sim.state.n * steps / wall, "particles": sim.state.n,
                  "dt": sim.dt, "steps_per_s": steps / wall, "rebuilds": sim.rebuilds - builds,
                  "pairs_per_particle": sim.neighbors.n_pairs / sim.state.n,
                  "touching_per_particle": touching / sim.state.n}))
"""


def measure(kind: str, n: int, settle: float, steps: int, threads: int | str, layer: str,
            saved: Path) -> dict:
    """One run in a fresh process; ``threads``: a count, or "auto" (the engine's choice among
    the machine's cores, :attr:`Simulation.threads`)."""
    cores = str(os.cpu_count() if threads == "auto" else threads)
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"), NUMBA_NUM_THREADS=cores,
               OMP_NUM_THREADS=cores, NUMBA_THREADING_LAYER=layer)
    out = subprocess.run([sys.executable, "-c", WORKER, kind, str(n), str(settle), str(steps),
                          str(saved), str(threads)], env=env, capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=1600, help="bodies (disks or rings)")
    ap.add_argument("--settle", type=float, default=6.0, help="t0 run before timing")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--layer", default="omp", help="numba threading layer (omp, tbb, workqueue)")
    ap.add_argument("--load", type=int, default=0, help="busy processes beside the timed runs")
    ap.add_argument("--states", type=Path, help="keep (or reuse) the settled states here")
    ap.add_argument("--threads", default="1,2",
                    help="thread counts to time, comma-separated; 'auto' is the engine's choice")
    args = ap.parse_args(argv)
    results: dict = {"cpu": cpu_model(), "layer": args.layer, "n": args.n, "steps": args.steps,
                     "settle_t0": args.settle, "load": args.load}
    with tempfile.TemporaryDirectory() as tmp:
        where = args.states or Path(tmp)
        where.mkdir(parents=True, exist_ok=True)
        states = {kind: where / f"{kind}_n{args.n}_t{args.settle:g}.pkl" for kind in KINDS}
        for kind in KINDS:
            if not states[kind].is_file():
                results[f"{kind}_settled"] = measure(kind, args.n, args.settle, args.steps, 2,
                                                     args.layer, states[kind])
        with busy_processes(args.load, 7200):
            timed(args, states, results)
    print(f"2D hopper, {args.n} bodies, drag limit, after {args.settle:g} t0, {args.steps} "
          f"timed steps, {results['cpu']}, threading layer {args.layer}, busy processes "
          f"{args.load}, median of {args.repeat}")
    print(f"{'model':<11}{'threads':>8}{'particles':>11}{'listed pairs/particle':>23}"
          f"{'touching':>10}{'M (vertex/particle)-steps/s':>30}{'cost / SP':>11}")
    for threads in thread_choices(args.threads):
        sp = results[f"sp_{threads}"]["per_s"]
        for kind in KINDS:
            r = results[f"{kind}_{threads}"]
            r["cost_ratio"] = sp / r["per_s"]
            print(f"{kind:<11}{threads:>8}{r['particles']:>11}{r['pairs_per_particle']:>23.2f}"
                  f"{r['touching_per_particle']:>10.3f}{r['per_s'] / 1e6:>30.2f}"
                  f"{r['cost_ratio']:>11.2f}")
    print(json.dumps(results))
    return results


def thread_choices(text: str) -> list[int | str]:
    """``--threads`` as a list: counts, or "auto"."""
    return [t if t == "auto" else int(t) for t in text.split(",")]


def timed(args: argparse.Namespace, states: dict[str, Path], results: dict) -> None:
    """The timed measurements, every model on each of ``--threads``, into ``results``."""
    for threads in thread_choices(args.threads):
        for kind in KINDS:
            runs = [measure(kind, args.n, args.settle, args.steps, threads, args.layer,
                            states[kind]) for _ in range(args.repeat)]
            results[f"{kind}_{threads}"] = {
                "per_s": statistics.median(r["per_s"] for r in runs),
                "all": [r["per_s"] for r in runs], "particles": runs[0]["particles"],
                "dt": runs[0]["dt"], "rebuilds": runs[0]["rebuilds"],
                "pairs_per_particle": runs[0]["pairs_per_particle"],
                "touching_per_particle": runs[0]["touching_per_particle"]}


if __name__ == "__main__":
    main()
