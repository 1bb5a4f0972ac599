"""LAMMPS dump and VTK exports: round trips through our readers, XML, and the real tools.

OVITO (``ovito``) and VTK (``vtk``) are optional test dependencies; their tests are skipped
when the packages are not installed.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from test_io_h5md import make_frame

from grainflow.io import VtkSeries, read_lammps_dump, write_lammps_dump, write_pvd, write_vtp

ATOM_COLUMNS = "id type radius x y z vx vy vz omegax omegay omegaz".split()


def frames_2d_3d() -> list:
    rng = np.random.default_rng(11)
    return [make_frame(rng, dim=2, step=0, n=6, periodic=(True, False)),
            make_frame(rng, dim=2, step=50, n=0, periodic=(True, False)),
            make_frame(rng, dim=3, step=100, n=9, periodic=(True, True, False))]


# --- LAMMPS dump ---------------------------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 3])
def test_lammps_dump_round_trip(tmp_path, dim):
    rng = np.random.default_rng(dim)
    frames = [make_frame(rng, dim=dim, step=s, n=n) for s, n in ((0, 5), (10, 0), (20, 12))]
    path = write_lammps_dump(tmp_path / "run.dump", frames[:2])
    write_lammps_dump(path, frames[2], append=True)
    blocks = read_lammps_dump(path)
    assert [b.step for b in blocks] == [0, 10, 20]
    for block, frame in zip(blocks, frames):
        assert list(block.columns) == ATOM_COLUMNS and block.n == frame.n
        assert block.time == pytest.approx(frame.time)
        np.testing.assert_array_equal(block.columns["id"], frame.id)
        np.testing.assert_array_equal(block.columns["type"], frame.type)
        for k, axis in enumerate("xyz"[:dim]):
            np.testing.assert_allclose(block.columns[axis], frame.position[:, k], rtol=1e-9)
            np.testing.assert_allclose(block.columns["v" + axis], frame.velocity[:, k], rtol=1e-9)
            assert block.boundary[k] == ("pp" if frame.box.periodic[k] else "ff")
        for k, axis in enumerate("xyz"):
            np.testing.assert_allclose(block.columns["omega" + axis], frame.omega[:, k], rtol=1e-9)
        np.testing.assert_allclose(block.columns["radius"], frame.radius, rtol=1e-9)
        np.testing.assert_allclose(block.bounds[:dim], np.c_[frame.box.lo, frame.box.hi], rtol=1e-9)
        if dim == 2:
            assert block.boundary[2] == "pp"
            assert not block.columns["z"].any() and not block.columns["vz"].any()
            zlo, zhi = block.bounds[2]
            assert zlo < 0 < zhi and zhi - zlo <= 0.01 * frame.box.lengths.max() + 2 * frame.radius.max(initial=0)


def test_lammps_dump_text_header(tmp_path):
    frame = make_frame(np.random.default_rng(1), dim=3, step=7, n=2, periodic=(True, True, False))
    lines = write_lammps_dump(tmp_path / "a.dump", frame).read_text().splitlines()
    assert lines[2:6] == ["ITEM: TIMESTEP", "7", "ITEM: NUMBER OF ATOMS", "2"]
    assert lines[6] == "ITEM: BOX BOUNDS pp pp ff"
    assert lines[10] == "ITEM: ATOMS " + " ".join(ATOM_COLUMNS)
    assert len(lines) == 13 and len(lines[11].split()) == len(ATOM_COLUMNS)


def test_lammps_dump_reader_reports_bad_files(tmp_path):
    (tmp_path / "bad.dump").write_text("ITEM: TIMESTEP\n3\nITEM: NUMBER OF PARTICLES\n1\n")
    with pytest.raises(ValueError, match="expected 'ITEM: NUMBER OF ATOMS'"):
        read_lammps_dump(tmp_path / "bad.dump")
    good = write_lammps_dump(tmp_path / "good.dump", make_frame(np.random.default_rng(0), n=4)).read_text()
    (tmp_path / "cut.dump").write_text("".join(good.splitlines(keepends=True)[:-2]))
    with pytest.raises(ValueError, match="file ends in the middle of a block"):
        read_lammps_dump(tmp_path / "cut.dump")


def test_ovito_reads_lammps_dump(tmp_path):
    ovito_io = pytest.importorskip("ovito.io")
    frames = frames_2d_3d()
    path = write_lammps_dump(tmp_path / "run.dump", frames)
    pipeline = ovito_io.import_file(str(path))
    assert pipeline.source.num_frames == 3
    for k, frame in enumerate(frames):
        data = pipeline.compute(k)
        assert data.attributes["Timestep"] == frame.step
        assert data.particles.count == frame.n
        assert tuple(data.cell.pbc[: frame.dim]) == frame.box.periodic
        if frame.n:
            np.testing.assert_array_equal(data.particles["Particle Identifier"][...], frame.id)
            np.testing.assert_allclose(data.particles["Radius"][...], frame.radius, rtol=1e-6)  # float32
            np.testing.assert_allclose(data.particles["Position"][...][:, : frame.dim], frame.position, rtol=1e-9)
            np.testing.assert_allclose(data.particles["Angular Velocity"][...], frame.omega, rtol=1e-9)


# --- VTK -----------------------------------------------------------------------------------


def read_vtp_xml(path) -> dict[str, np.ndarray]:
    """Decode every DataArray of a .vtp written by write_vtp (either encoding) by name."""
    import base64

    types = {"Int32": "<i4", "Int64": "<i8", "Float64": "<f8"}
    root = ET.parse(path).getroot()
    assert root.get("type") == "PolyData" and root.get("header_type") == "UInt64"
    arrays = {}
    for array in root.iter("DataArray"):
        dtype, components = types[array.get("type")], int(array.get("NumberOfComponents"))
        text = array.text or ""
        if array.get("format") == "binary":
            raw = base64.b64decode(text)
            size = int(np.frombuffer(raw[:8], "<u8")[0])
            values = np.frombuffer(raw[8:], dtype)
            assert size == len(raw) - 8
        else:
            values = np.array(text.split(), dtype=dtype)
        arrays[array.get("Name")] = values.reshape(-1, components) if components > 1 else values
    return arrays


@pytest.mark.parametrize("encoding", ["base64", "ascii"])
@pytest.mark.parametrize("dim", [2, 3])
def test_vtp_round_trip_through_xml(tmp_path, encoding, dim):
    frame = make_frame(np.random.default_rng(dim), dim=dim, step=3, n=15)
    arrays = read_vtp_xml(write_vtp(tmp_path / "f.vtp", frame, encoding=encoding))
    np.testing.assert_array_equal(arrays["Points"][:, :dim], frame.position)
    np.testing.assert_array_equal(arrays["velocity"][:, :dim], frame.velocity)
    if dim == 2:
        assert not arrays["Points"][:, 2].any() and not arrays["velocity"][:, 2].any()
    np.testing.assert_array_equal(arrays["id"], frame.id)
    np.testing.assert_array_equal(arrays["type"], frame.type)
    np.testing.assert_array_equal(arrays["radius"], frame.radius)
    np.testing.assert_array_equal(arrays["omega"], frame.omega)
    np.testing.assert_allclose(arrays["speed"], np.linalg.norm(frame.velocity, axis=1))
    np.testing.assert_array_equal(arrays["connectivity"], np.arange(15))
    np.testing.assert_array_equal(arrays["offsets"], np.arange(1, 16))
    assert arrays["TimeValue"][0] == frame.time


def test_vtk_series_and_pvd(tmp_path):
    rng = np.random.default_rng(3)
    series = VtkSeries(tmp_path / "vtk", prefix="hopper")
    frames = [make_frame(rng, step=s) for s in (0, 10, 20)]
    paths = [series.append(f) for f in frames]
    entries = [(float(d.get("timestep")), d.get("file")) for d in ET.parse(series.pvd_path).iter("DataSet")]
    assert entries == [(f.time, p.name) for f, p in zip(frames, paths)]
    assert all((tmp_path / "vtk" / name).exists() for _, name in entries)
    assert not list((tmp_path / "vtk").glob("*.tmp"))
    # a resumed run keeps the entries up to its checkpoint and continues the series
    resumed = VtkSeries(tmp_path / "vtk", prefix="hopper", resume_step=10)
    resumed.append(make_frame(rng, step=15))
    files = [d.get("file") for d in ET.parse(resumed.pvd_path).iter("DataSet")]
    assert files == ["hopper_000000000.vtp", "hopper_000000010.vtp", "hopper_000000015.vtp"]
    write_pvd(tmp_path / "two.pvd", [(0.5, "a.vtp"), (1.0, "b.vtp")])
    assert [d.get("file") for d in ET.parse(tmp_path / "two.pvd").iter("DataSet")] == ["a.vtp", "b.vtp"]


def test_write_vtp_rejects_unknown_encoding(tmp_path):
    with pytest.raises(ValueError, match="encoding='raw'"):
        write_vtp(tmp_path / "f.vtp", make_frame(np.random.default_rng(0)), encoding="raw")


@pytest.mark.parametrize("encoding", ["base64", "ascii"])
def test_vtk_library_reads_vtp(tmp_path, encoding):
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import vtk_to_numpy

    for k, frame in enumerate(frames_2d_3d()):
        path = write_vtp(tmp_path / f"f{k}.vtp", frame, encoding=encoding)
        reader = vtk.vtkXMLPolyDataReader()
        reader.SetFileName(str(path))
        reader.Update()
        assert reader.GetErrorCode() == 0
        poly = reader.GetOutput()
        assert poly.GetNumberOfPoints() == frame.n and poly.GetNumberOfVerts() == frame.n
        assert vtk_to_numpy(poly.GetFieldData().GetArray("TimeValue"))[0] == frame.time
        if frame.n:
            points = vtk_to_numpy(poly.GetPoints().GetData())
            np.testing.assert_array_equal(points[:, : frame.dim], frame.position)
            data = poly.GetPointData()
            np.testing.assert_array_equal(vtk_to_numpy(data.GetArray("id")), frame.id)
            np.testing.assert_array_equal(vtk_to_numpy(data.GetArray("omega")), frame.omega)
            np.testing.assert_array_equal(vtk_to_numpy(data.GetArray("radius")), frame.radius)
