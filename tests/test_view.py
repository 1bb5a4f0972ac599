"""``grainflow view``: movies (MP4, GIF) and poster frames of runs, 2D through matplotlib, 3D
through OVITO; fixed colour scales; clear errors for bad input; item progress with an ETA."""

from __future__ import annotations

import copy
import io
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

# One ray-tracing thread: the test machine is shared (read when OVITO starts its threads).
os.environ.setdefault("OVITO_THREAD_COUNT", "1")

from conftest import SIX_DISKS, one_thread  # noqa: E402
from test_dp_outputs import ring_frame  # noqa: E402

from grainflow.cli import app  # noqa: E402
from grainflow.frame import Box, Frame  # noqa: E402
from grainflow.io.h5md import TrajectoryWriter  # noqa: E402
from grainflow.plotting import movie as mv  # noqa: E402
from grainflow.plotting.movie import ViewError, write_movie  # noqa: E402
from grainflow.plotting.render3d import RendererUnavailable, bands, camera_for  # noqa: E402
from grainflow.progress import (ItemProgress, PlainItemProgress, RichItemProgress,  # noqa: E402
                                make_item_progress)


def has_imageio_ffmpeg() -> bool:
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        return False
    return True


#: MP4 needs imageio-ffmpeg (its bundled ffmpeg); GIF, PNG and the progress need nothing more.
needs_mp4 = pytest.mark.skipif(not has_imageio_ffmpeg(), reason="imageio-ffmpeg is not installed")

#: Six disks colliding in a periodic 2D box, 300 steps, a frame every 60: six frames.
TINY_2D: dict[str, Any] = {
    **SIX_DISKS, "output": {"thermo_every": 100, "frames_every": 60, "checkpoint_every": 0,
                            "snapshot": False}}


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def lattice_frames(count: int = 3, side: int = 4, radius: float = 0.4) -> list[Frame]:
    """A 3D cube of ``side``^3 spheres (spacing 1) falling with growing speed."""
    grid = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), -1).reshape(-1, 3)
    n = len(grid)
    frames = []
    for k in range(count):
        frames.append(Frame(
            step=100 * k, time=0.1 * k,
            box=Box(np.full(3, -1.0), np.full(3, side + 0.0), (False, False, False)),
            id=np.arange(n), type=(np.arange(n) % 2).astype(np.int32), body=np.full(n, -1),
            radius=np.full(n, radius), mass=np.ones(n), position=grid + [0.0, 0.0, -0.3 * k],
            velocity=np.tile([0.0, 0.0, -1.0 - k], (n, 1)), omega=np.zeros((n, 3))))
    return frames


@pytest.fixture(scope="module")
def run2d(tmp_path_factory) -> Path:
    """A real 2D run directory (config.toml, frames.h5 with six frames, manifest)."""
    from grainflow.runner import run_config

    rundir = tmp_path_factory.mktemp("view") / "run2d"
    config = copy.deepcopy(TINY_2D)
    with one_thread():
        run_config(config, rundir, progress="none", threads=1)
    return rundir


@pytest.fixture(scope="module")
def run3d(tmp_path_factory) -> Path:
    """A 3D run directory holding only frames.h5 (three frames of a falling cube)."""
    rundir = tmp_path_factory.mktemp("view") / "run3d"
    rundir.mkdir()
    frames = lattice_frames()
    with TrajectoryWriter(rundir / "frames.h5", 3, frames[0].box, contacts=False) as out:
        for frame in frames:
            out.append(frame)
    return rundir


@pytest.fixture(scope="module")
def ovito_renders() -> None:
    """Skip unless OVITO can ray-trace here (its module, Vulkan loader and a driver)."""
    from grainflow.plotting.render3d import probe_ovito

    try:
        probe_ovito()
    except RendererUnavailable as err:
        pytest.skip(f"OVITO cannot render here: {err}")


def mp4_frames(path: Path) -> tuple[tuple[int, int], list[np.ndarray]]:
    """(width, height) and the decoded RGB pictures of an MP4."""
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    w, h = meta["size"]
    pictures = [np.frombuffer(b, np.uint8).reshape(h, w, 3) for b in reader]
    return (w, h), pictures


