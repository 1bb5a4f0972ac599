"""Contacts and networks of a granular stream (SPEC A5), after seed 000 (Waitukaitis et al.,
PRE 83, 051302 (2011)), Sec. III and the Appendix.

Contact relation. Two grains i, j are *in contact* when the gap between their surfaces is
smaller than the cohesive shell thickness delta (seed: "grains are in contact if the separation
between their surfaces was less than the thickness of the cohesive shell"; its contact number
counts "neighbors whose centers are less than d + delta away"):

    |r_i - r_j| < r_i + r_j + delta          (= d + delta for monodisperse grains; strict <).

This counts touching pairs and pairs within reach of the cohesive force F_c. Pairs are found
with :class:`scipy.spatial.cKDTree` (``query_pairs`` at the largest reach 2 r_max + delta, then
filtered pair by pair).

* Contact number Z_i: the number of grains in contact with grain i.
* Networks: the connected components of the contact graph
  (:func:`scipy.sparse.csgraph.connected_components`); two grains are connected "if a path
  exists between them that consists of pairs of grains whose center-to-center distances are no
  larger than d + delta" (seed, Sec. III).
* Network size N_i of grain i: the number of grains of its network, itself included (a lone
  grain has N = 1). The seed's N(z) is "the average number of grains connected to a grain at a
  distance z below the aperture": the per-grain N_i averaged over the grains of a depth bin,
  i.e. a grain-weighted mean (a network of s grains counts s times).

Depth profiles (:func:`contact_profiles`): Z_i and N_i of every grain of every frame binned
against depth = -z (seed: frames a fixed interval apart, NF; 1 mm bins for Z, 5 mm bins for N),
pooled over frames with a frame-to-frame standard error (:class:`DepthProfile`).

Normalisation (:func:`normalised_contact_number`): the seed plots Z / Z_0, Z_0 "the average
initial contact number measured at z = ? mm" (the depth is lost, PARAMETERS.md: NF). Here
Z_0 is the profile's value in the bin containing ``reference_depth`` (default 0.5 mm: the first
1 mm bin below the aperture), or the count-weighted mean of the bins within
``reference_depth +- reference_half_width``.

Saturation network size (:func:`saturation_network_size`): N_inf = N(z ~ 20 cm) (seed,
Fig. 6c), the profile's value in the bin containing the depth (or a band around it).

Networks are computed among the particles of one type (``grain_type``, default 0 = the
grains of the ``stream`` scenario; None: every particle). Positions are used as they are; the
stream is not periodic and no minimum image is applied.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from grainflow.analysis.stream._common import (DepthProfile, ProfileValue, _each_frame,
                                               _frozen, _grain_mask, _non_negative, _positions,
                                               _positive, _ProfileAccumulator, _radii,
                                               profile_value_at)
from grainflow.frame import Frame

__all__ = [
    "SEED_CONTACT_BIN", "SEED_NETWORK_BIN", "SEED_SATURATION_DEPTH",
    "contact_pairs", "contact_numbers", "network_labels", "network_sizes",
    "Networks", "find_networks", "frame_networks",
    "ContactProfiles", "contact_profiles",
    "NormalisedProfile", "normalised_contact_number", "saturation_network_size",
]

#: Bin widths of the seed's contact number and network size profiles (m).
SEED_CONTACT_BIN = 1e-3
SEED_NETWORK_BIN = 5e-3
#: Depth of the saturation network size N_inf = N(z ~ 20 cm) (m).
SEED_SATURATION_DEPTH = 0.20


# --------------------------------------------------------------------------------------------
# Contacts and networks of one configuration
# --------------------------------------------------------------------------------------------


def _checked_pairs(pairs: ArrayLike, n: int) -> np.ndarray:
    p = np.asarray(pairs)
    if p.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    if p.ndim != 2 or p.shape[1] != 2 or not np.issubdtype(p.dtype, np.integer):
        raise ValueError(f"pairs: expected an (M, 2) integer array from contact_pairs, got "
                         f"shape {p.shape} and dtype {p.dtype}")
    if p.min() < 0 or p.max() >= n:
        raise ValueError(f"pairs: indices must lie in 0..{n - 1} (the positions' rows)")
    return p.astype(np.int64)


def contact_pairs(positions: ArrayLike, radii: ArrayLike, delta: float) -> np.ndarray:
    """Pairs of grains in contact, |r_i - r_j| < r_i + r_j + delta (seed 000: surface gap
    below the cohesive shell thickness delta).

    Parameters
    ----------
    positions : (N, 3) centres in metres.
    radii : (N,) radii, or one radius for all grains.
    delta : the shell thickness delta >= 0 in metres (seed: tens to hundreds of nm).

    Returns
    -------
    (M, 2) int64 array of row indices (i < j), sorted by i then j.
    """
    x = _positions(positions)
    r = _radii(radii, x.shape[0])
    dl = _non_negative("delta", delta)
    if x.shape[0] < 2:
        return np.zeros((0, 2), dtype=np.int64)
    reach = 2.0 * float(r.max()) + dl
    pairs = cKDTree(x).query_pairs(reach, output_type="ndarray").astype(np.int64)
    if pairs.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    dist = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
    pairs = pairs[dist < r[pairs[:, 0]] + r[pairs[:, 1]] + dl]
    pairs.sort(axis=1)
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return pairs[order]


def contact_numbers(positions: ArrayLike, radii: ArrayLike, delta: float, *,
                    pairs: ArrayLike | None = None) -> np.ndarray:
    """Contact number Z_i of every grain (seed 000: the number of neighbours whose centres are
    closer than d + delta), as an (N,) int64 array. ``pairs`` from :func:`contact_pairs`
    skips the search."""
    x = _positions(positions)
    p = contact_pairs(x, radii, delta) if pairs is None else _checked_pairs(pairs, x.shape[0])
    return np.bincount(p.ravel(), minlength=x.shape[0]).astype(np.int64)


def _components(n: int, pairs: np.ndarray) -> tuple[int, np.ndarray]:
    graph = coo_matrix((np.ones(pairs.shape[0], dtype=np.int8), (pairs[:, 0], pairs[:, 1])),
                       shape=(n, n)).tocsr()
    n_comp, labels = connected_components(graph, directed=False, return_labels=True)
    return int(n_comp), labels.astype(np.int64)


def network_labels(positions: ArrayLike, radii: ArrayLike, delta: float, *,
                   pairs: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Networks = connected components of the contact graph (seed 000, Sec. III).

    Returns ``(labels, sizes)``: (N,) network label of each grain (0..K-1) and (K,) number of
    grains in each network. ``pairs`` from :func:`contact_pairs` skips the search.
    """
    x = _positions(positions)
    n = x.shape[0]
    p = contact_pairs(x, radii, delta) if pairs is None else _checked_pairs(pairs, n)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    k, labels = _components(n, p)
    return labels, np.bincount(labels, minlength=k).astype(np.int64)


