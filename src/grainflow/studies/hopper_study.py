"""Reproduction of seed 003's hopper study (Cheng et al., Soft Matter 18, 8071 (2022)).

:func:`reproduce` builds the sweeps, runs them through :mod:`grainflow.sweep` (finished
points are never recomputed), fits the Beverloo law Q = C (w/sigma_avg - k)^beta per
(dimension, lambda) (seed eq. 1, Figs. 2-3), the sigmoid beta(lambda) in 2D (eq. 14, Fig. 4),
computes centre-line v_g(h) profiles (Fig. 5) and writes ``report.md`` with figures and the
comparison table. ``reduced=True`` shrinks widths, durations and the 3D system (every
reduction is listed in the report); docs/hopper_study.md explains the choices.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grainflow.scenarios.hopper import SIGMA_SMALL
from grainflow.studies.hopper_results import Series, collect_series, fmt, fmt_lambda_c


@dataclass(frozen=True)
class StudyPlan:
    """Sizes of the study; ``reductions`` lists how it departs from the seed."""

    widths_2d: tuple[float, ...]
    widths_3d: tuple[float, ...]
    lambdas_2d: tuple[float, ...]
    duration_2d: float
    duration_3d: float
    n_2d: int
    n_3d: int
    hard_E_sp: float
    wall_E: float
    reductions: tuple[str, ...] = field(default=())


FULL = StudyPlan(widths_2d=(3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0), widths_3d=(4.0, 5.0, 6.0, 8.0),
                 lambdas_2d=(0.0, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0, math.inf),
                 duration_2d=1000.0, duration_3d=600.0, n_2d=1600, n_3d=6400, hard_E_sp=1e4,
                 wall_E=1e4)
REDUCED = StudyPlan(widths_2d=(4.0, 5.0, 6.0, 8.0, 10.0), widths_3d=(4.0, 5.0, 6.0, 8.0),
                    lambdas_2d=(0.0, 3e-3, 3e-2, 0.3, math.inf), duration_2d=400.0,
                    duration_3d=250.0, n_2d=1600, n_3d=2000, hard_E_sp=1e3, wall_E=1e3,
                    reductions=("5 widths in 2D, 4 in 3D (seed: ~8)",
                                "3 finite lambda in 2D (seed: ~10); lambda_c poorly constrained",
                                "400 t0 of flow in 2D, 250 t0 in 3D",
                                "3D: N = 2000 in a cylinder of 20 sigma_s (seed: 6400, 30 sigma_s)",
                                "hard-particle limit at E_sp = 1e3 (seed: 1e4-1e5)",
                                "E_w = 1e3 (seed: 1e4; stiffer walls only shorten dt)"))

SEED = {("beta", 2, 0.0): 1.5, ("beta", 2, math.inf): 0.5, ("beta", 3, 0.0): 2.5,
        ("beta", 3, math.inf): 1.5, ("k", 2, 0.0): 1.6, ("k", 2, math.inf): 3.4,
        ("C", 2, 0.0): 0.14, ("C", 2, math.inf): 0.42, ("lambda_c", 2, None): 0.05}


def _base(dim: int, plan: StudyPlan, E_sp: float) -> dict[str, Any]:
    hopper: dict[str, Any] = {"n": plan.n_2d if dim == 2 else plan.n_3d, "orifice_width": 6.0,
                              "E_sp": E_sp, "E_w": max(plan.wall_E, E_sp), "lam": math.inf,
                              "dt_fraction": 0.05}
    if dim == 3 and plan is REDUCED:
        hopper["width"] = 20.0 * SIGMA_SMALL
    duration = plan.duration_2d if dim == 2 else plan.duration_3d
    return {"scenario": f"hopper{dim}d", "dim": dim,
            # health check at 2 r_s for E_sp = 100: with lambda -> 0 (no drag) the loose
            # initial fill falls ~30 sigma freely and its impact on the base compresses pairs
            # by up to ~0.65 sigma_avg (1.5 r_s) for a few t0. The impact energy per grain
            # (~20) stays below the pair barrier eps/2 = 50, dt/t_c ~ 0.01: the physics of the
            # SP model, not an instability.
            "run": {"duration": duration, "minimize": True,
                    "max_overlap_fraction": 2.0 if E_sp < 1e3 else 1.0,
                    "seed": 0},
            "output": {"thermo_every": 5000, "frames_every": 10000, "checkpoint_every": 0,
                       "snapshot": True},
            "hopper": hopper}


def sweep_specs(plan: StudyPlan) -> dict[str, Any]:
    """The study's sweeps (name -> validated :class:`~grainflow.sweep.SweepSpec`)."""
    from grainflow.sweep import parse_sweep

    analyses = ["grainflow.studies.hopper_results:flow_summary"]
    raw = {
        "q2d": {"base": _base(2, plan, 100.0), "overrides": {
            "hopper.orifice_width": list(plan.widths_2d), "hopper.lam": list(plan.lambdas_2d)}},
        "q3d": {"base": _base(3, plan, 100.0), "overrides": {
            "hopper.orifice_width": list(plan.widths_3d), "hopper.lam": [0.0, math.inf]}},
        "hard2d": {"base": _base(2, plan, plan.hard_E_sp), "overrides": {
            "hopper.orifice_width": list(plan.widths_2d), "hopper.lam": [0.0, math.inf]}},
    }
    return {name: parse_sweep({"name": name, "mode": "grid", "analyses": analyses, **spec})
            for name, spec in raw.items()}


