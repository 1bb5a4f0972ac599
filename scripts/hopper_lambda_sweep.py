"""The hopper study's reduced 2D lambda sweep (the authors' path) with another number of
grains, to tell how lambda_c follows the pile's height (docs/hopper_study.md, "lambda_c and
the friction limit").

Runs the ``q2d`` sweep of :data:`grainflow.studies.hopper_authors.AUTHORS_REDUCED` (six
widths, seven lambda, 150 t0) with ``hopper.n = N`` into OUT_DIR (finished points are kept),
then prints the free Beverloo exponent at each lambda and lambda_c from eq. (14) through the
free and the bounded betas, and through the free betas between their measured limits.

Usage (N = 3200: 42 runs, about 2,150 CPU-s, 18 minutes on 2 cores)::

    python scripts/hopper_lambda_sweep.py OUT_DIR [--n 3200]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from grainflow.studies.hopper_authors import (AUTHORS_REDUCED, SIGMOID_KINDS, _sigmoids,
                                              collect, sweep_specs, three_fits)
from grainflow.studies.points import run_sweeps
from grainflow.sweep import parse_sweep


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--n", type=int, default=3200, help="grains in the hopper (study: 1600)")
    args = parser.parse_args(argv)
    raw = sweep_specs(AUTHORS_REDUCED)["q2d"].model_dump()
    raw["base"]["hopper"]["n"] = args.n
    points = run_sweeps({"q2d": parse_sweep(raw)}, args.out, progress="plain")["q2d"]
    print(f"{len(points.rundirs)} runs, {points.cpu:.0f} CPU-s")
    fits = [(key[0], three_fits(series, 2, key[0]))
            for key, series in sorted(collect(args.out / "q2d").items())]
    for lam, three in fits:
        free = three.get("free")
        print(f"lambda = {lam:g}: free beta = " + (f"{free.beta:.3f} ± {free.beta_err:.3f}, "
                                                   f"k = {free.k:.2f}" if free else "not fit"))
    sigmoids = _sigmoids(fits, 2)
    for kind, label in SIGMOID_KINDS.items():
        s = sigmoids.get(kind)
        print(f"lambda_c from {label}: " + (f"{s.lambda_c:.4f} ± {s.lambda_c_err:.4f} "
                                            f"(b = {s.b:.2f}, chi2 = {s.chi2:.1f}, "
                                            f"{s.dof} dof)" if s else "not fit"))


if __name__ == "__main__":
    main()
