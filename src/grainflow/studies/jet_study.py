"""Reproduction of seed 002's jet study (Sano's thesis, Chapters 4-6) through the sweep engine.

Four sweeps, each a grid of ``[jet]`` fields times replicate seeds (the seed averages over
ten initial configurations; replicas differ in which lattice sites thinning removes):

- ``scatter``: 3D, D_jet = 4.5 d, phi_tilde = 0.9, mu_p = 0.2, X = D_tar/D_jet swept, at
  several e; the scattering angle psi0 of each run (:func:`scattering_summary`), fitted with
  the interpolation function of Fig. 4.2 (C0, C1, C2).
- ``anisotropy``: 3D, rectangular cross-section of area 16 d^2 at aspect ratios l for the
  eccentricities eps = (l^2 - 1)/(l^2 + 1); v2 of the azimuthal flux (Fig. 4.3).
- ``rheo3d``: 3D, D_jet = 10 d, D_tar = 22 d, phi_tilde swept, frictional (mu_p = 0.2) and
  frictionless; coarse-grained fields in the layer 0 < z < 5 d, pooled over replicas
  (Chapter 5): |sigma_rz/sigma_zz|, P/(n T) against Garzo-Dufty, mu* = a I, flatness.
- ``rheo2d``: 2D bidisperse frictionless, R_jet = 15 d, R_tar = 2.2 R_jet, phi_tilde swept;
  layers (a) 0 < x <= 5 d and (b) 5 < x <= 10 d (Chapter 6): the jamming-type fits
  phi = phi_s - a_s I_s^(2/alpha_s) and the mu(I) law.

:func:`reproduce` runs what is not yet done (finished points are never recomputed), analyses
the saved frames and writes ``report.md`` with figures and the table of seed numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from grainflow.studies.points import SweepPoints, run_sweeps

if TYPE_CHECKING:
    from grainflow.analysis.jet import Psi0Fit

#: Seed values (thesis Chapters 4-6; PARAMETERS.md "Seed 002"), with their quoted
#: uncertainty where the thesis gives one (else None: the issue's 10 % applies).
SEED: dict[str, tuple[float, float | None]] = {
    "C0": (1.68, None), "C1": (0.563, None), "C2": (0.554, None),
    "v2(eps=0.615), experiment": (0.16, None),
    "a (frictional)": (0.240, None), "a (frictionless)": (0.223, None),
    "|s_rz/s_zz| (frictional)": (1.7e-2, None), "|s_rz/s_zz| (frictionless)": (3.0e-2, None),
    "flatness z (frictional)": (2.70, None), "flatness r (frictional)": (2.98, None),
    "flatness theta (frictional)": (3.71, None),
    "flatness z (frictionless)": (2.87, None), "flatness r (frictionless)": (2.86, None),
    "flatness theta (frictionless)": (3.41, None),
    "phi_s": (0.834, 0.001), "a_s": (3.94, 0.5), "alpha_s": (1.36, 0.05),
    "phi_T": (0.858, 0.006), "a_T": (0.980, 0.1), "alpha_T": (1.15, 0.1),
    "mu_s": (0.0153, 0.009), "mu_max": (0.521, 0.06), "I0": (0.0820, 0.02),
}


@dataclass(frozen=True)
class JetPlan:
    """Sizes of the study; ``reductions`` lists how it departs from the seed."""

    scatter_X: tuple[float, ...]
    scatter_e: tuple[float, ...]
    scatter_n: int
    scatter_duration: float
    aspect_ratios: tuple[float, ...]
    aniso_n: int
    aniso_duration: float
    rheo3d_phi: tuple[float, ...]
    rheo3d_n: int
    rheo3d_window: tuple[float, float]
    rheo2d_phi: tuple[float, ...]
    rheo2d_n: int
    rheo2d_window: tuple[float, float]
    replicas: int
    rheology_replicas: int = 0  # 0: as ``replicas``
    reductions: tuple[str, ...] = field(default=())


FULL = JetPlan(scatter_X=(0.4, 0.6, 0.8, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0),
               scatter_e=(0.75, 0.90, 0.99), scatter_n=2000, scatter_duration=80.0,
               aspect_ratios=(1.0, 1.5, 2.05, 3.0, 4.0),
               aniso_n=4000, aniso_duration=120.0,
               rheo3d_phi=(0.3, 0.4, 0.45, 0.5, 0.8, 0.9), rheo3d_n=20_000,
               rheo3d_window=(50.0, 100.0), rheo2d_phi=(0.3, 0.5, 0.7, 0.8, 0.9),
               rheo2d_n=8000, rheo2d_window=(180.0, 300.0), replicas=10)
REDUCED = JetPlan(scatter_X=(0.4, 0.5, 0.6, 0.8, 1.2, 1.6, 2.0, 2.5, 3.5, 5.0), scatter_e=(0.75,),
                  scatter_n=1200, scatter_duration=50.0,
                  aspect_ratios=(1.0, 1.5, 2.05, 4.0), aniso_n=3000, aniso_duration=100.0,
                  rheo3d_phi=(0.3, 0.5, 0.9),
                  rheo3d_n=10_000, rheo3d_window=(40.0, 80.0), rheo2d_phi=(0.3, 0.5, 0.7, 0.9),
                  rheo2d_n=8000, rheo2d_window=(120.0, 200.0), replicas=3,
                  rheology_replicas=2,
                  reductions=("3 replicas per point (seed: 10); 2 for the rheology sweeps",
                              "psi0(X) at e = 0.75 only, 10 targets (X = 0.4-5), steady window "
                              "t = 20-50",
                              "v2 at 4 aspect ratios (eps = 0, 0.38, 0.615, 0.88), 3,000 grains, "
                              "window t = 50-100",
                              "3D rheology: phi_tilde = 0.3, 0.5, 0.9; 10,000 grains, window "
                              "t = 40-80 (seed: six values, 20,000 grains, 50-100)",
                              "2D rheology: phi_tilde = 0.3, 0.5, 0.7, 0.9; window t = 120-200 "
                              "(seed: 180-300)"))


def _base(dim: int, duration: float, jet: dict[str, Any], frames_every: int) -> dict[str, Any]:
    return {"scenario": f"jet{dim}d", "dim": dim,
            "run": {"duration": duration, "seed": 0},
            "output": {"thermo_every": 5000, "frames_every": frames_every,
                       "checkpoint_every": 0, "contacts": True, "snapshot": True},
            "jet": jet}


def _steps_per_unit_time(contact_time: float = 0.10) -> int:
    return int(round(1.0 / (0.02 * contact_time)))


def sweep_specs(plan: JetPlan) -> dict[str, Any]:
    """The study's sweeps (name -> validated :class:`~grainflow.sweep.SweepSpec`)."""
    from grainflow.sweep import parse_sweep

    per_unit = _steps_per_unit_time()
    scatter_jet = {"jet_diameter": 4.5, "target_diameter": 9.0, "phi_tilde": 0.9, "mu_p": 0.2,
                   "n": plan.scatter_n, "restitution": 0.75}
    # v2: a sheet-forming target (X = 2.5 on the equal-area circle's diameter)
    aniso_jet = {**scatter_jet, "cross_section": "rectangle", "cross_section_area": 16.0,
                 "aspect_ratio": 1.0, "n": plan.aniso_n,
                 "target_diameter": round(2.5 * math.sqrt(4 * 16.0 / math.pi), 2)}
    rheo3d_jet = {"jet_diameter": 10.0, "target_diameter": 22.0, "n": plan.rheo3d_n,
                  "phi_tilde": 0.9, "mu_p": 0.2}
    rheo2d_jet = {"jet_diameter": 30.0, "target_diameter": 66.0, "n": plan.rheo2d_n,
                  "sizes": "bidisperse", "mu_p": 0.0, "phi_tilde": 0.9}
    scatter = {"jet.target_diameter": [round(4.5 * X, 4) for X in plan.scatter_X],
               "jet.restitution": list(plan.scatter_e)}
    raw = {
        "scatter": {"base": _base(3, plan.scatter_duration, scatter_jet, per_unit),
                    "overrides": scatter,
                    "analyses": ["grainflow.studies.jet_study:scattering_summary"]},
        "anisotropy": {"base": _base(3, plan.aniso_duration, aniso_jet, per_unit),
                       "overrides": {"jet.aspect_ratio": list(plan.aspect_ratios)},
                       "analyses": ["grainflow.studies.jet_study:anisotropy_summary"]},
        "rheo3d": {"base": _base(3, plan.rheo3d_window[1], rheo3d_jet, per_unit // 2),
                   "overrides": {"jet.phi_tilde": list(plan.rheo3d_phi),
                                 "jet.mu_p": [0.0, 0.2]}},
        "rheo2d": {"base": _base(2, plan.rheo2d_window[1], rheo2d_jet, per_unit),
                   "overrides": {"jet.phi_tilde": list(plan.rheo2d_phi)}},
    }
    rheology = plan.rheology_replicas or plan.replicas
    return {name: parse_sweep({"name": name, "mode": "grid", **spec, "replicates":
                               rheology if name.startswith("rheo") else plan.replicas})
            for name, spec in raw.items()}


def with_target_spacing(spec: Any, spacing: float | None) -> Any:
    """``spec`` (a sweep of this study) with its base jet's target wall particles ``spacing``
    diameters apart (the thesis gives no lattice; docs/jets.md measures a smoother target);
    ``spec`` itself when ``spacing`` is None."""
    from grainflow.sweep import parse_sweep

    if spacing is None:
        return spec
    raw = spec.model_dump()
    raw["base"]["jet"]["target_spacing"] = spacing
    return parse_sweep(raw)


# ------------------------------------------------------------------- per-run analyses
#: Fraction of a scattering run after which the outgoing flow is steady: the per-run
#: analyses read only the run directory, so the window is t = 0.4-1 of the run's duration
#: (reduced plan 20-50, full plan 32-80).
STEADY_FROM = 0.4
#: The same for the anisotropy runs, measured farther out (shell ~11 d): the sheet moves at
#: about u0/2, and before t ~ 50 its far part is still filling with the fastest (y-going)
#: grains, which biases v2 negative (docs/jets.md, "v2").
STEADY_FROM_ANISOTROPY = 0.5


def _run_frames(rundir: Path) -> tuple[list[Any], dict[str, Any]]:
    import tomllib

    from grainflow.io.h5md import read_frames

    config = tomllib.loads((rundir / "config.toml").read_text())
    return list(read_frames(rundir / "frames.h5")), config


def _steady(config: dict[str, Any], start: float = STEADY_FROM) -> tuple[float, float]:
    duration = float(config["run"]["duration"])
    return start * duration, duration


def scattering_summary(rundir: str | Path) -> dict[str, float]:
    """Sweep analysis: psi0 of one 3D run over its steady window, with X = D_tar/D_jet, by
    the two definitions: ``psi0`` from the force on the target by Clanet's momentum balance
    1 - cos psi0 = F_wall/J_in, eq. 4.3, the one the thesis derives
    (:func:`grainflow.analysis.jet.force_balance_angle`), and ``psi0_velocity``, the
    direction of the outgoing momentum flux (:func:`~grainflow.analysis.jet.scattering_angle`;
    smaller in the forward cone, where inelastic grains lose flux, docs/jets.md)."""
    from grainflow.analysis.jet import force_balance_angle, scattering_angle

    frames, config = _run_frames(Path(rundir))
    jet = config["jet"]
    window = _steady(config)
    velocity = scattering_angle(frames, target_radius=0.5 * jet["target_diameter"],
                                jet_radius=0.5 * jet["jet_diameter"], window=window)
    force = force_balance_angle(frames, window=window)
    return {"psi0": float(force.psi0), "psi0_err": float(force.psi0_err),
            "psi0_velocity": float(velocity.psi0),
            "psi0_velocity_err": float(velocity.psi0_err),
            "X": jet["target_diameter"] / jet["jet_diameter"],
            "scattered": float(velocity.n_grains)}


def anisotropy_summary(rundir: str | Path) -> dict[str, float]:
    """Sweep analysis: v2 of the azimuthal flux of one rectangular-jet run, with its
    eccentricity eps = (l^2 - 1)/(l^2 + 1) (Sec. 4.2). The azimuth is that of each grain's
    velocity: its position's azimuth keeps a memory of the jet's shape (grains leave roughly
    in the direction of the place they hit), which biases v2 towards the long side."""
    from grainflow.analysis.jet import anisotropy_v2, eccentricity

    frames, config = _run_frames(Path(rundir))
    jet = config["jet"]
    half_long = 0.5 * math.sqrt(jet["cross_section_area"] * jet["aspect_ratio"])
    result = anisotropy_v2(frames, target_radius=0.5 * jet["target_diameter"],
                           jet_radius=half_long, window=_steady(config, STEADY_FROM_ANISOTROPY),
                           azimuth="velocity")
    return {"v2": float(result.v), "v2_err": float(result.v_err),
            "eps": float(eccentricity(jet["aspect_ratio"]))}


# ----------------------------------------------------------------------------- collection
#: psi0 error (rad) given to an X measured by a single replica, whose standard error is NaN.
SINGLE_REPLICA_PSI0_ERR = 0.02


def fit_psi0_means(X: np.ndarray, psi0: np.ndarray, psi0_err: np.ndarray) -> "Psi0Fit | None":
    """Fig. 4.2's interpolation (:func:`~grainflow.analysis.jet.fit_psi0`) through replica
    means of psi0 (:func:`_mean_by`), an X of one replica weighted with
    SINGLE_REPLICA_PSI0_ERR; None with fewer than four X."""
    from grainflow.analysis.jet import fit_psi0

    if len(X) < 4:
        return None
    return fit_psi0(X, psi0, np.where(np.isfinite(psi0_err), psi0_err, SINGLE_REPLICA_PSI0_ERR))


def _mean_by(keys: list[float], values: list[float]
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Replica mean and its standard error (replica spread / sqrt(n); a single replica's
    error is NaN) per distinct key."""
    groups: dict[float, list[float]] = {}
    for k, v in zip(keys, values):
        groups.setdefault(round(k, 6), []).append(v)
    ks = np.array(sorted(groups))
    mean = np.array([np.mean(groups[k]) for k in ks])
    err = np.array([np.std(groups[k], ddof=1) / math.sqrt(len(groups[k]))
                    if len(groups[k]) > 1 else np.nan for k in ks])
    return ks, mean, err


def _rheology_3d(points: SweepPoints, window: tuple[float, float]
                 ) -> tuple[dict[tuple[float, float], Any], dict[float, dict[str, tuple]],
                            dict[tuple[float, float], Any]]:
    """The 3D rheology sweep, each run's frames read once: pooled layer fields per
    (phi_tilde, mu_p), per mu_p the flatness per component at phi_tilde = 0.9
    (Table 5.1) as (replica mean, standard error), and the pooled contact fabric per
    (phi_tilde, mu_p) (:mod:`grainflow.analysis.jet.fabric`)."""
    from grainflow.analysis.jet.fabric import pool_fabrics, ring_fabric_3d
    from grainflow.analysis.jet.rheology import layer_fields_3d, layer_flatness, pool

    groups: dict[tuple[float, float], list[Any]] = {}
    fabrics: dict[tuple[float, float], list[Any]] = {}
    flat: dict[float, dict[str, list[float]]] = {}
    for p, rundir in zip(points.params, points.rundirs):
        frames, config = _run_frames(rundir)
        radius = 0.5 * config["jet"]["target_diameter"]
        key = (float(p["jet.phi_tilde"]), float(p["jet.mu_p"]))
        groups.setdefault(key, []).append(layer_fields_3d(frames, radius, window=window,
                                                          blocks=4))
        fabrics.setdefault(key, []).append(ring_fabric_3d(frames, radius, key[1],
                                                          window=window))
        if key[0] == 0.9:
            for name, v in layer_flatness(frames, radius, dim=3, window=window).items():
                flat.setdefault(key[1], {}).setdefault(name, []).append(v)
    flatness = {mu: {name: (float(np.mean(v)), float(np.std(v, ddof=1) / math.sqrt(len(v)))
                            if len(v) > 1 else float("nan")) for name, v in values.items()}
                for mu, values in flat.items()}
    return ({key: pool(layers) for key, layers in sorted(groups.items())}, flatness,
            {key: pool_fabrics(runs) for key, runs in sorted(fabrics.items())})


def _viscosity_lines(label: str, restitution: float, layers: dict[float, Any]) -> list[str]:
    """The 3D layer's shear viscosity against kinetic theory, ring by ring (Fig. 5.9;
    :func:`~grainflow.analysis.jet.rheology.viscosity_check`), as a report table."""
    from grainflow.analysis.jet.rheology import viscosity_check

    lines = ["", f"3D ({label}) shear viscosity eta = -sigma_rz / D_rz against kinetic theory "
             f"(eq. 5.5 at e = {restitution:.3f}; the seed's Fig. 5.9 finds the ratio near 1 for "
             "r/R_tar > 0.2), and mu*/I against a_KT, the slope of a flow with the kinetic "
             "theory's viscosity and pressure (docs/jets.md):", "",
             "| φ̃0 | r/R_tar | phi | D_rz | eta / eta_kin | mu*/I | a_KT |",
             "|---|---|---|---|---|---|---|"]
    for phi_tilde, layer in sorted(layers.items()):
        c = viscosity_check(layer, restitution)
        lines += [f"| {phi_tilde:g} | {r:.1f} | {phi:.3f} | {D:+.4f} | {ratio:.2f} | {slope:.2f} "
                  f"| {kin:.2f} |"
                  for r, phi, D, ratio, slope, kin in zip(c.r, c.phi, c.D, c.ratio, c.slope,
                                                          c.slope_kin)]
    return lines


def _fabric_lines(label: str, fabrics: dict[float, Any], layers: dict[float, Any]
                  ) -> list[str]:
    """The contacts in the 3D layer ring by ring (:mod:`grainflow.analysis.jet.fabric`):
    coordination, the normals' F_rz, the normal forces' mu*_n against the layer's mu*, and
    the sliding fraction, as a report table."""
    lines = ["", f"3D ({label}) grain-grain contacts in the layer: coordination Z, the rz "
             "component of the contact normals' fabric <n n>, the normal forces' share of "
             "the friction coefficient mu*_n = -3 F_f,rz / tr F_f (F_f: the fabric weighted "
             "by f_n |b|) beside the layer's mu*, and the fraction of contacts at the Coulomb "
             "cap (docs/jets.md):", "",
             "| φ̃0 | r/R_tar | Z | F_rz | mu*_n | mu* | sliding |", "|---|---|---|---|---|---|---|"]
    for phi_tilde, fab in sorted(fabrics.items()):
        mu = layers[phi_tilde].values["mu"]
        lines += [f"| {phi_tilde:g} | {r:.1f} | {z:.2f} | {frz:+.3f} | {mn:+.3f} | {m:+.3f} | "
                  + ("-" if np.isnan(sl) else f"{sl:.3f}") + " |"
                  for r, z, frz, mn, m, sl in zip(fab.r, fab.coordination, fab.fabric[:, 0, 2],
                                                  fab.normal_force_mu, mu, fab.sliding)]
    return lines


def _layers_2d(points: SweepPoints, window: tuple[float, float]) -> dict[float, tuple[Any, Any]]:
    """Pooled layers (a) and (b) per phi_tilde of the 2D rheology sweep."""
    from grainflow.analysis.jet.rheology import layer_fields_2d, pool

    groups: dict[float, list[tuple[Any, ...]]] = {}
    for p, rundir in zip(points.params, points.rundirs):
        frames, config = _run_frames(rundir)
        groups.setdefault(float(p["jet.phi_tilde"]), []).append(layer_fields_2d(
            frames, 0.5 * config["jet"]["target_diameter"], window=window, blocks=4))
    return {phi: tuple(pool(list(layer)) for layer in zip(*reps))
            for phi, reps in sorted(groups.items())}


def _fit_choices_3d_lines(layers: list[Any], label: str) -> list[str]:
    """Report lines: the 3D slope a of mu* = a I under each choice the seed leaves open
    (:func:`grainflow.analysis.jet.rheology.fit_choices_3d`), with the median shear fraction
    |D_rz| / D_dev of the rings."""
    from grainflow.analysis.jet.rheology import fit_choices_3d

    fractions = np.concatenate([np.asarray(lay.values["shear_fraction"]) for lay in layers])
    median = float(np.nanmedian(fractions)) if np.isfinite(fractions).any() else float("nan")
    lines = ["", f"3D ({label}) a of mu* = a I under the choices the seed leaves open (seed: "
             f"{SEED[f'a ({label})'][0]:g}); the rings' median shear fraction |D_rz| / D_dev "
             f"is {median:.2f} (next to the target the flow is mostly a compression along z "
             "and an extension in r):", "", "| rings, weights, strain rate | rings | a | ± |",
             "|---|---|---|---|"]
    for name, cells, fit in fit_choices_3d(layers):
        lines.append(f"| {name} | {cells} | " + (" - | - |" if fit is None else
                                                 f"{fit.a:.3g} | {fit.a_err:.2g} |"))
    return lines + [""]


def _fit_choices_lines(layers: list[Any]) -> list[str]:
    """Report lines: the 2D fits under each choice the seed leaves open
    (:func:`grainflow.analysis.jet.rheology.fit_choices_2d`)."""
    from grainflow.analysis.jet.rheology import fit_choices_2d

    def cell(fit: Any, attr: str) -> str:
        return "-" if fit is None else f"{getattr(fit, attr):.3g}"

    lines = ["", "2D fits under the choices the seed leaves open (the table below uses the "
             "first row; the seed: phi_s 0.834, alpha_s 1.36, phi_T 0.858, a_T 0.980, "
             "alpha_T 1.15, mu_max 0.521, I0 0.082). The shear fraction is |D_xy| / "
             "sqrt(D_xy^2 + D_ext^2): on the stagnation line the flow is an extension and "
             "D_xy ~ 0; I_dev uses the whole deviatoric rate:", "",
             "| cells, weights, strain rate | cells | phi_s | a_s | alpha_s | phi_T | a_T | "
             "alpha_T | mu_s | mu_max | I0 |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in fit_choices_2d(layers):
        lines.append(f"| {row.label} | {row.cells} | " + " | ".join(
            [cell(row.I_s, a) for a in ("phi_c", "a", "alpha")]
            + [cell(row.I_T, a) for a in ("phi_c", "a", "alpha")]
            + [cell(row.friction, a) for a in ("mu_s", "mu_max", "I0")]) + " |")
    return lines


def _dead_zone_line(label: str, points: SweepPoints, match: dict[str, float],
                    window: tuple[float, float]) -> str:
    """One report line: the dead zone of the first replica matching ``match``."""
    from grainflow.analysis.jet import dead_zone

    for p, rundir in zip(points.params, points.rundirs):
        if all(float(p[k]) == v for k, v in match.items()):
            frames, config = _run_frames(rundir)
            zone = dead_zone(frames, target_radius=0.5 * config["jet"]["target_diameter"],
                             window=window)
            if not zone.found:
                return f"- {label}: none"
            return (f"- {label}: found, up to {zone.height:g} d thick over the cells "
                    f"{zone.extent[1][0]:g} to {zone.extent[1][1]:g} (lateral)")
    return f"- {label}: not run"


# --------------------------------------------------------------------------------- report
@dataclass
class _Table:
    rows: list[str] = field(default_factory=list)

    def add(self, name: str, value: float | None, err: float | None, cost: float) -> None:
        seed, seed_err = SEED[name]
        tolerance = seed_err if seed_err is not None else 0.1 * abs(seed)
        if value is None or not np.isfinite(value):
            ours, verdict = "not measured", "—"
        else:
            ours = f"{value:.3g}" + (f" ± {err:.2g}" if err is not None and np.isfinite(err)
                                     else "")
            verdict = "agrees" if abs(value - seed) <= tolerance else "misses"
        quoted = f"{seed:g}" + (f" ± {seed_err:g}" if seed_err is not None else " (±10 %)")
        self.rows.append(f"| {name} | {quoted} | {ours} | {verdict} | {cost:.0f} |")


def reproduce(out_dir: str | Path, *, reduced: bool = True, scheduler: str | None = None,
              n_workers: int | None = None, progress: str = "auto") -> Path:
    """Run (or continue) the jet study into ``out_dir`` and write ``out_dir/report.md``."""
    from grainflow.analysis.jet.rheology import (
        fit_divergence_2d,
        fit_friction_2d,
        fit_friction_3d,
        kinetic_theory_check,
    )
    from grainflow.analysis.kinetic_theory import effective_restitution
    from grainflow.plotting.jet_plots import plot_psi0, plot_v2_vs_eccentricity
    from grainflow.plotting.jet_rheology_plots import (
        plot_divergence_2d,
        plot_friction_2d,
        plot_friction_3d,
        plot_pressure_ratio,
        plot_stress_profiles,
    )

    plan = REDUCED if reduced else FULL
    out = Path(out_dir)
    points = run_sweeps(sweep_specs(plan), out, scheduler=scheduler, n_workers=n_workers,
                        progress=progress)

    lines = [f"# Granular jets (seed 002) — {'reduced' if reduced else 'full'} version", ""]
    if plan.reductions:
        lines += ["Reductions relative to the seed:", ""] + [f"- {r}" for r in plan.reductions]
        lines.append("")
    lines += ["psi0 is the thesis's eq. 4.3 (force balance on the target), v2 the flux-weighted "
              "<cos 2 phi> of the outgoing velocities' azimuths; docs/jets.md defines every "
              "quantity and gives the measurements behind each miss.", ""]
    table = _Table()

    # Chapter 4: psi0(X) at e = 0.75, and v2(eps)
    sc = points["scatter"]
    at = [i for i, p in enumerate(sc.params) if float(p["jet.restitution"]) == 0.75]
    X, psi0, psi0_err = _mean_by([sc.summaries[i]["X"] for i in at],
                                 [sc.summaries[i]["psi0"] for i in at])
    fit = fit_psi0_means(X, psi0, psi0_err)
    for name in ("C0", "C1", "C2"):
        table.add(name, getattr(fit, name, None), getattr(fit, f"{name}_err", None), sc.cpu)
    _, psi0_v, psi0_v_err = _mean_by([sc.summaries[i]["X"] for i in at],
                                     [sc.summaries[i]["psi0_velocity"] for i in at])
    fit_v = fit_psi0_means(X, psi0_v, psi0_v_err)
    if len(X):
        plot_psi0(X, psi0, out / "psi0.png", psi0_err=psi0_err, fit=fit)
        plot_psi0(X, psi0_v, out / "psi0_velocity.png", psi0_err=psi0_v_err, fit=fit_v)
        lines += ["![psi0(X), force balance](psi0.png)",
                  "![psi0(X), outgoing velocity](psi0_velocity.png)"]
    an = points["anisotropy"]
    eps, v2, v2_err = _mean_by([s["eps"] for s in an.summaries], [s["v2"] for s in an.summaries])
    near = np.flatnonzero(np.isclose(eps, 0.615, atol=0.01))
    table.add("v2(eps=0.615), experiment", float(v2[near[0]]) if near.size else None,
              float(v2_err[near[0]]) if near.size else None, an.cpu)
    if len(eps):
        plot_v2_vs_eccentricity(eps, v2, out / "v2.png", v2_err=v2_err)
        lines.append("![v2(eps)](v2.png)")

    # Chapter 5: 3D rheology in the layer 0 < z < 5 d
    r3 = points["rheo3d"]
    layers3, flatness3, fabrics3 = (_rheology_3d(r3, plan.rheo3d_window) if r3.rundirs
                                    else ({}, {}, {}))
    checks = []
    for mu_p, label in ((0.2, "frictional"), (0.0, "frictionless")):
        mine = [lay for (phi, mu), lay in layers3.items() if mu == mu_p]
        friction = fit_friction_3d(mine) if mine else None
        table.add(f"a ({label})", getattr(friction, "a", None), getattr(friction, "a_err", None),
                  r3.cpu)
        dense = layers3.get((0.9, mu_p))
        ratio = dense.shear_ratio[0] if dense is not None else None
        ratio_err = dense.error("shear_ratio")[0] if dense is not None else None
        table.add(f"|s_rz/s_zz| ({label})", ratio, ratio_err, r3.cpu)
        flat = flatness3.get(mu_p, {})
        for comp in ("z", "r", "theta"):
            value, err = flat.get(comp, (None, None))
            table.add(f"flatness {comp} ({label})", value, err, r3.cpu)
        if mine:
            plot_friction_3d(mine, out / f"mu_I_3d_{label}.png", fit=friction,
                             labels=[f"φ̃0 = {phi:g}" for (phi, mu) in layers3 if mu == mu_p])
            lines.append(f"![mu*(I) 3D {label}](mu_I_3d_{label}.png)")
            e = float(effective_restitution(0.75, mu_p)) if mu_p > 0 else 0.75
            checks.append((label, [kinetic_theory_check(lay, e, 3) for lay in mine]))
            lines += _viscosity_lines(label, e, {phi: lay for (phi, mu), lay in layers3.items()
                                                 if mu == mu_p})
            lines += _fabric_lines(label, {phi: f for (phi, mu), f in fabrics3.items()
                                           if mu == mu_p},
                                   {phi: lay for (phi, mu), lay in layers3.items() if mu == mu_p})
        if dense is not None:
            plot_stress_profiles(dense, out / f"stress_3d_{label}.png")
            lines.append(f"![stress 3D {label}](stress_3d_{label}.png)")
        if mine:
            lines += _fit_choices_3d_lines(mine, label)
    for label, items in checks:
        plot_pressure_ratio(items, out / f"pressure_3d_{label}.png", per_direction=True)
        lines.append(f"![P/nT 3D {label}](pressure_3d_{label}.png)")

    # Chapter 6: 2D bidisperse frictionless, layers (a) and (b)
    r2 = points["rheo2d"]
    layers2 = _layers_2d(r2, plan.rheo2d_window) if r2.rundirs else {}
    flat2 = [lay for pair in layers2.values() for lay in pair]
    fits2: dict[str, Any] = {}
    for number, keys in (("I", ("phi_s", "a_s", "alpha_s")), ("I_T", ("phi_T", "a_T", "alpha_T"))):
        try:
            fits2[number] = fit_divergence_2d(flat2, number) if flat2 else None
        except ValueError:
            fits2[number] = None
        for key, attr in zip(keys, ("phi_c", "a", "alpha")):
            f = fits2[number]
            table.add(key, getattr(f, attr, None), getattr(f, f"{attr}_err", None), r2.cpu)
    try:
        mu_fit = fit_friction_2d(flat2, "mu_of_I") if flat2 else None
    except ValueError:
        mu_fit = None
    for key in ("mu_s", "mu_max", "I0"):
        table.add(key, getattr(mu_fit, key, None), getattr(mu_fit, f"{key}_err", None), r2.cpu)
    if flat2:
        labels = [f"φ̃0 = {phi:g}, layer {name}" for phi in layers2 for name in "ab"]
        plot_divergence_2d(flat2, out / "phi_I_2d.png",
                           fits={k: v for k, v in fits2.items() if v is not None},
                           labels=labels)
        plot_friction_2d(flat2, out / "mu_I_2d.png", fits=[mu_fit] if mu_fit else [],
                         labels=labels)
        lines += ["![phi(I) 2D](phi_I_2d.png)", "![mu*(I_s) 2D](mu_I_2d.png)"]
        if 0.9 in layers2:
            plot_stress_profiles(list(layers2[0.9]), out / "stress_2d.png")
            lines.append("![stress 2D](stress_2d.png)")
        lines += _fit_choices_lines(flat2)

    lines += ["", "Dead zone (cells next to the target with mean speed < 0.1 u0 and sqrt(T_g/m) < "
              "0.05 u0; the seed: one in 2D layer (a), none in 3D):", ""]
    lines += [_dead_zone_line(label, sweep, key, window) for label, sweep, key, window in (
        ("3D, φ̃0 = 0.9, μp = 0.2", r3, {"jet.phi_tilde": 0.9, "jet.mu_p": 0.2},
         plan.rheo3d_window),
        ("2D, φ̃0 = 0.9, frictionless", r2, {"jet.phi_tilde": 0.9}, plan.rheo2d_window))]
    lines += ["", "| quantity | seed | ours | within the seed's uncertainty (or 10 %) "
              "| run cost (CPU s, whole sweep) |", "|---|---|---|---|---|", *table.rows]
    lines += ["", "Scattering angle per X (e = 0.75; replica mean ± standard error): psi0 by "
              "the force balance of eq. 4.3 (the table above) and by the direction of the "
              "outgoing momentum flux:", "",
              "| X | psi0, eq. 4.3 (rad) | ± | psi0, velocity (rad) | ± |",
              "|---|---|---|---|---|"]
    lines += [f"| {x:g} | {p:.3f} | {e:.2g} | {pv:.3f} | {ev:.2g} |"
              for x, p, e, pv, ev in zip(X, psi0, psi0_err, psi0_v, psi0_v_err)]
    if fit_v is not None:
        lines += ["", f"Fit of the velocity angles: C0 = {fit_v.C0:.3g} ± {fit_v.C0_err:.2g}, "
                  f"C1 = {fit_v.C1:.3g} ± {fit_v.C1_err:.2g}, "
                  f"C2 = {fit_v.C2:.3g} ± {fit_v.C2_err:.2g}."]
    lines += ["", "v2 per eccentricity:", "", "| eps | v2 | ± |", "|---|---|---|"]
    lines += [f"| {x:.3f} | {v:.4f} | {e:.2g} |" for x, v, e in zip(eps, v2, v2_err)]
    total = sum(p.cpu for p in points.values())
    lines += ["", f"Total run time of the points: {total:.0f} s "
              f"({sum(len(p.rundirs) for p in points.values())} runs).", ""]
    report = out / "report.md"
    report.write_text("\n".join(lines) + "\n")
    return report
