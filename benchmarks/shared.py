"""Speed on a shared machine: grainflow and LAMMPS with CPU-bound processes beside them.

Starts ``--load`` busy processes (each a Python loop that stops by itself after
``--max-seconds``, and is stopped by the script when it ends), then measures, each in a fresh
process:

- the chute (32,000 grains, ``benchmarks/chute.py``'s case) with grainflow on 1 thread, 2
  threads and ``threads = "auto"``, and LAMMPS on 1 and 2 ranks;
- the 2D hopper of ``grainflow demo`` (1,600 grains, walls, drag, reinsertion) with grainflow
  on 1 thread, 2 threads and ``"auto"``.

``--load 0`` gives the idle figures for comparison. Prints a table and, as its last line,
JSON (particle-steps per second, the thread counts ``"auto"`` used, the CPU, the threading
layer, the load).

Usage::

    python benchmarks/shared.py [--load 1] [--chute-steps 1000] [--hopper-steps 50000]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from chute import benchmark_files, cpu_model, run_lammps  # benchmarks/chute.py, beside this

BUSY = "import time, sys\nend = time.time() + float(sys.argv[1])\nwhile time.time() < end:\n    pass\n"


def threading_layer() -> str:
    """numba's threading layer for the benchmarks run by :func:`run_python`: the environment's
    ``NUMBA_THREADING_LAYER``, else ``omp`` (never numba's own choice)."""
    return os.environ.get("NUMBA_THREADING_LAYER", "omp")


def run_python(code: str, *args: object) -> dict:
    """Run ``code`` with ``args`` in a fresh Python process on this checkout's sources, with
    the threading layer fixed (:func:`threading_layer`) and warnings off, and return the JSON
    object its last line prints."""
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {**os.environ, "NUMBA_THREADING_LAYER": threading_layer(), "PYTHONPATH": src,
           "PYTHONWARNINGS": "ignore"}
    out = subprocess.run([sys.executable, "-c", code, *map(str, args)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def list_check_options(doc: str, *, until: float, threads: int) -> argparse.ArgumentParser:
    """The options the list-check benchmarks (``stream.py``, ``jet.py``) share: ``--until``,
    ``--threads`` and ``--load`` (busy processes beside each run)."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--until", type=float, default=until)
    parser.add_argument("--threads", type=int, default=threads)
    parser.add_argument("--load", type=int, default=0)
    return parser


def print_machine(threads: int, load: int) -> None:
    """The line every run of a list-check benchmark starts with: CPU, layer, threads, load."""
    print(f"CPU: {cpu_model()}; threading layer: {threading_layer()}; threads: {threads}; "
          f"busy processes beside each run: {load}")


@contextmanager
def busy_processes(count: int, seconds: float) -> Iterator[None]:
    """``count`` CPU-bound processes beside the block: each stops by itself after ``seconds``
    and is stopped when the block ends; half a second lets them get going first."""
    busy = [subprocess.Popen([sys.executable, "-c", BUSY, str(seconds)]) for _ in range(count)]
    try:
        time.sleep(0.5 if busy else 0.0)
        yield
    finally:
        for p in busy:
            p.kill()
            p.wait()


WORKER = r"""
import json, math, sys, time
case, steps, threads = sys.argv[1], int(sys.argv[2]), sys.argv[3]
if case == "chute":
    from grainflow.scenarios.chute import chute_simulation
    sim = chute_simulation()
    warm = 50
else:
    from grainflow.scenarios.hopper import HopperSection, build_hopper, prepare
    sim = build_hopper(HopperSection(n=1600, orifice_width=10.0, E_sp=1000.0, E_w=1000.0,
                                     lam=math.inf), 2, seed=0)
    prepare(sim)
    warm = 500
sim.threads = threads if threads == "auto" else int(threads)
sim.fast_path_min_steps = 0  # the warm-up and the measured run use the compiled step loop
sim.run(warm)
t0 = time.perf_counter()
sim.run(steps)
wall = time.perf_counter() - t0
used = {}
previous = warm
for step, t, _ in sim.thread_log:
    if step > warm:
        used[t] = used.get(t, 0) + step - max(previous, warm)
    previous = step
print(json.dumps({"n": sim.state.n, "steps": steps, "wall": wall,
                  "psps": sim.state.n * steps / wall, "steps_on": used}))
"""

LAYER = "omp"


def run_grainflow(case: str, steps: int, threads: str) -> dict:
    cap = "2" if threads == "auto" else threads
    env = dict(os.environ, NUMBA_NUM_THREADS=cap, OMP_NUM_THREADS=cap,
               NUMBA_THREADING_LAYER=LAYER)
    out = subprocess.run([sys.executable, "-c", WORKER, case, str(steps), threads],
                         capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--load", type=int, default=1, help="busy processes beside the runs")
    ap.add_argument("--chute-steps", type=int, default=1000)
    ap.add_argument("--hopper-steps", type=int, default=50000)
    ap.add_argument("--max-seconds", type=float, default=900.0,
                    help="the busy processes stop by themselves after this long")
    ap.add_argument("--layer", default="omp", help="numba threading layer (omp, tbb, workqueue)")
    ap.add_argument("--skip-lammps", action="store_true")
    args = ap.parse_args(argv)
    global LAYER
    LAYER = args.layer
    results: dict = {"date": time.strftime("%Y-%m-%d"), "machine": cpu_model(),
                     "cores": os.cpu_count(), "threading_layer": LAYER, "load": args.load}
    with busy_processes(args.load, args.max_seconds):
        for case, steps in (("chute", args.chute_steps), ("hopper2d", args.hopper_steps)):
            for threads in ("1", "2", "auto"):
                r = run_grainflow(case, steps, threads)
                results[f"{case}_grainflow_{threads}"] = r["psps"]
                if threads == "auto":
                    results[f"{case}_auto_steps_on"] = r["steps_on"]
                print(f"  {case} {threads}: {r['psps'] / 1e6:.2f} M", file=sys.stderr,
                      flush=True)
        if not args.skip_lammps:
            data, deck = benchmark_files(None)
            for ranks in (1, 2):
                results[f"chute_lammps_{ranks}"] = run_lammps(data, deck, args.chute_steps,
                                                              ranks)["psps"]
    print(f"shared machine: {args.load} busy process(es) beside each run; {results['machine']} "
          f"({results['cores']} cores), numba threading layer {LAYER}")
    print(f"{'case':<10}{'code':<11}{'workers':>9}{'M particle-steps/s':>20}")
    for case in ("chute", "hopper2d"):
        for threads in ("1", "2", "auto"):
            v = results[f"{case}_grainflow_{threads}"]
            extra = ""
            if threads == "auto":
                extra = "  (steps on 1 / 2 threads: " + " / ".join(
                    str(results[f"{case}_auto_steps_on"].get(str(t), 0)) for t in (1, 2)) + ")"
            print(f"{case:<10}{'grainflow':<11}{threads:>9}{v / 1e6:>20.2f}{extra}")
        if case == "chute" and not args.skip_lammps:
            for ranks in (1, 2):
                print(f"{case:<10}{'LAMMPS':<11}{ranks:>9}"
                      f"{results[f'chute_lammps_{ranks}'] / 1e6:>20.2f}")
    auto = results["chute_grainflow_auto"]
    results["chute_auto_over_1_thread"] = auto / results["chute_grainflow_1"]
    results["hopper2d_auto_over_1_thread"] = (results["hopper2d_grainflow_auto"]
                                              / results["hopper2d_grainflow_1"])
    if not args.skip_lammps:
        results["chute_auto_over_lammps_2"] = auto / results["chute_lammps_2"]
        results["chute_auto_over_lammps_best"] = auto / max(results["chute_lammps_1"],
                                                            results["chute_lammps_2"])
    print(json.dumps(results))
    return results


if __name__ == "__main__":
    main()
