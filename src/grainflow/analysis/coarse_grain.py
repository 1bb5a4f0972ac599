"""Gaussian coarse-graining of particle data, after seed 003 (Cheng et al., Soft Matter 18,
8071 (2022), Sec. 4 and Fig. 5) and the Gaussian kernels of MercuryCG.

A particle quantity q_i becomes a field by summing normalised Gaussians centred on the grains::

    q_g(r) = sum_i q_i phi(r - r_i),
    phi(r) = (2 pi sigma^2)^(-d/2) exp(-|r|^2 / (2 sigma^2)),

i.e. (sqrt(2 pi) sigma)^-2 exp(...) in 2D, as printed in the seed, and (2 pi)^(-3/2) sigma^-3
exp(...) in 3D; the seed takes sigma = sigma_avg. With q_i = 1 this is the number density,
with q_i the grain area (volume) the packing fraction, and with q_i the velocity the seed's
v_g. The kernel is cut at ``cutoff`` * sigma (4 by default, found with a KD-tree) and
renormalised so that it still integrates to one. Distances are Euclidean (no periodic images).

Arrays: sample points (P, dim), grain positions (N, dim); dim = 2 or 3.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree
from scipy.special import gammainc

from grainflow.analysis.checks import frozen as _frozen
from grainflow.frame import Frame

_POINTS_PER_CHUNK = 4096


def _unit_up(up: ArrayLike | None, dim: int) -> np.ndarray:
    """Unit vector pointing against gravity; default the last axis (+y in 2D, +z in 3D)."""
    if up is None:
        return np.eye(dim)[-1]
    vec = np.asarray(up, dtype=float)
    norm = float(np.linalg.norm(vec)) if vec.shape == (dim,) else 0.0
    if not (norm > 0 and np.isfinite(norm)):
        raise ValueError(f"up: expected a non-zero vector of shape ({dim},), got {up!r}")
    return vec / norm


def _points_array(name: str, values: ArrayLike, dim: int | None = None) -> np.ndarray:
    """``values`` as a finite (n, dim) float array, or ValueError naming ``name``."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 2 or arr.shape[1] not in (2, 3) or (dim is not None and arr.shape[1] != dim):
        want = f"(n, {dim})" if dim is not None else "(n, 2) or (n, 3)"
        raise ValueError(f"{name}: expected shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return arr


def _check_kernel(sigma: float, cutoff: float) -> None:
    if not sigma > 0:
        raise ValueError(f"sigma: the kernel width must be positive, got {sigma}")
    if not 1.0 <= cutoff < np.inf:
        raise ValueError(f"cutoff: must be a finite number of widths >= 1, got {cutoff}")


def gaussian_kernel(r2: ArrayLike, sigma: float, dim: int, cutoff: float = 4.0) -> np.ndarray:
    """Normalised Gaussian phi at squared distances ``r2``, cut at ``cutoff`` * sigma.

    phi(r) = (2 pi sigma^2)^(-d/2) exp(-r^2 / 2 sigma^2) / P(d/2, c^2/2) for r <= c sigma and 0
    beyond, where P is the regularised lower incomplete gamma function: the fraction of the
    Gaussian's weight inside the cutoff (1 - exp(-c^2/2) in 2D), so that phi integrates to one.
    """
    _check_kernel(sigma, cutoff)
    r2 = np.asarray(r2, dtype=float)
    norm = (2.0 * np.pi * sigma**2) ** (-dim / 2) / gammainc(dim / 2, cutoff**2 / 2)
    return np.where(r2 <= (cutoff * sigma) ** 2, norm * np.exp(-r2 / (2.0 * sigma**2)), 0.0)


def coarse_grain(
    points: ArrayLike,
    positions: ArrayLike,
    values: ArrayLike | None = None,
    *,
    sigma: float,
    cutoff: float = 4.0,
) -> np.ndarray:
    """Gaussian coarse-grained field q_g(r) = sum_i q_i phi(r - r_i) at the sample points.

    Parameters
    ----------
    points : (P, dim) sample points.
    positions : (N, dim) grain centres.
    values : (N,) or (N, k) per-grain quantities q_i; None for q_i = 1 (number density).
    sigma : kernel width (the seed uses sigma_avg).
    cutoff : kernel range in units of sigma.

    Returns
    -------
    (P,) or (P, k) field values.
    """
    _check_kernel(sigma, cutoff)
    pos = _points_array("positions", positions)
    pts = _points_array("points", points, pos.shape[1])
    q = np.ones(pos.shape[0]) if values is None else np.asarray(values, dtype=float)
    if q.shape[:1] != pos.shape[:1] or q.ndim > 2:
        n = pos.shape[0]
        raise ValueError(f"values: expected shape ({n},) or ({n}, k), got {q.shape}")
    q2 = q[:, None] if q.ndim == 1 else q
    out = np.zeros((pts.shape[0], q2.shape[1]))
    grains = cKDTree(pos)
    for start in range(0, pts.shape[0], _POINTS_PER_CHUNK):
        chunk = pts[start : start + _POINTS_PER_CHUNK]
        pairs = cKDTree(chunk).sparse_distance_matrix(grains, cutoff * sigma, output_type="ndarray")
        phi = gaussian_kernel(pairs["v"] ** 2, sigma, pos.shape[1], cutoff)
        for col in range(q2.shape[1]):
            out[start : start + chunk.shape[0], col] = np.bincount(
                pairs["i"], weights=phi * q2[pairs["j"], col], minlength=chunk.shape[0]
            )
    return out if q.ndim == 2 else out[:, 0]


def number_density(
    points: ArrayLike, positions: ArrayLike, *, sigma: float, cutoff: float = 4.0
) -> np.ndarray:
    """Number density n(r) = sum_i phi(r - r_i), shape (P,)."""
    return coarse_grain(points, positions, None, sigma=sigma, cutoff=cutoff)


def packing_fraction(
    points: ArrayLike,
    positions: ArrayLike,
    sizes: ArrayLike,
    *,
    sigma: float,
    cutoff: float = 4.0,
) -> np.ndarray:
    """Packing fraction phi_p(r) = sum_i s_i phi(r - r_i), s_i the grain area (2D) / volume (3D).

    ``sizes`` has shape (N,); returns (P,). Overlaps of soft grains are counted twice, as in the
    seed's nominal areas.
    """
    s = np.asarray(sizes, dtype=float)
    if s.ndim != 1 or np.any(s <= 0):
        raise ValueError("sizes: expected a (N,) array of positive grain areas/volumes")
    return coarse_grain(points, positions, s, sigma=sigma, cutoff=cutoff)


def velocity_field(
    points: ArrayLike,
    positions: ArrayLike,
    velocities: ArrayLike,
    *,
    sigma: float,
    masses: ArrayLike | None = None,
    cutoff: float = 4.0,
) -> np.ndarray:
    """Coarse-grained velocity V(r) = sum_i m_i v_i phi / sum_i m_i phi, shape (P, dim).

    This is momentum density over mass density (MercuryCG's velocity); with ``masses`` None
    all weights are 1 (number-weighted). Unlike the seed's v_g (:func:`coarse_grain` of the
    velocities, a flux density with units of velocity x number density) it returns the grains'
    velocity wherever they are, independent of the local density. NaN where no grain lies
    within the cutoff.
    """
    pos = _points_array("positions", positions)
    vel = _points_array("velocities", velocities, pos.shape[1])
    m = np.ones(pos.shape[0]) if masses is None else np.asarray(masses, dtype=float)
    if m.shape != (pos.shape[0],) or vel.shape[0] != pos.shape[0]:
        raise ValueError("velocities/masses: need one row per grain in positions")
    weighted = np.column_stack([m[:, None] * vel, m])
    sums = coarse_grain(points, pos, weighted, sigma=sigma, cutoff=cutoff)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sums[:, :-1] / sums[:, -1:]


@dataclass(frozen=True)
class VelocityProfile:
    """Coarse-grained downward velocity on the hopper's centre line (seed 003 Fig. 5).

    Attributes
    ----------
    heights : (H,) distance h above the orifice centre, against gravity.
    velocity : (H,) sum_i m_i v_i phi / sum_i m_i phi (frame sums averaged before dividing),
        the speed in the direction of gravity (positive for outflow).
    flux : (H,) the seed's v_g(h) = sum_i v_i phi(r - r_i), frame-averaged.
    number_density : (H,) sum_i phi(r - r_i), frame-averaged (flux / number_density is the
        number-weighted velocity).
    sigma : kernel width used.
    dim : spatial dimension.
    n_frames : number of frames averaged.
    """

    heights: np.ndarray
    velocity: np.ndarray
    flux: np.ndarray
    number_density: np.ndarray
    sigma: float
    dim: int
    n_frames: int


def centreline_velocity_profile(
    positions: Sequence[ArrayLike],
    velocities: Sequence[ArrayLike],
    heights: ArrayLike,
    orifice_centre: ArrayLike,
    *,
    sigma: float,
    up: ArrayLike | None = None,
    masses: Sequence[ArrayLike] | None = None,
    cutoff: float = 4.0,
) -> VelocityProfile:
    """v_g(h) on the centre line above the orifice, averaged over frames (seed 003 Fig. 5).

    The seed plots "the average speed of the particles in the direction of gravity at the center
    of the hopper", smoothed as v_g(r) = sum_i v_{g,i} phi(r - r_i) with phi the Gaussian of
    width sigma_avg; v_{g,i} = -v_i . up. Sample points are r(h) = orifice_centre + h up. Both
    the seed's flux density and the density-normalised velocity are returned.

    Parameters
    ----------
    positions, velocities : sequences of (N_f, dim) arrays, one pair per frame.
    heights : (H,) heights above the orifice.
    orifice_centre : (dim,) centre of the orifice.
    sigma : kernel width (sigma_avg in the seed).
    up : (dim,) direction against gravity (default +y in 2D, +z in 3D).
    masses : optional sequence of (N_f,) masses for mass weighting of ``velocity``.
    cutoff : kernel range in units of sigma.
    """
    if len(positions) == 0 or len(positions) != len(velocities):
        raise ValueError("positions/velocities: need the same, non-zero number of frames")
    if masses is not None and len(masses) != len(positions):
        raise ValueError("masses: need one mass array per frame")
    centre = np.asarray(orifice_centre, dtype=float)
    dim = centre.shape[0]
    if centre.shape != (dim,) or dim not in (2, 3):
        raise ValueError(f"orifice_centre: expected 2 or 3 components, got shape {centre.shape}")
    axis = _unit_up(up, dim)
    h = np.asarray(heights, dtype=float).ravel()
    points = centre + h[:, None] * axis

    sums = np.zeros((h.size, 4))  # sum v phi, sum phi, sum m v phi, sum m phi
    for f, (pos, vel) in enumerate(zip(positions, velocities, strict=True)):
        pos_f = _points_array("positions", pos, dim)
        v_down = -_points_array("velocities", vel, dim) @ axis
        m = np.ones(pos_f.shape[0]) if masses is None else np.asarray(masses[f], dtype=float)
        if v_down.shape != (pos_f.shape[0],) or m.shape != v_down.shape:
            raise ValueError(f"velocities/masses: frame {f} does not match its positions")
        values = np.column_stack([v_down, np.ones_like(m), m * v_down, m])
        sums += coarse_grain(points, pos_f, values, sigma=sigma, cutoff=cutoff)
    sums /= len(positions)
    with np.errstate(invalid="ignore", divide="ignore"):
        velocity = sums[:, 2] / sums[:, 3]
    return VelocityProfile(
        heights=_frozen(h),
        velocity=_frozen(velocity),
        flux=_frozen(sums[:, 0]),
        number_density=_frozen(sums[:, 1]),
        sigma=float(sigma),
        dim=dim,
        n_frames=len(positions),
    )


def centreline_velocity_profile_from_frames(
    frames: Sequence[Frame],
    heights: ArrayLike,
    orifice_centre: ArrayLike,
    *,
    sigma: float,
    up: ArrayLike | None = None,
    mass_weighted: bool = False,
    cutoff: float = 4.0,
) -> VelocityProfile:
    """:func:`centreline_velocity_profile` from saved :class:`~grainflow.frame.Frame` objects.

    Uses each frame's particle positions and velocities (for the deformable-particle model pass
    frames of particle centres, not vertices); ``mass_weighted`` weights ``velocity`` by
    ``Frame.mass``.
    """
    return centreline_velocity_profile(
        [fr.position for fr in frames],
        [fr.velocity for fr in frames],
        heights,
        orifice_centre,
        sigma=sigma,
        up=up,
        masses=[fr.mass for fr in frames] if mass_weighted else None,
        cutoff=cutoff,
    )
