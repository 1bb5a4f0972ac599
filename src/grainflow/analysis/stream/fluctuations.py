"""Velocity deviations of a granular stream and their free-fall prediction (SPEC A6), after
seed 000 (Waitukaitis et al., PRE 83, 051302 (2011)), Sec. III and the Appendix.

Per-grain deviations. The seed defines "the mean squared velocity deviations <dv^2> for each
grain as the standard deviation of its velocity relative to the velocities of all other
neighbors within a small region, which we set at 1.5 d. If a grain has less than three
neighbors within this region it is excluded". Precisely, here: the neighbours of grain i are
the grains j != i with |r_j - r_i| < 1.5 d (``radius_factor`` d, strict <); grains with fewer
than ``min_neighbours`` = 3 neighbours get NaN and are excluded; for the others, with n_i the
number of neighbours,

    axial:       <dv_z^2>_i = (1/n_i) sum_j (v_j,z - v_i,z)^2
    transverse:  <dv_t^2>_i = (1/n_i) sum_j [(v_j,x - v_i,x)^2 + (v_j,y - v_i,y)^2] / 2
    total:       <|dv|^2>_i = (1/n_i) sum_j |v_j - v_i|^2 = <dv_z^2>_i + 2 <dv_t^2>_i

i.e. the mean square of the velocity *relative to grain i* (not about the neighbours' mean),
so that a uniform velocity gradient contributes (grad v . r_ij)^2 as in the seed's free-fall
estimate below. The transverse part is *per component* (the mean of x and y), so an isotropic
spread gives equal axial and transverse parts. A rigid translation gives zero.

Depth profiles (:func:`velocity_deviation_profile`): per-grain values binned against depth
-z (seed: 100 um bins, frames 0.2 ms apart) and pooled over frames (:class:`DepthProfile`).

Free-fall model (seed Sec. III, eq. for v(z); PARAMETERS.md: the printed form is lost, the form
below is inferred): grains leave the aperture at the axial speed v0 and fall freely,

    v(z) = sqrt(v0^2 + 2 g z),          z = depth below the aperture,

so two grains a distance dz apart along the stream differ in speed by dv = (dv/dz) dz =
g dz / v(z), and the axial deviation over a local range dz is

    <dv_z^2>(z) = (g dz)^2 / (v0^2 + 2 g z)      (proportional to 1/z, i.e. to t^-2, deep down).

With v0 and g known, dz is the only free parameter (:func:`fit_free_fall_deviation`, least
squares by :func:`scipy.optimize.least_squares`). For neighbours within 1.5 d on the grain's
own axis, dz^2 is close to the mean of the squared axial offsets (dz_ij)^2 of the neighbours.
v0 can be measured with :func:`aperture_speed`: the mean axial speed -v_z of the grains in the
slab 0 < depth < d just below the aperture. :func:`superficial_speed` gives another reading of
the seed's undefined "v0 ~ 10 cm/s": the outflow spread over the whole aperture at the hopper
bulk's packing fraction (docs/streams.md, "v0 by every reading").
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares
from scipy.spatial import cKDTree

from grainflow.analysis.rheology import FitStatistics
from grainflow.analysis.checks import paired_arrays
from grainflow.analysis.stream._common import (GRAVITY, DepthProfile, _count, _each_frame,
                                               _finite, _frame_diameter, _frozen, _grain_mask,
                                               _positions, _positive, _ProfileAccumulator,
                                               _vectors_like)
from grainflow.frame import Frame

__all__ = [
    "SEED_NEIGHBOUR_FACTOR", "SEED_MIN_NEIGHBOURS", "SEED_DEVIATION_BIN",
    "VelocityDeviations", "velocity_deviations", "frame_velocity_deviations",
    "DeviationProfiles", "velocity_deviation_profile",
    "free_fall_speed", "free_fall_axial_deviation",
    "FreeFallFit", "fit_free_fall_deviation", "fit_free_fall_profile",
    "ApertureSpeed", "aperture_speed", "SuperficialSpeed", "superficial_speed",
]

#: Neighbourhood radius in grain diameters, minimum neighbour count, and bin width (m) of the
#: seed's velocity deviations.
SEED_NEIGHBOUR_FACTOR = 1.5
SEED_MIN_NEIGHBOURS = 3
SEED_DEVIATION_BIN = 100e-6


# --------------------------------------------------------------------------------------------
# Per-grain deviations
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class VelocityDeviations:
    """Per-grain mean squared velocity deviations (:func:`velocity_deviations`), in m^2/s^2.

    Attributes
    ----------
    axial, transverse, total : (N,) <dv_z^2>, <dv_t^2> (per component), <|dv|^2>; NaN for the
        excluded grains.
    n_neighbours : (N,) neighbours within ``radius``.
    valid : (N,) True where n_neighbours >= min_neighbours.
    radius : the neighbourhood radius (radius_factor * diameter) in metres.
    index : (N,) rows of the grains in the frame they came from (identity for arrays).
    """

    axial: np.ndarray
    transverse: np.ndarray
    total: np.ndarray
    n_neighbours: np.ndarray
    valid: np.ndarray
    radius: float
    index: np.ndarray


def velocity_deviations(
    positions: ArrayLike,
    velocities: ArrayLike,
    diameter: float,
    *,
    radius_factor: float = SEED_NEIGHBOUR_FACTOR,
    min_neighbours: int = SEED_MIN_NEIGHBOURS,
) -> VelocityDeviations:
    """Mean squared velocity deviation of each grain relative to its neighbours (module
    docstring: seed 000 Appendix), split into axial (z) and transverse (x, y; per component).

    Parameters
    ----------
    positions, velocities : (N, 3) arrays (m, m/s).
    diameter : grain diameter d in metres; neighbours lie closer than ``radius_factor`` d.
    radius_factor : > 0 (seed: 1.5).
    min_neighbours : grains with fewer neighbours are excluded (NaN); seed: 3.
    """
    x = _positions(positions)
    n = x.shape[0]
    v = _vectors_like("velocities", velocities, n)
    radius = _positive("diameter", diameter) * _positive("radius_factor", radius_factor)
    k_min = _count("min_neighbours", min_neighbours, 1)
    if n >= 2:
        pairs = cKDTree(x).query_pairs(radius, output_type="ndarray").astype(np.int64)
    else:
        pairs = np.zeros((0, 2), dtype=np.int64)
    if pairs.size:
        pairs = pairs[np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) < radius]
    i, j = (pairs[:, 0], pairs[:, 1]) if pairs.size else (np.zeros(0, np.int64),) * 2
    dv = v[j] - v[i]
    ends = np.concatenate([i, j])
    sq_z = np.tile(dv[:, 2] ** 2, 2)
    sq_t = np.tile(dv[:, 0] ** 2 + dv[:, 1] ** 2, 2)
    count = np.bincount(ends, minlength=n)
    valid = count >= k_min
    with np.errstate(invalid="ignore", divide="ignore"):
        axial = np.bincount(ends, weights=sq_z, minlength=n) / count
        transverse = np.bincount(ends, weights=sq_t, minlength=n) / (2.0 * count)
    axial = np.where(valid, axial, np.nan)
    transverse = np.where(valid, transverse, np.nan)
    return VelocityDeviations(axial=_frozen(axial), transverse=_frozen(transverse),
                              total=_frozen(axial + 2.0 * transverse),
                              n_neighbours=_frozen(count, np.int64),
                              valid=_frozen(valid, bool), radius=radius,
                              index=_frozen(np.arange(n), np.int64))


def frame_velocity_deviations(
    frame: Frame,
    *,
    diameter: float | None = None,
    radius_factor: float = SEED_NEIGHBOUR_FACTOR,
    min_neighbours: int = SEED_MIN_NEIGHBOURS,
    grain_type: int | None = 0,
) -> VelocityDeviations:
    """:func:`velocity_deviations` of the grains (particles of ``grain_type``) of a frame;
    ``diameter`` defaults to twice the grains' median radius. ``index`` gives the rows."""
    frame = next(_each_frame(frame))
    rows = np.flatnonzero(_grain_mask(frame, grain_type))
    d = _frame_diameter(np.asarray(frame.radius, dtype=float)[rows], diameter)
    dev = velocity_deviations(np.asarray(frame.position)[rows], np.asarray(frame.velocity)[rows],
                              d, radius_factor=radius_factor, min_neighbours=min_neighbours)
    return VelocityDeviations(axial=dev.axial, transverse=dev.transverse, total=dev.total,
                              n_neighbours=dev.n_neighbours, valid=dev.valid,
                              radius=dev.radius, index=_frozen(rows, np.int64))


