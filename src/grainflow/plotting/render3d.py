"""Ray-traced pictures of 3D frames with OVITO's software renderer (Tachyon), off-screen.

Each grain is a sphere of its true radius and its own colour (computed by the caller, e.g.
:mod:`grainflow.plotting.movie`, on one colour scale for a whole movie). The camera is fixed
by :func:`camera_for` from a bounding box (a movie's union extent), so a movie does not
zoom or pan between frames: an ortho view of a coordinate plane (``plane="xz"``: side view,
viewer at -y, z up, as :func:`grainflow.plotting.snapshot.snapshot` projects), or by default
a perspective view from the front-left and a little above. The step, time and number of
grains (above) and a colour bar (below) are drawn with Pillow in white bands around the
rendered scene (:func:`compose`), so they never hide a grain.

OVITO's Python module (``pip install ovito``) renders through its Vulkan frame buffer even
with the software ray tracer, so it needs the Vulkan loader and a driver; without a GPU the
Mesa software driver does (Debian/Ubuntu: ``apt install libvulkan1 mesa-vulkan-drivers``).
:class:`RendererUnavailable` names that fix (or the matplotlib projection as the way round)
when either is missing.

Cost (one core, 640x480, 5,000 spheres): about 0.4 s a frame with ``quality="fast"``
(direct light, 2 anti-aliasing samples), 1.5 s with ``quality="fine"`` (ambient occlusion).
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any

import numpy as np
from matplotlib.colors import Colormap, Normalize

from grainflow.frame import Box, Frame

__all__ = ["QUALITY", "Camera", "OvitoRenderer", "RendererUnavailable", "bands", "camera_for",
           "check_ovito", "compose", "probe_ovito"]

_AXES = {"x": 0, "y": 1, "z": 2}
#: Tachyon settings of the two qualities: (ambient occlusion, anti-aliasing samples).
QUALITY = {"fast": (False, 2), "fine": (True, 3)}
#: Default perspective viewing direction: from the front-left (-y, -x), a little above.
PERSPECTIVE_DIRECTION = (0.45, 1.0, -0.35)
#: Vertical field of view of the perspective camera (radians).
PERSPECTIVE_FOV = np.radians(30.0)
_FIX = ("install the Vulkan loader and a driver (Debian/Ubuntu: apt install libvulkan1 "
        "mesa-vulkan-drivers, a software driver that needs no GPU), or draw a flat projection "
        "with matplotlib instead (--renderer matplotlib)")


class RendererUnavailable(RuntimeError):
    """OVITO cannot render here (module missing, or no Vulkan); the message names the fix.
    ``exit_code`` 2: the command line treats it as a usage problem with a way round."""

    exit_code = 2


@dataclass(frozen=True)
class Camera:
    """A fixed camera: ``position`` and unit ``direction`` (where it looks), ``up`` (the
    image's vertical), ``fov`` (perspective: vertical angle in radians; ortho: half the
    visible height in world units, OVITO's convention) and whether it is ``perspective``."""

    position: np.ndarray
    direction: np.ndarray
    up: np.ndarray
    fov: float
    perspective: bool


def camera_for(lo: Sequence[float], hi: Sequence[float], size: tuple[int, int], *,
               plane: str | None = None, margin: float = 0.04) -> Camera:
    """The camera that shows the whole box ``[lo, hi]`` in a ``size`` = (width, height)
    picture, with ``margin`` (a fraction) to spare.

    ``plane`` (two axes, e.g. ``"xz"``): an ortho view of that plane, first axis to the
    right, second up, viewer on the side that makes (right, up, towards viewer) right-handed
    (``"xz"``: at -y). None: a perspective view along :data:`PERSPECTIVE_DIRECTION` with z up,
    placed at the nearest distance at which every corner of the box is in the picture.
    """
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(hi >= lo):
        raise ValueError(f"camera_for: lo={lo}, hi={hi}; expected 3D bounds with hi >= lo")
    aspect = size[0] / size[1]
    centre = 0.5 * (lo + hi)
    corners = np.array(list(itertools.product(*zip(lo, hi))))  # the box's 8 corners
    offsets = corners - centre
    if plane is not None:
        right, up = (np.eye(3)[a] for a in _plane_axes(plane))
        forward = np.cross(up, right)
        half = max(np.abs(offsets @ up).max(), np.abs(offsets @ right).max() / aspect)
        half = max(half, 1e-12) * (1.0 + margin)
        distance = 2.0 * float(np.linalg.norm(hi - lo)) + 1.0
        return Camera(centre - distance * forward, forward, up, half, False)
    forward = np.asarray(PERSPECTIVE_DIRECTION, dtype=float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan_v = np.tan(PERSPECTIVE_FOV / 2) / (1.0 + margin)
    tan_h = tan_v * aspect
    along = offsets @ forward
    distance = max(float((np.abs(offsets @ right) / tan_h - along).max()),
                   float((np.abs(offsets @ up) / tan_v - along).max()), 1e-9)
    return Camera(centre - distance * forward, forward, up, float(PERSPECTIVE_FOV), True)


def _plane_axes(plane: str) -> tuple[int, int]:
    if len(plane) != 2 or plane[0] == plane[1] or not set(plane) <= set(_AXES):
        raise ValueError(f"plane: {plane!r}; use two different axes among x, y, z, e.g. 'xz'")
    return _AXES[plane[0]], _AXES[plane[1]]


def check_ovito() -> Any:
    """Import OVITO's modules; raise :class:`RendererUnavailable` with the fix if missing."""
    try:
        import ovito.data
        import ovito.pipeline
        import ovito.vis
    except ImportError as err:
        raise RendererUnavailable(
            f"3D pictures need OVITO's Python module, which is not installed ({err}); "
            "pip install ovito, or draw a flat projection with matplotlib instead "
            "(--renderer matplotlib)") from None
    return ovito


@functools.cache
def probe_ovito() -> None:
    """Render one sphere once per process: raises :class:`RendererUnavailable` with the fix
    when OVITO is missing or cannot render here (no Vulkan), before any real work."""
    box = Frame(step=0, time=0.0, box=Box(np.full(3, -1.0), np.ones(3), (False,) * 3),
                id=np.zeros(1, np.int64), type=np.zeros(1, np.int32), body=np.full(1, -1),
                radius=np.ones(1), mass=np.ones(1), position=np.zeros((1, 3)),
                velocity=np.zeros((1, 3)), omega=np.zeros((1, 3)))
    size = (16, 16)
    with OvitoRenderer(size, camera_for(-np.ones(3), np.ones(3), size)) as renderer:
        renderer.render(box, np.ones((1, 3)))


class OvitoRenderer:
    """Renders 3D frames to RGB arrays with one fixed ``camera`` at ``size`` = (width,
    height) pixels, ``quality`` a key of :data:`QUALITY`, on a white background.

    Holds one OVITO pipeline in OVITO's global scene while open; use it as a context
    manager (or call :meth:`close`) so the scene is left as it was found.
    """

    def __init__(self, size: tuple[int, int], camera: Camera, *, quality: str = "fast",
                 background: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> None:
        if quality not in QUALITY:
            raise ValueError(f"quality: {quality!r}; use one of {sorted(QUALITY)}")
        ovito = check_ovito()
        vis, pipeline = ovito.vis, ovito.pipeline
        self.size = (int(size[0]), int(size[1]))
        self.background = background
        self._source = pipeline.StaticSource(data=ovito.data.DataCollection())
        self._pipeline = pipeline.Pipeline(source=self._source)
        self._pipeline.add_to_scene()
        kind = vis.Viewport.Type.Perspective if camera.perspective else vis.Viewport.Type.Ortho
        self._viewport = vis.Viewport(type=kind, camera_pos=tuple(camera.position),
                                      camera_dir=tuple(camera.direction),
                                      camera_up=tuple(camera.up), fov=camera.fov)
        occlusion, samples = QUALITY[quality]
        self._renderer = vis.TachyonRenderer(ambient_occlusion=occlusion, shadows=False,
                                             antialiasing_samples=samples)
        self._open = True

    def render(self, frame: Frame, colours: np.ndarray) -> np.ndarray:
        """(height, width, 3) uint8 picture of ``frame``'s spheres with ``colours`` ((N, 3)
        RGB in [0, 1])."""
        import ovito.data

        if frame.dim != 3:
            raise ValueError(f"OvitoRenderer: frame has dim {frame.dim}; it draws 3D frames")
        data = ovito.data.DataCollection()
        particles = data.create_particles(count=frame.n)
        if frame.n:
            particles.create_property("Position", data=np.asarray(frame.position, dtype=float))
            particles.create_property("Radius", data=np.asarray(frame.radius, dtype=float))
            particles.create_property("Color", data=np.asarray(colours, dtype=float)[:, :3])
        self._source.data = data
        try:
            image = self._viewport.render_image(size=self.size, renderer=self._renderer,
                                                background=self.background)
        except RuntimeError as err:
            first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            if "vulkan" in str(err).lower():
                raise RendererUnavailable(f"OVITO could not render: {first} To fix it, "
                                          f"{_FIX}") from None
            raise
        return _rgb_of(image)

    def close(self) -> None:
        """Take this renderer's pipeline out of OVITO's scene (safe to call twice)."""
        if self._open:
            self._open = False
            self._pipeline.remove_from_scene()

    def __enter__(self) -> "OvitoRenderer":
        return self

    def __exit__(self, kind: type[BaseException] | None, err: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def _rgb_of(image: Any) -> np.ndarray:
    """(h, w, 3) uint8 copy of a Qt image in OVITO's RGBA8888 (or ARGB32) format."""
    h, w = image.height(), image.width()
    raw = np.frombuffer(image.constBits(), dtype=np.uint8, count=image.sizeInBytes())
    pixels = raw.reshape(h, image.bytesPerLine())[:, : 4 * w].reshape(h, w, 4)
    if "RGBA8888" in str(image.format()):
        return pixels[..., :3].copy()
    return pixels[..., 2::-1].copy()  # ARGB32 is B, G, R, A in memory on little-endian


def bands(size: tuple[int, int]) -> tuple[int, int]:
    """Heights in pixels of the white bands above (text) and below (colour bar) the
    rendered scene in a picture of ``size`` = (width, height) (see :func:`compose`); both 0
    when the picture is too small to spare them."""
    font = _font_px(size)
    top, bottom = round(1.8 * font), round(2.8 * font)
    if size[1] - top - bottom < size[1] // 2:
        return 0, 0
    return top, bottom


def compose(scene: np.ndarray, size: tuple[int, int], text: str, *,
            cmap: Colormap | None = None, norm: Normalize | None = None, label: str = "",
            ticks: Sequence[float] | None = None) -> np.ndarray:
    """The (height, width, 3) uint8 picture of ``size`` = (width, height): the rendered
    ``scene`` (as wide as the picture, as high as :func:`bands` leaves) between a white band
    with ``text`` (one line, e.g. step and time) above and, given ``cmap`` and ``norm``, a
    horizontal colour bar with its ends marked (the norm's range, or the first and last of
    ``ticks`` for categories such as types) and ``label`` below. Text is black, in
    matplotlib's DejaVu Sans, sized to the picture."""
    from PIL import Image, ImageDraw

    width, height = size
    top, bottom = bands(size)
    picture = Image.new("RGB", (width, height), (255, 255, 255))
    picture.paste(Image.fromarray(np.ascontiguousarray(scene)), (0, top))
    if top == 0:
        return np.asarray(picture)
    draw = ImageDraw.Draw(picture)
    px = _font_px(size)
    font = _font(px)
    draw.text((px // 2, top // 2), text, fill=(0, 0, 0), font=font, anchor="lm")
    if cmap is not None and norm is not None:
        ends = (norm.vmin, norm.vmax) if not ticks else (ticks[0], ticks[-1])
        _colour_bar(draw, (0, height - bottom, width, height), cmap, ends, label, font, px)
    return np.asarray(picture)


def _colour_bar(draw: Any, box: tuple[int, int, int, int], cmap: Colormap,
                ends: tuple[float, float], label: str, font: Any, px: int) -> None:
    """A horizontal colour bar in the band ``box`` (x0, y0, x1, y1): the low end's value
    left of it, the high end's right of it, ``label`` centred below."""
    x0, y0, x1, _ = box
    left, right = x0 + (x1 - x0) // 4, x1 - (x1 - x0) // 4
    bar_top, bar_bottom = y0 + round(0.4 * px), y0 + round(1.1 * px)
    colours = (np.asarray(cmap(np.linspace(0.0, 1.0, right - left)))[:, :3] * 255).round()
    for k, rgb in enumerate(colours.astype(int)):
        draw.line([(left + k, bar_top), (left + k, bar_bottom)], fill=tuple(rgb))
    draw.rectangle([left, bar_top, right, bar_bottom], outline=(0, 0, 0))
    middle = (bar_top + bar_bottom) // 2
    draw.text((left - px // 3, middle), f"{ends[0]:.4g}", fill=(0, 0, 0), font=font, anchor="rm")
    draw.text((right + px // 3, middle), f"{ends[1]:.4g}", fill=(0, 0, 0), font=font, anchor="lm")
    if label:
        draw.text(((left + right) // 2, bar_bottom + round(0.3 * px)), label, fill=(0, 0, 0),
                  font=font, anchor="mt")


def _font_px(size: tuple[int, int]) -> int:
    """Text height in pixels for a picture of ``size``: 1/28 of its smaller side, >= 8."""
    return max(8, round(min(size) / 28))


def _font(size: int) -> Any:
    """matplotlib's DejaVu Sans at ``size`` pixels (Pillow's own font if it cannot be read)."""
    from matplotlib import font_manager
    from PIL import ImageFont

    try:
        return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)
    except OSError:
        return ImageFont.load_default(size)
