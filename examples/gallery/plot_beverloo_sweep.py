"""# A parameter sweep: Beverloo's law from three hopper runs

`grainflow.sweep` runs many ordinary runs on dask.distributed and records each one, with
the numbers its analyses return, in a SQLite catalog. Here a sweep file (written inline as a
TOML string) varies the orifice width w of a small 2D soft-particle hopper of seed 003
(friction limit, lambda = 0, the authors' conventions); the analysis
`grainflow.studies.hopper_results:flow_summary` reads each run's orifice crossings and
returns the flow rate Q with its error bar. We read the catalog back and fit Beverloo's law
Q = C (w/sigma_avg - k)^beta with `grainflow.analysis.hopper.fit_beverloo`, with beta fixed
at 3/2, the seed's 2D value in this limit.

The figure shows Q rising faster than linearly with w along the fitted curve, and the
collapse Q/C against w - k on log axes, where the points follow the slope 3/2.

Shortened: 500 grains in a hopper 22 sigma_avg wide, 3 widths, 50 t0 each, about 30 s on
2 cores. The seed's study (1600 grains, 50 wide, six to twenty widths, seven to twelve
lambda, 150 t0) is `grainflow study hopper -o hopper_study`; docs/hopper_study.md and
docs/sweeps.md describe both.
"""

# %%
# The sweep file
# --------------
# A sweep is a base configuration (here inline under `[base]`; usually `base =
# "hopper2d.toml"`) and `[overrides]`: dotted config fields and their values. Every point's
# configuration is validated before anything runs. The same text in a file runs with
# `grainflow sweep beverloo.toml -o sweep` and `grainflow sweep-status sweep` lists the
# points and their numbers.

from pathlib import Path

from distributed import LocalCluster

from grainflow.analysis.hopper import fit_beverloo
from grainflow.plotting.hopper_plots import plot_beverloo
from grainflow.sweep import Catalog, load_sweep, run_sweep

SWEEP = """
name = "beverloo"
analyses = ["grainflow.studies.hopper_results:flow_summary"]

[base]
scenario = "hopper2d"
dim = 2

[base.run]
duration = 50.0            # t0 = sqrt(sigma_avg / g)
minimize = true            # FIRE removes the overlaps of the random fill first
max_overlap_fraction = 2.0
seed = 0

[base.output]
thermo_every = 5000
frames_every = 0
checkpoint_every = 0
snapshot = false
progress_interval = 600

[base.hopper]
convention = "authors"
n = 500
width = 22.0
orifice_width = 5.0
lam = 0.0

[overrides]
"hopper.orifice_width" = [3.0, 5.0, 7.0]
"""
Path("beverloo.toml").write_text(SWEEP)
spec = load_sweep("beverloo.toml")
for point in spec.points():
    print(point.point_id, point.label())

# %%
# Run it on a dask cluster
# ------------------------
# `run_sweep(spec, "sweep")` alone would start a `LocalCluster` of one single-threaded worker
# *process* per core. Worker processes start by importing the driving script again, so a
# script that does that must call `run_sweep` under `if __name__ == "__main__":`, which
# cannot be split into the cells of a gallery page. Here we start the cluster ourselves
# with workers as threads of this process (`processes=False`: nothing is imported again)
# and pass its address, exactly as one passes the address of a SLURM or PBS cluster
# (`scheduler="tcp://host:8786"`, docs/sweeps.md); each run picks one compute thread, as
# grainflow does for small systems. Running the sweep a second time finds every point done
# and runs nothing: an interrupted sweep continues where it stopped.

with LocalCluster(processes=False, n_workers=2, threads_per_worker=1,
                  dashboard_address=None) as cluster:
    result = run_sweep(spec, "sweep", scheduler=cluster.scheduler_address, progress="none")
    again = run_sweep(spec, "sweep", scheduler=cluster.scheduler_address, progress="none")
assert result.ok and again.skipped == again.total == 3

# %%
# Read the catalog and fit Beverloo's law
# ---------------------------------------
# Each catalog row has the point's parameters, its status and the numbers the analyses
# returned (`row.summary`). `fit_beverloo` is a weighted least-squares fit; with `beta`
# given it fits only C and k.

with Catalog.in_dir("sweep", readonly=True) as catalog:
    rows = catalog.rows(status="done")
w = [row.params["hopper.orifice_width"] for row in rows]
Q = [row.summary["Q"] for row in rows]
Q_err = [row.summary["Q_err"] for row in rows]
for row in rows:
    print(f"w = {row.params['hopper.orifice_width']:g}: Q = {row.summary['Q']:.3f} "
          f"+/- {row.summary['Q_err']:.3f} ({row.summary['wall_time_s']:.0f} s)")
fit = fit_beverloo(w, Q, Q_err=Q_err, beta=1.5)
print(f"Beverloo, beta = 3/2: C = {fit.C:.3f} +/- {fit.C_err:.3f}, "
      f"k = {fit.k:.2f} +/- {fit.k_err:.2f}, chi2/dof = {fit.chi2 / fit.dof:.2f}")
assert 0 < fit.k < 3 and fit.chi2 / fit.dof < 10

# %%
# The figure
# ----------
# `plot_beverloo` takes one or several fits (they carry their data): Q against w with the
# fitted curve, and the collapse Q/C against w/sigma_avg - k with reference slopes
# d - 1/2 = 3/2 (friction limit) and d - 3/2 = 1/2 (drag limit).

plot_beverloo(fit, Path("beverloo.png"), dim=2)
