"""Figures of the rheology next to a granular jet's target
(:mod:`grainflow.analysis.jet.rheology`), after seed 002 (H. Sano, PhD thesis (2013)):
stress profiles (Figs. 5.3, 6.4), velocity and temperature profiles (Figs. 5.4, 6.3), the
equation of state against Garzo-Dufty (Figs. 5.5, 5.6), mu* against I with the linear law
(Fig. 5.7), phi against I_T and I_s with the divergence fits (Fig. 6.5) and mu* against I_s
with the friction laws (Fig. 6.7).

Each function takes :class:`~grainflow.analysis.jet.rheology.LayerFields` (or
:class:`~grainflow.analysis.jet.rheology.KineticTheoryCheck`) results and a path, writes a PNG
and returns the path. ``labels`` names each layer; layers with the same label share a colour
and a legend entry (e.g. the (a) and (b) layers of several phi_0 in Figs. 6.5 and 6.7). Error
bars are the layers' standard errors. Units: d, m, t_0 = d/u0.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.ticker import NullFormatter

from grainflow.analysis.jet.rheology import KineticTheoryCheck, LayerFields
from grainflow.analysis.rheology import DivergenceFit, MuLinearFit, MuOfIFit, MuPowerLawFit
from grainflow.plotting.cg_plots import fit_parameters_text
from grainflow.plotting.figures import new_figure, save_figure

__all__ = ["plot_divergence_2d", "plot_friction_2d", "plot_friction_3d", "plot_pressure_ratio",
           "plot_stress_profiles", "plot_velocity_profiles"]

_MARKERS = "os^Dv<>p*hX"
_COLOURS = colormaps["tab10"].colors

_FIT_NAMES = {
    MuOfIFit: r"$\mu_s + (\mu_{max}-\mu_s)/(1+I_0/I_s)$",
    MuPowerLawFit: r"$\mu_s + b I_s^\beta$",
    MuLinearFit: r"$\mu^* = a I$",
}


# --- helpers ---------------------------------------------------------------------------------

def _layers(layers: LayerFields | Sequence[LayerFields], arg: str = "layers"
            ) -> list[LayerFields]:
    items = [layers] if isinstance(layers, (LayerFields, KineticTheoryCheck)) else list(layers)
    if not items:
        raise ValueError(f"{arg}: give at least one")
    return items


def _groups(n: int, labels: Sequence[str] | None, default: Sequence[str]) -> list[str]:
    if labels is None:
        return list(default)
    if len(labels) != n:
        raise ValueError(f"labels: expected {n} labels, got {len(labels)}")
    return [str(x) for x in labels]


def _style(names: list[str]) -> dict[str, tuple[str, tuple]]:
    """A marker and a colour per distinct label, in order of appearance."""
    out: dict[str, tuple[str, tuple]] = {}
    for name in names:
        if name not in out:
            k = len(out)
            out[name] = (_MARKERS[k % len(_MARKERS)], _COLOURS[k % 10])
    return out


def _errorbar(ax: Axes, x, y, err, marker, colour, label, seen: set[str]) -> None:
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    e = None if err is None else np.asarray(err, dtype=float)
    if e is not None and not np.any(np.isfinite(e)):
        e = None
    elif e is not None:
        e = np.where(np.isfinite(e), e, 0.0)
    ax.errorbar(x, y, yerr=e, fmt=marker, color=colour, ms=4, capsize=2, mfc="none",
                label=None if label in seen else label)
    seen.add(label)


def _positive_range(values: list[np.ndarray], log: bool) -> np.ndarray:
    x = np.concatenate([np.ravel(v) for v in values])
    x = x[np.isfinite(x) & ((x > 0) if log else True)]
    if x.size == 0:
        return np.array([])
    if log:
        return np.geomspace(x.min() / 1.5, x.max() * 1.5, 300)
    return np.linspace(0.0, x.max() * 1.1, 300)


def _tex(name: str) -> str:
    return r"\theta" if name == "theta" else name


def _across(layer: LayerFields) -> str:
    return "r" if layer.dim == 3 else "y"


def _stress_unit(dim: int) -> str:
    return r"m\,t_0^{-2}" if dim == 2 else r"m\,d^{-1}\,t_0^{-2}"


# --- profiles --------------------------------------------------------------------------------

def plot_stress_profiles(layers: LayerFields | Sequence[LayerFields], path: str | Path, *,
                         components: Sequence[tuple[int, int]] | None = None,
                         titles: Sequence[str] | None = None) -> Path:
    """Stress components against r / R_tar (Fig. 5.3) or y / R_tar (Fig. 6.4), one panel per
    layer. ``components``: index pairs into (r, theta, z) or (x, y); default the diagonal and
    both shear components (rr, thth, zz, rz, zr; xx, yy, xy, yx)."""
    items = _layers(layers)
    names = _groups(len(items), titles, [f"{lay.layer[0]:g} < {'z' if lay.dim == 3 else 'x'}"
                                         f" < {lay.layer[1]:g}" for lay in items])
    fig = new_figure(len(items), width=4.4, height=3.6)
    axes = np.atleast_1d(fig.subplots(1, len(items)))
    for ax, lay, title in zip(axes, items, names):
        comps = components
        if comps is None:
            comps = [(0, 0), (1, 1), (2, 2), (0, 2), (2, 0)] if lay.dim == 3 else \
                [(0, 0), (1, 1), (0, 1), (1, 0)]
        for k, (a, b) in enumerate(comps):
            if not (0 <= a < lay.dim and 0 <= b < lay.dim):
                raise ValueError(f"components: ({a}, {b}) is not a component of a "
                                 f"{lay.dim}D tensor")
            sub = _tex(lay.components[a]) + _tex(lay.components[b])
            ax.errorbar(lay.scaled_centres, lay.sigma[:, a, b], yerr=_clean(
                lay.errors["sigma"][:, a, b]), fmt=_MARKERS[k % len(_MARKERS)] + "-",
                color=_COLOURS[k % 10], ms=4, capsize=2, mfc="none", lw=0.8,
                label=rf"$\sigma_{{{sub}}}$")
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_xlabel(f"${_across(lay)}/R_{{tar}}$")
        ax.set_ylabel(rf"$\sigma_{{\alpha\beta}}$ [${_stress_unit(lay.dim)}$]")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


def _clean(err: np.ndarray) -> np.ndarray | None:
    e = np.asarray(err, dtype=float)
    return None if not np.any(np.isfinite(e)) else np.where(np.isfinite(e), e, 0.0)


def plot_velocity_profiles(layers: LayerFields | Sequence[LayerFields], path: str | Path, *,
                           labels: Sequence[str] | None = None) -> Path:
    """Mean velocity along the target (v_r in 3D, v_y in 2D) and sqrt(T_g/m) against
    r / R_tar or y / R_tar (Figs. 5.4 and 6.3 (i)), and phi (Fig. 6.3 (ii)), one curve per
    layer."""
    items = _layers(layers)
    names = _groups(len(items), labels, [f"layer {lay.layer[0]:g}-{lay.layer[1]:g}"
                                         for lay in items])
    style = _style(names)
    fig = new_figure(3, width=3.8, height=3.4)
    ax_v, ax_t, ax_phi = fig.subplots(1, 3)
    seen_v: set[str] = set()
    seen_t: set[str] = set()
    seen_p: set[str] = set()
    for lay, name in zip(items, names):
        marker, colour = style[name]
        along = 0 if lay.dim == 3 else 1
        x = lay.scaled_centres
        _errorbar(ax_v, x, lay.velocity[:, along], lay.errors["velocity"][:, along], marker,
                  colour, name, seen_v)
        with np.errstate(invalid="ignore"):
            root = np.sqrt(lay.T_g / lay.mass)
            root_err = 0.5 * lay.errors["T_g"] / (lay.mass * np.where(root > 0, root, np.nan))
        _errorbar(ax_t, x, root, root_err, marker, colour, name, seen_t)
        _errorbar(ax_phi, x, lay.phi, lay.errors["phi"], marker, colour, name, seen_p)
    first = items[0]
    comp = "r" if first.dim == 3 else "y"
    for ax in (ax_v, ax_t, ax_phi):
        ax.set_xlabel(f"${_across(first)}/R_{{tar}}$")
        ax.legend(fontsize=7, frameon=False)
    ax_v.set_ylabel(rf"$\bar v_{comp}$ [$d\,t_0^{{-1}}$]")
    ax_t.set_ylabel(r"$\sqrt{T_g/m}$ [$d\,t_0^{-1}$]")
    ax_phi.set_ylabel(r"$\phi$")
    return save_figure(fig, path)


# --- equation of state -----------------------------------------------------------------------

def plot_pressure_ratio(checks: KineticTheoryCheck | Sequence[KineticTheoryCheck],
                        path: str | Path, *, labels: Sequence[str] | None = None,
                        per_direction: bool = False) -> Path:
    """P / (n T_g) against phi with the Garzo-Dufty curve 1 + 2^(D-2)(1 + e) phi chi, eq. (5.2)
    (Fig. 5.5); with ``per_direction`` a second panel with sigma_aa / (n T_a) per component
    (Fig. 5.6). The curve is that of the first check's e, dim, phi_f and phi_c."""
    items = _layers(checks, "checks")
    for c in items:
        if not isinstance(c, KineticTheoryCheck):
            raise ValueError(f"checks: expected KineticTheoryCheck results, got "
                             f"{type(c).__name__}")
    names = _groups(len(items), labels, [f"set {k + 1}" for k in range(len(items))])
    style = _style(names)
    fig = new_figure(2 if per_direction else 1, width=4.6, height=3.8)
    axes = np.atleast_1d(fig.subplots(1, 2 if per_direction else 1))
    seen: set[str] = set()
    for check, name in zip(items, names):
        marker, colour = style[name]
        _errorbar(axes[0], check.phi, check.measured, check.measured_err, marker, colour, name,
                  seen)
    first = items[0]
    phi_all = np.concatenate([np.ravel(c.phi) for c in items])
    phi_all = phi_all[np.isfinite(phi_all)]
    top = max(float(phi_all.max()) * 1.05 if phi_all.size else 0.6, 0.05)
    curve = np.linspace(0.0, top, 300)
    theory = first.curve(curve)
    eq = "2" if first.dim == 3 else ""
    # the curve diverges at phi_c: the axis is scaled to the data and the curve at the data
    shown = [np.ravel(c.measured) for c in items] + [np.ravel(c.theory) for c in items]
    if per_direction:
        shown += [np.ravel(c.measured_components) for c in items]
    shown_all = np.concatenate(shown)
    shown_all = shown_all[np.isfinite(shown_all)]
    top_y = 1.15 * float(shown_all.max()) if shown_all.size else None
    for ax in axes:
        ax.plot(curve, theory, "-", color="k", lw=1.2,
                label=rf"$1 + {eq}(1+e)\phi\chi$, $e = {first.restitution:g}$")
        ax.set_xlabel(r"$\phi$")
        if top_y is not None and top_y > 1.0:
            ax.set_ylim(0.0, top_y)
    axes[0].set_ylabel(r"$P/(n T_g)$")
    axes[0].legend(fontsize=7, frameon=False)
    if per_direction:
        ax = axes[1]
        seen_c: set[str] = set()
        for check in items:
            for k, comp in enumerate(check.components):
                _errorbar(ax, check.phi, check.measured_components[:, k],
                          check.measured_components_err[:, k], _MARKERS[k % len(_MARKERS)],
                          _COLOURS[(k + 1) % 10], rf"$P_{{{_tex(comp)}}}/(n T_{{{_tex(comp)}}})$",
                          seen_c)
        ax.set_ylabel(r"$P_\alpha/(n T_\alpha)$")
        ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


