"""Dead zone of seed 002 Sec. 6.1.1: the frozen cells next to the target, where the grains'
mean speed and thermal speed both fall below thresholds, from frames or from coarse-grained
fields."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.cg import CGFields
from grainflow.analysis.checks import frozen as _frozen
from grainflow.analysis.checks import positive as _positive
from grainflow.analysis.jet._common import (GrainSelection, JetGeometry, check_dim,
                                            frames_in_window, grain_mask, jet_geometry)
from grainflow.frame import Frame


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
    geo: JetGeometry | None = None
    sums = None
    for frame in frames_in_window(source, window):
        if geo is None:
            geo = jet_geometry(frame.dim, direction, centre)
            n_lat = lateral_bins or (11 if geo.dim == 2 else 5)
            lat_edges = (np.linspace(-r_tar, r_tar, n_lat + 1) if geo.dim == 2
                         else np.linspace(0.0, r_tar, n_lat + 1))
            n_cells = n_h * n_lat
            sums = {"n": np.zeros(n_cells), "m": np.zeros(n_cells),
                    "p": np.zeros((n_cells, geo.dim)), "mvv": np.zeros(n_cells)}
        check_dim(frame, geo)
        mask = grain_mask(frame, grains)
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
