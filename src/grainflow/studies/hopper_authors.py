"""Seed 003's hopper study on the authors' path (second pass; docs/hopper_study.md).

The first pass (:mod:`grainflow.studies.hopper_study`) reads the printed seed. This one runs
the SP model as the authors' public code does (``[hopper] convention = "authors"``:
tangential kinetic friction, drag per unit mass, size-proportional stiffness, their lid,
lanes and counting rule, every magnitude converted to consistent units by
:mod:`grainflow.scenarios.hopper_units`) and sweeps lambda as they did: mu at its limit while
the drag rises, then the drag at its limit while mu falls.

Every seed number is compared through three fits of Q = C (w/sigma_avg - k)^beta, side by
side: the free fit; beta fixed as the paper fixed it (Figs. 2, 3 and 10: 3/2 and 1/2 in 2D,
5/2 and 3/2 in 3D); and the paper's bounded fit (beta <= 1.58 and k >= 0.5 in 2D, 1.5 <=
beta <= 2.5 in 3D). The paper then rescaled its bounded betas so that the three
smallest-lambda points average 3/2; we never rescale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grainflow.scenarios.hopper_units import AUTHORS_3D_SPK, AUTHORS_3D_UNITS, AUTHORS_CODE
from grainflow.studies.hopper_results import Series, collect_series, fmt, fmt_lambda_c

__all__ = ["AUTHORS_FULL", "AUTHORS_REDUCED", "AuthorsPlan", "FITS", "reproduce_authors",
           "sweep_specs"]

#: The authors' committed widths, w/sigma_avg = 3.0, 3.4, ..., 10.6.
AUTHORS_WIDTHS = tuple(round(3.0 + 0.4 * k, 1) for k in range(20))
#: lambda where the authors' sweep switches from raising the drag to lowering mu (0.181).
LAMBDA_SWITCH = AUTHORS_CODE.units.lam(AUTHORS_CODE.b_limit, AUTHORS_CODE.mu_limit)
#: mu/mu0 of the authors' 60 and 30 degree runs (mu = 50 code units).
MU_INCLINED = AUTHORS_CODE.units.mu(50.0)


@dataclass(frozen=True)
class AuthorsPlan:
    """Sizes of the second-pass study; ``reductions`` lists how it departs from the seed."""

    widths_2d: tuple[float, ...]
    lambdas_2d: tuple[float, ...]
    duration_2d: float
    widths_3d: tuple[float, ...]
    lambdas_3d: tuple[float, ...]
    duration_3d: float
    n_3d: int
    hard_E_sp: tuple[float, ...]
    widths_hard: tuple[float, ...]
    duration_hard: float
    theta_w: tuple[float, ...]
    duration_theta: float
    widths_theta: tuple[float, ...]
    lambdas_theta: tuple[float, ...]
    widths_probe: tuple[float, ...]
    probes: tuple[str, ...]
    #: Seeds (besides q2d's 0) of replicate 2D lambda sweeps (every lambda of lambdas_2d):
    #: the spread of beta between realizations, and so of lambda_c, which no fit's error holds.
    replicate_seeds: tuple[int, ...] = ()
    #: Widths of the replicate sweeps (None: widths_2d).
    replicate_widths: tuple[float, ...] | None = None
    #: lambdas of the replicate sweeps (None: lambdas_2d; the two limits give the spread of
    #: the limits' betas, not each realization's lambda_c).
    replicate_lambdas: tuple[float, ...] | None = None
    reductions: tuple[str, ...] = field(default=())


AUTHORS_FULL = AuthorsPlan(
    widths_2d=AUTHORS_WIDTHS,
    lambdas_2d=(0.0, 1e-4, 1e-3, 5e-3, 0.01, 0.02, 0.05, 0.1, LAMBDA_SWITCH, 0.5, 2.0,
                math.inf),
    duration_2d=300.0, widths_3d=(4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0),
    lambdas_3d=(0.0, 0.01, 0.05, LAMBDA_SWITCH, 1.0, math.inf), duration_3d=200.0,
    n_3d=6400,
    hard_E_sp=(1e4, 1e5), widths_hard=AUTHORS_WIDTHS[::2], duration_hard=150.0,
    theta_w=(60.0, 30.0, 20.0), duration_theta=300.0, widths_theta=AUTHORS_WIDTHS[::4],
    lambdas_theta=(0.0, 1e-4, 1e-3, 5e-3, 0.02, 0.1, 1.0, math.inf),
    widths_probe=(3.0, 4.6, 6.2, 7.8, 9.4, 10.6),
    probes=("friction_dt", "friction_E1000", "friction_full", "friction_constant",
            "friction_sequential", "friction_n3200", "friction3d_mu10", "friction3d_stiff"),
    replicate_seeds=(1, 2, 3), replicate_widths=AUTHORS_WIDTHS[::2])
AUTHORS_REDUCED = AuthorsPlan(
    widths_2d=(3.0, 4.6, 6.2, 7.8, 9.4, 10.6),
    lambdas_2d=(0.0, 5e-3, 0.02, 0.05, LAMBDA_SWITCH, 1.0, math.inf),
    duration_2d=150.0, widths_3d=(4.0, 5.0, 6.0, 7.0, 8.0, 9.0),
    lambdas_3d=(0.0, math.inf), duration_3d=100.0,
    n_3d=6400, hard_E_sp=(1e4, 1e5), widths_hard=(3.0, 5.4, 7.8, 10.2), duration_hard=100.0,
    theta_w=(60.0, 30.0), duration_theta=150.0, widths_theta=(3.0, 5.4, 7.8, 10.2),
    lambdas_theta=(0.0, 1e-3, 5e-3, 0.02, 0.1, math.inf),
    widths_probe=(3.0, 4.6, 6.2, 7.8, 9.4, 10.6),
    probes=("friction_n3200",), replicate_seeds=(1,), replicate_lambdas=(0.0, math.inf),
    reductions=("6 widths of the authors' 20 in 2D (3.0-10.6), 6 in 3D (4-9; full: 4-10)",
                "7 lambda in 2D (full: 12), the two limits in 3D (full: 6 lambda); the inclined hoppers at "
                "theta_w = 60 and 30 with 4 widths and 6 lambda (full: also 20, with 5 widths "
                "and 8 lambda)",
                "150 t0 of flow in 2D (the authors' runs: ~153 t0), 100 t0 in 3D and for the "
                "hard-particle limit (full: 300, 200, 150)",
                "hard-particle limit with 4 widths (full: 10)",
                "one friction-limit probe (N = 3200); full: also the sequential start, the "
                "authors' dt, E_sp = 1000, full friction, constant stiffness, and 3D at a "
                "tenth of mu and with the 3D branch's stiffness",
                "one replicate realization (seed 1) of the 2D limits, lambda = 0 and infinity "
                "(full: three of the whole 2D lambda sweep, over 10 widths)"))

#: E_sp of the authors' 3D branch (spK = 100), converted as its masses (pi r^2) and the 2D
#: code's g = 0.05 give (hopper_units.AUTHORS_3D_UNITS): 926.
STIFF_3D = AUTHORS_3D_UNITS.pair_force_scale(AUTHORS_3D_SPK)
#: The friction-limit probes: one convention changed at a time.
PROBES: dict[str, dict[str, Any]] = {
    "friction_dt": {"run": {"dt": AUTHORS_CODE.units.duration(AUTHORS_CODE.dt)}},
    "friction_full": {"hopper": {"friction_on": "full"}},
    "friction_constant": {"hopper": {"stiffness": "constant"}},
    "friction_E1000": {"hopper": {"E_sp": 1000.0, "E_w": 1000.0}},
    "friction3d_mu10": {"dim": 3, "hopper": {"mu_limit": 0.1 * AUTHORS_CODE.units.mu(10.0)}},
    "friction3d_stiff": {"dim": 3, "hopper": {"E_sp": STIFF_3D, "E_w": STIFF_3D}},
    "friction_sequential": {"hopper": {"initial_packing": "sequential"}},
    "friction_n3200": {"hopper": {"n": 3200}},
}


def probe_dim(name: str) -> int:
    """The dimension of a probe (2 unless it says ``"dim"``)."""
    return int(PROBES[name].get("dim", 2))


#: What each probe changes, for the report.
PROBE_LABELS = {"q2d": "the authors' conventions (dt = t_c/20)",
                "friction_dt": "the authors' dt = 0.005 code = 2.6e-4 t0",
                "friction_full": "friction on the full relative velocity",
                "friction_constant": "one eps for every pair (stiffness = 'constant')",
                "friction_E1000": "stiffer grains, E_sp = E_w = 1000 (the hard limit: below)",
                "q3d": "3D, the authors' conventions converted as in 2D",
                "friction3d_mu10": "3D with a ten times weaker friction, mu/mu0 = 0.85",
                "friction3d_stiff": "3D with the 3D branch's pair stiffness (spK = 100: "
                                    "E_sp = E_w = 926)",
                "friction_sequential": "the loose sequential start (packing 0.45) instead of "
                                       "the authors' inflated one",
                "friction_n3200": "twice the grains, N = 3200 (a pile twice as tall)"}

#: Seed numbers: (quantity, dim, lambda) -> value. C in the paper's plotted units (grains per
#: 1000 steps); ``C_SCALE`` turns them into area rates in Q0 (hopper_units).
SEED = {("beta", 2, 0.0): 1.5, ("beta", 2, math.inf): 0.5, ("beta", 3, 0.0): 2.5,
        ("beta", 3, math.inf): 1.5, ("k", 2, 0.0): 1.6, ("k", 2, math.inf): 3.4,
        ("C", 2, 0.0): 0.14, ("C", 2, math.inf): 0.42}
C_SCALE = AUTHORS_CODE.units.flow_rate(1.0, AUTHORS_CODE.dt)
#: The same if the paper's Q0 used its printed t0 = sqrt(10) code time (our t0 is 19.6): a
#: reading to test, not a fact of the code (docs/hopper_study.md, "Magnitudes").
C_SCALE_PRINTED_T0 = AUTHORS_CODE.units.time / math.sqrt(10.0)
#: The paper's fixed exponents (dim, lambda -> 0 or inf) and bounded-fit limits per dim.
FIXED_BETA = {(2, 0.0): 1.5, (2, math.inf): 0.5, (3, 0.0): 2.5, (3, math.inf): 1.5}
BOUNDS = {2: {"beta_bounds": (1e-6, 1.58), "k_min": 0.5},
          3: {"beta_bounds": (1.5, 2.5), "k_min": 0.5}}
#: The three fits of every series.
FITS = ("free", "fixed", "bounded")


def hard_name(E_sp: float) -> str:
    """Sweep name of the hard-particle limit at ``E_sp``."""
    return f"hard2d_E{E_sp:g}"


def _base(dim: int, plan: AuthorsPlan, duration: float, **hopper: Any) -> dict[str, Any]:
    section: dict[str, Any] = {"convention": "authors", "orifice_width": 6.0, "lam": math.inf,
                               **hopper}
    if dim == 3:
        section["n"] = plan.n_3d
    return {"scenario": f"hopper{dim}d", "dim": dim,
            # the soft pile under its weight and the loose fill's first impact compress pairs
            # by up to ~1.5 r_s at E_sp ~ 139 (docs/hopper_study.md, "Choices")
            "run": {"duration": duration, "minimize": True, "max_overlap_fraction": 2.0,
                    "seed": 0},
            "output": {"thermo_every": 5000, "frames_every": 20000, "checkpoint_every": 0,
                       "snapshot": True},
            "hopper": section}


def sweep_specs(plan: AuthorsPlan) -> dict[str, Any]:
    """The study's sweeps (name -> validated :class:`~grainflow.sweep.SweepSpec`)."""
    from grainflow.sweep import parse_sweep

    raw: dict[str, Any] = {
        "q2d": {"base": _base(2, plan, plan.duration_2d), "overrides": {
            "hopper.orifice_width": list(plan.widths_2d), "hopper.lam": list(plan.lambdas_2d)}},
        "q3d": {"base": _base(3, plan, plan.duration_3d), "overrides": {
            "hopper.orifice_width": list(plan.widths_3d), "hopper.lam": list(plan.lambdas_3d)}},
    }
    for E in plan.hard_E_sp:  # walls as stiff as the grains
        raw[hard_name(E)] = {
            "base": _base(2, plan, plan.duration_hard, E_sp=E, E_w=E),
            "overrides": {"hopper.orifice_width": list(plan.widths_hard),
                          "hopper.lam": [0.0, math.inf]}}
    if plan.theta_w:
        raw["theta2d"] = {"base": _base(2, plan, plan.duration_theta, mu_limit=MU_INCLINED),
                          "overrides": {"hopper.orifice_width": list(plan.widths_theta),
                                        "hopper.lam": list(plan.lambdas_theta),
                                        "hopper.theta_w": list(plan.theta_w)}}
    # the friction limit with one convention changed at a time (the report's "What moves
    # beta at the friction limit"): the authors' time step, stiffer grains, full friction ...
    for name in plan.probes:
        change = PROBES[name]
        dim = probe_dim(name)
        base = _base(dim, plan, plan.duration_2d if dim == 2 else plan.duration_3d, lam=0.0,
                     **change.get("hopper", {}))
        base["run"].update(change.get("run", {}))
        widths = plan.widths_probe if dim == 2 else plan.widths_3d
        raw[name] = {"base": base, "overrides": {"hopper.orifice_width": list(widths)}}
    if plan.theta_w:
        raw["theta2d"]["base"]["hopper"]["theta_w"] = plan.theta_w[0]
    if plan.replicate_seeds:
        raw[REPLICAS] = {"base": _base(2, plan, plan.duration_2d), "overrides": {
            "hopper.orifice_width": list(plan.replicate_widths or plan.widths_2d),
            "hopper.lam": list(plan.replicate_lambdas or plan.lambdas_2d)},
            "seeds": list(plan.replicate_seeds)}
    analyses = ["grainflow.studies.hopper_results:flow_summary"]
    return {name: parse_sweep({"name": name, "mode": "grid", "analyses": analyses, **spec})
            for name, spec in raw.items()}


