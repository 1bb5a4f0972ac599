"""# Contact laws: one grain bouncing off a wall

A single sphere hits a flat wall head-on, without gravity, and we measure what the contact
law does to it: the restitution coefficient (outgoing over incoming speed) and the contact
time. For the linear spring-dashpot of the `granular` law (Hooke normal spring, viscous
damping; SPEC M1) both are set exactly by `gf.stiffness_and_damping(restitution,
contact_time, meff)`; against a wall the effective mass is the grain's mass. For a Hertz
spring (`gf.ContactLaw(normal="hertz")`, elastic) the contact time depends on the impact
speed as `v**(-1/5)`.

In the figure the measured restitution sits on the diagonal for every set value, the Hooke
contact time is the set one at every impact speed, and the Hertz contact times follow the
analytic curve. The overlap histories on the right show how damping skews the linear
spring's half-sine (the largest overlap comes earlier, the grain leaves slowly) and how
close the elastic Hertz pulse is to a half-sine.
"""

# %%
# One grain, one wall
# -------------------
# A sphere of radius 0.5 and density 1 sits just above the plane `z = 0` (three steps of
# free flight away), moving down at speed `v`. An observer records its height every step;
# the contact lasts while the overlap `radius - z` is positive. The time step resolves the
# contact time with about 100 steps.

import numpy as np
from scipy.integrate import quad
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

import grainflow as gf

RADIUS = 0.5
MASS = 4.0 / 3.0 * np.pi * RADIUS**3  # density 1


def bounce(law, v_in, dt, steps):
    """Drop one grain on the plane z = 0 at speed v_in; return (times, overlaps, v_out)."""
    box = gf.Box(lo=np.full(3, -5.0), hi=np.full(3, 5.0), periodic=(False,) * 3)
    state = gf.ParticleState(3, box)
    gap = 3.0 * v_in * dt  # free flight for three steps before the contact
    state.add_particles([[0.0, 0.0, RADIUS + gap]], RADIUS, density=1.0,
                        v=[[0.0, 0.0, -v_in]])
    sim = gf.Simulation(state, dt=dt, law=law)
    sim.add_force(gf.WallForce([gf.walls.Plane(point=(0, 0, 0), normal=(0, 0, 1))], law,
                               wall_type=1))
    t, overlap = [], []
    sim.add_observer(lambda ctx: (t.append(ctx.time),
                                  overlap.append(RADIUS - ctx.state.x[0, 2])))
    sim.run(steps)
    return np.array(t), np.array(overlap), sim.state.v[0, 2]


def contact_time(t, overlap):
    """Time with positive overlap, the crossings interpolated linearly."""
    inside = np.flatnonzero(overlap > 0)
    a, b = inside[0], inside[-1]
    t_in = t[a - 1] + (t[a] - t[a - 1]) * overlap[a - 1] / (overlap[a - 1] - overlap[a])
    t_out = t[b] + (t[b + 1] - t[b]) * overlap[b] / (overlap[b] - overlap[b + 1])
    return t_out - t_in


# %%
# Linear spring-dashpot: restitution and contact time as set
# ----------------------------------------------------------
# `gf.stiffness_and_damping` turns a restitution `e` and a contact time `t_c` into the
# stiffness `kn` and the damping `gamma_n` (per unit effective mass, LAMMPS's convention).
# We set `t_c = 0.01` and four restitutions, and measure both back (code units: lengths in
# grain diameters, density 1). With 100 steps per contact, velocity Verlet's error on a
# velocity-dependent force leaves the restitution a few tenths of a percent high.

TC = 0.01
V_IN = 1.0
set_e = np.array([0.3, 0.5, 0.7, 0.9])
hooke = {}
for e in set_e:
    law = gf.GranularLaw(n_types=2)  # type 0: the grain, type 1: the wall
    kn, gamma_n = gf.stiffness_and_damping(restitution=e, contact_time=TC, meff=MASS)
    law.set_all(kn=kn, gamma_n=gamma_n, mu=0.5)
    t, overlap, v_out = bounce(law, V_IN, dt=TC / 100, steps=150)
    hooke[e] = (t, overlap, v_out / V_IN, contact_time(t, overlap))

measured_e = np.array([hooke[e][2] for e in set_e])
measured_tc = np.array([hooke[e][3] for e in set_e])
print("Hooke: set e =", set_e, "measured e =", np.round(measured_e, 4),
      "t_c / set =", np.round(measured_tc / TC, 4))
assert np.allclose(measured_e, set_e, rtol=0.01), "restitution off by more than 1 %"
assert np.allclose(measured_tc, TC, rtol=0.01), "contact time off by more than 1 %"

