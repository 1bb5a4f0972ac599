"""Scattered states of granular jets after seed 002, chapter 4 (H. Sano, PhD thesis (2013);
Sano & Hayakawa, PRE 86, 041308 (2012)) and the dead zone of Sec. 6.1.1: pure functions of
saved frames (:class:`~grainflow.frame.Frame`, e.g. from :func:`grainflow.io.h5md.read_frames`).

Geometry of the jet scenarios (fixed conventions; the functions take them as arguments with
these defaults)
-----------------------------------------------------------------------------------------------
* Units: d (the largest grain diameter) = 1, m = 1, u0 = 1 (the jet speed).
* 3D: the jet travels along ``direction`` = -z at speed u0, its axis the z axis (x = y = 0).
  The target is one layer of wall particles of type :data:`TARGET_TYPE` = 2 with centres at
  z = -0.5 inside a disk of radius R_tar, so its surface lies near z = 0; ``centre`` = (0, 0, 0)
  is where the axis meets the target surface.
* 2D: the jet travels along -x, its axis is y = 0; the target is a line of wall particles
  (type 2) at x = -0.5 for |y| <= R_tar; ``centre`` = (0, 0).
* Grains have types 0 and 1; the default ``grains`` selection is every particle whose type is
  not :data:`TARGET_TYPE`. ``grains`` may also be a sequence of types or a callable
  ``frame -> (N,) bool mask``.
* X = D_tar / D_jet = R_tar / R_jet (thesis Sec. 4.1). Positions are taken as they are (the
  jet scenarios are not periodic; no minimum image is applied).

Frames are read once, in order; ``window = (t0, t1)`` keeps those with t0 <= time <= t1 (the
thesis averages over t u0/d = 50-100 in 3D, 180-300 in 2D). A single Frame is accepted too.

The scattering shell
--------------------
The outgoing flow is observed where it crosses a shell around ``centre``: a spherical (3D) or
circular (2D) shell R_s <= |r - centre| < R_s + ``shell_width`` with

    R_s = shell_factor * max(R_tar, R_jet) + shell_offset      (defaults 1.5 and 3 d; width 2 d),

so it lies outside the target and the incoming jet, where the sheet or cone has formed. The
jet scenarios delete grains beyond ``removal_radius`` (default max(R_tar, R_jet) + 15 d): keep
R_s + shell_width inside it (true with the defaults while max(R_tar, R_jet) < 20 d). A grain
in the shell counts as *scattered* when

* it moves outward, w_i = v_i . r_hat_i > 0 (the incoming jet crosses the upstream half of the
  shell moving inward and is excluded), and
* its velocity differs from the incoming one by more than ``deflection`` u0,
  |v_i - u0 n| > deflection u0 (default 0.25), so that jet grains passing undeflected beside a
  small target (X < 1) do not count. A cone at the thesis's smallest angle psi0 ~ C2 = 0.55
  rad has |v - u0 n| >= 2 u0 sin(psi0/2) ~ 0.54 u0 even without loss of speed.

The force balance
-----------------
:func:`force_balance_angle` is a second definition of psi0, the one of Clanet's model that
eq. (4.3) states, 1 - cos psi0 = F_wall / J_in, from the force of the grains on the target
(frames saved with contacts) and the momentum flux of the incoming jet; it uses no shell.

Errors are delete-one jackknife estimates over ``blocks`` consecutive groups of frames (for a
plain mean this is the usual std/sqrt(blocks) of the block means; for the ratios used here it
also copes with blocks that hold few grains). With one block (e.g. a single frame) the jackknife
runs over the individual grain samples instead, which treats grains as independent and
underestimates the error of a correlated flow.

Fits (:func:`fit_psi0`) use :func:`scipy.optimize.least_squares`; standard errors are the square
roots of the covariance diagonal, (J^T J)^-1 from the Jacobian J of the weighted residuals:
absolute when ``psi0_err`` is given, scaled by the residual variance chi^2/dof when not.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from math import pi

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from grainflow.analysis.cg import CGFields
from grainflow.analysis.checks import frozen as _frozen
from grainflow.analysis.checks import each_frame, paired_arrays
from grainflow.analysis.checks import non_negative as _non_negative
from grainflow.analysis.checks import positive as _positive
from grainflow.analysis.rheology import FitStatistics
from grainflow.frame import ANCHOR, PAIR, Frame

__all__ = [
    "TARGET_TYPE", "SEED_PSI0_FIT", "SEED_V2", "JET_AREA",
    "ScatteringAngle", "scattering_angle", "ForceBalanceAngle", "force_balance_angle",
    "psi0_interpolation", "Psi0Fit", "fit_psi0",
    "AzimuthalFlux", "azimuthal_flux", "Anisotropy", "anisotropy_v2",
    "eccentricity", "aspect_ratio", "rectangle_sides",
    "DeadZone", "dead_zone",
]

#: Particle type of the target's wall particles in the jet scenarios.
TARGET_TYPE = 2
#: Thesis fit of Fig. 4.2 (3D, frictional, phi0/phi_fcc = 0.90, D_jet = 4.5 d): (C0, C1, C2) rad.
SEED_PSI0_FIT = (1.68, 0.563, 0.554)
#: Experimental anisotropy (Cheng et al., PRL 99, 188001 (2007)) quoted in Sec. 4.2: (eps, v2).
SEED_V2 = (0.615, 0.16)
#: Cross-section area of the rectangular jets of Sec. 4.2, in d^2.
JET_AREA = 16.0

GrainSelection = None | Sequence[int] | Callable[[Frame], np.ndarray]


# --------------------------------------------------------------------------------------------
# Input checks and geometry
# --------------------------------------------------------------------------------------------


def _check_weighting(weighting: str) -> str:
    if weighting not in ("flux", "count"):
        raise ValueError(f"weighting: 'flux' or 'count', got {weighting!r}")
    return weighting


def _check_window(window: tuple[float, float] | None) -> None:
    if window is not None and not (len(window) == 2 and window[0] <= window[1]):
        raise ValueError(f"window: (t_start, t_end) with t_start <= t_end, got {window!r}")


def _each_frame(frames: Frame | Iterable[Frame]) -> Iterator[Frame]:
    return each_frame(frames)


def _in_window(frame: Frame, window: tuple[float, float] | None) -> bool:
    return window is None or window[0] <= frame.time <= window[1]


def _frames_in_window(frames: Frame | Iterable[Frame],
                      window: tuple[float, float] | None) -> Iterator[Frame]:
    _check_window(window)
    for frame in _each_frame(frames):
        if _in_window(frame, window):
            yield frame


def _selection_mask(frame: Frame, selection: GrainSelection, name: str,
                    default: Callable[[Frame], np.ndarray]) -> np.ndarray:
    """(N,) bool mask of a particle selection: None (``default``), types or a callable."""
    if selection is None:
        return default(frame)
    if callable(selection):
        mask = np.asarray(selection(frame), dtype=bool)
        if mask.shape != (frame.n,):
            raise ValueError(f"{name}: the selection must return a ({frame.n},) mask, got shape "
                             f"{mask.shape}")
        return mask
    try:
        types = np.asarray(list(selection), dtype=np.int64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: None, a sequence of particle types or a callable "
                         f"frame -> mask, got {selection!r}") from None
    return np.isin(np.asarray(frame.type), types)


def _grain_mask(frame: Frame, grains: GrainSelection) -> np.ndarray:
    """(N,) bool mask of the grains of ``frame`` (default: type != TARGET_TYPE)."""
    return _selection_mask(frame, grains, "grains",
                           lambda f: np.asarray(f.type) != TARGET_TYPE)


def _target_mask(frame: Frame, target: GrainSelection) -> np.ndarray:
    """(N,) bool mask of the target's particles of ``frame`` (default: type == TARGET_TYPE)."""
    return _selection_mask(frame, target, "target",
                           lambda f: np.asarray(f.type) == TARGET_TYPE)


