"""Rheology of dense granular flow after seed 002 (H. Sano, PhD thesis (2013) on granular jets;
Sano & Hayakawa, PRE 86, 041308 (2012)): pure functions of coarse-grained field arrays.

Conventions
-----------
* Stress tensors are arrays of shape (..., D, D), D = 2 or 3, **compression positive**, as the
  thesis's eq. (6.1) and Appendix C::

      sigma_ab = (1/V) [ sum_i m_i u'_ia u'_ib + sum_{i<j} F^ij_a (r_i - r_j)_b ],

  with u' the velocity relative to the local mean and F^ij the force on i from j (a repulsive
  contact adds a positive term). The pressure is P = trace(sigma) / D.
* Strain rate D_ab = (d_a v_b + d_b v_a) / 2 (thesis Secs. 5.3.3 and 6.1.3). In simple shear
  v_x = gamma_dot y it is D_xy = gamma_dot / 2: D_ab is *half* the shear rate gamma_dot that
  GDR MiDi and most of the mu(I) literature put in I. The thesis puts D_ab in I, and so do the
  defaults here; ``use_shear_rate=True`` uses gamma_dot = 2 |D_ab| instead (I doubles, and so
  does a fitted I0).
* Effective friction mu* = -sigma_ab / P for a chosen pair of axes: -sigma_rz / P in 3D
  cylindrical components (Sec. 5.3.3), -sigma_xy / P in 2D (Sec. 6.1.4). Components are picked
  by index, so the caller may pass the tensor in any basis, Cartesian or cylindrical. With
  compression positive a viscous shear stress is sigma_ab = -eta D_ab (eq. 5.12), so mu* has the
  sign of D_ab.
* Inertial number in D dimensions, with d the grain diameter (the thesis's unit, the largest
  diameter) and m the grain mass::

      I = |D_ab| sqrt(m / (P d^(D-2)));  3D: |D_rz| sqrt(m / (P d));  2D: I_s = |D_xy| sqrt(m / P).

  P has units of energy / length^D. Eq. (2.56), gamma_dot / sqrt(P sigma^(D-1) / m) with sigma
  the diameter, is therefore not dimensionless (misprint); the power D-2 is, and it gives the
  2D I_s of Sec. 6.1.3. Sec.
  5.3.3 prints I = D_rz sqrt(P / (m d)), upside down. I_s is I with D = 2, so it has no
  function of its own.
* Temperature number I_T = sqrt(T / (P d^D)), T the granular temperature as an energy,
  T_g = sum_i m u_i^2 / (D N); in 2D I_T = sqrt(T_g / (P d^2)) (Sec. 6.1.3).
* Field functions broadcast over arrays; cells with P <= 0 (empty or in tension) give NaN, and
  NaN propagates. The fits instead reject non-finite data unless told ``drop_nan=True``.

Fits (:func:`fit_mu_of_I`, :func:`fit_mu_power_law`, :func:`fit_mu_linear`,
:func:`fit_divergence`) are least squares by :func:`scipy.optimize.curve_fit`, started from a
grid over the one non-linear parameter with the others solved linearly. Standard errors are the
square roots of the covariance diagonal (inverse of J^T J from the Jacobian J of the weighted
residuals): absolute when ``sigma`` (the data's standard errors) is given, scaled by the
residual variance chi^2/dof when not.

Units are those of the caller; the thesis uses d, m and d/u0.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import OptimizeWarning, curve_fit

from grainflow.analysis.checks import frozen as _frozen

# --------------------------------------------------------------------------------------------
# Stress, pressure and dimensionless numbers
# --------------------------------------------------------------------------------------------


def _stress_array(stress: ArrayLike) -> np.ndarray:
    """``stress`` as a float array of shape (..., D, D), D = 2 or 3, or ValueError."""
    s = np.asarray(stress, dtype=float)
    if s.ndim < 2 or s.shape[-1] != s.shape[-2] or s.shape[-1] not in (2, 3):
        raise ValueError(f"stress: expected shape (..., D, D) with D = 2 or 3, got {s.shape}")
    return s


def _positive_or_nan(values: ArrayLike) -> np.ndarray:
    """``values`` where > 0, NaN elsewhere (empty or tensile cells)."""
    arr = np.asarray(values, dtype=float)
    return np.where(arr > 0, arr, np.nan)


def _positive_parameter(name: str, value: ArrayLike) -> np.ndarray:
    """``value`` as a float array of positive finite numbers, or ValueError naming ``name``."""
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr) & (arr > 0)):
        raise ValueError(f"{name}: must be positive and finite, got {value!r}")
    return arr


def _check_dim(dim: int) -> None:
    if dim not in (2, 3):
        raise ValueError(f"dim: must be 2 or 3, got {dim!r}")


def pressure(stress: ArrayLike) -> np.ndarray:
    """Pressure P = trace(sigma) / D of (..., D, D) stress tensors (2D: (sigma_xx + sigma_yy)/2,
    Sec. 6.1.3). Compression positive, so P > 0 in a granular flow."""
    s = _stress_array(stress)
    return np.trace(s, axis1=-2, axis2=-1) / s.shape[-1]


def effective_friction(
    stress: ArrayLike,
    axes: tuple[int, int] = (0, 1),
    *,
    strain_rate: ArrayLike | None = None,
) -> np.ndarray:
    """Effective friction coefficient mu* = -sigma_ab / P (Secs. 5.3.3 and 6.1.4).

    Parameters
    ----------
    stress : (..., D, D) stress tensors, compression positive; the component (a, b) is used as
        given (symmetrise first if the contact stress of frictional grains is not symmetric).
    axes : (a, b), indices of the shear component: (0, 1) is sigma_xy; for a tensor in
        cylindrical components ordered (r, theta, z), (0, 2) is the thesis's sigma_rz.
    strain_rate : optional D_ab field broadcastable to ``stress[..., a, b]``; mu* is then
        multiplied by sgn(D_ab) (unchanged where D_ab = 0), so that it is positive wherever the
        shear stress opposes the deformation, whichever way the flow shears.

    Returns
    -------
    mu* with shape ``stress.shape[:-2]``; NaN where P <= 0.
    """
    s = _stress_array(stress)
    dim = s.shape[-1]
    a, b = axes
    if not (a != b and 0 <= a < dim and 0 <= b < dim):
        raise ValueError(f"axes: expected two different indices in [0, {dim}), got {axes!r}")
    mu = -s[..., a, b] / _positive_or_nan(pressure(s))
    if strain_rate is not None:
        mu = np.where(np.asarray(strain_rate, dtype=float) < 0, -mu, mu)
    return mu


def inertial_number(
    strain_rate_component: ArrayLike,
    pressure: ArrayLike,
    diameter: ArrayLike,
    mass: ArrayLike,
    dim: int,
    *,
    use_shear_rate: bool = False,
) -> np.ndarray:
    """Inertial number I = |D_ab| sqrt(m / (P d^(D-2))) (eq. 2.56 corrected; see module notes).

    3D: I = |D_rz| sqrt(m / (P d)) (Sec. 5.3.3); 2D: I_s = |D_xy| sqrt(m / P) (Sec. 6.1.3).

    Parameters
    ----------
    strain_rate_component : D_ab field (thesis convention, half the simple-shear rate).
    pressure : P field, same units as :func:`pressure` returns (energy / length^D).
    diameter : grain diameter d, > 0.
    mass : grain mass m, > 0 (a number or a field).
    dim : spatial dimension D, 2 or 3.
    use_shear_rate : use gamma_dot = 2 |D_ab| (GDR MiDi's I) instead of |D_ab| (the thesis's).

    Returns
    -------
    I, broadcast over the inputs; NaN where P <= 0.
    """
    _check_dim(dim)
    d = _positive_parameter("diameter", diameter)
    m = _positive_parameter("mass", mass)
    rate = np.abs(np.asarray(strain_rate_component, dtype=float))
    if use_shear_rate:
        rate = 2.0 * rate
    return rate * np.sqrt(m / (_positive_or_nan(pressure) * d ** (dim - 2)))


def temperature_number(
    T: ArrayLike, pressure: ArrayLike, diameter: ArrayLike, dim: int
) -> np.ndarray:
    """Temperature number I_T = sqrt(T / (P d^D)) (2D: sqrt(T_g / (P d^2)), Sec. 6.1.3).

    Parameters
    ----------
    T : granular temperature as an energy, T_g = sum_i m u_i^2 / (D N), >= 0.
    pressure : P field (energy / length^D).
    diameter : grain diameter d, > 0.
    dim : spatial dimension D, 2 or 3.

    Returns
    -------
    I_T, broadcast over the inputs; NaN where P <= 0.
    """
    _check_dim(dim)
    d = _positive_parameter("diameter", diameter)
    temperature = np.asarray(T, dtype=float)
    if np.any(temperature < 0):
        raise ValueError("T: granular temperatures must be >= 0")
    return np.sqrt(temperature / (_positive_or_nan(pressure) * d**dim))


# --------------------------------------------------------------------------------------------
# Fits: shared machinery
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class FitStatistics:
    """What every fit reports besides its parameters.

    Attributes
    ----------
    covariance : (p, p) read-only covariance of the free parameters, in the order listed by
        the fit's class.
    chi2_dof : sum of squared residuals / dof; residuals are divided by ``sigma`` when it was
        given (then ~1 for a good model), else this is the residual variance of the data.
    dof : n_points - number of free parameters.
    n_points : number of data points fitted (after ``drop_nan``).
    absolute_sigma : whether the standard errors come from the given ``sigma`` as absolute
        errors (True) or are scaled by chi2_dof (False).
    """

    covariance: np.ndarray
    chi2_dof: float
    dof: int
    n_points: int
    absolute_sigma: bool


def _fit_data(
    x_name: str,
    x: ArrayLike,
    y_name: str,
    y: ArrayLike,
    sigma: ArrayLike | None,
    n_params: int,
    drop_nan: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Validated 1-D (x, y, sigma); ValueError naming the offending argument."""
    xs = np.asarray(x, dtype=float)
    if xs.ndim != 1:
        raise ValueError(f"{x_name}: expected a 1-D array, got shape {xs.shape}")
    ys = np.asarray(y, dtype=float)
    if ys.shape != xs.shape:
        raise ValueError(f"{y_name}: expected shape {xs.shape} like {x_name}, got {ys.shape}")
    arrays = {x_name: xs, y_name: ys}
    if sigma is not None:
        err = np.asarray(sigma, dtype=float)
        if err.ndim == 0:
            err = np.full_like(xs, err)
        if err.shape != xs.shape:
            raise ValueError(f"sigma: expected one number or shape {xs.shape}, got {err.shape}")
        arrays["sigma"] = err
    if drop_nan:
        keep = ~np.any([np.isnan(arr) for arr in arrays.values()], axis=0)
        arrays = {name: arr[keep] for name, arr in arrays.items()}
    for name, arr in arrays.items():
        if not np.all(np.isfinite(arr)):
            hint = "; pass drop_nan=True to drop NaN points" if np.any(np.isnan(arr)) else ""
            raise ValueError(f"{name}: contains NaN or infinite values{hint}")
    xs, ys = arrays[x_name], arrays[y_name]
    if np.any(xs <= 0):
        raise ValueError(f"{x_name}: must be > 0 (got min {xs.min():g})")
    if "sigma" in arrays and np.any(arrays["sigma"] <= 0):
        raise ValueError("sigma: standard errors must be > 0")
    if xs.size <= n_params:
        raise ValueError(
            f"{x_name}: need more than {n_params} points to fit {n_params} parameter(s) with "
            f"uncertainties, got {xs.size}"
        )
    return xs, ys, arrays.get("sigma")