# %%
# Hertz: an elastic spring whose contact time depends on the impact speed
# -----------------------------------------------------------------------
# The Hertz normal force against a wall is `kn sqrt(R) delta**1.5` (R: the grain's radius).
# Energy conservation gives the largest overlap
# `delta_max = (5 m v**2 / (4 kn sqrt(R)))**(2/5)` and the contact time
# `t_c = 2.9432 delta_max / v`, i.e. `t_c ~ v**(-1/5)`.

KN_HERTZ = 1.0e4
hertz_law = gf.ContactLaw(n_types=2, normal="hertz")
hertz_law.set_all(kn=KN_HERTZ)
shape = 2.0 * quad(lambda s: 1.0 / np.sqrt(1.0 - s**2.5), 0.0, 1.0)[0]


def hertz_tc(v):
    delta_max = (5.0 * MASS * v**2 / (4.0 * KN_HERTZ * np.sqrt(RADIUS))) ** 0.4
    return shape * delta_max / v


speeds = np.array([0.25, 0.5, 1.0, 2.0, 4.0])
hertz = {}
for v in speeds:
    t, overlap, v_out = bounce(hertz_law, v, dt=hertz_tc(v) / 100, steps=150)
    hertz[v] = (t, overlap, v_out / v, contact_time(t, overlap))
hertz_measured = np.array([hertz[v][3] for v in speeds])
print("Hertz: t_c measured / analytic =", np.round(hertz_measured / hertz_tc(speeds), 4),
      "restitution =", np.round([hertz[v][2] for v in speeds], 6))
assert np.allclose(hertz_measured, hertz_tc(speeds), rtol=0.01)

# The linear spring's contact time, by contrast, does not depend on the impact speed:
law = gf.GranularLaw(n_types=2)
law.set_all(**dict(zip(("kn", "gamma_n"), gf.stiffness_and_damping(0.7, TC, MASS))), mu=0.5)
hooke_tc_v = np.array([contact_time(*bounce(law, v, dt=TC / 100, steps=150)[:2])
                       for v in speeds])
assert np.allclose(hooke_tc_v, TC, rtol=0.01)

# %%
# The figure
# ----------
# Left: measured against set restitution. Middle: contact time against impact speed,
# Hooke (constant, as set) and Hertz (with the analytic `v**(-1/5)` curve). Right: the
# overlap over the contact, in units of the largest overlap and of the contact time.

fig = Figure(figsize=(13, 4), layout="constrained")
FigureCanvasAgg(fig)
ax1, ax2, ax3 = fig.subplots(1, 3)

ax1.plot([0, 1], [0, 1], "k:", label="measured = set")
ax1.plot(set_e, measured_e, "o", label="Hooke + viscous damping")
ax1.set(xlabel="set restitution $e$", ylabel="measured restitution $v_{out}/v_{in}$",
        xlim=(0, 1), ylim=(0, 1), title="restitution")
ax1.legend()

vv = np.geomspace(speeds[0] / 1.3, speeds[-1] * 1.3, 100)
ax2.plot(vv, hertz_tc(vv), "k-", label=r"Hertz, analytic $\propto v^{-1/5}$")
ax2.plot(speeds, hertz_measured, "s", color="C1", label="Hertz, measured")
ax2.axhline(TC, color="C0", ls="--", label=f"Hooke, set $t_c$ = {TC}")
ax2.plot(speeds, hooke_tc_v, "o", color="C0", label="Hooke e = 0.7, measured")
ax2.set(xscale="log", yscale="log", xlabel="impact speed $v_{in}$",
        ylabel="contact time $t_c$", title="contact time", xticks=speeds,
        xticklabels=[f"{v:g}" for v in speeds], ylim=(0.005, 0.2))
ax2.xaxis.set_minor_formatter(NullFormatter())
ax2.legend(fontsize=8)

for e in (0.3, 0.9):
    t, overlap, _, tc = hooke[e]
    touching = overlap > -0.05 * overlap.max()
    t0 = t[np.argmax(overlap > 0)]
    ax3.plot((t[touching] - t0) / tc, overlap[touching] / overlap.max(),
             label=f"Hooke, e = {e}")
t, overlap, _, tc = hertz[1.0]
t0 = t[np.argmax(overlap > 0)]
touching = overlap > -0.05 * overlap.max()
ax3.plot((t[touching] - t0) / tc, overlap[touching] / overlap.max(), "k--",
         label="Hertz, elastic")
ax3.axhline(0, color="grey", lw=0.5)
ax3.set(xlabel=r"time since contact / $t_c$", ylabel=r"overlap / max overlap",
        xlim=(-0.05, 1.05), ylim=(-0.05, 1.05), title="overlap during the contact")
ax3.legend(fontsize=8)

fig.savefig("contact_laws.png", dpi=120)
