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
particle pair. The deformable rings' topology, ``Frame.ring_vertex`` (:mod:`grainflow.rings`),
is the int32 element ``/particles/all/ring_vertex`` (fill -1); a frame without it leaves its
rows at the fill value (nothing is written), and a frame in which no particle is in a ring
reads back with ``ring_vertex`` None, as does every frame of a file written before rings were
stored. All elements share one ``step`` and one ``time`` dataset (hard links).

Durability: the file is written in HDF5 SWMR mode, whose ordered metadata flushes keep the
file consistent at every instant. :meth:`TrajectoryWriter.append` writes a frame's data and
time, flushes, and only then extends ``step`` and flushes again, so a frame exists once
``step`` covers it (``len(step)`` is the frame count; other datasets may be one longer).
A writer killed at any moment leaves all earlier frames readable. HDF5 then still marks the
file "open for writing"; the readers here open it in SWMR read mode, which accepts that, and
``TrajectoryWriter(..., append=True)`` rewrites such a file cleanly before appending (and, the
same way, a file written before contact kinds were stored, into the current layout).

Damage: a file that HDF5 cannot read any more (truncated by a crash or a full disk, bytes
overwritten, empty, not HDF5 at all) makes every reader and the append path raise
:class:`DamagedFileError` naming the file and the way out, :func:`repair_frames`, which
salvages the whole frames that can still be read into a new file and keeps the original as
``<name>.damaged``. Frames with a non-finite value are refused by
:meth:`TrajectoryWriter.append` (:class:`NonFiniteFrameError`) before anything is written.
"""

from __future__ import annotations

import getpass
import io
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import h5py
import numpy as np

from grainflow import __version__
from grainflow.engine.simulation import InstabilityError
from grainflow.frame import CONTACT_KINDS, PAIR, Box, Contacts, Frame
from grainflow.io.aside import damaged_name, move_aside
from grainflow.user_warnings import warn_user

__all__ = ["DEFAULT_MAX_ROWS", "DamagedFileError", "NonFiniteFrameError", "TrajectoryWriter",
           "check_finite_frame", "count_frames", "max_rows_for", "read_frame", "read_frames",
           "repair_frames"]


class DamagedFileError(ValueError, OSError):
    """A trajectory file is damaged (truncated, overwritten, empty or not HDF5 at all).

    The message names the file and the way out (:func:`repair_frames`). ``path`` is the file.
    Also an :class:`OSError`, so code that caught HDF5's own errors still catches it.
    """

    def __init__(self, path: str | os.PathLike[str], what: str) -> None:
        name = Path(path).name
        super().__init__(
            f"trajectory file {path} is damaged: {what}. Salvage the whole frames it still "
            f"holds with grainflow.io.h5md.repair_frames({str(path)!r}) (a resumed run does "
            f"this itself), which keeps the damaged original as {name}.damaged"
        )
        self.path = Path(path)
        self.what = what


class NonFiniteFrameError(InstabilityError, ValueError):
    """A frame handed to a writer holds a NaN or infinite value; nothing of it was written.

    An :class:`~grainflow.engine.simulation.InstabilityError` (``step``, ``particle`` id,
    ``reason`` naming the array) and a :class:`ValueError`.
    """

H5MD_VERSION = (1, 1)
LAYOUT = "grainflow-h5md-1"
#: The trajectory's file name in a run directory (:mod:`grainflow.runner`).
RUN_TRAJECTORY = "frames.h5"
# Oldest HDF5 file-format version that supports SWMR; pinning both bounds keeps files
# readable by any HDF5 >= 1.10 even when a newer library writes them.
_LIBVER = ("v110", "v110")
_CHUNK_ROWS = 4096  # particles (or contacts) per chunk along the N axis
_CHUNK_FRAMES = 1024  # frames per chunk for per-frame scalars and vectors
#: Default bound of the row (particle or contact) axis of per-row datasets. A bounded row
#: axis leaves the frame axis the only unlimited one, so HDF5 indexes chunks in an
#: extensible array whose blocks never move once written: a file cut short (full disk, a
#: copy interrupted) keeps the index of its earlier frames, and :func:`repair_frames`
#: salvages them. (With two unlimited axes the index is a B-tree rewritten at the end of
#: the file, and any cut loses every frame.) The index costs about 16 bytes per
#: ``_CHUNK_ROWS`` rows of the bound, per frame and dataset.
DEFAULT_MAX_ROWS = 1 << 20


def max_rows_for(n_particles: int) -> int:
    """A row bound for a run starting with ``n_particles``: 16 times that (room for
    contacts, about 3 per grain in 3D, and for growth), at least :data:`DEFAULT_MAX_ROWS`,
    rounded up to whole chunks."""
    rows = max(DEFAULT_MAX_ROWS, 16 * int(n_particles))
    return -(-rows // _CHUNK_ROWS) * _CHUNK_ROWS

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
#: Optional per-particle element: absent from files written before rings were stored.
_RING_VERTEX = _Field("ring_vertex", f"{_PARTICLES}/ring_vertex", "i4", None, -1)
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
        A damaged existing file raises :class:`DamagedFileError` (then call
        :func:`repair_frames` and open again).
    resume_step:
        With ``append``: first drop stored frames whose step is greater than this, so a run
        resumed from a checkpoint at ``resume_step`` does not duplicate frames.
    max_rows:
        Most particles (and contacts) one frame may hold, fixed for the file (see
        :data:`DEFAULT_MAX_ROWS`: the bound is what lets a truncated file be salvaged);
        :func:`max_rows_for` gives a generous one from the initial particle count. A larger
        frame is refused with a ValueError. Ignored when appending to a file.

    Use as a context manager, or call :meth:`close`. Frames must have strictly increasing
    steps and finite values (else :class:`NonFiniteFrameError`, and nothing of the frame is
    written). ``Frame.extra`` is not stored. ``Frame.ring_vertex`` is, in any frame of a new
    file; a file written before rings were stored is continued as it is, and a frame with
    rings is refused there (ValueError: write a new file).
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
        max_rows: int = DEFAULT_MAX_ROWS,
    ) -> None:
        if dim not in (2, 3) or box.dim != dim:
            raise ValueError(f"TrajectoryWriter: dim={dim} must be 2 or 3 and equal box.dim ({box.dim})")
        if compression not in _COMPRESSIONS:
            raise ValueError(f"TrajectoryWriter: compression={compression!r}; use one of {_COMPRESSIONS}")
        if resume_step is not None and not append:
            raise ValueError("TrajectoryWriter: resume_step is only meaningful with append=True")
        if max_rows < 1:
            raise ValueError(f"TrajectoryWriter: max_rows={max_rows} must be >= 1")
        self.path = Path(path)
        self.dim = dim
        self.periodic = tuple(bool(p) for p in box.periodic)
        self.contacts = contacts
        if append and self.path.exists():
            self._check_existing_layout()
            with _guard(self.path, "while opening it to append"):
                self._file = _open_for_append(self.path, resume_step)
        else:
            self._file = h5py.File(self.path, "w", libver=_LIBVER)
            _create_layout(self._file, dim, self.periodic, contacts, compression, max_rows)
            self._file.swmr_mode = True
            self._file.flush()
        #: Most rows (particles, contacts) one frame may hold; fixed when the file is made.
        self.max_rows = self._file[_PARTICLE_FIELDS[0].element + "/value"].maxshape[1]
        #: Whether the file stores ``ring_vertex`` (every file but those from before rings).
        self.rings = _RING_VERTEX.element in self._file
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
        check_finite_frame(f"TrajectoryWriter({self.path}).append", frame, contacts=self.contacts)
        f, k = self._file, self._n_frames
        for fld in _PARTICLE_FIELDS:
            _write_rows(f[fld.element + "/value"], k, getattr(frame, fld.attr))
        if self.rings:
            _write_ring_vertex(f[_RING_VERTEX.element + "/value"], k, frame)
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
        with _open_for_read(self.path) as f, _guard(self.path, "while reading its layout"):
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
        self._check_ring_vertex(where, frame)
        self._check_rows(where, "particles", frame.n)
        if not self.contacts:
            return
        c = frame.contacts
        if c is None:
            raise ValueError(f"{where}: frame.contacts is None but the writer was opened with contacts=True")
        m = len(c.i)
        self._check_rows(where, "contacts", m)
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


    def _check_ring_vertex(self, where: str, frame: Frame) -> None:
        """Validate ``frame.ring_vertex`` (integers >= -1, one per particle), and refuse rings
        in a file written before rings were stored."""
        ring_vertex = frame.ring_vertex
        if ring_vertex is None:
            return
        _check_shape(where, "frame.ring_vertex", ring_vertex, (frame.n,))
        ring_vertex = np.asarray(ring_vertex)
        if ring_vertex.dtype.kind not in "iu" or (frame.n and ring_vertex.min() < -1):
            raise ValueError(f"{where}: frame.ring_vertex must hold integers >= -1 (-1 = in "
                             f"no ring); got dtype {ring_vertex.dtype}, minimum "
                             f"{ring_vertex.min() if frame.n else None}")
        if not self.rings and (ring_vertex >= 0).any():
            raise ValueError(f"{where}: the frame has deformable rings, but {self.path.name} "
                             "was written before ring_vertex was stored and cannot take it; "
                             "write the frames into a new file")

    def _check_rows(self, where: str, what: str, rows: int) -> None:
        if self.max_rows is not None and rows > self.max_rows:  # None: a file from before
            raise ValueError(
                f"{where}: the frame has {rows} {what}, more than the {self.max_rows} rows "
                f"per frame {self.path.name} was created for (max_rows); write into a new "
                "file with a larger max_rows")


def count_frames(path: str | os.PathLike[str]) -> int:
    """Number of complete frames in a trajectory file (also while a writer is running).

    Raises :class:`DamagedFileError` for a file HDF5 cannot read (as do the other readers).
    """
    with _open_for_read(path) as f, _guard(path, "while counting its frames"):
        return _complete_frames(f)


def read_frames(path: str | os.PathLike[str]) -> Iterator[Frame]:
    """Yield every complete frame of a trajectory file in order."""
    with _open_for_read(path) as f:
        with _guard(path, "while counting its frames"):
            n = _complete_frames(f)
        for k in range(n):
            with _guard(path, f"while reading frame {k}"):
                frame = _read(f, k)
            yield frame


def read_frame(path: str | os.PathLike[str], index: int) -> Frame:
    """Read frame ``index`` (negative counts from the end) of a trajectory file."""
    with _open_for_read(path) as f:
        with _guard(path, "while counting its frames"):
            n = _complete_frames(f)
        if not -n <= index < n:
            raise IndexError(f"read_frame({path}): index {index} out of range for {n} frames")
        with _guard(path, f"while reading frame {index % n}"):
            return _read(f, index % n)


def repair_frames(path: str | os.PathLike[str], resume_step: int | None = None) -> int:
    """Salvage the whole frames of a damaged trajectory; return how many were kept.

    Reads ``path`` through a corrected view of its HDF5 superblock (stored end-of-file set to
    the real size, "open for writing" mark cleared), so the library reads what is left
    instead of refusing the file, and keeps frames in order (those with step
    ``<= resume_step`` if given) up to the first one that does not read whole: every
    dataset of the frame must read, its step must be after the previous one, its time and
    every float finite, its ids and counts valid. The kept frames are written to a new file
    that replaces ``path`` atomically (temporary file + ``os.replace``). The original is
    never deleted: it is kept as ``<name>.damaged`` (``<name>.damaged.1``, ``.2``, ... if
    that exists). If no frame can be salvaged (or the file is not HDF5 at all), the
    original is moved to ``<name>.damaged``, no file is left at ``path`` (a writer opened
    with ``append=True`` then starts a new one) and 0 is returned. Warns
    (:class:`RuntimeWarning`) with the count and where the original went.

    Meant for a file that raised :class:`DamagedFileError`; on a whole file it rewrites the
    same frames (and still keeps the original as ``.damaged``). Whatever HDF5 cannot see
    is lost: a truncated file keeps about the frames before the cut (the bounded row axis,
    :data:`DEFAULT_MAX_ROWS`), while one written before that bound keeps its chunk index
    near the end of the file and then loses every frame.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"repair_frames: trajectory file {path} does not exist")
    tmp = path.with_name(path.name + ".repair")
    kept = 0
    try:
        kept = _salvage(path, tmp, resume_step)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if kept:
        damaged = damaged_name(path)
        try:
            os.link(path, damaged)  # keep the original under its new name, then swap atomically
        except OSError:
            os.replace(path, damaged)
        os.replace(tmp, path)
        what = f"kept its first {kept} whole frame(s) in a new {path.name}"
    else:
        tmp.unlink(missing_ok=True)
        damaged = move_aside(path)
        what = f"no whole frame could be salvaged; {path.name} will be started anew"
    warn_user(f"repair_frames({path}): {what}; the damaged original is kept as {damaged}",
              RuntimeWarning)
    return kept