# --- friction and divergence -----------------------------------------------------------------

def _scatter(ax: Axes, items: list[LayerFields], names: list[str], x: str, y: str) -> None:
    style = _style(names)
    seen: set[str] = set()
    for lay, name in zip(items, names):
        marker, colour = style[name]
        _errorbar(ax, lay.value(x), lay.value(y), lay.error(y), marker, colour, name, seen)


def plot_friction_3d(layers: LayerFields | Sequence[LayerFields], path: str | Path, *,
                     fit: MuLinearFit | None = None, labels: Sequence[str] | None = None
                     ) -> Path:
    """mu* (folded by the sign of D_rz) against I on linear axes with the fit mu* = a I
    (Fig. 5.7)."""
    items = _layers(layers)
    if fit is not None and not isinstance(fit, MuLinearFit):
        raise ValueError(f"fit: expected a MuLinearFit, got {type(fit).__name__}")
    names = _groups(len(items), labels, ["data"] * len(items))
    fig = new_figure(1, width=5.0, height=4.0)
    ax = fig.subplots()
    _scatter(ax, items, names, "I", "mu_folded")
    if fit is not None:
        curve = _positive_range([lay.I for lay in items], False)
        ax.plot(curve, fit.predict(curve), "-", color="k", lw=1.2,
                label=f"{_FIT_NAMES[MuLinearFit]}, {fit_parameters_text(fit)}")
    ax.set_xlabel(r"$I = |D_{rz}|\sqrt{m/(P d)}$")
    ax.set_ylabel(r"$\mu^* = -\sigma_{rz}/P$")
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    return save_figure(fig, path)


