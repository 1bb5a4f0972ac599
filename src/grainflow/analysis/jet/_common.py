"""What the jet analyses share (:mod:`grainflow.analysis.jet`): the particle selections
(grains, target), the jet's geometry (direction of travel, centre), the frame window, the
scattered grains found in the shell around the target, and the delete-one jackknife over
blocks of frames. The conventions are the package's (its module notes)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.checks import each_frame
from grainflow.analysis.checks import non_negative as _non_negative
from grainflow.analysis.checks import positive as _positive
from grainflow.frame import Frame

#: Particle type of the target's wall particles in the jet scenarios.
TARGET_TYPE = 2

GrainSelection = None | Sequence[int] | Callable[[Frame], np.ndarray]


# --------------------------------------------------------------------------------------------
# Input checks and geometry
# --------------------------------------------------------------------------------------------


def check_weighting(weighting: str) -> str:
    if weighting not in ("flux", "count"):
        raise ValueError(f"weighting: 'flux' or 'count', got {weighting!r}")
    return weighting


def check_window(window: tuple[float, float] | None) -> None:
    if window is not None and not (len(window) == 2 and window[0] <= window[1]):
        raise ValueError(f"window: (t_start, t_end) with t_start <= t_end, got {window!r}")


def in_window(frame: Frame, window: tuple[float, float] | None) -> bool:
    return window is None or window[0] <= frame.time <= window[1]


def frames_in_window(frames: Frame | Iterable[Frame],
                     window: tuple[float, float] | None) -> Iterator[Frame]:
    check_window(window)
    for frame in each_frame(frames):
        if in_window(frame, window):
            yield frame


def selection_mask(frame: Frame, selection: GrainSelection, name: str,
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


def grain_mask(frame: Frame, grains: GrainSelection) -> np.ndarray:
    """(N,) bool mask of the grains of ``frame`` (default: type != TARGET_TYPE)."""
    return selection_mask(frame, grains, "grains",
                          lambda f: np.asarray(f.type) != TARGET_TYPE)


def target_mask(frame: Frame, target: GrainSelection) -> np.ndarray:
    """(N,) bool mask of the target's particles of ``frame`` (default: type == TARGET_TYPE)."""
    return selection_mask(frame, target, "target",
                          lambda f: np.asarray(f.type) == TARGET_TYPE)


@dataclass(frozen=True)
class JetGeometry:
    dim: int
    n: np.ndarray  # unit direction of travel
    centre: np.ndarray


def unit_vector(name: str, vector: ArrayLike, dim: int) -> np.ndarray:
    v = np.asarray(vector, dtype=float)
    if v.shape != (dim,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: expected {dim} finite components for {dim}D frames, "
                         f"got {vector!r}")
    norm = float(np.linalg.norm(v))
    if norm == 0:
        raise ValueError(f"{name}: must not be the zero vector")
    return v / norm


def jet_geometry(dim: int, direction: ArrayLike | None, centre: ArrayLike | None) -> JetGeometry:
    if dim not in (2, 3):
        raise ValueError(f"frames: expected 2D or 3D frames, got dim = {dim}")
    default = (-1.0, 0.0) if dim == 2 else (0.0, 0.0, -1.0)
    n = unit_vector("direction", default if direction is None else direction, dim)
    c = np.zeros(dim) if centre is None else np.asarray(centre, dtype=float)
    if c.shape != (dim,) or not np.all(np.isfinite(c)):
        raise ValueError(f"centre: expected {dim} finite components for {dim}D frames, "
                         f"got {centre!r}")
    return JetGeometry(dim, n, c)


def check_dim(frame: Frame, geo: JetGeometry) -> None:
    if frame.dim != geo.dim:
        raise ValueError(f"frames: mixed dimensions, a {frame.dim}D frame at step {frame.step} "
                         f"after {geo.dim}D ones")


# --------------------------------------------------------------------------------------------
# Scattered grains in the shell
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ShellSamples:
    """Scattered grains found in the shell, pooled over frames (one row per grain and frame)."""

    geo: JetGeometry
    frame: np.ndarray  # (S,) index of the frame in the window
    n_frames: int
    mass: np.ndarray  # (S,)
    position: np.ndarray  # (S, dim), relative to the centre
    velocity: np.ndarray  # (S, dim)
    outward: np.ndarray  # (S,) v . r_hat > 0
    shell_radius: float
    shell_width: float


def shell_samples(frames, *, target_radius, jet_radius, direction, centre, grains, window,
                  u0, deflection, shell_factor, shell_offset, shell_width) -> ShellSamples:
    r_tar = _positive("target_radius", target_radius)
    r_jet = _positive("jet_radius", jet_radius)
    u0 = _positive("u0", u0)
    deflection = _non_negative("deflection", deflection)
    r_s = _positive("shell_factor", shell_factor) * max(r_tar, r_jet) + _non_negative(
        "shell_offset", shell_offset)
    width = _positive("shell_width", shell_width)
    geo: JetGeometry | None = None
    rows: dict[str, list[np.ndarray]] = {k: [] for k in ("frame", "m", "x", "v", "w")}
    n_frames = 0
    for frame in frames_in_window(frames, window):
        if geo is None:
            geo = jet_geometry(frame.dim, direction, centre)
        check_dim(frame, geo)
        mask = grain_mask(frame, grains)
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
    return ShellSamples(geo, frame_index, n_frames, np.concatenate(rows["m"]),
                        np.concatenate(rows["x"]), np.concatenate(rows["v"]),
                        np.concatenate(rows["w"]), r_s, width)


def block_count(blocks: int | None, n_frames: int) -> int:
    """Checked number of jackknife blocks of frames; default min(10, n_frames)."""
    if blocks is None:
        blocks = min(10, n_frames)
    if not isinstance(blocks, (int, np.integer)) or isinstance(blocks, bool) or blocks < 1:
        raise ValueError(f"blocks: a positive integer, got {blocks!r}")
    if blocks > n_frames:
        raise ValueError(f"blocks: {blocks} blocks need at least as many frames; the window "
                         f"holds {n_frames}")
    return int(blocks)


def block_of(frame: np.ndarray, n_frames: int, blocks: int) -> np.ndarray:
    """Block (of ``blocks`` groups of consecutive frames) of each frame index."""
    bounds = np.linspace(0, n_frames, blocks + 1).round().astype(int)
    return np.searchsorted(bounds, frame, side="right") - 1


def jackknife_units(samples: ShellSamples, blocks: int | None) -> tuple[np.ndarray, int, int]:
    """Jackknife unit of each sample, number of units, and the number of blocks (1: grains)."""
    blocks = block_count(blocks, samples.n_frames)
    if blocks == 1:
        return np.arange(samples.frame.size), samples.frame.size, 1
    return block_of(samples.frame, samples.n_frames, blocks), blocks, blocks


def jackknife(estimate: Callable[..., np.ndarray], totals: Sequence[np.ndarray],
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


def unit_sums(unit: np.ndarray, n_units: int, values: np.ndarray) -> np.ndarray:
    """Sum of ``values`` (S,) or (S, K) per unit -> (n_units,) or (n_units, K)."""
    if values.ndim == 1:
        return np.bincount(unit, weights=values, minlength=n_units)
    return np.stack([np.bincount(unit, weights=values[:, k], minlength=n_units)
                     for k in range(values.shape[1])], axis=1)
