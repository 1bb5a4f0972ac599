"""Damaged output files get a named error and a way out; non-finite values never reach a file.

Trajectories (``frames.h5``) truncated at several fractions, cut by one byte, empty, overwritten
with random bytes, with a corrupt chunk, left by a killed writer; thermo logs with garbage,
a binary blob, another header, rows of other widths; frames and thermo rows with NaN/inf.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from grainflow.engine.simulation import InstabilityError
from grainflow.frame import Contacts, Frame
from grainflow.io.h5md import (DamagedFileError, NonFiniteFrameError, TrajectoryWriter, count_frames,
                               read_frame, read_frames, repair_frames)
from grainflow.io.lammps_dump import read_lammps_dump, write_lammps_dump
from grainflow.io.thermo import THERMO_COLUMNS, ThermoLog
from grainflow.io.vtk import write_vtp
from test_io_h5md import assert_frames_equal, make_frame, write

#: Text of HDF5's own error stack that must not reach a user.
RAW_HDF5 = ("H5F", "H5D", "errno", "sblock", "stored_eof", "addr overflow", "synchronously")


def frames20(contacts: bool, seed: int = 0) -> list[Frame]:
    rng = np.random.default_rng(seed)
    return [make_frame(rng, step=10 * k, n=int(rng.integers(50, 200)), contacts=contacts)
            for k in range(20)]


def assert_named_error(err: pytest.ExceptionInfo, path: Path) -> None:
    message = str(err.value)
    assert str(path) in message and "damaged" in message and "repair_frames" in message, message
    assert not any(raw in message for raw in RAW_HDF5), message


def assert_every_reader_refuses(path: Path, frames: list[Frame]) -> None:
    for read in (count_frames, lambda p: list(read_frames(p)), lambda p: read_frame(p, 0)):
        with pytest.raises(DamagedFileError) as err:
            read(path)
        assert_named_error(err, path)
    first = frames[0]
    with pytest.raises(DamagedFileError) as err:
        TrajectoryWriter(path, first.dim, first.box, contacts=first.contacts is not None,
                         append=True, resume_step=first.step)
    assert_named_error(err, path)


def repair(path: Path, resume_step: int | None = None) -> int:
    with pytest.warns(RuntimeWarning, match="damaged original is kept"):
        return repair_frames(path, resume_step)


# --------------------------------------------------------------------------- truncation
@pytest.mark.parametrize("compression", ["gzip", None])
@pytest.mark.parametrize("contacts", [True, False])
def test_truncated_trajectory(tmp_path, compression, contacts):
    frames = frames20(contacts)
    whole = tmp_path / "whole.h5"
    write(whole, frames, compression=compression)
    size = whole.stat().st_size
    for fraction in (0.3, 0.6, 0.9, 0.99, 1 - 1 / size):
        cut = int(fraction * size)
        path = tmp_path / f"frames_{cut}.h5"
        shutil.copy(whole, path)
        os.truncate(path, cut)
        original = path.read_bytes()
        start = time.monotonic()
        assert_every_reader_refuses(path, frames)
        with pytest.raises(DamagedFileError, match="truncated"):
            count_frames(path)
        kept = repair(path, resume_step=190)
        assert time.monotonic() - start < 10  # no SWMR retry loop
        damaged = path.with_name(path.name + ".damaged")
        assert damaged.read_bytes() == original  # the user's file is kept as it was
        # the bounded row axis keeps the chunk index of earlier frames where it was written:
        # about the fraction of frames that lies before the cut survives
        assert kept >= int(0.8 * fraction * len(frames)) - 1, (fraction, kept)
        got = list(read_frames(path))
        assert len(got) == kept
        for a, b in zip(got, frames):
            assert_frames_equal(a, b, contacts=contacts)
        # the run continues: append creates (or continues) the file
        more = make_frame(np.random.default_rng(1), step=1000, contacts=contacts,
                          periodic=frames[0].box.periodic)
        with TrajectoryWriter(path, 3, frames[0].box, contacts=contacts, append=True,
                              resume_step=190) as w:
            w.append(more)
        assert [f.step for f in read_frames(path)] == [f.step for f in frames[:kept]] + [1000]


def test_truncated_file_of_a_killed_writer_does_not_hang(tmp_path):
    """A killed writer leaves the SWMR mark; a truncated such file must still fail at once."""
    path = tmp_path / "killed.h5"
    script = textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        import numpy as np
        from test_io_h5md import make_frame
        from grainflow.io.h5md import TrajectoryWriter
        rng = np.random.default_rng(3)
        frames = [make_frame(rng, step=k, n=100) for k in range(10)]
        w = TrajectoryWriter({str(path)!r}, 3, frames[0].box, contacts=True)
        for f in frames:
            w.append(f)
        os._exit(0)
    """)
    subprocess.run([sys.executable, "-c", script], check=True)
    assert count_frames(path) == 10  # killed, whole: readable
    rng = np.random.default_rng(3)
    frames = [make_frame(rng, step=k, n=100) for k in range(10)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        shutil.copy(path, tmp_path / "copy.h5")
        assert repair_frames(tmp_path / "copy.h5", resume_step=6) == 7  # a killed file repairs whole
    for a, b in zip(read_frames(tmp_path / "copy.h5"), frames[:7]):
        assert_frames_equal(a, b)
    os.truncate(path, path.stat().st_size // 2)
    start = time.monotonic()
    assert_every_reader_refuses(path, frames)
    kept = repair(path)
    assert time.monotonic() - start < 10
    assert 1 <= kept < 10
    for a, b in zip(read_frames(path), frames[:kept]):
        assert_frames_equal(a, b)


# --------------------------------------------------------------------------- garbage
@pytest.mark.parametrize("content", ["empty", "random", "text", "superblock"])
def test_garbage_trajectory(tmp_path, content):
    frames = frames20(True)
    path = tmp_path / "frames.h5"
    write(path, frames)
    rng = np.random.default_rng(4)
    data = path.read_bytes()
    if content == "empty":
        data = b""
    elif content == "random":
        data = rng.bytes(len(data))
    elif content == "text":
        data = b"step,time\n1,2\n"
    else:  # the superblock overwritten (signature kept)
        data = data[:8] + rng.bytes(40) + data[48:]
    path.write_bytes(data)
    assert_every_reader_refuses(path, frames)
    with pytest.raises(OSError):  # also an OSError, as HDF5's own errors were
        count_frames(path)
    assert repair(path) == 0
    assert not path.exists() and path.with_name("frames.h5.damaged").read_bytes() == data


@pytest.mark.parametrize("contacts", [True, False])
def test_corrupt_chunk_is_salvaged_up_to_the_frame_before(tmp_path, contacts):
    frames = frames20(contacts, seed=5)
    path = tmp_path / "frames.h5"
    write(path, frames, compression="gzip")
    bad = 12
    with h5py.File(path, "r") as f:
        info = f["particles/all/velocity/value"].id.get_chunk_info_by_coord((bad, 0, 0))
    with path.open("r+b") as fh:  # random bytes over frame 12's (compressed) velocities
        fh.seek(info.byte_offset)
        fh.write(np.random.default_rng(6).bytes(info.size))
    original = path.read_bytes()
    assert count_frames(path) == 20  # the metadata is whole
    got = []
    with pytest.raises(DamagedFileError, match="frame 12") as err:
        for frame in read_frames(path):
            got.append(frame)
    assert_named_error(err, path)
    assert len(got) == bad
    with pytest.raises(DamagedFileError):
        read_frame(path, bad)

    shutil.copy(path, tmp_path / "resume.h5")
    assert repair(path) == bad
    assert path.with_name("frames.h5.damaged").read_bytes() == original
    repaired = list(read_frames(path))
    assert len(repaired) == bad
    for a, b in zip(repaired, frames):
        assert_frames_equal(a, b, contacts=contacts)
    with h5py.File(path, "r") as f:  # written again with the original's compression
        assert f["particles/all/position/value"].compression == "gzip"
    # a second repair keeps the first .damaged too
    assert repair(path) == bad
    assert path.with_name("frames.h5.damaged.1").exists()
    # with a resume step, only frames up to it
    assert repair(tmp_path / "resume.h5", resume_step=55) == 6
    assert [f.step for f in read_frames(tmp_path / "resume.h5")] == [0, 10, 20, 30, 40, 50]


def test_missing_file_is_not_damaged(tmp_path):
    with pytest.raises(FileNotFoundError):
        count_frames(tmp_path / "nope.h5")
    with pytest.raises(FileNotFoundError):
        repair_frames(tmp_path / "nope.h5")


# --------------------------------------------------------------------------- non-finite
def poisoned(frame: Frame, name: str, row: int, value: float) -> Frame:
    fields = dict(frame.__dict__)
    if name.startswith("contacts."):
        c = frame.contacts
        arrays = {k: getattr(c, k).copy() for k in ("i", "j", "force", "branch", "kind")}
        arrays[name.split(".")[1]][row] = value
        fields["contacts"] = Contacts(**arrays)
    else:
        array = getattr(frame, name).copy()
        array[row] = value
        fields[name] = array
    return Frame(**fields)


@pytest.mark.parametrize("name", ["position", "velocity", "omega", "radius", "mass",
                                  "contacts.force", "contacts.branch"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_writers_refuse_non_finite_frames(tmp_path, name, value):
    rng = np.random.default_rng(7)
    good = make_frame(rng, step=1, n=10)
    bad = poisoned(make_frame(rng, step=2, n=10), name, 3, value)
    particle = bad.contacts.i[3] if name.startswith("contacts.") else bad.id[3]
    path = tmp_path / "t.h5"
    with TrajectoryWriter(path, 3, good.box, contacts=True) as w:
        w.append(good)
        with pytest.raises(NonFiniteFrameError, match=rf"frame\.{name} .*particle id {particle}") as err:
            w.append(bad)
        assert isinstance(err.value, InstabilityError) and isinstance(err.value, ValueError)
        assert (err.value.step, err.value.particle) == (2, particle)
        assert w.n_frames == 1
    assert count_frames(path) == 1
    with h5py.File(path, "r") as f:
        assert all(f[n].shape[0] == 1 for n in ("particles/all/position/value",
                                                  "observables/contacts/force/value"))
    assert_frames_equal(read_frame(path, 0), good)
    if name.startswith("contacts."):
        return  # dumps and VTK files do not carry contacts
    write_lammps_dump(tmp_path / "t.dump", good)
    with pytest.raises(ValueError, match=rf"frame\.{name} .*particle id {particle}"):
        write_lammps_dump(tmp_path / "t.dump", bad, append=True)
    assert [f.step for f in read_lammps_dump(tmp_path / "t.dump")] == [1]
    with pytest.raises(ValueError, match=rf"frame\.{name} .*particle id {particle}"):
        write_vtp(tmp_path / "t.vtp", bad)
    assert not (tmp_path / "t.vtp").exists()


# --------------------------------------------------------------------------- thermo.csv
def context(step: int, v: np.ndarray | None = None, kinetic: float = 1.0) -> SimpleNamespace:
    v = np.ones((3, 2)) if v is None else v
    state = SimpleNamespace(n=len(v), v=v, id=np.array([10, 11, 12][:len(v)]),
                            kinetic_energy=lambda: kinetic, rotational_energy=lambda: 0.5)
    return SimpleNamespace(step=step, time=0.01 * step, state=state, particle_steps=3 * step,
                           rebuilds=0, max_overlap=lambda: 0.0,
                           contacts=lambda: SimpleNamespace(i=np.zeros(2)))


def write_log(path: Path, steps) -> None:
    log = ThermoLog(path)
    for s in steps:
        log(context(s))
    log.close()


HEADER = ",".join(THERMO_COLUMNS)


@pytest.mark.parametrize("content", [
    "random text\nwithout, the, header\n",
    "step,time,N,kinetic_energy\n0,0.0,3,1.0\n",  # a header from an older version
    HEADER + "\n0,0.0,3,1.0,0.5,0.0,2,0\n",  # a row with fewer columns
    HEADER + "\n0,0.0,3,1.0,0.5,0.0,2,0,0,7\n",  # a row with more columns
    HEADER + "\n0,0.0,3,abc,0.5,0.0,2,0,0\n",  # a field that does not parse
    HEADER + "\n10,0.1,3,1.0,0.5,0.0,2,0,0\n5,0.05,3,1.0,0.5,0.0,2,0,0\n",  # steps backwards
    "",  # empty
    b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe binary",
])
def test_garbage_thermo_is_moved_aside(tmp_path, content):
    path = tmp_path / "thermo.csv"
    data = content if isinstance(content, bytes) else content.encode()
    path.write_bytes(data)
    with pytest.warns(RuntimeWarning, match=r"thermo\.csv cannot be continued .*thermo\.csv\.damaged") as rec:
        log = ThermoLog(path, resume_step=20)
    assert str(path) in str(rec[0].message)
    assert log.moved_aside == tmp_path / "thermo.csv.damaged"
    log(context(20))
    log(context(30))
    log.close()
    assert path.with_name("thermo.csv.damaged").read_bytes() == data
    lines = path.read_text().splitlines()
    assert lines[0] == HEADER and [int(r.split(",")[0]) for r in lines[1:]] == [20, 30]


def test_whole_thermo_and_torn_last_line_are_continued(tmp_path):
    path = tmp_path / "thermo.csv"
    write_log(path, [0, 10, 20, 30])
    with path.open("a") as fh:
        fh.write("40,0.4,3,1.0")  # torn by a crash
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        log = ThermoLog(path, resume_step=20)
    assert log.moved_aside is None
    log(context(20))  # already logged: skipped
    log(context(25))
    log.close()
    assert [int(r.split(",")[0]) for r in path.read_text().splitlines()[1:]] == [0, 10, 20, 25]
    assert not path.with_name("thermo.csv.damaged").exists()


def test_thermo_refuses_non_finite_rows(tmp_path):
    path = tmp_path / "thermo.csv"
    log = ThermoLog(path)
    log(context(0))
    v = np.array([[1.0, 0.0], [1e300, 1e300], [2.0, 0.0]])  # finite speeds, kinetic energy inf
    with pytest.raises(InstabilityError, match=r"'kinetic_energy' is inf .*particle id 11") as err:
        log(context(10, v=v, kinetic=float("inf")))
    assert (err.value.step, err.value.particle) == (10, 11)
    with pytest.raises(InstabilityError, match="'kinetic_energy' is nan"):
        log(context(10, v=np.array([[np.nan, 0.0], [1.0, 0.0]]), kinetic=float("nan")))
    log.close()
    assert [int(r.split(",")[0]) for r in path.read_text().splitlines()[1:]] == [0]
