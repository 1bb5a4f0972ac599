"""The hopper study's hard-particle limit (seed 003, Fig. 10) at stiffnesses of our choosing,
to tell whether the offset k still moves with E_sp where the study stops (docs/hopper_study.md:
the drag limit's k is 2.6-2.75 with beta fixed at 1/2 at E_sp = 1e4-1e5, the seed's 3.4).

Runs the study's ``hard2d`` sweep (:data:`grainflow.studies.hopper_authors.AUTHORS_FULL`: the
authors' conventions, walls as stiff as the grains, ten of their widths) at each ``--E`` and
``--lambdas`` into OUT_DIR/hard2d_E<E> (finished points are kept), then prints, per E_sp and
lambda, Q(w) and the three fits the report gives: free, beta fixed as the paper fixed it, and
the paper's bounded fit. Then, since the paper does not say which widths its hard-limit fits
used, the free and fixed fits again without the smallest widths (``--drop``, default up to
5): where Q(w) is not the fixed beta's curve, the fixed fit's k depends on the range.

Usage::

    python scripts/hopper_hard_limit.py OUT_DIR [--E 1e4 1e5 1e6] [--lambdas inf]
        [--duration 100] [--workers N] [--drop 5]

The time step follows the stiffest contact (dt ~ E_sp^-1/2): at 100 t0 a run takes about 33 s
at 1e4, 80 s at 1e5 and 190 s at 1e6 on one thread (AMD EPYC); the default 30 runs take
3,000 CPU-s, 25 minutes on 2 cores (docs/hopper_study.md, "The hard drag limit's k"). At
``--lambdas 0`` (the friction limit) runs take about 45 s at 1e4 and 95 s at 1e5.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path

import numpy as np

from grainflow import interrupt
from grainflow.studies.hopper_authors import (AUTHORS_FULL, collect, hard_name, sweep_specs,
                                              three_fits)
from grainflow.studies.hopper_results import Series
from grainflow.studies.points import run_sweeps
from grainflow.sweep import parse_sweep


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--E", type=float, nargs="+", default=[1e4, 1e5, 1e6],
                        help="E_sp = E_w of each series (study: 1e4 and 1e5)")
    parser.add_argument("--lambdas", type=float, nargs="+", default=[math.inf],
                        help="lambda values (study: 0 and inf)")
    parser.add_argument("--duration", type=float, default=100.0,
                        help="t0 of flow (reduced study 100, full 150)")
    parser.add_argument("--widths", type=float, nargs="+",
                        default=list(AUTHORS_FULL.widths_hard),
                        help="w / sigma_avg (default: the full study's ten)")
    parser.add_argument("--workers", type=int, default=None,
                        help="local dask workers (default: one per core)")
    parser.add_argument("--drop", type=int, default=5,
                        help="refit without up to this many of the smallest widths (default 5)")
    args = parser.parse_args(argv)
    # the study's own hard-limit sweeps at these stiffnesses, widths and duration
    plan = dataclasses.replace(AUTHORS_FULL, hard_E_sp=tuple(args.E),
                               widths_hard=tuple(args.widths), duration_hard=args.duration)
    study = sweep_specs(plan)
    specs = {}
    for E in args.E:
        raw = study[hard_name(E)].model_dump()
        raw["overrides"]["hopper.lam"]["values"] = list(args.lambdas)
        specs[hard_name(E)] = parse_sweep(raw)
    points = run_sweeps(specs, args.out, n_workers=args.workers, progress="plain")
    for E in args.E:
        name = hard_name(E)
        print(f"== E_sp = E_w = {E:g}: {len(points[name].rundirs)} runs, "
              f"{points[name].cpu:.0f} CPU-s")
        for key, series in sorted(collect(args.out / name).items()):
            lam = key[0]
            print(f"lambda = {lam:g}: Q(w) " + ", ".join(
                f"{w:g}: {q:.4g}" for w, q in sorted(zip(series.w, series.Q))))
            if series.clogged:
                print(f"   clogged at w = {sorted(series.clogged)}")
            for kind, fit in three_fits(series, 2, lam).items():
                print(f"   {kind:8s} beta = {fit.beta:.3f} ± {fit.beta_err:.3f}, "
                      f"k = {fit.k:.2f} ± {fit.k_err:.2f}, C = {fit.C:.3g}, "
                      f"chi2/dof = {fit.chi2 / max(fit.dof, 1):.2f}")
            for dropped in range(1, args.drop + 1):
                _print_range(series, 2, lam, dropped)


def _print_range(series: Series, dim: int, lam: float, dropped: int) -> None:
    """The free and fixed fits of a series without its ``dropped`` smallest widths."""
    order = np.argsort(series.w)[dropped:]
    if len(order) < 4:
        return
    part = dataclasses.replace(series, w=[series.w[i] for i in order],
                               Q=[series.Q[i] for i in order],
                               Q_err=[series.Q_err[i] for i in order])
    fits = three_fits(part, dim, lam)
    text = "; ".join(f"{kind} beta = {fit.beta:.2f}, k = {fit.k:.2f} ± {fit.k_err:.2f} "
                     f"(chi2/dof {fit.chi2 / max(fit.dof, 1):.1f})"
                     for kind, fit in fits.items() if kind in ("free", "fixed"))
    print(f"   w >= {min(part.w):g} ({len(order)} widths): {text}")


if __name__ == "__main__":
    interrupt.run(main)