@dataclass(frozen=True, kw_only=True)
class DeviationProfiles:
    """Depth profiles of the velocity deviations (:func:`velocity_deviation_profile`), in
    m^2/s^2; only grains with enough neighbours contribute."""

    axial: DepthProfile
    transverse: DepthProfile
    total: DepthProfile
    radius: float


def velocity_deviation_profile(
    frames: Frame | Iterable[Frame],
    *,
    diameter: float | None = None,
    bin_width: float = SEED_DEVIATION_BIN,
    radius_factor: float = SEED_NEIGHBOUR_FACTOR,
    min_neighbours: int = SEED_MIN_NEIGHBOURS,
    depth_range: tuple[float, float] | None = None,
    grain_type: int | None = 0,
    average: str = "pooled",
) -> DeviationProfiles:
    """Axial, transverse and total velocity deviations against depth, pooled over frames
    (seed 000: frames 0.2 ms apart, 100 um bins). Excluded grains (too few neighbours) do not
    count. ``diameter`` defaults to twice the median grain radius of each frame; ``average``:
    "pooled" or "frames" (:class:`~grainflow.analysis.stream.DepthProfile`)."""
    names = ("axial", "transverse", "total")
    accs = {k: _ProfileAccumulator(f"{k} <dv^2>", bin_width, depth_range, average)
            for k in names}
    radius = np.nan
    for frame in _each_frame(frames):
        dev = frame_velocity_deviations(frame, diameter=diameter, radius_factor=radius_factor,
                                        min_neighbours=min_neighbours, grain_type=grain_type)
        radius = dev.radius
        depth = -np.asarray(frame.position, dtype=float)[dev.index, 2]
        ok = dev.valid
        for k in names:
            accs[k].add(depth[ok], getattr(dev, k)[ok])
    return DeviationProfiles(**{k: accs[k].result() for k in names}, radius=float(radius))


