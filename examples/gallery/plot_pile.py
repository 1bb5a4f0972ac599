"""# A settling pile (the README quickstart)

The quickstart of the README, as a figure: 405 frictional spheres (diameter 1, density 1)
start on a loose lattice above a floor, fall under gravity (g = 1, code units) and settle
into a pile on the plane `z = 0`, periodic in x and y. The contact law is the linear
spring-dashpot with tangential history (`gf.GranularLaw`, restitution 0.8, contact time
0.01, Coulomb friction 0.5) for grain pairs and for the floor.

The figure shows the kinetic energy rising in free fall, then falling by four orders of
magnitude once the grains have landed, the number of contacts per grain rising to a steady
value between four and five, and two side views: the grains still moving at t = 6,
coloured by speed, and the pile at rest coloured by each grain's number of contacts. A
similar pile from a TOML file (2 mm glass beads in a box, SI units): `grainflow run
examples/pile3d.toml -o runs/pile`.
"""

# %%
# The set-up, exactly as in the README
# ------------------------------------
# Grains on a 9 x 9 x 5 lattice of spacing 1.1 (none touching) with a small random jitter.
# `gf.stiffness_and_damping` turns the restitution and contact time of a binary collision
# (effective mass `pi/12`, half a grain's mass) into the spring stiffness and damping.

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import grainflow as gf
from grainflow.frame import PAIR, WALL
from grainflow.plotting.snapshot import snapshot

box = gf.Box(lo=np.zeros(3), hi=np.array([10.0, 10.0, 40.0]), periodic=(True, True, False))
state = gf.ParticleState(3, box)
rng = np.random.default_rng(1)
cells = np.stack(np.meshgrid(*(np.arange(n) for n in (9, 9, 5)), indexing="ij"), -1).reshape(-1, 3)
x = 0.6 + 1.1 * cells + rng.uniform(-0.02, 0.02, cells.shape)  # 405 grains, none touching
state.add_particles(x, radius=0.5, density=1.0)
law = gf.GranularLaw()
kn, gamma_n = gf.stiffness_and_damping(restitution=0.8, contact_time=0.01, meff=np.pi / 12)
law.set_all(kn=kn, gamma_n=gamma_n, mu=0.5)
sim = gf.Simulation(state, dt=2e-4, law=law)
sim.add_force(gf.Gravity([0.0, 0.0, -1.0]))
sim.add_force(gf.WallForce([gf.walls.Plane(point=(0, 0, 0), normal=(0, 0, 1))], law, wall_type=0))

# %%
# Record the energy and the contacts while it runs
# ------------------------------------------------
# An observer is any callable taking the read-only observer context; here it runs every
# 500 steps and stores the time, the kinetic energy (translational + rotational), the
# height of the centre of mass and the mean number of contacts per grain,
# `Z = (2 N_pairs + N_floor) / N`.
#
# The README stops after 20,000 steps (t = 4), while the grains are still landing and
# bouncing (restitution 0.8); here the run goes on to t = 16, when the pile is at rest.

log = {"t": [], "ke": [], "z": [], "Z": []}
landing = []  # one frame while the grains land (t = 6)
movie = []  # a frame every 1000 steps (t = 0.2) for the movie at the end


def record(ctx):
    st = ctx.state
    log["t"].append(ctx.time)
    log["ke"].append(st.kinetic_energy() + st.rotational_energy())
    log["z"].append(float(np.mean(st.x[:, 2])))
    contacts = ctx.contacts()
    n_pairs = np.count_nonzero(contacts.kind == PAIR)
    n_floor = np.count_nonzero(contacts.kind == WALL)
    log["Z"].append((2 * n_pairs + n_floor) / st.n)
    if ctx.step == 30_000:
        landing.append(ctx.frame())
    if ctx.step % 1000 == 0 and ctx.step <= 40_000:
        movie.append(ctx.frame())


