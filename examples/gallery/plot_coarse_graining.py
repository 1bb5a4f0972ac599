"""# Coarse-graining: stress and packing fraction in a settled layer

`grainflow.analysis.cg` (A1) turns saved frames into continuum fields: densities, velocity,
temperature and the stress, kinetic plus contact, with each contact's force spread along its
branch line (docs/coarse_graining.md). Here 300 frictional disks settle under gravity into a
layer on a floor, periodic sideways, and we coarse-grain one frame with its contact list:
a map of the pressure, horizontal slab profiles of the packing fraction and the stress, and
the momentum balance div sigma = rho g. Averaged over a periodic slab it says that the
vertical stress at each height is the weight of the grains above it per unit width,
sigma_yy(y) = g int_y^top rho dy'.

In the figures, the pressure grows with depth (with force chains at a fine resolution), the
packing fraction is near 0.8 in the bulk and drops at the floor and the free surface, and
the vertical stress lies on the weight-above curve to a fraction of a percent.

Shortened: one static frame of a small layer. The studies coarse-grain flowing frames over
time windows with block error bars (the jet's rheology, `grainflow study jet`; the hopper's
centre line, `examples/coarse_grain_hopper.py`).
"""

# %%
# A settled layer
# ---------------
# 300 disks of radii 0.45-0.55 (density 1, g = 1) start on a loose lattice, periodic in x
# (width 15), above a floor. The contact dashpot and a drag (switched off at the end) bring
# them to rest; `sim.frame(contacts=True)` then holds every contact's force and branch
# vector, walls included.

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import grainflow as gf
from grainflow.analysis.cg import Cartesian, Lucy, coarse_grain
from grainflow.plotting.cg_plots import plot_field_map, plot_profiles

G, WIDTH = 1.0, 15.0
rng = np.random.default_rng(11)
n, cols = 300, 14
radius = rng.uniform(0.45, 0.55, n)
x = (np.arange(n) % cols + 0.5) * (WIDTH / cols) + rng.uniform(-0.02, 0.02, n)
y = 0.6 + (np.arange(n) // cols) * 1.15
state = gf.ParticleState(2, gf.Box(lo=np.array([0.0, 0.0]), hi=np.array([WIDTH, 40.0]),
                                   periodic=(True, False)))
state.add_particles(np.c_[x, y], radius, density=1.0)
law = gf.GranularLaw(n_types=2)
law.set_all(kn=2e3, gamma_n=20.0, mu=0.5)
sim = gf.Simulation(state, dt=1e-3, law=law, seed=3)
sim.dt = sim.stable_time_step()  # 1/50 of the contact time
sim.add_force(gf.Gravity([0.0, -G]))
sim.add_force(gf.WallForce([gf.walls.Plane(point=(0, 0), normal=(0, 1))], law, wall_type=1))
drag = sim.add_force(gf.Drag(0.5, per_mass=True))
sim.run(40_000, until=lambda s: s.state.kinetic_energy() < 1e-8, until_every=1000)
sim.remove_force(drag)
sim.run(2000)
frame = sim.frame(contacts=True)
print(f"settled at t = {frame.time:.1f}: {frame.contacts.i.size} contacts, "
      f"kinetic energy {state.kinetic_energy():.1e}")

# %%
# A pressure map
# --------------
# `Cartesian.uniform` makes a grid of cells; the Lucy kernel (support 1.5, about one and a
# half diameters) smooths the fields. The contact stress of each contact is spread along its
# branch line, so the load paths through the packing show up.

top = float(frame.position[:, 1].max()) + 1.0
grid = Cartesian.uniform([0.0, 0.0], [WIDTH, top], (60, int(4 * top)))
pmap = coarse_grain([frame], grid, Lucy(1.5))
plot_field_map(pmap, "pressure", Path("cg_pressure_map.png"),
               title="pressure P = tr(σ)/2, Lucy kernel of support 1.5")

# %%
# Slab profiles and the momentum balance
# --------------------------------------
# A grid with one bin spanning the periodic width exactly averages over x (branch lines
# crossing the boundary are wrapped) and resolves y finely; the kernel is Lucy's of
# support 1 (about a diameter). Stress is compression-positive. Within the kernel's reach
# of the floor the balance includes the floor's reaction, which the kernel spreads over that
# layer (its contacts' branch lines start at the floor), so the check is made above it.

KERNEL = Lucy(1.0)
slabs = coarse_grain([frame], Cartesian([[0.0, WIDTH], np.linspace(-1.0, top, 151)]), KERNEL)
plot_profiles(slabs, ["packing_fraction", "stress"], Path("cg_profiles.png"),
              components=[None, (1, 1)])

(yc,) = slabs.coordinates.centres  # the one resolved coordinate, y
sigma_yy = slabs.stress[:, 1, 1]
rho = slabs.mass_density
dy = yc[1] - yc[0]
# g int_y^top rho dy', by the trapezoid rule from the top down
weight_above = G * np.concatenate([np.cumsum(0.5 * (rho[1:] + rho[:-1])[::-1] * dy)[::-1],
                                   [0.0]])
above_floor = yc >= KERNEL.reach
floor = weight_above[above_floor][0]
error = np.max(np.abs(sigma_yy - weight_above)[above_floor]) / floor
total = G * frame.mass.sum() / WIDTH
print(f"weight per unit width {total:.3f}; at y = {KERNEL.reach:g}: sigma_yy = "
      f"{sigma_yy[above_floor][0]:.3f}, weight above {floor:.3f}; largest |sigma_yy - weight "
      f"above| for y >= {KERNEL.reach:g}: {error:.2%} of it")
assert error < 0.01, "the momentum balance should hold to the frame's force imbalance"

fig = Figure(figsize=(8.5, 4), layout="constrained")
FigureCanvasAgg(fig)
ax1, ax2 = fig.subplots(1, 2)
ax1.plot(sigma_yy, yc, "C0-", lw=2, label=r"$\sigma_{yy}$, coarse-grained")
ax1.plot(weight_above, yc, "k--", label=r"$g\int_y^{top}\rho\,dy'$, weight above")
for ax in (ax1, ax2):
    ax.axhspan(yc[0], KERNEL.reach, color="0.85", lw=0, label="floor + kernel reach")
ax1.set(xlabel=r"vertical stress ($\rho_s g d$ per unit width)", ylabel="height $y$ ($d$)",
        title="div σ = ρg, averaged over x")
ax1.legend(fontsize=8)
ax2.plot((sigma_yy - weight_above) / weight_above.max(), yc, "C3-")
ax2.set(xlabel=r"($\sigma_{yy}$ - weight above) / floor stress", ylabel="height $y$ ($d$)",
        title="residual")
fig.savefig("cg_momentum_balance.png", dpi=120)
