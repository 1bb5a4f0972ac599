"""# Free fall onto a wall

Five grains are released at rest at different heights above a plane wall, under gravity
`g = 1` (reduced units), with the API of the README's quickstart: `gf.ParticleState`,
`gf.GranularLaw`, `gf.Gravity`, `gf.WallForce` and `gf.Simulation`.

Until a grain touches the wall it falls on the parabola `z(t) = z0 - g t^2 / 2`, and it
reaches the wall (`z = r`) at `t = sqrt(2 (z0 - r) / g)`. The figure shows the simulated
heights on top of the parabolas, then the bounces: each rebound leaves the wall at `e`
times the impact speed, with the restitution `e = 0.6` the contact law was set to.
"""

# %%
# The set-up
# ----------
# Five spheres of radius 0.5 and density 1, side by side in a box periodic in x and y, the
# plane `z = 0` below them. `gf.stiffness_and_damping` turns a restitution and a contact
# time into the spring and dashpot; against a wall the effective mass is the grain's mass.

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import grainflow as gf

G = 1.0
RADIUS = 0.5
RESTITUTION = 0.6
heights = np.array([2.0, 3.0, 4.0, 5.0, 6.0])
n = heights.size

box = gf.Box(lo=np.zeros(3), hi=np.array([3.0 * n, 3.0, 10.0]), periodic=(True, True, False))
state = gf.ParticleState(3, box)
x = np.column_stack([1.5 + 3.0 * np.arange(n), np.full(n, 1.5), heights])
state.add_particles(x, radius=RADIUS, density=1.0)

mass = 4.0 / 3.0 * np.pi * RADIUS**3
law = gf.GranularLaw()
kn, gamma_n = gf.stiffness_and_damping(restitution=RESTITUTION, contact_time=0.01, meff=mass)
law.set_all(kn=kn, gamma_n=gamma_n, mu=0.5)
sim = gf.Simulation(state, dt=1e-4, law=law)
sim.add_force(gf.Gravity([0.0, 0.0, -G]))
sim.add_force(gf.WallForce([gf.walls.Plane(point=(0, 0, 0), normal=(0, 0, 1))], law,
                           wall_type=0))

# %%
# Running it
# ----------
# An observer records every grain's height every 10 steps, by grain id (the state may
# re-sort its particles in memory), for 5 time units: long enough for the highest grain to
# land and bounce.

times, z = [], []


def record(ctx):
    order = np.argsort(ctx.state.id)
    times.append(ctx.time)
    z.append(ctx.state.x[order, 2].copy())


sim.add_observer(record, every=10)
sim.run(50_000)
times, z = np.array(times), np.array(z)

landing = np.sqrt(2.0 * (heights - RADIUS) / G)
for k in range(n):
    before = times < 0.98 * landing[k]
    error = np.abs(z[before, k] - (heights[k] - 0.5 * G * times[before] ** 2)).max()
    print(f"z0 = {heights[k]:.0f}: lands at t = {landing[k]:.3f}, "
          f"largest deviation from the parabola before landing {error:.1e}")
    assert error < 1e-3

# The first rebound of the lowest grain rises to r + e^2 (z0 - r) (energy after the bounce).
after = (times > landing[0]) & (times < landing[0] + 1.5)
apex = z[after, 0].max()
expected = RADIUS + RESTITUTION**2 * (heights[0] - RADIUS)
print(f"first rebound of z0 = {heights[0]:.0f}: apex {apex:.3f}, e^2 (z0 - r) + r = {expected:.3f}")

# %%
# The figure
# ----------
# Simulated heights (lines) and the free-fall parabolas (dotted) until each grain lands.

fig = Figure(figsize=(7, 4.5), layout="constrained")
FigureCanvasAgg(fig)
ax = fig.subplots()
for k in range(n):
    line, = ax.plot(times, z[:, k], label=f"$z_0$ = {heights[k]:.0f}")
    t = np.linspace(0.0, landing[k], 100)
    ax.plot(t, heights[k] - 0.5 * G * t**2, ":", color="k", lw=1)
ax.axhline(RADIUS, color="grey", lw=0.8)
ax.text(0.05, RADIUS, "wall contact ($z = r$)", va="bottom", ha="left", fontsize=8)
ax.plot([], [], ":", color="k", label=r"$z_0 - g t^2 / 2$")
ax.set(xlabel="time $t$", ylabel="height $z$ of the grain's centre",
       title=f"free fall onto a plane wall (restitution {RESTITUTION})")
ax.legend(fontsize=8)
fig.savefig("free_fall.png", dpi=120)
