"""# Hopper discharge of soft disks (seed 003)

Seed 003 (Cheng et al., Soft Matter 18, 8071 (2022)) studies how the flow rate Q of soft
particles out of a hopper depends on how they dissipate energy: by kinetic friction between
touching grains (lambda = zeta/mu -> 0) or by a background drag on every grain
(lambda -> inf). This example runs the seed's 2D hopper (1600 bidisperse soft disks with
harmonic repulsion, a flat bottom, an orifice w = 6.2 sigma_avg, grains put back on top
after they leave) in the friction limit on the authors' conventions, and measures Q with
its error bar from the orifice crossings after the start-up transient (MSER rule).

The figure shows the cumulative number of crossings, the transient that was cut and the
steady window with its rate, the binned local rate, and a snapshot of the hopper coloured
by speed: a dense slow pile with a fast funnel above the orifice. Expect Q close to
8.5 sigma_avg^2/t0, the value of the same point in the reduced study.

Shortened: one orifice width, one lambda and 100 t0 of flow (the study: 150 t0 over six to
twenty widths and seven to twelve lambda, with Beverloo fits, about 35 minutes on 2 cores
for the reduced version): `grainflow study hopper -o hopper_study`, docs/hopper_study.md.
The drag limit is left out: there the pile turns over slowly and the rate settles only
after a few hundred t0 (`grainflow demo` runs 600 t0 of a drag-limited hopper).
"""

# %%
# The hopper
# ----------
# `HopperSection` is the `[hopper]` table of a configuration file. `convention="authors"`
# takes every model option as the authors' code has it (docs/hopper_study.md, "Second
# pass"); `lam=0` is the friction limit. `build_hopper` starts as their code does: random
# centres at packing 0.6, relaxed by FIRE with the radii x 1.2 and gravity off, then the radii
# restored (`initial_packing = "inflated"`); `prepare` is the seed's FIRE for any overlap left
# (none here) before gravity is switched on. The soft grains
# overlap strongly at the bottom of a friction-only pile, so the health check allows
# overlaps up to twice the small radius (as `grainflow study hopper` does).

import math
from pathlib import Path

from grainflow.analysis.hopper import flow_rate_from_events
from grainflow.plotting.hopper_plots import plot_flow_rate_timeseries
from grainflow.plotting.snapshot import snapshot
from grainflow.scenarios.hopper import (HopperSection, build_hopper, hopper_segments,
                                        hopper_updater, prepare)

section = HopperSection(convention="authors", n=1600, orifice_width=6.2, lam=0.0)
sim = build_hopper(section, 2, seed=0, max_overlap_fraction=2.0)
prepare(sim)
sim.run(math.ceil(100.0 / sim.dt))  # 100 t0, t0 = sqrt(sigma_avg / g)

# %%
# The flow rate
# -------------
# The reinsertion updater records the time and area of every grain it counts (here when it
# is moved back to the top, 2.5 diameters below the orifice, as the authors' code counts).
# `flow_rate_from_events` cuts the start-up transient (MSER on 50 time bins) and gives Q
# with the standard error of 10 block means.

events = hopper_updater(sim)
flow = flow_rate_from_events(events.event_times, events.event_sizes, t_begin=0.0,
                             t_end=sim.time)
print(f"Q = {flow.flow_rate:.3f} +/- {flow.flow_rate_err:.3f} sigma_avg^2/t0 from "
      f"{flow.n_events} grains after t = {flow.t_start:.0f} t0 (reduced study, 150 t0: "
      f"8.531 +/- 0.10)")
assert abs(flow.flow_rate - 8.531) < 5 * math.hypot(flow.flow_rate_err, 0.10)

# %%
# The crossings and the steady window
# -----------------------------------
# Left: the cumulative number of crossings N(t), the transient the MSER rule cut (grey) and
# the steady window (green) with the fitted rate. Right: the binned local rate with the
# steady mean and its error band. The first grains out come in a burst (the pile settles
# onto the orifice) before the flow steadies.

plot_flow_rate_timeseries(flow, Path("hopper_flow_rate.png"))

# %%
# A snapshot
# ----------
# The final state coloured by speed, with the walls drawn from the simulation's wall
# segments.

snapshot(sim.frame(), Path("hopper_snapshot.png"), walls=hopper_segments(sim),
         title=f"friction limit: t = {sim.time:.0f} t0, "
               f"Q = {flow.flow_rate:.2f} ± {flow.flow_rate_err:.2f}")
