"""Adjacent droplets traced back through the stream to the aperture, as seed 000 measures
their separation (Sec. III: "identifying the grains which make up a fully formed droplet, we
measure the vertical distance between the centers of mass for adjacent droplets Delta z and
compute the separation velocity both in the free falling stream and inside the hopper").

Method (:func:`trace_droplet_pairs`). In an *identification* frame the droplets
(:func:`~grainflow.analysis.stream.droplets.find_droplets` of the stream's grains) deeper than
``min_depth`` are ordered by depth, and each two consecutive ones are a pair. The grains of
each droplet are then followed by id through every frame, inside the hopper as well as in the
stream, and in each frame where all of them are present

    Delta z(t) = depth of the lower droplet's grains' centre of mass
                 - depth of the upper droplet's grains' centre of mass.

The pair leaves the aperture at t0, when the mean of the two centres' depths crosses zero
(linear interpolation between frames), with spacing Delta z0 = Delta z(t0). Its *initial*
separation velocity Delta v0 is the slope of a least-squares line through Delta z(t) over
t0 <= t <= t0 + ``initial_window`` (the seed: the droplets "leave the aperture with a
separation velocity Delta v0"; after that "the increase in Delta v abruptly stops"), its
*final* one Delta v_f the slope over the last ``final_window`` of the trace (the seed: once
the droplets are no longer connected, Delta v "remains fixed at a final separation
velocity"). Both windows are ours (the seed does not give them).

Unlike the forward tracker (:func:`~grainflow.analysis.stream.droplets.droplet_separations`),
which extrapolates a line fitted far below the aperture back to it, Delta z0 here is
measured, so it is not correlated with the fitted slope; and the pair is the same two sets of
grains whatever the interval between frames.

Several identification frames may be given; a pair found again (both droplets sharing more
than half their grains with an earlier pair's) is kept once, as first found.

Separation gradient (:func:`fit_separation_gradient`, seed 000 Sec. III, the figure of
Delta v0 against F_c, pair size and Delta z0, panel (c)). The seed collapses the pairs'
Delta v0 against their Delta z0 and fits the free-fall form: "the fit yields 1.4 cm/s,
reasonably close to the value 1.7 cm/s predicted from just the free-fall velocity profile".
A number that the free-fall profile predicts without the droplets' spacings is the velocity
difference across one grain diameter at the aperture, g d / v0 (PARAMETERS.md infers
v0 = 11.5 cm/s from 1.7 cm/s and d = 200 um): the 1.4 cm/s is the fitted gradient, not a
mean separation velocity. Here the pairs' (Delta z0, Delta v0) are fitted by
Delta v0 = sqrt(V^2 + 2 g Delta z0) - V with V free (unweighted least squares; the exact
form, since spacings of many grains are not small against v0^2 / 2g), and the gradient is
A = g d / V, the fit's slope at Delta z0 -> 0 per grain diameter.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares
from scipy.stats import linregress

from grainflow.analysis.stream._common import (GRAVITY, _count, _each_frame, _frozen,
                                               _non_negative, _positive, paired_arrays,
                                               stream_grains)
from grainflow.analysis.stream.droplets import (SEED_MIN_GRAINS, Droplet, find_droplets,
                                                free_fall_separation_velocity)
from grainflow.frame import Frame

__all__ = ["TracedPair", "trace_droplet_pairs", "SeparationGradient", "fit_separation_gradient"]


@dataclass(frozen=True, kw_only=True)
class TracedPair:
    """Two adjacent droplets followed by their grains' ids (:func:`trace_droplet_pairs`).

    Attributes
    ----------
    upper_ids, lower_ids : sorted ids of the shallower and the deeper droplet's grains.
    identified_at : time of the frame where the droplets were found (s).
    times : (T,) frames where every grain of both is present; dz : (T,) Delta z (m);
    centre_depth : (T,) mean depth of the two centres of mass (m).
    t0 : when ``centre_depth`` crosses zero (NaN if it is already below the aperture in the
        first frame); dz0 : Delta z at t0.
    initial_velocity, initial_velocity_err : slope of Delta z over [t0, t0 + initial window]
        and its standard error (NaN with fewer than three frames there).
    final_velocity, final_velocity_err : the same over the trace's last final window.
    n_grains_mean : mean size of the two droplets.
    predicted_velocity : free fall, sqrt(v0^2 + 2 g dz0) - v0 (NaN without v0 or dz0).
    """

    upper_ids: np.ndarray
    lower_ids: np.ndarray
    identified_at: float
    times: np.ndarray
    dz: np.ndarray
    centre_depth: np.ndarray
    t0: float
    dz0: float
    initial_velocity: float
    initial_velocity_err: float
    final_velocity: float
    final_velocity_err: float
    n_grains_mean: float
    predicted_velocity: float


def _slope(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    if t.size < 3 or np.ptp(t) == 0:
        return float("nan"), float("nan")
    fit = linregress(t, y)
    return float(fit.slope), float(fit.stderr)


def _shares_most(a: np.ndarray, b: np.ndarray) -> bool:
    return np.intersect1d(a, b, assume_unique=True).size > 0.5 * max(a.size, b.size)


class _IdIndex:
    """Rows of a frame's particles by id (sorted once per frame)."""

    def __init__(self, frame: Frame) -> None:
        ids = np.asarray(frame.id, dtype=np.int64)
        self.order = np.argsort(ids, kind="stable")
        self.sorted_ids = ids[self.order]
        self.depth = -np.asarray(frame.position, dtype=float)[:, 2]
        self.time = float(frame.time)

    def mean_depth(self, ids: np.ndarray) -> float | None:
        """Mean depth of the grains ``ids``; None if any of them is not in the frame."""
        pos = np.minimum(np.searchsorted(self.sorted_ids, ids), self.sorted_ids.size - 1)
        if self.sorted_ids.size == 0 or not np.array_equal(self.sorted_ids[pos], ids):
            return None
        return float(self.depth[self.order[pos]].mean())