#: Sweep name of the replicate 2D lambda sweeps (other seeds than q2d's).
REPLICAS = "replicas2d"


def collect(sweepdir: Path, lam: float | None = None) -> dict[tuple, Series]:
    """Series keyed by (lambda, E_sp or None, theta_w or None) from a finished sweep;
    ``lam`` for a sweep at one lambda (the probes)."""
    return collect_series(sweepdir, ("hopper.lam", "hopper.E_sp", "hopper.theta_w"),
                          fixed=None if lam is None else {"hopper.lam": lam})


def three_fits(series: Series, dim: int, lam: float) -> dict[str, Any]:
    """The free, fixed-beta (only at the two limits) and bounded Beverloo fits of a series;
    a fit that cannot be made (too few widths, no convergence) is absent."""
    from grainflow.analysis.hopper import fit_beverloo

    out: dict[str, Any] = {}
    if len(series.w) < 4:
        return out
    order = np.argsort(series.w)
    w = np.asarray(series.w)[order]
    Q = np.asarray(series.Q)[order]
    err = np.asarray(series.Q_err)[order]
    options: dict[str, dict[str, Any]] = {"free": {}, "bounded": dict(BOUNDS[dim])}
    if (dim, lam) in FIXED_BETA:
        options["fixed"] = {"beta": FIXED_BETA[(dim, lam)]}
    for name, kw in options.items():
        if BOUNDS[dim].get("k_min", 0.0) >= w.min() and name == "bounded":
            continue
        try:
            out[name] = fit_beverloo(w, Q, Q_err=err, **kw)
        except (ValueError, RuntimeError):
            continue
    return out


