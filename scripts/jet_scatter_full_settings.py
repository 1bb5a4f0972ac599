"""The jet study's scattering angle psi0(X) at the full plan's settings, to tell the
reductions' effect on C0, C1 and C2 from the model's (docs/jets.md, "Results of the reduced
study": the reduced study's C1 is 18 % below the thesis's 0.563).

Runs the ``scatter`` sweep of :data:`grainflow.studies.jet_study.FULL` (2,000 grains, run to
t = 80, window 32-80, the eleven X = 0.4-5 of Fig. 4.2) at e = 0.75, Fig. 4.2's restitution,
with ``--replicas`` replicas (the full study: 10) into OUT_DIR (finished points are kept),
then prints psi0 per X and the fit of Fig. 4.2's interpolation function by both definitions
of psi0 (eq. 4.3's force balance, the one the study's table uses, and the outgoing
velocities), over every X and over the reduced plan's range X = 0.5-5 (the eleven without 0.4).

Usage (3 replicas: 33 runs, about 15 minutes on 2 cores)::

    python scripts/jet_scatter_full_settings.py OUT_DIR [--replicas 3] [--workers N]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from grainflow import interrupt
from grainflow.studies.jet_study import FULL, SEED, _mean_by, fit_psi0_means, sweep_specs
from grainflow.studies.points import run_sweeps


def _fit_line(X: np.ndarray, psi0: np.ndarray, err: np.ndarray, label: str) -> str:
    fit = fit_psi0_means(X, psi0, err)
    if fit is None:
        return f"  {label}: fewer than four X, not fit"
    return f"  {label}: " + ", ".join(
        f"{name} = {getattr(fit, name):.3f} ± {getattr(fit, name + '_err'):.3f} "
        f"(thesis {SEED[name][0]:g})" for name in ("C0", "C1", "C2"))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--replicas", type=int, default=3)
    parser.add_argument("--workers", type=int, default=None,
                        help="local dask workers (default: one per core)")
    args = parser.parse_args(argv)
    plan = dataclasses.replace(FULL, replicas=args.replicas, scatter_e=(0.75,))
    points = run_sweeps({"scatter": sweep_specs(plan)["scatter"]}, args.out,
                        n_workers=args.workers, progress="plain")["scatter"]
    print(f"{len(points.rundirs)} runs, {points.cpu:.0f} CPU-s")
    keys = [s["X"] for s in points.summaries]
    for definition, label in (("psi0", "eq. 4.3 (force balance)"),
                              ("psi0_velocity", "outgoing velocities")):
        X, psi0, err = _mean_by(keys, [s[definition] for s in points.summaries])
        print(f"== psi0 by {label}")
        print("  X:    " + " ".join(f"{x:6.2f}" for x in X))
        print("  psi0: " + " ".join(f"{p:6.3f}" for p in psi0))
        print("  ±:    " + " ".join(f"{e:6.3f}" for e in err))
        print(_fit_line(X, psi0, err, "every X"))
        keep = X >= 0.5
        print(_fit_line(X[keep], psi0[keep], err[keep], "X >= 0.5"))


if __name__ == "__main__":
    interrupt.run(main)