def check_finite_frame(where: str, frame: Frame, *, contacts: bool) -> None:
    """Raise :class:`NonFiniteFrameError` if any float of ``frame`` (or its contacts) is not finite.

    Names the array and the particle id (for contacts, the particle ``i`` of the first bad
    row). Cheap when all is well: one ``np.isfinite(...).all()`` per array.
    """
    scalars = {"time": frame.time, "box.lo": frame.box.lo, "box.hi": frame.box.hi}
    for name, value in scalars.items():
        if not np.isfinite(np.asarray(value, dtype=float)).all():
            raise NonFiniteFrameError(frame.step, -1, f"{where}: frame.{name} = {value} is not finite")
    arrays = [(f"frame.{name}", getattr(frame, name), frame.id)
              for name in ("position", "velocity", "omega", "radius", "mass")]
    if contacts and frame.contacts is not None:
        c = frame.contacts
        arrays += [("frame.contacts.force", c.force, c.i), ("frame.contacts.branch", c.branch, c.i)]
    for name, values, ids in arrays:
        values = np.asarray(values)
        if values.dtype.kind == "f" and not np.isfinite(values).all():
            bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
            row = int(np.argmax(bad))
            particle = int(ids[row]) if row < len(ids) else -1
            raise NonFiniteFrameError(
                frame.step, particle,
                f"{where}: {name} is not finite ({values[row]}) in row {row}, particle id "
                f"{particle}; refusing to write the frame",
            )


