"""Figures of the jet analyses (:mod:`grainflow.analysis.jet`), after seed 002 chapter 4
(H. Sano, PhD thesis (2013)): the scattering angle psi0 against X = D_tar / D_jet with the
interpolation fit and its asymptotes (Fig. 4.2), the azimuthal flux dN/dphi with its cos 2phi
Fourier fit, and v2 against the eccentricity (Fig. 4.3) with the experimental point of Cheng
et al.

Each function takes data and a path, writes a PNG and returns the path. Figures are drawn on an
Agg canvas without pyplot (:mod:`grainflow.plotting.figures`). Angles are in radians.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import pi
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.jet import (SEED_PSI0_FIT, SEED_V2, Anisotropy, AzimuthalFlux, Psi0Fit,
                                    psi0_interpolation)
from grainflow.plotting.figures import new_figure, save_figure

__all__ = ["plot_azimuthal_flux", "plot_psi0", "plot_v2_vs_eccentricity"]


def _series(x_name: str, x: ArrayLike, y_name: str, y: ArrayLike, err_name: str,
            err: ArrayLike | None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Validated 1-D (x, y, err); ValueError naming the offending argument."""
    xs = np.asarray(x, dtype=float)
    ys = np.asarray(y, dtype=float)
    if xs.ndim != 1 or xs.size == 0:
        raise ValueError(f"{x_name}: expected a non-empty 1-D array, got shape {xs.shape}")
    if ys.shape != xs.shape:
        raise ValueError(f"{y_name}: expected shape {xs.shape} like {x_name}, got {ys.shape}")
    if err is None:
        return xs, ys, None
    es = np.asarray(err, dtype=float)
    if es.shape != xs.shape:
        raise ValueError(f"{err_name}: expected shape {xs.shape} like {x_name}, got {es.shape}")
    return xs, ys, es


def plot_psi0(
    X: ArrayLike,
    psi0: ArrayLike,
    path: str | Path,
    *,
    psi0_err: ArrayLike | None = None,
    fit: Psi0Fit | None = None,
    seed: bool = True,
) -> Path:
    """Scattering angle psi0 [rad] against X = D_tar / D_jet, like Fig. 4.2.

    Parameters
    ----------
    X, psi0 : (M,) ratios (> 0) and angles.
    path : output PNG path.
    psi0_err : (M,) standard errors (error bars).
    fit : a :func:`~grainflow.analysis.jet.fit_psi0` result: the interpolation function
        (solid) with its parameters in the legend, and the asymptotes psi0 = C0 (X >> 1) and
        psi0 = C1 X + C2 (X << 1), dotted.
    seed : also draw the thesis's curve (C0, C1, C2) = (1.68, 0.563, 0.554), dashed grey.
    """
    x, y, err = _series("X", X, "psi0", psi0, "psi0_err", psi0_err)
    if np.any(x <= 0):
        raise ValueError("X: values must be > 0")
    if fit is not None and not isinstance(fit, Psi0Fit):
        raise ValueError(f"fit: expected a Psi0Fit, got {type(fit).__name__}")
    fig = new_figure(1, width=5.2, height=4.0)
    ax = fig.subplots()
    ax.errorbar(x, y, yerr=err, fmt="o", color="k", ms=4, capsize=2, mfc="none", label="data")
    curve = np.linspace(0.0, float(x.max()) * 1.1, 300)
    if seed:
        ax.plot(curve, psi0_interpolation(curve, *SEED_PSI0_FIT), "--", color="0.5", lw=1,
                label="thesis: $C_0, C_1, C_2$ = 1.68, 0.563, 0.554")
    if fit is not None:
        ax.plot(curve, fit.predict(curve), "-", color="tab:red", lw=1.4,
                label=(rf"fit: $C_0$ = {fit.C0:.3g} $\pm$ {fit.C0_err:.2g}, "
                       rf"$C_1$ = {fit.C1:.3g} $\pm$ {fit.C1_err:.2g}, "
                       "\n" rf"$C_2$ = {fit.C2:.3g} $\pm$ {fit.C2_err:.2g}, "
                       rf"$\chi^2$/dof = {fit.chi2_dof:.2g}"))
        ax.axhline(fit.C0, ls=":", color="tab:red", lw=1)
        small = curve[fit.small_X(curve) <= fit.C0 * 1.05]
        ax.plot(small, fit.small_X(small), ":", color="tab:red", lw=1,
                label=r"asymptotes $C_0$ and $C_1 X + C_2$")
    ax.axhline(pi / 2, ls="-", color="0.85", lw=0.8, zorder=0)
    ax.set_xlim(0.0, curve[-1])
    ax.set_xlabel(r"$X = D_{tar}/D_{jet}$")
    ax.set_ylabel(r"scattering angle $\psi_0$ [rad]")
    ax.legend(fontsize=7, frameon=False, loc="lower right")
    return save_figure(fig, path)


