"""Snapshot images: files are written, grains have their true size, nearer grains are on top."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest
from matplotlib.image import imread
from test_io_h5md import make_frame

from grainflow.frame import Box, Frame
from grainflow.plotting.snapshot import snapshot


def frame_of(position, radius, velocity=None, periodic=None) -> Frame:
    """A frame with the given grains and otherwise neutral data."""
    position = np.asarray(position, dtype=float)
    n, dim = position.shape
    return Frame(
        step=1, time=0.5,
        box=Box(lo=position.min(axis=0) - 1, hi=position.max(axis=0) + 1, periodic=periodic or (False,) * dim),
        id=np.arange(n), type=np.zeros(n, np.int32), body=np.full(n, -1),
        radius=np.asarray(radius, dtype=float), mass=np.ones(n),
        position=position, velocity=np.zeros((n, dim)) if velocity is None else np.asarray(velocity, float),
        omega=np.zeros((n, 3)),
    )


def plot_pixels(path) -> np.ndarray:
    """RGB pixels of the plot area (left of the colour bar)."""
    image = imread(path)[:, :, :3]
    return image[:, : int(0.7 * image.shape[1])]


def count_colour(pixels: np.ndarray, rgb) -> int:
    return int((np.abs(pixels - np.asarray(rgb)).max(axis=2) < 0.03).sum())


@pytest.mark.parametrize("dim", [2, 3])
def test_snapshot_writes_png(tmp_path, dim):
    frame = make_frame(np.random.default_rng(dim), dim=dim, n=200)
    path = snapshot(frame, tmp_path / "a.png", walls=[((0, 0), (1, 1))] if dim == 2 else None, title="T")
    assert path == tmp_path / "a.png"
    image = imread(path)
    assert image.shape[0] > 300 and image.shape[1] > 300
    assert image[:, :, :3].std() > 0.05  # not blank


def test_empty_frame_and_other_formats(tmp_path):
    frame = make_frame(np.random.default_rng(0), dim=2, n=0)
    assert snapshot(frame, tmp_path / "empty.png").stat().st_size > 0
    assert snapshot(make_frame(np.random.default_rng(1), n=5), tmp_path / "a.svg").read_text().startswith("<?xml")


def test_disk_has_true_radius_and_is_round(tmp_path):
    """A disk of radius 1 in a plot spanning [-5, 5] (+3 % margins) is 2/10.6 of the axes wide."""
    frame = frame_of([[0.0, 0.0]], [1.0], periodic=(True, True))
    frame = Frame(**{**frame.__dict__, "box": Box(np.array([-5.0, -5.0]), np.array([5.0, 5.0]), (True, True))})
    path = snapshot(frame, tmp_path / "disk.png", title="")
    coloured = np.nonzero(np.ptp(plot_pixels(path), axis=2) > 0.2)
    disk_height, disk_width = (np.ptp(c) + 1 for c in coloured)
    dark = imread(path)[:, :, :3].max(axis=2) < 0.3
    top_spine = dark[dark.sum(axis=1).argmax()]  # the longest dark lines are the axes spines
    left_spine = dark[:, dark.sum(axis=0).argmax()]
    axes_width, axes_height = np.ptp(np.nonzero(top_spine)[0]), np.ptp(np.nonzero(left_spine)[0])
    assert axes_width == pytest.approx(axes_height, rel=0.02)  # equal aspect, square data
    assert disk_width / axes_width == pytest.approx(2 / 10.6, rel=0.03)
    assert disk_height / axes_height == pytest.approx(2 / 10.6, rel=0.03)


@pytest.mark.parametrize(("plane", "near_coordinate"), [("xz", -1.0), ("xy", 1.0), ("yz", 1.0)])
def test_nearer_sphere_is_drawn_on_top(tmp_path, plane, near_coordinate):
    """A small near sphere in front of a big far one stays visible in the projection."""
    hidden = ({"x", "y", "z"} - set(plane)).pop()
    axis = "xyz".index(hidden)
    position = np.zeros((2, 3))
    position[0, axis] = near_coordinate  # near, small, coloured 1 (yellow)
    position[1, axis] = -near_coordinate  # far, big, coloured 0 (purple)
    frame = frame_of(position, [0.5, 2.0])
    pixels = plot_pixels(snapshot(frame, tmp_path / "p.png", plane=plane, color_by=np.array([1.0, 0.0])))
    yellow = matplotlib.colormaps["viridis"](1.0)[:3]
    purple = matplotlib.colormaps["viridis"](0.0)[:3]
    assert count_colour(pixels, yellow) > 1000
    assert count_colour(pixels, purple) > 10 * count_colour(pixels, yellow)


def test_snapshot_errors(tmp_path):
    frame = make_frame(np.random.default_rng(2), n=4)
    with pytest.raises(ValueError, match="color_by='colour'; use one of"):
        snapshot(frame, tmp_path / "a.png", color_by="colour")
    with pytest.raises(ValueError, match=r"color_by array has shape \(3,\), expected \(4,\)"):
        snapshot(frame, tmp_path / "a.png", color_by=np.zeros(3))
    with pytest.raises(ValueError, match="plane='xx'"):
        snapshot(frame, tmp_path / "a.png", plane="xx")


def test_backend_is_left_alone(tmp_path):
    before = matplotlib.get_backend()
    snapshot(make_frame(np.random.default_rng(3), n=3), tmp_path / "a.png", color_by="type")
    assert matplotlib.get_backend() == before
