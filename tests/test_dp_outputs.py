"""Deformable rings in every output: frames, H5MD, VTK polygons and snapshots."""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from matplotlib.collections import EllipseCollection, PolyCollection
from matplotlib.image import imread
from test_io_exports import read_vtp_xml
from test_io_h5md import assert_frames_equal

from grainflow.frame import Box, Frame
from grainflow.insertion.dp_bodies import add_rings
from grainflow.io.h5md import TrajectoryWriter, read_frames, repair_frames
from grainflow.io.vtk import VtkSeries, write_rings_vtp
from grainflow.plotting import snapshot as snapshot_module
from grainflow.rings import RING_VERTEX, frame_rings, polygon_area, ring_outlines
from grainflow.state import ParticleState

N_V = 8
AREAS = (1.0, 1.5, 0.8)
#: Ring centres; the last one straddles the periodic x boundary at x = 5.
CENTRES = ((-2.0, 0.0), (1.0, 2.0), (4.8, -2.0))
BOX = Box(np.array([-5.0, -5.0]), np.array([5.0, 5.0]), (True, False))


def ring_state(seed: int = 0) -> ParticleState:
    """Three 8-vertex rings between free grains, shuffled, positions wrapped into the box."""
    rng = np.random.default_rng(seed)
    st = ParticleState(2, BOX)
    st.add_particles([[-4.0, 4.0], [0.0, -4.0]], 0.3, density=1.0, type=1)
    add_rings(st, CENTRES, AREAS, n_vertices=N_V, type=[0, 2, 0], rng=rng,
              v=rng.normal(size=(3, 2)))
    st.add_particles([[3.0, 4.0]], 0.4, density=1.0, type=1, v=[[1.0, 0.0]])
    st.reindex(rng.permutation(st.n))
    x = st.arrays["x"]
    x[:, 0] = -5.0 + np.mod(x[:, 0] + 5.0, 10.0)
    return st


def ring_frame(step: int = 0, seed: int = 0) -> Frame:
    return ring_state(seed).to_frame(step, 0.01 * step)


def plain_frame(step: int = 0) -> Frame:
    """A frame of the same box with free grains only (``ring_vertex`` None)."""
    st = ParticleState(2, BOX)
    st.add_particles([[-1.0, 0.0], [1.0, 0.0]], 0.5, density=1.0, v=[[0.5, 0.0], [-0.5, 0.0]])
    return st.to_frame(step, 0.01 * step)


# --------------------------------------------------------------------------- frames
def test_to_frame_carries_ring_vertex_and_frame_rings_orders_vertices():
    st = ring_state()
    frame = st.to_frame(3, 0.03)
    np.testing.assert_array_equal(frame.ring_vertex, st.arrays[RING_VERTEX])
    assert frame.ring_vertex.dtype == np.int32
    assert not np.shares_memory(frame.ring_vertex, st.arrays[RING_VERTEX])
    bodies, index = frame_rings(frame)
    assert index.shape == (3, N_V) and np.unique(bodies).size == 3
    np.testing.assert_array_equal(frame.ring_vertex[index], np.tile(np.arange(N_V), (3, 1)))
    assert (frame.body[index] == bodies[:, None]).all()
    assert (frame.ring_vertex == -1).sum() == 3  # the free grains
    assert plain_frame().ring_vertex is None
    assert frame_rings(plain_frame())[1].shape == (0, 0)


def test_ring_outlines_are_whole_across_the_periodic_boundary():
    frame = ring_frame()
    _, index = frame_rings(frame)
    assert np.ptp(frame.position[index[2], 0]) > 5.0  # the last ring is cut by the wrap
    outlines = ring_outlines(frame, index)
    np.testing.assert_allclose(polygon_area(outlines), AREAS, rtol=1e-12)
    assert np.ptp(outlines[2, :, 0]) < 2.0  # drawn whole,
    assert (np.abs(outlines[2, :, 0]) > 5.0).any()  # sticking out of the box
    assert ring_outlines(frame, np.zeros((0, 0), dtype=np.int64)).shape == (0, 0, 2)


# --------------------------------------------------------------------------- H5MD
def write(path, frames, **kwargs) -> None:
    with TrajectoryWriter(path, 2, BOX, contacts=False, **kwargs) as writer:
        for frame in frames:
            writer.append(frame)


