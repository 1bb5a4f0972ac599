"""Cost per particle-step against system size: the chute cut from 1,000 to 128,000 grains.

The LAMMPS chute (``benchmarks/chute.py``) cut to its ``x < f_x Lx, y < f_y Ly`` corner
(:func:`grainflow.scenarios.chute.chute_cut_data`, still periodic) for the small sizes, as
is at 32k, replicated 2 x 2 at 128k. Each size runs in grainflow on 1 thread, 2 threads and
``threads = "auto"`` (each in a fresh process after 50 warm-up steps), and in LAMMPS on 1
and 2 ranks from the same data file (written with
:func:`~grainflow.insertion.lammps_data.write_lammps_data`; 128k is LAMMPS's ``replicate
2 2 1`` of the full chute, the same grains grainflow replicates). Steps per size are chosen
so that each measurement does about ``--work`` particle-steps, at most ``--max-steps`` (the
chute accelerates down its slope; after about 15,000 steps LAMMPS loses a grain of the
smallest cut through the top of its shrink-wrapped box).

Prints a table (ns per particle-step; each size's cost relative to 128k's; grainflow /
LAMMPS speed) and, as its last line, JSON with every figure, the CPU and the threading
layer.

Usage::

    python benchmarks/sizes.py [--work 1e7] [--max-steps 5000] [--sizes 1k,2k,...,128k]
                               [--skip-lammps]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from chute import benchmark_files, cpu_model, run_lammps  # benchmarks/chute.py, beside this

#: Size label -> how the chute is cut (fractions of Lx, Ly) or replicated ("RxR").
SIZES = {"1k": (0.25, 0.16), "2k": (0.25, 0.3), "4k": (0.5, 0.3), "8k": (0.5, 0.5),
         "16k": (1.0, 0.5), "32k": "1x1", "128k": "2x2"}

WORKER = r"""
import json, os, sys, time
from grainflow.scenarios.chute import chute_cut, chute_simulation
size, steps, threads = sys.argv[1], int(sys.argv[2]), sys.argv[3]
if "x" in size:
    rx, ry = (int(v) for v in size.split("x"))
    sim = chute_simulation(replicate=(rx, ry))
else:
    fx, fy = (float(v) for v in size.split(","))
    sim = chute_cut(fx, fy)