@dataclass(frozen=True)
class _Geometry:
    dim: int
    n: np.ndarray  # unit direction of travel
    centre: np.ndarray


def _unit(name: str, vector: ArrayLike, dim: int) -> np.ndarray:
    v = np.asarray(vector, dtype=float)
    if v.shape != (dim,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: expected {dim} finite components for {dim}D frames, "
                         f"got {vector!r}")
    norm = float(np.linalg.norm(v))
    if norm == 0:
        raise ValueError(f"{name}: must not be the zero vector")
    return v / norm


def _geometry(dim: int, direction: ArrayLike | None, centre: ArrayLike | None) -> _Geometry:
    if dim not in (2, 3):
        raise ValueError(f"frames: expected 2D or 3D frames, got dim = {dim}")
    default = (-1.0, 0.0) if dim == 2 else (0.0, 0.0, -1.0)
    n = _unit("direction", default if direction is None else direction, dim)
    c = np.zeros(dim) if centre is None else np.asarray(centre, dtype=float)
    if c.shape != (dim,) or not np.all(np.isfinite(c)):
        raise ValueError(f"centre: expected {dim} finite components for {dim}D frames, "
                         f"got {centre!r}")
    return _Geometry(dim, n, c)


def _check_dim(frame: Frame, geo: _Geometry) -> None:
    if frame.dim != geo.dim:
        raise ValueError(f"frames: mixed dimensions, a {frame.dim}D frame at step {frame.step} "
                         f"after {geo.dim}D ones")


# --------------------------------------------------------------------------------------------
# Scattered grains in the shell
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Samples:
    """Scattered grains found in the shell, pooled over frames (one row per grain and frame)."""

    geo: _Geometry
    frame: np.ndarray  # (S,) index of the frame in the window
    n_frames: int
    mass: np.ndarray  # (S,)
    position: np.ndarray  # (S, dim), relative to the centre
    velocity: np.ndarray  # (S, dim)
    outward: np.ndarray  # (S,) v . r_hat > 0
    shell_radius: float
    shell_width: float


def _shell_samples(frames, *, target_radius, jet_radius, direction, centre, grains, window,
                   u0, deflection, shell_factor, shell_offset, shell_width) -> _Samples:
    r_tar = _positive("target_radius", target_radius)
    r_jet = _positive("jet_radius", jet_radius)
    u0 = _positive("u0", u0)
    deflection = _non_negative("deflection", deflection)
    r_s = _positive("shell_factor", shell_factor) * max(r_tar, r_jet) + _non_negative(
        "shell_offset", shell_offset)
    width = _positive("shell_width", shell_width)
    geo: _Geometry | None = None
    rows: dict[str, list[np.ndarray]] = {k: [] for k in ("frame", "m", "x", "v", "w")}
    n_frames = 0
    for frame in _frames_in_window(frames, window):
        if geo is None:
            geo = _geometry(frame.dim, direction, centre)
        _check_dim(frame, geo)
        mask = _grain_mask(frame, grains)
        x = np.asarray(frame.position, dtype=float)[mask] - geo.centre
        v = np.asarray(frame.velocity, dtype=float)[mask]
        m = np.asarray(frame.mass, dtype=float)[mask]
        r = np.linalg.norm(x, axis=1)
        in_shell = (r >= r_s) & (r < r_s + width)
        safe = np.where(r > 0, r, 1.0)
        w = np.einsum("ij,ij->i", v, x) / safe
        deflected = np.linalg.norm(v - u0 * geo.n, axis=1) > deflection * u0
        keep = in_shell & (w > 0) & deflected
        rows["frame"].append(np.full(int(keep.sum()), n_frames))
        rows["m"].append(m[keep])
        rows["x"].append(x[keep])
        rows["v"].append(v[keep])
        rows["w"].append(w[keep])
        n_frames += 1
    if geo is None:
        raise ValueError("frames: no frame lies in the window" if window is not None
                         else "frames: no frames given")
    frame_index = np.concatenate(rows["frame"]).astype(np.int64)
    if frame_index.size == 0:
        raise ValueError(
            f"frames: no scattered grains in the shell {r_s:g} <= r < {r_s + width:g} around "
            f"{geo.centre.tolist()} (grains moving outward with |v - u0 n| > {deflection:g} u0); "
            "check the window, the geometry and the grains selection")
    return _Samples(geo, frame_index, n_frames, np.concatenate(rows["m"]),
                    np.concatenate(rows["x"]), np.concatenate(rows["v"]),
                    np.concatenate(rows["w"]), r_s, width)


def _n_blocks(blocks: int | None, n_frames: int) -> int:
    """Checked number of jackknife blocks of frames; default min(10, n_frames)."""
    if blocks is None:
        blocks = min(10, n_frames)
    if not isinstance(blocks, (int, np.integer)) or isinstance(blocks, bool) or blocks < 1:
        raise ValueError(f"blocks: a positive integer, got {blocks!r}")
    if blocks > n_frames:
        raise ValueError(f"blocks: {blocks} blocks need at least as many frames; the window "
                         f"holds {n_frames}")
    return int(blocks)


def _block_of(frame: np.ndarray, n_frames: int, blocks: int) -> np.ndarray:
    """Block (of ``blocks`` groups of consecutive frames) of each frame index."""
    bounds = np.linspace(0, n_frames, blocks + 1).round().astype(int)
    return np.searchsorted(bounds, frame, side="right") - 1