def plot_divergence_2d(layers: LayerFields | Sequence[LayerFields], path: str | Path, *,
                       fits: Mapping[str, DivergenceFit] | None = None,
                       labels: Sequence[str] | None = None) -> Path:
    """phi against I_T (left, eq. 6.2) and I_s (right, eq. 6.3) on log axes with the fits
    ``fits["I_T"]`` and ``fits["I"]`` (Fig. 6.5). On the I_s panel a ring marks the cells
    that flow mostly by extension (shear fraction |D_xy| / D_dev < 1/2: D_xy is not their
    rate of deformation)."""
    items = _layers(layers)
    fits = {} if fits is None else dict(fits)
    for key, fit in fits.items():
        if key not in ("I", "I_T") or not isinstance(fit, DivergenceFit):
            raise ValueError("fits: expected {'I': DivergenceFit, 'I_T': DivergenceFit}, got "
                             f"{key!r}: {type(fit).__name__}")
    names = _groups(len(items), labels, [f"layer {lay.layer[0]:g}-{lay.layer[1]:g}"
                                         for lay in items])
    fig = new_figure(2, width=4.6, height=3.8)
    axes = fig.subplots(1, 2)
    for ax, key, symbol in ((axes[0], "I_T", "I_T"), (axes[1], "I", "I_s")):
        _scatter(ax, items, names, key, "phi")
        if key == "I":
            _mark_extension(ax, items)
        fit = fits.get(key)
        if fit is not None:
            curve = _positive_range([lay.value(key) for lay in items], True)
            if curve.size:
                limits = ax.get_ylim()
                ax.plot(curve, fit.predict(curve), "-", color="k", lw=1.2,
                        label=rf"$\phi_c - a\,{symbol}^{{2/\alpha}}$"
                        f"\n{fit_parameters_text(fit)}")
                ax.axhline(fit.phi_c, ls=":", color="k", lw=0.8)
                ax.set_ylim(min(limits[0], fit.phi_c), max(limits[1], fit.phi_c) + 0.01)
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(f"${symbol}$")
        ax.set_ylabel(r"$\phi$")
        ax.legend(fontsize=7, frameon=False, loc="lower left")
    return save_figure(fig, path)


