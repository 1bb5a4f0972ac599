"""Does the droplets' separation depend on the interval between saved frames, and on how the
pairs are followed?

The forward tracker (``track_droplets`` + ``droplet_separations``: droplets matched frame to
frame by shared ids, each adjacent pair's line fitted where it was seen and carried back to
the aperture) gave separation velocities of 15.8 +- 2.2 cm/s in a run with frames 0.4 ms
apart and 7-11 in runs with frames 1-2 ms apart (docs/streams.md). This script takes one run
saved at a short frame interval and, for every k-th frame of its steady window (for each k
given), measures the separations both ways: forward-tracked, and traced back to the aperture
by the grains of droplets paired in frames 10 ms apart below ``--min-depth``
(``trace_droplet_pairs``, the seed's method and the study's). Same grains, same droplets;
only the frame interval and the method change.

For each it prints the pairs, their separation velocity (mean with its standard error, and
median; for traced pairs the initial one, Delta v0), the free-fall prediction at their own
spacing, the gradient g d / V of the free-fall fit over the pairs (the seed's 1.4 cm/s),
the length L0 at the aperture and the pairs' time spans.

Usage::

    python scripts/stream_frame_interval.py RUNDIR [--every 1 2 5 10] [--min-depth 0.05]

RUNDIR is a point's run directory, e.g. one made by ``scripts/stream_full_point.py OUT
--hopper-diameter "5 mm" --fill-height "3 mm" --contact-time "100 us" --frames-every 100``
(frames every 0.2 ms).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from grainflow.analysis.stream import (aperture_length, aperture_speed, droplet_separations,
                                       find_droplets, fit_separation_gradient, stream_grains,
                                       track_droplets)
from grainflow.studies.stream_study import _window_frames, traced_pairs_in


def _row(method: str, interval: float, pairs: list[Any], velocity: str, d: float) -> str:
    """A table row over ``pairs`` (forward-tracked or traced), whose separation velocity is
    their attribute ``velocity``."""
    if not pairs:
        return f"| {method} | {interval:.3g} | 0 | | | | | | |"
    dz0 = np.array([p.dz0 for p in pairs])
    dv = np.array([getattr(p, velocity) for p in pairs])
    pred = np.array([p.predicted_velocity for p in pairs])
    span = np.array([1e3 * np.ptp(p.times) for p in pairs])
    length = aperture_length(pairs)
    try:
        fit = fit_separation_gradient(dz0, dv, grain_diameter=d)
        gradient = f"{100 * fit.gradient:.3g} ± {100 * fit.gradient_err:.2g}"
    except ValueError as exc:
        gradient = f"no fit ({exc})"
    return (f"| {method} | {interval:.3g} | {dv.size} | {100 * dv.mean():.3g} ± "
            f"{100 * dv.std() / np.sqrt(dv.size):.2g} | {100 * np.median(dv):.3g} | "
            f"{100 * np.nanmean(pred):.3g} | {gradient} | {1e3 * length.mean:.3g} ± "
            f"{1e3 * length.err:.2g} | {np.median(span):.3g} |")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rundir", type=Path)
    parser.add_argument("--every", type=int, nargs="+", default=[1, 2, 5, 10],
                        help="use every k-th frame of the window, for each k")
    parser.add_argument("--min-depth", type=float, default=0.05,
                        help="traced pairs: droplets deeper than this (m) when paired")
    args = parser.parse_args(argv)
    frames, section = _window_frames(args.rundir)
    d = section.grain_diameter
    v0 = aperture_speed(frames).v0  # as the study's summary takes it
    interval = float(np.median(np.diff([f.time for f in frames])))
    print(f"{len(frames)} frames {1e3 * interval:.3g} ms apart from t = {frames[0].time:.4g} s; "
          f"v0 = {100 * v0:.3g} cm/s")
    print("| method | frame interval (ms) | pairs | separation velocity (cm/s) | median (cm/s) | "
          "free fall (cm/s) | g d / V of the fit (cm/s) | L0 (mm) | median span (ms) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for k in args.every:
        sub = frames[::k]
        stream = [stream_grains(f) for f in sub]
        seps = droplet_separations(track_droplets(
            [find_droplets(f, section.cohesion_range, min_grains=30) for f in stream]), v0=v0)
        print(_row("forward", 1e3 * k * interval, seps, "velocity", d))
        pairs = traced_pairs_in(sub, section.cohesion_range, v0, min_depth=args.min_depth)
        print(_row("traced", 1e3 * k * interval, pairs, "initial_velocity", d))


if __name__ == "__main__":
    main()