def network_sizes(positions: ArrayLike, radii: ArrayLike, delta: float, *,
                  pairs: ArrayLike | None = None) -> np.ndarray:
    """Network size N_i of every grain: the number of grains in its network, itself included
    (a lone grain has 1). (N,) int64."""
    labels, sizes = network_labels(positions, radii, delta, pairs=pairs)
    return sizes[labels]


@dataclass(frozen=True, kw_only=True)
class Networks:
    """Contacts and networks of one configuration (:func:`find_networks`).

    Attributes
    ----------
    pairs : (M, 2) contact pairs (row indices, i < j).
    contact_number : (N,) Z_i.
    label : (N,) network label of each grain, 0..n_networks-1.
    sizes : (n_networks,) grains per network.
    network_size : (N,) N_i = sizes[label[i]].
    delta : the shell thickness used.
    index : (N,) rows of the grains in the frame they came from (identity for arrays).
    """

    pairs: np.ndarray
    contact_number: np.ndarray
    label: np.ndarray
    sizes: np.ndarray
    network_size: np.ndarray
    delta: float
    index: np.ndarray

    @property
    def n_networks(self) -> int:
        return int(self.sizes.size)

    def members(self, label: int) -> np.ndarray:
        """Rows (in the arrays given) of the grains of network ``label``."""
        return np.flatnonzero(self.label == label)


def find_networks(positions: ArrayLike, radii: ArrayLike, delta: float) -> Networks:
    """Contact pairs, contact numbers and networks of one configuration, with one search."""
    x = _positions(positions)
    pairs = contact_pairs(x, radii, delta)
    z = contact_numbers(x, radii, delta, pairs=pairs)
    labels, sizes = network_labels(x, radii, delta, pairs=pairs)
    return Networks(pairs=_frozen(pairs, np.int64), contact_number=_frozen(z, np.int64),
                    label=_frozen(labels, np.int64), sizes=_frozen(sizes, np.int64),
                    network_size=_frozen(sizes[labels], np.int64), delta=float(delta),
                    index=_frozen(np.arange(x.shape[0]), np.int64))


def frame_networks(frame: Frame, delta: float, *, grain_type: int | None = 0) -> Networks:
    """:func:`find_networks` of the grains (particles of ``grain_type``) of a frame; arrays are
    over those grains, ``index`` gives their rows in the frame."""
    frame = next(_each_frame(frame))
    rows = np.flatnonzero(_grain_mask(frame, grain_type))
    x = np.asarray(frame.position, dtype=float)[rows]
    r = np.asarray(frame.radius, dtype=float)[rows]
    nets = find_networks(x, r, delta)
    return Networks(pairs=nets.pairs, contact_number=nets.contact_number, label=nets.label,
                    sizes=nets.sizes, network_size=nets.network_size, delta=nets.delta,
                    index=_frozen(rows, np.int64))