def _collect(sweepdir: Path) -> dict[float, Series]:
    return {key[0]: series for key, series in collect_series(sweepdir).items()}


def _fits(series: dict[float, Series]) -> dict[float, Any]:
    from grainflow.analysis.hopper import fit_beverloo

    fits = {}
    for lam, s in sorted(series.items()):
        if len(s.w) >= 4:
            order = np.argsort(s.w)
            fits[lam] = fit_beverloo(np.array(s.w)[order], np.array(s.Q)[order],
                                     Q_err=np.array(s.Q_err)[order])
    return fits


def _profiles(series: Series, dim: int) -> tuple[list[Any], list[float]]:
    from grainflow.analysis.coarse_grain import centreline_velocity_profile_from_frames
    from grainflow.io.h5md import read_frames

    profiles, widths = [], []
    for w, rundir in sorted(zip(series.w, series.rundirs)):
        path = Path(rundir) / "frames.h5"
        if not path.is_file():
            continue
        frames = list(read_frames(path))
        frames = frames[len(frames) // 3:]  # the last two thirds: past the transient
        if frames:
            profiles.append(centreline_velocity_profile_from_frames(
                frames, np.linspace(0.0, 20.0, 81), np.zeros(dim), sigma=1.0))
            widths.append(w)
    return profiles, widths


def reproduce(out_dir: str | Path, *, reduced: bool = True, scheduler: str | None = None,
              n_workers: int | None = None, progress: str = "auto") -> Path:
    """Run (or continue) the hopper study into ``out_dir`` and write ``out_dir/report.md``."""
    from grainflow.analysis.hopper import fit_beta_sigmoid
    from grainflow.plotting.hopper_plots import (
        plot_beta_sigmoid,
        plot_beverloo,
        plot_velocity_profiles,
    )
    from grainflow.studies.points import run_sweeps

    plan = REDUCED if reduced else FULL
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict[float, Series]] = {}
    specs = sweep_specs(plan)
    run_sweeps(specs, out, scheduler=scheduler, n_workers=n_workers, progress=progress)
    for name in specs:
        results[name] = _collect(out / name)

    fits = {name: _fits(series) for name, series in results.items()}
    lines = [f"# Hopper study (seed 003) — {'reduced' if reduced else 'full'} version", ""]
    if plan.reductions:
        lines += ["Reductions relative to the seed:", ""] + [f"- {r}" for r in plan.reductions]
        lines.append("")
    for name, dim in (("q2d", 2), ("q3d", 3), ("hard2d", 2)):
        if fits[name]:
            labels = [f"λ = {lam:g}" for lam in fits[name]]
            plot_beverloo(list(fits[name].values()), out / f"{name}_beverloo.png", dim=dim,
                          labels=labels)
            lines.append(f"![Q(w) {name}]({name}_beverloo.png)")
    finite = [(lam, f) for lam, f in fits["q2d"].items() if 0 < lam < math.inf]
    sigmoid = None
    if len(finite) >= 3:
        sigmoid = fit_beta_sigmoid([lam for lam, _ in finite], [f.beta for _, f in finite],
                                   dim=2, beta_err=[max(f.beta_err, 1e-6) for _, f in finite])
        plot_beta_sigmoid(sigmoid, out / "beta_lambda.png")
        lines.append("![beta(lambda)](beta_lambda.png)")
    if math.inf in results["q2d"]:
        profiles, widths = _profiles(results["q2d"][math.inf], 2)
        if profiles:
            plot_velocity_profiles(profiles, widths, out / "vg_profiles.png")
            lines.append("![v_g(h)](vg_profiles.png)")
        if results["q2d"][math.inf].rundirs:
            final = Path(results["q2d"][math.inf].rundirs[-1]) / "final.png"
            lines.append(f"![snapshot]({final.relative_to(out)})")

    lines += ["", "| quantity | seed | ours | run cost (CPU s) |", "|---|---|---|---|"]

    def row(label: str, key: tuple, fit_set: str, attr: str) -> None:
        _, dim, lam = key
        fit = fits[fit_set].get(lam)
        ours = fmt(getattr(fit, attr), getattr(fit, f"{attr}_err")) if fit else "not run/fit"
        cost = results[fit_set].get(lam, Series()).cpu
        lines.append(f"| {label} | {SEED.get(key, 'n/a')} | {ours} | {cost:.0f} |")

    row("2D β, λ→0", ("beta", 2, 0.0), "q2d", "beta")
    row("2D β, λ→∞", ("beta", 2, math.inf), "q2d", "beta")
    row("3D β, λ→0", ("beta", 3, 0.0), "q3d", "beta")
    row("3D β, λ→∞", ("beta", 3, math.inf), "q3d", "beta")
    for lam in (0.0, math.inf):
        row(f"hard-particle k, λ={lam:g}", ("k", 2, lam), "hard2d", "k")
        row(f"hard-particle C, λ={lam:g}", ("C", 2, lam), "hard2d", "C")
    lines.append(f"| 2D λ_c | 0.05 | "
                 f"{fmt_lambda_c(sigmoid)} | |")
    lines += ["", "All Beverloo fits Q = C (w - k)^beta (fit uncertainties, 1 sigma):", "",
              "| sweep | λ | widths | C | k | β | χ²/dof |", "|---|---|---|---|---|---|---|"]
    for name, series_fits in fits.items():
        for lam, fit in series_fits.items():
            widths = ", ".join(f"{w:g}" for w in fit.x)
            chi = fit.chi2 / fit.dof if fit.dof > 0 else float("nan")
            lines.append(f"| {name} | {lam:g} | {widths} | {fmt(fit.C, fit.C_err)} | "
                         f"{fmt(fit.k, fit.k_err)} | {fmt(fit.beta, fit.beta_err)} | "
                         f"{fmt(chi)} |")
    lines += ["", "Measured flow rates (area/volume per t0, steady window by MSER):", "",
              "| sweep | λ | w | Q | ± |", "|---|---|---|---|---|"]
    for name, series in results.items():
        for lam, ser in sorted(series.items()):
            for w, q, e in sorted(zip(ser.w, ser.Q, ser.Q_err)):
                lines.append(f"| {name} | {lam:g} | {w:g} | {q:.4g} | {e:.2g} |")
    total = sum(s.cpu for series in results.values() for s in series.values())
    lines += ["", f"Total run time of the points: {total:.0f} s.", ""]
    report = out / "report.md"
    report.write_text("\n".join(lines) + "\n")
    return report