def _units(samples: _Samples, blocks: int | None) -> tuple[np.ndarray, int, int]:
    """Jackknife unit of each sample, number of units, and the number of blocks (1: grains)."""
    blocks = _n_blocks(blocks, samples.n_frames)
    if blocks == 1:
        return np.arange(samples.frame.size), samples.frame.size, 1
    return _block_of(samples.frame, samples.n_frames, blocks), blocks, blocks


def _jackknife(estimate: Callable[..., np.ndarray], totals: Sequence[np.ndarray],
               per_unit: Sequence[np.ndarray]) -> np.ndarray:
    """Delete-one jackknife standard error of ``estimate(*sums)``.

    ``totals[k]`` are the pooled sums (any shape), ``per_unit[k]`` the same sums per unit
    (units first). NaN with fewer than two units.
    """
    n_units = per_unit[0].shape[0]
    if n_units < 2:
        return np.full(np.shape(estimate(*totals)), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        loo = estimate(*[np.asarray(t)[None, ...] - np.asarray(u)
                         for t, u in zip(totals, per_unit)])
        mean = np.nanmean(loo, axis=0)
        return np.sqrt((n_units - 1) / n_units * np.nansum((loo - mean) ** 2, axis=0))


def _unit_sums(unit: np.ndarray, n_units: int, values: np.ndarray) -> np.ndarray:
    """Sum of ``values`` (S,) or (S, K) per unit -> (n_units,) or (n_units, K)."""
    if values.ndim == 1:
        return np.bincount(unit, weights=values, minlength=n_units)
    return np.stack([np.bincount(unit, weights=values[:, k], minlength=n_units)
                     for k in range(values.shape[1])], axis=1)


# --------------------------------------------------------------------------------------------
# Scattering angle (Sec. 4.1, Fig. 4.2)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class ScatteringAngle:
    """Scattering angle of the outgoing flow (:func:`scattering_angle`).

    Attributes
    ----------
    psi0 : angle in rad between the direction of travel of the incoming jet and the mean
        (flux-weighted by default) velocity of the scattered grains in the meridional plane;
        pi/2 for a flat sheet, > pi/2 for a backward cone.
    psi0_err : jackknife standard error (see the module notes); NaN when it cannot be formed.
    axial, radial : the weighted means <v . n> and <v . e_rho> whose atan2 is psi0.
    n_grains : grain samples used (a grain counts once per frame it is found in the shell).
    n_frames : frames in the window; blocks : jackknife blocks (1: over grains).
    X : R_tar / R_jet; shell_radius, shell_width : the shell; weighting : "flux" or "count".
    """

    psi0: float
    psi0_err: float
    axial: float
    radial: float
    n_grains: int
    n_frames: int
    blocks: int
    X: float
    shell_radius: float
    shell_width: float
    weighting: str


def scattering_angle(
    frames: Frame | Iterable[Frame],
    *,
    target_radius: float,
    jet_radius: float,
    direction: ArrayLike | None = None,
    centre: ArrayLike | None = None,
    grains: GrainSelection = None,
    window: tuple[float, float] | None = None,
    u0: float = 1.0,
    deflection: float = 0.25,
    shell_factor: float = 1.5,
    shell_offset: float = 3.0,
    shell_width: float = 2.0,
    weighting: str = "flux",
    blocks: int | None = None,
) -> ScatteringAngle:
    """Scattering angle psi0 of a granular jet from particle data (thesis Sec. 4.1, Fig. 4.2).

    psi0 is measured from the incoming jet axis, the direction of travel n (seed 002,
    "psi0 convention" in PARAMETERS.md): eq. (4.3), 1 - cos psi0 = 4 A_cs / (pi D_jet^2), gives
    psi0 -> 0 for a vanishing target (narrow forward cone, psi0 ~ C1 X), pi/2 for a flat sheet
    along the target and > pi/2 for a backward cone (C0 = 1.68 rad for large targets).

    Extraction (the thesis does not say how it measured psi0; this is our definition). Take the
    scattered grains in the shell around the target centre (module notes: outward moving,
    deflected by more than ``deflection`` u0). Split each velocity into its component along
    the direction of travel, b_i = v_i . n, and its component away from the jet axis,
    a_i = v_i . e_rho,i, with e_rho,i the unit vector from the axis to the grain, perpendicular
    to n (2D: +-y; a grain exactly on the axis uses |v_perp|). Then::

        psi0 = atan2( sum_i w_i a_i , sum_i w_i b_i ),

    summed over the scattered grains of all frames of the window. Averaging the meridional
    components (not the velocity vectors, whose radial parts cancel round the axis) keeps
    psi0 in [0, pi]; averaging components rather than per-grain angles keeps thermal noise from
    biasing it.

    Weighting. ``"flux"`` (default): w_i = m_i (v_i . r_hat_i), the grain's outward radial
    velocity times its mass. sum_i w_i v_i / shell_width is then the momentum flux through the
    shell, so psi0 is the direction of the scattered momentum flux, the quantity whose axial
    part j_sc cos psi0 enters the momentum balance (4.2) of Clanet's model that defines psi0;
    every crossing counts once whatever its speed, and slow grains lingering in the shell
    (which a snapshot oversamples in proportion to 1/speed) do not bias it. ``"count"``:
    w_i = m_i, the direction of the mean (mass-weighted) velocity of the grains in the shell.
    The two agree when the outgoing grains share one speed.

    Parameters
    ----------
    frames : saved frames (a list, a generator such as :func:`grainflow.io.h5md.read_frames`,
        or one Frame).
    target_radius, jet_radius : R_tar and R_jet in units of d, > 0.
    direction : direction of travel of the jet; default -z (3D) or -x (2D).
    centre : where the jet axis meets the target surface; default the origin.
    grains : which particles are grains (module notes); default type != TARGET_TYPE.
    window : (t_start, t_end) of the steady state, inclusive; default every frame.
    u0 : speed of the incoming jet.
    deflection : minimum |v - u0 n| / u0 of a scattered grain, >= 0.
    shell_factor, shell_offset, shell_width : the shell R_s <= r < R_s + width with
        R_s = shell_factor * max(R_tar, R_jet) + shell_offset.
    weighting : "flux" or "count" (above).
    blocks : blocks of consecutive frames for the jackknife error; default min(10, frames);
        1 runs the jackknife over the grain samples.
    """
    weighting = _check_weighting(weighting)
    s = _shell_samples(frames, target_radius=target_radius, jet_radius=jet_radius,
                       direction=direction, centre=centre, grains=grains, window=window, u0=u0,
                       deflection=deflection, shell_factor=shell_factor,
                       shell_offset=shell_offset, shell_width=shell_width)
    n = s.geo.n
    b = s.velocity @ n
    perp = s.position - np.outer(s.position @ n, n)
    rho = np.linalg.norm(perp, axis=1)
    v_perp = s.velocity - np.outer(b, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(rho > 1e-12, np.einsum("ij,ij->i", v_perp, perp) / rho,
                     np.linalg.norm(v_perp, axis=1))
    w = s.mass * (s.outward if weighting == "flux" else 1.0)
    unit, n_units, n_blocks = _units(s, blocks)
    sums = [np.sum(w * a), np.sum(w * b), np.sum(w)]
    per_unit = [_unit_sums(unit, n_units, w * a), _unit_sums(unit, n_units, w * b)]
    psi0 = float(np.arctan2(sums[0], sums[1]))
    err = float(_jackknife(lambda ya, yb: np.arctan2(ya, yb), sums[:2], per_unit))
    return ScatteringAngle(
        psi0=psi0, psi0_err=err, axial=float(sums[1] / sums[2]),
        radial=float(sums[0] / sums[2]), n_grains=int(w.size), n_frames=s.n_frames,
        blocks=n_blocks, X=float(target_radius) / float(jet_radius),
        shell_radius=s.shell_radius, shell_width=s.shell_width, weighting=weighting,
    )


# --------------------------------------------------------------------------------------------
# Scattering angle from the force balance on the target (Sec. 4.1.1, Clanet's model)
# --------------------------------------------------------------------------------------------

#: Fraction of the jet's undisturbed extent kept (the middle) by ``line_density="initial"``.
_INITIAL_MIDDLE = 0.6
#: Smallest share of the first frame's grains that must move at u0 n (``"initial"``).
_INITIAL_UNDISTURBED = 0.95
#: At most this many equal sub-slabs, each at least _SUBSLAB_LENGTH long, give the error of
#: the initial line density (shorter ones would measure the lattice's layering).
_INITIAL_SUBSLABS = 10
_SUBSLAB_LENGTH = 10.0


@dataclass(frozen=True, kw_only=True)
class ForceBalanceAngle:
    """Scattering angle from the momentum balance on the target (:func:`force_balance_angle`).

    Attributes
    ----------
    psi0 : arccos(1 - F_wall / J_in) in rad, eq. (4.3); pi/2 when the target absorbs the
        incoming momentum flux J_in, > pi/2 when it receives more (backward cone).
    psi0_err : jackknife standard error over blocks of frames (the error of J_in is not
        included unless J_in comes from the window); NaN when it cannot be formed.
    ratio, ratio_err : F_wall / J_in = 1 - cos psi0 = 4 A_cs / (pi D_jet^2), the total cross
        section A_cs = F_wall / j_in of eq. (4.3) over the jet's cross-section, and its error.
    F_wall, F_wall_err : force of the grains on the target along the direction of travel n,
        averaged over the frames used, and its jackknife error.
    J_in, J_in_err : momentum flux of the incoming jet lambda m u0^2 (mass flow rate times u0)
        and its standard error (0 for a given line density; NaN for an initial jet too short
        for two sub-slabs).
    lambda_ : grains per unit length of the undisturbed jet.
    n_frames : frames whose force entered the mean; n_skipped : frames of the window left out
        (``line_density="window"``: upstream slab not filled by the jet).
    blocks : jackknife blocks (1: over single frames).
    force : "contacts" or "anchors"; line_density : "initial", "window" or "given".
    """

    psi0: float
    psi0_err: float
    ratio: float
    ratio_err: float
    F_wall: float
    F_wall_err: float
    J_in: float
    J_in_err: float
    lambda_: float
    n_frames: int
    n_skipped: int
    blocks: int
    force: str
    line_density: str


def _where(frame: Frame) -> str:
    return f"the frame at step {frame.step} (t = {frame.time:g})"


def _wall_force(frame: Frame, geo: _Geometry, grains: GrainSelection, target: GrainSelection,
                force: str) -> float:
    """F_wall . n of one frame: force of the grains on the target (or minus the anchors')."""
    c = frame.contacts
    if c is None:
        raise ValueError(f"frames: {_where(frame)} holds no contacts; save them with the run "
                         "(output.contacts = true) to measure the force on the target")
    t_mask = _target_mask(frame, target)
    if not t_mask.any():
        raise ValueError(f"target: {_where(frame)} holds no target particle (check the target "
                         "selection)")
    ids = np.asarray(frame.id)
    t_ids = ids[t_mask]
    f = np.asarray(c.force, dtype=float).reshape(-1, geo.dim)
    kind = np.asarray(c.kind)
    on_target = np.isin(c.i, t_ids)
    if force == "anchors":
        rows = (kind == ANCHOR) & on_target
        if not rows.any():
            raise ValueError(f"force: 'anchors' needs tether rows (kind ANCHOR) on the target; "
                             f"{_where(frame)} has none: use force='contacts'")
        return float(-(f[rows].sum(axis=0) @ geo.n))
    g_ids = ids[_grain_mask(frame, grains) & ~t_mask]
    pair = kind == PAIR
    from_grain = pair & on_target & np.isin(c.j, g_ids)  # force on target i from grain j
    on_grain = pair & np.isin(c.i, g_ids) & np.isin(c.j, t_ids)  # on grain i from target j
    return float((f[from_grain].sum(axis=0) - f[on_grain].sum(axis=0)) @ geo.n)


def _jet_grains(frame: Frame, geo: _Geometry, grains: GrainSelection, u0: float,
                undisturbed: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Of the grains: height h = (x - centre) . (-n) above the target surface, distance from
    the jet axis, mass, and the undisturbed flag |v - u0 n| <= undisturbed u0."""
    mask = _grain_mask(frame, grains)
    x = np.asarray(frame.position, dtype=float)[mask] - geo.centre
    v = np.asarray(frame.velocity, dtype=float)[mask]
    still = np.linalg.norm(v - u0 * geo.n, axis=1) <= undisturbed * u0
    h = -(x @ geo.n)
    lateral = np.linalg.norm(x + np.outer(h, geo.n), axis=1)
    return h, lateral, np.asarray(frame.mass, dtype=float)[mask], still


def _initial_line_density(frame: Frame, geo: _Geometry, grains: GrainSelection, u0: float,
                          undisturbed: float) -> tuple[float, float, float]:
    """(lambda, mass per length, its error) of the undisturbed jet in the first frame."""
    h, _, m, still = _jet_grains(frame, geo, grains, u0, undisturbed)
    if h.size == 0:
        raise ValueError(f"line_density: 'initial' found no grains in the first frame given "
                         f"({_where(frame)}); check the grains selection")
    share = float(still.mean())
    if share < _INITIAL_UNDISTURBED:
        raise ValueError(
            f"line_density: 'initial' measures the jet in the first frame given, which must "
            f"show the undisturbed jet (t = 0 of the jet scenarios); in {_where(frame)} only "
            f"{share:.1%} of the grains move at u0 n (within {undisturbed:g} u0). Pass the "
            "frames from t = 0, a number, or line_density='window'")
    hj, mj = h[still & (h > 0)], m[still & (h > 0)]
    if hj.size == 0:
        raise ValueError(f"line_density: no undisturbed grain upstream of the target in "
                         f"{_where(frame)}; check direction and centre")
    lo, hi = float(hj.min()), float(hj.max())
    trim = 0.5 * (1.0 - _INITIAL_MIDDLE) * (hi - lo)
    a, b = lo + trim, hi - trim
    inside = (hj >= a) & (hj < b)
    if b <= a or inside.sum() < 10:
        raise ValueError(f"line_density: the undisturbed jet in {_where(frame)} is too short "
                         f"to measure ({inside.sum()} grains in its middle "
                         f"{_INITIAL_MIDDLE:.0%}); pass a number")
    length = b - a
    k = min(_INITIAL_SUBSLABS, int(length // _SUBSLAB_LENGTH))
    err = float("nan")
    if k >= 2:
        sub = np.clip(((hj[inside] - a) / (length / k)).astype(int), 0, k - 1)
        per_sub = np.bincount(sub, weights=mj[inside], minlength=k) / (length / k)
        err = float(np.std(per_sub, ddof=1) / np.sqrt(k))
    return float(inside.sum()) / length, float(mj[inside].sum()) / length, err


def _psi0_of(ratio: np.ndarray) -> np.ndarray:
    return np.arccos(np.clip(1.0 - ratio, -1.0, 1.0))


def force_balance_angle(
    frames: Frame | Iterable[Frame],
    *,
    force: str = "contacts",
    line_density: str | float = "initial",
    direction: ArrayLike | None = None,
    centre: ArrayLike | None = None,
    grains: GrainSelection = None,
    target: GrainSelection = None,
    window: tuple[float, float] | None = None,
    upstream: tuple[float, float] = (10.0, 20.0),
    u0: float = 1.0,
    undisturbed: float = 0.05,
    blocks: int | None = None,
) -> ForceBalanceAngle:
    """Scattering angle psi0 defined by the momentum balance of Clanet's model (thesis
    Sec. 4.1.1, eqs. 4.1-4.3), from the force of the grains on the target.

    With the incoming momentum flux J_in = (pi D_jet^2 / 4) j_in, the scattered one
    J_sc = pi D_tar h(D_tar/2) j_sc and F_wall the force the grains exert on the target along
    the jet's direction of travel n, conservation of the flux (4.1) and the momentum balance
    along n (4.2) read::

        J_sc - J_in = 0,        J_sc cos psi0 - J_in = -F_wall,

    so that (4.3)::

        1 - cos psi0 = F_wall / J_in = 4 A_cs / (pi D_jet^2),   A_cs = F_wall / j_in.

    Here J_in = lambda m u0^2 (mass flow rate lambda m u0 times u0; lambda = grains per unit
    length of the undisturbed jet; masses are summed, so mixed masses are fine) and
    psi0 = arccos(1 - <F_wall> / J_in). This is the angle eq. (4.3) defines; the direction of
    the outgoing velocities (:func:`scattering_angle`) need not agree with it, since
    inelastic grains do not conserve the momentum flux (4.1).

    Force (``force``). ``"contacts"`` (default): per frame, the sum over the particle-pair
    contacts (kind PAIR of :class:`~grainflow.frame.Contacts`) between a target particle and
    a grain of the force on the target particle, projected on n (rows may list either
    particle first; for those listed on the grain, Newton's third law). Contacts between two
    target particles, tethers (BOND, ANCHOR) and wall contacts do not count. It is the force
    the grains exert, whatever holds the target. ``"anchors"``: minus the tether forces
    holding the target to its anchor points (ANCHOR rows on target particles), projected on
    n. In a steady state it equals the contact force on average (the bonds between target
    particles cancel in pairs), with the target's oscillations as extra noise; it needs a
    tethered target. Every frame in the window must hold contacts (``output.contacts``).

    Line density (``line_density``).

    * ``"initial"`` (default): measured in the first frame of ``frames``, whether or not it
      lies in the window. That frame must show the undisturbed jet (t = 0 of the jet
      scenarios, where every grain moves at u0 n): at least 95 % of its grains must move
      within ``undisturbed`` u0 of u0 n, else a ValueError. lambda = the undisturbed grains
      upstream of the target (h > 0, below) in the middle 60 % of their extent along n
      (trimming the lattice's ragged front and tail), over that length; J_in_err is the
      scatter of up to 10 equal sub-slabs of at least 10 d. The jet is uniform by
      construction (a lattice thinned at random), so this is lambda at every time, measured
      on many grains and untouched by the flow at the target or by the passage of the jet's
      tail. (The thinned lattice's lambda is not quite the continuum phi_tilde sqrt(2) A_jet
      of the 3D fcc jet: 20.27-20.41 over four seeds, +-0.06 each, against 20.24 for
      20,000 grains with D_jet = 4.5 d.)
    * ``"window"``: per frame of the window, the undisturbed grains (velocity within
      ``undisturbed`` u0 of u0 n) at heights ``upstream[0] <= h < upstream[1]`` above the
      target surface, h = (x - centre) . (-n); lambda = count / (upstream[1] - upstream[0]),
      averaged over the frames. A frame enters (its force too) only while the undisturbed
      jet fills the slab: some undisturbed grain at h >= upstream[1] (the jet's tail has not
      entered the slab), some grain at h < upstream[0] (its front has passed it), and no
      disturbed grain in the slab within 1 d of the jet's lateral extent there (the flow at
      the target does not reach it; in a small 3D run at X = 2.5 it reaches ~8 d above the
      target, hence the default slab 10-20 d; 2D, with its dead zone, may need more). Late
      in a run the tail empties the slab. Frames left out are counted in ``n_skipped``.
    * A number: lambda in grains per unit length, with m the mean grain mass of the first
      frame.

    ``"initial"`` is the default as the more robust: the window's slab holds fewer grains (a
    larger error), needs the jet to outlast the window by the slab's height (short runs
    fail) and a slab clear of the flow at the target, whose reach depends on X, the
    dimension and the packing.

    Errors are delete-one jackknife estimates over ``blocks`` consecutive groups of the frames
    used (module notes; with one block, over single frames), of F_wall, of the ratio and of
    psi0 itself. With ``"initial"`` or a number J_in is a constant of the jet and its error
    (J_in_err) is not included: it is small for a long jet (0.3 % for 20,000 grains), where
    the force fluctuates far more; with ``"window"`` the jackknife covers lambda too.

    Parameters
    ----------
    frames : saved frames with contacts (a list, a generator such as
        :func:`grainflow.io.h5md.read_frames`, or one Frame), read once, in order.
    force : "contacts" or "anchors" (above).
    line_density : "initial", "window" or lambda > 0 in grains per unit length (above).
    direction : direction of travel of the jet n; default -z (3D) or -x (2D).
    centre : where the jet axis meets the target surface; default the origin.
    grains : which particles are grains (module notes); default type != TARGET_TYPE.
    target : which particles make the target, like ``grains``; default type == TARGET_TYPE.
        A particle in both selections counts as target.
    window : (t_start, t_end) of the steady state, inclusive; default every frame.
    upstream : (h_lo, h_hi), 0 <= h_lo < h_hi, the slab of ``line_density="window"``.
    u0 : speed of the incoming jet, > 0.
    undisturbed : largest |v - u0 n| / u0 of an undisturbed jet grain, >= 0.
    blocks : blocks of consecutive frames for the jackknife; default min(10, frames).

    Raises ValueError when F_wall / J_in lies outside [0, 2], where eq. (4.3) has no angle
    (a wrong ``direction`` flips the sign of F_wall).
    """
    if force not in ("contacts", "anchors"):
        raise ValueError(f"force: 'contacts' or 'anchors', got {force!r}")
    given: float | None = None
    if isinstance(line_density, str):
        if line_density not in ("initial", "window"):
            raise ValueError(f"line_density: 'initial', 'window' or a positive number, got "
                             f"{line_density!r}")
        mode = line_density
    else:
        given = _positive("line_density", line_density)
        mode = "given"
    u0 = _positive("u0", u0)
    undisturbed = _non_negative("undisturbed", undisturbed)
    try:
        h_lo, h_hi = (float(x) for x in upstream)
    except (TypeError, ValueError):
        raise ValueError(f"upstream: (h_lo, h_hi) heights above the target, got "
                         f"{upstream!r}") from None
    if not (np.isfinite(h_lo) and np.isfinite(h_hi) and 0 <= h_lo < h_hi):
        raise ValueError(f"upstream: (h_lo, h_hi) with 0 <= h_lo < h_hi, got {upstream!r}")
    _check_window(window)
    geo: _Geometry | None = None
    first: tuple[float, float, float] | None = None  # (lambda, mass per length, error)
    mean_mass = float("nan")
    walls: list[float] = []
    masses: list[float] = []  # mass per unit length in the slab ("window")
    counts: list[int] = []
    n_in_window = 0
    for frame in _each_frame(frames):
        if geo is None:
            geo = _geometry(frame.dim, direction, centre)
            if mode == "initial":
                first = _initial_line_density(frame, geo, grains, u0, undisturbed)
            elif mode == "given":
                picked = _grain_mask(frame, grains)
                if not picked.any():
                    raise ValueError(f"grains: {_where(frame)} holds no grains to take the "
                                     "grain mass m of J_in = lambda m u0^2 from")
                mean_mass = float(np.mean(np.asarray(frame.mass)[picked]))
        _check_dim(frame, geo)
        if not _in_window(frame, window):
            continue
        n_in_window += 1
        if mode == "window":
            h, lateral, m, still = _jet_grains(frame, geo, grains, u0, undisturbed)
            in_slab = (h >= h_lo) & (h < h_hi)
            slab = still & in_slab
            filled = (bool(slab.any()) and bool(np.any(still & (h >= h_hi)))
                      and bool(np.any(h < h_lo)))
            if not filled:
                continue
            reach = float(lateral[slab].max()) + 1.0  # the jet's half-width, plus d
            if np.any(~still & in_slab & (lateral <= reach)):
                continue  # the disturbance near the target reaches the slab
            counts.append(int(slab.sum()))
            masses.append(float(m[slab].sum()) / (h_hi - h_lo))
        walls.append(_wall_force(frame, geo, grains, target, force))
    if geo is None:
        raise ValueError("frames: no frames given")
    if n_in_window == 0:
        raise ValueError("frames: no frame lies in the window")
    if not walls:
        raise ValueError(
            f"line_density: no frame of the window has the undisturbed jet filling the upstream "
            f"slab {h_lo:g} <= h < {h_hi:g} (undisturbed grains beyond it, the front past it, "
            "no disturbed grain in it); the jet's tail may have passed or the flow at the "
            "target reach the slab: use line_density='initial', move the window or upstream")
    F = np.asarray(walls)
    n_frames = F.size
    n_blocks = _n_blocks(blocks, n_frames)
    index = np.arange(n_frames)
    unit = index if n_blocks == 1 else _block_of(index, n_frames, n_blocks)
    n_units = n_frames if n_blocks == 1 else n_blocks
    ones = np.ones(n_frames)
    totals_F = [F.sum(), float(n_frames)]
    per_F = [_unit_sums(unit, n_units, F), _unit_sums(unit, n_units, ones)]
    F_mean = float(F.mean())
    F_err = float(_jackknife(lambda s, n: s / n, totals_F, per_F))
    if mode == "window":
        mu = np.asarray(masses)
        lam = float(np.mean(counts)) / (h_hi - h_lo)
        J_in = float(mu.mean()) * u0**2
        totals = [F.sum(), mu.sum()]
        per = [per_F[0], _unit_sums(unit, n_units, mu)]

        def ratio_of(sf, sm):
            return sf / (sm * u0**2)

        J_err = float(_jackknife(lambda sm, n: sm / n * u0**2, [mu.sum(), float(n_frames)],
                                 [per[1], per_F[1]]))
    else:
        if mode == "initial":
            assert first is not None
            lam, mass_per_length, mass_err = first
            J_in, J_err = mass_per_length * u0**2, mass_err * u0**2
        else:
            assert given is not None
            lam, J_in, J_err = given, given * mean_mass * u0**2, 0.0
        totals, per = totals_F, per_F

        def ratio_of(sf, n):
            return sf / n / J_in

    ratio = F_mean / J_in
    if not (np.isfinite(ratio) and 0.0 <= ratio <= 2.0):
        raise ValueError(
            f"F_wall / J_in = {ratio:.4g} (F_wall = {F_mean:.4g}, J_in = {J_in:.4g}) lies outside "
            "[0, 2], where 1 - cos psi0 = F_wall / J_in (eq. 4.3) has no angle; check direction "
            "(the jet's direction of travel), u0, the window and the line density")
    return ForceBalanceAngle(
        psi0=float(np.arccos(1.0 - ratio)),
        psi0_err=float(_jackknife(lambda *s: _psi0_of(ratio_of(*s)), totals, per)),
        ratio=float(ratio), ratio_err=float(_jackknife(ratio_of, totals, per)),
        F_wall=F_mean, F_wall_err=F_err,
        J_in=float(J_in), J_in_err=float(J_err), lambda_=float(lam), n_frames=int(n_frames),
        n_skipped=int(n_in_window - n_frames), blocks=n_blocks, force=force,
        line_density=mode,
    )


# --------------------------------------------------------------------------------------------
# psi0(X): interpolation function and fit (Fig. 4.2)
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Azimuthal flux dN/dphi and the anisotropy v_n (Sec. 4.2, Fig. 4.3)
# --------------------------------------------------------------------------------------------


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


def _azimuths(s: _Samples, reference_axis: ArrayLike | None, azimuth: str) -> np.ndarray:
    """phi of each sample in the target plane, from the reference axis, right-handed about -n."""
    if s.geo.dim != 3:
        raise ValueError("frames: the azimuthal flux and v_n need 3D frames; a 2D jet has no "
                         "azimuth (its two branches are +-y)")
    if azimuth not in ("position", "velocity"):
        raise ValueError(f"azimuth: 'position' or 'velocity', got {azimuth!r}")
    up = -s.geo.n
    ref = _unit("reference_axis", (1.0, 0.0, 0.0) if reference_axis is None
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
    weighting = _check_weighting(weighting)
    s = _shell_samples(frames, target_radius=target_radius, jet_radius=jet_radius, **geometry)
    phi = _azimuths(s, reference_axis, azimuth)
    w = s.outward if weighting == "flux" else np.ones_like(s.outward)
    unit, n_units, n_blocks = _units(s, blocks)
    return s, phi, w, unit, n_units, n_blocks, weighting


def _harmonic(phi, w, unit, n_units, order):
    c = w * np.cos(order * phi)
    totals = [np.sum(c), np.sum(w)]
    per_unit = [_unit_sums(unit, n_units, c), _unit_sums(unit, n_units, w)]
    v = float(totals[0] / totals[1])
    return v, float(_jackknife(lambda a, b: a / b, totals, per_unit))


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
    per_unit_total = _unit_sums(unit, n_units, w)

    def density(h, t):
        return h / (np.asarray(t)[..., None] * width)

    err = _jackknife(density, [hist, np.asarray(total)], [per_unit_hist, per_unit_total])
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


# --------------------------------------------------------------------------------------------
# Dead zone (Sec. 6.1.1)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class DeadZone:
    """Frozen cells next to the target (:func:`dead_zone`).

    Attributes
    ----------
    mask : bool array of the grid's shape, True for dead cells.
    speed : mean speed |V| per cell (NaN where too few grains were seen).
    thermal_speed : sqrt(T_g / m) per cell, T_g = sum_i m_i |v_i - V|^2 / (D N) and m the
        mean grain mass in the cell (NaN where too few grains).
    samples : grain samples per cell (frames path), or None (coarse-grained fields).
    edges : the grid's bin edges per axis: (height, lateral) for the frames path.
    extent : per axis, the (lo, hi) edges of the box holding every dead cell; (nan, nan) if none.
    thickness : frames path: per lateral column, the height of the stack of dead cells that
        starts at the target (0 when the first cell is alive); None for fields.
    height : max of ``thickness`` (frames path; NaN for fields).
    found : whether any cell is dead (frames path: any dead cell touching the target).
    speed_threshold, thermal_threshold : the thresholds, in units of u0.
    """

    mask: np.ndarray
    speed: np.ndarray
    thermal_speed: np.ndarray
    samples: np.ndarray | None
    edges: tuple[np.ndarray, ...]
    extent: tuple[tuple[float, float], ...]
    thickness: np.ndarray | None
    height: float
    found: bool
    speed_threshold: float
    thermal_threshold: float


def _extent(mask: np.ndarray, edges: Sequence[np.ndarray]) -> tuple[tuple[float, float], ...]:
    out = []
    for axis, e in enumerate(edges):
        others = tuple(a for a in range(mask.ndim) if a != axis)
        hit = np.nonzero(mask.any(axis=others) if others else mask)[0]
        out.append((float(e[hit.min()]), float(e[hit.max() + 1])) if hit.size
                   else (float("nan"), float("nan")))
    return tuple(out)


def dead_zone(
    source: CGFields | Frame | Iterable[Frame],
    *,
    target_radius: float | None = None,
    direction: ArrayLike | None = None,
    centre: ArrayLike | None = None,
    grains: GrainSelection = None,
    window: tuple[float, float] | None = None,
    u0: float = 1.0,
    speed_threshold: float = 0.1,
    thermal_threshold: float = 0.05,
    layer_thickness: float = 5.0,
    depth: float = 10.0,
    lateral_bins: int | None = None,
    min_samples: int = 5,
) -> DeadZone:
    """Dead zone near the target: cells where the grains are frozen (thesis Sec. 6.1.1).

    A cell is *dead* when it holds at least ``min_samples`` grain samples (summed over the
    frames) and both its mean speed and its thermal speed are small::

        |V| < speed_threshold u0   and   sqrt(T_g / m) < thermal_threshold u0,

    V = sum m v / sum m and T_g = sum_i m_i |v_i - V|^2 / (D N) over the grains of the cell in all
    frames of the window (the thesis's T_g, fluctuations about the window's mean velocity), m the
    mean grain mass. A small mean speed alone is not enough: it holds at every stagnation point,
    and in 3D the granular temperature is largest there (no dead zone); the thesis finds a frozen
    layer (a), 0 < x <= 5 d, only in 2D. Defaults 0.1 and 0.05 (T_g < 2.5e-3 m u0^2) are ours;
    the thesis gives no number.

    ``source`` is either frames, binned here on a grid next to the target, or coarse-grained
    fields (:func:`grainflow.analysis.cg.coarse_grain`, e.g. with ``contacts=False``), whose own
    grid is used (their ``velocity``, ``temperature``, ``number_density`` and ``mass_density``;
    cells with no grain are not dead; ``min_samples`` and the geometry arguments are then unused).

    Grid of the frames path: height h = (r - centre) . (-n) above the target surface, in layers
    (lo, hi] of ``layer_thickness`` from 0 to ``depth`` (defaults: the thesis's layers (a) 0-5 d
    and (b) 5-10 d); lateral coordinate over the target, |lateral| <= R_tar: in 2D the signed
    distance from the axis (+y for the default geometry), ``lateral_bins`` cells (default 11, as
    Sec. 6.1.3); in 3D the distance rho from the axis, ``lateral_bins`` rings of equal width
    (default 5, Delta r = R_tar / 5).

    Parameters
    ----------
    source : CGFields, or frames (a list, a generator, one Frame).
    target_radius : R_tar, required with frames.
    direction, centre, grains, window : as :func:`scattering_angle`.
    u0 : jet speed.
    speed_threshold, thermal_threshold : fractions of u0, > 0.
    layer_thickness, depth : height cells, > 0; depth >= layer_thickness.
    lateral_bins : number of lateral cells, >= 1.
    min_samples : fewest grain samples for a cell to be classified, >= 1.
    """
    u0 = _positive("u0", u0)
    a = _positive("speed_threshold", speed_threshold)
    b = _positive("thermal_threshold", thermal_threshold)
    if isinstance(source, CGFields):
        n = source.number_density
        rho = source.mass_density
        with np.errstate(invalid="ignore", divide="ignore"):
            speed = np.linalg.norm(source.velocity, axis=-1)
            thermal = np.sqrt(source.temperature / (rho / n))
        seen = np.isfinite(speed) & np.isfinite(thermal) & (n > 0)
        speed, thermal = np.where(seen, speed, np.nan), np.where(seen, thermal, np.nan)
        mask = seen & (speed < a * u0) & (thermal < b * u0)
        edges = tuple(source.coordinates.edges)
        return DeadZone(mask=mask, speed=speed, thermal_speed=thermal, samples=None,
                        edges=edges, extent=_extent(mask, edges), thickness=None,
                        height=float("nan"), found=bool(mask.any()), speed_threshold=a,
                        thermal_threshold=b)
    if target_radius is None:
        raise ValueError("target_radius: required when dead_zone is given frames")
    r_tar = _positive("target_radius", target_radius)
    dz = _positive("layer_thickness", layer_thickness)
    depth = _positive("depth", depth)
    if depth < dz:
        raise ValueError(f"depth: must be >= layer_thickness ({dz:g}), got {depth!r}")
    if not isinstance(min_samples, (int, np.integer)) or min_samples < 1:
        raise ValueError(f"min_samples: a positive integer, got {min_samples!r}")
    if lateral_bins is not None and (not isinstance(lateral_bins, (int, np.integer))
                                     or lateral_bins < 1):
        raise ValueError(f"lateral_bins: a positive integer, got {lateral_bins!r}")
    n_h = int(np.ceil(depth / dz - 1e-9))
    h_edges = np.arange(n_h + 1) * dz
    geo: _Geometry | None = None
    sums = None
    for frame in _frames_in_window(source, window):
        if geo is None:
            geo = _geometry(frame.dim, direction, centre)
            n_lat = lateral_bins or (11 if geo.dim == 2 else 5)
            lat_edges = (np.linspace(-r_tar, r_tar, n_lat + 1) if geo.dim == 2
                         else np.linspace(0.0, r_tar, n_lat + 1))
            n_cells = n_h * n_lat
            sums = {"n": np.zeros(n_cells), "m": np.zeros(n_cells),
                    "p": np.zeros((n_cells, geo.dim)), "mvv": np.zeros(n_cells)}
        _check_dim(frame, geo)
        mask = _grain_mask(frame, grains)
        x = np.asarray(frame.position, dtype=float)[mask] - geo.centre
        v = np.asarray(frame.velocity, dtype=float)[mask]
        m = np.asarray(frame.mass, dtype=float)[mask]
        h = -(x @ geo.n)
        perp = x + np.outer(h, geo.n)
        if geo.dim == 2:
            lateral = perp @ np.array([geo.n[1], -geo.n[0]])
        else:
            lateral = np.linalg.norm(perp, axis=1)
        ih = np.searchsorted(h_edges, h, side="left") - 1  # cells (lo, hi]
        il = np.searchsorted(lat_edges, lateral, side="right") - 1
        il = np.where(lateral == lat_edges[-1], n_lat - 1, il)  # |lateral| <= R_tar
        ok = (ih >= 0) & (ih < n_h) & (il >= 0) & (il < n_lat)
        cell = ih[ok] * n_lat + il[ok]
        sums["n"] += np.bincount(cell, minlength=n_cells)
        sums["m"] += np.bincount(cell, weights=m[ok], minlength=n_cells)
        for k in range(geo.dim):
            sums["p"][:, k] += np.bincount(cell, weights=m[ok] * v[ok, k], minlength=n_cells)
        sums["mvv"] += np.bincount(cell, weights=m[ok] * np.sum(v[ok] ** 2, axis=1),
                                   minlength=n_cells)
    if geo is None or sums is None:
        raise ValueError("source: no frame lies in the window" if window is not None
                         else "source: no frames given")
    seen = sums["n"] >= min_samples
    with np.errstate(invalid="ignore", divide="ignore"):
        V = sums["p"] / sums["m"][:, None]
        speed = np.linalg.norm(V, axis=1)
        # sum m |v - V|^2 = sum m v^2 - M |V|^2; T_g / m_mean = that / (D * M)
        fluct = np.maximum(sums["mvv"] - sums["m"] * speed**2, 0.0)
        thermal = np.sqrt(fluct / (geo.dim * sums["m"]))
    shape = (n_h, n_lat)
    speed = np.where(seen, speed, np.nan).reshape(shape)
    thermal = np.where(seen, thermal, np.nan).reshape(shape)
    dead = (seen.reshape(shape) & (speed < a * u0) & (thermal < b * u0))
    alive = ~dead
    first_alive = np.where(alive.any(axis=0), alive.argmax(axis=0), n_h)
    thickness = h_edges[first_alive]
    edges = (_frozen(h_edges), _frozen(lat_edges))
    return DeadZone(mask=dead, speed=speed, thermal_speed=thermal,
                    samples=sums["n"].reshape(shape).astype(np.int64), edges=edges,
                    extent=_extent(dead, edges), thickness=_frozen(thickness),
                    height=float(thickness.max()), found=bool(thickness.max() > 0),
                    speed_threshold=a, thermal_threshold=b)
