"""# Deformable particles: rings settling into a pile

Deformable particles (DP, SPEC M6) are the third particle model of seed 003 (Cheng et al.,
Soft Matter 18, 8071 (2022), section 2.3): each grain is a closed ring of 16 vertex
particles held together by a shape energy (area, perimeter and bending terms, seed eq. 8).
Here 48 rough rings (vertices are disks of diameter l0 that repel the vertices of other
rings, seed eq. 9), a 50:50 mixture of two sizes with area ratio 1.96, fall under gravity
into a closed box and settle, damped by a drag on every vertex.

The figure shows the settled pile with each ring drawn as its polygon and coloured by its
shape parameter p^2 / (4 pi a) (1.013 for the regular 16-gon), the energies while the rings
fall and settle (the shape energy rises as the rings land and relaxes to the elastic energy
of the loaded pile), and the shape parameter against height: rings near the floor carry the pile's
weight and are the most deformed. Areas stay within a fraction of a percent of their
preferred value (area stiffness K_a = 1e4).

Shortened: a closed box with 48 rings for 25 t0. The seed's DP hopper (1600 rings) is
`examples/hopper2d_dp.toml` and the DP hopper study `grainflow study hopper-dp`; see
docs/dp.md.
"""

# %%
# Rings, shape energy and contacts
# --------------------------------
# Seed units: sigma_avg = g = rho = 1 (rho per unit area: a ring's mass is its area). The
# rings are built as regular 16-gons by `add_rings` on a loose lattice, with random
# orientations. `ShapeForce(k_a, k_l, k_b)` is the shape energy of every ring (the seed's
# K_a = 1e4, K_l = 10, K_b = 0.1: stiff areas, soft perimeters). Vertices of different
# rings repel with the soft harmonic law (energy E_c = 116, the authors' value) and rub
# with kinetic friction on their tangential relative velocity; walls act on vertices
# through the same law (type 2 for the walls).

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import grainflow as gf
from grainflow.engine.deformable import ShapeForce
from grainflow.insertion.dp_bodies import add_rings
from grainflow.plotting.snapshot import snapshot
from grainflow.rings import frame_rings, ring_outlines, shape_parameter

WIDTH = 10.0
A_SMALL = np.pi / 4 / 1.2**2  # a small ring: diameter sigma_s = sigma_avg / 1.2
rng = np.random.default_rng(3)

state = gf.ParticleState(2, gf.Box(lo=np.array([0.0, 0.0]), hi=np.array([WIDTH, 30.0]),
                                   periodic=(False, False)))