sim.threads = threads if threads == "auto" else int(threads)
sim.fast_path_min_steps = 0  # the warm-up and the measured run use the compiled step loop
sim.run(50)
t0 = time.perf_counter()
sim.run(steps)
wall = time.perf_counter() - t0
used = sorted({t for _, t, _ in sim.thread_log})
print(json.dumps({"n": sim.state.n, "steps": steps, "wall": wall, "threads_used": used}))
"""

LAYER = "omp"


def size_arg(spec) -> str:
    return spec if isinstance(spec, str) else f"{spec[0]},{spec[1]}"


def run_grainflow(spec, steps: int, threads: str) -> dict:
    """``threads``: "1", "2" or "auto" (auto chooses between 1 and 2)."""
    cap = "2" if threads == "auto" else threads
    env = dict(os.environ, NUMBA_NUM_THREADS=cap, OMP_NUM_THREADS=cap,
               NUMBA_THREADING_LAYER=LAYER)
    out = subprocess.run([sys.executable, "-c", WORKER, size_arg(spec), str(steps), threads],
                         capture_output=True, text=True, env=env, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["ns_per_particle_step"] = 1e9 * res["wall"] / (res["n"] * res["steps"])
    return res


def lammps_files(spec, tmp: Path, deck: Path, data: Path) -> tuple[Path, Path]:
    """The data file and deck LAMMPS runs for one size."""
    from grainflow.insertion.lammps_data import write_lammps_data
    from grainflow.scenarios.chute import chute_cut_data

    text = deck.read_text()
    if isinstance(spec, str):
        rx, ry = (int(v) for v in spec.split("x"))
        if (rx, ry) != (1, 1):
            text = re.sub(r"^(read_data.*)$", rf"\1\nreplicate\t{rx} {ry} 1", text, flags=re.M)
        out_data = data
    else:
        out_data = write_lammps_data(tmp / f"data.{size_arg(spec)}",
                                     chute_cut_data(spec[0], spec[1], data), n_types=2)
    out_deck = tmp / f"in.{size_arg(spec)}"
    out_deck.write_text(text)
    return out_data, out_deck


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", type=float, default=1e7,
                    help="particle-steps per measurement (sets the steps of each size)")
    ap.add_argument("--max-steps", type=int, default=5000)
    ap.add_argument("--sizes", default=",".join(SIZES))
    ap.add_argument("--layer", default="omp", help="numba threading layer (omp, tbb, workqueue)")
    ap.add_argument("--skip-lammps", action="store_true")
    args = ap.parse_args(argv)
    global LAYER
    LAYER = args.layer
    labels = args.sizes.split(",")
    unknown = [s for s in labels if s not in SIZES]
    if unknown:
        ap.error(f"--sizes: {unknown} not known; choose from {','.join(SIZES)}")
    data, deck = benchmark_files(None)
    results: dict = {"date": time.strftime("%Y-%m-%d"), "machine": cpu_model(),
                     "cores": os.cpu_count(), "threading_layer": LAYER, "work": args.work,
                     "sizes": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for label in labels:
            spec = SIZES[label]
            probe = run_grainflow(spec, 20, "1")
            steps = min(max(100, int(args.work / probe["n"])), args.max_steps)
            row: dict = {"n": probe["n"], "steps": steps}
            for threads in ("1", "2", "auto"):
                r = run_grainflow(spec, steps, threads)
                row[f"grainflow_{threads}"] = r["ns_per_particle_step"]
                if threads == "auto":
                    row["auto_threads_used"] = r["threads_used"]
            if not args.skip_lammps:
                ldata, ldeck = lammps_files(spec, Path(tmp), deck, data)
                for ranks in (1, 2):
                    lm = run_lammps(ldata, ldeck, steps, ranks)
                    row[f"lammps_{ranks}"] = 1e9 / lm["psps"]
            results["sizes"][label] = row
            print(f"  {label}: N={row['n']} done", file=sys.stderr, flush=True)
    ref = results["sizes"].get("128k")
    print(f"chute cut to sizes, {results['machine']} ({results['cores']} cores), numba "
          f"threading layer {LAYER}; ns per particle-step (lower is faster)")
    head = f"{'size':>6}{'N':>8}{'gf 1':>8}{'gf 2':>8}{'gf auto':>9}"
    if not args.skip_lammps:
        head += f"{'lmp 1':>8}{'lmp 2':>8}{'gf/lmp 1':>10}{'gf/lmp 2':>10}"
    if ref:
        head += f"{'1 vs 128k':>11}{'2 vs 128k':>11}"
    print(head)
    for label, row in results["sizes"].items():
        line = (f"{label:>6}{row['n']:>8}{row['grainflow_1']:>8.1f}{row['grainflow_2']:>8.1f}"
                f"{row['grainflow_auto']:>9.1f}")
        if not args.skip_lammps:
            row["speed_ratio_1"] = row["lammps_1"] / row["grainflow_1"]
            row["speed_ratio_2"] = row["lammps_2"] / row["grainflow_2"]
            line += (f"{row['lammps_1']:>8.1f}{row['lammps_2']:>8.1f}"
                     f"{row['speed_ratio_1']:>10.2f}{row['speed_ratio_2']:>10.2f}")
        if ref:
            row["cost_vs_128k_1"] = row["grainflow_1"] / ref["grainflow_1"]
            row["cost_vs_128k_2"] = row["grainflow_2"] / ref["grainflow_2"]
            line += f"{row['cost_vs_128k_1']:>11.2f}{row['cost_vs_128k_2']:>11.2f}"
        print(line)
    print("gf/lmp: grainflow's speed over LAMMPS's (above 1: grainflow faster); "
          "x vs 128k: cost per particle-step over that at 128k")
    print(json.dumps(results))
    return results


if __name__ == "__main__":
    main()
