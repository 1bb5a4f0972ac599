"""Movies and poster frames of a run: ``grainflow view RUN``.

:func:`write_movie` turns a run directory, a trajectory file (``frames.h5``) or a sequence of
:class:`~grainflow.frame.Frame` objects into an MP4 (H.264, yuv420p, through the ffmpeg that
``imageio-ffmpeg`` ships) or an animated GIF (Pillow), and optionally a PNG poster frame.

How a movie is made, in two passes over the selected frames:

1. *Scan*: the union extent of the grains (so the axes, or the camera, stay put for the whole
   movie) and the range of the colour quantity (so a colour means the same value in every
   frame; ``vmin``/``vmax`` override it).
2. *Render*: 2D frames (and 3D ones with ``renderer="matplotlib"``: a projection on
   ``plane``) are drawn by :func:`grainflow.plotting.snapshot.draw_frame` on matplotlib's
   Agg canvas, with a colour bar and the step, time and N in the title; 3D frames are
   ray-traced by OVITO (:mod:`grainflow.plotting.render3d`), spheres at their true radius,
   the step, time and a colour bar drawn onto the picture. Each picture goes straight to the
   writer; the one chosen as poster (default: the last, the most developed state of the
   flow) is also saved as a PNG.

Colours (:data:`MOVIE_COLOR_BY`): the per-grain quantities of the snapshots, plus
``"network"``: the number of grains in each grain's contact network (connected components
of the graph of centres closer than r_i + r_j + ``delta``, seed 000's definition;
:func:`grainflow.analysis.stream.network_sizes`), on a log scale. Networks are found without
periodic images. ``"type"`` uses a qualitative colour map (one colour per type up to 10).

Outputs are written to a hidden ``.NAME.partial.SUFFIX`` file beside the target and renamed
over it when complete, so a failed render leaves an older movie as it was.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Protocol

import numpy as np
from matplotlib import colormaps, rc_context
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import Colormap, ListedColormap, LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import FormatStrFormatter

from grainflow.frame import Frame
from grainflow.plotting.render3d import QUALITY, probe_ovito
from grainflow.plotting.snapshot import (COLOR_BY, Segment, colour_values as snapshot_values,
                                         disk_layout, draw_frame, figure_size, frame_limits,
                                         frame_title, plot_axes, ring_index)
from grainflow.progress import ItemProgress, make_item_progress

__all__ = ["MOVIE_COLOR_BY", "MOVIE_SUFFIXES", "ColourScale", "FrameSource", "GifWriter",
           "Mp4Writer", "MovieWriter", "ViewError", "check_movie_path", "colour_scale",
           "check_colour", "movie_values", "open_frames", "open_movie",
           "parse_frames", "parse_size", "select_frames", "write_movie", "write_png"]

#: Quantities a movie can colour grains by, with their colour-bar labels.
MOVIE_COLOR_BY = {**COLOR_BY, "network": "contact network size (grains)"}
#: Movie formats by file suffix.
MOVIE_SUFFIXES = {".mp4": "MP4 (H.264)", ".gif": "animated GIF"}
POSTER_SUFFIXES = (".png", ".jpg", ".jpeg")
RENDERERS = ("auto", "ovito", "matplotlib")
#: Default picture size of 3D frames rendered by OVITO (width, height).
SIZE_3D = (640, 480)
_DPI = 100
_MAX_SIDE = 8192


class ViewError(ValueError):
    """Bad input for a movie (a missing run, no frames, an unknown option value); the
    message names the option and the fix."""


# ----------------------------------------------------------------------------- frame input
class FrameSource:
    """Random access to the frames of a run directory, a trajectory file or a sequence of
    frames (``len``, indexing); ``name`` says where they come from, for messages."""

    def __init__(self, name: str, count: int, read: Any) -> None:
        self.name = name
        self._count = count
        self._read = read

    def __len__(self) -> int:
        return self._count

    def __getitem__(self, index: int) -> Frame:
        return self._read(index)


def open_frames(run_or_frames: str | os.PathLike[str] | Sequence[Frame]) -> FrameSource:
    """The frames of a run directory (its ``frames.h5``), an H5MD trajectory file, or a
    sequence of frames. Raises :class:`ViewError` for a path that is neither, and for a run
    directory without frames."""
    if isinstance(run_or_frames, (str, os.PathLike)):
        return _open_path(Path(run_or_frames))
    frames = list(run_or_frames)
    if not all(isinstance(f, Frame) for f in frames):
        raise ViewError("frames: expected a run directory, a trajectory file or a sequence of "
                        "grainflow Frame objects")
    return FrameSource(f"{len(frames)} frames given", len(frames), frames.__getitem__)


def _open_path(path: Path) -> FrameSource:
    from grainflow.io.h5md import RUN_TRAJECTORY as FRAMES, count_frames, read_frame

    if path.is_dir():
        trajectory = path / FRAMES
        if not trajectory.is_file():
            raise ViewError(f"{path}: no {FRAMES} in this run directory (was "
                            "output.frames_every = 0? set it above 0 and run again)")
    elif path.is_file():
        trajectory = path
    else:
        raise ViewError(f"{path}: no such run directory or trajectory file")
    count = count_frames(trajectory)
    return FrameSource(str(trajectory), count, lambda k: read_frame(trajectory, k))


def parse_frames(text: str | slice | None) -> slice:
    """``"a:b"`` (Python slice of the frame numbers; either end may be left out or be
    negative, e.g. ``"-20:"``: the last 20), a slice, or None (all) -> a slice."""
    if text is None:
        return slice(None)
    if isinstance(text, slice):
        return text
    parts = str(text).split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        start, stop = (int(p) if p.strip() else None for p in parts)
    except ValueError:
        raise ViewError(f"--frames: {text!r} is not valid; give a range of frame numbers "
                        "a:b (from a up to but not including b; e.g. 0:50, 10:, -20:)") from None
    return slice(start, stop)


def select_frames(count: int, frames: str | slice | None = None, every: int = 1) -> list[int]:
    """Indices of the frames shown: the range ``frames`` (see :func:`parse_frames`) of
    ``count`` frames, then every ``every``-th of them. Raises :class:`ViewError` if none."""
    if not isinstance(every, (int, np.integer)) or every < 1:
        raise ViewError(f"--every: {every!r} is not valid; give a whole number >= 1 (1: every "
                        "frame, 2: every other one)")
    chosen = list(range(count)[parse_frames(frames)][::int(every)])
    if not chosen:
        what = "has no frames" if count == 0 else f"has {count} frames, none in --frames {frames}"
        raise ViewError(f"nothing to show: the trajectory {what}; "
                        + ("run it with output.frames_every > 0" if count == 0
                           else "choose a range within 0:" + str(count)))
    return chosen


def parse_size(size: str | Sequence[int] | None) -> tuple[int, int] | None:
    """``"WxH"`` in pixels (e.g. ``"640x480"``), a (width, height) pair, or None."""
    if size is None:
        return None
    try:
        if isinstance(size, str):
            w_text, h_text = size.lower().split("x")
            width, height = int(w_text), int(h_text)
        else:
            width, height = (int(v) for v in size)
            if tuple(size) != (width, height):
                raise ValueError
    except (ValueError, TypeError):
        raise ViewError(f"--size: {size!r} is not valid; give WIDTHxHEIGHT in pixels, "
                        "e.g. 640x480") from None
    if not (16 <= width <= _MAX_SIDE and 16 <= height <= _MAX_SIDE):
        raise ViewError(f"--size: {width}x{height} is out of range; each side must be "
                        f"16 to {_MAX_SIDE} pixels, e.g. 640x480")
    return width, height


# --------------------------------------------------------------------------------- colours
@dataclass(frozen=True)
class ColourScale:
    """One colour scale for a whole movie: colour map, norm (fixed range), bar label and,
    for categories (types), the values to label on the bar."""

    cmap: Colormap
    norm: Normalize
    label: str
    ticks: tuple[float, ...] | None = None

    def rgb(self, values: np.ndarray) -> np.ndarray:
        """(N, 3) RGB in [0, 1] of ``values``."""
        return np.asarray(self.cmap(self.norm(np.asarray(values, dtype=float))))[..., :3]


def movie_values(frame: Frame, color_by: str, *, delta: float = 0.0,
                 plane: str | None = None) -> np.ndarray:
    """(N,) colour values of ``frame``: a snapshot quantity (:data:`COLOR_BY`) or
    ``"network"``, each grain's contact-network size at contact reach r_i + r_j + ``delta``."""
    if color_by == "network":
        from grainflow.analysis.stream.networks import network_sizes

        x = np.zeros((frame.n, 3))
        x[:, : frame.dim] = frame.position
        return network_sizes(x, frame.radius, float(delta)).astype(float)
    axes = plot_axes(frame.dim, plane or "xz")
    return snapshot_values(frame, color_by, axes)[0]


