"""Where the 3D slope a of mu* = a I misses: the layer's shear viscosity against kinetic
theory (docs/jets.md, "3D mu* = a I").

With the thesis's I = D_rz sqrt(m / (P d)) (the form its eq. 5.13 follows from) and
sigma_rz = -eta D_rz (eq. 5.12), mu* / I = eta / sqrt(P m / d), so a flow whose viscosity is
Garzo-Dufty's (eqs. 5.5-5.11) and whose pressure follows eq. 5.2 has the slope

    a_KT(phi) = 5 eta*(phi) / (16 sqrt(6 phi (1 + 2 phi (1 + e) chi)))

(:func:`grainflow.analysis.kinetic_theory.friction_slope`): 0.35 at its lowest (phi ~ 0.2,
e = 0.75), above 0.8 past phi = 0.5. The thesis's
a = 0.223 / 0.240 thus says its layer's viscosity is below kinetic theory's (its Fig. 5.10:
"less than 80 %"), while its Fig. 5.9 finds eta close to the theory.

Runs (or reuses) the reduced study's ``rheo3d`` sweep in OUT_DIR (12 runs, about 770 CPU-s,
7 minutes on 2 cores), then prints per ring of every (phi_tilde, mu_p): phi, T_g, P, D_rz,
sigma_rz, the measured eta = -sigma_rz / D_rz, eta_kin of eq. 5.5 (e = 0.75 frictionless,
the renormalised 0.616 frictional, eq. 2.55), their ratio, mu*/I and a_KT; the kinetic and
contact parts of sigma_rz at phi_tilde = 0.9; and a fitted with and without the grains'
contacts with the target's particles in the stress (eq. 5.1 sums over "the particles
located at r"; the target's lie below the layer), and with every contact force replaced by
its normal part (what the tangential forces carry).

``--target-spacing 0.5`` runs the same on a smoother target (wall particles half a diameter
apart; the thesis gives no lattice); use another OUT_DIR.

Usage::

    python scripts/jet_rheo3d_viscosity.py OUT_DIR [--target-spacing 0.5]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from grainflow import interrupt
from grainflow.analysis import kinetic_theory as kt
from grainflow.analysis.jet.rheology import (fit_friction_3d, layer_fields_3d, pool,
                                              viscosity_check)
from grainflow.frame import Frame
from grainflow.scenarios.jet import TARGET_TYPE
from grainflow.studies.jet_study import REDUCED, _run_frames, sweep_specs, with_target_spacing
from grainflow.studies.points import run_sweeps


def without_target_contacts(frame: Frame) -> Frame:
    """The frame with every contact that involves a target particle left out."""
    c = frame.contacts
    target = np.asarray(frame.id)[np.asarray(frame.type) == TARGET_TYPE]
    keep = ~(np.isin(c.i, target) | np.isin(c.j, target))
    return dataclasses.replace(frame, contacts=c.select(keep))


def normal_parts_only(frame: Frame) -> Frame:
    """The frame with every contact force replaced by its part along the branch vector (the
    tangential forces left out of the stress)."""
    c = frame.contacts
    branch = np.asarray(c.branch, dtype=float)
    length = np.linalg.norm(branch, axis=1)
    unit = branch / np.where(length > 0, length, 1.0)[:, None]
    normal = np.sum(np.asarray(c.force, dtype=float) * unit, axis=1)[:, None] * unit
    return dataclasses.replace(frame, contacts=dataclasses.replace(c, force=normal))


def print_rings(key: tuple[float, float], layer) -> None:
    e = 0.75 if key[1] == 0.0 else float(kt.effective_restitution(0.75, key[1]))
    c = viscosity_check(layer, e)
    v = layer.values
    print(f"phi_tilde {key[0]}, mu_p {key[1]} (e = {e:.3f})")
    print("  r/R    phi    T_g      P     D_rz  sigma_rz     eta  eta_kin  ratio  mu*/I  a_KT")
    for k, r in enumerate(c.r):
        print(f"  {r:.2f}  {c.phi[k]:.3f}  {v['T_g'][k]:.4f}  {v['P'][k]:.4f}  {c.D[k]:+.4f}"
              f"  {v['sigma'][k, 0, 2]:+.5f}  {c.eta[k]:6.3f}  {c.eta_kin[k]:6.3f}"
              f"  {c.ratio[k]:5.2f}  {c.slope[k]:5.2f}  {c.slope_kin[k]:4.2f}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--target-spacing", type=float, default=None,
                        help="spacing of the target's wall particles in d (default: the "
                        "scenario's, 1: touching)")
    args = parser.parse_args(argv)
    spec = with_target_spacing(sweep_specs(REDUCED)["rheo3d"], args.target_spacing)
    points = run_sweeps({"rheo3d": spec}, args.out, progress="plain")["rheo3d"]
    print(f"{len(points.rundirs)} runs, {points.cpu:.0f} CPU-s")
    groups: dict[str, dict[tuple[float, float], list]] = {"with": {}, "without": {},
                                                         "normal parts only, with": {}}
    for p, rundir in zip(points.params, points.rundirs):
        frames, config = _run_frames(rundir)
        radius = 0.5 * config["jet"]["target_diameter"]
        key = (float(p["jet.phi_tilde"]), float(p["jet.mu_p"]))
        for name, fr in (("with", frames),
                         ("without", [without_target_contacts(f) for f in frames]),
                         ("normal parts only, with", [normal_parts_only(f) for f in frames])):
            groups[name].setdefault(key, []).append(
                layer_fields_3d(fr, radius, window=REDUCED.rheo3d_window, blocks=4))
    layers = {name: {k: pool(v) for k, v in sorted(g.items())} for name, g in groups.items()}
    for key, layer in layers["with"].items():
        print_rings(key, layer)
        if key[0] == 0.9:
            main_fields = layer.sources[0]
            kinetic = main_fields.kinetic_stress.reshape(-1, 3, 3)[:, 0, 2]
            contact = main_fields.contact_stress().reshape(-1, 3, 3)[:, 0, 2]
            print("  sigma_rz kinetic part", np.round(kinetic, 4), "contact part",
                  np.round(contact, 4))
    for name, by_key in layers.items():
        for mu_p in sorted({k[1] for k in by_key}):
            sel = [lay for k, lay in by_key.items() if k[1] == mu_p]
            fit = fit_friction_3d(sel)
            print(f"a, mu_p = {mu_p}, {name} the grain-target contacts in the stress: "
                  f"{fit.a:.3f} ± {fit.a_err:.3f}")


if __name__ == "__main__":
    interrupt.run(main)
