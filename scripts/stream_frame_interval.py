"""Does the droplet tracker's answer depend on the interval between saved frames?

A stream run with dt = 0.4 us and frames every 1000 steps (0.4 ms) gave droplet separation
velocities of 15.8 +- 2.2 cm/s, where runs with frames 1-2 ms apart gave 7-11 (docs/streams.md).
This script takes one run saved at a short frame interval and tracks its droplets on every
k-th frame of the steady window, for each k given, so the frame interval is the only thing
that changes: the same grains, the same droplets.

For each interval it prints the number of adjacent pairs tracked, their separation velocity
(mean and standard error) against the free-fall prediction, the length L0 at the aperture,
and the pairs' time spans (how long each pair was followed).

Usage::

    python scripts/stream_frame_interval.py RUNDIR [--every 1 2 5 10] [--min-span 0]

RUNDIR is a point's run directory, e.g. one made by ``scripts/stream_full_point.py OUT
--hopper-diameter "5 mm" --fill-height "3 mm" --contact-time "100 us" --frames-every 100``
(frames every 0.2 ms).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from grainflow.analysis.stream import (aperture_length, aperture_speed, droplet_separations,
                                       find_droplets, stream_grains, track_droplets)
from grainflow.studies.stream_study import _window_frames


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rundir", type=Path)
    parser.add_argument("--every", type=int, nargs="+", default=[1, 2, 5, 10],
                        help="track on every k-th frame of the window, for each k")
    parser.add_argument("--min-span", type=float, default=0.0,
                        help="also report only the pairs followed for at least this long (ms)")
    args = parser.parse_args(argv)
    frames, section = _window_frames(args.rundir)
    v0 = aperture_speed(frames).v0  # as the study's summary takes it
    stream = [stream_grains(f) for f in frames]
    droplets = [find_droplets(f, section.cohesion_range, min_grains=30) for f in stream]
    interval = np.median(np.diff([f.time for f in frames]))
    print(f"{len(frames)} frames {1e3 * interval:.3g} ms apart from t = {frames[0].time:.4g} s; "
          f"v0 = {100 * v0:.3g} cm/s")
    print("| frame interval (ms) | pairs | separation velocity (cm/s) | free fall (cm/s) | "
          "L0 (mm) | median span (ms) |")
    print("|---|---|---|---|---|---|")
    for k in args.every:
        seps = droplet_separations(track_droplets(droplets[::k]), v0=v0)
        span = np.array([1e3 * np.ptp(s.times) for s in seps])
        if args.min_span > 0:
            seps = [s for s, t in zip(seps, span) if t >= args.min_span]
            span = span[span >= args.min_span]
        if not seps:
            print(f"| {1e3 * k * interval:.3g} | 0 | | | | |")
            continue
        v = 100 * np.array([s.velocity for s in seps])
        pred = 100 * np.array([s.predicted_velocity for s in seps])
        length = aperture_length(seps)
        print(f"| {1e3 * k * interval:.3g} | {len(seps)} | {v.mean():.3g} ± "
              f"{v.std() / np.sqrt(v.size):.2g} | {np.nanmean(pred):.3g} | "
              f"{1e3 * length.mean:.3g} ± {1e3 * length.err:.2g} | {np.median(span):.3g} |")


if __name__ == "__main__":
    main()
