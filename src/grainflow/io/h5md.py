"""Trajectories in HDF5 following the H5MD 1.1 layout, durable against a killed writer.

Layout (see ``docs/output_format.md`` for the full tree and a plain-h5py reading example):
every per-particle quantity is an H5MD time-dependent element ``{step, time, value}`` under
``/particles/all`` whose ``value`` has shape ``(n_frames, N_max, ...)``. The particle number
varies between frames, so frame ``k`` occupies rows ``[:n_k]`` of ``value[k]`` and the rest is
the dataset's fill value (-1 for integers, NaN for floats), as H5MD prescribes for ``id``;
``n_k`` is also stored explicitly in ``/observables/particle_number``. Contacts are stored the
same way ((i, j) in ``/connectivity/contacts``; force, branch vector and the int8 kind code of
the partner, :data:`~grainflow.frame.CONTACT_KINDS`, in ``/observables/contacts``). A file
written before kinds were stored has no ``kind`` dataset and reads back with every contact a
particle pair. All elements share one ``step`` and one ``time`` dataset (hard links).

Durability: the file is written in HDF5 SWMR mode, whose ordered metadata flushes keep the
file consistent at every instant. :meth:`TrajectoryWriter.append` writes a frame's data and
time, flushes, and only then extends ``step`` and flushes again, so a frame exists once
``step`` covers it (``len(step)`` is the frame count; other datasets may be one longer).
A writer killed at any moment leaves all earlier frames readable. HDF5 then still marks the
file "open for writing"; the readers here open it in SWMR read mode, which accepts that, and
``TrajectoryWriter(..., append=True)`` rewrites such a file cleanly before appending (and, the
same way, a file written before contact kinds were stored, into the current layout).
"""

from __future__ import annotations

import getpass
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import h5py
import numpy as np

from grainflow import __version__
from grainflow.frame import CONTACT_KINDS, PAIR, Box, Contacts, Frame

__all__ = ["TrajectoryWriter", "count_frames", "read_frame", "read_frames"]

H5MD_VERSION = (1, 1)
LAYOUT = "grainflow-h5md-1"
# Oldest HDF5 file-format version that supports SWMR; pinning both bounds keeps files
# readable by any HDF5 >= 1.10 even when a newer library writes them.
_LIBVER = ("v110", "v110")
_CHUNK_ROWS = 4096  # particles (or contacts) per chunk along the N axis
_CHUNK_FRAMES = 1024  # frames per chunk for per-frame scalars and vectors

_PARTICLES = "particles/all"
_STEP = f"{_PARTICLES}/position/step"
_TIME = f"{_PARTICLES}/position/time"
_PARTICLE_NUMBER = "observables/particle_number"
_CONTACT_NUMBER = "observables/contact_number"


@dataclass(frozen=True)
class _Field:
    """One per-row time-dependent element: where it lives and how it is typed."""

    attr: str  # attribute of Frame (or Contacts) holding the data
    element: str  # H5MD element path
    dtype: str
    width: str | int | None  # trailing component count: None (scalar), "dim", or an int
    fill: Any

    def trailing(self, dim: int) -> tuple[int, ...]:
        """Shape of one row of this field in a ``dim``-dimensional system."""
        if self.width is None:
            return ()
        return (dim,) if self.width == "dim" else (int(self.width),)


_PARTICLE_FIELDS = (
    _Field("id", f"{_PARTICLES}/id", "i8", None, -1),
    _Field("type", f"{_PARTICLES}/species", "i4", None, -1),
    _Field("body", f"{_PARTICLES}/body", "i8", None, -1),
    _Field("radius", f"{_PARTICLES}/radius", "f8", None, np.nan),
    _Field("mass", f"{_PARTICLES}/mass", "f8", None, np.nan),
    _Field("position", f"{_PARTICLES}/position", "f8", "dim", np.nan),
    _Field("velocity", f"{_PARTICLES}/velocity", "f8", "dim", np.nan),
    _Field("omega", f"{_PARTICLES}/omega", "f8", 3, np.nan),
)
_CONTACT_PAIRS = _Field("pair", "connectivity/contacts", "i8", 2, -1)
_CONTACT_KIND = _Field("kind", "observables/contacts/kind", "i1", None, -1)
_CONTACT_FIELDS = (
    _Field("force", "observables/contacts/force", "f8", "dim", np.nan),
    _Field("branch", "observables/contacts/branch", "f8", "dim", np.nan),
    _CONTACT_KIND,
)
_BOX_ELEMENTS = (f"{_PARTICLES}/box/edges", f"{_PARTICLES}/box/offset")
_COMPRESSIONS = ("gzip", "lzf", None)


