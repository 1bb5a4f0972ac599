"""Hopper-flow analyses (SPEC A8) after seed 003: Cheng et al., "Hopper flows of deformable
particles", Soft Matter 18, 8071 (2022), arXiv 2208.05581.

Pure functions of saved data:

* :func:`flow_rate_from_events` -- steady-state number rate dN/dt and area (2D) / volume (3D)
  flow rate Q from the times at which grains first crossed the orifice (the seed counts a grain
  as "out" the first time it leaves the orifice, Sec. 2.4), with the start-up transient cut by
  the MSER rule (:func:`mser_truncation`) and an error bar from block averages;
  :func:`flow_rate_from_cumulative` does the same from a cumulative count N(t).
* :func:`orifice_number_density` and :func:`overlap_corrected_flow_rate` -- the
  overlap-corrected flow rate Q' of the seed's Appendix B.
* :func:`fit_beverloo` -- Q = C (w/sigma_avg - k)^beta, seed eq. (1), with free or fixed beta.
* :func:`beta_sigmoid` and :func:`fit_beta_sigmoid` -- beta(lambda), seed eq. (14).

Units are those of the caller; the seed uses sigma_avg, t0 = sqrt(sigma_avg/g) and
Q0 = sigma_avg^d / t0. Results are frozen dataclasses holding read-only copies of arrays.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import curve_fit

from grainflow.analysis.checks import frozen as _frozen
from grainflow.analysis.coarse_grain import _unit_up
from grainflow.user_warnings import warn_user


def _as_1d(name: str, values: ArrayLike) -> np.ndarray:
    """``values`` as a finite 1-D float array, or ValueError naming ``name``."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite values; remove them first")
    return arr


# --------------------------------------------------------------------------------------------
# Flow rate from crossing events
# --------------------------------------------------------------------------------------------