#: The lambda_c fits of a beta(lambda) series (:func:`_sigmoids`) and their report labels:
#: eq. (14) through the free and through the bounded betas (never rescaled), and eq. (14)
#: through the free betas with its limits d - 1/2, d - 3/2 replaced by the free betas the same
#: series measures at lambda = 0 and infinity (the midpoint of the model's own transition).
SIGMOID_KINDS = {"free": "the free betas", "bounded": "the bounded betas",
                 "measured": "the free betas, between their measured limits"}


def _sigmoids(fits: list[tuple[float, dict[str, Any]]], dim: int, *,
              weighted: bool = True) -> dict[str, Any]:
    """lambda_c of each of :data:`SIGMOID_KINDS` over (lambda, three fits) pairs; a lambda may
    appear once per realization (the measured limits are then the realizations' mean free
    betas at lambda = 0 and infinity). ``weighted``: each beta weighs by its fit's error (at
    least 0.02); otherwise all weigh alike and the covariance is scaled by the scatter about
    the sigmoid, which then holds the spread between realizations."""
    from grainflow.analysis.hopper import fit_beta_sigmoid

    ends = {end: [f["free"].beta for lam, f in fits if lam == end and "free" in f]
            for end in (0.0, math.inf)}
    measured = (float(np.mean(ends[0.0])), float(np.mean(ends[math.inf]))) \
        if ends[0.0] and ends[math.inf] else None
    out = {}
    for kind in SIGMOID_KINDS:
        source = "free" if kind == "measured" else kind
        if kind == "measured" and measured is None:
            continue
        pts = [(lam, f[source]) for lam, f in sorted(fits, key=lambda item: item[0])
               if 0 < lam < math.inf and source in f]
        if len(pts) >= 3:
            try:
                out[kind] = fit_beta_sigmoid(
                    [lam for lam, _ in pts], [f.beta for _, f in pts], dim=dim,
                    beta_err=[max(f.beta_err, 0.02) for _, f in pts] if weighted else None,
                    limits=measured if kind == "measured" else None)
            except (ValueError, RuntimeError):
                pass
    return out