def check_colour(color_by: str, delta: float) -> None:
    """Raise :class:`ViewError` for an unknown ``color_by`` or a negative ``delta``."""
    if color_by not in MOVIE_COLOR_BY:
        raise ViewError(f"--color-by: {color_by!r} is not known; use one of "
                        f"{', '.join(sorted(MOVIE_COLOR_BY))}")
    if not (np.isfinite(delta) and delta >= 0):
        raise ViewError(f"--delta: {delta!r} is not valid; give the contact distance margin "
                        ">= 0 in the run's length unit (0: grains touching)")


def colour_scale(color_by: str, low: float, high: float, *, vmin: float | None = None,
                 vmax: float | None = None, cmap: str | None = None) -> ColourScale:
    """The fixed scale of ``color_by`` over values in ``[low, high]`` (the whole movie's
    range; ``vmin``/``vmax`` replace its ends). Speeds start at 0; network sizes are on a log
    scale from 1 grain; types get one colour each from a qualitative map (up to 10 types)."""
    label = MOVIE_COLOR_BY[color_by]
    if not np.isfinite(low):  # no grains in any frame
        low, high = 0.0, 1.0
    if color_by in ("speed", "omega", "network"):
        low = 1.0 if color_by == "network" else 0.0
    lo = low if vmin is None else float(vmin)
    hi = high if vmax is None else float(vmax)
    if not hi > lo:
        if vmax is not None:
            raise ViewError(f"--vmax: {vmax} is not above the colour scale's start {lo:.6g}; "
                            "give a larger --vmax" + ("" if vmin is not None else
                                                      " or a --vmin below it"))
        hi = lo + max(abs(lo), 1.0)  # one value everywhere: a range around it
    if color_by == "network":
        if lo <= 0:
            raise ViewError(f"--vmin: {vmin} is not valid for network sizes (a log scale); "
                            "give a size >= 1")
        return ColourScale(colormaps[cmap or "plasma"], LogNorm(lo, hi), label)
    if (color_by == "type" and cmap is None and vmin is None and vmax is None
            and low >= 0 and high <= 9):
        types = int(high) + 1
        listed = ListedColormap(colormaps["tab10"].colors[:types], name="types")
        return ColourScale(listed, Normalize(-0.5, types - 0.5), label,
                           ticks=tuple(float(t) for t in range(types)))
    return ColourScale(colormaps[cmap or "viridis"], Normalize(lo, hi), label)