def mser_truncation(series: ArrayLike) -> int:
    """Truncation point of a start-up transient by the MSER rule.

    MSER ("marginal standard error rule", White, Simulation 69, 323 (1997); MSER-5 in White,
    Cobb & Spratt, Proc. Winter Simulation Conf. 2000, 755, recommended by Hoad, Robinson &
    Davies, J. Oper. Res. Soc. 61, 1389 (2010)) drops the first ``d`` observations, with ``d``
    minimising the squared standard error of the mean of what remains::

        MSER(d) = 1/(n - d)^2 * sum_{i >= d} (x_i - mean(x[d:]))^2 ,   0 <= d <= n // 2.

    Dropping transient points removes their bias from the mean; dropping steady points only
    shrinks the sample, so the minimum balances bias against noise. The search stops at half the
    record because the statistic is meaningless for a short tail; a minimum at that boundary
    means the record may still be in transient, which is reported as a RuntimeWarning.

    Parameters
    ----------
    series : (n,) observations in time order, n >= 4 (e.g. a local rate in time bins).

    Returns
    -------
    d : the number of leading observations to discard.
    """
    x = _as_1d("series", series)
    n = x.shape[0]
    if n < 4:
        raise ValueError(f"series: MSER needs at least 4 observations, got {n}")
    suffix_sum = np.cumsum(x[::-1])[::-1]
    suffix_sq = np.cumsum((x * x)[::-1])[::-1]
    d = np.arange(n // 2 + 1)
    m = n - d
    spread = suffix_sq[d] - suffix_sum[d] ** 2 / m
    d_star = int(np.argmin(np.maximum(spread, 0.0) / m**2))
    if d_star == n // 2:
        warn_user(
            "mser_truncation: the MSER minimum lies at half the record; the transient may last "
            "longer than the record, so run longer before trusting the steady-state mean",
            RuntimeWarning,
        )
    return d_star


@dataclass(frozen=True)
class FlowRate:
    """Steady-state discharge measured from orifice-crossing events.

    Attributes
    ----------
    number_rate, number_rate_err : dN/dt in the steady window and the standard error of the
        mean of its ``n_blocks`` block rates.
    flow_rate, flow_rate_err : Q = (sum of grain areas/volumes crossing)/time in the window and
        its block standard error; NaN when no grain sizes were given.
    t_begin : start of the record.
    t_start, t_end : the steady window; ``t_start`` is where the detected transient ends.
    n_events : crossings inside the steady window.
    n_transient : crossings discarded as transient (``t_begin <= t < t_start``).
    n_blocks : number of equal-duration blocks the error bar comes from.
    block_number_rates, block_flow_rates : (n_blocks,) rates in each block.
    times : (N,) all crossing times of the record, sorted.
    sizes : (N,) the grain size of each crossing (NaN when not given).
    rate_bin_centres, local_rate : (n_bins,) the binned local rate dN/dt the transient rule
        (:func:`mser_truncation`) ran on.
    """

    number_rate: float
    number_rate_err: float
    flow_rate: float
    flow_rate_err: float
    t_begin: float
    t_start: float
    t_end: float
    n_events: int
    n_transient: int
    n_blocks: int
    block_number_rates: np.ndarray
    block_flow_rates: np.ndarray
    times: np.ndarray
    sizes: np.ndarray
    rate_bin_centres: np.ndarray
    local_rate: np.ndarray

    @property
    def transient_duration(self) -> float:
        """Length of the discarded start-up transient, ``t_start - t_begin``."""
        return self.t_start - self.t_begin


def _event_sizes(sizes: ArrayLike | float | None, n: int) -> np.ndarray:
    """Per-event grain sizes (n,), NaN when ``sizes`` is None; ValueError if not positive."""
    if sizes is None:
        return np.full(n, np.nan)
    arr = np.full(n, float(sizes)) if np.ndim(sizes) == 0 else _as_1d("sizes", sizes)
    if arr.shape != (n,):
        raise ValueError(f"sizes: expected one size per event ({n}), got shape {arr.shape}")
    if not np.all(np.isfinite(arr) & (arr > 0)):
        raise ValueError("sizes: grain areas/volumes must be finite and positive")
    return arr


def _block_rates(
    times: np.ndarray, sizes: np.ndarray, t_start: float, t_end: float, n_blocks: int
) -> tuple[np.ndarray, np.ndarray]:
    """Number rate and size rate in ``n_blocks`` equal blocks of [t_start, t_end]."""
    edges = np.linspace(t_start, t_end, n_blocks + 1)
    counts, _ = np.histogram(times, bins=edges)
    size_sums, _ = np.histogram(times, bins=edges, weights=sizes)
    width = (t_end - t_start) / n_blocks
    return counts / width, size_sums / width


def _mean_and_sem(values: np.ndarray) -> tuple[float, float]:
    return float(values.mean()), float(values.std(ddof=1) / np.sqrt(values.size))


def flow_rate_from_events(
    times: ArrayLike,
    sizes: ArrayLike | float | None = None,
    *,
    t_begin: float | None = None,
    t_end: float | None = None,
    t_steady: float | None = None,
    n_blocks: int = 10,
    n_bins: int = 50,
) -> FlowRate:
    """Steady-state flow rate from the times grains first crossed the orifice.

    The seed (Sec. 2.4) counts a grain as discharged the first time it exits the orifice and
    measures the area (2D) or volume (3D) flow rate Q in units Q0 = sigma_avg^d / t0. Here::

        dN/dt = n_events / (t_end - t_start),
        Q     = sum_{t_start <= t_i <= t_end} s_i / (t_end - t_start)

    with s_i the area/volume of the grain of event i.

    Transient: the record [t_begin, t_end] is cut into ``n_bins`` equal time bins and the series
    of local rates (count / bin width) is truncated by the MSER rule (:func:`mser_truncation`);
    ``t_start`` is the left edge of the first kept bin. The bins are MSER's batch means: MSER
    weighs the bias of a slow transient spread over many fine bins too lightly (it sees
    sum b_i^2 where the mean suffers (sum b_i)^2), so the bins are coarse, 50 over the record by
    default, which on synthetic Poisson records with an exponential start-up of time tau cuts
    at 3-5 tau and leaves no bias beyond the error bar while tau <= T/50. Pass ``t_steady`` to
    impose the start of the steady state instead.

    Error bar: the steady window is split into ``n_blocks`` equal-duration blocks; the rates are
    the block means' average and the error the standard error of the block means,
    std(ddof=1)/sqrt(n_blocks). Blocks must be longer than the correlation time of the flow
    (intermittent arches); 10 blocks of a long run satisfy this in practice.

    Parameters
    ----------
    times : (N,) crossing times (any order); events outside [t_begin, t_end] are ignored.
    sizes : (N,) area/volume of each crossing grain, or one value for all; None gives NaN Q.
    t_begin : start of the record (default: first event). Give the time the orifice opened so
        that a delay before the first crossing counts as transient.
    t_end : end of the record (default: last event).
    t_steady : impose the start of the steady window, skipping transient detection.
    n_blocks : number of blocks for the error bar, >= 2.
    n_bins : number of bins of the local-rate series MSER runs on, >= 4.
    """
    t_all = _as_1d("times", times)
    s_all = _event_sizes(sizes, t_all.size)
    if n_blocks < 2:
        raise ValueError(f"n_blocks: need at least 2 blocks for an error bar, got {n_blocks}")
    if n_bins < 4:
        raise ValueError(f"n_bins: MSER needs at least 4 bins, got {n_bins}")
    min_events = 10 * n_blocks
    if t_all.size < min_events:
        raise ValueError(
            f"times: need at least {min_events} crossing events for n_blocks={n_blocks}, got "
            f"{t_all.size}; run longer or lower n_blocks"
        )
    order = np.argsort(t_all, kind="stable")
    t_all, s_all = t_all[order], s_all[order]
    t0 = float(t_all[0]) if t_begin is None else float(t_begin)
    t1 = float(t_all[-1]) if t_end is None else float(t_end)
    if not t1 > t0:
        raise ValueError(f"t_begin/t_end: need t_begin < t_end, got {t0} and {t1}")
    keep = (t_all >= t0) & (t_all <= t1)
    t_rec, s_rec = t_all[keep], s_all[keep]
    if t_rec.size < min_events:
        raise ValueError(
            f"times: only {t_rec.size} events inside [t_begin, t_end]; need {min_events}"
        )

    edges = np.linspace(t0, t1, n_bins + 1)
    local_rate = np.histogram(t_rec, bins=edges)[0] / (edges[1] - edges[0])
    if t_steady is None:
        t_start = float(edges[mser_truncation(local_rate)])
    elif t0 <= t_steady < t1:
        t_start = float(t_steady)
    else:
        raise ValueError(f"t_steady: must lie in [t_begin, t_end) = [{t0}, {t1}), got {t_steady}")

    in_window = t_rec >= t_start
    n_events = int(np.count_nonzero(in_window))
    if n_events < 2 * n_blocks:
        raise ValueError(
            f"times: the steady window [{t_start}, {t1}] holds {n_events} events, fewer than 2 "
            f"per block; run longer or lower n_blocks"
        )
    number_rates, size_rates = _block_rates(
        t_rec[in_window], s_rec[in_window], t_start, t1, n_blocks
    )
    number_rate, number_rate_err = _mean_and_sem(number_rates)
    flow_rate, flow_rate_err = _mean_and_sem(size_rates)
    return FlowRate(
        number_rate=number_rate,
        number_rate_err=number_rate_err,
        flow_rate=flow_rate,
        flow_rate_err=flow_rate_err,
        t_begin=t0,
        t_start=t_start,
        t_end=t1,
        n_events=n_events,
        n_transient=int(t_rec.size - n_events),
        n_blocks=n_blocks,
        block_number_rates=_frozen(number_rates),
        block_flow_rates=_frozen(size_rates),
        times=_frozen(t_rec),
        sizes=_frozen(s_rec),
        rate_bin_centres=_frozen(0.5 * (edges[:-1] + edges[1:])),
        local_rate=_frozen(local_rate),
    )


def flow_rate_from_cumulative(
    times: ArrayLike,
    counts: ArrayLike,
    cumulative_size: ArrayLike | None = None,
    **options: float | int | None,
) -> FlowRate:
    """:func:`flow_rate_from_events` for a sampled cumulative count N(t) (e.g. a thermo log).

    Each increment N(t_k) - N(t_{k-1}) becomes that many events at t_k, so the time resolution
    is the sampling interval, which must be short compared with a block. ``cumulative_size`` is
    the matching cumulative discharged area/volume; its increment is shared equally among the
    events of the sample. The record starts at ``times[0]`` (``counts[0]`` is the baseline).

    Parameters
    ----------
    times : (K,) increasing sample times.
    counts : (K,) non-decreasing cumulative number of grains that crossed the orifice.
    cumulative_size : (K,) non-decreasing cumulative area/volume, optional.
    options : keyword arguments passed on to :func:`flow_rate_from_events`
        (``t_begin`` defaults to ``times[0]``).
    """
    t = _as_1d("times", times)
    n = _as_1d("counts", counts)
    if n.shape != t.shape or t.size < 2:
        raise ValueError(f"counts: need one count per sample time (>= 2), got {n.shape}, {t.shape}")
    if np.any(np.diff(t) <= 0):
        raise ValueError("times: sample times must be strictly increasing")
    increments = np.diff(n)
    if np.any(increments < 0) or np.any(increments != np.round(increments)):
        raise ValueError("counts: must be non-decreasing integers (a cumulative count)")
    increments = increments.astype(np.int64)
    event_times = np.repeat(t[1:], increments)
    sizes = None
    if cumulative_size is not None:
        s = _as_1d("cumulative_size", cumulative_size)
        if s.shape != t.shape:
            raise ValueError(f"cumulative_size: expected shape {t.shape}, got {s.shape}")
        size_increments = np.diff(s)
        if np.any((increments == 0) & (size_increments != 0)):
            raise ValueError("cumulative_size: grows at a sample where counts does not")
        counted = increments > 0
        per_event = size_increments[counted] / increments[counted]
        sizes = np.repeat(per_event, increments[counted])
    options.setdefault("t_begin", float(t[0]))
    return flow_rate_from_events(event_times, sizes, **options)  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------------
# Overlap-corrected flow rate Q' (seed Appendix B)
# --------------------------------------------------------------------------------------------


def orifice_number_density(
    positions: Sequence[np.ndarray],
    orifice_centre: ArrayLike,
    w: float,
    *,
    up: ArrayLike | None = None,
) -> tuple[float, float]:
    """Number density rho_n = N/A of grain centres in the region above the orifice.

    Seed 003, Appendix B / Fig. 11(b): "a 2w x w rectangular region near the hopper orifice"
    (the figure itself is lost in our copy). Reading taken: in 2D the rectangle spans 2w across
    the hopper, centred on the orifice, and w upwards from the orifice line (area 2 w^2). The 3D
    analogue (not in the seed) is the cylinder of diameter 2w and height w standing on the
    orifice (volume pi w^3).

    Parameters
    ----------
    positions : sequence of (N_f, dim) grain-centre arrays, one per frame (steady state).
    orifice_centre : (dim,) centre of the orifice.
    w : orifice width (2D) or diameter (3D), > 0.
    up : (dim,) direction against gravity (default +y in 2D, +z in 3D).

    Returns
    -------
    (rho_n, rho_n_err) : frame-averaged density and the standard error of the frame mean
        (frames treated as independent: space them by more than the flow's correlation time).
    """
    if len(positions) == 0:
        raise ValueError("positions: need at least one frame")
    if not w > 0:
        raise ValueError(f"w: the orifice width must be positive, got {w}")
    centre = np.asarray(orifice_centre, dtype=float)
    dim = centre.shape[0]
    if dim not in (2, 3):
        raise ValueError(f"orifice_centre: expected 2 or 3 components, got {centre.shape}")
    axis = _unit_up(up, dim)
    measure = 2.0 * w**2 if dim == 2 else np.pi * w**3
    densities = np.empty(len(positions))
    for f, pos in enumerate(positions):
        rel = np.asarray(pos, dtype=float).reshape(-1, dim) - centre
        height = rel @ axis
        lateral = np.linalg.norm(rel - np.outer(height, axis), axis=1)
        inside = (height >= 0) & (height <= w) & (lateral <= w)
        densities[f] = np.count_nonzero(inside) / measure
    err = densities.std(ddof=1) / np.sqrt(densities.size) if densities.size > 1 else np.nan
    return float(densities.mean()), float(err)


@dataclass(frozen=True)
class OverlapCorrectedFlowRate:
    """Q' of seed 003 Appendix B with the numbers it came from.

    Attributes
    ----------
    flow_rate, flow_rate_err : Q' = Q a_eff / a_avg and its propagated standard error.
    effective_size : a_eff = 1 / rho_n, the area (volume) per grain near the orifice.
    mean_grain_size : a_avg = (a_s + a_l)/2, the mean nominal grain area (volume).
    number_density, number_density_err : rho_n in the 2w x w region.
    """

    flow_rate: float
    flow_rate_err: float
    effective_size: float
    mean_grain_size: float
    number_density: float
    number_density_err: float


def overlap_corrected_flow_rate(
    flow_rate: float,
    number_density: float,
    mean_grain_size: float,
    *,
    flow_rate_err: float = 0.0,
    number_density_err: float = 0.0,
) -> OverlapCorrectedFlowRate:
    """Overlap-corrected flow rate Q' of seed 003, Appendix B.

    The soft-particle model lets grains overlap, so counting nominal grain areas that cross the
    orifice (Q) overstates the area of space that flows out. The seed measures the number
    density rho_n = N/A in a 2w x w region above the orifice (:func:`orifice_number_density`),
    defines the effective grain area a_eff = 1/rho_n and the corrected rate::

        Q' = Q a_eff / a_avg = Q / (rho_n a_avg),        a_avg = (a_s + a_l)/2.

    (OCR of the seed: "a_eff = 1/rho_n, and the corrected area flow rate is
    Q' = Q a_eff/a_avg"; taken literally.) For a bidisperse 50:50 flow Q = a_avg dN/dt, so
    Q' = (dN/dt)/rho_n: the area swept by the grains, voids included. When overlaps do not
    depend on w the factor is constant and only C changes; the seed finds beta' = beta there
    and a shifted beta' for very soft grains (E_sp = 20). Errors are propagated in quadrature.

    Parameters
    ----------
    flow_rate : Q, e.g. ``FlowRate.flow_rate``.
    number_density : rho_n, > 0.
    mean_grain_size : a_avg (2D area, 3D volume), > 0.
    flow_rate_err, number_density_err : standard errors, >= 0.
    """
    if not number_density > 0:
        raise ValueError(f"number_density: must be positive, got {number_density}")
    if not mean_grain_size > 0:
        raise ValueError(f"mean_grain_size: must be positive, got {mean_grain_size}")
    if flow_rate_err < 0 or number_density_err < 0:
        raise ValueError("flow_rate_err/number_density_err: standard errors must be >= 0")
    effective_size = 1.0 / number_density
    corrected = flow_rate * effective_size / mean_grain_size
    rel_err = np.hypot(
        flow_rate_err / flow_rate if flow_rate != 0 else 0.0, number_density_err / number_density
    )
    return OverlapCorrectedFlowRate(
        flow_rate=float(corrected),
        flow_rate_err=float(abs(corrected) * rel_err),
        effective_size=float(effective_size),
        mean_grain_size=float(mean_grain_size),
        number_density=float(number_density),
        number_density_err=float(number_density_err),
    )


# --------------------------------------------------------------------------------------------
# Beverloo fit, seed eq. (1)
# --------------------------------------------------------------------------------------------


def beverloo(x: ArrayLike, C: float, k: float, beta: float) -> np.ndarray:
    """Beverloo law, seed 003 eq. (1): Q = C (x - k)^beta with x = w/sigma_avg (0 for x <= k)."""
    return C * np.clip(np.asarray(x, dtype=float) - k, 0.0, None) ** beta


@dataclass(frozen=True)
class BeverlooFit:
    """Least-squares fit of Q = C (w/sigma_avg - k)^beta.

    Attributes
    ----------
    C, k, beta : fitted (or, for ``beta``, imposed) parameters.
    C_err, k_err, beta_err : standard uncertainties, sqrt of the covariance diagonal
        (``beta_err`` is 0 when beta was fixed).
    beta_fixed : whether beta was imposed.
    covariance : (p, p) covariance of the free parameters in the order (C, k[, beta]).
    chi2, dof : sum of squared (weighted) residuals and M - p.
    x : (M,) w/sigma_avg of the data; Q, Q_err : (M,) data (Q_err NaN when not given).
    at_bound : the parameters (``"k"``, ``"beta"``) that ended on a bound of a bounded fit.
    """

    C: float
    k: float
    beta: float
    C_err: float
    k_err: float
    beta_err: float
    beta_fixed: bool
    covariance: np.ndarray
    chi2: float
    dof: int
    x: np.ndarray
    Q: np.ndarray
    Q_err: np.ndarray
    at_bound: tuple[str, ...] = ()

    def predict(self, x: ArrayLike) -> np.ndarray:
        """Q from the fitted law at x = w/sigma_avg."""
        return beverloo(x, self.C, self.k, self.beta)


def _beverloo_start(
    x: np.ndarray, Q: np.ndarray, weights: np.ndarray, beta: float | None
) -> tuple[float, float, float]:
    """Starting (C, k, beta): scan k below min(x), linear fit of log Q on log(x - k) for each."""
    span = max(float(x.max() - x.min()), float(x.min()), 1.0)
    k_grid = np.concatenate([[0.0], x.min() - span * np.geomspace(1e-3, 2.0, 80)])
    k_grid = k_grid[k_grid < x.min()]
    log_q = np.log(Q)
    best: tuple[float, float, float, float] | None = None
    for k in k_grid:
        log_x = np.log(x - k)
        if beta is None:
            slope, intercept = np.polyfit(log_x, log_q, 1, w=weights)
        else:
            slope = beta
            intercept = np.average(log_q - beta * log_x, weights=weights**2)
        resid = np.sum((weights * (log_q - intercept - slope * log_x)) ** 2)
        if slope > 0 and (best is None or resid < best[0]):
            best = (resid, float(np.exp(intercept)), float(k), float(slope))
    if best is None:
        raise ValueError("Q: the flow rate does not grow with w; cannot fit the Beverloo law")
    return best[1], best[2], best[3]


def fit_beverloo(
    w: ArrayLike,
    Q: ArrayLike,
    *,
    sigma_avg: float = 1.0,
    Q_err: ArrayLike | None = None,
    beta: float | None = None,
    beta_bounds: tuple[float, float] | None = None,
    k_min: float | None = None,
) -> BeverlooFit:
    """Fit the Beverloo law Q = C (w/sigma_avg - k)^beta (seed 003 eq. (1), Figs. 2-3).

    Weighted non-linear least squares (:func:`scipy.optimize.curve_fit`, trust-region
    reflective with bounds C > 0, 0 < beta <= 10, k < min(w/sigma_avg) so every point lies
    above the offset). With ``Q_err`` the errors are taken as absolute (``absolute_sigma=True``)
    and the uncertainties are the sqrt of the covariance diagonal; without, the covariance is
    scaled by chi2/dof. Starting values come from a scan over k of linear fits of
    log Q = log C + beta log(w/sigma_avg - k). k and beta are strongly correlated, so give
    widths spanning a decade of w/sigma_avg - k where possible.

    Parameters
    ----------
    w : (M,) orifice widths (2D) / diameters (3D), > 0.
    Q : (M,) flow rates, > 0 (drop clogged widths, Q = 0, before fitting).
    sigma_avg : mean grain diameter, so that x = w / sigma_avg.
    Q_err : (M,) standard errors of Q, > 0 (e.g. ``FlowRate.flow_rate_err``).
    beta : impose the exponent and fit only C and k (e.g. beta = d - 1/2).
    beta_bounds, k_min : a bounded fit, ``beta_bounds[0] <= beta <= beta_bounds[1]`` and
        ``k >= k_min``: how the seed's authors fitted beta(lambda) (beta <= 1.58 and k >= 0.5
        in 2D, 1.5 <= beta <= 2.5 in 3D; docs/hopper_study.md). A parameter that ends on its bound
        is reported with the uncertainty of the local curvature; see :attr:`BeverlooFit.at_bound`.
    """
    w_arr, q_arr = _as_1d("w", w), _as_1d("Q", Q)
    if q_arr.shape != w_arr.shape:
        raise ValueError(f"Q: expected one flow rate per width {w_arr.shape}, got {q_arr.shape}")
    if not sigma_avg > 0:
        raise ValueError(f"sigma_avg: must be positive, got {sigma_avg}")
    if np.any(w_arr <= 0):
        raise ValueError("w: orifice widths must be positive")
    if np.any(q_arr <= 0):
        raise ValueError("Q: flow rates must be positive; drop clogged widths (Q = 0) first")
    if beta is not None and not 0 < beta <= 10:
        raise ValueError(f"beta: a fixed exponent must lie in (0, 10], got {beta}")
    if beta is not None and beta_bounds is not None:
        raise ValueError("beta_bounds: give a fixed beta or bounds on it, not both")
    beta_lo, beta_hi = (1e-6, 10.0) if beta_bounds is None else map(float, beta_bounds)
    if not 0 < beta_lo < beta_hi <= 10:
        raise ValueError(f"beta_bounds: {beta_bounds!r}; expected 0 < lower < upper <= 10")
    n_params = 3 if beta is None else 2
    if w_arr.size <= n_params:
        raise ValueError(
            f"w: need more than {n_params} orifice widths to fit {n_params} parameters with "
            f"uncertainties, got {w_arr.size}; add widths"
            + (" or fix beta" if beta is None else "")
        )
    if Q_err is None:
        err = None
    else:
        err = _as_1d("Q_err", Q_err)
        if err.shape != q_arr.shape or np.any(err <= 0):
            raise ValueError("Q_err: need one positive standard error per flow rate")
    x = w_arr / sigma_avg
    weights = q_arr / err if err is not None else np.ones_like(q_arr)  # 1/err of log Q
    c0, k0, b0 = _beverloo_start(x, q_arr, weights, beta)

    k_max = float(x.min()) * (1.0 - 1e-9)
    k_lo = -np.inf if k_min is None else float(k_min)
    if not k_lo < k_max:
        raise ValueError(f"k_min: {k_min!r} must lie below the smallest width {x.min():g}")
    if k0 <= k_lo:  # start inside the bounds
        k0 = k_lo + 0.01 * (k_max - k_lo)
    if beta is None:
        model = beverloo
        p0 = [c0, k0, float(np.clip(b0, beta_lo + 1e-9 * beta_hi, beta_hi * (1 - 1e-9)))]
        bounds = ([0.0, k_lo, beta_lo], [np.inf, k_max, beta_hi])
    else:
        def model(xx: np.ndarray, C: float, k: float) -> np.ndarray:
            return beverloo(xx, C, k, beta)

        p0 = [c0, k0]
        bounds = ([0.0, k_lo], [np.inf, k_max])
    popt, pcov = curve_fit(
        model, x, q_arr, p0=p0, sigma=err, absolute_sigma=err is not None, bounds=bounds,
        method="trf", x_scale="jac", max_nfev=20000,
    )
    resid = (q_arr - model(x, *popt)) / (err if err is not None else 1.0)
    perr = np.sqrt(np.diag(pcov))
    at_bound = tuple(name for name, value, lo, hi in (
        ("k", popt[1], k_lo, np.inf), ("beta", popt[2] if beta is None else math.nan,
                                       beta_lo if beta_bounds else -np.inf,
                                       beta_hi if beta_bounds else np.inf))
        if np.isclose(value, lo, rtol=1e-6, atol=1e-9) or np.isclose(value, hi, rtol=1e-6,
                                                                      atol=1e-9))
    return BeverlooFit(
        C=float(popt[0]),
        k=float(popt[1]),
        beta=float(popt[2]) if beta is None else float(beta),
        C_err=float(perr[0]),
        k_err=float(perr[1]),
        beta_err=float(perr[2]) if beta is None else 0.0,
        beta_fixed=beta is not None,
        covariance=_frozen(pcov),
        chi2=float(np.sum(resid**2)),
        dof=int(x.size - n_params),
        x=_frozen(x),
        Q=_frozen(q_arr),
        Q_err=_frozen(err if err is not None else np.full_like(q_arr, np.nan)),
        at_bound=at_bound,
    )


# --------------------------------------------------------------------------------------------
# beta(lambda) sigmoid, seed eq. (14)
# --------------------------------------------------------------------------------------------


def _sigmoid_limits(dim: int, limits: tuple[float, float] | None) -> tuple[float, float]:
    """(beta_0, beta_inf): eq. (14)'s d - 1/2 and d - 3/2 unless ``limits`` are given."""
    return (dim - 0.5, dim - 1.5) if limits is None else limits


def beta_sigmoid(lam: ArrayLike, lambda_c: float, b: float, dim: int,
                 limits: tuple[float, float] | None = None) -> np.ndarray:
    """Beverloo exponent versus lambda = zeta/mu, seed 003 eq. (14)::

        beta(lambda) = d - 1 - (1/2) tanh[ (1/b) log10(lambda / lambda_c) ].

    beta -> d - 1/2 as lambda -> 0 (kinetic friction only), d - 3/2 as lambda -> infinity
    (viscous drag only), and d - 1 at lambda = lambda_c; 1/b is the stretching exponent
    (0 < 1/b < 1 in the seed). Reading taken: the OCR of eq. (14) is garbled (it resembles
    "beta = (1/2)(d - tanh[log10(lambda/lambda_c)^(1/b)])", whose limits are right only in 2D);
    this form gives the limits and midpoint the seed states in both 2D and 3D (PARAMETERS.md).

    ``limits = (beta_0, beta_inf)`` puts other limits in place of d - 1/2 and d - 3/2 (the
    exponents a model measures at lambda = 0 and infinity):
    beta = (beta_0 + beta_inf)/2 - (beta_0 - beta_inf)/2 tanh[...], so that lambda_c stays the
    midpoint of the transition between the two regimes the model has.

    Parameters
    ----------
    lam : (M,) lambda values, > 0.
    lambda_c : midpoint, > 0.
    b : stretching parameter, > 0.
    dim : spatial dimension d (2 or 3).
    limits : (beta at lambda -> 0, beta at lambda -> infinity); None: the seed's.
    """
    beta_0, beta_inf = _sigmoid_limits(dim, limits)
    shape = np.tanh(np.log10(np.asarray(lam, dtype=float) / lambda_c) / b)
    return 0.5 * (beta_0 + beta_inf) - 0.5 * (beta_0 - beta_inf) * shape


#: |tanh argument| inside which eq. (14) lies between 10 % and 90 % of its way (tanh = 0.8).
_TRANSITION_HALF_WIDTH = math.atanh(0.8)


@dataclass(frozen=True)
class SigmoidFit:
    """Least-squares fit of seed eq. (14) to beta(lambda).

    Attributes
    ----------
    lambda_c, lambda_c_err : midpoint and its standard uncertainty (propagated from log10).
    log10_lambda_c, log10_lambda_c_err : the parameter actually fitted.
    b, b_err : stretching parameter and its standard uncertainty.
    dim : spatial dimension d.
    covariance : (2, 2) covariance of (log10 lambda_c, b).
    chi2, dof : sum of squared (weighted) residuals and M - 2.
    lam, beta, beta_err : (M,) the data (beta_err NaN when not given).
    limits : the sigmoid's (beta_0, beta_inf); None: eq. (14)'s d - 1/2 and d - 3/2.
    """

    lambda_c: float
    lambda_c_err: float
    log10_lambda_c: float
    log10_lambda_c_err: float
    b: float
    b_err: float
    dim: int
    covariance: np.ndarray
    chi2: float
    dof: int
    lam: np.ndarray
    beta: np.ndarray
    beta_err: np.ndarray
    limits: tuple[float, float] | None = None

    def predict(self, lam: ArrayLike) -> np.ndarray:
        """beta(lambda) from the fitted sigmoid."""
        return beta_sigmoid(lam, self.lambda_c, self.b, self.dim, self.limits)

    @property
    def levels(self) -> tuple[float, float, float]:
        """(beta_0, midpoint, beta_inf) of the sigmoid."""
        beta_0, beta_inf = _sigmoid_limits(self.dim, self.limits)
        return beta_0, 0.5 * (beta_0 + beta_inf), beta_inf

    def _log_offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """The distinct sampled lambdas and log10(lambda / lambda_c) / b of each: the tanh
        argument."""
        lam = np.unique(self.lam)
        return lam, np.log10(lam / self.lambda_c) / self.b

    @property
    def transition_lambdas(self) -> np.ndarray:
        """The distinct sampled lambdas inside the transition, where the sigmoid has gone
        between 10 % and 90 % of its way from one limit to the other
        (|log10(lambda/lambda_c)| < atanh(0.8) b)."""
        lam, x = self._log_offsets()
        return lam[np.abs(x) < _TRANSITION_HALF_WIDTH]

    @property
    def resolved(self) -> bool:
        """Whether the data place lambda_c: at least two distinct sampled lambdas inside the
        transition. With fewer, the best fit narrows to a step (b at or near its bound)
        pinned to a sample, and ``lambda_c_err``, read off the fit's curvature, means nothing
        (a 3D sweep whose beta falls from 3.1 to 1.7 between lambda = 0.05 and 0.18 gave
        0.1806 ± 0.0002 with b = 0.001); :attr:`bracket` is then all the data say."""
        return self.transition_lambdas.size >= 2

    @property
    def bracket(self) -> tuple[float, float]:
        """The sampled lambdas that bound the transition: the largest below it and the
        smallest above it (0 and infinity where no sample lies on that side)."""
        lam, x = self._log_offsets()
        below, above = lam[x <= -_TRANSITION_HALF_WIDTH], lam[x >= _TRANSITION_HALF_WIDTH]
        return (float(below.max()) if below.size else 0.0,
                float(above.min()) if above.size else math.inf)


def fit_beta_sigmoid(
    lam: ArrayLike,
    beta: ArrayLike,
    *,
    dim: int,
    beta_err: ArrayLike | None = None,
    limits: tuple[float, float] | None = None,
) -> SigmoidFit:
    """Fit lambda_c and b of seed 003 eq. (14) (:func:`beta_sigmoid`) to beta(lambda) (Fig. 4).

    log10(lambda_c) and b are fitted (curve_fit, trust-region reflective, b in [1e-3, 1e3]);
    lambda_c_err = ln(10) lambda_c sigma_log10. With ``beta_err`` (e.g. ``BeverlooFit.beta_err``)
    the errors are absolute; without, the covariance is scaled by chi2/dof. Starting values come
    from a grid over (log10 lambda_c, b). The pure limits lambda = 0 and infinity carry no
    information on lambda_c or b and cannot be placed on a log axis; leave them out. Where
    fewer than two sampled lambdas fall inside the transition the data do not place lambda_c
    (:attr:`SigmoidFit.resolved` is False): quote :attr:`SigmoidFit.bracket` then, not
    lambda_c ± lambda_c_err.

    Parameters
    ----------
    lam : (M,) finite lambda = zeta/mu values, > 0; M >= 3.
    beta : (M,) fitted Beverloo exponents.
    dim : spatial dimension d (2 or 3).
    beta_err : (M,) standard errors of beta, > 0.
    limits : (beta_0, beta_inf) in place of eq. (14)'s d - 1/2 and d - 3/2, e.g. the
        exponents measured at lambda = 0 and infinity; they must differ.
    """
    lam_arr, beta_arr = _as_1d("lam", lam), _as_1d("beta", beta)
    if limits is not None:
        limits = (float(limits[0]), float(limits[1]))
        if not (np.all(np.isfinite(limits)) and limits[0] != limits[1]):
            raise ValueError(f"limits: need two different finite exponents, got {limits}")
    if beta_arr.shape != lam_arr.shape:
        raise ValueError(f"beta: expected one exponent per lambda {lam_arr.shape}")
    if dim not in (2, 3):
        raise ValueError(f"dim: must be 2 or 3, got {dim}")
    if np.any(lam_arr <= 0):
        raise ValueError("lam: lambda must be positive and finite; drop the lambda = 0 limit")
    if lam_arr.size < 3:
        raise ValueError(f"lam: need at least 3 points to fit lambda_c and b, got {lam_arr.size}")
    if beta_err is None:
        err = None
    else:
        err = _as_1d("beta_err", beta_err)
        if err.shape != beta_arr.shape or np.any(err <= 0):
            raise ValueError("beta_err: need one positive standard error per exponent")

    def model(lam_: np.ndarray, log_lc: float, b: float) -> np.ndarray:
        return beta_sigmoid(lam_, 10.0**log_lc, b, dim, limits)

    w2 = 1.0 / err**2 if err is not None else np.ones_like(beta_arr)
    log_lam = np.log10(lam_arr)
    grid = [
        (lc, b)
        for lc in np.linspace(log_lam.min() - 1, log_lam.max() + 1, 41)
        for b in np.geomspace(0.1, 30, 25)
    ]
    sse = [np.sum(w2 * (beta_arr - model(lam_arr, lc, b)) ** 2) for lc, b in grid]
    p0 = grid[int(np.argmin(sse))]
    popt, pcov = curve_fit(
        model, lam_arr, beta_arr, p0=p0, sigma=err, absolute_sigma=err is not None,
        bounds=([-np.inf, 1e-3], [np.inf, 1e3]), method="trf", max_nfev=20000,
    )
    perr = np.sqrt(np.diag(pcov))
    lambda_c = 10.0 ** popt[0]
    resid = (beta_arr - model(lam_arr, *popt)) / (err if err is not None else 1.0)
    return SigmoidFit(
        lambda_c=float(lambda_c),
        lambda_c_err=float(np.log(10.0) * lambda_c * perr[0]),
        log10_lambda_c=float(popt[0]),
        log10_lambda_c_err=float(perr[0]),
        b=float(popt[1]),
        b_err=float(perr[1]),
        dim=dim,
        covariance=_frozen(pcov),
        chi2=float(np.sum(resid**2)),
        dof=int(lam_arr.size - 2),
        lam=_frozen(lam_arr),
        beta=_frozen(beta_arr),
        beta_err=_frozen(err if err is not None else np.full_like(beta_arr, np.nan)),
        limits=limits,
    )
