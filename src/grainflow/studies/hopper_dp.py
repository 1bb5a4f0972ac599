"""Seed 003's hopper study with deformable particles (SPEC M6; docs/dp.md): Q(w) of rough and
smooth DP rings for the seed's (K_l, K_b) pairs in both lambda limits.

Every run is the 2D hopper of :mod:`grainflow.scenarios.hopper` on the authors' conventions
(``convention = "authors"``: tangential kinetic friction per vertex pair, drag per unit mass
on every vertex, their lid, lanes and counting rule) with ``particles = "dp_rough"`` or
``"dp_smooth"``. Each (model, lambda) series is fitted to Q = C (w/sigma_avg - k)^beta three
ways, as in :mod:`grainflow.studies.hopper_authors`: free, beta fixed as the paper fixed it
(3/2 and 1/2), and the paper's bounded fit.

What the seed says about DP hoppers (section 3 and Figs. 2, 4, 7): beta does not depend on
deformability or roughness (3/2 at lambda -> 0, 1/2 at lambda -> inf); k grows with
rigidity (lambda -> inf, smooth DP: from ~1 at small K_b to ~3.5 only for K_b above ~10^3;
from ~1 to ~2 as K_l rises from 1 to 10^3; lambda -> 0: k < 1 at K_b = 0.1 and ~1.5 at
K_b = 100) and with roughness; C ~ 0.42 (lambda -> inf) and ~0.15 (lambda -> 0) for every
K_l, K_b (N = 1600).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grainflow.studies.hopper_authors import AUTHORS_WIDTHS, C_SCALE, fit_cell, three_fits
from grainflow.studies.hopper_results import Series, collect_series

__all__ = ["DP_FULL", "DP_REDUCED", "DPModel", "DPPlan", "reproduce_dp", "sweep_specs",
           "three_fits", "usable"]


@dataclass(frozen=True)
class DPModel:
    """One deformable-particle model of the study."""

    particles: str  # "dp_rough" or "dp_smooth"
    K_l: float
    K_b: float
    lambdas: tuple[float, ...] = (0.0, math.inf)  # the limits run for this model

    @property
    def name(self) -> str:
        return f"{self.particles.removeprefix('dp_')}_Kl{self.K_l:g}_Kb{self.K_b:g}"

    @property
    def short(self) -> str:
        """A legend label: ``rough 10/0.1`` (kind, K_l/K_b)."""
        return f"{self.particles.removeprefix('dp_')} {self.K_l:g}/{self.K_b:g}"

    @property
    def label(self) -> str:
        kind = "rough (frictional)" if self.particles == "dp_rough" else "smooth (frictionless)"
        return f"{kind} DP, K_l = {self.K_l:g}, K_b = {self.K_b:g}"


#: The seed's DP models (Figs. 2, 4 and 7): the frictional DP and four frictionless ones.
SEED_MODELS = (DPModel("dp_rough", 10.0, 0.1), DPModel("dp_smooth", 10.0, 0.1),
               DPModel("dp_smooth", 10.0, 10.0), DPModel("dp_smooth", 10.0, 100.0),
               DPModel("dp_smooth", 1000.0, 0.1))


@dataclass(frozen=True)
class DPPlan:
    """Sizes of the DP study; ``reductions`` lists how it departs from the seed."""

    models: tuple[DPModel, ...]
    widths: tuple[float, ...]
    n: int
    width: float
    duration: float
    dt_fraction: float
    reductions: tuple[str, ...] = field(default=())

    @property
    def lambdas(self) -> tuple[float, ...]:
        """Every lambda some model runs, ascending."""
        return tuple(sorted({lam for m in self.models for lam in m.lambdas}))


DP_FULL = DPPlan(models=SEED_MODELS, widths=AUTHORS_WIDTHS[::2], n=1600, width=50.0,
                 duration=150.0, dt_fraction=0.05)
DP_REDUCED = DPPlan(
    models=(DPModel("dp_rough", 10.0, 0.1), DPModel("dp_rough", 10.0, 100.0, (math.inf,)),
            DPModel("dp_smooth", 10.0, 0.1, (math.inf,))),
    widths=(3.0, 4.0, 5.0, 6.0), n=200, width=20.0, duration=60.0, dt_fraction=1.0 / 15.0,
    reductions=("N = 200 rings in a hopper 20 sigma_avg wide (seed: 1600 in 50), so C is "
                "not the seed's (it depends on N, seed Appendix C); beta and k are compared",
                "4 widths, 3-6 sigma_avg (full: 3.0-10.2, 10 widths)",
                "3 models: rough (10, 0.1) in both limits, rough (10, 100) and smooth "
                "(10, 0.1) in the drag limit only (full: the seed's five models, both "
                "limits); a smooth run costs 5 times a rough one (its contacts are 25 times "
                "stiffer)",
                "60 t0 of flow, of which the first ~20 t0 are the loose fill settling at the "
                "drag limit's terminal speed (full: 150 t0), dt = t_c/15 (full: t_c/20)"))

#: Seed values for the report: (quantity, lambda) -> text.
SEED = {("beta", 0.0): "3/2 (all DP models)", ("beta", math.inf): "1/2 (all DP models)",
        ("C", 0.0): f"0.15 ({0.15 * C_SCALE:.2f})", ("C", math.inf): f"0.42 ({0.42 * C_SCALE:.2f})"}
#: The seed's k for DP (section 3, Fig. 7): model name -> {lambda: text}.
SEED_K = {"rough_Kl10_Kb0.1": {0.0: "above the smooth DP's (roughness raises k)",
                               math.inf: "above the smooth DP's"},
          "smooth_Kl10_Kb0.1": {0.0: "< 1", math.inf: "~1"},
          "smooth_Kl10_Kb10": {0.0: "", math.inf: "between ~1 and ~3.5"},
          "smooth_Kl10_Kb100": {0.0: "~1.5", math.inf: "rises with K_b (3.5 needs K_b > 10^3)"},
          "smooth_Kl1000_Kb0.1": {0.0: "", math.inf: "~2"}}


def _base(plan: DPPlan, model: DPModel) -> dict[str, Any]:
    return {"scenario": "hopper2d", "dim": 2,
            "run": {"duration": plan.duration, "minimize": True, "seed": 0},
            "output": {"thermo_every": 5000, "frames_every": 50000, "checkpoint_every": 0,
                       "snapshot": True},
            "hopper": {"convention": "authors", "particles": model.particles,
                       "K_l": model.K_l, "K_b": model.K_b, "n": plan.n, "width": plan.width,
                       "orifice_width": plan.widths[0], "lam": math.inf,
                       "dt_fraction": plan.dt_fraction}}


def sweep_specs(plan: DPPlan) -> dict[str, Any]:
    """One sweep per model over widths and the two lambda limits (name -> SweepSpec)."""
    from grainflow.sweep import parse_sweep

    analyses = ["grainflow.studies.hopper_results:flow_summary"]
    return {m.name: parse_sweep({
        "name": m.name, "mode": "grid", "analyses": analyses, "base": _base(plan, m),
        "overrides": {"hopper.orifice_width": list(plan.widths),
                      "hopper.lam": list(m.lambdas)}}) for m in plan.models}


def usable(fit: Any, dim: int = 2) -> bool:
    """Whether a Beverloo fit is physical: k >= 0 and beta <= d + 1 (a free fit to four
    noisy widths can converge to beta = 9, k = -50, which describes nothing)."""
    return fit is not None and fit.k >= 0 and fit.beta <= dim + 1


def _cell(fit: Any, attr: str) -> str:
    """:func:`fit_cell`, or what makes the fit degenerate."""
    if fit is not None and not usable(fit):
        return f"degenerate (β = {fit.beta:.3g}, k = {fit.k:.3g})"
    return fit_cell(fit, attr)


def _arrow(lam: float) -> str:
    return "0" if lam == 0 else "∞"


def _figures(out: Path, plan: DPPlan, fits: dict, results: dict) -> list[str]:
    """Q(w) with free fits per lambda limit (the seed's Fig. 2), k against K_b and the
    model (Fig. 7), and a snapshot of the rings (Fig. 1)."""
    from grainflow.plotting.hopper_plots import plot_beverloo, plot_offsets

    lines = []
    for lam in plan.lambdas:
        chosen = []  # the free fit, or beta fixed where the free fit is degenerate
        for m in plan.models:
            three = fits.get(m.name, {}).get(lam, {})
            if usable(three.get("free")):
                chosen.append((m.short, three["free"]))
            elif three.get("fixed") is not None:
                chosen.append((f"{m.short} (free fit degenerate)", three["fixed"]))
        if chosen:
            name = f"dp_beverloo_lambda_{_arrow(lam).replace('∞', 'inf')}.png"
            plot_beverloo([f for _, f in chosen], out / name, dim=2,
                          labels=[label for label, _ in chosen])
            lines.append(f"![Q(w), λ → {_arrow(lam)}; legend: kind K_l/K_b]({name})")
    k_points = {lam: [(m.short, fits[m.name][lam]["free"]) for m in plan.models
                      if usable(fits.get(m.name, {}).get(lam, {}).get("free"))]
                for lam in plan.lambdas}
    if any(k_points.values()):
        plot_offsets(k_points, out / "dp_offsets.png")
        lines.append("![k and beta of every model](dp_offsets.png)")
    for m in plan.models:
        ser = results.get(m.name, {}).get((math.inf,))
        if ser and ser.rundirs:
            final = Path(ser.rundirs[int(np.argmax(ser.w))]) / "final.png"
            if final.is_file():
                lines.append(f"![{m.label}, λ → ∞, w = {max(ser.w):g}]"
                             f"({final.relative_to(out)})")
                break
    return lines


def _seed_table(plan: DPPlan, fits: dict, results: dict) -> list[str]:
    lines = ["", "## Seed numbers, three fits side by side", "",
             "| model | λ | quantity | seed | free | beta fixed | bounded (paper) |",
             "|---|---|---|---|---|---|---|"]
    for m in plan.models:
        for lam in m.lambdas:
            f = fits.get(m.name, {}).get(lam, {})
            clogged = results.get(m.name, {}).get((lam,), Series()).clogged
            for attr in ("beta", "k", "C"):
                seed = (SEED_K.get(m.name, {}).get(lam, "") if attr == "k"
                        else SEED.get((attr, lam), ""))
                if attr == "k" and clogged:
                    seed += f"; clogged here at w = {', '.join(f'{w:g}' for w in clogged)}"
                lines.append(f"| {m.label} | → {_arrow(lam)} | {attr} | {seed} | "
                             f"{_cell(f.get('free'), attr)} | "
                             f"{_cell(f.get('fixed'), attr)} | "
                             f"{_cell(f.get('bounded'), attr)} |")
    return lines


def _rates_table(plan: DPPlan, results: dict) -> list[str]:
    lines = ["", "## Measured flow rates (MSER steady window)", "",
             "| model | λ | w | Q | ± | CPU s (series) |", "|---|---|---|---|---|---|"]
    for m in plan.models:
        for (lam,), ser in sorted(results.get(m.name, {}).items()):
            for w, q, e in sorted(zip(ser.w, ser.Q, ser.Q_err)):
                lines.append(f"| {m.label} | {lam:g} | {w:g} | {q:.4g} | {e:.2g} | "
                             f"{ser.cpu:.0f} |")
            for w in sorted(ser.clogged):
                lines.append(f"| {m.label} | {lam:g} | {w:g} | 0 (clogged) | | {ser.cpu:.0f} |")
    total = sum(s.cpu for series in results.values() for s in series.values())
    return lines + ["", f"Total run time of the points: {total:.0f} s.", ""]


def _failed_table(out: Path, plan: DPPlan) -> list[str]:
    """Points whose run or flow analysis failed, with the reason (e.g. too few crossings for
    the error bar of a slow flow)."""
    from grainflow.sweep import Catalog

    lines = []
    for m in plan.models:
        if not (out / m.name).is_dir():
            continue
        with Catalog.in_dir(out / m.name) as catalog:
            for row in catalog.rows("failed"):
                reason = (row.error or "").strip().splitlines()
                lines.append(f"| {m.label} | {float(row.params['hopper.lam']):g} | "
                             f"{float(row.params['hopper.orifice_width']):g} | "
                             f"{reason[-1] if reason else 'unknown'} |")
    if not lines:
        return []
    return (["", "## Points without a flow rate", "", "| model | λ | w | reason |",
             "|---|---|---|---|"] + lines + [""])


def reproduce_dp(out_dir: str | Path, *, reduced: bool = True, scheduler: str | None = None,
                 n_workers: int | None = None, progress: str = "auto") -> Path:
    """Run (or continue) the DP study into ``out_dir``; write ``out_dir/report.md``."""
    from grainflow.studies.points import run_sweeps

    plan = DP_REDUCED if reduced else DP_FULL
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict[tuple, Series]] = {}
    specs = sweep_specs(plan)
    run_sweeps(specs, out, scheduler=scheduler, n_workers=n_workers, progress=progress)
    for name in specs:
        results[name] = collect_series(out / name, ("hopper.lam",))
    fits = {name: {key[0]: three_fits(s, 2, key[0]) for key, s in sorted(series.items())}
            for name, series in results.items()}
    lines = [f"# Hopper study with deformable particles (seed 003) — "
             f"{'reduced' if reduced else 'full'} version", "",
             "`[hopper] convention = \"authors\"`, `particles = \"dp_rough\" | \"dp_smooth\"` "
             "(docs/dp.md). Area flow rates in Q0 = sigma_avg^2/t0; the seed's C as printed, "
             f"then in our units read as grains per 1000 code steps (x {C_SCALE:.2f}, "
             "docs/hopper_study.md). Fits: free; beta fixed as the paper fixed it (3/2, 1/2); "
             "the paper's bounded fit (beta <= 1.58, k >= 0.5). Never rescaled.", ""]
    if plan.reductions:
        lines += ["Reductions relative to the full study:", ""]
        lines += [f"- {r}" for r in plan.reductions] + [""]
    lines += _figures(out, plan, fits, results)
    lines += _seed_table(plan, fits, results)
    lines += _rates_table(plan, results)
    lines += _failed_table(out, plan)
    report = out / "report.md"
    report.write_text("\n".join(lines) + "\n")
    return report
