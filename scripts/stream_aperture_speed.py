"""The stream's aperture speed v0 by every reading we could give the seed's "v0 ~ 10 cm/s".

Seed 000 quotes v0 ~ 10 cm/s "at the aperture" (d = 200 um, D = 3 mm) without defining it;
the study's v0 (:func:`grainflow.analysis.stream.fluctuations.aperture_speed`) is the mean
axial speed of the grains in the first diameter below the aperture. This script runs the
reduced study's hopper (D_h = 5 mm, H = 3 mm, t_c = 100 us), cohesionless, e = 0.88, with
the stream followed to 6 cm, to ``--until`` s, then samples 25 frames 2 ms apart and prints:

- the mean axial speed (number-weighted) and packing fraction over the aperture's disk in a
  slab one diameter thick just above, centred on and just below the aperture plane, on the
  axis (r < d) and flux-weighted (<v^2>/<v>);
- v0 of a fit v(z) = sqrt(v0^2 + 2 g z) to the mean speed below the aperture;
- the outflow Q and the superficial speed Q V_grain / (phi_b A) (the speed the outflow would
  have at the hopper bulk's packing phi_b across the whole aperture A, as Beverloo's law is
  read; :func:`grainflow.analysis.stream.superficial_speed`, which the study reports too).

Usage (about 3 minutes on 2 cores)::

    python scripts/stream_aperture_speed.py [--until 0.25] [--threads 2]
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy.optimize import curve_fit

from grainflow.analysis.stream import GRAVITY
from grainflow.analysis.stream import (free_fall_speed, outflow_steadiness,
                                       superficial_speed)
from grainflow.scenarios.stream import StreamSection, build_stream


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--until", type=float, default=0.25)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args(argv)

    section = StreamSection(hopper_diameter="5 mm", fill_height="3 mm", contact_time="100 us",
                            open_time="0.05 s", stream_depth="6 cm", restitution=0.88,
                            cohesion_force="0 nN")
    sim = build_stream(section, seed=1)
    sim.threads = args.threads
    sim.run(int(round(args.until / sim.dt)))
    frames = []
    for _ in range(25):
        sim.run(int(round(0.002 / sim.dt)))
        frames.append(sim.frame())

    d, R = section.grain_diameter, 0.5 * section.aperture_diameter
    grain = math.pi / 6.0 * d**3
    grains = [f.type == 0 for f in frames]
    depth = np.concatenate([-f.position[g, 2] for f, g in zip(frames, grains)])
    speed = np.concatenate([-f.velocity[g, 2] for f, g in zip(frames, grains)])
    r = np.concatenate([np.hypot(*f.position[g, :2].T) for f, g in zip(frames, grains)])
    n_frames = len(frames)

    print(f"t = {args.until:g}-{args.until + 0.05:g} s, {n_frames} frames; speeds in cm/s")
    print("| slab (one d thick) | mean v | on the axis (r < d) | flux-weighted | packing |")
    print("|---|---|---|---|---|")
    for lo, label in ((-d, "just above the aperture"), (-0.5 * d, "centred on it"),
                      (0.0, "just below (the study's v0)")):
        inside = (depth > lo) & (depth < lo + d) & (r < R)
        v = speed[inside]
        axis = inside & (r < d)
        phi = inside.sum() / n_frames * grain / (math.pi * R**2 * d)
        print(f"| {label} | {100 * v.mean():.1f} | {100 * speed[axis].mean():.1f} | "
              f"{100 * (v**2).sum() / v.sum():.1f} | {phi:.3f} |")

    flow = outflow_steadiness(frames)
    superficial = superficial_speed(frames, flow.mean_rate,
                                    aperture_diameter=section.aperture_diameter,
                                    hopper_diameter=section.hopper_diameter,
                                    fill_height=section.fill_height)
    print(f"outflow Q = {flow.mean_rate / 1000:.1f} grains/ms; bulk packing phi_b = "
          f"{superficial.phi_b:.3f}; superficial speed Q V_grain/(phi_b A) = "
          f"{100 * superficial.speed:.1f} cm/s")

    edges = np.arange(0.0, 0.06 + 1e-9, 0.001)
    centres, means = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        cell = (depth > a) & (depth < b)
        if cell.sum() > 50:
            centres.append(0.5 * (a + b))
            means.append(speed[cell].mean())
    z, v = np.array(centres), np.array(means)
    for start in (0.002, 0.01):
        use = z >= start
        (v0,), _ = curve_fit(lambda zz, v0_: free_fall_speed(zz, v0_), z[use], v[use], p0=[0.1])
        print(f"free-fall fit v(z) = sqrt(v0^2 + 2 g z) over {1000 * start:g}-"
              f"{1000 * z[use].max():.1f} mm: v0 = {100 * v0:.1f} cm/s")
    print("depth (mm), mean v (cm/s), sqrt(v^2 - 2 g z) (cm/s):")
    for zz, vv in zip(z[:6], v[:6]):
        start_speed = math.sqrt(max(vv**2 - 2 * GRAVITY * zz, 0.0))
        print(f"  {1000 * zz:.1f}  {100 * vv:.1f}  {100 * start_speed:.1f}")


if __name__ == "__main__":
    main()
