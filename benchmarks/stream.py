"""A falling stream under the neighbour list's two checks, on the same machine, in one run.

Builds the reduced stream study's hopper (seed 000: 200 um glass, 3 mm aperture, D_h = 5 mm,
H = 3 mm, t_c = 100 us; e = 0.40, F_c = 300 nN) with the stream followed to 22 cm, and runs
it from the rained-in start to ``--until`` seconds (the stream reaches 22 cm at about
0.26 s), once with each ``list_check`` (``absolute``: rebuild once a grain has moved half
the skin; ``relative``: once a pair may have moved the skin against each other,
:mod:`grainflow.kernels.list_check`), each in a fresh process with the threading layer
fixed (``NUMBA_THREADING_LAYER``, default ``omp``) on ``--threads`` threads. Prints the CPU
and the layer, then per check the wall time of the whole run, and over the last ``--tail``
seconds (the stream at full depth) the particle-steps per second and the steps between
list builds. ``--load N`` runs N busy processes beside each run (a shared machine).

Usage::

    python benchmarks/stream.py [--until 0.30] [--tail 0.04] [--threads 2] [--load 0]
"""

from __future__ import annotations

# benchmarks/shared.py, beside this script
from shared import busy_processes, list_check_options, print_machine, run_python

WORKER = r"""
import json, sys, time
from grainflow.scenarios.stream import StreamSection, build_stream
check, until, tail, threads = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
section = StreamSection(hopper_diameter="5 mm", fill_height="3 mm", contact_time="100 us",
                        open_time="0.05 s", stream_depth="22 cm", restitution=0.40,
                        cohesion_force="300 nN")
sim = build_stream(section, seed=1, list_check=check)
sim.threads = threads
start = time.perf_counter()
sim.run(int(round((until - tail) / sim.dt)))
mark = (time.perf_counter(), sim.particle_steps, sim.rebuilds, sim.step)
sim.run(int(round(tail / sim.dt)))
end = time.perf_counter()
print(json.dumps({"wall": end - start, "grains": sim.state.n,
                  "tail_rate": (sim.particle_steps - mark[1]) / (end - mark[0]),
                  "steps_per_build": (sim.step - mark[3]) / max(1, sim.rebuilds - mark[2])}))
"""


def main(argv: list[str] | None = None) -> dict:
    parser = list_check_options(__doc__, until=0.30, threads=2)
    parser.add_argument("--tail", type=float, default=0.04)
    args = parser.parse_args(argv)
    print_machine(args.threads, args.load)
    results = {}
    for check in ("absolute", "relative"):
        with busy_processes(args.load, 3600.0):  # stopped when the run ends
            r = run_python(WORKER, check, args.until, args.tail, args.threads)
            results[check] = r
        print(f"{check:>8}: whole run to {args.until:g} s {r['wall']:.1f} s; last "
              f"{args.tail:g} s ({r['grains']} grains): {r['tail_rate'] / 1e6:.2f} M "
              f"particle-steps/s, {r['steps_per_build']:.1f} steps per list build", flush=True)
    a, b = results["absolute"], results["relative"]
    print(f"relative / absolute: whole run {a['wall'] / b['wall']:.2f}x, stream at full depth "
          f"{b['tail_rate'] / a['tail_rate']:.2f}x")
    return results


if __name__ == "__main__":
    main()