# --------------------------------------------------------------------------------------------
# Free fall
# --------------------------------------------------------------------------------------------


def _depths(depth: ArrayLike, v0: float, g: float) -> np.ndarray:
    z = np.asarray(depth, dtype=float)
    if not np.all(np.isfinite(z)):
        raise ValueError("depth: contains NaN or infinite values")
    if np.any(v0 ** 2 + 2.0 * g * z <= 0):
        raise ValueError("depth: v0^2 + 2 g depth must be > 0 (depths above the aperture "
                         "where the free-falling grain would not reach)")
    return z


def free_fall_speed(depth: ArrayLike, v0: float, g: float = GRAVITY) -> np.ndarray | float:
    """Free-fall speed v(z) = sqrt(v0^2 + 2 g z) at depth z below the aperture (seed 000)."""
    v0_ = _finite("v0", v0)
    g_ = _positive("g", g)
    out = np.sqrt(v0_ ** 2 + 2.0 * g_ * _depths(depth, v0_, g_))
    return float(out) if out.ndim == 0 else out


def free_fall_axial_deviation(depth: ArrayLike, dz: float, v0: float, g: float = GRAVITY
                              ) -> np.ndarray | float:
    """Axial velocity deviation over a local range dz of a freely falling stream,
    <dv_z^2> = (g dz)^2 / (v0^2 + 2 g z) (seed 000, Sec. III)."""
    v0_ = _finite("v0", v0)
    g_ = _positive("g", g)
    dz_ = _finite("dz", dz)
    out = (g_ * dz_) ** 2 / (v0_ ** 2 + 2.0 * g_ * _depths(depth, v0_, g_))
    return float(out) if out.ndim == 0 else out


