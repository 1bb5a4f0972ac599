"""Droplets of a granular stream: shapes, aspect ratios, tracking and separation velocities
(SPEC A7), after seed 000 (Waitukaitis et al., PRE 83, 051302 (2011)), Sec. II-III and the
Appendix.

Droplets. A droplet is a network (:mod:`~grainflow.analysis.stream.networks`: connected
component of the contact relation |r_i - r_j| < r_i + r_j + delta) of at least ``min_grains``
= 30 grains (seed: "droplet widths and heights are calculated for networks with 30 or more
particles").

Shape (:func:`droplet_shape`), from the n grain centres r_k of a droplet:

* centre of mass c = (1/n) sum r_k (monodisperse grains; equal masses);
* gyration tensor S = (1/n) sum (r_k - c)(r_k - c)^T; the principal axis a is the unit
  eigenvector of its largest eigenvalue, oriented downstream (a_z <= 0, i.e. towards larger
  depth; if a_z = 0 its first non-zero component is made positive);
* length L = max_k s_k - min_k s_k with s_k = (r_k - c) . a: "the maximum extent of a network
  along its principal axis" (seed). Between grain *centres* by default; with
  ``include_grain_size`` one mean grain diameter is added (extent between surfaces);
* width W: "the mean radial extent from the principal axis of each droplet averaged over all
  angles (partitioned into N bins)" (seed; N is lost, NF). Here: the azimuth phi_k of each
  grain about the axis (from a fixed perpendicular reference) is put in one of
  ``n_azimuth_bins`` = 8 equal bins; in each bin the largest radial distance rho_k =
  |(r_k - c) - s_k a| is the radial extent in that direction; W is the mean over the non-empty
  bins. W is thus a *radius* (half-width); with ``include_grain_size`` one mean grain radius is
  added;
* aspect ratio A = L / (2 W): length over full width (the seed's "length to width aspect
  ratio", with width = diameter: a sphere of grains gives A ~ 1 and most droplets lie between
  1 and 3, as the seed reports).

Selection (:func:`select_droplets`, seed Appendix): droplets whose centre of mass lies deeper
than ``min_depth`` = 20 cm ("to ensure droplets are fully formed / completely separated"),
after excluding the ``exclude_farthest`` = 1000 droplets farthest from the aperture ("effects
of stream initialization (e.g. plug formation) are avoided"). The droplets given are pooled
(from one or several frames); the exclusion ranks them all by depth. A short run has far fewer
droplets than the seed's: pass a smaller ``exclude_farthest`` (0 disables it).

Aspect-ratio histogram (:func:`aspect_ratio_histogram`): the most probable value is the centre
of the fullest bin; the fraction between 1 and 3 (seed: "?% of droplets", NF; most probable
value ~ 2) is counted from the values, 1 <= A <= 3.

Tracking (:func:`track_droplets`). Droplets of consecutive frames are matched by the particle
ids they share (stable ids). Droplet a of frame k continues as droplet b of frame k + 1 when
they share more than ``overlap`` (default 0.5) of the grains of *each*:

    shared(a, b) > overlap * max(n_a, n_b).

With overlap >= 0.5 such a b is a's largest-overlap partner and unique (and vice versa), so a
track never forks. Small exchanges (a few grains lost or gained, a small fragment shed or
absorbed) keep the track; when droplets of comparable size merge or a droplet splits into
comparable parts, no partner passes the test: the old tracks *end* (reason "merged" if most of
a's grains went into one droplet of the next frame, "split" if most went into several, "lost"
otherwise, e.g. the droplet fell out of the frame or broke below ``min_grains``) and the
droplets of the next frame start new tracks (reason "merged", "split", "new"; "first" in the
first frame). A track ends with "end" at the last frame.

Separations (:func:`droplet_separations`). In each frame the tracked droplets present are
ordered by depth; two tracks are *adjacent* in the frames where they are consecutive in that
order. For each adjacent pair, Delta z(t) = depth(lower) - depth(upper) (the vertical distance
between centres of mass, > 0) over those frames, and the separation velocity Delta v is the
slope of a least-squares line (:func:`scipy.stats.linregress`, with its standard error).
The seed's free-fall prediction for two points a distance Delta z0 apart at the aperture
(:func:`free_fall_separation_velocity`) is

    Delta v0 = sqrt(v0^2 + 2 g Delta z0) - v0  (~ g Delta z0 / v0),

and Delta z0, the separation when the pair's centre passed the aperture, is estimated (when
v0 is given) by assuming free fall of the pair's centre from the aperture: the time since the
crossing of a centre at depth h is (sqrt(v0^2 + 2 g h) - v0) / g; t0 is the mean of the
crossing times so obtained, and Delta z0 the fitted line at t0.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.stats import linregress

from grainflow.analysis.stream._common import (GRAVITY, _count, _each_frame, _finite, _frozen,
                                               _non_negative, _positions, _positive)
from grainflow.analysis.stream.networks import Networks, frame_networks
from grainflow.frame import Frame

__all__ = [
    "SEED_MIN_GRAINS", "SEED_MIN_DEPTH", "SEED_EXCLUDE_FARTHEST", "DEFAULT_AZIMUTH_BINS",
    "DropletShape", "droplet_shape", "Droplet", "find_droplets",
    "DropletSelection", "select_droplets", "AspectHistogram", "aspect_ratio_histogram",
    "DropletTrack", "track_droplets", "DropletSeparation", "droplet_separations",
    "free_fall_separation_velocity",
]

#: Smallest droplet (grains), depth of fully formed droplets (m), droplets excluded as the
#: farthest from the aperture (seed 000, Appendix).
SEED_MIN_GRAINS = 30
SEED_MIN_DEPTH = 0.20
SEED_EXCLUDE_FARTHEST = 1000
#: Azimuth bins of the width (the seed's number is lost).
DEFAULT_AZIMUTH_BINS = 8


# --------------------------------------------------------------------------------------------
# Shape of one droplet
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class DropletShape:
    """Centre, principal axis, length, width and aspect ratio of a droplet (module docstring).

    Attributes
    ----------
    centre : (3,) centre of mass (m).
    axis : (3,) unit principal axis, oriented downstream (axis[2] <= 0).
    length : extent along the axis (m); width : mean radial extent (a half-width, m).
    aspect_ratio : length / (2 width) (NaN when width is 0).
    eigenvalues : (3,) gyration-tensor eigenvalues, largest first (m^2).
    """

    centre: np.ndarray
    axis: np.ndarray
    length: float
    width: float
    aspect_ratio: float
    eigenvalues: np.ndarray


def _orient(axis: np.ndarray) -> np.ndarray:
    if axis[2] != 0:
        return axis if axis[2] < 0 else -axis
    first = axis[np.flatnonzero(axis)[0]]
    return axis if first > 0 else -axis


def droplet_shape(
    positions: ArrayLike,
    *,
    n_azimuth_bins: int = DEFAULT_AZIMUTH_BINS,
    grain_diameter: float = 0.0,
) -> DropletShape:
    """Shape of a droplet from its grains' centres (definitions in the module docstring).

    Parameters
    ----------
    positions : (n, 3) grain centres, n >= 2.
    n_azimuth_bins : azimuth bins of the width (the seed's N, NF).
    grain_diameter : added to the length, and half of it to the width, to measure the extent
        to the grains' surfaces; 0 (default) measures between centres.
    """
    x = _positions(positions)
    if x.shape[0] < 2:
        raise ValueError(f"positions: a droplet needs at least 2 grains, got {x.shape[0]}")
    nb = _count("n_azimuth_bins", n_azimuth_bins, 1)
    dd = _non_negative("grain_diameter", grain_diameter)
    centre = x.mean(axis=0)
    rel = x - centre
    gyration = rel.T @ rel / x.shape[0]
    vals, vecs = np.linalg.eigh(gyration)
    axis = _orient(vecs[:, -1])
    s = rel @ axis
    length = float(s.max() - s.min()) + dd
    radial = rel - np.outer(s, axis)
    ref = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e1 = ref - (ref @ axis) * axis
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = np.arctan2(radial @ e2, radial @ e1)
    k = np.minimum(((phi + np.pi) / (2.0 * np.pi) * nb).astype(np.int64), nb - 1)
    rho = np.linalg.norm(radial, axis=1)
    extent = np.full(nb, -np.inf)
    np.maximum.at(extent, k, rho)
    width = float(extent[np.isfinite(extent)].mean()) + 0.5 * dd
    aspect = length / (2.0 * width) if width > 0 else float("nan")
    return DropletShape(centre=_frozen(centre), axis=_frozen(axis), length=length, width=width,
                        aspect_ratio=float(aspect), eigenvalues=_frozen(vals[::-1]))


# --------------------------------------------------------------------------------------------
# Droplets of a frame
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class Droplet(DropletShape):
    """A droplet found in a frame (:func:`find_droplets`).

    Attributes (besides the shape's)
    ----------
    step, time : of the frame.
    label : its network label in the frame's :class:`Networks`.
    ids : (n,) sorted stable particle ids of its grains.
    velocity : (3,) mean velocity of its grains (m/s).
    """

    step: int
    time: float
    label: int
    ids: np.ndarray
    velocity: np.ndarray

    @property
    def n_grains(self) -> int:
        return int(self.ids.size)

    @property
    def depth(self) -> float:
        """Depth of the centre of mass below the aperture, -z (m)."""
        return float(-self.centre[2])


def find_droplets(
    frame: Frame,
    delta: float,
    *,
    min_grains: int = SEED_MIN_GRAINS,
    n_azimuth_bins: int = DEFAULT_AZIMUTH_BINS,
    include_grain_size: bool = False,
    min_depth: float | None = None,
    grain_type: int | None = 0,
    networks: Networks | None = None,
) -> list[Droplet]:
    """The droplets of a frame: networks of at least ``min_grains`` grains (seed: 30), with
    their shapes, sorted from the shallowest to the deepest centre of mass.

    Parameters
    ----------
    frame : a 3D Frame.
    delta : cohesive shell thickness (m), for the networks.
    min_grains : smallest droplet, >= 2.
    n_azimuth_bins : see :func:`droplet_shape`.
    include_grain_size : measure length and width to the grains' surfaces (adds the mean
        grain diameter to L and radius to W) instead of between centres.
    min_depth : keep only droplets whose centre of mass is deeper than this (m); e.g. 0 drops
        the network of grains still in the hopper. Default: all.
    grain_type : particle type of the grains (None: every particle).
    networks : :func:`frame_networks` of this frame, to skip the search.
    """
    frame = next(_each_frame(frame))
    k_min = _count("min_grains", min_grains, 2)
    nets = frame_networks(frame, delta, grain_type=grain_type) if networks is None else networks
    if not isinstance(nets, Networks):
        raise ValueError(f"networks: expected a Networks result, got {type(nets).__name__}")
    z_min = None if min_depth is None else _finite("min_depth", min_depth)
    position = np.asarray(frame.position, dtype=float)
    velocity = np.asarray(frame.velocity, dtype=float)
    radius = np.asarray(frame.radius, dtype=float)
    ids = np.asarray(frame.id, dtype=np.int64)
    order = np.argsort(nets.label, kind="stable")
    starts = np.searchsorted(nets.label[order], np.arange(nets.n_networks + 1))
    out: list[Droplet] = []
    for label in np.flatnonzero(nets.sizes >= k_min):
        rows = nets.index[order[starts[label]:starts[label + 1]]]
        x = position[rows]
        if z_min is not None and -x[:, 2].mean() <= z_min:
            continue
        dd = 2.0 * float(radius[rows].mean()) if include_grain_size else 0.0
        shape = droplet_shape(x, n_azimuth_bins=n_azimuth_bins, grain_diameter=dd)
        out.append(Droplet(centre=shape.centre, axis=shape.axis, length=shape.length,
                           width=shape.width, aspect_ratio=shape.aspect_ratio,
                           eigenvalues=shape.eigenvalues, step=int(frame.step),
                           time=float(frame.time), label=int(label),
                           ids=_frozen(np.sort(ids[rows]), np.int64),
                           velocity=_frozen(velocity[rows].mean(axis=0))))
    out.sort(key=lambda d: d.depth)
    return out


# --------------------------------------------------------------------------------------------
# Selection and aspect ratios
# --------------------------------------------------------------------------------------------


def _droplet_list(name: str, droplets: Iterable[Droplet]) -> list[Droplet]:
    out = list(droplets)
    for d in out:
        if not isinstance(d, Droplet):
            raise ValueError(f"{name}: expected Droplet objects (from find_droplets), got "
                             f"{type(d).__name__}")
    return out


@dataclass(frozen=True, kw_only=True)
class DropletSelection:
    """Droplets kept by :func:`select_droplets`, with how many each rule removed."""

    droplets: tuple[Droplet, ...]
    n_input: int
    n_excluded_farthest: int
    n_too_shallow: int
    min_depth: float
    exclude_farthest: int

    @property
    def aspect_ratios(self) -> np.ndarray:
        return np.array([d.aspect_ratio for d in self.droplets], dtype=float)


def select_droplets(
    droplets: Iterable[Droplet],
    *,
    min_depth: float = SEED_MIN_DEPTH,
    exclude_farthest: int = SEED_EXCLUDE_FARTHEST,
) -> DropletSelection:
    """The seed's selection of fully formed droplets: drop the ``exclude_farthest`` droplets
    deepest below the aperture (all droplets given ranked together; seed: 1000), then keep
    those whose centre of mass lies deeper than ``min_depth`` (seed: 20 cm)."""
    items = _droplet_list("droplets", droplets)
    z_min = _finite("min_depth", min_depth)
    n_far = _count("exclude_farthest", exclude_farthest, 0)
    ranked = sorted(items, key=lambda d: d.depth, reverse=True)
    rest = ranked[n_far:]
    kept = [d for d in rest if d.depth > z_min]
    kept.sort(key=lambda d: (d.time, d.depth))
    return DropletSelection(droplets=tuple(kept), n_input=len(items),
                            n_excluded_farthest=len(ranked) - len(rest),
                            n_too_shallow=len(rest) - len(kept), min_depth=z_min,
                            exclude_farthest=n_far)


@dataclass(frozen=True, kw_only=True)
class AspectHistogram:
    """Histogram of droplet aspect ratios (:func:`aspect_ratio_histogram`).

    Attributes
    ----------
    edges : (B + 1,) bin edges; counts : (B,) droplets per bin; density : (B,) counts / (n w).
    n : droplets (finite aspect ratios); n_outside : of which outside the edges.
    mode : centre of the fullest bin (the most probable aspect ratio; seed ~ 2).
    fraction_1_3, fraction_1_3_err : fraction with 1 <= A <= 3 and its binomial error.
    mean, median : of the values.
    """

    edges: np.ndarray
    counts: np.ndarray
    density: np.ndarray
    n: int
    n_outside: int
    mode: float
    fraction_1_3: float
    fraction_1_3_err: float
    mean: float
    median: float


def aspect_ratio_histogram(
    aspect_ratios: ArrayLike | Iterable[Droplet] | DropletSelection,
    *,
    bins: int | ArrayLike = 32,
    max_aspect: float = 8.0,
) -> AspectHistogram:
    """Histogram of aspect ratios with the most probable value and the fraction between 1 and
    3 (seed 000, Fig. 2c).

    Parameters
    ----------
    aspect_ratios : values, droplets, or a :class:`DropletSelection`. NaN values are dropped.
    bins : number of equal bins on [0, max_aspect], or the edges.
    max_aspect : upper edge when ``bins`` is a number.
    """
    if isinstance(aspect_ratios, DropletSelection):
        values = aspect_ratios.aspect_ratios
    else:
        items = list(aspect_ratios) if not isinstance(aspect_ratios, np.ndarray) \
            else aspect_ratios
        if len(items) and all(isinstance(d, Droplet) for d in items):
            values = np.array([d.aspect_ratio for d in items], dtype=float)
        else:
            try:
                values = np.asarray(items, dtype=float)
            except (TypeError, ValueError):
                raise ValueError("aspect_ratios: expected numbers or Droplet objects") from None
    if values.ndim != 1:
        raise ValueError(f"aspect_ratios: expected a 1-D array, got shape {values.shape}")
    values = values[np.isfinite(values)]
    if values.size == 0:
        raise ValueError("aspect_ratios: no finite aspect ratio to histogram")
    if np.any(values < 0):
        raise ValueError("aspect_ratios: values must be >= 0")
    if np.ndim(bins) == 0:
        nb = _count("bins", bins, 1)  # type: ignore[arg-type]
        edges = np.linspace(0.0, _positive("max_aspect", max_aspect), nb + 1)
    else:
        edges = np.asarray(bins, dtype=float)
        if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
            raise ValueError("bins: expected a number of bins or increasing edges")
    counts, _ = np.histogram(values, bins=edges)
    n = int(values.size)
    density = counts / (n * np.diff(edges))
    k = int(np.argmax(counts))
    p = float(np.mean((values >= 1.0) & (values <= 3.0)))
    return AspectHistogram(edges=_frozen(edges), counts=_frozen(counts, np.int64),
                           density=_frozen(density), n=n,
                           n_outside=int(n - counts.sum()),
                           mode=float(0.5 * (edges[k] + edges[k + 1])),
                           fraction_1_3=p, fraction_1_3_err=float(np.sqrt(p * (1 - p) / n)),
                           mean=float(values.mean()), median=float(np.median(values)))


# --------------------------------------------------------------------------------------------
# Tracking
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class DropletTrack:
    """One droplet followed over consecutive frames (:func:`track_droplets`).

    Attributes
    ----------
    track_id : index in the list of tracks.
    droplets : the droplet in each frame, in time order.
    start : "first", "new", "merged" or "split"; end : "end", "lost", "merged" or "split"
        (module docstring).
    """

    track_id: int
    droplets: tuple[Droplet, ...]
    start: str
    end: str

    @property
    def times(self) -> np.ndarray:
        return np.array([d.time for d in self.droplets])

    @property
    def depths(self) -> np.ndarray:
        return np.array([d.depth for d in self.droplets])

    @property
    def centres(self) -> np.ndarray:
        return np.array([d.centre for d in self.droplets])

    @property
    def n_grains(self) -> np.ndarray:
        return np.array([d.n_grains for d in self.droplets])


def _shared_counts(prev: list[Droplet], nxt: list[Droplet]) -> np.ndarray:
    """(len(prev), len(nxt)) numbers of shared particle ids."""
    shared = np.zeros((len(prev), len(nxt)), dtype=np.int64)
    if not prev or not nxt:
        return shared
    all_ids = np.concatenate([d.ids for d in nxt])
    owner = np.concatenate([np.full(d.ids.size, k) for k, d in enumerate(nxt)])
    order = np.argsort(all_ids, kind="stable")
    all_ids, owner = all_ids[order], owner[order]
    if np.any(all_ids[1:] == all_ids[:-1]):
        raise ValueError("frames_droplets: a particle id belongs to two droplets of one frame")
    for a, d in enumerate(prev):
        pos = np.searchsorted(all_ids, d.ids)
        pos = np.minimum(pos, all_ids.size - 1)
        hit = all_ids[pos] == d.ids
        shared[a] = np.bincount(owner[pos[hit]], minlength=len(nxt))
    return shared


def track_droplets(
    frames_droplets: Sequence[Sequence[Droplet]],
    *,
    overlap: float = 0.5,
) -> list[DropletTrack]:
    """Follow droplets through consecutive frames by their shared particle ids (rules in the
    module docstring).

    Parameters
    ----------
    frames_droplets : for each frame, in time order, its droplets (e.g. :func:`find_droplets`
        of consecutive frames).
    overlap : a continuation shares more than ``overlap`` * max(n_a, n_b) ids; in [0.5, 1).

    Returns
    -------
    Tracks in order of their first frame (then depth).
    """
    ov = _finite("overlap", overlap)
    if not 0.5 <= ov < 1.0:
        raise ValueError(f"overlap: expected a fraction in [0.5, 1), got {overlap!r}")
    frames = [_droplet_list("frames_droplets", f) for f in frames_droplets]
    times = [f[0].time for f in frames if f]
    if any(b <= a for a, b in zip(times, times[1:])):
        raise ValueError("frames_droplets: frames must be in increasing time order, one list "
                         "of droplets per frame")
    members: list[list[Droplet]] = []
    starts: list[str] = []
    ends: dict[int, str] = {}
    current: list[int] = []
    for k, drops in enumerate(frames):
        if k == 0:
            current = []
            for d in drops:
                members.append([d])
                starts.append("first")
                current.append(len(members) - 1)
            continue
        prev = frames[k - 1]
        shared = _shared_counts(prev, drops)
        n_prev = np.array([d.n_grains for d in prev])
        n_next = np.array([d.n_grains for d in drops])
        cont = shared > ov * np.maximum(n_prev[:, None], n_next[None, :]) if shared.size \
            else np.zeros(shared.shape, dtype=bool)
        nxt_track: list[int] = []
        for b, d in enumerate(drops):
            a_match = np.flatnonzero(cont[:, b])
            if a_match.size:
                t = current[int(a_match[0])]
                members[t].append(d)
                nxt_track.append(t)
                continue
            col = shared[:, b]
            if col.size and col.max() > 0.5 * d.n_grains:
                reason = "split"
            elif col.sum() > 0.5 * d.n_grains:
                reason = "merged"
            else:
                reason = "new"
            members.append([d])
            starts.append(reason)
            nxt_track.append(len(members) - 1)
        for a, d in enumerate(prev):
            if cont[a].any():
                continue
            row = shared[a]
            if row.size and row.max() > 0.5 * d.n_grains:
                ends[current[a]] = "merged"
            elif row.sum() > 0.5 * d.n_grains:
                ends[current[a]] = "split"
            else:
                ends[current[a]] = "lost"
        current = nxt_track
    return [DropletTrack(track_id=t, droplets=tuple(m), start=starts[t],
                         end=ends.get(t, "end")) for t, m in enumerate(members)]


# --------------------------------------------------------------------------------------------
# Separation of adjacent droplets
# --------------------------------------------------------------------------------------------


def free_fall_separation_velocity(dz0: ArrayLike, v0: float, g: float = GRAVITY
                                  ) -> np.ndarray | float:
    """Separation velocity of two freely falling points a distance dz0 apart at the aperture,
    Delta v0 = sqrt(v0^2 + 2 g dz0) - v0 (seed 000, Sec. III; ~ g dz0 / v0 for small dz0)."""
    v0_ = _non_negative("v0", v0)
    g_ = _positive("g", g)
    dz = np.asarray(dz0, dtype=float)
    if not np.all(np.isfinite(dz)) or np.any(v0_ ** 2 + 2.0 * g_ * dz < 0):
        raise ValueError("dz0: expected finite separations with v0^2 + 2 g dz0 >= 0")
    out = np.sqrt(v0_ ** 2 + 2.0 * g_ * dz) - v0_
    return float(out) if out.ndim == 0 else out


@dataclass(frozen=True, kw_only=True)
class DropletSeparation:
    """Vertical separation of two adjacent droplets over time (:func:`droplet_separations`).

    Attributes
    ----------
    upper, lower : track ids (upper = shallower).
    times : (T,) frame times; dz : (T,) depth(lower) - depth(upper) (m).
    velocity, velocity_err : slope of the least-squares line dz(t) and its standard error.
    intercept : the line at t = 0.
    n_grains_mean : mean over the frames of the mean grains per droplet of the pair.
    t0 : estimated time when the pair's centre passed the aperture (NaN without v0).
    dz0 : the line at t0 (NaN without v0).
    predicted_velocity : free_fall_separation_velocity(dz0, v0, g) (NaN without v0).
    """

    upper: int
    lower: int
    times: np.ndarray
    dz: np.ndarray
    velocity: float
    velocity_err: float
    intercept: float
    n_grains_mean: float
    t0: float
    dz0: float
    predicted_velocity: float

    def predict(self, t: ArrayLike) -> np.ndarray:
        return self.intercept + self.velocity * np.asarray(t, dtype=float)


def droplet_separations(
    tracks: Sequence[DropletTrack],
    *,
    min_points: int = 3,
    v0: float | None = None,
    g: float = GRAVITY,
) -> list[DropletSeparation]:
    """Separation Delta z(t) and separation velocity of every pair of adjacent tracked droplets
    (module docstring; seed 000, Fig. 3).

    Parameters
    ----------
    tracks : from :func:`track_droplets`.
    min_points : pairs adjacent in fewer frames are skipped (>= 3 for an error estimate).
    v0 : the speed at the aperture (m/s) to estimate Delta z0 and the free-fall prediction.
    g : gravity (m/s^2).

    Returns
    -------
    Pairs sorted by the time they were first adjacent, then depth.
    """
    items = list(tracks)
    for t in items:
        if not isinstance(t, DropletTrack):
            raise ValueError(f"tracks: expected DropletTrack objects, got {type(t).__name__}")
    k_min = _count("min_points", min_points, 2)
    v0_ = None if v0 is None else _non_negative("v0", v0)
    g_ = _positive("g", g)
    by_frame: dict[tuple[int, float], list[tuple[float, int, Droplet]]] = {}
    for t in items:
        for d in t.droplets:
            by_frame.setdefault((d.step, d.time), []).append((d.depth, t.track_id, d))
    series: dict[tuple[int, int], list[tuple[float, float, float, float]]] = {}
    first_seen: dict[tuple[int, int], tuple[float, float]] = {}
    for (_, time), entries in sorted(by_frame.items(), key=lambda kv: kv[0][1]):
        entries.sort(key=lambda e: e[0])
        for (z_up, t_up, d_up), (z_lo, t_lo, d_lo) in zip(entries, entries[1:]):
            key = (t_up, t_lo)
            series.setdefault(key, []).append(
                (time, z_lo - z_up, 0.5 * (d_up.n_grains + d_lo.n_grains), 0.5 * (z_up + z_lo)))
            first_seen.setdefault(key, (time, z_up))
    out: list[DropletSeparation] = []
    for key, rows in series.items():
        if len(rows) < k_min:
            continue
        arr = np.array(rows)
        times, dz = arr[:, 0], arr[:, 1]
        if np.ptp(times) == 0:
            continue
        fit = linregress(times, dz)
        t0 = dz0 = pred = float("nan")
        if v0_ is not None:
            mid = np.maximum(arr[:, 3], 0.0)
            t0 = float(np.mean(times - (np.sqrt(v0_ ** 2 + 2.0 * g_ * mid) - v0_) / g_))
            dz0 = float(fit.intercept + fit.slope * t0)
            if v0_ ** 2 + 2.0 * g_ * dz0 >= 0:
                pred = float(free_fall_separation_velocity(dz0, v0_, g_))
        out.append(DropletSeparation(
            upper=key[0], lower=key[1], times=_frozen(times), dz=_frozen(dz),
            velocity=float(fit.slope), velocity_err=float(fit.stderr),
            intercept=float(fit.intercept), n_grains_mean=float(arr[:, 2].mean()),
            t0=t0, dz0=dz0, predicted_velocity=pred))
    out.sort(key=lambda s: first_seen[(s.upper, s.lower)])
    return out
