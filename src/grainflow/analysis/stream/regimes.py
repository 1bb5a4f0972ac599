"""Regimes of a cohesive granular stream: spray, clustering, droplets, dripping (SPEC A7), after
seed 000 (Waitukaitis et al., PRE 83, 051302 (2011)), Sec. III and Figs. 4-5.

The seed tells the regimes apart by the shape of the network-size profile N(z) below the
aperture and by the outflow:

* spray (F_c = 0): "N monotonically decreases toward unity";
* clustering (F_c below ~100 nN): "N first dips sharply as particles leave the hopper, but then
  undergoes a prolonged period of slow growth, after which it saturates at values less than
  ~30 grains";
* droplets (100-2000 nN): "N quickly increases to a peak value before settling down to its
  asymptotic value", with droplets of >= 30 grains;
* dripping (largest F_c): "there is no longer a steady outflow from the aperture ... large
  aggregates of grains slowly ooze through the aperture".

The seed gives no numerical criteria; :class:`RegimeThresholds` holds ours. From the network
size profile restricted to depth > ``min_depth`` (default 0, below the aperture), bins with
data only:

* N_inf: the asymptote, the count-weighted mean of the deepest ``tail_bins`` bins (or, when
  ``asymptote_depth`` is given, the bin containing it, like N_inf = N(20 cm));
* N_peak: the largest N above the tail (shallower than its first bin), at depth z_peak;
* N_min: the smallest N above the tail, at z_min;
* growth = N_inf / N_min (regrowth after the dip), drop = N_peak / N_inf (fall after the peak).

Rules, in order:

1. dripping if ``outflow_cv`` (coefficient of variation of the outflow rate over time windows,
   :func:`outflow_steadiness`) is given and exceeds ``max_outflow_cv`` (default 0.5), or is
   infinite (no outflow at all);
2. droplets if droplets are present (``droplet_count`` > 0; when it is not given: N_peak >=
   ``droplet_min_grains`` = 30, i.e. the mean grain sits in a network that large) and the
   profile falls after its peak, drop >= ``min_drop`` (default 1.5), and either rises to that
   peak from its minimum (z_peak > z_min) or does not regrow after its minimum (growth <
   ``min_growth``): a first-bin maximum followed by a dip and regrowth is clustering;
3. spray if the profile does not regrow, growth < ``min_growth`` (default 1.2), and its
   asymptote is near one, N_inf < ``spray_max`` (default 2);
4. clustering otherwise (dip, regrowth, saturation; or persistent small aggregates).

The decision keeps every number it was made on (:class:`RegimeDecision`).

Outflow steadiness (:func:`outflow_steadiness`): grains (matched by stable id between
consecutive frames) that cross the plane at ``crossing_depth`` below the aperture (default one
grain diameter) downward between two frames; the rate of each frame interval is
crossings / dt; intervals are grouped ``window`` at a time and the coefficient of variation
CV = std / mean of the window rates (std with ddof = 1) measures unsteadiness (infinite when
nothing flows). Frames should be equally spaced and closer than the time a grain takes to
fall past the plane.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass, field

import numpy as np

from grainflow.analysis.stream._common import (DepthProfile, _count, _each_frame, _finite,
                                               _frame_diameter, _frozen, _grain_mask,
                                               _positive, profile_value_at)
from grainflow.analysis.stream.networks import ContactProfiles
from grainflow.frame import Frame

__all__ = ["REGIMES", "RegimeThresholds", "RegimeDecision", "classify_regime",
           "OutflowSteadiness", "outflow_steadiness"]

#: Regime names, from the least to the most cohesive.
REGIMES = ("spray", "clustering", "droplets", "dripping")


@dataclass(frozen=True)
class RegimeThresholds:
    """Thresholds of :func:`classify_regime` (module docstring; the seed gives none)."""

    max_outflow_cv: float = 0.5
    droplet_min_grains: int = 30
    min_drop: float = 1.5
    min_growth: float = 1.2
    spray_max: float = 2.0
    tail_bins: int = 3
    asymptote_depth: float | None = None
    min_depth: float = 0.0

    def __post_init__(self) -> None:
        for name in ("max_outflow_cv", "min_drop", "min_growth", "spray_max"):
            _positive(name, getattr(self, name))
        _count("droplet_min_grains", self.droplet_min_grains, 1)
        _count("tail_bins", self.tail_bins, 1)
        _finite("min_depth", self.min_depth)
        if self.asymptote_depth is not None:
            _finite("asymptote_depth", self.asymptote_depth)


@dataclass(frozen=True, kw_only=True)
class RegimeDecision:
    """Outcome of :func:`classify_regime`: the regime, the rule that decided it and the
    numbers (NaN where not computed)."""

    regime: str
    reason: str
    n_start: float
    n_peak: float
    peak_depth: float
    n_min: float
    min_depth: float
    n_inf: float
    growth: float
    drop: float
    droplets_present: bool
    droplet_count: int | None
    outflow_cv: float | None
    thresholds: RegimeThresholds = field(default_factory=RegimeThresholds)

    def numbers(self) -> dict[str, float | int | bool | str | None]:
        """The decision as a flat dict (thresholds prefixed ``threshold_``)."""
        out = {k: v for k, v in asdict(self).items() if k != "thresholds"}
        out.update({f"threshold_{k}": v for k, v in asdict(self.thresholds).items()})
        return out


def classify_regime(
    network_size: DepthProfile | ContactProfiles,
    *,
    droplet_count: int | None = None,
    outflow_cv: float | None = None,
    thresholds: RegimeThresholds | None = None,
) -> RegimeDecision:
    """Classify a stream as spray, clustering, droplets or dripping (rules in the module
    docstring).

    Parameters
    ----------
    network_size : the network-size profile N(z) (or :class:`ContactProfiles`).
    droplet_count : droplets of >= 30 grains found below the aperture (e.g. the total of
        :func:`~grainflow.analysis.stream.find_droplets` with ``min_depth=0`` over the
        frames); None infers their presence from N_peak.
    outflow_cv : coefficient of variation of the outflow (:func:`outflow_steadiness`); None
        skips the dripping test.
    thresholds : :class:`RegimeThresholds` (default values when None).
    """
    th = RegimeThresholds() if thresholds is None else thresholds
    if not isinstance(th, RegimeThresholds):
        raise ValueError(f"thresholds: expected RegimeThresholds, got {type(th).__name__}")
    if isinstance(network_size, ContactProfiles):
        network_size = network_size.network_size
    if not isinstance(network_size, DepthProfile):
        raise ValueError(f"network_size: expected a DepthProfile or ContactProfiles, got "
                         f"{type(network_size).__name__}")
    count = None if droplet_count is None else _count("droplet_count", droplet_count, 0)
    cv = None
    if outflow_cv is not None:
        cv = float(outflow_cv)
        if not (cv >= 0):
            raise ValueError(f"outflow_cv: expected a number >= 0 (or inf), got {outflow_cv!r}")

    p = network_size
    ok = (p.centres > th.min_depth) & (p.count > 0) & np.isfinite(p.mean)
    z, n, w = p.centres[ok], p.mean[ok], p.count[ok].astype(float)
    if z.size < th.tail_bins + 2:
        raise ValueError(f"network_size: need at least {th.tail_bins + 2} bins with data "
                         f"below depth {th.min_depth:g} m to classify, got {z.size}; use "
                         "narrower bins or follow the stream deeper")
    if th.asymptote_depth is not None:
        n_inf = profile_value_at(p, th.asymptote_depth).value
        tail_start = float(p.edges[np.searchsorted(p.edges, th.asymptote_depth, "right") - 1])
    else:
        n_inf = float(np.sum(w[-th.tail_bins:] * n[-th.tail_bins:]) / w[-th.tail_bins:].sum())
        tail_start = float(z[-th.tail_bins])
    head = z < tail_start
    if not np.any(head):
        raise ValueError("thresholds: asymptote_depth leaves no bin above it")
    zh, nh = z[head], n[head]
    k_peak, k_min = int(np.argmax(nh)), int(np.argmin(nh))
    n_peak, n_min = float(nh[k_peak]), float(nh[k_min])
    growth = n_inf / n_min if n_min > 0 else float("inf")
    drop = n_peak / n_inf if n_inf > 0 else float("inf")
    present = (count > 0) if count is not None else n_peak >= th.droplet_min_grains

    def decide(regime: str, reason: str) -> RegimeDecision:
        return RegimeDecision(regime=regime, reason=reason, n_start=float(n[0]),
                              n_peak=n_peak, peak_depth=float(zh[k_peak]), n_min=n_min,
                              min_depth=float(zh[k_min]), n_inf=n_inf, growth=growth,
                              drop=drop, droplets_present=bool(present), droplet_count=count,
                              outflow_cv=cv, thresholds=th)

    if cv is not None and cv > th.max_outflow_cv:
        return decide("dripping", f"outflow CV {cv:.3g} > {th.max_outflow_cv:g}: no steady "
                      "outflow")
    rises = bool(zh[k_peak] > zh[k_min])
    if present and drop >= th.min_drop and (rises or growth < th.min_growth):
        return decide("droplets", f"N rises to a peak {n_peak:.3g} at {zh[k_peak]:.3g} m and "
                      f"falls to N_inf = {n_inf:.3g} (drop {drop:.3g} >= {th.min_drop:g}); "
                      "droplets present")
    if growth < th.min_growth and n_inf < th.spray_max:
        return decide("spray", f"no regrowth (N_inf / N_min = {growth:.3g} < "
                      f"{th.min_growth:g}) and N_inf = {n_inf:.3g} < {th.spray_max:g}")
    return decide("clustering", f"N dips to {n_min:.3g} and saturates at N_inf = {n_inf:.3g} "
                  f"(growth {growth:.3g})")


@dataclass(frozen=True, kw_only=True)
class OutflowSteadiness:
    """Outflow through a plane below the aperture (:func:`outflow_steadiness`).

    Attributes
    ----------
    times : (K,) mid-times of the frame intervals; rates : (K,) crossings / dt (grains/s).
    window_rates : (W,) mean rate of each window of ``window`` intervals.
    mean_rate : total crossings / total time; cv : std / mean of window_rates (inf when
        the mean is 0, NaN with fewer than 2 windows).
    crossing_depth : the plane's depth (m).
    """

    times: np.ndarray
    rates: np.ndarray
    window_rates: np.ndarray
    mean_rate: float
    cv: float
    crossing_depth: float
    window: int


def outflow_steadiness(
    frames: Frame | Iterable[Frame],
    *,
    crossing_depth: float | None = None,
    window: int = 5,
    grain_type: int | None = 0,
) -> OutflowSteadiness:
    """Outflow rate through the plane ``crossing_depth`` below the aperture (default one grain
    diameter) between consecutive frames, and its coefficient of variation over windows of
    ``window`` frame intervals (module docstring)."""
    w = _count("window", window, 1)
    h = None if crossing_depth is None else _finite("crossing_depth", crossing_depth)
    times: list[float] = []
    rates: list[float] = []
    durations: list[float] = []
    crossings: list[int] = []
    prev: tuple[float, np.ndarray, np.ndarray] | None = None
    for frame in _each_frame(frames):
        rows = _grain_mask(frame, grain_type)
        if h is None:
            h = _frame_diameter(np.asarray(frame.radius, dtype=float)[rows], None)
        ids = np.asarray(frame.id, dtype=np.int64)[rows]
        depth = -np.asarray(frame.position, dtype=float)[rows, 2]
        order = np.argsort(ids)
        cur = (float(frame.time), ids[order], depth[order])
        if prev is not None:
            dt = cur[0] - prev[0]
            if not dt > 0:
                raise ValueError("frames: times must increase from frame to frame")
            _, i_prev, i_cur = np.intersect1d(prev[1], cur[1], assume_unique=True,
                                                   return_indices=True)
            c = int(np.sum((prev[2][i_prev] < h) & (cur[2][i_cur] >= h)))
            times.append(0.5 * (prev[0] + cur[0]))
            rates.append(c / dt)
            durations.append(dt)
            crossings.append(c)
        prev = cur
    if not rates:
        raise ValueError("frames: need at least 2 frames to measure an outflow rate")
    assert h is not None
    n_win = len(rates) // w
    dur = np.array(durations)
    cr = np.array(crossings, dtype=float)
    win = np.array([cr[k * w:(k + 1) * w].sum() / dur[k * w:(k + 1) * w].sum()
                    for k in range(n_win)])
    mean = float(cr.sum() / dur.sum())
    if mean == 0:
        cv = float("inf")
    elif n_win < 2:
        cv = float("nan")
    else:
        cv = float(np.std(win, ddof=1) / np.mean(win)) if np.mean(win) > 0 else float("inf")
    return OutflowSteadiness(times=_frozen(times), rates=_frozen(rates),
                             window_rates=_frozen(win), mean_rate=mean, cv=cv,
                             crossing_depth=float(h), window=w)