# --------------------------------------------------------------------------------------------
# Depth profiles
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class ContactProfiles:
    """Contact number Z(z) and network size N(z) against depth (:func:`contact_profiles`)."""

    contact_number: DepthProfile
    network_size: DepthProfile
    delta: float


def contact_profiles(
    frames: Frame | Iterable[Frame],
    delta: float,
    *,
    contact_bin: float = SEED_CONTACT_BIN,
    network_bin: float = SEED_NETWORK_BIN,
    depth_range: tuple[float, float] | None = None,
    grain_type: int | None = 0,
    average: str = "pooled",
) -> ContactProfiles:
    """Depth profiles of the contact number Z and the network size N, averaged over frames.

    Every grain of every frame contributes its Z_i to the bin of its depth (-z) in
    ``contact_bin`` bins and its N_i in ``network_bin`` bins (seed 000, Appendix: 1 mm and
    5 mm). Frames should be a fixed interval apart in the steady state (the seed's interval is
    lost). The means are pooled over grain samples (or averaged frame by frame with
    ``average="frames"``); errors come from frame-to-frame scatter
    (:class:`~grainflow.analysis.stream.DepthProfile`).

    Parameters
    ----------
    frames : a Frame or an iterable of Frames (read once).
    delta : cohesive shell thickness in metres (>= 0).
    contact_bin, network_bin : bin widths in metres.
    depth_range : (min, max) depth of the grains binned; default: all grains.
    grain_type : particle type of the grains (None: every particle).
    average : "pooled" or "frames" (:class:`~grainflow.analysis.stream.DepthProfile`).
    """
    dl = _non_negative("delta", delta)
    acc_z = _ProfileAccumulator("contact number", contact_bin, depth_range, average)
    acc_n = _ProfileAccumulator("network size", network_bin, depth_range, average)
    for frame in _each_frame(frames):
        nets = frame_networks(frame, dl, grain_type=grain_type)
        depth = -np.asarray(frame.position, dtype=float)[nets.index, 2]
        acc_z.add(depth, nets.contact_number)
        acc_n.add(depth, nets.network_size)
    return ContactProfiles(contact_number=acc_z.result(), network_size=acc_n.result(),
                           delta=dl)


@dataclass(frozen=True, kw_only=True)
class NormalisedProfile:
    """Z(z) / Z_0 (:func:`normalised_contact_number`).

    Attributes
    ----------
    profile : the normalised profile (errors: relative errors of Z and Z_0 in quadrature).
    reference : Z_0 with its error, depth band and sample count.
    """

    profile: DepthProfile
    reference: ProfileValue


def normalised_contact_number(
    profile: DepthProfile | ContactProfiles,
    reference_depth: float = 0.5e-3,
    *,
    reference_half_width: float | None = None,
) -> NormalisedProfile:
    """The contact number normalised by its value near the aperture, Z(z) / Z_0 (seed 000,
    Fig. 6a: "we normalize Z by the average initial contact number Z_0, measured at z = ? mm";
    the depth is lost, NF).

    Z_0 is :func:`profile_value_at` ``(profile, reference_depth, reference_half_width)``: by
    default the bin containing ``reference_depth`` = 0.5 mm, i.e. the first 1 mm bin below the
    aperture. Z_0 must be > 0 (a stream with no contact at the reference depth cannot be
    normalised; move the reference up towards the aperture).
    """
    if isinstance(profile, ContactProfiles):
        profile = profile.contact_number
    if not isinstance(profile, DepthProfile):
        raise ValueError(f"profile: expected a DepthProfile or ContactProfiles, got "
                         f"{type(profile).__name__}")
    ref = profile_value_at(profile, reference_depth, reference_half_width)
    if not ref.value > 0:
        raise ValueError(f"reference_depth: the contact number there is {ref.value:g}; Z_0 "
                         "must be > 0 (choose a depth nearer the aperture)")
    err = ref.err if np.isfinite(ref.err) else 0.0
    return NormalisedProfile(profile=profile.scaled(ref.value, err, quantity="Z / Z0"),
                             reference=ref)


def saturation_network_size(
    profile: DepthProfile | ContactProfiles,
    depth: float = SEED_SATURATION_DEPTH,
    *,
    half_width: float | None = None,
) -> ProfileValue:
    """Saturation network size N_inf = N(z ~ depth) (seed 000, Fig. 6c: N(z ~ 20 cm)): the
    network-size profile in the bin containing ``depth`` (or the count-weighted mean of the
    bins within ``depth +- half_width``), with its standard error."""
    if isinstance(profile, ContactProfiles):
        profile = profile.network_size
    _positive("depth", depth)
    return profile_value_at(profile, depth, half_width)