@dataclass(frozen=True, kw_only=True)
class FreeFallFit(FitStatistics):
    """Fit of <dv_z^2>(z) = (g dz)^2 / (v0^2 + 2 g z), dz free (:func:`fit_free_fall_deviation`).

    Attributes
    ----------
    dz, dz_err : the local range in metres and its standard error.
    v0, g : the fixed aperture speed and gravity.
    depth_range : (min, max) depth of the points fitted.
    """

    dz: float
    dz_err: float
    v0: float
    g: float
    depth_range: tuple[float, float]

    def predict(self, depth: ArrayLike) -> np.ndarray | float:
        """The fitted <dv_z^2> at ``depth``."""
        return free_fall_axial_deviation(depth, self.dz, self.v0, self.g)


def fit_free_fall_deviation(
    depth: ArrayLike,
    dv2_axial: ArrayLike,
    v0: float,
    *,
    g: float = GRAVITY,
    sigma: ArrayLike | None = None,
    counts: ArrayLike | None = None,
    relative: bool = False,
    depth_range: tuple[float, float] = (0.0, np.inf),
) -> FreeFallFit:
    """Least-squares fit of the free-fall axial deviation (g dz)^2 / (v0^2 + 2 g z) to measured
    <dv_z^2>(z), with dz the only free parameter (seed 000: "the initial velocity v0 is known
    and the only free parameter is the neighborhood size dz").

    Parameters
    ----------
    depth, dv2_axial : (M,) depths (m) and axial deviations (m^2/s^2), e.g. a profile's
        ``centres`` and ``mean``. NaN points are dropped.
    v0 : the axial speed at the aperture (m/s), e.g. from :func:`aperture_speed`.
    g : gravity (m/s^2).
    sigma : (M,) standard errors of dv2_axial: residuals are divided by them and the error of
        dz is absolute. Points with non-finite or zero sigma are dropped.
    counts : (M,) sample counts, used as weights (residual * sqrt(count)) when ``sigma`` is not
        given; the error is then scaled by the residual variance chi^2/dof (as it is without
        any weights).
    relative : without ``sigma`` or ``counts``, weight each point by 1 / |dv2_axial|, i.e.
        fit relative deviations (every decade of a log-log plot counts alike; unweighted
        least squares is dominated by the large values near the aperture); error scaled by
        chi^2/dof.
    depth_range : (min, max) depths fitted; default every point below the aperture (depth > 0;
        the model does not describe the hopper).

    Returns
    -------
    :class:`FreeFallFit`; least squares by :func:`scipy.optimize.least_squares`, error from
    the Jacobian, (J^T J)^-1.
    """
    z, y = paired_arrays("depth", depth, "dv2_axial", dv2_axial)
    v0_ = _finite("v0", v0)
    g_ = _positive("g", g)
    if (sigma is not None) + (counts is not None) + bool(relative) > 1:
        raise ValueError("counts: give at most one of sigma, counts and relative=True")
    w = np.ones_like(z)
    if sigma is not None:
        s = np.asarray(sigma, dtype=float)
        if s.shape != z.shape:
            raise ValueError(f"sigma: expected shape {z.shape} like depth, got {s.shape}")
        with np.errstate(divide="ignore"):
            w = np.where(np.isfinite(s) & (s > 0), 1.0 / s, np.nan)
    elif counts is not None:
        c = np.asarray(counts, dtype=float)
        if c.shape != z.shape or np.any(c < 0):
            raise ValueError(f"counts: expected shape {z.shape} like depth, values >= 0")
        w = np.sqrt(c)
    elif relative:
        with np.errstate(divide="ignore"):
            w = 1.0 / np.abs(y)
    lo, hi = (float(depth_range[0]), float(depth_range[1]))
    if not lo < hi:
        raise ValueError(f"depth_range: expected (min, max) with min < max, got {depth_range!r}")
    keep = np.isfinite(z) & np.isfinite(y) & np.isfinite(w) & (w > 0) & (z > lo) & (z <= hi)
    keep &= v0_ ** 2 + 2.0 * g_ * np.where(np.isfinite(z), z, 0.0) > 0
    z, y, w = z[keep], y[keep], w[keep]
    if z.size < 2:
        raise ValueError(f"dv2_axial: need at least 2 finite points with depth in "
                         f"({lo:g}, {hi:g}] m to fit dz, got {z.size}")
    shape = g_ ** 2 / (v0_ ** 2 + 2.0 * g_ * z)  # <dv_z^2> = dz^2 * shape

    def residuals(p: np.ndarray) -> np.ndarray:
        return (p[0] ** 2 * shape - y) * w

    p2 = float(np.sum(w ** 2 * y * shape) / np.sum(w ** 2 * shape ** 2))  # linear guess
    start = np.sqrt(p2) if p2 > 0 else float(np.sqrt(np.mean(np.abs(y) / shape)))
    start = start if start > 0 else 1e-6
    res = least_squares(residuals, [start], bounds=([0.0], [np.inf]), method="trf",
                        x_scale="jac")
    dof = z.size - 1
    chi2_dof = float(2.0 * res.cost / dof)
    jtj = float(res.jac[:, 0] @ res.jac[:, 0])
    absolute = sigma is not None
    var = (1.0 / jtj if jtj > 0 else np.inf) * (1.0 if absolute else chi2_dof)
    return FreeFallFit(dz=float(res.x[0]), dz_err=float(np.sqrt(var)), v0=v0_, g=g_,
                       depth_range=(float(z.min()), float(z.max())),
                       covariance=_frozen([[var]]), chi2_dof=chi2_dof, dof=dof,
                       n_points=int(z.size), absolute_sigma=absolute)


