"""Figures of the hopper-flow analyses (SPEC A8), after seed 003 (Cheng et al., Soft Matter 18,
8071 (2022)): Beverloo fits (Fig. 2), beta(lambda) (Fig. 4), centre-line velocity profiles
(Fig. 5) and the flow-rate record with its steady window.

Each function takes result objects of :mod:`grainflow.analysis.hopper` /
:mod:`grainflow.analysis.coarse_grain` and a path, writes a PNG and returns the path. Figures
are drawn on an Agg canvas without pyplot, so no global backend is changed. Data are expected
in the seed's units (lengths in sigma_avg, times in t0 = sqrt(sigma_avg/g), flow rates in
Q0 = sigma_avg^d / t0) unless scale arguments say otherwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps

from grainflow.analysis.coarse_grain import VelocityProfile
from grainflow.analysis.hopper import BeverlooFit, FlowRate, SigmoidFit
from grainflow.plotting.figures import new_figure, save_figure

_MARKERS = "os^Dv<>p*hX"


def _as_list(items: object) -> list:
    return list(items) if isinstance(items, Sequence) else [items]


def _labels(labels: Sequence[str] | None, n: int, default: str) -> list[str]:
    if labels is None:
        return [default.format(i + 1) for i in range(n)] if n > 1 else [""]
    if len(labels) != n:
        raise ValueError(f"labels: expected {n} labels, got {len(labels)}")
    return list(labels)


def _q_unit(dim: int) -> str:
    return rf"$Q_0=\sigma_{{avg}}^{dim}/t_0$"


def plot_beverloo(
    fits: BeverlooFit | Sequence[BeverlooFit],
    path: str | Path,
    *,
    dim: int = 2,
    labels: Sequence[str] | None = None,
) -> Path:
    """Q vs w/sigma_avg with Beverloo fits, and the log-log collapse (seed Fig. 2 a/b, 2 c/d).

    Left: Q/Q0 against w/sigma_avg with error bars and the fitted Q = C (w/sigma_avg - k)^beta.
    Right: Q/C against w/sigma_avg - k on log axes, with reference slopes d - 1/2 (dotted) and
    d - 3/2 (dashed), where curves of one exponent collapse onto a line.

    Parameters
    ----------
    fits : one or several :class:`~grainflow.analysis.hopper.BeverlooFit` (they carry the data).
    path : output PNG path.
    dim : spatial dimension d (axis units and reference slopes).
    labels : one legend label per fit.
    """
    fit_list = _as_list(fits)
    names = _labels(labels, len(fit_list), "series {}")
    fig = new_figure(2)
    ax_lin, ax_log = fig.subplots(1, 2)
    colours = colormaps["tab10"].colors
    x_lo = []
    for i, (fit, name) in enumerate(zip(fit_list, names, strict=True)):
        colour, marker = colours[i % 10], _MARKERS[i % len(_MARKERS)]
        err = None if np.all(np.isnan(fit.Q_err)) else fit.Q_err
        params = (
            rf"$C={fit.C:.3g}\pm{fit.C_err:.2g}$, $k={fit.k:.3g}\pm{fit.k_err:.2g}$, "
            + (rf"$\beta={fit.beta:.3g}$ (fixed)" if fit.beta_fixed
               else rf"$\beta={fit.beta:.3g}\pm{fit.beta_err:.2g}$")
        )
        label = f"{name}: {params}" if name else params
        ax_lin.errorbar(fit.x, fit.Q, yerr=err, fmt=marker, color=colour, ms=5, capsize=2,
                        mfc="none", label=label)
        x_curve = np.linspace(max(fit.k, 0.0) + 1e-3, fit.x.max() * 1.03, 300)
        ax_lin.plot(x_curve, fit.predict(x_curve), "-", color=colour, lw=1.2)
        excess = fit.x - fit.k
        ax_log.errorbar(excess, fit.Q / fit.C, yerr=None if err is None else err / fit.C,
                        fmt=marker, color=colour, ms=5, capsize=2, mfc="none", label=name or None)
        x_lo.append(excess.min())
    ax_lin.set_xlim(left=0)
    ax_lin.set_ylim(bottom=0)
    ax_lin.set_xlabel(r"$w/\sigma_{avg}$")
    ax_lin.set_ylabel(rf"$Q/Q_0$   ({_q_unit(dim)})")
    ax_lin.legend(fontsize=7, loc="upper left", frameon=False)
    ax_lin.set_title("(a) flow rate and Beverloo fit", fontsize=10)

    x_ref = np.geomspace(min(x_lo) * 0.8, max(f.x.max() - f.k for f in fit_list) * 1.2, 50)
    ax_log.plot(x_ref, x_ref ** (dim - 0.5), ":", color="0.3", lw=1,
                label=rf"slope $d-1/2={dim - 0.5:g}$")
    ax_log.plot(x_ref, x_ref ** (dim - 1.5), "--", color="0.3", lw=1,
                label=rf"slope $d-3/2={dim - 1.5:g}$")
    ax_log.set_xscale("log")
    ax_log.set_yscale("log")
    ax_log.set_xlabel(r"$w/\sigma_{avg} - k$")
    ax_log.set_ylabel(r"$Q/C$")
    ax_log.legend(fontsize=7, frameon=False)
    ax_log.set_title("(b) collapse", fontsize=10)
    return save_figure(fig, path)


def plot_beta_sigmoid(
    fits: SigmoidFit | Sequence[SigmoidFit],
    path: str | Path,
    *,
    labels: Sequence[str] | None = None,
) -> Path:
    """beta against lambda = zeta/mu on a log axis with the eq. (14) sigmoid (seed Fig. 4).

    Dashed lines mark the limits d - 1/2 and d - 3/2 (or the fit's own ``limits``), a dotted
    line the midpoint d - 1 (halfway between them), and short ticks the fitted lambda_c.
    """
    fit_list = _as_list(fits)
    names = _labels(labels, len(fit_list), "series {}")
    fig = new_figure(1, width=5.0, height=3.8)
    ax = fig.subplots()
    colours = colormaps["tab10"].colors
    lam_all = np.concatenate([f.lam for f in fit_list])
    lam_curve = np.geomspace(lam_all.min() / 10, lam_all.max() * 10, 400)
    for i, (fit, name) in enumerate(zip(fit_list, names, strict=True)):
        colour, marker = colours[i % 10], _MARKERS[i % len(_MARKERS)]
        err = None if np.all(np.isnan(fit.beta_err)) else fit.beta_err
        if fit.resolved:
            label = (rf"$\lambda_c={fit.lambda_c:.2g}\pm{fit.lambda_c_err:.1g}$, "
                     rf"$b={fit.b:.2g}\pm{fit.b_err:.1g}$")
        else:
            low, high = fit.bracket
            label = rf"a step at $\lambda$ = {low:g}-{high:g}: $\lambda_c$ not resolved"
        ax.errorbar(fit.lam, fit.beta, yerr=err, fmt=marker, color=colour, ms=5, capsize=2,
                    mfc="none", label=f"{name}: {label}" if name else label)
        ax.plot(lam_curve, fit.predict(lam_curve), "-", color=colour, lw=1.2)
        ax.axvline(fit.lambda_c, ymin=0.0, ymax=0.06, color=colour, lw=1.5)
    for levels in sorted({f.levels for f in fit_list}):
        for level, style in zip(levels, ("--", ":", "--")):
            ax.axhline(level, ls=style, color="0.5", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel(r"$\lambda = \zeta/\mu$")
    ax.set_ylabel(r"Beverloo exponent $\beta$")
    ax.legend(fontsize=7, frameon=False, loc="lower left")
    return save_figure(fig, path)


def plot_velocity_profiles(
    profiles: Sequence[VelocityProfile],
    widths: Sequence[float],
    path: str | Path,
    *,
    quantity: str = "velocity",
    scaled: bool = False,
    sigma_avg: float = 1.0,
    t0: float = 1.0,
) -> Path:
    """Centre-line v_g(h) above the orifice for several orifice widths (seed Fig. 5).

    Curves run from blue (smallest w) to red (largest), as in the seed.

    Parameters
    ----------
    profiles : one :class:`~grainflow.analysis.coarse_grain.VelocityProfile` per width.
    widths : orifice widths w, same length units as the heights.
    path : output PNG path.
    quantity : "velocity" (density-normalised, sigma_avg/t0) or "flux" (the seed's literal
        v_g = sum_i v_i phi, units sigma_avg^(1-d)/t0).
    scaled : plot v / sqrt(g w) against h / w (free-fall scaling, g = sigma_avg/t0^2).
    sigma_avg, t0 : the units of the data, to express axes in sigma_avg and t0.
    """
    if len(profiles) == 0 or len(profiles) != len(widths):
        raise ValueError("profiles/widths: need one orifice width per profile (at least one)")
    if quantity not in ("velocity", "flux"):
        raise ValueError(f"quantity: choose 'velocity' or 'flux', got {quantity!r}")
    fig = new_figure(1, width=5.0, height=3.8)
    ax = fig.subplots()
    order = np.argsort(widths)
    cmap = colormaps["coolwarm"]
    g = sigma_avg / t0**2
    dim = profiles[0].dim
    for rank, idx in enumerate(order):
        prof, w = profiles[idx], float(widths[idx])
        v = prof.velocity if quantity == "velocity" else prof.flux
        if scaled:
            x, y = prof.heights / w, v / np.sqrt(g * w)
        else:
            x, y = prof.heights / sigma_avg, v / (sigma_avg / t0)
            if quantity == "flux":
                y = y * sigma_avg**dim
        colour = cmap(rank / max(len(order) - 1, 1))
        ax.plot(x, y, "-", color=colour, lw=1.5, label=rf"$w/\sigma_{{avg}}={w / sigma_avg:.3g}$")
    symbol = r"v_g" if quantity == "velocity" else r"\sum_i v_{g,i}\,\phi(\mathbf{r}-\mathbf{r}_i)"
    if scaled:
        ax.set_xlabel(r"$h/w$")
        ax.set_ylabel(rf"${symbol}/\sqrt{{g w}}$")
    else:
        ax.set_xlabel(r"$h/\sigma_{avg}$")
        unit = (r"\sigma_{avg}/t_0" if quantity == "velocity"
                else rf"\sigma_{{avg}}^{{{1 - dim}}}/t_0")
        ax.set_ylabel(rf"${symbol}\;[{unit}]$")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=7, frameon=False)
    what = ("density-normalised" if quantity == "velocity"
            else "seed's $v_g$, not divided by density")
    ax.set_title(f"centre-line speed along gravity ({what})", fontsize=9)
    return save_figure(fig, path)


def plot_flow_rate_timeseries(flow: FlowRate, path: str | Path, *, t0: float = 1.0) -> Path:
    """Cumulative count N(t) and local rate with the detected steady window shaded.

    Left: N(t) of all crossings, the steady window [t_start, t_end] shaded and the line of
    slope dN/dt through the window. Right: the binned local rate the MSER rule ran on, with the
    steady rate and its error band.
    """
    fig = new_figure(2)
    ax_n, ax_r = fig.subplots(1, 2)
    t = flow.times / t0
    t_start, t_end = flow.t_start / t0, flow.t_end / t0
    counts = np.arange(1, t.size + 1)
    for ax in (ax_n, ax_r):
        ax.axvspan(flow.t_begin / t0, t_start, color="0.6", alpha=0.25, lw=0,
                   label="transient (cut)")
        ax.axvspan(t_start, t_end, color="tab:green", alpha=0.12, lw=0, label="steady window")
        ax.axvline(t_start, color="tab:green", lw=1)
    ax_n.step(t, counts, where="post", color="k", lw=1, label="crossings")
    n_at_start = flow.n_transient
    rate = flow.number_rate * t0
    ax_n.plot([t_start, t_end], [n_at_start, n_at_start + rate * (t_end - t_start)], "--",
              color="tab:red", lw=1.2,
              label=rf"$dN/dt = {rate:.4g}\pm{flow.number_rate_err * t0:.2g}\;t_0^{{-1}}$")
    ax_n.set_xlabel(r"$t/t_0$")
    ax_n.set_ylabel(r"cumulative crossings $N(t)$")
    ax_n.set_xlim(flow.t_begin / t0, t_end)
    ax_n.set_ylim(bottom=0)
    ax_n.legend(fontsize=7, frameon=False, loc="upper left")
    ax_n.set_title("(a) orifice crossings", fontsize=10)

    ax_r.step(flow.rate_bin_centres / t0, flow.local_rate * t0, where="mid", color="k", lw=1,
              label="binned rate")
    err = flow.number_rate_err * t0
    ax_r.axhspan(rate - err, rate + err, color="tab:red", alpha=0.25, lw=0)
    ax_r.axhline(rate, color="tab:red", lw=1, ls="--", label="steady mean ± s.e.")
    ax_r.set_xlabel(r"$t/t_0$")
    ax_r.set_ylabel(r"local rate $dN/dt\;[t_0^{-1}]$")
    ax_r.set_xlim(flow.t_begin / t0, t_end)
    ax_r.set_ylim(bottom=0)
    ax_r.legend(fontsize=7, frameon=False, loc="lower right")
    ax_r.set_title("(b) MSER transient cut", fontsize=10)
    return save_figure(fig, path)


def plot_offsets(points: dict[float, Sequence[tuple[str, BeverlooFit]]],
                 path: str | Path) -> Path:
    """The offset k and exponent beta of each model's Beverloo fit at each lambda limit (the
    DP study's version of seed Fig. 7: how k moves with deformability and roughness while beta
    should not).

    ``points``: lambda -> [(model label, fit)]; one marker series per lambda. Reference lines:
    beta = 3/2 and 1/2 (the seed's 2D exponents at lambda -> 0 and inf).
    """
    labels: list[str] = []
    for series in points.values():
        labels += [name for name, _ in series if name not in labels]
    if not labels:
        raise ValueError("points: no fits to draw")
    fig = new_figure(2, width=4.8, height=3.8)
    ax_k, ax_b = fig.subplots(1, 2, sharey=False)
    colours = colormaps["tab10"].colors
    y = np.arange(len(labels))
    for i, (lam, series) in enumerate(sorted(points.items())):
        name = r"$\lambda\to0$" if lam == 0 else (r"$\lambda\to\infty$" if np.isinf(lam)
                                                  else rf"$\lambda={lam:g}$")
        rows = [labels.index(label) + 0.12 * (i - 0.5) for label, _ in series]
        fits = [f for _, f in series]
        for ax, attr in ((ax_k, "k"), (ax_b, "beta")):
            ax.errorbar([getattr(f, attr) for f in fits], rows,
                        xerr=[getattr(f, f"{attr}_err") for f in fits], fmt=_MARKERS[i],
                        color=colours[i], ms=5, capsize=2, mfc="none", label=name)
    for ax in (ax_k, ax_b):
        ax.set_yticks(y, labels, fontsize=7)
        ax.invert_yaxis()
    ax_b.axvline(1.5, ls=":", color="0.3", lw=1)
    ax_b.axvline(0.5, ls="--", color="0.3", lw=1)
    ax_k.set_xlabel(r"offset $k$ ($w/\sigma_{avg}$ at $Q = 0$)")
    ax_b.set_xlabel(r"exponent $\beta$")
    ax_k.legend(fontsize=7, frameon=False)
    ax_k.set_title("(a) offset k", fontsize=10)
    ax_b.set_title(r"(b) exponent $\beta$ (seed: 3/2 and 1/2)", fontsize=10)
    return save_figure(fig, path)