def assert_same(read: Frame, written: Frame) -> None:
    assert_frames_equal(read, written, contacts=False)
    if written.ring_vertex is None:
        assert read.ring_vertex is None
    else:
        assert read.ring_vertex.dtype == np.int32
        np.testing.assert_array_equal(read.ring_vertex, written.ring_vertex)


def test_h5md_round_trip_with_and_without_rings(tmp_path):
    frames = [plain_frame(0), ring_frame(1, seed=1), ring_frame(2, seed=2), plain_frame(3)]
    path = tmp_path / "t.h5"
    write(path, frames)
    for read, written in zip(read_frames(path), frames, strict=True):
        assert_same(read, written)
    with h5py.File(path, "r") as f:
        ds = f["particles/all/ring_vertex/value"]
        assert ds.dtype == np.int32 and ds.fillvalue == -1 and ds.shape[0] == 4
        assert f["particles/all/ring_vertex/step"] == f["particles/all/position/step"]


def test_h5md_frame_without_any_ring_reads_none(tmp_path):
    frame = dataclasses.replace(plain_frame(0), ring_vertex=np.full(2, -1, np.int32))
    write(tmp_path / "t.h5", [frame])
    assert next(read_frames(tmp_path / "t.h5")).ring_vertex is None


def test_h5md_resume_and_repair_keep_ring_vertex(tmp_path):
    frames = [ring_frame(k, seed=k) for k in range(3)]
    path = tmp_path / "t.h5"
    write(path, frames)
    more = ring_frame(2, seed=7)
    write(path, [more], append=True, resume_step=1)
    expected = [frames[0], frames[1], more]
    for read, written in zip(read_frames(path), expected, strict=True):
        assert_same(read, written)
    with pytest.warns(RuntimeWarning, match="kept its first 3"):
        assert repair_frames(path) == 3
    for read, written in zip(read_frames(path), expected, strict=True):
        assert_same(read, written)


def test_h5md_file_from_before_rings_reads_none_and_refuses_rings(tmp_path):
    path = tmp_path / "old.h5"
    write(path, [plain_frame(0)])
    with h5py.File(path, "r+") as f:  # the layout before ring_vertex was stored
        del f["particles/all/ring_vertex"]
    assert next(read_frames(path)).ring_vertex is None
    with TrajectoryWriter(path, 2, BOX, contacts=False, append=True) as writer:
        assert not writer.rings
        with pytest.raises(ValueError, match="written before ring_vertex was stored"):
            writer.append(ring_frame(1))
        writer.append(plain_frame(2))
    assert [f.step for f in read_frames(path)] == [0, 2]


@pytest.mark.parametrize(("change", "message"), [
    (lambda rv: rv[:-1], r"ring_vertex has shape"),
    (lambda rv: rv.astype(float), "must hold integers >= -1"),
    (lambda rv: np.where(rv < 0, -2, rv), "must hold integers >= -1"),
])
def test_h5md_refuses_a_bad_ring_vertex(tmp_path, change, message):
    frame = ring_frame()
    bad = dataclasses.replace(frame, ring_vertex=change(frame.ring_vertex))
    with TrajectoryWriter(tmp_path / "t.h5", 2, BOX, contacts=False) as writer:
        with pytest.raises(ValueError, match=message):
            writer.append(bad)
        assert writer.n_frames == 0


# --------------------------------------------------------------------------- VTK
@pytest.mark.parametrize("encoding", ["base64", "ascii"])
def test_rings_vtp_holds_one_counter_clockwise_polygon_per_ring(tmp_path, encoding):
    frame = ring_frame()
    bodies, index = frame_rings(frame)
    path = write_rings_vtp(tmp_path / "r.vtp", frame, encoding=encoding)
    piece = ET.parse(path).getroot().find("PolyData/Piece")
    assert piece.get("NumberOfPolys") == "3" and piece.get("NumberOfPoints") == str(3 * N_V)
    arrays = read_vtp_xml(path)
    np.testing.assert_array_equal(arrays["offsets"], N_V * np.arange(1, 4))
    np.testing.assert_array_equal(arrays["connectivity"], np.arange(3 * N_V))
    points = arrays["Points"][arrays["connectivity"]].reshape(3, N_V, 3)
    assert not points[..., 2].any()
    np.testing.assert_allclose(points[..., :2], ring_outlines(frame, index))
    np.testing.assert_allclose(polygon_area(points[..., :2]), AREAS, rtol=1e-12)  # ccw, whole
    np.testing.assert_array_equal(arrays["id"].reshape(3, N_V), frame.id[index])
    np.testing.assert_array_equal(arrays["ring_vertex"], np.tile(np.arange(N_V), 3))
    np.testing.assert_array_equal(arrays["body"], bodies)
    np.testing.assert_array_equal(arrays["type"], [0, 2, 0])
    np.testing.assert_allclose(arrays["area"], AREAS, rtol=1e-12)
    assert arrays["TimeValue"][0] == frame.time