def _weights(err: np.ndarray | None, n: int) -> np.ndarray:
    return np.ones(n) if err is None else 1.0 / err


def _linear_start(
    y: np.ndarray,
    weights: np.ndarray,
    grid: np.ndarray,
    basis: Callable[[float], np.ndarray],
) -> tuple[float, np.ndarray]:
    """Starting values for a model linear in all parameters but one, g.

    For each g in ``grid`` solve the weighted linear least squares y ~ basis(g) @ c; return the
    (g, c) with the smallest residual.
    """
    best: tuple[float, float, np.ndarray] | None = None
    for g in grid:
        design = basis(g) * weights[:, None]
        coef, *_ = np.linalg.lstsq(design, y * weights, rcond=None)
        sse = float(np.sum((design @ coef - y * weights) ** 2))
        if np.isfinite(sse) and (best is None or sse < best[0]):
            best = (sse, float(g), coef)
    assert best is not None  # the grids below always give finite designs for x > 0
    return best[1], best[2]


def _least_squares(
    model: Callable[..., np.ndarray],
    x_name: str,
    x: np.ndarray,
    y: np.ndarray,
    err: np.ndarray | None,
    p0: Sequence[float],
    lower: Sequence[float] | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """(parameters, standard errors, FitStatistics fields) of a curve_fit.

    Levenberg-Marquardt without bounds (as the thesis, Sec. 6.1.3), trust-region reflective
    with the lower bounds ``lower``.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OptimizeWarning)  # singular covariance: checked below
        try:
            popt, pcov = curve_fit(
                model, x, y, p0=p0, sigma=err, absolute_sigma=err is not None,
                bounds=(-np.inf, np.inf) if lower is None else (lower, np.inf),
                method="lm" if lower is None else "trf",
            )
        except RuntimeError as exc:  # no convergence within curve_fit's evaluations
            raise ValueError(
                f"{x_name}: the fit of {getattr(model, '__name__', 'the law')} did not converge "
                f"({exc}); the data may not follow the law over this range of {x_name}"
            ) from None
    if not np.all(np.isfinite(pcov)):
        raise ValueError(
            f"{x_name}: the data do not determine all parameters (singular covariance); "
            f"spread the points over a wider range of {x_name}"
        )
    resid = (y - model(x, *popt)) / (1.0 if err is None else err)
    dof = x.size - len(p0)
    stats = {
        "covariance": _frozen(pcov),
        "chi2_dof": float(np.sum(resid**2) / dof),
        "dof": dof,
        "n_points": int(x.size),
        "absolute_sigma": err is not None,
    }
    return popt, np.sqrt(np.diag(pcov)), stats


# --------------------------------------------------------------------------------------------
# Friction laws mu*(I)
# --------------------------------------------------------------------------------------------


def mu_of_I(I: ArrayLike, mu_s: float, mu_max: float, I0: float) -> np.ndarray:
    """Jop-Forterre-Pouliquen friction law, eq. (2.57)::

        mu* = mu_s + (mu_max - mu_s) / (1 + I0 / I),

    mu_s at I -> 0, mu_max at I -> infinity, halfway at I = I0. Eq. (6.9) misprints it as the
    product mu_s + (mu_max - mu_s)(1 + I0/I), which diverges at I -> 0 and contradicts the text
    around it (mu* starts from mu_s at zero shear rate and converges to mu_max at high I_s);
    the fitted values of Sec. 6.1.4 belong to this form.
    """
    x = np.asarray(I, dtype=float)
    return mu_s + (mu_max - mu_s) * x / (x + I0)


@dataclass(frozen=True, kw_only=True)
class MuOfIFit(FitStatistics):
    """Fit of eq. (2.57); parameters (mu_s, mu_max, I0) and their standard errors."""

    mu_s: float
    mu_max: float
    I0: float
    mu_s_err: float
    mu_max_err: float
    I0_err: float

    def predict(self, I: ArrayLike) -> np.ndarray:
        """mu*(I) from the fitted law."""
        return mu_of_I(I, self.mu_s, self.mu_max, self.I0)


def fit_mu_of_I(
    I: ArrayLike,
    mu: ArrayLike,
    sigma: ArrayLike | None = None,
    *,
    drop_nan: bool = False,
) -> MuOfIFit:
    """Fit mu* = mu_s + (mu_max - mu_s) / (1 + I0/I), eq. (2.57) (printed wrongly as eq. 6.9).

    Thesis, 2D bidisperse frictionless grains (Sec. 6.1.4): mu_s = 0.0153 +- 0.009,
    mu_max = 0.521 +- 0.06, I0 = 0.0820 +- 0.02 (with I = I_s built on D_xy).
    Trust-region reflective with I0 >= 0; start from a grid over I0.

    Parameters
    ----------
    I : (M,) inertial numbers, > 0.
    mu : (M,) effective friction coefficients.
    sigma : standard errors of mu, (M,) or one number, > 0; absolute.
    drop_nan : drop points where I, mu or sigma is NaN (otherwise NaN raises ValueError).
    """
    x, y, err = _fit_data("I", I, "mu", mu, sigma, 3, drop_nan)
    I0_start, (mu_s0, mu_max0) = _linear_start(
        y, _weights(err, x.size), np.geomspace(x.min() / 10, x.max() * 10, 61),
        lambda I0: np.column_stack([I0 / (x + I0), x / (x + I0)]),
    )
    p, e, stats = _least_squares(
        mu_of_I, "I", x, y, err, [mu_s0, mu_max0, I0_start], lower=[-np.inf, -np.inf, 0.0]
    )
    return MuOfIFit(
        mu_s=float(p[0]), mu_max=float(p[1]), I0=float(p[2]),
        mu_s_err=float(e[0]), mu_max_err=float(e[1]), I0_err=float(e[2]), **stats,
    )


def mu_power_law(I: ArrayLike, mu_s: float, b: float, beta: float) -> np.ndarray:
    """Power-law friction, eqs. (2.58) and (6.10): mu* = mu_s + b I^beta."""
    return mu_s + b * np.asarray(I, dtype=float) ** beta


@dataclass(frozen=True, kw_only=True)
class MuPowerLawFit(FitStatistics):
    """Fit of eq. (2.58)/(6.10); free parameters (mu_s, b, beta), or (b, beta) with mu_s fixed
    (then ``mu_s_fixed`` is True and ``mu_s_err`` is 0)."""

    mu_s: float
    b: float
    beta: float
    mu_s_err: float
    b_err: float
    beta_err: float
    mu_s_fixed: bool

    def predict(self, I: ArrayLike) -> np.ndarray:
        """mu*(I) from the fitted law."""
        return mu_power_law(I, self.mu_s, self.b, self.beta)


def fit_mu_power_law(
    I: ArrayLike,
    mu: ArrayLike,
    sigma: ArrayLike | None = None,
    mu_s: float | None = None,
    *,
    drop_nan: bool = False,
) -> MuPowerLawFit:
    """Fit mu* = mu_s + b I^beta, eqs. (2.58) and (6.10).

    The thesis fixes mu_s = 0 and finds b = 1.18 +- 0.1, beta = 0.592 +- 0.03 (2D bidisperse
    frictionless grains, Sec. 6.1.4). Levenberg-Marquardt; start from a grid over beta.

    Parameters
    ----------
    I : (M,) inertial numbers, > 0.
    mu : (M,) effective friction coefficients.
    sigma : standard errors of mu, (M,) or one number, > 0; absolute.
    mu_s : None fits mu_s; a number fixes it (``mu_s=0.0`` as the thesis).
    drop_nan : drop points where I, mu or sigma is NaN (otherwise NaN raises ValueError).
    """
    if mu_s is not None and not np.isfinite(mu_s):
        raise ValueError(f"mu_s: a fixed mu_s must be finite, got {mu_s!r}")
    x, y, err = _fit_data("I", I, "mu", mu, sigma, 2 if mu_s is not None else 3, drop_nan)
    weights, betas = _weights(err, x.size), np.linspace(0.02, 3.0, 150)
    if mu_s is None:
        beta0, (mu_s0, b0) = _linear_start(
            y, weights, betas, lambda beta: np.column_stack([np.ones_like(x), x**beta])
        )
        p, e, stats = _least_squares(mu_power_law, "I", x, y, err, [mu_s0, b0, beta0])
        values, errors = p, e
    else:
        fixed = float(mu_s)
        beta0, (b0,) = _linear_start(y - fixed, weights, betas, lambda beta: (x**beta)[:, None])

        def model(xx: np.ndarray, b: float, beta: float) -> np.ndarray:
            return mu_power_law(xx, fixed, b, beta)

        p, e, stats = _least_squares(model, "I", x, y, err, [b0, beta0])
        values, errors = [fixed, *p], [0.0, *e]
    return MuPowerLawFit(
        mu_s=float(values[0]), b=float(values[1]), beta=float(values[2]),
        mu_s_err=float(errors[0]), b_err=float(errors[1]), beta_err=float(errors[2]),
        mu_s_fixed=mu_s is not None, **stats,
    )


@dataclass(frozen=True, kw_only=True)
class MuLinearFit(FitStatistics):
    """Fit of mu* = a I (Sec. 5.3.3); parameter a and its standard error."""

    a: float
    a_err: float

    def predict(self, I: ArrayLike) -> np.ndarray:
        """mu*(I) = a I."""
        return self.a * np.asarray(I, dtype=float)


def fit_mu_linear(
    I: ArrayLike,
    mu: ArrayLike,
    sigma: ArrayLike | None = None,
    *,
    drop_nan: bool = False,
) -> MuLinearFit:
    """Fit mu* = a I through the origin (zero yield stress), Sec. 5.3.3 and Fig. 5.7.

    Thesis, 3D jets: a = 0.240 (frictional, mu_p = 0.2) and 0.223 (frictionless), with I built
    on D_rz.

    Parameters
    ----------
    I : (M,) inertial numbers, > 0.
    mu : (M,) effective friction coefficients.
    sigma : standard errors of mu, (M,) or one number, > 0; absolute.
    drop_nan : drop points where I, mu or sigma is NaN (otherwise NaN raises ValueError).
    """
    x, y, err = _fit_data("I", I, "mu", mu, sigma, 1, drop_nan)
    w2 = _weights(err, x.size) ** 2
    a0 = float(np.sum(w2 * x * y) / np.sum(w2 * x * x))

    def model(xx: np.ndarray, a: float) -> np.ndarray:
        return a * xx

    p, e, stats = _least_squares(model, "I", x, y, err, [a0])
    return MuLinearFit(a=float(p[0]), a_err=float(e[0]), **stats)


# --------------------------------------------------------------------------------------------
# Divergence of the pressure near jamming: phi(I)
# --------------------------------------------------------------------------------------------


def phi_of_I(I: ArrayLike, phi_c: float, a: float, alpha: float) -> np.ndarray:
    """Packing fraction against I_T or I_s, eqs. (6.2)/(6.3): phi = phi_c - a I^(2/alpha)."""
    return phi_c - a * np.asarray(I, dtype=float) ** (2.0 / alpha)


@dataclass(frozen=True, kw_only=True)
class DivergenceFit(FitStatistics):
    """Fit of eq. (6.2) or (6.3); parameters (phi_c, a, alpha) and their standard errors."""

    phi_c: float
    a: float
    alpha: float
    phi_c_err: float
    a_err: float
    alpha_err: float

    def predict(self, I: ArrayLike) -> np.ndarray:
        """phi(I) from the fitted law."""
        return phi_of_I(I, self.phi_c, self.a, self.alpha)

    def number(self, phi: ArrayLike) -> np.ndarray:
        """The inverse, I(phi) = ((phi_c - phi) / a)^(alpha/2); NaN for phi >= phi_c."""
        gap = _positive_or_nan(self.phi_c - np.asarray(phi, dtype=float))
        return (gap / self.a) ** (self.alpha / 2.0)

    def scaled_pressure(self, phi: ArrayLike) -> np.ndarray:
        """Equation of state 1/I^2 = a^alpha / (phi_c - phi)^alpha, eqs. (6.4)/(6.5).

        P d^2 / T_g for a fit against I_T (6.4), P / (m D_xy^2) for one against the 2D I_s
        (6.5). The ratio of the I_T fit's to the I_s fit's gives m d^2 D_xy^2 / T_g, eq. (6.8).
        NaN for phi >= phi_c.
        """
        return self.number(phi) ** -2.0


def fit_divergence(
    I: ArrayLike,
    phi: ArrayLike,
    sigma: ArrayLike | None = None,
    *,
    drop_nan: bool = False,
) -> DivergenceFit:
    """Fit phi = phi_c - a I^(2/alpha), eqs. (6.2) (I = I_T) and (6.3) (I = I_s).

    Levenberg-Marquardt as the thesis (Sec. 6.1.3), which fits phi_c, a and alpha jointly; start
    from a grid over alpha. Thesis, 2D bidisperse frictionless grains: phi_T = 0.858 +- 0.006,
    a_T = 0.980 +- 0.1, alpha_T = 1.15 +- 0.1 against I_T; phi_s = 0.834 +- 0.001,
    a_s = 3.94 +- 0.5, alpha_s = 1.36 +- 0.05 against I_s.

    Parameters
    ----------
    I : (M,) I_T or I_s values, > 0.
    phi : (M,) packing (area) fractions.
    sigma : standard errors of phi, (M,) or one number, > 0; absolute.
    drop_nan : drop points where I, phi or sigma is NaN (otherwise NaN raises ValueError).
    """
    x, y, err = _fit_data("I", I, "phi", phi, sigma, 3, drop_nan)
    alpha0, (phi_c0, a0) = _linear_start(
        y, _weights(err, x.size), np.geomspace(0.2, 20.0, 121),
        lambda alpha: np.column_stack([np.ones_like(x), -(x ** (2.0 / alpha))]),
    )
    p, e, stats = _least_squares(phi_of_I, "I", x, y, err, [phi_c0, a0, alpha0])
    return DivergenceFit(
        phi_c=float(p[0]), a=float(p[1]), alpha=float(p[2]),
        phi_c_err=float(e[0]), a_err=float(e[1]), alpha_err=float(e[2]), **stats,
    )


def scaled_shear_stress(
    phi: ArrayLike,
    friction: MuOfIFit | MuPowerLawFit | MuLinearFit,
    divergence: DivergenceFit,
) -> np.ndarray:
    """Shear stress against packing fraction from a friction law and the I_s divergence fit.

    sigma_ab d^(D-2) / (m D_ab^2) = -mu*(I) / I^2 with I = I(phi) from ``divergence``: with the
    power law at mu_s = 0 this is eq. (6.11) in 2D,

        sigma_xy / (m D_xy^2) = -b a_s^((1-beta/2) alpha_s) / (phi_s - phi)^((1-beta/2) alpha_s),

    a divergence with exponent (1 - beta/2) alpha_s (0.96 in the thesis), the beta_s of the
    shear viscosity, eqs. (6.12)-(6.13). ``divergence`` must be the fit against I (I_s in 2D),
    not I_T. NaN for phi >= phi_c.
    """
    inertial = divergence.number(phi)
    return -friction.predict(inertial) / inertial**2


# --------------------------------------------------------------------------------------------
# Velocity distributions (Sec. 5.3.3, Fig. 5.8, Table 5.1)
# --------------------------------------------------------------------------------------------


def gaussian_vdf(c: ArrayLike) -> np.ndarray:
    """Gaussian reference of Fig. 5.8, exp(-c^2/2) / sqrt(2 pi): flatness 3."""
    x = np.asarray(c, dtype=float)
    return np.exp(-0.5 * x**2) / np.sqrt(2.0 * np.pi)


def exponential_vdf(c: ArrayLike) -> np.ndarray:
    """Exponential reference of Fig. 5.8, exp(-sqrt(2) |c|) / sqrt(2): flatness 6."""
    return np.exp(-np.sqrt(2.0) * np.abs(np.asarray(c, dtype=float))) / np.sqrt(2.0)


def _velocity_samples(
    velocities: ArrayLike, masses: ArrayLike | None
) -> tuple[np.ndarray, np.ndarray]:
    """Validated (N,) or (N, D) velocities and (N,) weights (masses, or ones)."""
    v = np.asarray(velocities, dtype=float)
    if v.ndim not in (1, 2) or v.shape[0] < 2:
        raise ValueError(f"velocities: expected shape (N,) or (N, D) with N >= 2, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError("velocities: contains NaN or infinite values")
    if masses is None:
        return v, np.ones(v.shape[0])
    w = np.asarray(masses, dtype=float)
    if w.shape != (v.shape[0],):
        raise ValueError(f"masses: expected shape ({v.shape[0]},), got {w.shape}")
    _positive_parameter("masses", w)
    return v, w


def _fluctuations(v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean, u = v - mean, std) per component, moments weighted by ``w``."""
    mean = np.average(v, axis=0, weights=w)
    u = v - mean
    std = np.sqrt(np.average(u**2, axis=0, weights=w))
    if np.any(std <= 0):
        raise ValueError("velocities: a component has no spread; its distribution is undefined")
    return mean, u, std


def flatness(velocities: ArrayLike, masses: ArrayLike | None = None) -> float | np.ndarray:
    """Flatness <u^4> / <u^2>^2 of the fluctuation u = v - <v>, per component (Table 5.1).

    3 for a Gaussian, 6 for the exponential exp(-sqrt(2)|c|)/sqrt(2). The thesis (3D jets,
    phi0/phi_fcc = 0.90) finds 2.87 / 2.86 / 3.41 (z / r / theta) for frictionless and
    2.70 / 2.98 / 3.71 for frictional grains. Population moments (no small-sample correction).

    Parameters
    ----------
    velocities : (N,) one component or (N, D) components of the grains in a cell.
    masses : (N,) grain masses to weight the mean and the moments by (mass-weighted VDF);
        None weights every grain equally.

    Returns
    -------
    A float for (N,) input, a (D,) array for (N, D).
    """
    v, w = _velocity_samples(velocities, masses)
    _, u, std = _fluctuations(v, w)
    result = np.average(u**4, axis=0, weights=w) / std**4
    return float(result) if v.ndim == 1 else result


@dataclass(frozen=True)
class VelocityDistribution:
    """Histogram estimate of a velocity distribution, per component.

    Attributes
    ----------
    centres : (n_bins,) bin centres: c = (v - mean)/v0 if ``temperature_scaled``, else the
        fluctuation u = v - mean in velocity units.
    density : (n_bins,) or (n_bins, D): f~(c) or f(u); (weighted) counts / (total weight x bin
        width), so samples beyond the bins are missing from its integral, not spread over it.
    mean : () or (D,) (mass-weighted) mean velocity.
    v0 : () or (D,) scale, the standard deviation sqrt(<u^2>) = sqrt(T_a / m).
    temperature_scaled : whether ``centres`` are in units of v0.
    """

    centres: np.ndarray
    density: np.ndarray
    mean: np.ndarray
    v0: np.ndarray
    temperature_scaled: bool


def velocity_distribution(
    velocities: ArrayLike,
    bins: int | ArrayLike = 40,
    *,
    temperature_scaled: bool = True,
    limits: tuple[float, float] | None = None,
    masses: ArrayLike | None = None,
) -> VelocityDistribution:
    """Scaled velocity distribution f~(c) per component, Sec. 5.3.3 and Fig. 5.8.

    The thesis writes f(v_a) = v_a0^-1 f~(c_a) with v_a0 = sqrt(2 T_a / m) and demands
    int f~ dc = int c^2 f~ dc = 1, int c f~ dc = 0, and compares with the unit-variance curves
    :func:`gaussian_vdf` and :func:`exponential_vdf`. With T_a = m <u_a^2> (its T_g per
    component), c = u / sqrt(2 T_a / m) would have <c^2> = 1/2, so the printed v0 contradicts
    the normalisation and the reference curves (it fits if T there means the kinetic energy
    m <u_a^2> / 2). Here the normalisation wins: c = (v - <v>) / v0 with v0 = sqrt(<u^2>), the
    standard deviation, i.e. sqrt(T_a / m) with T_a = m <u_a^2>.

    Parameters
    ----------
    velocities : (N,) one component or (N, D) components of the grains in a cell.
    bins : number of equal bins over ``limits``, or the bin edges (then ``limits`` must be None).
    temperature_scaled : bin c = u / v0 (default) or the fluctuation u = v - <v> itself.
    limits : (low, high) of the bins; default (-5, 5) for c and +-5 of the largest v0 for u.
    masses : (N,) grain masses to weight the mean, v0 and the histogram by; None: equal weights.
    """
    v, w = _velocity_samples(velocities, masses)
    mean, u, std = _fluctuations(v, w)
    x = u / std if temperature_scaled else u
    if np.ndim(bins) == 0:
        if int(bins) != bins or bins < 1:
            raise ValueError(f"bins: expected a positive integer or bin edges, got {bins!r}")
        if limits is not None:
            low, high = limits
        else:
            high = 5.0 if temperature_scaled else 5.0 * float(np.max(std))
            low = -high
        if not (np.isfinite(low) and np.isfinite(high) and low < high):
            raise ValueError(f"limits: expected finite (low, high) with low < high, got {limits!r}")
        edges = np.linspace(low, high, int(bins) + 1)
    else:
        if limits is not None:
            raise ValueError("limits: give bin edges or limits, not both")
        edges = np.asarray(bins, dtype=float)
        if edges.ndim != 1 or edges.size < 2 or not np.all(np.diff(edges) > 0):
            raise ValueError("bins: edges must be a 1-D increasing array of at least 2 values")
    columns = x.reshape(x.shape[0], -1)
    counts = np.stack(
        [np.histogram(col, bins=edges, weights=w)[0] for col in columns.T], axis=-1
    )
    density = counts / (w.sum() * np.diff(edges)[:, None])
    return VelocityDistribution(
        centres=_frozen(0.5 * (edges[1:] + edges[:-1])),
        density=_frozen(density.reshape((edges.size - 1,) + x.shape[1:])),
        mean=_frozen(mean),
        v0=_frozen(std),
        temperature_scaled=temperature_scaled,
    )
