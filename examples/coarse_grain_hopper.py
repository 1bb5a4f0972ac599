"""Coarse-grain a run: the tiny 2D hopper (examples/hopper2d_tiny.toml) is run with frames and
their contact lists, then its packing fraction, velocity and pressure are mapped over the
second half of the run and the pressure profile along the centre line is plotted with error
bars from four blocks of frames.

Usage::

    python examples/coarse_grain_hopper.py [OUTDIR]

Writes OUTDIR/run (the run directory) and OUTDIR/*.png (default OUTDIR: ./cg_hopper).
"""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path

import numpy as np

from grainflow.analysis.cg import Cartesian, CGFields, Lucy, coarse_grain
from grainflow.io.h5md import read_frame, read_frames
from grainflow.plotting.cg_plots import plot_field_map, plot_profiles
from grainflow.runner import run_config

EXAMPLES = Path(__file__).resolve().parent


def main(out: Path, steps: int = 40000) -> tuple[CGFields, CGFields]:
    """Run, coarse-grain and plot; returns the 2D map fields and the centre-line profile."""
    config = tomllib.loads((EXAMPLES / "hopper2d_tiny.toml").read_text())
    config["run"]["steps"] = steps
    config["output"].update(frames_every=steps // 30, contacts=True)
    rundir = Path(out) / "run"
    run_config(config, rundir, overwrite=True, progress="none")

    trajectory = rundir / "frames.h5"
    first = read_frame(trajectory, 0)
    diameter = 2.0 * float(np.mean(first.radius))
    lo, hi = first.box.lo, first.box.hi
    end = float(read_frame(trajectory, -1).time)
    window = (0.5 * end, end)
    kernel = Lucy(2.0 * diameter)  # Lucy's support: two diameters

    grid = Cartesian.uniform(lo, hi, (40, 40))
    maps = coarse_grain(read_frames(trajectory), grid, kernel, window=window)
    plot_field_map(maps, "packing_fraction", Path(out) / "packing_fraction.png")
    plot_field_map(maps, "velocity", Path(out) / "velocity_y.png", component=1)
    plot_field_map(maps, "pressure", Path(out) / "pressure.png")

    centre = 0.5 * (lo[0] + hi[0])
    column = Cartesian([[centre - 2 * diameter, centre + 2 * diameter],
                        np.linspace(lo[1], hi[1], 31)])
    profile = coarse_grain(read_frames(trajectory), column, kernel, window=window, blocks=4)
    plot_profiles(profile, ["pressure", "packing_fraction"], Path(out) / "centre_line.png")
    return maps, profile


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("cg_hopper"))