def plot_azimuthal_flux(
    flux: AzimuthalFlux,
    path: str | Path,
    *,
    anisotropy: Anisotropy | None = None,
    orders: Sequence[int] = (2,),
) -> Path:
    """Normalised azimuthal flux (1/N) dN/dphi with block error bars and its Fourier fit
    (1/2 pi)(1 + 2 sum v_n cos n phi), by default the cos 2phi term alone.

    Parameters
    ----------
    flux : an :func:`~grainflow.analysis.jet.azimuthal_flux` result.
    path : output PNG path.
    anisotropy : an :func:`~grainflow.analysis.jet.anisotropy_v2` result of order 2 to draw
        instead of the flux's own v2 (they agree when computed with the same arguments).
    orders : the harmonics of ``flux`` drawn in the fit (ignored with ``anisotropy``).
    """
    if not isinstance(flux, AzimuthalFlux):
        raise ValueError(f"flux: expected an AzimuthalFlux, got {type(flux).__name__}")
    if anisotropy is not None and not (isinstance(anisotropy, Anisotropy)
                                       and anisotropy.order == 2):
        raise ValueError("anisotropy: expected an Anisotropy result of order 2")
    fig = new_figure(1, width=5.2, height=4.0)
    ax = fig.subplots()
    err = np.where(np.isfinite(flux.density_err), flux.density_err, 0.0)
    ax.errorbar(flux.centres, flux.density, yerr=err, fmt="o", color="k", ms=4, capsize=2,
                mfc="none", label=f"{flux.weighting}-weighted, {flux.n_grains} samples")
    phi = np.linspace(-pi, pi, 400)
    if anisotropy is not None:
        model = (1.0 + 2.0 * anisotropy.v * np.cos(2.0 * phi)) / (2.0 * pi)
        label = rf"$v_2$ = {anisotropy.v:.3f} $\pm$ {anisotropy.v_err:.3f}"
    else:
        model = flux.model(phi, orders)
        label = ", ".join(rf"$v_{k}$ = {flux.v[list(flux.orders).index(k)]:.3f} $\pm$ "
                          rf"{flux.v_err[list(flux.orders).index(k)]:.3f}" for k in orders)
    ax.plot(phi, model, "-", color="tab:red", lw=1.3,
            label=r"$(1 + 2\sum v_n \cos n\varphi)/2\pi$" "\n" + label)
    ax.axhline(1.0 / (2.0 * pi), ls=":", color="0.5", lw=0.8)
    ax.set_xlim(-pi, pi)
    ax.set_xticks([-pi, -pi / 2, 0, pi / 2, pi],
                  [r"$-\pi$", r"$-\pi/2$", "0", r"$\pi/2$", r"$\pi$"])
    ax.set_xlabel(r"azimuth $\varphi$ from the short axis")
    ax.set_ylabel(r"$(1/N)\,dN/d\varphi$")
    ax.legend(fontsize=7, frameon=False, loc="lower center")
    return save_figure(fig, path)


def plot_v2_vs_eccentricity(
    eps: ArrayLike,
    v2: ArrayLike,
    path: str | Path,
    *,
    v2_err: ArrayLike | None = None,
    reference: bool = True,
) -> Path:
    """Elliptic flow v2 against the eccentricity eps of the jet's cross-section (Fig. 4.3).

    Parameters
    ----------
    eps, v2 : (M,) eccentricities and v2 values.
    path : output PNG path.
    v2_err : (M,) standard errors (error bars).
    reference : draw the experimental point v2 = 0.16 at eps = 0.615 (Cheng et al.) and the
        perfect-fluid expectation v2 / eps = constant through it (dashed).
    """
    x, y, err = _series("eps", eps, "v2", v2, "v2_err", v2_err)
    fig = new_figure(1, width=5.0, height=4.0)
    ax = fig.subplots()
    ax.errorbar(x, y, yerr=err, fmt="s", color="k", ms=4, capsize=2, mfc="none",
                label="simulation")
    if reference:
        e_ref, v_ref = SEED_V2
        top = max(float(np.nanmax(x)), e_ref) * 1.1
        line = np.linspace(0.0, top, 50)
        ax.plot(line, v_ref / e_ref * line, "--", color="0.5", lw=1,
                label=r"$v_2 \propto \varepsilon$ (perfect fluid)")
        ax.plot([e_ref], [v_ref], "*", color="tab:red", ms=10, label="experiment (Cheng et al.)")
    ax.axhline(0.0, color="0.85", lw=0.8, zorder=0)
    ax.set_xlabel(r"eccentricity $\varepsilon = (l^2-1)/(l^2+1)$")
    ax.set_ylabel(r"$v_2$")
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    return save_figure(fig, path)
