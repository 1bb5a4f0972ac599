"""The jet study's 2D rheology at the full plan's settings, to tell the reductions' effect on
the 2D fits from the model's (docs/jets.md, "The reductions do not cause the 2D misses").

Runs the ``rheo2d`` sweep of :data:`grainflow.studies.jet_study.FULL` (five phi_tilde, 8,000
grains, run to t = 300) with ``--replicas`` replicas (the full study: 10) into OUT_DIR
(finished points are kept), then prints the fits of eqs. (6.2), (6.3) and (2.57) over the
full window 180-300 and the reduced study's 120-200, each with and without phi_tilde = 0.8
(the full plan's value the reduced one lacks), and the table of the full window's fits under
each choice the seed leaves open (:func:`grainflow.analysis.jet.rheology.fit_choices_2d`: the
weights, layer (a) or (b) alone, the cells that flow mostly by shear, I_dev for I_s).
``--target-spacing 0.5`` runs the same on a smoother target (wall particles half a diameter
apart; the thesis gives no lattice), to tell what the target sets; use another OUT_DIR.

Usage (3 replicas: 15 runs, about 9-12 minutes on 2 cores)::

    python scripts/jet_rheo2d_full_settings.py OUT_DIR [--replicas 3] [--target-spacing 0.5]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from grainflow import interrupt
from grainflow.analysis.jet.rheology import fit_divergence_2d, fit_friction_2d
from grainflow.studies.jet_study import (FULL, _fit_choices_lines, _layers_2d, sweep_specs,
                                        with_target_spacing)
from grainflow.studies.points import run_sweeps


def _fits(layers: dict, label: str) -> None:
    flat = [lay for pair in layers.values() for lay in pair]
    print(f"== {label}")
    for number, names in (("I", ("phi_s", "a_s", "alpha_s")),
                          ("I_T", ("phi_T", "a_T", "alpha_T"))):
        f = fit_divergence_2d(flat, number)
        print("  " + ", ".join(f"{n} = {getattr(f, a):.4g} ± {getattr(f, a + '_err'):.2g}"
                               for n, a in zip(names, ("phi_c", "a", "alpha"))))
    m = fit_friction_2d(flat, "mu_of_I")
    print("  " + ", ".join(f"{a} = {getattr(m, a):.4g} ± {getattr(m, a + '_err'):.2g}"
                           for a in ("mu_s", "mu_max", "I0")))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--replicas", type=int, default=3)
    parser.add_argument("--target-spacing", type=float, default=None,
                        help="spacing of the target's wall particles in d (default: the "
                        "scenario's, 1: touching)")
    args = parser.parse_args(argv)
    plan = dataclasses.replace(FULL, replicas=args.replicas, rheology_replicas=args.replicas)
    spec = with_target_spacing(sweep_specs(plan)["rheo2d"], args.target_spacing)
    points = run_sweeps({"rheo2d": spec}, args.out, progress="plain")["rheo2d"]
    print(f"{len(points.rundirs)} runs, {points.cpu:.0f} CPU-s")
    for window in (FULL.rheo2d_window, (120.0, 200.0)):
        layers = _layers_2d(points, window)
        _fits(layers, f"window {window}, phi_tilde {sorted(layers)}")
        _fits({k: v for k, v in layers.items() if k != 0.8}, f"window {window}, without 0.8")
        if window == FULL.rheo2d_window:
            print("\n".join(_fit_choices_lines([lay for pair in layers.values() for lay in pair])))


if __name__ == "__main__":
    interrupt.run(main)