# ----------------------------------------------------------------------------- the writers
class MovieWriter(Protocol):
    """Takes (height, width, 3) uint8 pictures of one size in order; :meth:`close` finishes
    the file; :meth:`abort` removes what was written."""

    path: Path

    def append(self, picture: np.ndarray) -> None: ...

    def close(self) -> Path: ...

    def abort(self) -> None: ...


class _PartialFile:
    """A file written under a hidden ``.NAME.partial.SUFFIX`` name and renamed over ``path``
    when complete; what was written is removed on :meth:`abort`. Checks the pictures' size."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self.partial = self.path.with_name(f".{self.path.stem}.partial{self.path.suffix}")
        self.size: tuple[int, int] | None = None
        self.count = 0

    def _check(self, picture: np.ndarray) -> np.ndarray:
        picture = np.asarray(picture)
        if picture.ndim != 3 or picture.shape[2] != 3 or picture.dtype != np.uint8:
            raise ValueError(f"{self.path.name}: a picture must be an (h, w, 3) uint8 array, "
                             f"got {picture.shape} {picture.dtype}")
        size = (picture.shape[1], picture.shape[0])
        if self.size is None:
            self.size = size
            self.path.parent.mkdir(parents=True, exist_ok=True)
        elif size != self.size:
            raise ValueError(f"{self.path.name}: picture {self.count} is {size[0]}x{size[1]}, "
                             f"the first was {self.size[0]}x{self.size[1]}; a movie's pictures "
                             "all have one size")
        self.count += 1
        return picture

    def _finish(self) -> Path:
        os.replace(self.partial, self.path)
        return self.path

    def abort(self) -> None:
        self.partial.unlink(missing_ok=True)

    def __enter__(self) -> "_PartialFile":
        return self

    def __exit__(self, kind: type[BaseException] | None, err: BaseException | None,
                 tb: TracebackType | None) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()

    def close(self) -> Path:
        """Rename the finished partial file over ``path``; returns ``path``."""
        return self._finish()


class Mp4Writer(_PartialFile):
    """H.264 in yuv420p (plays in browsers and players) through imageio-ffmpeg's ffmpeg,
    ``fps`` pictures per second. yuv420p halves the colour resolution, so the sides must be
    even: a picture with an odd side is padded with one white row or column."""

    def __init__(self, path: str | os.PathLike[str], fps: float, quality: float = 6.0) -> None:
        super().__init__(path)
        try:
            import imageio_ffmpeg
        except ImportError:
            raise ViewError(f"{self.path}: writing MP4 needs imageio-ffmpeg (pip install "
                            "imageio-ffmpeg); or write an animated GIF (-o movie.gif)") from None
        self._ffmpeg = imageio_ffmpeg
        self.fps = float(fps)
        self.quality = quality
        self._pipe: Any = None

    def append(self, picture: np.ndarray) -> None:
        picture = _pad_even(self._check(picture))
        if self._pipe is None:
            self._pipe = self._ffmpeg.write_frames(
                str(self.partial), (picture.shape[1], picture.shape[0]), fps=self.fps,
                codec="libx264", pix_fmt_in="rgb24", pix_fmt_out="yuv420p",
                quality=self.quality, macro_block_size=1, ffmpeg_log_level="error",
                output_params=["-f", "mp4"])
            self._pipe.send(None)
        self._pipe.send(np.ascontiguousarray(picture).tobytes())

    def close(self) -> Path:
        if self._pipe is None:
            raise ValueError(f"{self.path}: no pictures to write")
        self._pipe.close()
        self._pipe = None
        return self._finish()

    def abort(self) -> None:
        if self._pipe is not None:
            try:
                self._pipe.close()
            except Exception:  # ffmpeg may already have failed; the partial file goes anyway
                pass
            self._pipe = None
        super().abort()


class GifWriter(_PartialFile):
    """An animated GIF through Pillow, ``round(1000 / fps)`` ms a picture, looping; each
    picture is reduced to a palette of ``colors`` colours. Pillow writes the file at
    :meth:`close`, so the (palette) pictures are kept until then."""

    def __init__(self, path: str | os.PathLike[str], fps: float, colors: int = 128) -> None:
        super().__init__(path)
        self.duration_ms = max(1, round(1000.0 / float(fps)))
        self.colors = colors
        self._pictures: list[Any] = []

    def append(self, picture: np.ndarray) -> None:
        from PIL import Image

        picture = self._check(picture)
        self._pictures.append(Image.fromarray(np.ascontiguousarray(picture))
                              .quantize(colors=self.colors))

    def close(self) -> Path:
        if not self._pictures:
            raise ValueError(f"{self.path}: no pictures to write")
        first, *rest = self._pictures
        first.save(self.partial, format="GIF", save_all=True, append_images=rest,
                   duration=self.duration_ms, loop=0)
        self._pictures = []
        return self._finish()


def open_movie(path: str | os.PathLike[str], fps: float) -> Mp4Writer | GifWriter:
    """The writer for ``path``'s suffix (:data:`MOVIE_SUFFIXES`), ``fps`` pictures a second."""
    path = check_movie_path(path)
    if not (np.isfinite(fps) and fps > 0):
        raise ViewError(f"--fps: {fps!r} is not valid; give pictures per second > 0, e.g. 10")
    return Mp4Writer(path, fps) if path.suffix.lower() == ".mp4" else GifWriter(path, fps)