def fit_free_fall_profile(
    profile: DepthProfile | DeviationProfiles,
    v0: float,
    *,
    g: float = GRAVITY,
    weighting: str = "err",
    depth_range: tuple[float, float] = (0.0, np.inf),
) -> FreeFallFit:
    """:func:`fit_free_fall_deviation` on an axial-deviation profile. ``weighting``: "err"
    (the profile's standard errors, absolute; bins without an error are dropped), "count"
    (sample counts), "relative" (1 / value: relative deviations) or "none"."""
    if isinstance(profile, DeviationProfiles):
        profile = profile.axial
    if not isinstance(profile, DepthProfile):
        raise ValueError(f"profile: expected a DepthProfile or DeviationProfiles, got "
                         f"{type(profile).__name__}")
    if weighting not in ("err", "count", "relative", "none"):
        raise ValueError(f"weighting: 'err', 'count', 'relative' or 'none', got {weighting!r}")
    return fit_free_fall_deviation(
        profile.centres, profile.mean, v0, g=g, depth_range=depth_range,
        sigma=profile.err if weighting == "err" else None,
        counts=profile.count if weighting == "count" else None,
        relative=weighting == "relative")


# --------------------------------------------------------------------------------------------
# Speed at the aperture
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class ApertureSpeed:
    """Mean axial speed just below the aperture (:func:`aperture_speed`).

    Attributes
    ----------
    v0, err : mean of -v_z (m/s, positive downward) and its standard error (frame-to-frame
        scatter with several frames, grain scatter std/sqrt(n) with one).
    count : grain samples; n_frames : frames used; slab : the slab thickness (m).
    """

    v0: float
    err: float
    count: int
    n_frames: int
    slab: float


