"""Azimuthal flux dN/dphi of the grains scattered by a jet of rectangular cross-section and its
harmonics v_n, the anisotropy of seed 002 Sec. 4.2 and Fig. 4.3 (v2 = <cos 2 phi>; the
experiment of Cheng et al., PRL 99, 188001 (2007): v2 = 0.16 at eccentricity 0.615)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from math import pi

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.checks import frozen as _frozen
from grainflow.analysis.checks import positive as _positive
from grainflow.analysis.jet._common import (GrainSelection, ShellSamples, check_weighting,
                                            jackknife, jackknife_units, shell_samples, unit_sums,
                                            unit_vector)
from grainflow.frame import Frame

#: Experimental anisotropy (Cheng et al., PRL 99, 188001 (2007)) quoted in Sec. 4.2: (eps, v2).
SEED_V2 = (0.615, 0.16)
#: Cross-section area of the rectangular jets of Sec. 4.2, in d^2.
JET_AREA = 16.0


def eccentricity(aspect: ArrayLike) -> np.ndarray | float:
    """Eccentricity eps = (l^2 - 1) / (l^2 + 1) of a rectangular cross-section of aspect ratio
    l = long / short side (Sec. 4.2). It is (<y^2> - <x^2>) / (<y^2> + <x^2>) of the uniform
    rectangle with its short side along x, the heavy-ion definition; l > 0 (l < 1 gives eps < 0).
    """
    l_ = np.asarray(aspect, dtype=float)
    if not np.all(np.isfinite(l_)) or np.any(l_ <= 0):
        raise ValueError(f"aspect: aspect ratios must be finite and > 0, got {aspect!r}")
    out = (l_**2 - 1.0) / (l_**2 + 1.0)
    return float(out) if out.ndim == 0 else out


def aspect_ratio(eps: ArrayLike) -> np.ndarray | float:
    """Inverse of :func:`eccentricity`: l = sqrt((1 + eps) / (1 - eps)), -1 < eps < 1
    (eps = 0.615 of Cheng et al. is l = 2.05)."""
    e = np.asarray(eps, dtype=float)
    if not np.all(np.isfinite(e)) or np.any(np.abs(e) >= 1):
        raise ValueError(f"eps: eccentricities must lie in (-1, 1), got {eps!r}")
    out = np.sqrt((1.0 + e) / (1.0 - e))
    return float(out) if out.ndim == 0 else out


def rectangle_sides(aspect: float, area: float = JET_AREA) -> tuple[float, float]:
    """(short, long) sides of the rectangle of aspect ratio ``aspect`` >= 1 and ``area``
    (the jets of Sec. 4.2 keep 16 d^2)."""
    l_ = _positive("aspect", aspect)
    if l_ < 1:
        raise ValueError(f"aspect: long / short side, >= 1, got {aspect!r}")
    a = _positive("area", area)
    return float(np.sqrt(a / l_)), float(np.sqrt(a * l_))


def _azimuths(s: ShellSamples, reference_axis: ArrayLike | None, azimuth: str) -> np.ndarray:
    """phi of each sample in the target plane, from the reference axis, right-handed about -n."""
    if s.geo.dim != 3:
        raise ValueError("frames: the azimuthal flux and v_n need 3D frames; a 2D jet has no "
                         "azimuth (its two branches are +-y)")
    if azimuth not in ("position", "velocity"):
        raise ValueError(f"azimuth: 'position' or 'velocity', got {azimuth!r}")
    up = -s.geo.n
    ref = unit_vector("reference_axis", (1.0, 0.0, 0.0) if reference_axis is None
                      else reference_axis, 3)
    e1 = ref - (ref @ up) * up
    if np.linalg.norm(e1) < 1e-9:
        raise ValueError("reference_axis: must not be parallel to the jet direction")
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    vec = s.position if azimuth == "position" else s.velocity
    return np.arctan2(vec @ e2, vec @ e1)


def _azimuthal_inputs(frames, *, target_radius, jet_radius, reference_axis, azimuth, weighting,
                      blocks, **geometry):
    weighting = check_weighting(weighting)
    s = shell_samples(frames, target_radius=target_radius, jet_radius=jet_radius, **geometry)
    phi = _azimuths(s, reference_axis, azimuth)
    w = s.outward if weighting == "flux" else np.ones_like(s.outward)
    unit, n_units, n_blocks = jackknife_units(s, blocks)
    return s, phi, w, unit, n_units, n_blocks, weighting


def _harmonic(phi, w, unit, n_units, order):
    c = w * np.cos(order * phi)
    totals = [np.sum(c), np.sum(w)]
    per_unit = [unit_sums(unit, n_units, c), unit_sums(unit, n_units, w)]
    v = float(totals[0] / totals[1])
    return v, float(jackknife(lambda a, b: a / b, totals, per_unit))


@dataclass(frozen=True, kw_only=True)
class AzimuthalFlux:
    """Azimuthal distribution of the scattered flux (:func:`azimuthal_flux`).

    Attributes
    ----------
    edges : (n_bins + 1,) bin edges in phi, from -pi to pi.
    centres : (n_bins,) bin centres.
    density : (n_bins,) dN/dphi normalised to unit integral, (1/N) dN/dphi; isotropic:
        1/(2 pi) everywhere.
    density_err : (n_bins,) jackknife standard errors of ``density``.
    orders : (K,) harmonics n = 1 ... n_max; v, v_err : (K,) their coefficients
        v_n = <cos n phi> from the unbinned samples (:func:`anisotropy_v2`) and errors.
    rate : crossings per unit time (``weighting="flux"``: sum_i v_i . r_hat / shell_width per
        frame) or grains in the shell per frame (``"count"``).
    n_grains, n_frames, blocks, weighting, azimuth : as in :func:`anisotropy_v2`.
    """

    edges: np.ndarray
    centres: np.ndarray
    density: np.ndarray
    density_err: np.ndarray
    orders: np.ndarray
    v: np.ndarray
    v_err: np.ndarray
    rate: float
    n_grains: int
    n_frames: int
    blocks: int
    weighting: str
    azimuth: str

    def model(self, phi: ArrayLike, orders: Sequence[int] = (2,)) -> np.ndarray:
        """(1 / 2 pi) (1 + 2 sum_n v_n cos n phi) over the chosen harmonics (default v2 only):
        the Fourier fit of ``density``."""
        p = np.asarray(phi, dtype=float)
        total = np.ones_like(p)
        for order in orders:
            hit = np.nonzero(self.orders == order)[0]
            if hit.size == 0:
                raise ValueError(f"orders: harmonic {order} not computed; available "
                                 f"{self.orders.tolist()}")
            total = total + 2.0 * self.v[hit[0]] * np.cos(order * p)
        return total / (2.0 * pi)


def azimuthal_flux(
    frames: Frame | Iterable[Frame],
    *,
    target_radius: float,
    jet_radius: float,
    n_bins: int = 36,
    n_max: int = 4,
    reference_axis: ArrayLike | None = None,
    azimuth: str = "position",
    weighting: str = "flux",
    direction: ArrayLike | None = None,
    centre: ArrayLike | None = None,
    grains: GrainSelection = None,
    window: tuple[float, float] | None = None,
    u0: float = 1.0,
    deflection: float = 0.25,
    shell_factor: float = 1.5,
    shell_offset: float = 3.0,
    shell_width: float = 2.0,
    blocks: int | None = None,
) -> AzimuthalFlux:
    """Azimuthal distribution dN/dphi of the scattered grains crossing the shell (3D only),
    Sec. 4.2, eq. (4.6), with its Fourier coefficients v_1 ... v_n_max.

    phi is measured in the target plane (perpendicular to the jet) from ``reference_axis``
    (default x, the short axis of a rectangular jet), counter-clockwise seen from upstream
    (about -n: x -> y for the default geometry); it is the azimuth of the grain's position
    (``azimuth="position"``, default: where it crosses the shell) or of its velocity
    (``"velocity"``, the heavy-ion convention; the same far from the target). Scattered grains
    and the shell are those of :func:`scattering_angle`. Each grain is weighted by its outward
    radial velocity (``weighting="flux"``, default), so the histogram counts crossings of the
    shell, the flux dN/dphi of eq. (4.6); ``"count"`` counts the grains in the shell. Bin
    errors are jackknife errors (module notes). The remaining parameters are those of
    :func:`scattering_angle`.

    Parameters
    ----------
    n_bins : number of equal phi bins over [-pi, pi), >= 4.
    n_max : highest harmonic whose v_n is computed, >= 2.
    """
    if not isinstance(n_bins, (int, np.integer)) or n_bins < 4:
        raise ValueError(f"n_bins: an integer >= 4, got {n_bins!r}")
    if not isinstance(n_max, (int, np.integer)) or n_max < 2:
        raise ValueError(f"n_max: an integer >= 2, got {n_max!r}")
    s, phi, w, unit, n_units, n_blocks, weighting = _azimuthal_inputs(
        frames, target_radius=target_radius, jet_radius=jet_radius,
        reference_axis=reference_axis, azimuth=azimuth, weighting=weighting, blocks=blocks,
        direction=direction, centre=centre, grains=grains, window=window, u0=u0,
        deflection=deflection, shell_factor=shell_factor, shell_offset=shell_offset,
        shell_width=shell_width)
    edges = np.linspace(-pi, pi, int(n_bins) + 1)
    width = edges[1] - edges[0]
    b = np.clip(((phi + pi) // width).astype(int), 0, n_bins - 1)
    hist = np.bincount(b, weights=w, minlength=n_bins)
    per_unit_hist = np.zeros((n_units, n_bins))
    np.add.at(per_unit_hist, (unit, b), w)
    total = float(w.sum())
    per_unit_total = unit_sums(unit, n_units, w)

    def density(h, t):
        return h / (np.asarray(t)[..., None] * width)

    err = jackknife(density, [hist, np.asarray(total)], [per_unit_hist, per_unit_total])
    orders = np.arange(1, int(n_max) + 1)
    vs = [_harmonic(phi, w, unit, n_units, k) for k in orders]
    rate = total / s.n_frames / (s.shell_width if weighting == "flux" else 1.0)
    return AzimuthalFlux(
        edges=_frozen(edges), centres=_frozen(0.5 * (edges[1:] + edges[:-1])),
        density=_frozen(hist / (total * width)), density_err=_frozen(err),
        orders=orders, v=_frozen([v for v, _ in vs]), v_err=_frozen([e for _, e in vs]),
        rate=rate, n_grains=int(phi.size), n_frames=s.n_frames, blocks=n_blocks,
        weighting=weighting, azimuth=azimuth,
    )


@dataclass(frozen=True, kw_only=True)
class Anisotropy:
    """Flow harmonic v_n of the scattered flux (:func:`anisotropy_v2`).

    Attributes
    ----------
    order : n; v : v_n = <cos n phi>; v_err : its jackknife standard error.
    n_grains : grain samples used; n_frames : frames in the window; blocks : jackknife blocks
    (1: over grains). weighting : "flux" or "count"; azimuth : "position" or "velocity".
    """

    order: int
    v: float
    v_err: float
    n_grains: int
    n_frames: int
    blocks: int
    weighting: str
    azimuth: str


def anisotropy_v2(
    frames: Frame | Iterable[Frame],
    *,
    target_radius: float,
    jet_radius: float,
    order: int = 2,
    reference_axis: ArrayLike | None = None,
    azimuth: str = "position",
    weighting: str = "flux",
    direction: ArrayLike | None = None,
    centre: ArrayLike | None = None,
    grains: GrainSelection = None,
    window: tuple[float, float] | None = None,
    u0: float = 1.0,
    deflection: float = 0.25,
    shell_factor: float = 1.5,
    shell_offset: float = 3.0,
    shell_width: float = 2.0,
    blocks: int | None = None,
) -> Anisotropy:
    """Anisotropy v_n (default the elliptic flow v2) of the scattered flux, Sec. 4.2 (3D only).

    Normalised as in heavy-ion physics, dN/dphi = (N / 2 pi) (1 + 2 sum_n v_n cos n(phi - Phi)),
    so that::

        v_n = < cos n(phi - Phi) > = sum_i w_i cos(n phi_i) / sum_i w_i,

    with the symmetry plane Phi = 0: phi is measured from ``reference_axis`` (default x, the
    short axis of the rectangular jet; pass another axis for another plane). v2 > 0 means more
    flux along the short axis, the hydrodynamic response to the steeper pressure gradient
    there. Weights w_i are the outward radial velocities (``weighting="flux"``, default: v_n
    are then the Fourier coefficients of the flux dN/dphi of eq. (4.6), each crossing counted
    once) or 1 (``"count"``: the grains in the shell); the thesis's expansion
    dN/dphi = sum_n v_n cos n phi differs only by this normalisation. The coefficients come
    from the unbinned samples (no binning bias). Reference: v2 = 0.16 at eps = 0.615
    (Cheng et al., :data:`SEED_V2`), at a cross-section of 16 d^2 (:data:`JET_AREA`); the
    thesis finds smaller v2, not proportional to eps (Fig. 4.3).

    Parameters
    ----------
    order : the harmonic n >= 1.
    Others : as :func:`azimuthal_flux` and :func:`scattering_angle`.
    """
    if not isinstance(order, (int, np.integer)) or isinstance(order, bool) or order < 1:
        raise ValueError(f"order: a positive integer, got {order!r}")
    s, phi, w, unit, n_units, n_blocks, weighting = _azimuthal_inputs(
        frames, target_radius=target_radius, jet_radius=jet_radius,
        reference_axis=reference_axis, azimuth=azimuth, weighting=weighting, blocks=blocks,
        direction=direction, centre=centre, grains=grains, window=window, u0=u0,
        deflection=deflection, shell_factor=shell_factor, shell_offset=shell_offset,
        shell_width=shell_width)
    v, err = _harmonic(phi, w, unit, n_units, int(order))
    return Anisotropy(order=int(order), v=v, v_err=err, n_grains=int(phi.size),
                      n_frames=s.n_frames, blocks=n_blocks, weighting=weighting,
                      azimuth=azimuth)
