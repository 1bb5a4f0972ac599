"""VTK XML output for ParaView: one ``.vtp`` PolyData file per frame and a ``.pvd`` series.

Each particle is a point (2D: ``z = 0``) with a vertex cell, carrying point data ``id``,
``type``, ``radius``, ``mass``, ``speed``, ``velocity`` and ``omega`` (3 components each).
The frame's time is stored as the field array ``TimeValue``, which ParaView recognises.

Deformable rings (:mod:`grainflow.rings`) go to a second PolyData file per frame
(:func:`write_rings_vtp`): one closed polygon cell per ring, its points the ring's vertices in
ring order (counter-clockwise), unwrapped across periodic boundaries so that no ring is cut.
"""

from __future__ import annotations

import base64
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path
from typing import Literal

import numpy as np

from grainflow.frame import Frame
from grainflow.io.h5md import check_finite_frame
from grainflow.rings import frame_rings, polygon_area, ring_outlines

__all__ = ["VtkSeries", "write_pvd", "write_rings_vtp", "write_vtp"]

Encoding = Literal["base64", "ascii"]
_VTK_TYPES = {
    np.dtype("<i4"): "Int32",
    np.dtype("<i8"): "Int64",
    np.dtype("<f8"): "Float64",
}


def write_vtp(path: str | os.PathLike[str], frame: Frame, *, encoding: Encoding = "base64") -> Path:
    """Write ``frame`` as a VTK XML PolyData file; returns the path.

    ``encoding="base64"`` stores arrays as inline base64 binary (little-endian, UInt64
    byte-count header), ``"ascii"`` as text. A frame with a non-finite value raises
    :class:`~grainflow.io.h5md.NonFiniteFrameError` (a ValueError naming the array and
    particle id) and nothing is written.
    """
    root, poly = _polydata(f"write_vtp({path})", frame, encoding)
    piece = ET.SubElement(poly, "Piece", NumberOfPoints=str(frame.n), NumberOfVerts=str(frame.n))
    _data_array(ET.SubElement(piece, "Points"), "Points", _pad3(frame.position), encoding)
    verts = ET.SubElement(piece, "Verts")
    _data_array(verts, "connectivity", np.arange(frame.n, dtype=np.int64), encoding)
    _data_array(verts, "offsets", np.arange(1, frame.n + 1, dtype=np.int64), encoding)
    point_data = ET.SubElement(piece, "PointData", Scalars="radius", Vectors="velocity")
    for name, values in _point_arrays(frame).items():
        _data_array(point_data, name, values, encoding)
    return _write_xml(root, Path(path))


def write_rings_vtp(path: str | os.PathLike[str], frame: Frame, *,
                    encoding: Encoding = "base64") -> Path:
    """Write the deformable rings of ``frame`` as VTK XML PolyData polygons; returns the path.

    One polygon cell per ring (rings in ascending body id), whose ``N_v`` points are the
    ring's vertices in ring order (counter-clockwise; 2D: ``z = 0``), unwrapped across
    periodic boundaries. Point data: ``id`` (Int64, the vertex particle's id),
    ``ring_vertex`` (Int32), ``speed`` and ``velocity``; cell data: ``body`` (Int64),
    ``type`` (Int32, the type of vertex 0) and ``area`` (Float64, the polygon's area). A
    frame without rings gives a file without cells. Encoding and non-finite values as in
    :func:`write_vtp`.
    """
    root, poly = _polydata(f"write_rings_vtp({path})", frame, encoding)
    ring_body, index = frame_rings(frame)
    n_rings, n_vertices = index.shape
    outlines = ring_outlines(frame, index)
    piece = ET.SubElement(poly, "Piece", NumberOfPoints=str(index.size), NumberOfPolys=str(n_rings))
    _data_array(ET.SubElement(piece, "Points"), "Points", _pad3(outlines.reshape(-1, frame.dim)),
                encoding)
    polys = ET.SubElement(piece, "Polys")
    _data_array(polys, "connectivity", np.arange(index.size, dtype=np.int64), encoding)
    _data_array(polys, "offsets", n_vertices * np.arange(1, n_rings + 1, dtype=np.int64), encoding)
    point_data = ET.SubElement(piece, "PointData", Scalars="ring_vertex", Vectors="velocity")
    velocity = np.asarray(frame.velocity)[index.ravel()]
    for name, values in {
        "id": np.asarray(frame.id, dtype="<i8")[index.ravel()],
        "ring_vertex": np.tile(np.arange(n_vertices, dtype="<i4"), n_rings),
        "speed": np.linalg.norm(velocity, axis=1),
        "velocity": _pad3(velocity),
    }.items():
        _data_array(point_data, name, values, encoding)
    cell_data = ET.SubElement(piece, "CellData", Scalars="body")
    for name, values in {
        "body": np.asarray(ring_body, dtype="<i8"),
        "type": np.asarray(frame.type, dtype="<i4")[index[:, :1]].ravel(),
        "area": polygon_area(outlines[..., :2]),
    }.items():
        _data_array(cell_data, name, values, encoding)
    return _write_xml(root, Path(path))