def check_movie_path(path: str | os.PathLike[str]) -> Path:
    """``path`` as a Path if its suffix is a movie format (:data:`MOVIE_SUFFIXES`); else a
    :class:`ViewError` naming the formats."""
    path = Path(path)
    if path.suffix.lower() not in MOVIE_SUFFIXES:
        raise ViewError(f"--output: {path.name!r} has an unknown suffix {path.suffix!r}; name "
                        "the movie .mp4 (H.264) or .gif (animated GIF)")
    return path


def write_png(picture: np.ndarray, path: str | os.PathLike[str]) -> Path:
    """Save an (h, w, 3) uint8 picture (format from the suffix: PNG or JPEG); returns the
    path. Written under a partial name and renamed, as the movies are."""
    from PIL import Image

    with _PartialFile(path) as out:
        out._check(picture)
        Image.fromarray(np.ascontiguousarray(picture)).save(
            out.partial, format="PNG" if out.path.suffix.lower() == ".png" else "JPEG")
    return out.path


def _pad_even(picture: np.ndarray) -> np.ndarray:
    """``picture`` with a white row and/or column added where a side is odd."""
    h, w = picture.shape[:2]
    if h % 2 == 0 and w % 2 == 0:
        return picture
    return np.pad(picture, ((0, h % 2), (0, w % 2), (0, 0)), constant_values=255)