def fit_cell(fit: Any, attr: str) -> str:
    """One table cell: the value with its error, "(fixed)" or "(at bound)" as it applies."""
    if fit is None:
        return "–"
    value = getattr(fit, attr)
    err = getattr(fit, f"{attr}_err")
    if attr == "beta" and fit.beta_fixed:
        return f"{value:g} (fixed)"
    text = fmt(value, err)
    return text + (" (at bound)" if attr in fit.at_bound else "")


def _chi(fit: Any) -> str:
    return fmt(fit.chi2 / fit.dof) if fit is not None and fit.dof > 0 else "–"


def _key_order(item: tuple[tuple, Any]) -> tuple:
    return tuple(-1 if v is None else v for v in item[0])


def _arrow(lam: float) -> str:
    return "0" if lam == 0 else "∞"


def _seed_c(c: float) -> str:
    """A seed C as printed and in our units, read both ways (see :data:`C_SCALE`)."""
    return f"{c} ({c * C_SCALE:.2f} \\| {c * C_SCALE_PRINTED_T0:.2f})"


def _sigmoid_fits(plan: AuthorsPlan, fits: dict) -> dict[Any, dict[str, Any]]:
    """beta(lambda) sigmoids: ``"q2d"``, ``"q3d"`` and each theta_w of the inclined hoppers."""
    out: dict[Any, dict[str, Any]] = {
        name: _sigmoids([(key[0], f) for key, f in fits.get(name, {}).items()], dim)
        for name, dim in (("q2d", 2), ("q3d", 3))}
    for theta in plan.theta_w:
        out[theta] = _sigmoids([(key[0], f) for key, f in fits.get("theta2d", {}).items()
                                if key[2] == theta], 2)
    return out