# --- file creation ----------------------------------------------------------------------


def _create_layout(
    f: h5py.File, dim: int, periodic: tuple[bool, ...], contacts: bool, compression: str | None,
    max_rows: int,
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
            "value", shape=(0, 0, *trailing), maxshape=(None, max_rows, *trailing),
            chunks=(1, min(_CHUNK_ROWS, max_rows), *trailing), dtype=fld.dtype, fillvalue=fld.fill, **opts,
        )

    def per_frame(name: str, dtype: str, trailing: tuple[int, ...] = ()) -> None:
        element(name).create_dataset(
            "value", shape=(0, *trailing), maxshape=(None, *trailing),
            chunks=(_CHUNK_FRAMES, *trailing), dtype=dtype,
        )

    for fld in (*_PARTICLE_FIELDS, _RING_VERTEX):
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


def _grow_rows(ds: h5py.Dataset, k: int, n: int) -> None:
    """Make room for frame ``k`` of ``n`` rows in a (frames, N_max, ...) dataset (at the fill
    value until written), growing N_max if needed."""
    ds.resize((k + 1, max(ds.shape[1], n), *ds.shape[2:]))


def _write_rows(ds: h5py.Dataset, k: int, rows: np.ndarray) -> None:
    """Store ``rows`` as frame ``k`` of a (frames, N_max, ...) dataset, growing N_max if needed."""
    n = len(rows)
    _grow_rows(ds, k, n)
    if n:
        ds[k, :n] = rows