def png_pixels(path: Path) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as image:
        return np.asarray(image.convert("RGB"))


# ----------------------------------------------------------------------------------- movies
@needs_mp4
def test_mp4_has_the_selected_frames_at_the_requested_size(run2d, tmp_path):
    movie = write_movie(run2d, tmp_path / "m.mp4", size=(320, 240), every=2,
                        poster=tmp_path / "p.png", progress="none")
    size, pictures = mp4_frames(movie)
    assert size == (320, 240) and len(pictures) == 3  # frames 0, 2, 4 of six
    assert png_pixels(tmp_path / "p.png").shape == (240, 320, 3)
    assert all(p.std() > 5 for p in pictures)  # not blank
    assert not list(tmp_path.glob(".*partial*"))


@needs_mp4
def test_gif_frame_count_range_and_default_even_size(run2d, tmp_path):
    from PIL import Image

    movie = write_movie(run2d, tmp_path / "m.gif", frames="1:5", every=2, fps=5,
                        progress="none")
    with Image.open(movie) as gif:
        assert gif.n_frames == 2  # frames 1 and 3
        assert gif.info["duration"] == 200
        w, h = gif.size
    mp4 = write_movie(run2d, tmp_path / "m.mp4", frames="-2:", progress="none")
    size, pictures = mp4_frames(mp4)
    assert size == (w, h) and w % 2 == 0 and h % 2 == 0 and len(pictures) == 2


@pytest.mark.parametrize("color_by", ["speed", "type", "network", "radius"])
def test_colour_by_quantities(color_by, tmp_path):
    config_frames = [ring_frame(0), ring_frame(1)]  # deformable rings are drawn as polygons
    path = write_movie(config_frames, tmp_path / "m.gif", color_by=color_by, delta=0.05,
                       size=(200, 160), poster=tmp_path / "p.png", progress="none")
    assert path.is_file() and png_pixels(tmp_path / "p.png").std() > 5


def test_colour_scale_is_fixed_over_the_movie(tmp_path):
    """Grain 0 moves at speed 1 in both frames; grain 1 at 0.5, then 3. On the movie's one
    scale (0 to 3) grain 0 has the same colour in the first and the last picture."""
    from matplotlib import colormaps

    frames = []
    for k, fast in enumerate((0.5, 3.0)):
        frames.append(Frame(
            step=k, time=float(k), box=Box(np.zeros(2), np.full(2, 4.0), (False, False)),
            id=np.arange(2), type=np.zeros(2, np.int32), body=np.full(2, -1),
            radius=np.full(2, 0.8), mass=np.ones(2), position=np.array([[1.0, 2.0], [3.0, 2.0]]),
            velocity=np.array([[1.0, 0.0], [fast, 0.0]]), omega=np.zeros((2, 3))))
    expected = np.array(colormaps["viridis"](1.0 / 3.0)[:3]) * 255
    for index in (0, -1):
        write_movie(frames, tmp_path / "m.gif", poster=tmp_path / f"p{index}.png",
                    poster_frame=index, size=(300, 200), progress="none")
        pixels = png_pixels(tmp_path / f"p{index}.png").astype(float)
        near = np.abs(pixels - expected).max(axis=2) < 4
        assert near.sum() > 500, index

    scale = mv.colour_scale("speed", 0.2, 3.0)
    assert (scale.norm.vmin, scale.norm.vmax) == (0.0, 3.0)
    assert mv.colour_scale("speed", 0.2, 3.0, vmax=5.0).norm.vmax == 5.0
    network = mv.colour_scale("network", 1.0, 40.0)
    assert type(network.norm).__name__ == "LogNorm" and network.norm.vmin == 1.0
    types = mv.colour_scale("type", 0.0, 2.0)
    assert types.ticks == (0.0, 1.0, 2.0) and types.cmap.N == 3
    flat = mv.colour_scale("radius", 0.5, 0.5)  # one value everywhere still gets a range
    assert flat.norm.vmax > flat.norm.vmin