#: Key of the pooled realizations in :func:`replicate_sigmoids`.
POOLED = "pooled"


def realization_fits(fits: dict, replicas: dict[tuple, Series]) -> dict[tuple[float, int], Any]:
    """The three fits of every 2D realization keyed (lambda, seed): q2d's as seed 0, each
    replicate series (keyed (lambda, seed), :func:`collect_series`) fitted once."""
    out: dict[tuple[float, int], Any] = {(key[0], 0): f for key, f in fits.get("q2d", {}).items()}
    out.update({(lam, int(seed)): three_fits(ser, 2, lam)
                for (lam, seed), ser in replicas.items()})
    return out


def replicate_sigmoids(realizations: dict[tuple[float, int], Any]) -> dict[Any, dict[str, Any]]:
    """2D lambda_c of each realization (seed -> sigmoids) of :func:`realization_fits` and of
    all of them pooled (:data:`POOLED`: one unweighted fit to every realization's betas, its
    error from their scatter about the sigmoid, so it holds the spread between
    realizations)."""
    by_seed: dict[int, list[tuple[float, dict[str, Any]]]] = {}
    for (lam, seed), three in sorted(realizations.items()):
        by_seed.setdefault(seed, []).append((lam, three))
    out: dict[Any, dict[str, Any]] = {seed: _sigmoids(pts, 2) for seed, pts in by_seed.items()}
    out[POOLED] = _sigmoids([(lam, three) for (lam, _), three in realizations.items()], 2,
                            weighted=False)
    return out


def _figures(out: Path, fits: dict, results: dict, dims: dict[str, int],
             sigmoids: dict[Any, dict[str, Any]],
             replicates: dict[Any, dict[str, Any]]) -> list[str]:
    """Q(w) with the free fits per sweep, two snapshots, beta(lambda) and, with replicate
    realizations, beta(lambda) of each and pooled."""
    from grainflow.plotting.hopper_plots import plot_beta_sigmoid, plot_beverloo

    lines = []
    for name, dim in dims.items():
        chosen = [(key, f["free"]) for key, f in fits.get(name, {}).items() if "free" in f]
        if name in PROBES or not chosen:
            continue
        labels = [", ".join(p for p in (f"λ = {k[0]:g}", f"E_sp = {k[1]:g}" if k[1] else "",
                                        f"θ_w = {k[2]:g}" if k[2] else "") if p)
                  for k, _ in chosen]
        plot_beverloo([f for _, f in chosen], out / f"{name}_beverloo.png", dim=dim,
                      labels=labels)
        lines.append(f"![Q(w) {name}]({name}_beverloo.png)")
    lines.append("")
    for lam, label in ((0.0, "friction limit"), (math.inf, "drag limit")):
        ser = results["q2d"].get((lam, None, None))
        if ser and ser.rundirs:
            final = Path(ser.rundirs[int(np.argmax(ser.w))]) / "final.png"
            if final.is_file():
                lines.append(f"![{label}, w = {max(ser.w):g}]({final.relative_to(out)})")
    if "free" in sigmoids["q2d"]:
        plot_beta_sigmoid(sigmoids["q2d"]["free"], out / "beta_lambda.png")
        lines.append("![beta(lambda), free fits](beta_lambda.png)")
    chosen = [(key, s["free"]) for key, s in replicates.items() if "free" in s]
    if len(chosen) > 2:  # seed 0, another seed and the pooled fit
        plot_beta_sigmoid([f for _, f in chosen], out / "beta_lambda_realizations.png",
                          labels=[str(key) if key == POOLED else f"seed {key}"
                                  for key, _ in chosen])
        lines.append("![beta(lambda) of each realization, free fits]"
                     "(beta_lambda_realizations.png)")
    return lines


