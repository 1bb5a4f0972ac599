"""psi0(X): the interpolation function of seed 002's Fig. 4.2 and its least-squares fit,
X = D_tar / D_jet (thesis: C0 = 1.68, C1 = 0.563, C2 = 0.554 rad)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from grainflow.analysis.checks import frozen as _frozen
from grainflow.analysis.checks import paired_arrays
from grainflow.analysis.rheology import FitStatistics

#: Thesis fit of Fig. 4.2 (3D, frictional, phi0/phi_fcc = 0.90, D_jet = 4.5 d): (C0, C1, C2) rad.
SEED_PSI0_FIT = (1.68, 0.563, 0.554)


def psi0_interpolation(X: ArrayLike, C0: float, C1: float, C2: float) -> np.ndarray:
    """Interpolation function of Fig. 4.2 for the scattering angle::

        psi0 = sqrt( C0'^2 (1 - exp(-C1^2 X^2 / C0'^2)) ) + C2,   C0' = C0 - C2,

    with asymptotes psi0 -> C0 for X >> 1 (eq. 4.4, sheet) and psi0 ~ C1 X + C2 for X << 1
    (eq. 4.5 plus the fitting offset C2). Thesis: C0 = 1.68, C1 = 0.563, C2 = 0.554 rad
    (:data:`SEED_PSI0_FIT`). C0' = 0 gives the constant C2.
    """
    x = np.asarray(X, dtype=float)
    c0p2 = float(C0 - C2) ** 2
    if c0p2 == 0.0:
        return np.full_like(x, float(C2))
    return np.sqrt(c0p2 * -np.expm1(-(C1**2) * x**2 / c0p2)) + C2


@dataclass(frozen=True, kw_only=True)
class Psi0Fit(FitStatistics):
    """Fit of :func:`psi0_interpolation`: (C0, C1, C2) in rad and their standard errors;
    ``covariance`` is ordered (C0, C1, C2)."""

    C0: float
    C1: float
    C2: float
    C0_err: float
    C1_err: float
    C2_err: float

    def predict(self, X: ArrayLike) -> np.ndarray:
        """psi0(X) from the fitted interpolation function."""
        return psi0_interpolation(X, self.C0, self.C1, self.C2)

    def small_X(self, X: ArrayLike) -> np.ndarray:
        """The asymptote C1 X + C2 for X << 1."""
        return self.C1 * np.asarray(X, dtype=float) + self.C2


def _fit_arrays(X: ArrayLike, psi0: ArrayLike, psi0_err: ArrayLike | None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    x, y = paired_arrays("X", X, "psi0", psi0)
    if not np.all(np.isfinite(x)) or np.any(x <= 0):
        raise ValueError("X: values must be finite and > 0")
    if not np.all(np.isfinite(y)):
        raise ValueError("psi0: contains NaN or infinite values")
    err = None
    if psi0_err is not None:
        err = np.asarray(psi0_err, dtype=float)
        if err.ndim == 0:
            err = np.full_like(x, float(err))
        if err.shape != x.shape:
            raise ValueError(f"psi0_err: expected one number or shape {x.shape}, got "
                             f"{err.shape}")
        if not np.all(np.isfinite(err)) or np.any(err <= 0):
            raise ValueError("psi0_err: standard errors must be finite and > 0")
    if x.size <= 3:
        raise ValueError(f"X: need more than 3 points to fit C0, C1, C2 with uncertainties, "
                         f"got {x.size}")
    if np.unique(x).size < 3:
        raise ValueError("X: need at least 3 distinct values")
    return x, y, err


def fit_psi0(X: ArrayLike, psi0: ArrayLike, psi0_err: ArrayLike | None = None) -> Psi0Fit:
    """Fit the interpolation function of Fig. 4.2 to psi0(X) (:func:`psi0_interpolation`).

    Least squares by :func:`scipy.optimize.least_squares` (trust-region reflective) in the
    parameters (C0' = C0 - C2 >= 0, C1 >= 0, C2), since the function depends on C0' and C1
    only through their squares; the covariance (J^T J)^-1 from the Jacobian of the weighted
    residuals is mapped to (C0, C1, C2). Started from the best of a few guesses built on the
    straight line through the smallest-X third of the data. Thesis: C0 = 1.68, C1 = 0.563,
    C2 = 0.554 rad.

    Parameters
    ----------
    X : (M,) target-to-jet diameter ratios D_tar / D_jet, > 0.
    psi0 : (M,) scattering angles in rad.
    psi0_err : standard errors of psi0, (M,) or one number, > 0; absolute. Without them the
        errors are scaled by the residual variance chi^2/dof.
    """
    x, y, err = _fit_arrays(X, psi0, psi0_err)
    weights = np.ones_like(x) if err is None else 1.0 / err

    def residuals(p: np.ndarray) -> np.ndarray:
        return (psi0_interpolation(x, p[0] + p[2], p[1], p[2]) - y) * weights

    low = x <= np.quantile(x, 1 / 3)
    if np.unique(x[low]).size < 2:
        low = np.argsort(x)[:2]
    slope, intercept = np.polyfit(x[low], y[low], 1)
    span = max(float(np.ptp(y)), 1e-3)
    c2_starts = [intercept, float(y.min()) - 0.1 * span]
    best = None
    for c2 in c2_starts:
        c0p = max(float(y.max()) - c2, 1e-3)
        for c1 in (abs(slope), abs(slope) * 3, abs(slope) / 3, c0p / float(np.median(x))):
            p0 = np.array([c0p, max(c1, 1e-3), c2])
            res = least_squares(residuals, p0, bounds=([1e-12, 0.0, -np.inf], np.inf),
                                method="trf", x_scale="jac")
            if best is None or res.cost < best.cost:
                best = res
    assert best is not None
    jac = best.jac
    dof = x.size - 3
    chi2_dof = float(2.0 * best.cost / dof)
    jtj = jac.T @ jac
    if np.linalg.matrix_rank(jtj) < 3:
        raise ValueError("X: the data do not determine C0, C1 and C2 (singular covariance); "
                         "spread the points over both the cone (X < 1) and sheet (X > 2) regimes")
    cov_p = np.linalg.inv(jtj) * (1.0 if err is not None else chi2_dof)
    to_c = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    cov = to_c @ cov_p @ to_c.T
    c0p, c1, c2 = best.x
    e = np.sqrt(np.diag(cov))
    return Psi0Fit(C0=float(c0p + c2), C1=float(c1), C2=float(c2), C0_err=float(e[0]),
                   C1_err=float(e[1]), C2_err=float(e[2]), covariance=_frozen(cov),
                   chi2_dof=chi2_dof, dof=dof, n_points=int(x.size),
                   absolute_sigma=err is not None)
