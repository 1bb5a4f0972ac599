"""Snapshot images of a frame: grains drawn at their true size, coloured by a per-grain value.

2D frames are drawn as disks; 3D frames as the projection of the spheres onto a coordinate
plane, drawn far-to-near so that nearer grains cover farther ones. A 2D frame's deformable
rings (:mod:`grainflow.rings`) are drawn as filled polygons through their vertices, each
coloured by the mean of its vertices' values (optionally with the vertex disks outlined).
Figures are rendered with matplotlib's Agg canvas directly, without pyplot, so importing this
module leaves the user's matplotlib backend alone. :func:`draw_frame` is the drawing itself,
into a given Axes; :func:`snapshot` and the movies of :mod:`grainflow.plotting.movie` (which
pass one colour scale and fixed bounds for all their frames) both go through it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.axes import Axes
from matplotlib.collections import EllipseCollection, LineCollection, PolyCollection
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure

from grainflow.frame import Frame
from grainflow.rings import frame_rings, ring_outlines

__all__ = ["COLOR_BY", "Drawn", "colour_values", "draw_frame", "frame_limits", "figure_size",
           "plot_axes", "snapshot"]

Segment = tuple[tuple[float, float], tuple[float, float]]
_AXES = {"x": 0, "y": 1, "z": 2}
#: Per-grain quantities ``color_by`` accepts, with their colour-bar labels.
COLOR_BY = {
    "speed": "speed |v|",
    "omega": "angular speed |ω|",
    "radius": "radius",
    "mass": "mass",
    "type": "type",
    "body": "body id (-1 = free)",
    "id": "id",
    "depth": "distance towards the viewer",
}


def snapshot(
    frame: Frame,
    path: str | os.PathLike[str],
    *,
    color_by: str | np.ndarray = "speed",
    walls: Sequence[Segment] | None = None,
    title: str | None = None,
    plane: str = "xz",
    cmap: str = "viridis",
    dpi: int = 150,
    vertices: bool = False,
) -> Path:
    """Draw ``frame`` to an image file (format from the suffix, e.g. ``.png``); returns the path.

    ``color_by``: a name from :data:`COLOR_BY` or an (N,) array of values. ``walls``: line
    segments ``((x0, y0), (x1, y1))`` in the plotted coordinates. ``plane``: for 3D frames, the
    two axes shown (``"xz"``: side view, ``"xy"``: top view, ``"yz"``); ignored in 2D.
    The default title gives the step, time and number of grains (and of rings).

    In 2D, each deformable ring is one filled polygon through its vertices, unwrapped across
    periodic boundaries, coloured by the mean of ``color_by`` over its vertices (by type:
    the ring's type), on the colour scale of the other grains; ``vertices=True`` also outlines
    the vertex particles' disks thinly.
    """
    lo, hi = frame_limits(frame, plane, walls)
    fig = Figure(figsize=figure_size(hi - lo), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    drawn = draw_frame(ax, frame, color_by=color_by, walls=walls, title=title, plane=plane,
                       cmap=cmap, vertices=vertices, limits=(lo, hi))
    fig.colorbar(drawn.mappable, ax=ax, label=drawn.label, shrink=0.8)
    path = Path(path)
    fig.savefig(path, dpi=dpi)
    return path


@dataclass(frozen=True)
class Drawn:
    """What :func:`draw_frame` drew: the grains' ``mappable`` (for a colour bar) and the
    colour-bar ``label``."""

    mappable: EllipseCollection
    label: str


def draw_frame(
    ax: Axes,
    frame: Frame,
    *,
    color_by: str | np.ndarray = "speed",
    walls: Sequence[Segment] | None = None,
    title: str | None = None,
    plane: str = "xz",
    cmap: str | Colormap = "viridis",
    vertices: bool = False,
    norm: Normalize | None = None,
    limits: tuple[np.ndarray, np.ndarray] | None = None,
    label: str | None = None,
) -> Drawn:
    """Draw ``frame`` into ``ax`` (grains at true size, rings as polygons, walls, axis names,
    title); the one drawing routine behind :func:`snapshot` and the movies of
    :mod:`grainflow.plotting.movie`. Adds no colour bar: returns the mappable and its label.

    ``color_by``, ``walls``, ``title``, ``plane``, ``cmap``, ``vertices``: as in
    :func:`snapshot`. ``norm``: a fixed colour scale (a movie's, the same in every frame);
    None: the range of this frame's values. ``limits``: ``(lo, hi)`` plot bounds in the
    plotted coordinates; None: :func:`frame_limits`. ``label``: the colour-bar label (default:
    the quantity's, or ``"value"`` for an array).
    """
    axes = plot_axes(frame.dim, plane)
    values, default_label = colour_values(frame, color_by, axes)
    index = ring_index(frame)
    outlines = ring_outlines(frame, index)
    order, centres, diameters = disk_layout(frame, axes, index)

    lo, hi = limits if limits is not None else _limits(frame, axes, walls, outlines)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), aspect="equal")
    grains = EllipseCollection(
        diameters, diameters, np.zeros(len(order)), units="xy",
        offsets=centres, offset_transform=ax.transData, cmap=cmap, norm=norm,
        edgecolors="black", linewidths=0.2,
    )
    grains.set_array(values[order])
    ax.add_collection(grains)
    if len(index):
        _draw_rings(ax, frame, index, outlines, values, grains, vertices, fixed=norm is not None)
    if walls:
        ax.add_collection(LineCollection(np.asarray(walls, dtype=float), colors="black", linewidths=1.5))
    names = "xyz"
    ax.set_xlabel(names[axes[0]])
    ax.set_ylabel(names[axes[1]])
    ax.set_title(title if title is not None else frame_title(frame, len(index)))
    return Drawn(grains, label if label is not None else default_label)


def ring_index(frame: Frame) -> np.ndarray:
    """The vertex indices of each deformable ring of a 2D frame, one row per ring (none in
    3D)."""
    return frame_rings(frame)[1] if frame.dim == 2 else np.zeros((0, 0), dtype=np.int64)


def disk_layout(frame: Frame, axes: list[int], index: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The grains drawn as disks, from farthest to nearest (ring vertices, ``index``, are
    drawn with their rings): their indices, plotted centres and diameters."""
    order = _draw_order(frame, axes)
    order = order[~np.isin(order, index)]
    return order, frame.position[order][:, axes], 2.0 * frame.radius[order]


def frame_title(frame: Frame, rings: int = 0) -> str:
    """The default title: step, time, number of particles (and of rings)."""
    counted = f", {rings} rings" if rings else ""
    return f"step {frame.step}, t = {frame.time:.6g}, N = {frame.n}{counted}"


def frame_limits(frame: Frame, plane: str = "xz", walls: Sequence[Segment] | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Plot bounds ``(lo, hi)`` (each (2,)) of ``frame`` as :func:`snapshot` draws it: the
    grains, the walls, the rings and the periodic box axes, with a 3 % margin."""
    axes = plot_axes(frame.dim, plane)
    index = frame_rings(frame)[1] if frame.dim == 2 else np.zeros((0, 0), dtype=np.int64)
    return _limits(frame, axes, walls, ring_outlines(frame, index))


def plot_axes(dim: int, plane: str) -> list[int]:
    """Indices of the horizontal and vertical plot axes (``[0, 1]`` in 2D; ``plane``, e.g.
    ``"xz"``, in 3D)."""
    if dim == 2:
        return [0, 1]
    if len(plane) != 2 or plane[0] == plane[1] or not set(plane) <= set(_AXES):
        raise ValueError(f"snapshot: plane={plane!r}; use two different axes among x, y, z, e.g. 'xz'")
    return [_AXES[plane[0]], _AXES[plane[1]]]


def _depth(frame: Frame, axes: list[int]) -> np.ndarray:
    """Distance towards the viewer along the axis not shown (zeros in 2D).

    The viewer looks along the third axis such that the plot axes and the view form a
    right-handed frame: for ``"xy"`` the viewer is at +z, for ``"xz"`` at -y.
    """
    if frame.dim == 2:
        return np.zeros(frame.n)
    hidden = 3 - sum(axes)
    cyclic = (axes[0], axes[1], hidden) in ((0, 1, 2), (1, 2, 0), (2, 0, 1))
    return frame.position[:, hidden] * (1.0 if cyclic else -1.0)


def _draw_order(frame: Frame, axes: list[int]) -> np.ndarray:
    """Indices from farthest to nearest, so nearer grains are drawn on top."""
    return np.argsort(_depth(frame, axes), kind="stable")


def colour_values(frame: Frame, color_by: str | np.ndarray, axes: list[int] | None = None
                  ) -> tuple[np.ndarray, str]:
    """Per-grain colour values ((N,) floats) and the colour-bar label: ``color_by`` a name
    from :data:`COLOR_BY` or an (N,) array. ``axes``: the plot axes (for ``"depth"``; default
    the 2D plane or the 3D side view ``"xz"``)."""
    axes = plot_axes(frame.dim, "xz") if axes is None else axes
    if not isinstance(color_by, str):
        values = np.asarray(color_by, dtype=float)
        if values.shape != (frame.n,):
            raise ValueError(f"snapshot: color_by array has shape {values.shape}, expected ({frame.n},)")
        return values, "value"
    if color_by not in COLOR_BY:
        raise ValueError(f"snapshot: color_by={color_by!r}; use one of {sorted(COLOR_BY)} or an (N,) array")
    computed = {
        "speed": lambda: np.linalg.norm(frame.velocity, axis=1),
        "omega": lambda: np.linalg.norm(frame.omega, axis=1),
        "depth": lambda: _depth(frame, axes),
    }
    values = computed[color_by]() if color_by in computed else getattr(frame, color_by)
    return np.asarray(values, dtype=float).reshape(frame.n), COLOR_BY[color_by]


def _draw_rings(ax: Axes, frame: Frame, index: np.ndarray, outlines: np.ndarray,
                values: np.ndarray, grains: EllipseCollection, vertices: bool,
                fixed: bool = False) -> None:
    """Add the rings ``index`` as polygons ``outlines`` coloured by the mean of ``values`` over
    their vertices, on one colour scale with ``grains`` (``fixed``: the grains' norm is a
    given scale, kept; else the range of both); outline the vertex disks if asked."""
    ring_values = values[index].mean(axis=1)
    polygons = PolyCollection(outlines, cmap=grains.get_cmap(), norm=grains.norm,
                              edgecolors="black", linewidths=0.4)
    polygons.set_array(ring_values)
    if not fixed:
        both = np.concatenate([grains.get_array(), ring_values])
        for mappable in (grains, polygons):
            mappable.set_clim(both.min(), both.max())
    ax.add_collection(polygons)
    if vertices:
        diameters = 2.0 * frame.radius[index.ravel()]
        ax.add_collection(EllipseCollection(
            diameters, diameters, np.zeros(index.size), units="xy",
            offsets=outlines.reshape(-1, 2), offset_transform=ax.transData,
            facecolors="none", edgecolors="black", linewidths=0.2,
        ))


def _limits(frame: Frame, axes: list[int], walls: Sequence[Segment] | None,
            outlines: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plot bounds fitting the grains, the walls, the ring ``outlines`` (R, N_v, 2) and the
    periodic box axes, with a small margin."""
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    if frame.n:
        centres = frame.position[:, axes]
        lo = np.minimum(lo, (centres - frame.radius[:, None]).min(axis=0))
        hi = np.maximum(hi, (centres + frame.radius[:, None]).max(axis=0))
    if walls:
        points = np.asarray(walls, dtype=float).reshape(-1, 2)
        lo, hi = np.minimum(lo, points.min(axis=0)), np.maximum(hi, points.max(axis=0))
    if outlines.size:
        points = outlines.reshape(-1, 2)
        r_max = float(frame.radius.max())
        lo, hi = np.minimum(lo, points.min(axis=0) - r_max), np.maximum(hi, points.max(axis=0) + r_max)
    for k, axis in enumerate(axes):
        if frame.box.periodic[axis] or not np.isfinite(lo[k]):
            lo[k] = min(lo[k], frame.box.lo[axis])
            hi[k] = max(hi[k], frame.box.hi[axis])
    margin = 0.03 * max(float((hi - lo).max()), 1e-12)
    return lo - margin, hi + margin


def figure_size(extent: np.ndarray) -> tuple[float, float]:
    """Inches (w, h) of a figure for a plot of data ``extent`` (w, h): 6.5 in on the long
    side plus room for the axis labels, title and colour bar."""
    width, height = np.maximum(6.5 * extent / extent.max(), 2.5)
    return float(width) + 1.6, float(height) + 0.9