def _seed_table(plan: AuthorsPlan, fits: dict, sigmoids: dict[Any, dict[str, Any]],
                replicates: dict[Any, dict[str, Any]]) -> list[str]:
    """Every seed number with the free, fixed-beta and bounded fits side by side."""
    lines = ["", "## Seed numbers, three fits side by side", "",
             "| quantity | seed | free | beta fixed | bounded (paper) |", "|---|---|---|---|---|"]

    def row(label: str, name: str, lam: float, attr: str, seed: Any) -> None:
        f = fits.get(name, {}).get((lam, None, None), {})
        lines.append(f"| {label} | {seed} | {fit_cell(f.get('free'), attr)} | "
                     f"{fit_cell(f.get('fixed'), attr)} | {fit_cell(f.get('bounded'), attr)} |")

    for dim, name in ((2, "q2d"), (3, "q3d")):
        for lam in (0.0, math.inf):
            row(f"{dim}D β, λ→{_arrow(lam)}", name, lam, "beta", SEED[("beta", dim, lam)])
    for lam in (0.0, math.inf):
        row(f"C, λ→{_arrow(lam)} (E_sp = 139)", "q2d", lam, "C",
            _seed_c(0.15 if lam == 0 else 0.42))
    for E in plan.hard_E_sp:
        for lam in (0.0, math.inf):
            for attr in ("beta", "k"):
                row(f"hard {attr}, λ→{_arrow(lam)}, E_sp = {E:g}", hard_name(E), lam, attr,
                    SEED[(attr, 2, lam)])
            row(f"hard C, λ→{_arrow(lam)}, E_sp = {E:g}", hard_name(E), lam, "C",
                _seed_c(SEED[("C", 2, lam)]))
    for dim, name, seed in ((2, "q2d", 0.05), (3, "q3d", 0.07)):
        for kind, label in SIGMOID_KINDS.items():
            s = sigmoids[name].get(kind)
            lines.append(f"| {dim}D λ_c from {label} | {seed} | "
                         f"{fmt_lambda_c(s)} | | |")
        if dim == 2 and len(replicates) > 2:
            for kind, label in SIGMOID_KINDS.items():
                s = replicates[POOLED].get(kind)
                lines.append(f"| 2D λ_c, {len(replicates) - 1} realizations pooled ({label}) "
                             f"| {seed} | "
                             f"{fmt_lambda_c(s)} | | |")
    for theta in plan.theta_w:
        for kind, label in SIGMOID_KINDS.items():
            s = sigmoids[theta].get(kind)
            lines.append(f"| λ_c at θ_w = {theta:g}° ({label}) | falls to ~6e-3 (OCR "
                         f"'6x10^?') | {fmt_lambda_c(s)} "
                         "| | |")
    return lines


def _probe_table(plan: AuthorsPlan, fits: dict, results: dict) -> list[str]:
    """The friction limit of the study, its probes and the hard-particle limit."""
    lines = ["", "## What moves beta at the friction limit (lambda = 0)", "",
             "| run | free β | k | C | bounded β | CPU s |", "|---|---|---|---|---|---|"]
    labels = {**PROBE_LABELS, **{hard_name(E): f"hard-particle limit, E_sp = E_w = {E:g} "
                                  f"({len(plan.widths_hard)} widths, {plan.duration_hard:g} t0)"
                                  for E in plan.hard_E_sp}}
    for name in ("q2d", *(p for p in plan.probes if probe_dim(p) == 2),
                 *(hard_name(E) for E in plan.hard_E_sp), "q3d",
                 *(p for p in plan.probes if probe_dim(p) == 3)):
        key = (0.0, None, None)
        f = fits.get(name, {}).get(key, {})
        cost = results.get(name, {}).get(key, Series()).cpu
        lines.append(f"| {labels[name]} | {fit_cell(f.get('free'), 'beta')} | "
                     f"{fit_cell(f.get('free'), 'k')} | {fit_cell(f.get('free'), 'C')} | "
                     f"{fit_cell(f.get('bounded'), 'beta')} | {cost:.0f} |")
    return lines


#: The exponent of a viscous, pressure-driven flow through the orifice, beta = d: Stokes flow
#: through a slit in a thin wall (2D, Q = pi w^2 dp / (32 eta), Hasimoto 1958) or a circular
#: hole in a thin plate (3D, Sampson 1891: Q = w^3 dp / (24 eta)); Beverloo's is d - 1/2.
VISCOUS_BETA = {2: 2.0, 3: 3.0}