def _write_ring_vertex(ds: h5py.Dataset, k: int, frame: Frame) -> None:
    """Store ``frame.ring_vertex`` as frame ``k``; a frame without it keeps the fill value
    -1 (no chunk is written, so a run without rings stores nothing)."""
    if frame.ring_vertex is None:
        _grow_rows(ds, k, frame.n)
    else:
        _write_rows(ds, k, frame.ring_vertex)


def _write_scalar(ds: h5py.Dataset, k: int, value: Any) -> None:
    """Store ``value`` as entry ``k`` of a (frames, ...) dataset."""
    ds.resize((k + 1, *ds.shape[1:]))
    ds[k] = value


# --- reading ----------------------------------------------------------------------------


def _open_for_read(path: str | os.PathLike[str]) -> h5py.File:
    """Open read-only: works on closed files, live ones and ones whose writer died.

    The superblock is checked first (:func:`_check_superblock`), so a truncated or garbage
    file raises :class:`DamagedFileError` at once. A closed file is opened normally, where
    a corrupt metadata block fails at once; only a file marked "open for writing" (a live
    writer, or a killed one) is opened in SWMR mode, whose reader retries such reads.
    """
    if not Path(path).exists():
        raise FileNotFoundError(f"trajectory file {path} does not exist")
    _check_superblock(Path(path))
    with _guard(path, "HDF5 cannot open it"):
        try:
            f = h5py.File(path, "r")
        except OSError as err:
            if "already open for write" not in str(err):
                raise
            f = h5py.File(path, "r", swmr=True)
    try:
        with _guard(path, "HDF5 cannot read its root group"):
            ours = "parameters/grainflow" in f and f["parameters/grainflow"].attrs.get("layout") == LAYOUT.encode()
    except BaseException:
        f.close()
        raise
    if not ours:
        f.close()
        raise ValueError(f"{path} is not a grainflow H5MD trajectory (layout {LAYOUT})")
    return f


