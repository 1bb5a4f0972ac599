"""The hopper study's reduced lambda sweep (the authors' path) with another pile: a number of
grains, a container width or a realization other than the study's, to tell how the friction
limit and lambda_c follow the pile's height (docs/hopper_study.md, "lambda_c and the
friction limit" and "3D").

Runs the ``q2d`` (or ``q3d``) sweep of :data:`grainflow.studies.hopper_authors.AUTHORS_REDUCED`
with ``hopper.n = N`` and ``hopper.width = W`` into OUT_DIR (finished points are kept), then
prints the free Beverloo exponent at each lambda, Q at each width, the fits with beta fixed
at the limits (the paper's, and at lambda = 0 also the viscous d), and lambda_c from
eq. (14) through the free and the bounded betas, and through the free betas between their
measured limits. ``--lambdas`` replaces the sweep's lambda (3D default: the full plan's
0, 0.01, 0.05, 0.181, 1, inf; the reduced study runs only the two limits).

Usage::

    python scripts/hopper_lambda_sweep.py OUT_DIR [--dim 2] [--n 3200] [--width W]
        [--seed 1] [--lambdas 0 inf]

2D, N = 3200: 42 runs, about 2,150 CPU-s, 18 minutes on 2 cores; 3D, W = 16.667: 36 runs,
3,175 CPU-s, 27 minutes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from grainflow import interrupt
from grainflow.analysis.hopper import fit_beverloo
from grainflow.studies.hopper_authors import (AUTHORS_FULL, AUTHORS_REDUCED, SIGMOID_KINDS,
                                              _sigmoids, collect, sweep_specs, three_fits)
from grainflow.studies.hopper_results import fmt_lambda_c
from grainflow.studies.points import run_sweeps
from grainflow.sweep import parse_sweep


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--dim", type=int, choices=(2, 3), default=2)
    parser.add_argument("--n", type=int, default=None,
                        help="grains in the hopper (study: 1600 in 2D, 6400 in 3D)")
    parser.add_argument("--width", type=float, default=None,
                        help="W / sigma_avg: side walls (2D) or cylinder diameter (3D); "
                        "default the scenario's (50 and 25)")
    parser.add_argument("--seed", type=int, default=None,
                        help="realization (the sweep's seed_start; study: 0), for a replicate")
    parser.add_argument("--lambdas", type=float, nargs="+", default=None,
                        help="lambda values (default: the study's 2D sweep, the full plan's 3D)")
    args = parser.parse_args(argv)
    name = f"q{args.dim}d"
    raw = sweep_specs(AUTHORS_REDUCED)[name].model_dump()
    if args.n is not None:
        raw["base"]["hopper"]["n"] = args.n
    if args.width is not None:
        raw["base"]["hopper"]["width"] = args.width
    if args.seed is not None:  # the sweep sets run.seed of each point from its own seeds
        raw["seed_start"] = args.seed
    lambdas = args.lambdas or (list(AUTHORS_FULL.lambdas_3d) if args.dim == 3 else None)
    if lambdas is not None:
        raw["overrides"]["hopper.lam"]["values"] = lambdas
    points = run_sweeps({name: parse_sweep(raw)}, args.out, progress="plain")[name]
    print(f"{len(points.rundirs)} runs, {points.cpu:.0f} CPU-s")
    fits = []
    for key, series in sorted(collect(args.out / name).items()):
        lam = key[0]
        three = three_fits(series, args.dim, lam)
        fits.append((lam, three))
        free = three.get("free")
        print(f"lambda = {lam:g}: free beta = " + (f"{free.beta:.3f} ± {free.beta_err:.3f}, "
                                                   f"k = {free.k:.2f}" if free else "not fit"))
        print("   Q(w): " + ", ".join(f"{w:g}: {q:.4g}" for w, q in sorted(zip(series.w,
                                                                                 series.Q))))
        fixed = [three["fixed"]] if "fixed" in three else []
        if lam == 0.0 and len(series.w) >= 4:  # the viscous exponent beside Beverloo's
            fixed.append(fit_beverloo(series.w, series.Q, Q_err=series.Q_err, beta=args.dim))
        for fit in fixed:
            print(f"   beta fixed at {fit.beta:g}: k = {fit.k:.2f}, "
                  f"chi2/dof = {fit.chi2 / fit.dof:.2f}")
    sigmoids = _sigmoids(fits, args.dim)
    for kind, label in SIGMOID_KINDS.items():
        s = sigmoids.get(kind)
        detail = f" (b = {s.b:.2f}, chi2 = {s.chi2:.1f}, {s.dof} dof)" if s else ""
        print(f"lambda_c from {label}: {fmt_lambda_c(s)}{detail}")


if __name__ == "__main__":
    interrupt.run(main)
