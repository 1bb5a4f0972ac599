"""# A movie of the demo: a 2D hopper discharging

`grainflow demo` runs a small 2D hopper discharge of seed 003's soft particles: 1,600
bidisperse disks (diameters 1 and 1.4) in a flat-bottomed hopper with an orifice of 10
sigma_avg, in the drag-limited limit (lambda -> inf), with the grains that leave through the
orifice put back on top. It prints the flow rate with its error bar and writes a snapshot, the
flow rate against time and a movie, `movie.mp4`, made by
`grainflow.plotting.movie.write_movie` (the Python side of `grainflow view RUN`).

Here the demo runs for 150 t0 instead of its default 600 t0 so that the page builds in
under a minute: the movie shows the pile settling from its loose random start, the jet
through the orifice and the reinserted grains raining down on top. The flow rate of so short
a run still contains the start-up transient (the demo's default length lets the analysis
discard it): for a steady rate run `grainflow demo` itself, and for the Beverloo law and
beta(lambda) the study, `grainflow study hopper`.
"""

# %%
# Running the demo
# ----------------
# `demo` writes everything into the directory it is given: `snapshot.png`,
# `flow_rate.png`, `events.csv` (one line per grain through the orifice) and
# `movie.mp4` (`movie_frames` pictures spread over the run, grains coloured by speed on one
# colour scale for the whole movie).

from grainflow.studies.hopper_demo import demo

flow = demo(".", duration=150.0, movie_frames=60, progress="plain")

# %%
# The same from the command line
# ------------------------------
# `grainflow demo -o grainflow-demo` runs the full-length demo. Any saved run gets a movie
# with `grainflow view RUN` (`--color-by type|network`, `--every K`, `--fps`, `-o
# movie.gif` for a GIF); 3D runs are ray-traced by OVITO.

print(f"flow rate over the short run: {flow.flow_rate:.3g} +/- {flow.flow_rate_err:.2g} Q0 "
      f"({flow.n_events} grains through the orifice)")