sim.add_observer(record, every=500)
sim.run(80_000)
log = {k: np.array(v) for k, v in log.items()}

# %%
# The key numbers
# ---------------
# At t = 16 the pile is at rest: its kinetic energy is a tiny fraction of the potential
# energy it released, and each grain touches between four and five others (or the floor).

m_total = float(np.sum(sim.state.mass))
lost = m_total * 1.0 * (log["z"][0] - log["z"][-1])  # m g dz, g = 1
print(f"final kinetic energy {log['ke'][-1]:.3g} = {log['ke'][-1] / lost:.1e} of the "
      f"potential energy released ({lost:.4g}); Z = {log['Z'][-1]:.2f} contacts per grain")
assert log["ke"][-1] < 1e-3 * lost, "the pile has not settled"

# %%
# Energy and contacts over time
# -----------------------------
# A `Figure` on its own Agg canvas (no pyplot): kinetic energy on a log scale, the contacts
# per grain on a second axis.

fig = Figure(figsize=(6.5, 4), layout="constrained")
FigureCanvasAgg(fig)
ax = fig.add_subplot()
ax.semilogy(log["t"], log["ke"], "C0-", label="kinetic energy")
ax.set(xlabel="time (code units, $\\sqrt{d/g}$)", ylabel="kinetic energy (code units)",
       title="405 grains settling on a floor")
ax2 = ax.twinx()
ax2.plot(log["t"], log["Z"], "C1--", label="contacts per grain $Z$")
ax2.set_ylabel("contacts per grain $Z$", color="C1")
fig.legend(loc="upper right", bbox_to_anchor=(0.85, 0.95))
fig.savefig("pile_energy.png", dpi=120)

# %%
# Side views: landing, and at rest
# --------------------------------
# `grainflow.plotting.snapshot.snapshot` draws a frame with every grain at its true size;
# a 3D frame is projected on a plane (`"xz"`: the side view), nearer grains drawn over
# farther ones. At t = 6 the grains are still moving (coloured by speed); at rest we colour
# each grain by its number of contacts, computed from the frame's contact list (pairs count
# for both grains, the floor for one): the few grains with none are rattlers.

snapshot(landing[0], Path("pile_landing.png"), plane="xz", color_by="speed")

final = sim.frame(contacts=True)
index_of = {pid: k for k, pid in enumerate(final.id)}
touching = [index_of[p] for p in final.contacts.i]
touching += [index_of[p] for p in final.contacts.of_kind(PAIR).j]
n_contacts = np.bincount(touching, minlength=final.n).astype(float)
print(f"rattlers (no contact): {np.count_nonzero(n_contacts == 0)} of {final.n}")
snapshot(final, Path("pile_at_rest.png"), plane="xz", color_by=n_contacts,
         title="at rest (t = 16), coloured by contacts per grain")

# %%
# A movie, ray-traced
# -------------------
# `grainflow.plotting.movie.write_movie` turns frames (or a saved run: `grainflow view
# RUN` on the command line) into an MP4 or a GIF. 3D frames are ray-traced by OVITO's
# software renderer, spheres at their true radius seen from a fixed camera, coloured on one
# speed scale for the whole movie, with the step and time above the picture. Here: the first
# t = 8 of the run, one picture per 0.2 time units. Where OVITO cannot render (it needs a
# Vulkan loader and Mesa's CPU driver: `bash scripts/setup_system.sh`), the movie falls back
# to matplotlib's flat side view and says so.

from grainflow.plotting.movie import write_movie
from grainflow.plotting.render3d import RendererUnavailable

try:
    write_movie(movie, "pile.mp4", color_by="speed", fps=10, size=(640, 480), progress="none")
    print("rendered by OVITO")
except RendererUnavailable as why:
    print(f"OVITO cannot render here ({why}); drawn with matplotlib instead")
    write_movie(movie, "pile.mp4", color_by="speed", fps=10, size=(640, 480),
                renderer="matplotlib", plane="xz", progress="none")