@contextmanager
def _guard(path: str | os.PathLike[str], doing: str) -> Iterator[None]:
    """Turn HDF5's errors (OSError, KeyError, RuntimeError from h5py) into :class:`DamagedFileError`."""
    try:
        yield
    except (DamagedFileError, FileNotFoundError, PermissionError, IsADirectoryError):
        raise
    except (OSError, KeyError, RuntimeError) as err:
        raise DamagedFileError(path, f"HDF5 cannot read it ({doing})") from err


# --- damage: superblock checks and salvage -----------------------------------------------

_SIGNATURE = b"\x89HDF\r\n\x1a\n"


@dataclass(frozen=True)
class _Superblock:
    """The fields of a version 2/3 superblock at offset 0 that a salvage needs."""

    raw: bytes  # the superblock up to (not including) its checksum
    offset_size: int
    flags: int
    stored_eof: int

    @property
    def eof_at(self) -> int:
        return 12 + 2 * self.offset_size


def _read_superblock(path: Path) -> _Superblock | None:
    """Parse the superblock; None for versions 0/1 (not written by grainflow, not checked).

    Raises :class:`DamagedFileError` for an empty file, a file without the HDF5 signature at
    offset 0, or a version 2/3 superblock whose checksum does not match.
    """
    with path.open("rb") as fh:
        head = fh.read(64)
    if not head:
        raise DamagedFileError(path, "it is empty (0 bytes)")
    if not head.startswith(_SIGNATURE):
        raise DamagedFileError(path, "it does not start with the HDF5 signature (overwritten, or not HDF5)")
    version = head[8] if len(head) > 8 else -1
    if version in (0, 1):
        return None
    if version not in (2, 3) or len(head) < 12:
        raise DamagedFileError(path, f"its HDF5 superblock is unreadable (version byte {version})")
    offset_size = head[9]
    end = 12 + 4 * offset_size
    if offset_size not in (2, 4, 8) or len(head) < end + 4:
        raise DamagedFileError(path, "its HDF5 superblock is cut short or corrupt")
    raw = head[:end]
    if int.from_bytes(head[end:end + 4], "little") != _lookup3(raw):
        raise DamagedFileError(path, "its HDF5 superblock is corrupt (checksum mismatch)")
    eof_at = 12 + 2 * offset_size
    return _Superblock(raw=raw, offset_size=offset_size, flags=head[11],
                       stored_eof=int.from_bytes(head[eof_at:eof_at + offset_size], "little"))