def test_rings_keep_the_movie_scale(tmp_path):
    """draw_frame with a fixed norm colours ring polygons on it, unchanged."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    from grainflow.plotting.snapshot import draw_frame

    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    norm = Normalize(0.0, 10.0)
    drawn = draw_frame(ax, ring_frame(), color_by="type", norm=norm, label="type")
    (polygons,) = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert drawn.mappable.norm is norm and polygons.norm is norm
    assert polygons.get_clim() == (0.0, 10.0) and drawn.label == "type"


# ---------------------------------------------------------------------------------------- 3D
@needs_mp4
def test_3d_ovito_picture_shows_the_grains(run3d, tmp_path, ovito_renders):
    """An ortho side view (xz): pixels at the grains' centres are coloured, a corner far from
    grains and labels is background white; the movie has its frames at the size asked."""
    size = (320, 240)
    movie = write_movie(run3d, tmp_path / "m.mp4", size=size, plane="xz", color_by="type",
                        poster=tmp_path / "p.png", progress="none")
    (w, h), pictures = mp4_frames(movie)
    assert (w, h) == size and len(pictures) == 3
    poster = png_pixels(tmp_path / "p.png").astype(int)
    frames = lattice_frames()
    lo = np.min([(f.position - 0.4).min(axis=0) for f in frames], axis=0)
    hi = np.max([(f.position + 0.4).max(axis=0) for f in frames], axis=0)
    top, bottom = bands(size)  # the scene lies between the text and colour-bar bands
    scene_h = h - top - bottom
    camera = camera_for(lo, hi, (w, scene_h), plane="xz")
    centre = 0.5 * (lo + hi)
    scale = (scene_h / 2) / camera.fov  # pixels per length unit
    last = frames[-1]
    for x in last.position[[0, 21, 63]]:  # three grains
        col = int(round(w / 2 + (x[0] - centre[0]) * scale))
        row = int(round(top + scene_h / 2 - (x[2] - centre[2]) * scale))
        assert poster[row, col].min() < 235, (x, poster[row, col])  # not white: a grain
        gap = int(round(col + 0.5 * scale))  # half-way to the next column of grains
        assert poster[row, gap].min() > 240, (x, poster[row, gap])  # background between
    assert (poster[h - 3, 3] >= 250).all()  # bottom-left corner: background
    assert (np.abs(np.diff(poster[h // 2], axis=1)).sum(axis=1) > 30).sum() > 6  # edges
    assert poster[:top].min() < 100 and poster[h - bottom:].min() < 100  # label, colour bar


def test_3d_perspective_default_and_flat_projection(run3d, tmp_path, ovito_renders):
    from PIL import Image

    gif = write_movie(run3d, tmp_path / "m.gif", size=(160, 120), color_by="speed",
                      quality="fine", progress="none")
    with Image.open(gif) as movie:
        assert movie.n_frames == 3 and movie.size == (160, 120)
    flat = write_movie(run3d, tmp_path / "f.gif", renderer="matplotlib", color_by="network",
                       delta=0.3, size=(200, 160), progress="none")
    with Image.open(flat) as movie:
        assert movie.n_frames == 3 and movie.size == (200, 160)


def test_perspective_camera_sees_every_corner():
    lo, hi, size = np.array([0.0, -1.0, 2.0]), np.array([4.0, 3.0, 9.0]), (640, 480)
    camera = camera_for(lo, hi, size)
    assert camera.perspective and np.isclose(np.linalg.norm(camera.direction), 1.0)
    right = np.cross(camera.direction, camera.up)
    tan_v = np.tan(camera.fov / 2)
    corners = np.array(np.meshgrid(*zip(lo, hi))).reshape(3, -1).T
    rel = corners - camera.position
    depth = rel @ camera.direction
    assert (depth > 0).all()
    assert (np.abs(rel @ camera.up) / depth <= tan_v * 1.0001).all()
    assert (np.abs(rel @ right) / depth <= tan_v * size[0] / size[1] * 1.0001).all()
    ortho = camera_for(lo, hi, size, plane="xz")
    assert not ortho.perspective and np.allclose(ortho.direction, [0, 1, 0])
    assert np.isclose(ortho.fov, 3.5 * 1.04)  # half of z's 7, with the margin


# ------------------------------------------------------------------------------- bad input
def bad_cases(run2d: Path, tmp: Path) -> list[tuple[dict[str, Any], str]]:
    empty = tmp / "empty"
    empty.mkdir(exist_ok=True)
    out = tmp / "m.mp4"
    return [
        ({"run_or_frames": tmp / "missing", "path": out}, "no such run directory"),
        ({"run_or_frames": empty, "path": out}, "no frames.h5 in this run directory"),
        ({"run_or_frames": [], "path": out}, "the trajectory has no frames"),
        ({"path": out, "color_by": "colour"}, "--color-by: 'colour' is not known"),
        ({"path": out, "color_by": "network", "delta": -1.0}, "--delta: -1.0 is not valid"),
        ({"path": out, "size": "640by480"}, "--size: '640by480' is not valid"),
        ({"path": out, "size": "641x480"}, "MP4 (H.264, yuv420p) needs even sides"),
        ({"path": out, "size": "8x8"}, "--size: 8x8 is out of range"),
        ({"path": tmp / "m.avi"}, "unknown suffix '.avi'; name the movie .mp4"),
        ({"path": out, "poster": tmp / "p.bmp"}, "--poster: 'p.bmp' has an unknown suffix"),
        ({"path": out, "every": 0}, "--every: 0 is not valid"),
        ({"path": out, "frames": "1:2:3"}, "--frames: '1:2:3' is not valid"),
        ({"path": out, "frames": "10:20"}, "none in --frames 10:20"),
        ({"path": out, "fps": 0}, "--fps: 0 is not valid"),
        ({"path": out, "renderer": "ovito"}, "--renderer ovito: the run is 2D"),
        ({"path": out, "renderer": "povray"}, "--renderer: 'povray' is not valid"),
        ({"path": out, "plane": "xx"}, "--plane: 'xx' is not valid"),
        ({"path": out, "quality": "best"}, "--quality: 'best' is not valid"),
        ({"path": out, "cmap": "rainbowish"}, "--cmap: 'rainbowish' is not a matplotlib"),
        ({"path": tmp / "m.gif", "vmin": 2.0, "vmax": 1.0}, "--vmax: 1.0 is not above"),
        ({"path": out, "poster_frame": 6}, "poster_frame: 6 is outside"),
    ]


def test_bad_input_raises_a_clear_error(run2d, tmp_path):
    for kwargs, text in bad_cases(run2d, tmp_path):
        kwargs = {"run_or_frames": run2d, "progress": "none", **kwargs}
        with pytest.raises(ViewError) as err:
            write_movie(kwargs.pop("run_or_frames"), kwargs.pop("path"), **kwargs)
        assert text in str(err.value), (kwargs, str(err.value))
    assert {p.name for p in tmp_path.iterdir()} == {"empty"}  # nothing written


def test_mp4_without_imageio_ffmpeg_names_the_fix(run2d, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # import imageio_ffmpeg fails
    with pytest.raises(ViewError, match="pip install imageio-ffmpeg.*movie.gif"):
        write_movie(run2d, tmp_path / "m.mp4", progress="none")
    assert not list(tmp_path.iterdir())


def test_3d_without_ovito_names_the_fix(run3d, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "ovito", None)  # import ovito now fails
    with pytest.raises(RendererUnavailable, match="pip install ovito.*--renderer matplotlib"):
        write_movie(run3d, tmp_path / "m.gif", progress="none")
    assert not (tmp_path / "m.gif").exists()
    gif = write_movie(run3d, tmp_path / "m.gif", renderer="matplotlib", size=(100, 80),
                      progress="none")  # the way round works without OVITO
    assert gif.is_file()


# ------------------------------------------------------------------------------- the writers
@needs_mp4
def test_writers_pad_odd_mp4_sides_and_replace_only_when_complete(tmp_path):
    with mv.open_movie(tmp_path / "odd.mp4", fps=4) as movie:
        for k in range(3):
            movie.append(np.full((31, 45, 3), 40 * k, np.uint8))
    size, pictures = mp4_frames(tmp_path / "odd.mp4")
    assert size == (46, 32) and len(pictures) == 3

    target = tmp_path / "keep.gif"
    target.write_bytes(b"old movie")
    with pytest.raises(RuntimeError, match="painting failed"):
        with mv.open_movie(target, fps=4) as movie:
            movie.append(np.zeros((20, 20, 3), np.uint8))
            raise RuntimeError("painting failed")
    assert target.read_bytes() == b"old movie" and len(list(tmp_path.iterdir())) == 2
    with pytest.raises(ValueError, match="all have one size"):
        with mv.open_movie(tmp_path / "sizes.gif", fps=4) as movie:
            movie.append(np.zeros((20, 20, 3), np.uint8))
            movie.append(np.zeros((20, 22, 3), np.uint8))
    assert not (tmp_path / "sizes.gif").exists()


@needs_mp4
def test_stream_movie_goes_through_the_movie_writer(tmp_path):
    from test_stream_analysis import DELTA, ball, make_frame

    from grainflow.plotting.stream_plots import write_stream_movie

    frames = [make_frame(ball(2, (0.0, 0.0, -0.01)) - [0, 0, 1e-3 * k], time=1e-3 * k, step=k)
              for k in range(2)]
    movie = write_stream_movie(frames, tmp_path / "s.mp4", DELTA, depth_range=(0, 0.02),
                               columns=2)
    size, pictures = mp4_frames(movie)
    assert len(pictures) == 2 and size[0] % 2 == 0 and size[1] % 2 == 0
    with pytest.raises(ViewError, match="unknown suffix"):
        write_stream_movie(frames, tmp_path / "s.avi", DELTA)


# --------------------------------------------------------------------------------- the CLI
@needs_mp4
def test_cli_view_writes_movie_and_poster_in_the_run(run2d, tmp_path):
    rundir = tmp_path / "run"
    shutil.copytree(run2d, rundir)
    result = CliRunner().invoke(app, ["view", str(rundir), "--size", "240x200", "--every", "3",
                                      "--progress", "plain", "--color-by", "type"])
    assert result.exit_code == 0, result.output
    assert f"wrote {rundir / 'movie.mp4'} and {rundir / 'poster.png'}" in result.stdout
    assert "eta" in result.stdout
    size, pictures = mp4_frames(rundir / "movie.mp4")
    assert size == (240, 200) and len(pictures) == 2
    from grainflow.runner import read_manifest

    assert {"movie.mp4", "poster.png"} <= set(read_manifest(rundir))
    again = CliRunner().invoke(app, ["view", str(rundir), "--progress", "none", "--frames", ":1"])
    assert again.exit_code == 0, again.output  # grainflow's own movie is replaced
    assert len(mp4_frames(rundir / "movie.mp4")[1]) == 1


def test_cli_view_errors_are_one_line(run2d, tmp_path):
    rundir = tmp_path / "run"
    shutil.copytree(run2d, rundir)
    (rundir / "poster.png").write_bytes(b"mine")
    refused = CliRunner().invoke(app, ["view", str(rundir), "--progress", "none"])
    assert refused.exit_code == 2
    assert refused.stderr.strip() == (f"error: {rundir / 'poster.png'} exists and was not "
                                      "written by grainflow; move it away or give --poster")
    assert (rundir / "poster.png").read_bytes() == b"mine"
    bad = CliRunner().invoke(app, ["view", str(rundir), "-o", str(tmp_path / "m.gif"),
                                   "--poster", str(tmp_path / "p.png"), "--color-by", "heat"])
    assert bad.exit_code == 2 and bad.stderr.startswith("error: --color-by: 'heat'")
    missing = CliRunner().invoke(app, ["view", str(tmp_path / "nowhere")])
    assert missing.exit_code == 2 and "no such run directory" in missing.stderr


# ---------------------------------------------------------------------------- item progress
def test_plain_item_progress_prints_count_and_eta():
    out = io.StringIO()
    with make_item_progress("auto", 3, "frame", stream=out, interval=0.0) as p:
        assert isinstance(p, PlainItemProgress)
        for k in range(3):
            p.advance(info=f"step {k}")
    lines = out.getvalue().splitlines()
    assert lines[0] == "frame 0/3"
    assert lines[1].startswith("frame 1/3 (33.3%)  eta ") and lines[1].endswith("step 0")
    assert lines[3].startswith("frame 3/3 (100.0%)  eta 0:00:00")
    assert lines[4].startswith("frame 3/3 done in ")
    assert len(lines) == 5


def test_plain_item_progress_prints_at_most_once_per_interval():
    out = io.StringIO()
    p = make_item_progress("plain", 100, "run", stream=out, interval=3600.0)
    for _ in range(49):
        p.advance(2)  # k items at once
    assert out.getvalue().splitlines() == ["run 0/100"] and p.done == 98
    p.advance(2)  # the last item is always reported
    p.close()
    p.close()  # closing twice is harmless
    lines = out.getvalue().splitlines()
    assert lines[1].startswith("run 100/100 (100.0%)  eta 0:00:00")
    assert len(lines) == 3 and lines[2].startswith("run 100/100 done in")


def test_item_progress_modes():
    terminal = FakeTerminal()
    with make_item_progress("auto", 4, "phase", stream=terminal) as bar:
        assert isinstance(bar, RichItemProgress)
        bar.advance(2, info="fields")
    assert "2/4" in terminal.getvalue() and "eta" in terminal.getvalue()
    quiet = make_item_progress("none", 2, "run")
    assert type(quiet) is ItemProgress
    quiet.advance()
    assert quiet.done == 1 and quiet.eta() >= 0.0
    assert ItemProgress(5).eta() == float("inf")
    with pytest.raises(ValueError, match="progress: 'fancy' is not valid"):
        make_item_progress("fancy", 2)
    with pytest.raises(ValueError, match="total=-1"):
        make_item_progress("none", -1)


def test_movie_progress_plain_lines(run2d, tmp_path, capsys):
    write_movie(run2d, tmp_path / "m.gif", size=(120, 100), frames=":2", progress="plain",
                interval=0.0)
    out = capsys.readouterr().out.splitlines()
    assert "frame 0/2" in out and any(line.startswith("frame 2/2 (100.0%)  eta") for line in out)
    assert any(line.startswith("scan 1/2") for line in out)


@pytest.mark.parametrize("with_walls", [False, True])
def test_pictures_on_the_kept_background_are_those_of_whole_figures(run2d, with_walls):
    """After the first picture the 2D painter draws only the grains, walls and title over a
    kept background: each picture is, pixel for pixel, the whole figure drawn again (as
    every picture was before); a frame with rings is drawn whole."""
    from matplotlib.colors import Normalize

    source = mv.open_frames(run2d)
    frames = [source[k] for k in range(len(source))]
    lo, hi = mv.frame_limits(frames[0])
    lo, hi = lo - 1.0, hi + 1.0
    walls = [((lo[0] + 0.5, lo[1] + 0.5), (hi[0] - 0.5, lo[1] + 1.5))] if with_walls else None
    speeds = [np.linalg.norm(f.velocity, axis=1) for f in frames]
    scale = mv.ColourScale(mv.colormaps["viridis"], Normalize(0.0, max(s.max() for s in speeds)),
                           "speed")
    kept = mv._MatplotlibPainter((320, 240), (lo, hi), scale, "xz", walls)
    whole = mv._MatplotlibPainter((320, 240), (lo, hi), scale, "xz", walls)
    whole._keep_background = lambda ax, grains: None  # every picture drawn whole
    pictures = [kept.paint(f, s) for f, s in zip(frames, speeds)]
    assert kept._scene is not None and whole._scene is None
    assert len({p.tobytes() for p in pictures}) == len(frames)  # grains and title move
    for frame, values, picture in zip(frames, speeds, pictures):
        assert np.array_equal(picture, whole.paint(frame, values))
    rings = ring_frame(0)
    kept.paint(rings, np.zeros(rings.n))
    assert kept._scene is None  # drawn whole