cx, cy = np.meshgrid(1.0 + 1.6 * np.arange(6), 1.0 + 1.6 * np.arange(8))  # none touching
centres = np.column_stack([cx.ravel(), cy.ravel()])
areas = rng.permutation(np.repeat([A_SMALL, 1.96 * A_SMALL], len(centres) // 2))
add_rings(state, centres, areas, n_vertices=16, contact="rough", rng=rng)

law = gf.SoftLaw(n_types=3)
law.set_all(epsilon=116.0, mu_k=1.0, kinetic_on="tangential")
sim = gf.Simulation(state, dt=1.0, law=law)  # dt set below from the time scales
shape = sim.add_force(ShapeForce(k_a=1e4, k_l=10.0, k_b=0.1, n_vertices=16))
box = [gf.walls.Plane(point=(0, 0, 0), normal=(0, 1, 0)),
       gf.walls.Plane(point=(0, 0, 0), normal=(1, 0, 0)),
       gf.walls.Plane(point=(WIDTH, 0, 0), normal=(-1, 0, 0))]
sim.add_force(gf.WallForce(box, law, wall_type=2))
sim.add_force(gf.Gravity([0.0, -1.0]))
sim.add_force(gf.Drag(1.0, per_mass=True))  # -gamma m v on every vertex, gamma = 1 / t0
sim.dt = sim.stable_time_step(0.05)  # 1/20 of the fastest oscillation (vertex contacts)
print(f"{len(centres)} rings, {state.n} vertices, dt = {sim.dt:.3g} t0")

# %%
# Run and record the energies
# ---------------------------
# The observer reads the shape energy and each ring's area from the `ShapeForce` (they need
# the simulation's force context, which the closure has; `shape.a0` holds the preferred
# areas by body id), and the kinetic energy from the state.

log = {"t": [], "shape": [], "kinetic": [], "area_error": []}


def record(ctx):
    body, a = shape.areas(sim.context)
    a0 = shape.a0[np.searchsorted(shape.ring_body, body)]  # preferred areas, by body id
    log["t"].append(ctx.time)
    log["shape"].append(shape.potential_energy(sim.context))
    log["kinetic"].append(ctx.state.kinetic_energy())
    log["area_error"].append(np.max(np.abs(a / a0 - 1)))


sim.add_observer(record, every=250)
sim.run(int(25.0 / sim.dt))
log = {k: np.array(v) for k, v in log.items()}
U0 = log["shape"][0]  # the regular polygons' own bending energy (the rings start regular)
print(f"shape energy above the regular rings' {log['shape'][-1] - U0:.3g} at the end "
      f"(peak {log['shape'].max() - U0:.3g}); kinetic energy {log['kinetic'][-1]:.2g} "
      f"(peak {log['kinetic'].max():.3g}); largest area change "
      f"{log['area_error'].max():.2%}")
assert log["kinetic"][-1] < 1e-2 * log["kinetic"].max(), "the pile has not settled"
assert log["area_error"].max() < 0.01, "areas should stay within 1 % at K_a = 1e4"

# %%
# Shape of every ring at the end
# ------------------------------
# `frame_rings` gives each ring's vertices in order, `ring_outlines` their positions (ring
# unbroken across periodic boundaries, none here), and `shape_parameter` p^2/(4 pi a).

frame = sim.frame()
bodies, index = frame_rings(frame)
outlines = ring_outlines(frame, index)
A = shape_parameter(outlines)
height = outlines[:, :, 1].mean(axis=1)
per_vertex = np.zeros(frame.n)
per_vertex[index] = A[:, None]
snapshot(frame, Path("dp_pile.png"), color_by=per_vertex, cmap="plasma",
         title=f"48 rough rings, t = {frame.time:.0f} t0; colour: shape parameter p²/(4πa)")
print(f"shape parameter: {A.min():.4f} to {A.max():.4f} (regular 16-gon 1.0131)")
assert A.min() > 1.0131 - 1e-3

# %%
# Energies and deformation against height
# ---------------------------------------
# Even a regular 16-gon has some bending energy (its edges are not parallel), so the shape
# energy is shown above its value at the start. The kinetic energy falls by three orders of
# magnitude; it does not reach zero: the rings' friction is kinetic (a force against the
# sliding velocity, seed eq. 12) with no static part, so the soft pile keeps creeping
# slowly.

fig = Figure(figsize=(10, 4), layout="constrained")
FigureCanvasAgg(fig)
ax1, ax2 = fig.subplots(1, 2)
ax1.semilogy(log["t"], log["kinetic"], label="kinetic energy")
ax1.semilogy(log["t"], log["shape"] - U0, label="shape energy (eq. 8) above regular rings")
ax1.set(xlabel="time ($t_0$)", ylabel="energy ($g\\rho\\sigma_{avg}^3$)",
        title="rings falling and settling")
ax1.legend()
ax2.plot(height, A, "o", mfc="none")
ax2.axhline(16 / np.pi * np.tan(np.pi / 16), color="k", ls=":", label="regular 16-gon")
ax2.set(xlabel="height of the ring's centre ($\\sigma_{avg}$)",
        ylabel="shape parameter $p^2/(4\\pi a)$", title="deformation under the pile's weight")
ax2.legend()
fig.savefig("dp_energy_and_shape.png", dpi=120)