def _check_superblock(path: Path) -> None:
    """Raise :class:`DamagedFileError` if the file is garbage or shorter than HDF5 recorded.

    A live SWMR writer may, for an instant, have recorded a larger end of file than it has
    written yet, so a file marked open for writing is looked at a few times before it is
    called truncated.
    """
    for attempt in range(6):
        sb = _read_superblock(path)
        size = path.stat().st_size
        if sb is None or size >= sb.stored_eof:
            return
        if not sb.flags or attempt == 5:
            raise DamagedFileError(path, f"it is truncated ({size} bytes of the {sb.stored_eof} "
                                         "HDF5 recorded; a crash or a full disk?)")
        time.sleep(0.05)


def _lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle``: the checksum of HDF5 metadata (H5_checksum_lookup3)."""
    mask = 0xFFFFFFFF

    def rot(x: int, k: int) -> int:
        return ((x << k) | (x >> (32 - k))) & mask

    length = len(data)
    a = b = c = (0xDEADBEEF + length + initval) & mask
    i = 0
    while length > 12:
        a = (a + int.from_bytes(data[i:i + 4], "little")) & mask
        b = (b + int.from_bytes(data[i + 4:i + 8], "little")) & mask
        c = (c + int.from_bytes(data[i + 8:i + 12], "little")) & mask
        a = (a - c) & mask; a ^= rot(c, 4); c = (c + b) & mask  # noqa: E702
        b = (b - a) & mask; b ^= rot(a, 6); a = (a + c) & mask  # noqa: E702
        c = (c - b) & mask; c ^= rot(b, 8); b = (b + a) & mask  # noqa: E702
        a = (a - c) & mask; a ^= rot(c, 16); c = (c + b) & mask  # noqa: E702
        b = (b - a) & mask; b ^= rot(a, 19); a = (a + c) & mask  # noqa: E702
        c = (c - b) & mask; c ^= rot(b, 4); b = (b + a) & mask  # noqa: E702
        length -= 12
        i += 12
    if length == 0:
        return c
    tail = data[i:] + bytes(12 - length)
    a = (a + int.from_bytes(tail[0:4], "little")) & mask
    b = (b + int.from_bytes(tail[4:8], "little")) & mask
    c = (c + int.from_bytes(tail[8:12], "little")) & mask
    c ^= b; c = (c - rot(b, 14)) & mask  # noqa: E702
    a ^= c; a = (a - rot(c, 11)) & mask  # noqa: E702
    b ^= a; b = (b - rot(a, 25)) & mask  # noqa: E702
    c ^= b; c = (c - rot(b, 16)) & mask  # noqa: E702
    a ^= c; a = (a - rot(c, 4)) & mask  # noqa: E702
    b ^= a; b = (b - rot(a, 14)) & mask  # noqa: E702
    c ^= b; c = (c - rot(b, 24)) & mask  # noqa: E702
    return c


class _PatchedView(io.RawIOBase):
    """Read-only view of a file with its first bytes replaced (h5py's file-object driver)."""

    def __init__(self, path: Path, head: bytes) -> None:
        super().__init__()
        self._fh = path.open("rb")
        self._head = head
        self._pos = 0
        self._size = os.fstat(self._fh.fileno()).st_size

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        base = {io.SEEK_SET: 0, io.SEEK_CUR: self._pos, io.SEEK_END: self._size}[whence]
        self._pos = base + offset
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, buffer: Any) -> int:
        self._fh.seek(self._pos)
        n = self._fh.readinto(buffer)
        if self._pos < len(self._head) and n:
            k = min(len(self._head) - self._pos, n)
            memoryview(buffer)[:k] = self._head[self._pos:self._pos + k]
        self._pos += n
        return n

    def close(self) -> None:
        self._fh.close()
        super().close()


