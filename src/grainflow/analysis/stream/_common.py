"""Shared helpers of :mod:`grainflow.analysis.stream`: input checks, frame access and the
depth profile (binned per-grain values averaged over frames).

Geometry (fixed, see :mod:`grainflow.scenarios.stream`): SI units, gravity along -z, the
aperture centred on the origin in the plane z = 0, *depth* = -z (positive below the aperture).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.checks import each_frame
from grainflow.analysis.checks import finite as _finite
from grainflow.analysis.checks import frozen as _frozen
from grainflow.analysis.checks import non_negative as _non_negative
from grainflow.analysis.checks import paired_arrays
from grainflow.analysis.checks import positive as _positive
from grainflow.frame import Frame
from grainflow.scenarios.stream import GRAVITY  # standard gravity (m/s^2), along -z

__all__ = ["GRAVITY", "DepthProfile", "ProfileValue", "depth_profile", "profile_value_at",
           "stream_grains"]



# --------------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------------


def _count(name: str, value: int, minimum: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)


def _positions(positions: ArrayLike, name: str = "positions") -> np.ndarray:
    """(N, 3) finite float array."""
    x = np.asarray(positions, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"{name}: expected an (N, 3) array of 3D centres, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return x


def _vectors_like(name: str, values: ArrayLike, n: int) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if v.shape != (n, 3):
        raise ValueError(f"{name}: expected shape ({n}, 3) like positions, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return v


def _radii(radii: ArrayLike, n: int) -> np.ndarray:
    """(N,) positive radii; a single number is broadcast."""
    r = np.asarray(radii, dtype=float)
    if r.ndim == 0:
        r = np.full(n, float(r))
    if r.shape != (n,):
        raise ValueError(f"radii: expected one number or shape ({n},) like positions, "
                         f"got {r.shape}")
    if not (np.all(np.isfinite(r)) and np.all(r > 0)):
        raise ValueError("radii: every radius must be finite and > 0")
    return r


def _each_frame(frames: Frame | Iterable[Frame]) -> Iterator[Frame]:
    return each_frame(frames, dim=3, who="the stream analyses")


def _grain_mask(frame: Frame, grain_type: int | None) -> np.ndarray:
    """(N,) mask of the grains: particles of type ``grain_type`` (None: every particle)."""
    if grain_type is None:
        return np.ones(frame.n, dtype=bool)
    return np.asarray(frame.type) == int(grain_type)


def _frame_diameter(radius: np.ndarray, diameter: float | None) -> float:
    """``diameter`` checked, or twice the median radius of the grains when None."""
    if diameter is not None:
        return _positive("diameter", diameter)
    if radius.size == 0:
        raise ValueError("diameter: cannot be taken from a frame without grains; pass it")
    return 2.0 * float(np.median(radius))


# --------------------------------------------------------------------------------------------
# Depth profiles
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class DepthProfile:
    """Per-grain values binned against depth and averaged over frames.

    Bins are ``[k w, (k + 1) w)`` in depth (w = ``bin_width``), so the aperture plane
    (depth 0) is always an edge; negative depths lie inside the hopper. The mean of a bin is
    the pooled mean over every grain sample of every frame that fell in it (the seed computes
    each quantity "for each grain" at frames a fixed interval apart and bins them). Its
    standard error treats frames as independent clusters of samples (the ratio-estimator /
    linearised jackknife error): with S_f and n_f the sum and count of frame f in the bin, m
    the pooled mean and F the number of frames,

        err = sqrt(F / (F - 1) * sum_f (S_f - m n_f)^2) / sum_f n_f,

    so it measures frame-to-frame scatter, not grain-to-grain scatter (grains of one frame are
    correlated). It is NaN when fewer than two frames have samples in the bin.

    With ``average="frames"`` the mean is instead the plain mean over the frames that have
    samples in the bin of each frame's bin mean S_f / n_f (every frame weighs the same,
    however many grains it put in the bin), and the error is their standard deviation
    (ddof = 1) over sqrt(frames_with_data). The two agree when every frame holds the same
    number of grains in the bin; pooling is the steadier one in sparse, deep bins.

    Attributes
    ----------
    quantity : what was binned (e.g. ``"contact number"``).
    bin_width : w in metres.
    edges : (B + 1,) bin edges in depth [m]; centres : (B,) bin centres.
    mean, err : (B,) mean and its standard error (NaN for empty bins).
    count : (B,) grain samples in each bin, all frames together.
    frames_with_data : (B,) frames that had at least one sample in the bin.
    n_frames : frames used.
    """

    quantity: str
    bin_width: float
    edges: np.ndarray
    centres: np.ndarray
    mean: np.ndarray
    err: np.ndarray
    count: np.ndarray
    frames_with_data: np.ndarray
    n_frames: int
    average: str = "pooled"

    def __len__(self) -> int:
        return int(self.centres.size)

    def scaled(self, factor: float, factor_err: float = 0.0, quantity: str | None = None
               ) -> DepthProfile:
        """The profile divided by ``factor`` (errors combined in quadrature with the relative
        error ``factor_err / factor``; correlations ignored)."""
        f = _positive("factor", factor)
        fe = _non_negative("factor_err", factor_err)
        mean = self.mean / f
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.sqrt((self.err / self.mean) ** 2 + (fe / f) ** 2)
        err = np.abs(mean) * rel
        err = np.where(self.mean == 0, self.err / f, err)
        return DepthProfile(quantity=quantity or f"{self.quantity} / {f:.4g}",
                            bin_width=self.bin_width, edges=self.edges, centres=self.centres,
                            mean=_frozen(mean), err=_frozen(err), count=self.count,
                            frames_with_data=self.frames_with_data, n_frames=self.n_frames,
                            average=self.average)


class _ProfileAccumulator:
    """Per-frame sums and counts on bins aligned at depth 0 (bin k = floor(depth / w))."""

    def __init__(self, quantity: str, bin_width: float,
                 depth_range: tuple[float, float] | None, average: str = "pooled") -> None:
        if average not in ("pooled", "frames"):
            raise ValueError(f"average: 'pooled' (every grain sample counts alike) or 'frames' "
                             f"(every frame counts alike), got {average!r}")
        self.average = average
        self.quantity = quantity
        self.w = _positive("bin_width", bin_width)
        if depth_range is not None:
            try:
                lo, hi = (float(depth_range[0]), float(depth_range[1]))
            except (TypeError, ValueError, IndexError):
                raise ValueError(f"depth_range: expected (min_depth, max_depth) in metres, got "
                                 f"{depth_range!r}") from None
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
                raise ValueError(f"depth_range: expected finite (min_depth, max_depth) with "
                                 f"min < max, got {depth_range!r}")
            depth_range = (lo, hi)
        self.range = depth_range
        self.frames: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, depths: np.ndarray, values: np.ndarray) -> None:
        depths = np.asarray(depths, dtype=float)
        values = np.asarray(values, dtype=float)
        keep = np.isfinite(depths) & np.isfinite(values)
        if self.range is not None:
            keep &= (depths >= self.range[0]) & (depths < self.range[1])
        k = np.floor(depths[keep] / self.w).astype(np.int64)
        bins, inverse = np.unique(k, return_inverse=True)
        n = np.bincount(inverse, minlength=bins.size).astype(float)
        s = np.bincount(inverse, weights=values[keep], minlength=bins.size)
        self.frames.append((bins, n, s))

    def result(self) -> DepthProfile:
        n_frames = len(self.frames)
        if n_frames == 0:
            raise ValueError("frames: no frames given")
        if self.range is not None:
            k_lo = int(np.floor(self.range[0] / self.w))
            k_hi = int(np.ceil(self.range[1] / self.w)) - 1
        else:
            ks = [b for b, _, _ in self.frames if b.size]
            if not ks:
                raise ValueError("frames: no grain samples to bin (empty frames, no particle "
                                 "of the grain type, or none that qualifies)")
            k_lo = int(min(b.min() for b in ks))
            k_hi = int(max(b.max() for b in ks))
        n_bins = k_hi - k_lo + 1
        counts = np.zeros((n_frames, n_bins))
        sums = np.zeros((n_frames, n_bins))
        for f, (bins, n, s) in enumerate(self.frames):
            counts[f, bins - k_lo] = n
            sums[f, bins - k_lo] = s
        total_n = counts.sum(axis=0)
        total_s = sums.sum(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = total_s / total_n
            resid = sums - mean * counts
            resid[:, total_n == 0] = 0.0
            frames_with = (counts > 0).sum(axis=0)
            err = (np.sqrt(n_frames / max(n_frames - 1, 1) * (resid ** 2).sum(axis=0))
                   / total_n)
        err = np.where(frames_with >= 2, err, np.nan)
        if self.average == "frames":
            has = counts > 0
            per_frame = np.where(has, sums / np.where(has, counts, 1.0), np.nan)
            mean = np.where(frames_with > 0, np.nansum(per_frame, axis=0)
                            / np.maximum(frames_with, 1), np.nan)
            dev2 = np.where(has, (per_frame - mean) ** 2, 0.0).sum(axis=0)
            err = np.where(frames_with >= 2, np.sqrt(dev2 / np.maximum(frames_with - 1, 1)
                                                     / np.maximum(frames_with, 1)), np.nan)
        edges = (np.arange(k_lo, k_hi + 2) * self.w).astype(float)
        return DepthProfile(quantity=self.quantity, bin_width=self.w, edges=_frozen(edges),
                            centres=_frozen(0.5 * (edges[:-1] + edges[1:])),
                            mean=_frozen(mean), err=_frozen(err),
                            count=_frozen(total_n, np.int64),
                            frames_with_data=_frozen(frames_with, np.int64), n_frames=n_frames,
                            average=self.average)


def depth_profile(
    depths: ArrayLike | Sequence[ArrayLike],
    values: ArrayLike | Sequence[ArrayLike],
    bin_width: float,
    *,
    depth_range: tuple[float, float] | None = None,
    quantity: str = "",
    average: str = "pooled",
) -> DepthProfile:
    """Bin per-grain ``values`` against ``depths`` and average over frames (:class:`DepthProfile`
    gives the mean and its error).

    Parameters
    ----------
    depths, values : one frame as two (N,) arrays, or several frames as two sequences of
        (N_f,) arrays (depth = -z in metres). Non-finite samples are skipped.
    bin_width : bin width in metres (seed 000: 1 mm for the contact number, 5 mm for the
        network size, 100 um for the velocity deviations).
    depth_range : (min, max) depths kept; bins cover it. Default: every sample, bins from the
        shallowest to the deepest one.
    quantity : name stored in the result.
    average : "pooled" (default: every grain sample counts alike) or "frames" (every frame
        counts alike); see :class:`DepthProfile`.
    """
    acc = _ProfileAccumulator(quantity, bin_width, depth_range, average)
    try:
        single = np.asarray(depths, dtype=float).ndim == 1
    except (TypeError, ValueError):  # ragged: one array per frame
        single = False
    if single:
        frames_d, frames_v = [depths], [values]
    else:
        frames_d, frames_v = list(depths), list(values)
        if len(frames_v) != len(frames_d):
            raise ValueError(f"values: expected {len(frames_d)} frames like depths, got "
                             f"{len(frames_v)}")
    for f, (d, v) in enumerate(zip(frames_d, frames_v)):
        acc.add(*paired_arrays(f"depths[{f}]", d, f"values[{f}]", v))
    return acc.result()


@dataclass(frozen=True, kw_only=True)
class ProfileValue:
    """The value of a profile in a depth band (see :func:`profile_value_at`).

    Attributes
    ----------
    value, err : count-weighted mean of the bins in the band and its standard error.
    depth : the depth asked for; depth_range : (lo, hi) edges of the bins used.
    count : grain samples in those bins.
    """

    value: float
    err: float
    depth: float
    depth_range: tuple[float, float]
    count: int


def profile_value_at(profile: DepthProfile, depth: float, half_width: float | None = None
                     ) -> ProfileValue:
    """Mean of ``profile`` around ``depth``: the bins whose centres lie within
    ``depth +- half_width`` (default: only the bin containing ``depth``), weighted by their
    sample counts; the error combines the bins' errors as independent,
    sqrt(sum (n_b err_b)^2) / sum n_b.

    Used for the saturation network size N_inf = N(z ~ 20 cm) (seed 000) and the mean contact
    number at 4 cm of the phase diagram.
    """
    if not isinstance(profile, DepthProfile):
        raise ValueError(f"profile: expected a DepthProfile, got {type(profile).__name__}")
    z = _finite("depth", depth)
    if half_width is None:
        sel = (profile.edges[:-1] <= z) & (z < profile.edges[1:])
    else:
        hw = _non_negative("half_width", half_width)
        sel = np.abs(profile.centres - z) <= hw + 1e-12 * profile.bin_width
    sel &= profile.count > 0
    if not np.any(sel):
        raise ValueError(f"depth: the profile has no samples around depth {z:g} m (its bins "
                         f"span {profile.edges[0]:g}..{profile.edges[-1]:g} m); choose a "
                         "depth inside it or a larger half_width")
    n = profile.count[sel].astype(float)
    value = float(np.sum(n * profile.mean[sel]) / n.sum())
    err = float(np.sqrt(np.sum((n * profile.err[sel]) ** 2)) / n.sum())
    idx = np.flatnonzero(sel)
    return ProfileValue(value=value, err=err, depth=z,
                        depth_range=(float(profile.edges[idx[0]]),
                                     float(profile.edges[idx[-1] + 1])),
                        count=int(n.sum()))


def stream_grains(frame: Frame, *, above: float = 0.0) -> Frame:
    """The frame restricted to the grains below the aperture plane (depth > ``-above``):
    the *stream*. Seed 000's network sizes are those of the stream's networks: measured on
    all grains, every grain near the aperture would belong to the whole hopper's packed bed
    (tens of thousands of grains, cohesive or not), and the seed's rise of N to a peak below
    the aperture (Fig. 6b) could not be seen. Contacts (``frame.contacts``) are dropped."""
    import dataclasses

    keep = frame.position[:, 2] < above
    extra = {k: v[keep] for k, v in frame.extra.items()
             if getattr(v, "shape", ())[:1] == (frame.n,)}
    return dataclasses.replace(
        frame, id=frame.id[keep], type=frame.type[keep], body=frame.body[keep],
        radius=frame.radius[keep], mass=frame.mass[keep], position=frame.position[keep],
        velocity=frame.velocity[keep], omega=frame.omega[keep], contacts=None,
        ring_vertex=None if frame.ring_vertex is None else frame.ring_vertex[keep],
        extra=extra)