def write_pvd(path: str | os.PathLike[str], entries: Iterable[tuple[float, str | os.PathLike[str]]]) -> Path:
    """Write a ParaView collection listing ``(time, file)`` entries; file paths as given.

    Give paths relative to the ``.pvd``'s folder so the collection can be moved with its files.
    The file is replaced atomically, so a reader never sees it half written.
    """
    root = ET.Element("VTKFile", type="Collection", version="1.0", byte_order="LittleEndian")
    collection = ET.SubElement(root, "Collection")
    for time, file in entries:
        ET.SubElement(collection, "DataSet", timestep=repr(float(time)), group="", part="0", file=str(file))
    return _write_xml(root, Path(path))


class VtkSeries:
    """Write frames as ``<prefix>_<step>.vtp`` files in ``directory`` plus ``<prefix>.pvd``.

    The ``.pvd`` is rewritten after every frame, so it can be opened while a run is going.
    ``resume_step``: keep the entries of an existing ``.pvd`` with step ``<= resume_step``
    (a resumed run continues the series); without it an existing series is started afresh.
    A frame with deformable rings also gets ``<prefix>_rings_<step>.vtp``
    (:func:`write_rings_vtp`), listed in ``<prefix>_rings.pvd``, kept the same way.
    """

    def __init__(
        self,
        directory: str | os.PathLike[str],
        prefix: str = "frame",
        *,
        encoding: Encoding = "base64",
        resume_step: int | None = None,
    ) -> None:
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.prefix = prefix
        self.encoding = encoding
        self._frames = _Collection(self.directory, prefix, resume_step)
        self._rings = _Collection(self.directory, f"{prefix}_rings", resume_step)
        self.pvd_path = self._frames.path
        self.rings_pvd_path = self._rings.path

    @property
    def entries(self) -> list[tuple[float, str]]:
        """(time, file) entries of the frames collection."""
        return self._frames.entries

    def append(self, frame: Frame) -> Path:
        """Write ``frame`` (and its rings, if any) and update the collections; returns the
        particles' ``.vtp`` path."""
        path = write_vtp(self.directory / self._frames.file_name(frame.step), frame,
                         encoding=self.encoding)
        self._frames.add(frame.time, path.name)
        if frame_rings(frame)[0].size:
            rings = write_rings_vtp(self.directory / self._rings.file_name(frame.step), frame,
                                    encoding=self.encoding)
            self._rings.add(frame.time, rings.name)
        return path


