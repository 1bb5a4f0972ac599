"""Why grain friction raises the 3D slope a of mu* = a I: the contacts next to the target
with and without friction (docs/jets.md, "3D mu* = a I").

Runs (or reuses) the reduced study's ``rheo3d`` sweep in OUT_DIR (12 runs, about 770 CPU-s,
7 minutes on 2 cores; the same sweep as ``scripts/jet_rheo3d_viscosity.py``), then prints
per ring of every (phi_tilde, mu_p), pooled over the replicas, over the study's window
(:func:`grainflow.analysis.jet.fabric.ring_fabric_3d`): the coordination number Z, the
fabric's F_rz and F_zz of the contact normals, mu*_n = -3 F_f,rz / tr F_f of the
normal-force-weighted fabric (the -sigma_rz / P the contacts' normal forces carry), the mean
normal force, and the
fraction of contacts sliding at the Coulomb cap; beside them the layer's phi, mu* and I.

Usage::

    python scripts/jet_rheo3d_fabric.py OUT_DIR [--target-spacing 0.5]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from grainflow import interrupt
from grainflow.analysis.jet.fabric import pool_fabrics, ring_fabric_3d
from grainflow.analysis.jet.rheology import layer_fields_3d, pool
from grainflow.studies.jet_study import REDUCED, _run_frames, sweep_specs, with_target_spacing
from grainflow.studies.points import run_sweeps


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--target-spacing", type=float, default=None,
                        help="spacing of the target's wall particles in d (default: the "
                        "scenario's, 1: touching)")
    args = parser.parse_args(argv)
    spec = with_target_spacing(sweep_specs(REDUCED)["rheo3d"], args.target_spacing)
    points = run_sweeps({"rheo3d": spec}, args.out, progress="plain")["rheo3d"]
    print(f"{len(points.rundirs)} runs, {points.cpu:.0f} CPU-s; window t = "
          f"{REDUCED.rheo3d_window[0]:g}-{REDUCED.rheo3d_window[1]:g}")
    fabrics: dict[tuple[float, float], list] = {}
    layers: dict[tuple[float, float], list] = {}
    for p, rundir in zip(points.params, points.rundirs):
        frames, config = _run_frames(rundir)
        radius = 0.5 * config["jet"]["target_diameter"]
        key = (float(p["jet.phi_tilde"]), float(p["jet.mu_p"]))
        fabrics.setdefault(key, []).append(
            ring_fabric_3d(frames, radius, key[1], window=REDUCED.rheo3d_window))
        layers.setdefault(key, []).append(
            layer_fields_3d(frames, radius, window=REDUCED.rheo3d_window))
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


if __name__ == "__main__":
    interrupt.run(main)