def _open_salvage_view(path: Path) -> h5py.File | None:
    """Open ``path`` for salvage without SWMR: superblock EOF set to the real size, mark cleared.

    Reads past the real end then fail at once ("address overflow") instead of the library
    refusing the whole file; None if even that cannot be opened.
    """
    try:
        sb = _read_superblock(path)
    except DamagedFileError:
        return None
    try:
        if sb is None:
            return h5py.File(path, "r")
        raw = bytearray(sb.raw)
        raw[11] = 0  # clear the "open for writing" / SWMR mark
        size = path.stat().st_size
        raw[sb.eof_at:sb.eof_at + sb.offset_size] = size.to_bytes(sb.offset_size, "little")
        head = bytes(raw) + _lookup3(bytes(raw)).to_bytes(4, "little")
        return h5py.File(_PatchedView(path, head), "r")
    except (OSError, KeyError, RuntimeError, ValueError):
        return None


def _salvage(path: Path, tmp: Path, resume_step: int | None) -> int:
    """Write the leading whole frames of ``path`` (step <= resume_step) to ``tmp``; return the count."""
    src = _open_salvage_view(path)
    if src is None:
        return 0
    kept = 0
    try:
        try:
            if src["parameters/grainflow"].attrs.get("layout") != LAYOUT.encode():
                return 0
            dim, _, has_contacts = _layout_of(src)
            n_frames = _complete_frames(src)
        except (OSError, KeyError, RuntimeError, ValueError, TypeError):
            return 0
        writer: TrajectoryWriter | None = None
        last: Frame | None = None
        try:
            for k in range(n_frames):
                try:
                    frame = _read(src, k)
                    _check_salvaged(frame, last, dim, has_contacts)
                except (OSError, KeyError, RuntimeError, ValueError, TypeError, IndexError):
                    break
                if resume_step is not None and frame.step > resume_step:
                    break
                if writer is None:
                    writer = _copy_writer(src, tmp)
                writer.append(frame)
                last = frame
                kept += 1
        finally:
            if writer is not None:
                writer.close()
    finally:
        src.close()
    return kept


def _copy_writer(src: h5py.File, path: Path) -> TrajectoryWriter:
    """A new trajectory at ``path`` with the layout, compression and row bound of ``src``."""
    dim, periodic, has_contacts = _layout_of(src)
    return TrajectoryWriter(path, dim, Box(lo=np.zeros(dim), hi=np.ones(dim), periodic=periodic),
                            contacts=has_contacts,
                            compression=src[_PARTICLE_FIELDS[0].element + "/value"].compression,
                            max_rows=_max_rows_of(src))


def _max_rows_of(f: h5py.File) -> int:
    """The row bound of an existing file (a file from before the bound: the default, or
    its widest dataset's row count)."""
    bound = f[_PARTICLE_FIELDS[0].element + "/value"].maxshape[1]
    if bound is not None:
        return int(bound)
    fields = [*_PARTICLE_FIELDS, *((_CONTACT_PAIRS,) if _CONTACT_PAIRS.element in f else ())]
    return max(DEFAULT_MAX_ROWS, *(f[fld.element + "/value"].shape[1] for fld in fields))