class TrajectoryWriter:
    """Append :class:`~grainflow.frame.Frame` objects to an H5MD trajectory file.

    Parameters
    ----------
    path:
        File to write; created (or overwritten) unless ``append`` is true.
    dim:
        2 or 3; must equal ``box.dim``.
    box:
        Box of the run. Its periodic flags become the H5MD ``boundary`` attribute; every
        appended frame must have the same flags. Each frame's own bounds are stored.
    contacts:
        Store each frame's :class:`~grainflow.frame.Contacts` (frames must then carry them).
    compression:
        ``"gzip"`` (default; level 4 with shuffle, readable by every HDF5 build), ``None``
        (several times faster to write; DEM float data shrink only ~25 % with gzip) or
        ``"lzf"`` (fast, but only h5py can read it). Ignored when appending to a file.
    append:
        Continue an existing file instead of overwriting it (a missing file is created).
    resume_step:
        With ``append``: first drop stored frames whose step is greater than this, so a run
        resumed from a checkpoint at ``resume_step`` does not duplicate frames.

    Use as a context manager, or call :meth:`close`. Frames must have strictly increasing
    steps. ``Frame.extra`` is not stored.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        dim: int,
        box: Box,
        *,
        contacts: bool,
        compression: str | None = "gzip",
        append: bool = False,
        resume_step: int | None = None,
    ) -> None:
        if dim not in (2, 3) or box.dim != dim:
            raise ValueError(f"TrajectoryWriter: dim={dim} must be 2 or 3 and equal box.dim ({box.dim})")
        if compression not in _COMPRESSIONS:
            raise ValueError(f"TrajectoryWriter: compression={compression!r}; use one of {_COMPRESSIONS}")
        if resume_step is not None and not append:
            raise ValueError("TrajectoryWriter: resume_step is only meaningful with append=True")
        self.path = Path(path)
        self.dim = dim
        self.periodic = tuple(bool(p) for p in box.periodic)
        self.contacts = contacts
        if append and self.path.exists():
            self._check_existing_layout()
            self._file = _open_for_append(self.path, resume_step)
        else:
            self._file = h5py.File(self.path, "w", libver=_LIBVER)
            _create_layout(self._file, dim, self.periodic, contacts, compression)
            self._file.swmr_mode = True
            self._file.flush()
        step = self._file[_STEP]
        self._n_frames = int(step.shape[0])
        self._last_step = int(step[-1]) if self._n_frames else None

    @property
    def n_frames(self) -> int:
        """Number of frames in the file."""
        return self._n_frames

    def append(self, frame: Frame) -> None:
        """Write one frame; once this returns, the frame survives a kill of the process."""
        if self._file is None:
            raise ValueError(f"TrajectoryWriter({self.path}): append() after close()")
        self._check_frame(frame)
        f, k = self._file, self._n_frames
        for fld in _PARTICLE_FIELDS:
            _write_rows(f[fld.element + "/value"], k, getattr(frame, fld.attr))
        _write_scalar(f[_PARTICLE_NUMBER + "/value"], k, frame.n)
        lo = np.asarray(frame.box.lo, dtype=float)
        _write_scalar(f[_BOX_ELEMENTS[0] + "/value"], k, np.asarray(frame.box.hi, dtype=float) - lo)
        _write_scalar(f[_BOX_ELEMENTS[1] + "/value"], k, lo)
        if self.contacts:
            c = frame.contacts
            _write_rows(f[_CONTACT_PAIRS.element + "/value"], k, np.stack([c.i, c.j], axis=-1))
            for fld in _CONTACT_FIELDS:
                _write_rows(f[fld.element + "/value"], k, getattr(c, fld.attr))
            _write_scalar(f[_CONTACT_NUMBER + "/value"], k, len(c.i))
        _write_scalar(f[_TIME], k, frame.time)
        f.flush()  # everything is on disk before extending step makes the frame visible
        _write_scalar(f[_STEP], k, frame.step)
        f.flush()
        self._n_frames += 1
        self._last_step = frame.step

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> TrajectoryWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _check_existing_layout(self) -> None:
        """Refuse to append to a file whose dimension, boundaries or contacts differ."""
        with _open_for_read(self.path) as f:
            dim, periodic, has_contacts = _layout_of(f)
        if (dim, periodic, has_contacts) != (self.dim, self.periodic, self.contacts):
            raise ValueError(
                f"TrajectoryWriter({self.path}, append=True): file has dim={dim}, "
                f"periodic={periodic}, contacts={has_contacts}, but the writer was given "
                f"dim={self.dim}, periodic={self.periodic}, contacts={self.contacts}; "
                "pass matching arguments or write to a new file"
            )

    def _check_frame(self, frame: Frame) -> None:
        """Validate a frame against the file before anything is written."""
        where = f"TrajectoryWriter({self.path}).append"
        if frame.dim != self.dim or tuple(bool(p) for p in frame.box.periodic) != self.periodic:
            raise ValueError(
                f"{where}: frame.box has dim={frame.dim}, periodic={frame.box.periodic}; "
                f"the file stores dim={self.dim}, periodic={self.periodic}"
            )
        if self._last_step is not None and frame.step <= self._last_step:
            raise ValueError(
                f"{where}: frame.step={frame.step} is not after the last stored step "
                f"{self._last_step}; when resuming, open with append=True, resume_step=<checkpoint step>"
            )
        for fld in _PARTICLE_FIELDS:
            expected = (frame.n, *fld.trailing(self.dim))
            _check_shape(where, f"frame.{fld.attr}", getattr(frame, fld.attr), expected)
        if not self.contacts:
            return
        c = frame.contacts
        if c is None:
            raise ValueError(f"{where}: frame.contacts is None but the writer was opened with contacts=True")
        m = len(c.i)
        _check_shape(where, "frame.contacts.i", c.i, (m,))
        _check_shape(where, "frame.contacts.j", c.j, (m,))
        for fld in _CONTACT_FIELDS:
            expected = (m, *fld.trailing(self.dim))
            _check_shape(where, f"frame.contacts.{fld.attr}", getattr(c, fld.attr), expected)
        kind = np.asarray(c.kind)
        if m and not (kind.dtype.kind in "iu" and 0 <= kind.min() and kind.max() < len(CONTACT_KINDS)):
            raise ValueError(
                f"{where}: frame.contacts.kind must hold integer codes 0..{len(CONTACT_KINDS) - 1} "
                f"({', '.join(CONTACT_KINDS)}); got {np.unique(kind)[:8]}"
            )


def count_frames(path: str | os.PathLike[str]) -> int:
    """Number of complete frames in a trajectory file (also while a writer is running)."""
    with _open_for_read(path) as f:
        return _complete_frames(f)


def read_frames(path: str | os.PathLike[str]) -> Iterator[Frame]:
    """Yield every complete frame of a trajectory file in order."""
    with _open_for_read(path) as f:
        for k in range(_complete_frames(f)):
            yield _read(f, k)


def read_frame(path: str | os.PathLike[str], index: int) -> Frame:
    """Read frame ``index`` (negative counts from the end) of a trajectory file."""
    with _open_for_read(path) as f:
        n = _complete_frames(f)
        if not -n <= index < n:
            raise IndexError(f"read_frame({path}): index {index} out of range for {n} frames")
        return _read(f, index % n)


# --- file creation ----------------------------------------------------------------------


def _create_layout(
    f: h5py.File, dim: int, periodic: tuple[bool, ...], contacts: bool, compression: str | None
) -> None:
    """Create every group and dataset of an empty trajectory (SWMR forbids creating later)."""
    h5md = f.create_group("h5md")
    h5md.attrs["version"] = np.array(H5MD_VERSION, dtype=np.int32)
    h5md.create_group("author").attrs["name"] = np.bytes_(_author())
    creator = h5md.create_group("creator")
    creator.attrs["name"] = np.bytes_("grainflow")
    creator.attrs["version"] = np.bytes_(__version__)
    f.create_group("parameters/grainflow").attrs["layout"] = np.bytes_(LAYOUT)

    box = f.create_group(f"{_PARTICLES}/box")
    box.attrs["dimension"] = np.int32(dim)
    box.attrs["boundary"] = np.array([b"periodic" if p else b"none" for p in periodic], dtype="S8")

    step = f.create_dataset(_STEP, shape=(0,), maxshape=(None,), chunks=(_CHUNK_FRAMES,), dtype="i8")
    time = f.create_dataset(_TIME, shape=(0,), maxshape=(None,), chunks=(_CHUNK_FRAMES,), dtype="f8")
    opts = _compression_options(compression)

    def element(name: str) -> h5py.Group:
        group = f.require_group(name)
        if "step" not in group:
            group["step"], group["time"] = step, time  # hard links: one time axis for all
        return group

    def per_row(fld: _Field) -> None:
        trailing = fld.trailing(dim)
        element(fld.element).create_dataset(
            "value", shape=(0, 0, *trailing), maxshape=(None, None, *trailing),
            chunks=(1, _CHUNK_ROWS, *trailing), dtype=fld.dtype, fillvalue=fld.fill, **opts,
        )

    def per_frame(name: str, dtype: str, trailing: tuple[int, ...] = ()) -> None:
        element(name).create_dataset(
            "value", shape=(0, *trailing), maxshape=(None, *trailing),
            chunks=(_CHUNK_FRAMES, *trailing), dtype=dtype,
        )

    for fld in _PARTICLE_FIELDS:
        per_row(fld)
    per_frame(_PARTICLE_NUMBER, "i8")
    for name in _BOX_ELEMENTS:
        per_frame(name, "f8", (dim,))
    if contacts:
        per_row(_CONTACT_PAIRS)
        f[_CONTACT_PAIRS.element].attrs["particles_group"] = f[_PARTICLES].ref
        for fld in _CONTACT_FIELDS:
            per_row(fld)
        f[_CONTACT_KIND.element].attrs["names"] = np.array([n.encode() for n in CONTACT_KINDS], dtype="S8")
        per_frame(_CONTACT_NUMBER, "i8")


def _compression_options(compression: str | None) -> dict[str, Any]:
    """h5py dataset keywords for a compression choice."""
    if compression is None:
        return {}
    opts: dict[str, Any] = {"compression": compression, "shuffle": True}
    if compression == "gzip":
        opts["compression_opts"] = 4
    return opts


def _author() -> str:
    """Name for the mandatory H5MD author attribute."""
    try:
        return getpass.getuser()
    except (KeyError, OSError):
        return "unknown"


# --- writing helpers --------------------------------------------------------------------


def _check_shape(where: str, name: str, array: np.ndarray, expected: tuple[int, ...]) -> None:
    """Raise a ValueError naming ``name`` if ``array`` does not have shape ``expected``."""
    shape = np.shape(array)
    if shape != expected:
        raise ValueError(f"{where}: {name} has shape {shape}, expected {expected}")


def _write_rows(ds: h5py.Dataset, k: int, rows: np.ndarray) -> None:
    """Store ``rows`` as frame ``k`` of a (frames, N_max, ...) dataset, growing N_max if needed."""
    n = len(rows)
    ds.resize((k + 1, max(ds.shape[1], n), *ds.shape[2:]))
    if n:
        ds[k, :n] = rows


def _write_scalar(ds: h5py.Dataset, k: int, value: Any) -> None:
    """Store ``value`` as entry ``k`` of a (frames, ...) dataset."""
    ds.resize((k + 1, *ds.shape[1:]))
    ds[k] = value


# --- reading ----------------------------------------------------------------------------


def _open_for_read(path: str | os.PathLike[str]) -> h5py.File:
    """Open read-only in SWMR mode: works on closed files, live ones and ones whose writer died."""
    if not Path(path).exists():
        raise FileNotFoundError(f"trajectory file {path} does not exist")
    f = h5py.File(path, "r", swmr=True)
    if "parameters/grainflow" not in f or f["parameters/grainflow"].attrs.get("layout") != LAYOUT.encode():
        f.close()
        raise ValueError(f"{path} is not a grainflow H5MD trajectory (layout {LAYOUT})")
    return f


def _time_dependent(f: h5py.File) -> list[h5py.Dataset]:
    """Every dataset with a frame axis: the shared step and time, then the value datasets."""
    names = [fld.element for fld in _PARTICLE_FIELDS] + [_PARTICLE_NUMBER, *_BOX_ELEMENTS]
    if _CONTACT_NUMBER in f:
        names += [_CONTACT_PAIRS.element, _CONTACT_NUMBER] + [fld.element for fld in _CONTACT_FIELDS]
    return [f[_STEP], f[_TIME]] + [f[name + "/value"] for name in names]


def _complete_frames(f: h5py.File) -> int:
    """Frames in the file: ``step`` is extended last on append and trimmed first on resume."""
    return int(f[_STEP].shape[0])


def _layout_of(f: h5py.File) -> tuple[int, tuple[bool, ...], bool]:
    """(dim, periodic flags, has contacts) of an open trajectory file."""
    box = f[f"{_PARTICLES}/box"]
    periodic = tuple(b == b"periodic" for b in box.attrs["boundary"])
    return int(box.attrs["dimension"]), periodic, _CONTACT_NUMBER in f


def _read(f: h5py.File, k: int) -> Frame:
    """Read frame ``k`` of an open file into a new :class:`Frame` (arrays are fresh copies)."""
    _, periodic, has_contacts = _layout_of(f)
    n = int(f[_PARTICLE_NUMBER + "/value"][k])
    rows = {fld.attr: f[fld.element + "/value"][k, :n] for fld in _PARTICLE_FIELDS}
    edges = f[_BOX_ELEMENTS[0] + "/value"][k]
    lo = f[_BOX_ELEMENTS[1] + "/value"][k]
    contacts = None
    if has_contacts:
        m = int(f[_CONTACT_NUMBER + "/value"][k])
        pair = f[_CONTACT_PAIRS.element + "/value"][k, :m]
        data = {fld.attr: f[fld.element + "/value"][k, :m] for fld in _CONTACT_FIELDS if fld.element in f}
        # a file written before contact kinds were stored has no kind: every contact is a pair
        data.setdefault("kind", np.full(m, PAIR, dtype=np.int8))
        contacts = Contacts(i=pair[:, 0].copy(), j=pair[:, 1].copy(), **data)
    return Frame(
        step=int(f[_STEP][k]),
        time=float(f[_TIME][k]),
        box=Box(lo=lo, hi=lo + edges, periodic=periodic),
        contacts=contacts,
        **rows,
    )


# --- resuming ---------------------------------------------------------------------------


def _open_for_append(path: Path, resume_step: int | None) -> h5py.File:
    """Open an existing trajectory in SWMR mode, dropping frames after ``resume_step``.

    A file whose writer was killed is still marked open-for-writing by HDF5, which refuses
    to open it for writing again; such a file is first rewritten (kept frames only) into a
    clean file that atomically replaces it. So is a file written before contact kinds were
    stored (its contacts become pairs), since SWMR cannot add the missing dataset in place
    and adding it outside SWMR would not survive a kill.
    """
    with _open_for_read(path) as f:
        outdated = _CONTACT_NUMBER in f and _CONTACT_KIND.element not in f
    if outdated:
        _rewrite(path, resume_step)
    try:
        f = h5py.File(path, "r+", libver=_LIBVER)
    except OSError as err:
        if "already open for write" not in str(err):
            raise
        _rewrite(path, resume_step)
        f = h5py.File(path, "r+", libver=_LIBVER)
    f.swmr_mode = True
    keep = _frames_to_keep(f, resume_step)
    datasets = _time_dependent(f)
    for group in (datasets[:1], datasets[1:]):  # hide dropped frames (step) first, then trim
        for ds in group:
            ds.resize((keep, *ds.shape[1:]))
        f.flush()
    return f


def _frames_to_keep(f: h5py.File, resume_step: int | None) -> int:
    """Number of leading complete frames with step <= ``resume_step`` (all if None)."""
    n = _complete_frames(f)
    if resume_step is None:
        return n
    return int(np.searchsorted(f[_STEP][:n], resume_step, side="right"))


def _rewrite(path: Path, resume_step: int | None) -> None:
    """Copy the frames to keep into a clean file and atomically replace ``path`` with it."""
    tmp = path.with_name(path.name + ".recover")
    with _open_for_read(path) as src:
        dim, periodic, has_contacts = _layout_of(src)
        keep = _frames_to_keep(src, resume_step)
        compression = src[_PARTICLE_FIELDS[0].element + "/value"].compression
        box = Box(lo=np.zeros(dim), hi=np.zeros(dim), periodic=periodic)
        with TrajectoryWriter(tmp, dim, box, contacts=has_contacts, compression=compression) as dst:
            for k in range(keep):
                dst.append(_read(src, k))
    os.replace(tmp, path)