def test_vtk_series_writes_a_rings_collection_for_frames_with_rings(tmp_path):
    series = VtkSeries(tmp_path / "vtk")
    for frame in (plain_frame(0), ring_frame(1), ring_frame(2)):
        series.append(frame)
    files = sorted(p.name for p in (tmp_path / "vtk").iterdir())
    assert files == ["frame.pvd", "frame_000000000.vtp", "frame_000000001.vtp",
                     "frame_000000002.vtp", "frame_rings.pvd", "frame_rings_000000001.vtp",
                     "frame_rings_000000002.vtp"]
    listed = [d.get("file") for d in ET.parse(series.rings_pvd_path).iter("DataSet")]
    assert listed == ["frame_rings_000000001.vtp", "frame_rings_000000002.vtp"]
    resumed = VtkSeries(tmp_path / "vtk", resume_step=1)
    resumed.append(ring_frame(5))
    listed = [d.get("file") for d in ET.parse(series.rings_pvd_path).iter("DataSet")]
    assert listed == ["frame_rings_000000001.vtp", "frame_rings_000000005.vtp"]


# --------------------------------------------------------------------------- snapshots
@pytest.fixture
def figures(monkeypatch) -> list:
    """The figures ``snapshot`` draws, kept for inspection."""
    drawn = []

    class Recorded(snapshot_module.Figure):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            drawn.append(self)

    monkeypatch.setattr(snapshot_module, "Figure", Recorded)
    return drawn


def collections(figure, kind) -> list:
    return [c for c in figure.axes[0].collections if type(c) is kind]


def test_snapshot_draws_one_polygon_per_ring(tmp_path, figures):
    frame = ring_frame()
    _, index = frame_rings(frame)
    path = snapshot_module.snapshot(frame, tmp_path / "dp.png", color_by="type")
    assert imread(path)[:, :, :3].std() > 0.05
    (polygons,) = collections(figures[0], PolyCollection)
    assert len(polygons.get_paths()) == 3
    np.testing.assert_array_equal(polygons.get_array(), [0, 2, 0])  # coloured by ring type
    for drawn, outline in zip(polygons.get_paths(), ring_outlines(frame, index), strict=True):
        np.testing.assert_allclose(drawn.vertices[:N_V], outline)
    (grains,) = collections(figures[0], EllipseCollection)
    assert len(grains.get_offsets()) == 3  # the free grains only
    assert grains.get_clim() == polygons.get_clim() == (0.0, 2.0)
    assert "3 rings" in figures[0].axes[0].get_title()


def test_snapshot_colours_rings_by_the_mean_and_outlines_vertices(tmp_path, figures):
    frame = ring_frame()
    _, index = frame_rings(frame)
    values = np.arange(frame.n, dtype=float)
    snapshot_module.snapshot(frame, tmp_path / "dp.png", color_by=values, vertices=True)
    (polygons,) = collections(figures[0], PolyCollection)
    np.testing.assert_allclose(polygons.get_array(), values[index].mean(axis=1))
    grains, disks = collections(figures[0], EllipseCollection)
    assert len(disks.get_offsets()) == 3 * N_V
    np.testing.assert_allclose(disks.get_offsets(), ring_outlines(frame, index).reshape(-1, 2))


def test_snapshot_of_grains_without_rings_draws_no_polygon(tmp_path, figures):
    snapshot_module.snapshot(plain_frame(), tmp_path / "plain.png")
    assert not collections(figures[0], PolyCollection)
    (grains,) = collections(figures[0], EllipseCollection)
    assert len(grains.get_offsets()) == 2