def _pairs_in(frame: Frame, delta: float, min_grains: int, min_depth: float,
              grain_type: int | None) -> list[tuple[Droplet, Droplet]]:
    drops = find_droplets(stream_grains(frame), delta, min_grains=min_grains,
                          min_depth=min_depth, grain_type=grain_type)
    return list(zip(drops, drops[1:]))


def trace_droplet_pairs(
    frames: Sequence[Frame],
    delta: float,
    *,
    identify: Sequence[int] = (-1,),
    min_grains: int = SEED_MIN_GRAINS,
    min_depth: float = 0.0,
    initial_window: float = 0.01,
    final_window: float = 0.02,
    v0: float | None = None,
    g: float = GRAVITY,
    grain_type: int | None = 0,
) -> list[TracedPair]:
    """Adjacent droplets found in the frames ``identify`` and traced through all ``frames``
    by their grains (module docstring).

    Parameters
    ----------
    frames : whole frames (the hopper's grains included) in increasing time order.
    delta : cohesive shell thickness (m), for the droplets' networks.
    identify : indices into ``frames`` of the identification frames.
    min_grains : smallest droplet (seed: 30).
    min_depth : only droplets whose centre is deeper than this (m) in the identification
        frame are paired (the seed's fully formed droplets are those below 20 cm).
    initial_window, final_window : spans (s) of the initial and final slope fits.
    v0 : the speed at the aperture (m/s), for the free-fall prediction.
    g : gravity (m/s^2).
    grain_type : particle type of the grains (None: every particle).

    Returns
    -------
    Pairs in the order found (identification frame, then depth).
    """
    items = [next(_each_frame(f)) for f in frames]
    if not items:
        raise ValueError("frames: expected at least one frame")
    times = np.array([f.time for f in items])
    if np.any(np.diff(times) <= 0):
        raise ValueError("frames: expected frames in increasing time order")
    k_min = _count("min_grains", min_grains, 2)
    depth_min = _non_negative("min_depth", min_depth)
    w0 = _positive("initial_window", initial_window)
    wf = _positive("final_window", final_window)
    v0_ = None if v0 is None else _non_negative("v0", v0)
    g_ = _positive("g", g)
    chosen = []
    for k in identify:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or \
                not -len(items) <= k < len(items):
            raise ValueError(f"identify: {k!r} is not an index into the {len(items)} frames")
        chosen.append(int(k) % len(items))
    found: list[tuple[Droplet, Droplet, float]] = []
    for k in chosen:
        for upper, lower in _pairs_in(items[k], delta, k_min, depth_min, grain_type):
            if not any(_shares_most(upper.ids, u.ids) and _shares_most(lower.ids, lo.ids)
                       for u, lo, _ in found):
                found.append((upper, lower, items[k].time))
    if not found:
        return []
    index = [_IdIndex(f) for f in items]
    out: list[TracedPair] = []
    for upper, lower, t_id in found:
        rows = []
        for ix in index:
            zu, zl = ix.mean_depth(upper.ids), ix.mean_depth(lower.ids)
            if zu is not None and zl is not None:
                rows.append((ix.time, zl - zu, 0.5 * (zu + zl)))
        arr = np.array(rows)
        t, dz, centre = arr[:, 0], arr[:, 1], arr[:, 2]
        t0 = dz0 = float("nan")
        below = np.flatnonzero(centre >= 0.0)
        if below.size and below[0] > 0:
            i = int(below[0])
            f = -centre[i - 1] / (centre[i] - centre[i - 1])
            t0 = float(t[i - 1] + f * (t[i] - t[i - 1]))
            dz0 = float(dz[i - 1] + f * (dz[i] - dz[i - 1]))
        early = (t >= t0) & (t <= t0 + w0) if np.isfinite(t0) else np.zeros(t.size, bool)
        v_init, e_init = _slope(t[early], dz[early])
        late = t >= t[-1] - wf
        v_final, e_final = _slope(t[late], dz[late])
        pred = float("nan")
        if v0_ is not None and np.isfinite(dz0) and v0_ ** 2 + 2.0 * g_ * dz0 >= 0:
            pred = float(free_fall_separation_velocity(dz0, v0_, g_))
        out.append(TracedPair(
            upper_ids=upper.ids, lower_ids=lower.ids, identified_at=t_id, times=_frozen(t),
            dz=_frozen(dz), centre_depth=_frozen(centre), t0=t0, dz0=dz0,
            initial_velocity=v_init, initial_velocity_err=e_init, final_velocity=v_final,
            final_velocity_err=e_final,
            n_grains_mean=0.5 * (upper.n_grains + lower.n_grains), predicted_velocity=pred))
    return out