# ---------------------------------------------------------------------------- the painters
class _Painter(Protocol):
    def paint(self, frame: Frame, values: np.ndarray) -> np.ndarray: ...

    def close(self) -> None: ...


@dataclass
class _Scene:
    """A kept picture background and the artists drawn over it (:class:`_MatplotlibPainter`)."""

    axes: Any
    grains: Any
    overlays: list[Any]
    background: Any


class _MatplotlibPainter:
    """2D frames (or 3D ones projected on ``plane``) drawn by snapshot's :func:`draw_frame`
    into one figure of ``size`` pixels, with fixed ``limits`` and colour ``scale``."""

    def __init__(self, size: tuple[int, int], limits: tuple[np.ndarray, np.ndarray],
                 scale: ColourScale, plane: str, walls: Sequence[Segment] | None) -> None:
        self.size, self.limits, self.scale = size, limits, scale
        self.plane, self.walls = plane, walls
        self.figure = Figure(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI,
                             layout="constrained")
        # matplotlib's 10 pt from 600 px up; smaller on smaller pictures, down to 5 pt
        self.font_size = float(np.clip(min(size) / 60.0, 5.0, 10.0))
        FigureCanvasAgg(self.figure)
        #: Where the first picture's layout put the axes and the colour bar. Limits and
        #: colour scale are fixed over the movie, so later pictures reuse the layout rather
        #: than solve it again (half the cost of a picture).
        self._positions: tuple[Any, Any] | None = None
        #: Once a frame without rings is drawn: everything but its grains, title and walls,
        #: rendered once (:meth:`_keep_background`), and those artists, which later frames
        #: without rings update and draw over it (about 10x faster than a whole figure).
        self._scene: _Scene | None = None

    def paint(self, frame: Frame, values: np.ndarray) -> np.ndarray:
        if self._scene is not None and not ring_index(frame).size:
            return self._repaint(frame, values)
        self._scene = None
        self.figure.clear()
        with rc_context({"font.size": self.font_size}):
            if self._positions is None:
                ax, cax = self.figure.add_subplot(), None
            else:
                ax, cax = (self.figure.add_axes(p) for p in self._positions)
            drawn = draw_frame(ax, frame, color_by=values, walls=self.walls, plane=self.plane,
                               cmap=self.scale.cmap, norm=self.scale.norm, limits=self.limits,
                               label=self.scale.label)
            if cax is None:
                bar = self.figure.colorbar(drawn.mappable, ax=ax, label=drawn.label,
                                           shrink=0.8, ticks=self.scale.ticks)
            else:
                bar = self.figure.colorbar(drawn.mappable, cax=cax, label=drawn.label,
                                           ticks=self.scale.ticks)
            if isinstance(self.scale.norm, LogNorm):  # plain numbers, not powers of 10
                bar.ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
                bar.ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
            self.figure.canvas.draw()
            if self._positions is None:
                self._positions = (ax.get_position(), bar.ax.get_position())
                self.figure.set_layout_engine("none")
            rgba = _fit(np.asarray(self.figure.canvas.buffer_rgba())[..., :3], self.size)
            if not ring_index(frame).size:  # (in the same font size: tick labels depend on it)
                self._keep_background(ax, drawn.mappable)
        return rgba

    def _keep_background(self, ax: Any, grains: Any) -> None:
        """Render the figure without the grains, the walls drawn over them and the title,
        and keep it with those artists for :meth:`_repaint`."""
        overlays = [c for c in ax.collections if c is not grains]
        moving = [grains, *overlays, ax.title]
        title_at = ax.title.get_position()  # a draw places a hidden title elsewhere
        for artist in moving:
            artist.set_visible(False)
        canvas = self.figure.canvas
        canvas.draw()
        background = canvas.copy_from_bbox(self.figure.bbox)
        for artist in moving:
            artist.set_visible(True)
        ax.title.set_position(title_at)
        self._scene = _Scene(ax, grains, overlays, background)

    def _repaint(self, frame: Frame, values: np.ndarray) -> np.ndarray:
        """The picture of ``frame`` (no rings) on the kept background: the grains' centres,
        sizes and colours and the title updated, drawn as :func:`draw_frame` orders them
        (grains, then walls)."""
        scene = self._scene
        assert scene is not None
        order, centres, diameters = disk_layout(frame, plot_axes(frame.dim, self.plane),
                                                ring_index(frame))
        grains = scene.grains
        grains.set_offsets(centres)
        grains.set_widths(diameters)
        grains.set_heights(diameters)
        grains.set_angles(np.zeros(len(order)))
        grains.set_array(values[order])
        scene.axes.title.set_text(frame_title(frame))
        canvas = self.figure.canvas
        canvas.restore_region(scene.background)
        for artist in (grains, *scene.overlays, scene.axes.title):
            scene.axes.draw_artist(artist)
        return _fit(np.asarray(canvas.buffer_rgba())[..., :3], self.size)

    def close(self) -> None:
        self.figure.clear()