def _regime_table(results: dict) -> list[str]:
    """The friction limit fitted with beta fixed at Beverloo's d - 1/2 and at the viscous d:
    which law the measured Q(w) follows (chi^2/dof), and its k."""
    from grainflow.analysis.hopper import fit_beverloo

    lines = ["", "## The friction limit: Beverloo's exponent against a viscous flow's", "",
             "| series | β fixed | C | k | χ²/dof |", "|---|---|---|---|---|"]
    for name, dim in (("q2d", 2), ("friction_n3200", 2), ("q3d", 3)):
        ser = results.get(name, {}).get((0.0, None, None))
        if ser is None or len(ser.w) < 3:
            continue
        for label, beta in (("Beverloo", dim - 0.5), ("viscous", VISCOUS_BETA[dim])):
            try:
                f = fit_beverloo(ser.w, ser.Q, Q_err=ser.Q_err, beta=beta)
            except (ValueError, RuntimeError):
                continue
            lines.append(f"| {PROBE_LABELS[name]} | {beta:g} ({label}) | {fit_cell(f, 'C')} | "
                         f"{fit_cell(f, 'k')} | {_chi(f)} |")
    return lines


def _height_table(results: dict) -> list[str]:
    """Q at the friction limit with twice the grains over Q with the study's N, width by
    width. A Beverloo (inertial) flow does not depend on the pile's height; a viscous,
    pressure-driven one (Stokes flow through a slit, Q ~ rho g H w^2 / eta) doubles with it."""
    base = results.get("q2d", {}).get((0.0, None, None))
    tall = results.get("friction_n3200", {}).get((0.0, None, None))
    if not base or not tall:
        return []
    lines = ["", "## The friction limit against the pile's height", "",
             "| w | Q (N = 1600) | Q (N = 3200) | ratio |", "|---|---|---|---|"]
    rates = {w: (q, e) for w, q, e in zip(base.w, base.Q, base.Q_err)}
    for w, q, e in sorted(zip(tall.w, tall.Q, tall.Q_err)):
        if w in rates:
            q0, e0 = rates[w]
            ratio = q / q0
            lines.append(f"| {w:g} | {fmt(q0, e0)} | {fmt(q, e)} | "
                         f"{fmt(ratio, ratio * math.hypot(e / q, e0 / q0))} |")
    return lines


def _replicate_table(realizations: dict[tuple[float, int], Any]) -> list[str]:
    """The free beta of the 2D limits for every seed of :func:`realization_fits`, their mean
    and sample standard deviation: the spread between realizations, which the fits' errors do
    not hold."""
    lines = ["", "## Replicates of the 2D limits (free fits)", "",
             "| λ | seed | β | k | C |", "|---|---|---|---|---|"]
    for lam in (0.0, math.inf):
        betas = []
        for seed in sorted(seed for lam_r, seed in realizations if lam_r == lam):
            f = realizations[lam, seed].get("free")
            lines.append(f"| {_arrow(lam)} | {seed} | {fit_cell(f, 'beta')} | "
                         f"{fit_cell(f, 'k')} | {fit_cell(f, 'C')} |")
            if f is not None:
                betas.append(f.beta)
        if len(betas) >= 2:
            lines.append(f"| {_arrow(lam)} | mean ± s.d. ({len(betas)}) | "
                         f"{fmt(float(np.mean(betas)), float(np.std(betas, ddof=1)))} | | |")
    return lines


def _realization_table(realizations: dict[tuple[float, int], Any],
                       replicates: dict[Any, dict[str, Any]]) -> list[str]:
    """The free beta at every lambda for every realization of :func:`realization_fits` with
    their mean and sample standard deviation, then lambda_c of each realization
    (:func:`replicate_sigmoids`) and of all pooled."""
    betas: dict[float, dict[int, Any]] = {}
    for (lam, seed), three in realizations.items():
        betas.setdefault(lam, {})[seed] = three.get("free")
    seeds = sorted({seed for _, seed in realizations})
    lines = ["", "## beta(lambda) and lambda_c of each 2D realization (free fits)", "",
             "| λ | " + " | ".join(f"seed {s}" for s in seeds) + " | mean ± s.d. |",
             "|---|" + "---|" * (len(seeds) + 1)]
    for lam in sorted(betas):
        row = [betas[lam].get(s) for s in seeds]
        values = [f.beta for f in row if f is not None]
        spread = (fmt(float(np.mean(values)), float(np.std(values, ddof=1)))
                  if len(values) >= 2 else "")
        lines.append(f"| {lam:g} | " + " | ".join(fit_cell(f, "beta") for f in row)
                     + f" | {spread} |")
    for kind, label in SIGMOID_KINDS.items():
        cells = []
        for s in seeds:
            fit = replicates.get(s, {}).get(kind)
            cells.append(fmt_lambda_c(fit))
        per_seed = [replicates[s][kind].lambda_c for s in seeds
                    if kind in replicates.get(s, {}) and replicates[s][kind].resolved]
        spread = (fmt(float(np.mean(per_seed)), float(np.std(per_seed, ddof=1)))
                  if len(per_seed) >= 2 else "")
        lines.append(f"| λ_c ({label}) | " + " | ".join(cells) + f" | {spread} |")
    pooled = replicates.get(POOLED, {})
    lines += ["", "Pooled (one unweighted sigmoid through every realization's betas, its error "
              "from their scatter): " + "; ".join(
                  f"λ_c = {fmt_lambda_c(pooled[k])} ({label})"
                  for k, label in SIGMOID_KINDS.items() if k in pooled) + "."]
    return lines