class _Collection:
    """``<prefix>.pvd`` in ``directory`` listing ``<prefix>_<step>.vtp`` files; see
    :class:`VtkSeries` for ``resume_step``."""

    def __init__(self, directory: Path, prefix: str, resume_step: int | None) -> None:
        self.prefix = prefix
        self.path = directory / f"{prefix}.pvd"
        self.entries: list[tuple[float, str]] = []
        if resume_step is not None and self.path.exists():
            self.entries = [e for e in _read_pvd(self.path) if self._step_of(e[1]) <= resume_step]

    def file_name(self, step: int) -> str:
        """Name of the file of the frame at ``step``."""
        return f"{self.prefix}_{step:09d}.vtp"

    def add(self, time: float, name: str) -> None:
        """List ``name`` at ``time`` and rewrite the collection."""
        self.entries.append((float(time), name))
        write_pvd(self.path, self.entries)

    def _step_of(self, name: str) -> int:
        """Step encoded in a file name written by :meth:`file_name`."""
        match = re.fullmatch(re.escape(self.prefix) + r"_(-?\d+)\.vtp", name)
        if match is None:
            raise ValueError(f"{self.path}: entry {name!r} was not written by VtkSeries('{self.prefix}')")
        return int(match.group(1))


def _read_pvd(path: Path) -> list[tuple[float, str]]:
    """(time, file) entries of a ``.pvd`` collection."""
    return [(float(d.get("timestep", 0.0)), d.get("file", "")) for d in ET.parse(path).iter("DataSet")]


def _polydata(where: str, frame: Frame, encoding: Encoding) -> tuple[ET.Element, ET.Element]:
    """The ``VTKFile`` root and its ``PolyData`` element holding the frame's ``TimeValue``;
    ValueError for an unknown encoding or a non-finite value in ``frame``."""
    if encoding not in ("base64", "ascii"):
        raise ValueError(f"{where}: encoding={encoding!r}; use 'base64' or 'ascii'")
    check_finite_frame(where, frame, contacts=False)
    root = ET.Element(
        "VTKFile", type="PolyData", version="1.0", byte_order="LittleEndian", header_type="UInt64"
    )
    poly = ET.SubElement(root, "PolyData")
    field_data = ET.SubElement(poly, "FieldData")
    _data_array(field_data, "TimeValue", np.array([frame.time], dtype=float), encoding)
    return root, poly


def _point_arrays(frame: Frame) -> dict[str, np.ndarray]:
    """Per-particle arrays written as point data, in VTK-compatible dtypes."""
    return {
        "id": np.asarray(frame.id, dtype="<i8"),
        "type": np.asarray(frame.type, dtype="<i4"),
        "radius": np.asarray(frame.radius, dtype="<f8"),
        "mass": np.asarray(frame.mass, dtype="<f8"),
        "speed": np.linalg.norm(frame.velocity, axis=1) if frame.n else np.zeros(0),
        "velocity": _pad3(frame.velocity),
        "omega": np.asarray(frame.omega, dtype="<f8"),
    }


def _pad3(vectors: np.ndarray) -> np.ndarray:
    """(N, dim) -> (N, 3) float64, zero-padded."""
    out = np.zeros((len(vectors), 3))
    out[:, : np.shape(vectors)[1]] = vectors
    return out


def _data_array(parent: ET.Element, name: str, values: np.ndarray, encoding: Encoding) -> None:
    """Append a ``DataArray`` element holding ``values`` ((N,) or (N, k))."""
    values = np.ascontiguousarray(values, dtype=np.asarray(values).dtype.newbyteorder("<"))
    components = 1 if values.ndim == 1 else values.shape[1]
    element = ET.SubElement(
        parent, "DataArray", type=_VTK_TYPES[values.dtype], Name=name,
        NumberOfComponents=str(components), NumberOfTuples=str(len(values)),
        format="binary" if encoding == "base64" else "ascii",
    )
    if encoding == "base64":
        raw = values.tobytes()
        element.text = base64.b64encode(np.uint64(len(raw)).astype("<u8").tobytes() + raw).decode("ascii")
    else:  # shortest text that reads back to the same value
        element.text = " ".join(map(str, values.ravel().tolist()))


def _write_xml(root: ET.Element, path: Path) -> Path:
    """Write an XML tree to ``path`` through a temporary file and an atomic rename."""
    ET.indent(root)
    tmp = path.with_name(path.name + ".tmp")
    ET.ElementTree(root).write(tmp, encoding="utf-8", xml_declaration=True)
    os.replace(tmp, path)
    return path