def _check_salvaged(frame: Frame, last: Frame | None, dim: int, contacts: bool) -> None:
    """Raise ValueError unless a frame read from a damaged file is whole and follows ``last``."""
    if last is not None and not (frame.step > last.step and frame.time >= last.time):
        raise ValueError("steps or times out of order")
    n = frame.n
    for fld in _PARTICLE_FIELDS:
        if np.shape(getattr(frame, fld.attr)) != (n, *fld.trailing(dim)):
            raise ValueError(f"{fld.attr}: rows missing")
    if n and (frame.id < 0).any():
        raise ValueError("absent particle ids")
    if frame.ring_vertex is not None and (np.shape(frame.ring_vertex) != (n,)
                                          or (frame.ring_vertex < -1).any()):
        raise ValueError("ring_vertex: rows missing or invalid")
    if contacts:
        c = frame.contacts
        m = len(c.i)
        if any(len(x) != m for x in (c.j, c.force, c.branch, c.kind)):
            raise ValueError("contact rows missing")
        if m and ((c.i < 0).any() or (c.kind < 0).any() or (c.kind >= len(CONTACT_KINDS)).any()):
            raise ValueError("absent contact rows")
    check_finite_frame("repair_frames", frame, contacts=contacts)  # NaN rows are missing rows


def _time_dependent(f: h5py.File) -> list[h5py.Dataset]:
    """Every dataset with a frame axis: the shared step and time, then the value datasets."""
    names = [fld.element for fld in _PARTICLE_FIELDS] + [_PARTICLE_NUMBER, *_BOX_ELEMENTS]
    if _RING_VERTEX.element in f:
        names.append(_RING_VERTEX.element)
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
    if not 0 <= n <= f[_PARTICLE_FIELDS[0].element + "/value"].shape[1]:
        raise OSError(f"frame {k}: stored particle number {n} is impossible")
    rows = {fld.attr: f[fld.element + "/value"][k, :n] for fld in _PARTICLE_FIELDS}
    rows["ring_vertex"] = _read_ring_vertex(f, k, n)
    edges = f[_BOX_ELEMENTS[0] + "/value"][k]
    lo = f[_BOX_ELEMENTS[1] + "/value"][k]
    contacts = None
    if has_contacts:
        m = int(f[_CONTACT_NUMBER + "/value"][k])
        if not 0 <= m <= f[_CONTACT_PAIRS.element + "/value"].shape[1]:
            raise OSError(f"frame {k}: stored contact number {m} is impossible")
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


def _read_ring_vertex(f: h5py.File, k: int, n: int) -> np.ndarray | None:
    """``ring_vertex`` of frame ``k``; None if no particle is in a ring (or the file is from
    before rings were stored)."""
    if _RING_VERTEX.element not in f:
        return None
    ring_vertex = f[_RING_VERTEX.element + "/value"][k, :n]
    return ring_vertex if (ring_vertex >= 0).any() else None


# --- resuming ---------------------------------------------------------------------------


def _open_for_append(path: Path, resume_step: int | None) -> h5py.File:
    """Open an existing trajectory in SWMR mode, dropping frames after ``resume_step``.

    A file whose writer was killed is still marked open-for-writing by HDF5, which refuses
    to open it for writing again; such a file is first rewritten (kept frames only) into a
    clean file that atomically replaces it. So is a file written before contact kinds were
    stored (its contacts become pairs), since SWMR cannot add the missing dataset in place
    and adding it outside SWMR would not survive a kill. A file written before rings were
    stored is continued as it is (without ``ring_vertex``; see :class:`TrajectoryWriter`).
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
        keep = _frames_to_keep(src, resume_step)
        try:
            with _copy_writer(src, tmp) as dst:
                for k in range(keep):
                    dst.append(_read(src, k))
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    os.replace(tmp, path)
