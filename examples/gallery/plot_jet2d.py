"""# A granular jet hitting a target (seed 002)

Seed 002 (Sano's thesis, 2013; Sano & Hayakawa, PRE 86, 041308) simulates a dense jet of
grains hitting a fixed target and asks in which direction the grains leave: the scattering
angle psi0, measured from the jet's direction of travel (pi/2: a flat sheet along the
target, more: a backward cone). This example runs a small 2D jet (the `jet2d` scenario: a
strip of 800 frictional grains, D_jet = 10 d, moving at u0 onto a target of 22 d made of
tethered wall particles, restitution 0.75) and measures psi0 over the steady window by the
two definitions of `grainflow.analysis.jet`: the thesis's momentum balance
1 - cos psi0 = F_wall / J_in (eq. 4.3, from the force of the grains on the target) and the
direction of the scattered momentum flux through a ring around the target.

The figure shows the jet spreading into two sheets along the target with a slow dead zone
at its centre, and psi0 over sliding windows settling once the jet's front has spread.
Expect psi0 of 1.4-1.5 rad, just under pi/2: nearly flat sheets along the target. The
flux definition gives the smaller angle: inelastic grains lose momentum flux on their way
out, so the two need not agree (docs/jets.md).

Shortened: one small 2D jet for 60 d/u0. The seed's psi0(X) over target sizes is 3D
(`grainflow study jet -o jet_study`, sweep `scatter`); the 2D study there is the rheology
near the target (D_jet = 30 d, 8,000 grains). See docs/jets.md.
"""

# %%
# Run the jet
# -----------
# Units: the grain diameter d, its mass m and the jet speed u0 are 1. The configuration is
# a dict here (the same as a `[jet]` table in a TOML file, `examples/jet2d.toml`). Frames
# are saved every d/u0 with their contact lists (`contacts = true`), which the force
# balance needs. The scenario integrates with Adams-Bashforth 2 at dt = t_c/50, as the seed.

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import grainflow as gf
from grainflow.analysis.jet import force_balance_angle, scattering_angle
from grainflow.io import read_frames
from grainflow.plotting.snapshot import snapshot

D_JET, D_TAR = 10.0, 22.0
config = {
    "scenario": "jet2d", "dim": 2,
    "run": {"duration": 60.0},
    "output": {"thermo_every": 2000, "frames_every": 500, "contacts": True,
               "checkpoint_every": 0, "snapshot": False},
    "jet": {"jet_diameter": D_JET, "target_diameter": D_TAR, "n": 800, "mu_p": 0.2,
            "restitution": 0.75, "contact_time": 0.1},
}
summary = gf.run_config(config, "runs/jet2d", overwrite=True, progress="none")
frames = list(read_frames("runs/jet2d/frames.h5"))
print(f"{summary.steps} steps in {summary.wall_time_s:.1f} s; {len(frames)} frames")

# %%
# The scattering angle over the steady window
# -------------------------------------------
# The jet's front reaches the target at t = 2; by t = 20 the flow around the target is
# steady, and the jet (about 100 d long) is still arriving at t = 60. Both estimates carry a
# jackknife error over blocks of consecutive frames. The force balance takes the jet's
# momentum flux J_in from the undisturbed jet in the first frame.

WINDOW = (20.0, 60.0)
by_flux = scattering_angle(frames, target_radius=D_TAR / 2, jet_radius=D_JET / 2,
                           window=WINDOW)
by_force = force_balance_angle(frames, window=WINDOW)
print(f"psi0 = {by_force.psi0:.3f} +/- {by_force.psi0_err:.3f} rad (force balance, eq. 4.3: "
      f"F_wall/J_in = {by_force.ratio:.3f}); {by_flux.psi0:.3f} +/- {by_flux.psi0_err:.3f} "
      f"rad (momentum flux of {by_flux.n_grains} scattered grains)")
assert 1.2 < by_force.psi0 < 1.8 and 1.2 < by_flux.psi0 < 1.8, "expected sheets near pi/2"

# %%
# A snapshot
# ----------
# A frame in the steady window, coloured by speed: the jet comes in from the right at u0,
# slows in a nearly stagnant zone on the target's centre and leaves along it in two sheets.
# The target's tethered particles are the row at x = -1/2.

snapshot(frames[40], Path("jet2d_snapshot.png"), color_by="speed",
         title=f"2D jet on a tethered target, t = {frames[40].time:.0f} d/u0")

# %%
# psi0 over sliding windows
# -------------------------
# The same two analyses on windows of 8 d/u0. The force on the target grows while the
# first grains spread over it, then fluctuates about its steady value. The flux estimate
# needs scattered grains in the measuring ring (radius 19.5 d), which the sheets reach
# only after t = 12 (before that `scattering_angle` refuses, saying the ring is empty).

starts = np.arange(4.0, 53.0, 4.0)
force = [force_balance_angle(frames, window=(t, t + 8.0)) for t in starts]
flux_starts = starts[starts >= 16.0]
flux = [scattering_angle(frames, target_radius=D_TAR / 2, jet_radius=D_JET / 2,
                         window=(t, t + 8.0)) for t in flux_starts]

fig = Figure(figsize=(6.5, 4), layout="constrained")
FigureCanvasAgg(fig)
ax = fig.add_subplot()
ax.errorbar(starts + 4.0, [r.psi0 for r in force], [r.psi0_err for r in force], fmt="o",
            capsize=2, label="force balance, eq. 4.3")
ax.errorbar(flux_starts + 4.0, [r.psi0 for r in flux], [r.psi0_err for r in flux], fmt="s",
            mfc="none", capsize=2, label="scattered momentum flux")
ax.axvspan(*WINDOW, color="tab:green", alpha=0.1, label="steady window")
ax.axhline(np.pi / 2, color="k", ls=":", label=r"$\pi/2$: a flat sheet")
ax.set(xlabel="window centre $t$ ($d/u_0$)", ylabel=r"scattering angle $\psi_0$ (rad)",
       title=f"2D jet, $X = D_{{tar}}/D_{{jet}}$ = {D_TAR / D_JET:.1f}")
ax.legend(fontsize=8)
fig.savefig("jet2d_psi0.png", dpi=120)