# --------------------------------------------------------------------------------------------
# The free-fall fit over the pairs
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class SeparationGradient:
    """The free-fall fit of separation velocities against spacings at the aperture
    (:func:`fit_separation_gradient`).

    Attributes
    ----------
    speed, speed_err : V of Delta v0 = sqrt(V^2 + 2 g Delta z0) - V and its standard error
        (m/s): the aperture speed the separations imply.
    gradient, gradient_err : A = g d / V, the velocity difference across one grain diameter
        at the aperture (m/s; the seed's 1.4 cm/s), and its error.
    pairs : pairs fitted (finite, positive Delta z0 and finite Delta v0).
    rms_residual : root-mean-square residual of Delta v0 (m/s).
    """

    speed: float
    speed_err: float
    gradient: float
    gradient_err: float
    pairs: int
    rms_residual: float

    def predict(self, dz0: ArrayLike, g: float = GRAVITY) -> np.ndarray | float:
        """The fitted Delta v0 at spacings ``dz0`` (m)."""
        return free_fall_separation_velocity(dz0, self.speed, g)


def fit_separation_gradient(
    dz0: ArrayLike,
    dv0: ArrayLike,
    *,
    grain_diameter: float,
    g: float = GRAVITY,
) -> SeparationGradient:
    """Fit Delta v0 = sqrt(V^2 + 2 g Delta z0) - V to pairs' spacings ``dz0`` at the aperture
    (m) and separation velocities ``dv0`` (m/s), V free, and give the gradient A = g d / V
    (module docstring; seed 000, Sec. III). Pairs without a finite, positive spacing or a
    finite velocity are left out; at least two must remain."""
    d = _positive("grain_diameter", grain_diameter)
    g_ = _positive("g", g)
    z, v = paired_arrays("dz0", dz0, "dv0", dv0)
    keep = np.isfinite(z) & (z > 0) & np.isfinite(v)
    z, v = z[keep], v[keep]
    if z.size < 2:
        raise ValueError(f"dz0: need at least two pairs with a finite, positive spacing and a "
                         f"finite velocity, got {z.size}")
    if not np.any(v > 0):
        raise ValueError("dv0: no pair separates (every Delta v0 <= 0); the free-fall form has "
                         "no positive speed to fit")

    def residual(p: np.ndarray) -> np.ndarray:
        return np.sqrt(p[0] ** 2 + 2.0 * g_ * z) - p[0] - v

    # start from the linearised form, Delta v0 ~ g Delta z0 / V
    start = g_ * float(np.sum(z ** 2)) / float(np.sum(z * np.maximum(v, 0.0)))
    fit = least_squares(residual, x0=[start], bounds=([1e-9 * start], [np.inf]))
    speed = float(fit.x[0])
    rss = float(np.sum(fit.fun ** 2))
    jtj = float(fit.jac[:, 0] @ fit.jac[:, 0])
    speed_err = math.sqrt(rss / (z.size - 1) / jtj) if jtj > 0 else float("nan")
    gradient = g_ * d / speed
    return SeparationGradient(speed=speed, speed_err=speed_err, gradient=gradient,
                              gradient_err=gradient * speed_err / speed, pairs=int(z.size),
                              rms_residual=math.sqrt(rss / z.size))