def _key_cells(key: tuple) -> str:
    return " | ".join("" if v is None else f"{v:g}" for v in key)


def _fits_table(fits: dict) -> list[str]:
    lines = ["", "## Every fit", "",
             "| sweep | λ | E_sp | θ_w | fit | widths | C | k | β | χ²/dof |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, by_key in fits.items():
        for key, three in by_key.items():
            for kind in FITS:
                f = three.get(kind)
                if f is not None:
                    lines.append(f"| {name} | {_key_cells(key)} | {kind} | {f.x.min():g}–"
                                 f"{f.x.max():g} ({f.x.size}) | {fit_cell(f, 'C')} | "
                                 f"{fit_cell(f, 'k')} | {fit_cell(f, 'beta')} | {_chi(f)} |")
    return lines


def _rates_table(results: dict) -> list[str]:
    lines = ["", "## Measured flow rates (MSER steady window)", "",
             "| sweep | λ | E_sp | θ_w | w | Q | ± | CPU s (series) |",
             "|---|---|---|---|---|---|---|---|"]
    for name, series in results.items():
        for key, ser in sorted(series.items(), key=_key_order):
            for w, q, e in sorted(zip(ser.w, ser.Q, ser.Q_err)):
                lines.append(f"| {name} | {_key_cells(key)} | {w:g} | {q:.4g} | {e:.2g} | "
                             f"{ser.cpu:.0f} |")
    total = sum(s.cpu for series in results.values() for s in series.values())
    return lines + ["", f"Total run time of the points: {total:.0f} s.", ""]


def reproduce_authors(out_dir: str | Path, *, reduced: bool = True,
                      scheduler: str | None = None, n_workers: int | None = None,
                      progress: str = "auto") -> Path:
    """Run (or continue) the second-pass study into ``out_dir``; write ``out_dir/report.md``."""
    from grainflow.studies.points import run_sweeps

    plan = AUTHORS_REDUCED if reduced else AUTHORS_FULL
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results = {}
    specs = sweep_specs(plan)
    run_sweeps(specs, out, scheduler=scheduler, n_workers=n_workers, progress=progress)
    for name in specs:
        if name != REPLICAS:
            results[name] = collect(out / name, 0.0 if name in PROBES else None)
    dims = {"q2d": 2, "q3d": 3, "theta2d": 2, **{hard_name(E): 2 for E in plan.hard_E_sp},
            **{p: probe_dim(p) for p in plan.probes}}
    fits = {name: {key: three_fits(s, dims[name], key[0])
                   for key, s in sorted(series.items(), key=_key_order)}
            for name, series in results.items()}

    lines = [f"# Hopper study (seed 003), the authors' path — "
             f"{'reduced' if reduced else 'full'} version", "",
             "`[hopper] convention = \"authors\"` (docs/hopper_study.md, \"Second pass\"). "
             "Flow rates are area (2D) / volume (3D) rates in Q0 = sigma_avg^d/t0. The seed's C "
             "are as printed, then in our units (in brackets) read two ways: as grains per 1000 "
             f"code steps (the seed notes' reading: x {C_SCALE:.2f}) | with the paper's printed t0 = "
             f"sqrt(10) code time (x {C_SCALE_PRINTED_T0:.2f}). "
             "Fits: free; beta fixed as the paper fixed it; the paper's bounded fit (2D beta <= "
             "1.58, k >= 0.5; 3D 1.5 <= beta <= 2.5). Never rescaled.", ""]
    if plan.reductions:
        lines += ["Reductions relative to the full study:", ""]
        lines += [f"- {r}" for r in plan.reductions] + [""]
    sigmoids = _sigmoid_fits(plan, fits)
    replicas = (collect_series(out / REPLICAS, ("hopper.lam", "run.seed"))
                if plan.replicate_seeds else {})
    realizations = realization_fits(fits, replicas) if replicas else {}
    replicates = replicate_sigmoids(realizations) if replicas else {}
    lines += _figures(out, fits, results, dims, sigmoids, replicates)
    lines += _seed_table(plan, fits, sigmoids, replicates)
    lines += _probe_table(plan, fits, results)
    lines += _regime_table(results)
    lines += _height_table(results)
    if replicas:
        lines += _replicate_table(realizations)
        lines += _realization_table(realizations, replicates)
    lines += _fits_table(fits)
    lines += _rates_table(results)
    report = out / "report.md"
    report.write_text("\n".join(lines) + "\n")
    return report
