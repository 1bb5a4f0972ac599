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

``--smooth-restitution E`` runs frictionless grains only, at normal restitution E (the
thesis's kinetic theory stands for its frictional grains by smooth ones at e_bar = 0.616, eq.
2.55): whether e_bar alone gives the frictional layer's a; use another OUT_DIR.

``--fabric`` prints instead what friction changes in the layer's contacts: per ring of every
(phi_tilde, mu_p), pooled over the replicas (:mod:`grainflow.analysis.jet.fabric`), the
layer's phi, mu* and I, the coordination number Z, the fabric's F_rz and F_zz of the
contact normals, mu*_n = -3 F_f,rz / tr F_f of the normal-force-weighted fabric (the
-sigma_rz / P the contacts' normal forces carry), the mean normal force and the fraction of
contacts sliding at the Coulomb cap.

Usage::

    python scripts/jet_rheo3d_viscosity.py OUT_DIR [--target-spacing 0.5]
        [--smooth-restitution 0.616] [--fabric]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from grainflow import interrupt
from grainflow.analysis import kinetic_theory as kt
from grainflow.analysis.jet.fabric import pool_fabrics, ring_fabric_3d
from grainflow.analysis.jet.rheology import (fit_friction_3d, layer_fields_3d, pool,
                                              viscosity_check)
from grainflow.frame import Frame
from grainflow.scenarios.jet import TARGET_TYPE, JetSection
from grainflow.studies.jet_study import REDUCED, _run_frames, sweep_specs, with_target_spacing
from grainflow.studies.points import run_sweeps
from grainflow.sweep import parse_sweep


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


def smooth_at(spec, restitution: float | None):
    """``spec`` with frictionless grains only, at normal restitution ``restitution``
    (``spec`` itself for None)."""
    if restitution is None:
        return spec
    raw = spec.model_dump()
    raw["base"]["jet"]["restitution"] = restitution
    raw["overrides"]["jet.mu_p"] = [0.0]
    return parse_sweep(raw)


def print_rings(key: tuple[float, float], layer, restitution: float) -> None:
    e = restitution if key[1] == 0.0 else float(kt.effective_restitution(restitution, key[1]))
    c = viscosity_check(layer, e)
    v = layer.values
    print(f"phi_tilde {key[0]}, mu_p {key[1]} (e = {e:.3f})")
    print("  r/R    phi    T_g      P     D_rz  sigma_rz     eta  eta_kin  ratio  mu*/I  a_KT")
    for k, r in enumerate(c.r):
        print(f"  {r:.2f}  {c.phi[k]:.3f}  {v['T_g'][k]:.4f}  {v['P'][k]:.4f}  {c.D[k]:+.4f}"
              f"  {v['sigma'][k, 0, 2]:+.5f}  {c.eta[k]:6.3f}  {c.eta_kin[k]:6.3f}"
              f"  {c.ratio[k]:5.2f}  {c.slope[k]:5.2f}  {c.slope_kin[k]:4.2f}")


def print_fabric(points) -> None:
    """The contacts in the layer, ring by ring, per (phi_tilde, mu_p) (``--fabric``)."""
    fabrics: dict[tuple[float, float], list] = {}
    layers: dict[tuple[float, float], list] = {}
    window = REDUCED.rheo3d_window
    for p, rundir in zip(points.params, points.rundirs):
        frames, config = _run_frames(rundir)
        radius = 0.5 * config["jet"]["target_diameter"]
        key = (float(p["jet.phi_tilde"]), float(p["jet.mu_p"]))
        fabrics.setdefault(key, []).append(ring_fabric_3d(frames, radius, key[1], window=window))
        layers.setdefault(key, []).append(layer_fields_3d(frames, radius, window=window))
    print(f"window t = {window[0]:g}-{window[1]:g}")
    for key in sorted(fabrics):
        fab = pool_fabrics(fabrics[key])
        lay = pool(layers[key]).values
        print(f"phi_tilde {key[0]}, mu_p {key[1]}")
        print("  r/R    phi    mu*      I      Z   F_rz   F_zz   mu*_n   <f_n>  sliding")
        for k, r in enumerate(fab.r):
            print(f"  {r:.2f}  {lay['phi'][k]:.3f}  {lay['mu'][k]:+.3f}  {lay['I'][k]:.4f}"
                  f"  {fab.coordination[k]:4.2f}  {fab.fabric[k, 0, 2]:+.3f}"
                  f"  {fab.fabric[k, 2, 2]:.3f}  {fab.normal_force_mu[k]:+6.3f}"
                  f"  {fab.normal_force[k]:7.4f}  {fab.sliding[k]:7.3f}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--target-spacing", type=float, default=None,
                        help="spacing of the target's wall particles in d (default: the "
                        "scenario's, 1: touching)")
    parser.add_argument("--smooth-restitution", type=float, default=None,
                        help="frictionless grains only, at this normal restitution")
    parser.add_argument("--fabric", action="store_true",
                        help="print the contacts in the layer instead (module docstring)")
    args = parser.parse_args(argv)
    spec = smooth_at(with_target_spacing(sweep_specs(REDUCED)["rheo3d"], args.target_spacing),
                     args.smooth_restitution)
    restitution = spec.base["jet"].get("restitution",
                                       JetSection.model_fields["restitution"].default)
    points = run_sweeps({"rheo3d": spec}, args.out, progress="plain")["rheo3d"]
    print(f"{len(points.rundirs)} runs, {points.cpu:.0f} CPU-s")
    if args.fabric:
        print_fabric(points)
        return
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
        print_rings(key, layer, restitution)
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
