"""A granular jet hitting its target under the neighbour list's two checks, on one machine.

Builds the jet study's rheology points (seed 002: ``rheo3d``, D_jet = 10 d onto D_tar = 22 d,
phi_tilde = 0.9, mu_p = 0.2; ``rheo2d``, the bidisperse frictionless 2D jet, D_jet = 30 d onto
66 d) and runs each to ``--until`` (in d/u0), once with each ``list_check`` (``absolute``:
rebuild once a grain has moved half the skin; ``relative``: once a pair may have moved the
skin against each other, :mod:`grainflow.kernels.list_check`), each in a fresh process with
the threading layer fixed (``NUMBA_THREADING_LAYER``, default ``omp``) on ``--threads``
threads, as a study's dask worker runs it. Prints the CPU and the layer, then per case and
check the wall time, particle-steps per second and steps between list builds.

Usage::

    python benchmarks/jet.py [--until 40] [--threads 1] [--load 0]
"""

from __future__ import annotations

# benchmarks/shared.py, beside this script
from shared import busy_processes, list_check_options, print_machine, run_python

WORKER = r"""
import json, sys, time
from grainflow.scenarios.jet import JetSection, build_jet
case, check, until, threads = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
if case == "rheo3d":
    section, dim = JetSection(jet_diameter=10.0, target_diameter=22.0, n=10_000,
                              phi_tilde=0.9, mu_p=0.2), 3
else:
    section, dim = JetSection(jet_diameter=30.0, target_diameter=66.0, n=8000,
                              sizes="bidisperse", mu_p=0.0, phi_tilde=0.9), 2
sim = build_jet(section, dim, seed=0, list_check=check)
sim.threads = threads
sim.run(10)  # compile
start, steps0, builds0, ps0 = time.perf_counter(), sim.step, sim.rebuilds, sim.particle_steps
sim.run(int(round(until / sim.dt)))
wall = time.perf_counter() - start
print(json.dumps({"wall": wall, "rate": (sim.particle_steps - ps0) / wall,
                  "steps_per_build": (sim.step - steps0) / max(1, sim.rebuilds - builds0)}))
"""


def main(argv: list[str] | None = None) -> dict:
    args = list_check_options(__doc__, until=40.0, threads=1).parse_args(argv)
    print_machine(args.threads, args.load)
    results: dict = {}
    for case in ("rheo3d", "rheo2d"):
        for check in ("absolute", "relative"):
            with busy_processes(args.load, 3600.0):  # stopped when the run ends
                r = run_python(WORKER, case, check, args.until, args.threads)
                results[case, check] = r
            print(f"{case} {check:>8}: to t = {args.until:g} d/u0 {r['wall']:.1f} s, "
                  f"{r['rate'] / 1e6:.2f} M particle-steps/s, {r['steps_per_build']:.1f} "
                  "steps per list build", flush=True)
        a, b = results[case, "absolute"], results[case, "relative"]
        print(f"{case} relative / absolute: {a['wall'] / b['wall']:.2f}x")
    return results


if __name__ == "__main__":
    main()