def _mark_extension(ax, items: Sequence[LayerFields]) -> None:
    """Rings around the cells whose shear fraction is below 1/2 (layers that have one)."""
    x, y = [], []
    for lay in items:
        if "shear_fraction" not in lay.values:
            continue
        I, phi = np.asarray(lay.value("I")), np.asarray(lay.value("phi"))  # noqa: E741
        low = (np.asarray(lay.values["shear_fraction"]) < 0.5) & (I > 0) & np.isfinite(phi)
        x.append(I[low])
        y.append(phi[low])
    if x and np.concatenate(x).size:
        ax.plot(np.concatenate(x), np.concatenate(y), "o", mfc="none", mec="k", ms=10,
                mew=0.8, label="shear fraction < 1/2 (extension)")


def plot_friction_2d(layers: LayerFields | Sequence[LayerFields], path: str | Path, *,
                     fits: MuOfIFit | MuPowerLawFit | Sequence = (),
                     labels: Sequence[str] | None = None, xlog: bool = True) -> Path:
    """mu* (folded by the sign of D_xy) against I_s with the friction laws eq. (2.57)
    (printed as 6.9) and eq. (6.10) (Fig. 6.7)."""
    items = _layers(layers)
    fit_list = [fits] if isinstance(fits, (MuOfIFit, MuPowerLawFit)) else list(fits)
    for fit in fit_list:
        if not isinstance(fit, (MuOfIFit, MuPowerLawFit)):
            raise ValueError(f"fits: expected MuOfIFit or MuPowerLawFit results, got "
                             f"{type(fit).__name__}")
    names = _groups(len(items), labels, [f"layer {lay.layer[0]:g}-{lay.layer[1]:g}"
                                         for lay in items])
    fig = new_figure(1, width=5.2, height=4.0)
    ax = fig.subplots()
    _scatter(ax, items, names, "I", "mu_folded")
    curve = _positive_range([lay.I for lay in items], xlog)
    if curve.size:
        limits = ax.get_ylim()
        for k, fit in enumerate(fit_list):
            ax.plot(curve, fit.predict(curve), ["-", "--", ":"][k % 3], color="k", lw=1.2,
                    label=f"{_FIT_NAMES[type(fit)]}\n{fit_parameters_text(fit)}")
        ax.set_ylim(limits)
    if xlog:
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(r"$I_s = |D_{xy}|\sqrt{m/P}$")
    ax.set_ylabel(r"$\mu^* = -\sigma_{xy}/P$")
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    return save_figure(fig, path)
