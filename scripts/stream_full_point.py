"""Points of the stream study's full plan at the seed's sizes, to tell what the reductions do
to the droplets (docs/streams.md, "Results of the reduced version": the peak network size
and the droplets' spacing at the aperture miss the seed's).

Runs the ``phase`` sweep of :data:`grainflow.studies.stream_study.FULL` (the 7.5 mm hopper
filled 6 mm high, t_c = 50 us, 0.45 s, the stream followed to 22 cm) restricted to the
chosen restitutions and cohesions, into OUT_DIR/phase (finished points are kept, and the
full study run into the same OUT_DIR finds them done). ``--hopper-diameter``,
``--fill-height`` and ``--contact-time`` change one of the full plan's sizes back to the
reduced plan's, to tell which reduction moves a number, and ``--cohesion-range`` changes the
shell delta (NF in the seed; give ``--fc`` with it to hold F_c delta), ``--dt-fraction``
the time step, ``--frames-every`` the steps between saved frames and ``--mu`` the Coulomb
friction (NF); such runs go into a sweep directory
named after the change (``OUT_DIR/phase-contact_time-100us``), because a point is named by
its e and F_c only and the full study must not take them for its own.
``--plan reduced`` runs the reduced plan's points instead
(:data:`~grainflow.studies.stream_study.REDUCED`: the 5 mm hopper, t_c = 100 us, 0.36 s),
into OUT_DIR/phase-reduced: forces between the reduced study's grid values place its
clustering-to-droplet crossover more closely than the grid's bracket.
Prints each run's summary (:func:`grainflow.studies.stream_study.stream_summary`) and, for a
cohesive stream, its adjacent droplets' separation velocities against free fall and the toy
model's length L0 at the aperture, as the study's report gives them.

Usage (one point on one thread, AMD EPYC: about 2.5-3 hours at the full plan's t_c = 50 us;
5,985 s with ``--contact-time "100 us"`` while the other core was busy; 1,100-2,500 s in the
reduced hopper, ``--hopper-diameter "5 mm" --fill-height "3 mm"``; docs/streams.md)::

    python scripts/stream_full_point.py OUT_DIR [--plan reduced] [--e 0.88] [--fc 1000]
        [--contact-time "100 us"]
        [--hopper-diameter "5 mm"] [--fill-height "3 mm"] [--cohesion-range "50 nm"]
        [--dt-fraction 0.01] [--mu 0.1] [--frames-every 100]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from grainflow import interrupt
from grainflow.analysis.stream import aperture_length
from grainflow.studies.points import run_sweeps
from grainflow.studies.stream_study import (FULL, REDUCED, _section, _tracked_separations,
                                           regime_name, sweep_specs)
from grainflow.sweep import parse_sweep


#: the [stream] fields a run may change from the full plan's, each naming its own sweep directory
STREAM_FIELDS = ("hopper-diameter", "fill-height", "contact-time", "cohesion-range")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--plan", choices=("full", "reduced"), default="full",
                        help="whose sizes and timing the runs take (default: the full plan's)")
    parser.add_argument("--e", type=float, nargs="+", default=[0.88],
                        help="restitutions (default 0.88)")
    parser.add_argument("--fc", type=float, nargs="+", default=[1000.0],
                        help="cohesion forces in nN (default 1000)")
    for name in STREAM_FIELDS:
        parser.add_argument(f"--{name}", default=None,
                            help=f"the [stream] table's {name.replace('-', '_')} with its "
                            "unit (default: the full plan's)")
    parser.add_argument("--dt-fraction", type=float, default=None,
                        help="time step as a fraction of t_c (default: the plan's 0.02)")
    parser.add_argument("--frames-every", type=int, default=None,
                        help="steps between saved frames (default: the plan's 1000); the "
                        "droplet tracker's frame interval")
    parser.add_argument("--mu", type=float, default=None,
                        help="Coulomb friction between grains and with the walls (default: "
                        "the [stream] table's 0.5; NF in the seed)")
    args = parser.parse_args(argv)
    raw = sweep_specs(FULL if args.plan == "full" else REDUCED)["phase"].model_dump()
    # a point is named by its e and F_c only: a run with a size changed, or of the other
    # plan, goes into a sweep directory of its own, which the full study (OUT_DIR/phase)
    # never reads as its own
    sweep = "phase" if args.plan == "full" else "phase-reduced"
    for name in (field.replace("-", "_") for field in STREAM_FIELDS):
        if getattr(args, name) is not None:
            raw["base"]["stream"][name] = getattr(args, name)
            sweep += f"-{name}-{getattr(args, name)}".replace(" ", "")
    if args.dt_fraction is not None:
        raw["base"]["run"]["dt_fraction"] = args.dt_fraction
        sweep += f"-dt_fraction-{args.dt_fraction:g}"
    if args.frames_every is not None:
        raw["base"]["output"]["frames_every"] = args.frames_every
        sweep += f"-frames_every-{args.frames_every}"
    if args.mu is not None:
        raw["base"]["stream"]["mu"] = args.mu
        sweep += f"-mu-{args.mu:g}"
    raw["overrides"] = {"stream.restitution": list(args.e),
                        "stream.cohesion_force": [f"{f:g} nN" for f in args.fc]}
    delta = _section(raw["base"]).cohesion_range  # m
    points = run_sweeps({sweep: parse_sweep(raw)}, args.out, progress="plain")[sweep]
    print(f"{len(points.rundirs)} runs, {points.cpu:.0f} CPU-s")
    for params, rundir, summary in zip(points.params, points.rundirs, points.summaries):
        print(f"== {params}: {rundir}")
        print("  " + ", ".join(f"{k} = {v:.4g}" for k, v in summary.items()))
        print(f"  regime: {regime_name(summary)}")
        if params["stream.cohesion_force"] == "0 nN":
            continue
        _, seps = _tracked_separations(rundir, delta, summary["v0"])
        if not seps:
            print("  no adjacent droplets tracked")
            continue
        v = 100 * np.array([q.initial_velocity for q in seps])
        predicted = 100 * np.array([q.predicted_velocity for q in seps])
        length = aperture_length(seps)
        print(f"  {len(seps)} adjacent pairs traced to the aperture: initial separation "
              f"velocity {v.mean():.3g} ± "
              f"{v.std() / np.sqrt(v.size):.2g} cm/s, free fall {np.nanmean(predicted):.3g} cm/s; "
              f"L0 = {1e3 * length.mean:.3g} ± {1e3 * length.err:.2g} mm ({length.pairs} pairs)")


if __name__ == "__main__":
    interrupt.run(main)
