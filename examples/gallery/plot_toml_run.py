"""# A run from a TOML file: a 2D silo emptying

Everything a run needs can be written in one TOML file and run with `grainflow run
silo.toml -o runs/silo`, or from Python with `grainflow.run_config`. This example writes a
small configuration (the `generic` scenario: a box, a population of grains, a contact law,
walls and a deletion region), runs it into a run directory, and reads the outputs back:
`thermo.csv` (one row of global numbers every few steps) and the H5MD trajectory
`frames.h5` (`grainflow.io.read_frames`).

The system: about 350 frictional disks (diameters 1 and 1.2, 2D, reduced units with
g = 1) start on a lattice in a flat-bottomed silo with a 5-diameter orifice and drain; grains
that fall below the silo are deleted. The figure shows the number of grains left falling
linearly in time (a constant flow rate while the silo empties, unlike a liquid's, which
slows as the level falls) and snapshots of the silo read back from the trajectory.
"""

# %%
# The configuration
# -----------------
# The file as a user would write it (every field is in `docs/config.md`; unknown keys and
# impossible values are refused with the field's dotted path before anything runs). The
# time step is left out: it is `dt_fraction` (0.02) times the binary contact time.

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import grainflow as gf
from grainflow.io import read_frames
from grainflow.plotting.snapshot import snapshot

CONFIG = """
scenario = "generic"
dim = 2
gravity = [0, -1]

[run]
duration = 60.0            # in sqrt(d/g)
seed = 0

[output]
thermo_every = 500
frames_every = 5000
checkpoint_every = 0       # only at the start and the end (and on Ctrl-C)

[box]
lo = [-12, -10]
hi = [12, 45]

[[particles]]
fill = "lattice"
lattice = "triangular"
region = { lo = [-10, 0.5], hi = [10, 28] }
spacing = 1.3
radius = [0.5, 0.6]        # bidisperse, to avoid crystallising
fractions = [0.5, 0.5]
density = 1.0

[contact]
law = "granular"
restitution = 0.5
contact_time = 0.05
mu = 0.5

[[walls]]
shape = "hopper2d"         # two side walls and a bottom with a centred orifice
W = 20
theta_w_deg = 90           # flat bottom
orifice_w = 5
height = 40

[[delete]]                 # grains that fell out of the silo
every = 100
region = { lo = [-12, -5], hi = [12, 45] }
"""
Path("silo.toml").write_text(CONFIG)

# %%
# Run it
# ------
# `run_config` validates the file, builds the simulation, runs it and writes the run
# directory: `config.toml` (the resolved configuration), `thermo.csv`, `frames.h5`,
# `checkpoint.npz`, `final.png` (the last state with its walls, shown below) and
# `summary.json`. On the command line the same is
# `grainflow run silo.toml -o runs/silo`; `grainflow info runs/silo` summarises a run
# directory, `grainflow resume runs/silo` continues an interrupted one from its checkpoint
# and `grainflow export runs/silo --format dump` (or `vtk`) writes files for OVITO or
# ParaView.

summary = gf.run_config("silo.toml", "runs/silo", overwrite=True, progress="none")
print(f"{summary.status}: {summary.steps} steps of dt = {summary.dt:.3g}, "
      f"{summary.wall_time_s:.1f} s, {summary.particle_steps_per_s:.3g} particle-steps/s")

# %%
# Read the outputs back
# ---------------------
# `thermo.csv` is a plain CSV file; `read_frames` yields the saved frames
# (`grainflow.Frame`: positions, velocities, radii, ids ...) in order.

thermo = np.genfromtxt("runs/silo/thermo.csv", delimiter=",", names=True)
frames = list(read_frames("runs/silo/frames.h5"))
print(f"{len(frames)} frames, N = {frames[0].n} -> {frames[-1].n}")

# The flow rate: a straight line through N(t) while the silo is between 80 % and 30 % full
# (the start-up and the end, when the heap no longer covers the orifice, are left out).
n0 = thermo["N"][0]
steady = (thermo["N"] < 0.8 * n0) & (thermo["N"] > 0.3 * n0)
slope, intercept = np.polyfit(thermo["time"][steady], thermo["N"][steady], 1)
print(f"flow rate Q = {-slope:.2f} grains per unit time (orifice 5 d, 2D)")
assert -slope > 0, "the silo did not drain"

# %%
# The figure: grains left and kinetic energy
# ------------------------------------------

fig = Figure(figsize=(6.5, 4), layout="constrained")
FigureCanvasAgg(fig)
ax = fig.add_subplot()
ax.plot(thermo["time"], thermo["N"], "C0-", label="grains in the silo (thermo.csv)")
t = thermo["time"][steady]
ax.plot(t, slope * t + intercept, "k--", label=f"linear fit, Q = {-slope:.2f} / $t_0$")
ax.set(xlabel="time $t$ ($t_0 = \\sqrt{d/g}$)", ylabel="number of grains $N$")
ax2 = ax.twinx()
ax2.semilogy(thermo["time"], thermo["kinetic_energy"], "C1:", label="kinetic energy")
ax2.set_ylabel("kinetic energy (code units)", color="C1")
fig.legend(loc="upper right", bbox_to_anchor=(0.86, 0.95))
fig.savefig("silo_discharge.png", dpi=120)

# %%
# Snapshots read back from the trajectory
# ---------------------------------------
# The start, coloured by radius, and a frame during the discharge, coloured by speed.
# Frames hold the grains only; the walls are drawn from the same `hopper2d` shape as in the
# configuration (`gf.walls.Hopper2D`, whose segments are the four walls).

hopper = gf.walls.Hopper2D(W=20, theta_w_deg=90, orifice_w=5, height=40)
walls = [(s.p0[:2], s.p1[:2]) for s in hopper.segments()]
snapshot(frames[0], Path("silo_start.png"), walls=walls, color_by="radius",
         title=f"t = 0: the lattice, N = {frames[0].n}")
snapshot(frames[4], Path("silo_draining.png"), walls=walls, color_by="speed",
         title=f"t = {frames[4].time:.0f}: draining, N = {frames[4].n}")
