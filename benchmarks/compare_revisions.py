"""Speed of this working tree against an earlier revision, in one run, on one machine.

Checks out ``--base`` (a git revision) into a temporary worktree and times ``--case``: the
LAMMPS chute (``chute``: 32,000 spheres, ``--steps`` steps after 50 warm-up steps) or the
2D hopper of ``grainflow demo`` (``hopper2d``: 1600 soft disks, drag limit, walls and
reinsertion, ``--steps`` steps after 500 warm-up steps) or the smooth deformable-ring hopper
of ``dp_hopper.py`` (``dp_smooth``: 1600 rings of 16 vertices, from a landed state given by
``--state``) or any run configuration (``config``: ``--config FILE`` built as ``grainflow run``
builds it, FIRE included, then ``--warmup`` steps, e.g. to steady flow) with both source trees,
alternating them ``--repeat`` times on 1 and 2 threads, each measurement in a fresh process
with the threading layer fixed (``NUMBA_THREADING_LAYER``, default ``omp``). Prints the CPU,
the median particle-steps per second of each, their ratio, and whether the two trees give
the same kinetic energy (bitwise) after the run.

Usage::

    python benchmarks/compare_revisions.py --base 8afff5a [--steps 1000] [--repeat 3]
    python benchmarks/compare_revisions.py --base fba8333 --case hopper2d --steps 10000
    python benchmarks/compare_revisions.py --base HEAD --case dp_smooth --state landed.pkl
    python benchmarks/compare_revisions.py --base HEAD --case config \
        --config benchmarks/hopper_authors2d.toml --warmup 30000 --steps 20000
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from chute import cpu_model  # benchmarks/chute.py, beside this script

REPO = Path(__file__).resolve().parents[1]

#: What each case builds and how long it warms up, in a fresh process (argv: data file, steps).
SETUP = {
    "chute": ("from grainflow.scenarios.chute import chute_simulation\n"
              "sim = chute_simulation(sys.argv[1])\nsim.run(50)\n"),
    "hopper2d": ("import math\n"
                 "from grainflow.scenarios.hopper import HopperSection, build_hopper, prepare\n"
                 "sim = build_hopper(HopperSection(n=1600, orifice_width=10.0, E_sp=1000.0, "
                 "E_w=1000.0, lam=math.inf), 2, seed=0)\nprepare(sim)\nsim.run(500)\n"),
    # --data: a pickled state_dict of this hopper after it has landed (dp_hopper.py's settle)
    "dp_smooth": ("import math, pickle\nfrom pathlib import Path\n"
                  "from grainflow.scenarios.hopper import HopperSection, build_hopper\n"
                  "sim = build_hopper(HopperSection(convention='authors', particles='dp_smooth', "
                  "n=1600, orifice_width=6.0, lam=math.inf), 2, seed=0)\n"
                  "sim.load_state_dict(pickle.loads(Path(sys.argv[1]).read_bytes()))\n"),
    # --config: a run configuration, then --warmup steps (GRAINFLOW_WARMUP)
    "config": ("from grainflow.config.build import build_simulation\n"
               "from grainflow.config.schema import load_config\n"
               "sim = build_simulation(load_config(sys.argv[1]))\n"
               "sim.threads = int(os.environ['NUMBA_NUM_THREADS'])\n"
               "sim.run(int(os.environ['GRAINFLOW_WARMUP']))\n"),
}
TIMED = r"""
sim.threads = int(os.environ["NUMBA_NUM_THREADS"])  # the count measured, not "auto"
sim.fast_path_min_steps = 0  # (older revisions ignore both attributes)
sim.run(50)  # warm up the compiled step loop, where there is one
steps = int(sys.argv[2])
t0 = time.perf_counter()
sim.run(steps)
wall = time.perf_counter() - t0
print(json.dumps({"psps": sim.state.n * steps / wall, "steps_per_s": steps / wall,
                  "ke": sim.state.kinetic_energy()}))
"""


def measure(src: Path, data: Path, steps: int, threads: int, layer: str,
            case: str = "chute", warmup: int = 0) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src), NUMBA_NUM_THREADS=str(threads),
               OMP_NUM_THREADS=str(threads), NUMBA_THREADING_LAYER=layer,
               GRAINFLOW_WARMUP=str(warmup))
    worker = "import json, os, sys, time\n" + SETUP[case] + TIMED
    out = subprocess.run([sys.executable, "-c", worker, str(data), str(steps)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--base", required=True, help="git revision to compare against")
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--layer", default="omp", help="numba threading layer (omp, tbb, workqueue)")
    ap.add_argument("--case", default="chute", choices=sorted(SETUP))
    ap.add_argument("--state", type=Path,
                    help="dp_smooth: the landed hopper's pickled state_dict (write one with "
                         "dp_hopper.py's settle phase)")
    ap.add_argument("--config", type=Path, help="config: the run configuration (TOML)")
    ap.add_argument("--warmup", type=int, default=0,
                    help="config: steps run before the timed ones (default 0)")
    args = ap.parse_args(argv)
    if args.case == "dp_smooth" and (args.state is None or not args.state.is_file()):
        ap.error("--state: the dp_smooth case needs the landed hopper's pickled state_dict")
    if args.case == "config" and (args.config is None or not args.config.is_file()):
        ap.error("--config: the config case needs a run configuration file")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        tree = tmp / "base"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(tree),
                        args.base], check=True, capture_output=True)
        try:
            data = tmp / "data.chute"  # plain text: older readers do not open .gz
            with gzip.open(REPO / "src/grainflow/data/chute/data.chute.gz", "rb") as f:
                data.write_bytes(f.read())
            if args.case == "dp_smooth":
                data = args.state.resolve()
            if args.case == "config":
                data = args.config.resolve()
            trees = {"base": tree / "src", "current": REPO / "src"}
            results: dict = {"case": args.case, "cpu": cpu_model(), "layer": args.layer,
                             "steps": args.steps, "base": args.base}
            for threads in (1, 2):
                runs: dict[str, list[dict]] = {k: [] for k in trees}
                for _ in range(args.repeat):
                    for name, src in trees.items():
                        runs[name].append(measure(src, data, args.steps, threads, args.layer,
                                                  args.case, args.warmup))
                med = {k: statistics.median(r["psps"] for r in v) for k, v in runs.items()}
                results[f"{threads}_threads"] = {
                    "base_psps": med["base"], "current_psps": med["current"],
                    "ratio": med["current"] / med["base"],
                    "same_ke": runs["base"][0]["ke"] == runs["current"][0]["ke"],
                    "all": {k: [r["psps"] for r in v] for k, v in runs.items()}}
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)],
                           capture_output=True)
            shutil.rmtree(tree, ignore_errors=True)
    what = f"{args.config} after {args.warmup} steps" if args.case == "config" else args.case
    print(f"{what}, {args.steps} steps, {results['cpu']}, threading layer {args.layer}, "
          f"median of {args.repeat}")
    for threads in (1, 2):
        r = results[f"{threads}_threads"]
        print(f"{threads} thread(s): {args.base} {r['base_psps'] / 1e6:.2f} M, current "
              f"{r['current_psps'] / 1e6:.2f} M particle-steps/s, ratio {r['ratio']:.3f}, "
              f"same kinetic energy: {r['same_ke']}")
    print(json.dumps(results))
    return results


if __name__ == "__main__":
    main()