def aperture_speed(
    frames: Frame | Iterable[Frame],
    *,
    slab: float | None = None,
    grain_type: int | None = 0,
) -> ApertureSpeed:
    """The axial speed v0 at the aperture: the mean of -v_z over the grains with
    0 < depth < ``slab`` (default one grain diameter, twice the median radius of the first
    frame's grains), pooled over frames (seed 000: v0 ~ 10 cm/s for d = 200 um, D = 3 mm)."""
    depths: list[np.ndarray] = []
    speeds: list[np.ndarray] = []
    h = None if slab is None else _positive("slab", slab)
    for frame in _each_frame(frames):
        rows = _grain_mask(frame, grain_type)
        if h is None:
            h = _frame_diameter(np.asarray(frame.radius, dtype=float)[rows], None)
        depth = -np.asarray(frame.position, dtype=float)[rows, 2]
        inside = (depth > 0) & (depth < h)
        depths.append(depth[inside])
        speeds.append(-np.asarray(frame.velocity, dtype=float)[rows, 2][inside])
    if not depths:
        raise ValueError("frames: no frames given")
    assert h is not None
    samples = np.concatenate(speeds)
    if samples.size == 0:
        raise ValueError(f"frames: no grain lies in the slab 0 < depth < {h:g} m below the "
                         "aperture; pass frames of a flowing stream or a thicker slab")
    acc = _ProfileAccumulator("axial speed", h, (0.0, h))
    for d_, s_ in zip(depths, speeds):
        acc.add(np.clip(d_, 0.0, np.nextafter(h, 0.0)), s_)
    prof = acc.result()
    if len(depths) >= 2 and np.isfinite(prof.err[0]):
        err = float(prof.err[0])
    else:
        err = float(np.std(samples, ddof=1) / np.sqrt(samples.size)) if samples.size > 1 \
            else float("nan")
    return ApertureSpeed(v0=float(samples.mean()), err=err, count=int(samples.size),
                         n_frames=len(depths), slab=float(h))


@dataclass(frozen=True, kw_only=True)
class SuperficialSpeed:
    """The outflow's superficial speed at the aperture (:func:`superficial_speed`).

    Attributes
    ----------
    speed : Q V_grain / (phi_b A) (m/s). phi_b : the bulk packing fraction. count : grain
        samples in the bulk region over all frames; n_frames : frames used.
    """

    speed: float
    phi_b: float
    count: int
    n_frames: int


def superficial_speed(
    frames: Frame | Iterable[Frame],
    outflow: float,
    *,
    aperture_diameter: float,
    hopper_diameter: float,
    fill_height: float,
    grain_type: int | None = 0,
) -> SuperficialSpeed:
    """The speed u = Q V_grain / (phi_b A) at which ``outflow`` Q (grains per second) would
    cross the whole aperture (area A = pi D^2/4) at the hopper bulk's packing fraction phi_b:
    the superficial speed of Beverloo's law (Q = phi_b A u), one reading of seed 000's
    undefined "v0 ~ 10 cm/s" at the aperture (docs/streams.md).

    phi_b counts the grains' volumes (pi/6) d^3 with their centres in the cylinder
    r < 0.35 D_h, H/6 < z < 2H/3 above the hopper's base (z = 0, the aperture's plane): away
    from the side wall, the base and the refilled top, averaged over ``frames``."""
    radius_b = 0.35 * _positive("hopper_diameter", hopper_diameter)
    height = _positive("fill_height", fill_height)
    area = 0.25 * np.pi * _positive("aperture_diameter", aperture_diameter) ** 2
    lo, hi = height / 6.0, 2.0 * height / 3.0
    volume, count, n_frames = 0.0, 0, 0
    for frame in _each_frame(frames):
        rows = _grain_mask(frame, grain_type)
        x = np.asarray(frame.position, dtype=float)[rows]
        r = np.asarray(frame.radius, dtype=float)[rows]
        inside = (np.hypot(x[:, 0], x[:, 1]) < radius_b) & (x[:, 2] > lo) & (x[:, 2] < hi)
        volume += float(np.sum(4.0 / 3.0 * np.pi * r[inside] ** 3))
        count += int(inside.sum())
        n_frames += 1
    if n_frames == 0:
        raise ValueError("frames: no frames given")
    if count == 0:
        raise ValueError(f"frames: no grain in the hopper's bulk (r < {radius_b:g} m, "
                         f"{lo:g} < z < {hi:g} m); pass frames of a filled hopper")
    phi_b = volume / (n_frames * np.pi * radius_b**2 * (hi - lo))
    grain_volume = volume / count
    return SuperficialSpeed(speed=float(outflow * grain_volume / (phi_b * area)),
                            phi_b=float(phi_b), count=count, n_frames=n_frames)