class _OvitoPainter:
    """3D frames ray-traced by OVITO with a camera fixed on the box ``[lo, hi]``, between a
    band with the step, time and N above and one with the colour bar below."""

    def __init__(self, size: tuple[int, int], lo: np.ndarray, hi: np.ndarray,
                 scale: ColourScale, plane: str | None, quality: str) -> None:
        from grainflow.plotting.render3d import OvitoRenderer, bands, camera_for

        self.size, self.scale = size, scale
        top, bottom = bands(size)
        scene = (size[0], size[1] - top - bottom)
        self.renderer = OvitoRenderer(scene, camera_for(lo, hi, scene, plane=plane),
                                      quality=quality)

    def paint(self, frame: Frame, values: np.ndarray) -> np.ndarray:
        from grainflow.plotting.render3d import compose

        scene = self.renderer.render(frame, self.scale.rgb(values))
        text = f"step {frame.step}    t = {frame.time:.6g}    N = {frame.n}"
        return compose(scene, self.size, text, cmap=self.scale.cmap, norm=self.scale.norm,
                       label=self.scale.label, ticks=self.scale.ticks)

    def close(self) -> None:
        self.renderer.close()


def _fit(picture: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``picture`` cropped or padded (white) to exactly ``size`` = (width, height): matplotlib
    may round a figure's pixel size by one."""
    w, h = size
    picture = picture[:h, :w]
    pad = ((0, h - picture.shape[0]), (0, w - picture.shape[1]), (0, 0))
    return np.ascontiguousarray(np.pad(picture, pad, constant_values=255) if any(
        p[1] for p in pad) else picture)


# ---------------------------------------------------------------------------- orchestration
@dataclass
class _Scan:
    """What the first pass found over the selected frames, with each frame's colour values
    (kept for the second pass: network sizes are a graph search per frame)."""

    low: float = np.inf
    high: float = -np.inf
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None
    values: list[np.ndarray] = field(default_factory=list)

    def add_values(self, values: np.ndarray) -> None:
        self.values.append(values)
        finite = values[np.isfinite(values)]
        if finite.size:
            self.low = min(self.low, float(finite.min()))
            self.high = max(self.high, float(finite.max()))

    def add_box(self, lo: np.ndarray, hi: np.ndarray) -> None:
        self.lo = lo if self.lo is None else np.minimum(self.lo, lo)
        self.hi = hi if self.hi is None else np.maximum(self.hi, hi)


def _extent_3d(frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the spheres of a 3D frame (the box on periodic axes and when empty)."""
    lo = np.array(frame.box.lo, dtype=float)
    hi = np.array(frame.box.hi, dtype=float)
    if frame.n:
        r = frame.radius[:, None]
        grains_lo, grains_hi = (frame.position - r).min(axis=0), (frame.position + r).max(axis=0)
        periodic = np.asarray(frame.box.periodic)
        lo = np.where(periodic, np.minimum(lo, grains_lo), grains_lo)
        hi = np.where(periodic, np.maximum(hi, grains_hi), grains_hi)
    return lo, hi


def _renderer_for(dim: int, renderer: str) -> str:
    """``"ovito"`` or ``"matplotlib"`` for a run of ``dim`` and the ``renderer`` option."""
    if renderer not in RENDERERS:
        raise ViewError(f"--renderer: {renderer!r} is not valid; use auto (OVITO for 3D, "
                        "matplotlib for 2D), ovito or matplotlib")
    if renderer == "auto":
        return "ovito" if dim == 3 else "matplotlib"
    if renderer == "ovito" and dim == 2:
        raise ViewError("--renderer ovito: the run is 2D; 2D frames are drawn with matplotlib "
                        "(--renderer auto)")
    if renderer == "ovito":
        probe_ovito()  # before the scan: say at once if OVITO cannot render here
    return renderer


def _check_plane(plane: str | None) -> None:
    if plane is not None and (len(plane) != 2 or plane[0] == plane[1]
                              or not set(plane) <= set("xyz")):
        raise ViewError(f"--plane: {plane!r} is not valid; give two different axes among "
                        "x, y, z (xz: side view, xy: top view)")


def _check_paths(path: Path, poster: Path | None) -> None:
    check_movie_path(path)
    if poster is not None:
        if poster.suffix.lower() not in POSTER_SUFFIXES:
            raise ViewError(f"--poster: {poster.name!r} has an unknown suffix "
                            f"{poster.suffix!r}; name the poster .png (or .jpg)")
        if poster.resolve() == path.resolve():
            raise ViewError(f"--poster: {poster} is the movie's own path; give another name")


def _scan(source: FrameSource, chosen: list[int], color_by: str, delta: float,
          plane: str | None, flat: bool, walls: Sequence[Segment] | None,
          progress: ItemProgress) -> _Scan:
    """First pass: colour range and union extent (plot bounds when ``flat``, else 3D)."""
    scan = _Scan()
    for k in chosen:
        frame = source[k]
        scan.add_values(movie_values(frame, color_by, delta=delta, plane=plane))
        if flat:
            scan.add_box(*frame_limits(frame, plane or "xz", walls))
        else:
            scan.add_box(*_extent_3d(frame))
        progress.advance(info=f"step {frame.step}")
    return scan


def write_movie(
    run_or_frames: str | os.PathLike[str] | Sequence[Frame],
    path: str | os.PathLike[str],
    *,
    color_by: str = "speed",
    every: int = 1,
    frames: str | slice | None = None,
    fps: float = 10.0,
    size: str | tuple[int, int] | None = None,
    poster: str | os.PathLike[str] | None = None,
    poster_frame: int = -1,
    plane: str | None = None,
    renderer: str = "auto",
    quality: str = "fast",
    delta: float = 0.0,
    vmin: float | None = None,
    vmax: float | None = None,
    cmap: str | None = None,
    walls: Sequence[Segment] | None = None,
    progress: str = "auto",
    interval: float = 10.0,
) -> Path:
    """Write a movie of a run to ``path`` (``.mp4``: H.264; ``.gif``: animated GIF); returns
    the path.

    ``run_or_frames``: a run directory, an H5MD trajectory file or a sequence of frames (an
    in-memory run). ``color_by``: a name of :data:`MOVIE_COLOR_BY`; ``delta``: the contact
    distance margin of ``"network"`` in the run's length unit (0: grains touching).
    ``frames``: a range ``"a:b"`` of frame numbers, then ``every``: every K-th of them.
    ``fps``: pictures per second. ``size``: ``"WxH"`` or (w, h) pixels (even for MP4);
    default: from the run's extent in 2D, 640x480 in 3D. ``poster``: also save this PNG of
    the selected frame ``poster_frame`` (default the last). ``plane``: in 3D, an ortho view
    of two axes (``"xz"``: side view) instead of the default perspective; with
    ``renderer="matplotlib"`` (flat disks, no OVITO needed) the projection plane (default
    ``"xz"``). ``quality``: OVITO's ``"fast"`` or ``"fine"`` (ambient occlusion, ~4x slower).
    ``vmin``/``vmax``: the colour range (default: the range over the selected frames);
    ``cmap``: a matplotlib colour map name. ``walls``: 2D line segments to draw.
    ``progress``: ``"auto"``, ``"rich"``, ``"plain"`` or ``"none"``, a line every
    ``interval`` seconds when plain.

    Raises :class:`ViewError` for bad input (naming the option and the fix) and
    :class:`~grainflow.plotting.render3d.RendererUnavailable` when OVITO cannot render.
    """
    path, poster_path = Path(path), None if poster is None else Path(poster)
    wanted = _check_options(path, poster_path, size, color_by, delta, cmap, plane, quality)
    source = open_frames(run_or_frames)
    chosen = select_frames(len(source), frames, every)
    poster_index = _poster_index(chosen, poster_frame)
    kind = _renderer_for(source[chosen[0]].dim, renderer)
    writer = open_movie(path, fps)
    with make_item_progress(progress, len(chosen), "scan", interval=interval) as p:
        scan = _scan(source, chosen, color_by, delta, plane, kind == "matplotlib", walls, p)
    scale = colour_scale(color_by, scan.low, scan.high, vmin=vmin, vmax=vmax, cmap=cmap)
    painter = _painter(kind, wanted, scan, scale, plane, quality, walls)
    try:
        with writer, make_item_progress(progress, len(chosen), "frame", interval=interval) as p:
            for k, picture in _pictures(source, chosen, painter, scan.values):
                writer.append(picture)
                if poster_path is not None and k == poster_index:
                    write_png(picture, poster_path)
                p.advance(info=f"run frame {k}")
    finally:
        painter.close()
    return path


def _check_options(path: Path, poster: Path | None, size: str | tuple[int, int] | None,
                   color_by: str, delta: float, cmap: str | None, plane: str | None,
                   quality: str) -> tuple[int, int] | None:
    """Check the options that need no frames (raising :class:`ViewError`); returns the
    requested size, if any."""
    _check_paths(path, poster)
    check_colour(color_by, delta)
    if cmap is not None and cmap not in colormaps:
        raise ViewError(f"--cmap: {cmap!r} is not a matplotlib colour map; e.g. viridis, "
                        "plasma, coolwarm")
    _check_plane(plane)
    if quality not in QUALITY:
        raise ViewError(f"--quality: {quality!r} is not valid; use fast or fine")
    wanted = parse_size(size)
    if wanted is not None and path.suffix.lower() == ".mp4" and (wanted[0] % 2 or wanted[1] % 2):
        raise ViewError(f"--size: {wanted[0]}x{wanted[1]} has an odd side; MP4 (H.264, "
                        f"yuv420p) needs even sides, e.g. {wanted[0] + wanted[0] % 2}x"
                        f"{wanted[1] + wanted[1] % 2}")
    return wanted


def _poster_index(chosen: list[int], poster_frame: int) -> int:
    """The frame number of the poster: ``chosen[poster_frame]``."""
    if not -len(chosen) <= poster_frame < len(chosen):
        raise ViewError(f"poster_frame: {poster_frame} is outside the {len(chosen)} frames "
                        "shown; give an index among them (-1: the last)")
    return chosen[poster_frame]


def _painter(kind: str, wanted: tuple[int, int] | None, scan: _Scan, scale: ColourScale,
             plane: str | None, quality: str, walls: Sequence[Segment] | None) -> _Painter:
    """The painter of ``kind`` at the size ``wanted`` (default: from the extent in 2D,
    :data:`SIZE_3D` in 3D), fixed on the scanned extent."""
    assert scan.lo is not None and scan.hi is not None
    if kind == "matplotlib":
        size = wanted or _even(figure_size(scan.hi - scan.lo))
        return _MatplotlibPainter(size, (scan.lo, scan.hi), scale, plane or "xz", walls)
    return _OvitoPainter(wanted or SIZE_3D, scan.lo, scan.hi, scale, plane, quality)


def _pictures(source: FrameSource, chosen: list[int], painter: _Painter,
              values: list[np.ndarray]) -> Iterator[tuple[int, np.ndarray]]:
    """(frame number, picture) of each chosen frame, in order, coloured by the ``values``
    the scan found for it."""
    for k, colours in zip(chosen, values):
        yield k, painter.paint(source[k], colours)


def _even(inches: tuple[float, float]) -> tuple[int, int]:
    """Pixels at the movie's resolution of a figure ``inches`` wide and high, rounded up to
    even sides."""
    w, h = (int(np.ceil(v * _DPI)) for v in inches)
    return w + w % 2, h + h % 2
