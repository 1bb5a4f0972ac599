"""H5MD trajectories: round trip, layout, validation, resume, and survival of a SIGKILL.

``make_frame`` and ``assert_frames_equal`` are also imported by the other output tests.
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from grainflow.frame import ANCHOR, BOND, CONTACT_KINDS, PAIR, WALL, Box, Contacts, Frame
from grainflow.io.h5md import (DEFAULT_MAX_ROWS, TrajectoryWriter, count_frames, read_frame,
                               read_frames)

DOC = Path(__file__).resolve().parents[1] / "docs" / "output_format.md"


def make_frame(
    rng: np.random.Generator,
    *,
    dim: int = 3,
    step: int = 0,
    n: int | None = None,
    contacts: bool = True,
    periodic: tuple[bool, ...] | None = None,
) -> Frame:
    """A frame of ``n`` (random if None) particles with random data and random contacts."""
    n = int(rng.integers(0, 40)) if n is None else n
    periodic = periodic if periodic is not None else (True,) + (False,) * (dim - 1)
    lo = rng.uniform(-1.0, 0.0, dim)
    hi = lo + rng.uniform(1.0, 2.0, dim)
    ids = rng.permutation(10 * n + 1)[:n].astype(np.int64)
    contact_data = None
    if contacts:
        m = int(rng.integers(0, 3 * n + 1))
        contact_data = Contacts(
            i=rng.choice(ids, m) if n else np.zeros(0, np.int64),
            j=rng.choice(ids, m) if n else np.zeros(0, np.int64),
            force=rng.normal(size=(m, dim)),
            branch=rng.normal(size=(m, dim)),
        )
    omega = np.zeros((n, 3))
    omega[:, 2 if dim == 2 else slice(None)] = rng.normal(size=(n,) if dim == 2 else (n, 3))
    return Frame(
        step=step,
        time=0.001 * step,
        box=Box(lo=lo, hi=hi, periodic=periodic),
        id=ids,
        type=rng.integers(0, 3, n).astype(np.int32),
        body=np.where(rng.random(n) < 0.3, rng.integers(0, 5, n), -1).astype(np.int64),
        radius=rng.uniform(0.01, 0.05, n),
        mass=rng.uniform(1.0, 2.0, n),
        position=rng.uniform(lo, hi, (n, dim)),
        velocity=rng.normal(size=(n, dim)),
        omega=omega,
        contacts=contact_data,
    )


def assert_frames_equal(a: Frame, b: Frame, *, contacts: bool = True) -> None:
    """Exact equality of everything a trajectory stores (box bounds to rounding)."""
    assert (a.step, a.time, a.box.periodic) == (b.step, b.time, b.box.periodic)
    np.testing.assert_allclose(a.box.lo, b.box.lo, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.box.hi, b.box.hi, rtol=0, atol=1e-12)
    for name in ("id", "type", "body", "radius", "mass", "position", "velocity", "omega"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype.kind == y.dtype.kind, name
        np.testing.assert_array_equal(x, y, err_msg=name)
    if not contacts:
        return
    for name in ("i", "j", "force", "branch", "kind"):
        np.testing.assert_array_equal(getattr(a.contacts, name), getattr(b.contacts, name), err_msg=name)


#: Box periodicity of ``mixed_contacts_frame``: walls bound x and z (x and y in 2D).
MIXED_PERIODIC = {2: (False, False), 3: (False, True, False)}


def mixed_contacts_frame(step: int = 40, dim: int = 3, rows=slice(None)) -> Frame:
    """Four 1 cm grains with contacts of every kind, built by hand; ``rows`` selects contacts.

    3D coordinates (2D keeps x and z): grains 7 and 3 rest side by side on the floor (wall 0,
    z = 0) and touch each other; grain 12 touches the side wall x = 0.5 (wall 2) and is bonded
    to grain 5 (bond stretched past touching), which is tethered to an anchor above it. Forces
    are the ~0.01-0.5 N of millimetre-scale overlaps; branches follow from the positions.
    """
    axes = [0, 1, 2] if dim == 3 else [0, 2]
    ids = np.array([7, 3, 12, 5], dtype=np.int64)
    x = np.array([[0.1000, 0.20, 0.0098], [0.1195, 0.20, 0.0099],
                  [0.4902, 0.25, 0.0600], [0.4650, 0.25, 0.0600]])
    at = {int(p): x[r] for r, p in enumerate(ids)}
    anchor = np.array([0.4500, 0.25, 0.0800])
    n37 = (at[3] - at[7]) / np.linalg.norm(at[3] - at[7])
    # (i, kind, j, partner point, force on i from the partner)
    table = [
        (3, PAIR, 7, at[7], 0.21 * n37 + [0.0, 0.0, -0.004]),
        (7, WALL, 0, at[7] * [1, 1, 0], np.array([0.012, 0.0, 0.35])),
        (3, WALL, 0, at[3] * [1, 1, 0], np.array([-0.003, 0.0, 0.41])),
        (12, WALL, 2, np.array([0.5, *at[12][1:]]), np.array([-0.52, 0.0, 0.001])),
        (12, BOND, 5, at[5], -5.0 * (np.linalg.norm(at[12] - at[5]) - 0.02) * np.array([1.0, 0.0, 0.0])),
        (5, ANCHOR, -1, anchor, -2.0 * (at[5] - anchor)),
    ]
    table = [table[r] for r in np.arange(len(table))[rows]]
    contacts = Contacts(
        i=np.array([t[0] for t in table], dtype=np.int64),
        j=np.array([t[2] for t in table], dtype=np.int64),
        force=np.array([t[4] for t in table], dtype=float).reshape(-1, 3)[:, axes],
        branch=np.array([at[t[0]] - t[3] for t in table], dtype=float).reshape(-1, 3)[:, axes],
        kind=np.array([t[1] for t in table], dtype=np.int8),
    )
    omega = np.zeros((4, 3))
    omega[:, 2] = [0.3, -0.3, 0.0, 1.5]
    if dim == 3:
        omega[:, 0] = [0.0, 0.1, -0.2, 0.0]
    lo, hi = np.zeros(3), np.array([0.5, 0.4, 0.3])
    return Frame(
        step=step,
        time=1e-5 * step,
        box=Box(lo=lo[axes], hi=hi[axes], periodic=MIXED_PERIODIC[dim]),
        id=ids,
        type=np.array([0, 0, 1, 1], dtype=np.int32),
        body=np.full(4, -1, dtype=np.int64),
        radius=np.full(4, 0.01),
        mass=np.full(4, 1.0e-2),
        position=x[:, axes].copy(),
        velocity=np.array([[0.0, 0.0, -1e-4], [2e-4, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 3e-3]])[:, axes],
        omega=omega,
        contacts=contacts,
    )


def write(path: Path, frames: list[Frame], **kwargs) -> None:
    """Write ``frames`` to a new trajectory."""
    first = frames[0]
    with TrajectoryWriter(path, first.dim, first.box, contacts=first.contacts is not None, **kwargs) as w:
        for frame in frames:
            w.append(frame)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("compression", ["gzip", None])
def test_round_trip_with_varying_particle_number(tmp_path, dim, compression):
    rng = np.random.default_rng(dim)
    sizes = [12, 30, 0, 5, 40, 1]  # grows, empties, regrows past the old maximum, shrinks
    frames = [make_frame(rng, dim=dim, step=10 * k, n=n) for k, n in enumerate(sizes)]
    path = tmp_path / "traj.h5"
    write(path, frames, compression=compression)

    assert count_frames(path) == len(frames)
    got = list(read_frames(path))
    assert [g.n for g in got] == sizes
    for a, b in zip(got, frames):
        assert_frames_equal(a, b)
    assert_frames_equal(read_frame(path, -1), frames[-1])
    assert_frames_equal(read_frame(path, 2), frames[2])
    with pytest.raises(IndexError, match="out of range"):
        read_frame(path, len(frames))


def test_frames_read_back_are_independent_copies(tmp_path):
    frame = make_frame(np.random.default_rng(1), n=10)
    write(tmp_path / "t.h5", [frame])
    a = read_frame(tmp_path / "t.h5", 0)
    a.position[:] = 0.0
    a.contacts.i[:] = -5
    b = read_frame(tmp_path / "t.h5", 0)
    assert_frames_equal(b, frame)
    assert not np.shares_memory(b.contacts.i, b.contacts.j)


def test_without_contacts(tmp_path):
    rng = np.random.default_rng(2)
    frames = [make_frame(rng, step=s, contacts=False) for s in (1, 2)]
    write(tmp_path / "t.h5", frames)
    got = list(read_frames(tmp_path / "t.h5"))
    assert all(g.contacts is None for g in got)
    for a, b in zip(got, frames):
        assert_frames_equal(a, b, contacts=False)
    with h5py.File(tmp_path / "t.h5", "r") as f:
        assert "connectivity" not in f


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("compression", ["gzip", None])
def test_round_trip_of_every_contact_kind(tmp_path, dim, compression):
    # all six rows, then four (rows past the count are fill), then all six in reverse order
    frames = [mixed_contacts_frame(0, dim), mixed_contacts_frame(10, dim, slice(2, None)),
              mixed_contacts_frame(20, dim, slice(None, None, -1))]
    path = tmp_path / "t.h5"
    write(path, frames, compression=compression)
    got = list(read_frames(path))
    for a, b in zip(got, frames):
        assert_frames_equal(a, b)
        assert a.contacts.kind.dtype == np.int8
    walls = got[0].contacts.of_kind(WALL)
    assert list(walls.i) == [7, 3, 12] and list(walls.j) == [0, 0, 2]
    assert list(got[0].contacts.of_kind(ANCHOR).j) == [-1]
    np.testing.assert_array_equal(got[0].contacts.of_kind(BOND).branch,
                                  frames[0].position[2:3] - frames[0].position[3:4])
    with h5py.File(path, "r", swmr=True) as f:
        kind = f["observables/contacts/kind/value"]
        force = f["observables/contacts/force/value"]
        assert kind.dtype == np.int8 and kind.shape == (3, 6) and kind.fillvalue == -1
        assert kind.chunks == (1, 4096) and kind.maxshape == (None, DEFAULT_MAX_ROWS)
        assert (kind.compression, kind.shuffle) == (force.compression, force.shuffle)
        assert list(kind[1]) == [WALL, WALL, BOND, ANCHOR, -1, -1]
        assert f["observables/contacts/kind/step"] == f["particles/all/position/step"]
        assert [n.decode() for n in f["observables/contacts/kind"].attrs["names"]] == list(CONTACT_KINDS)


def test_file_without_kind_dataset_reads_as_pairs_and_is_upgraded_on_resume(tmp_path):
    rng = np.random.default_rng(21)
    old = [make_frame(rng, step=s, n=8, periodic=MIXED_PERIODIC[3]) for s in (0, 5)]
    path = tmp_path / "old.h5"
    write(path, old)
    with h5py.File(path, "r+") as f:  # the layout written before contact kinds were stored
        del f["observables/contacts/kind"]
    got = list(read_frames(path))
    for a, b in zip(got, old):
        assert a.contacts.kind.dtype == np.int8 and (a.contacts.kind == PAIR).all()
        assert_frames_equal(a, b)
    assert_frames_equal(read_frame(path, -1), old[-1])
    new = mixed_contacts_frame(step=9)
    with TrajectoryWriter(path, 3, new.box, contacts=True, append=True, resume_step=0) as w:
        assert w.n_frames == 1
        w.append(new)
    got = list(read_frames(path))
    assert [g.step for g in got] == [0, 9]
    assert_frames_equal(got[0], old[0])
    assert_frames_equal(got[1], new)
    with h5py.File(path, "r", swmr=True) as f:
        assert f["observables/contacts/kind/value"].shape[0] == 2
        assert f["observables/contacts/kind/step"] == f["particles/all/position/step"]


def test_resume_trims_contact_kinds(tmp_path):
    frames = [mixed_contacts_frame(10 * k, 2, slice(k % 3, None)) for k in range(6)]
    path = tmp_path / "t.h5"
    write(path, frames)
    later = [mixed_contacts_frame(25, 2, slice(None, None, -2)), mixed_contacts_frame(26, 2)]
    with TrajectoryWriter(path, 2, frames[0].box, contacts=True, append=True, resume_step=20) as w:
        assert w.n_frames == 3
        with h5py.File(path, "r", swmr=True) as f:  # trimmed while the writer holds the file
            assert f["observables/contacts/kind/value"].shape[0] == 3
        for frame in later:
            w.append(frame)
    got = list(read_frames(path))
    assert [g.step for g in got] == [0, 10, 20, 25, 26]
    for a, b in zip(got, frames[:3] + later):
        assert_frames_equal(a, b)
    with h5py.File(path, "r", swmr=True) as f:
        lengths = {f[name].shape[0] for name in ("observables/contacts/kind/value",
                                                 "observables/contacts/force/value",
                                                 "connectivity/contacts/value")}
        assert lengths == {5}
        assert list(f["observables/contacts/kind/value"][3, :3]) == [ANCHOR, WALL, WALL]


def test_h5md_layout(tmp_path):
    rng = np.random.default_rng(3)
    frames = [make_frame(rng, dim=2, step=s, n=n, periodic=(True, False)) for s, n in ((0, 3), (5, 7))]
    path = tmp_path / "t.h5"
    write(path, frames)
    with h5py.File(path, "r") as f:
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        assert f["h5md/creator"].attrs["name"] == b"grainflow"
        assert "name" in f["h5md/author"].attrs
        box = f["particles/all/box"]
        assert box.attrs["dimension"] == 2
        assert list(box.attrs["boundary"]) == [b"periodic", b"none"]
        np.testing.assert_allclose(box["edges/value"][1], frames[1].box.hi - frames[1].box.lo)
        step = f["particles/all/position/step"]
        assert list(step[:]) == [0, 5]
        for element in ("particles/all/id", "particles/all/velocity", "particles/all/box/edges",
                        "observables/particle_number", "connectivity/contacts"):
            assert f[element + "/step"] == step, f"{element}/step is not a hard link"
            assert f[element + "/time"] == f["particles/all/position/time"]
        ids = f["particles/all/id/value"]
        assert ids.shape == (2, 7) and ids.fillvalue == -1
        assert list(ids[0, 3:]) == [-1] * 4  # H5MD: fill value marks absent particles
        assert np.isnan(f["particles/all/position/value"][0, 3:]).all()
        pairs = f["connectivity/contacts"]
        assert f[pairs.attrs["particles_group"]].name == "/particles/all"


def test_doc_example_reads_frames_with_plain_h5py(tmp_path):
    """The h5py snippet in docs/output_format.md runs and returns the last frame."""
    rng = np.random.default_rng(4)
    frames = [make_frame(rng, step=0, n=20, periodic=MIXED_PERIODIC[3]), mixed_contacts_frame(step=3)]
    path = tmp_path / "t.h5"
    write(path, frames)
    block = re.search(r"<!-- h5py-example -->\s*```python\n(.*?)```", DOC.read_text(), re.S)
    assert block, "docs/output_format.md lost its marked h5py example"
    code = block.group(1)
    assert len(code.strip().splitlines()) <= 14
    namespace: dict = {"path": str(path)}
    exec(code, namespace)
    last = frames[-1]
    assert namespace["n_frames"] == 2 and namespace["step"] == last.step
    np.testing.assert_array_equal(namespace["ids"], last.id)
    np.testing.assert_array_equal(namespace["pos"], last.position)
    np.testing.assert_array_equal(namespace["omega"], last.omega)
    np.testing.assert_array_equal(namespace["pairs"], np.stack([last.contacts.i, last.contacts.j], -1))
    np.testing.assert_array_equal(namespace["force"], last.contacts.force)
    np.testing.assert_array_equal(namespace["kind"], last.contacts.kind)


def test_doc_stress_example_sums_every_contact_kind(tmp_path):
    """The contact-stress snippet in docs/output_format.md: sum of force (x) branch over all rows / V."""
    frames = [mixed_contacts_frame(step=0, rows=slice(3)), mixed_contacts_frame(step=3)]
    path = tmp_path / "t.h5"
    write(path, frames)
    block = re.search(r"<!-- h5py-stress-example -->\s*```python\n(.*?)```", DOC.read_text(), re.S)
    assert block, "docs/output_format.md lost its marked contact-stress example"
    namespace: dict = {"path": str(path)}
    exec(block.group(1), namespace)
    c, volume = frames[-1].contacts, np.prod(frames[-1].box.lengths)
    expected = sum(np.outer(f, b) for f, b in zip(c.force, c.branch)) / volume
    np.testing.assert_allclose(namespace["stress"], expected, rtol=1e-12, atol=0)
    assert expected[2, 2] > 0  # compression positive: the floor pushes up on grains above it
    by_kind = namespace["by_kind"]
    assert list(by_kind) == list(CONTACT_KINDS)
    np.testing.assert_allclose(sum(by_kind.values()), expected, rtol=1e-12, atol=1e-15)
    for code, name in enumerate(CONTACT_KINDS):
        part = c.of_kind(code)
        np.testing.assert_allclose(by_kind[name], part.force.T @ part.branch / volume, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda f: {"position": f.position[:, :2]}, r"frame\.position has shape"),
        (lambda f: {"omega": f.omega[:-1]}, r"frame\.omega has shape"),
        (lambda f: {"step": 0}, r"frame\.step=0 is not after the last stored step 7"),
        (lambda f: {"contacts": None}, r"frame\.contacts is None"),
        (lambda f: {"contacts": Contacts(f.contacts.i, f.contacts.j[:1], f.contacts.force, f.contacts.branch)},
         r"frame\.contacts\.j has shape"),
        (lambda f: {"box": Box(f.box.lo, f.box.hi, (True, True, True))}, r"periodic"),
        (lambda f: {"contacts": Contacts(f.contacts.i, f.contacts.j, f.contacts.force, f.contacts.branch,
                                         f.contacts.kind[:1])}, r"frame\.contacts\.kind has shape"),
        (lambda f: {"contacts": Contacts(f.contacts.i, f.contacts.j, f.contacts.force, f.contacts.branch,
                                         np.full(len(f.contacts.i), 4))}, r"kind must hold integer codes 0\.\.3"),
    ],
)
def test_append_rejects_bad_frames(tmp_path, change, message):
    rng = np.random.default_rng(5)
    good = make_frame(rng, step=7, n=6)
    with TrajectoryWriter(tmp_path / "t.h5", 3, good.box, contacts=True) as w:
        w.append(good)
        bad = make_frame(rng, step=8, n=6)
        bad = Frame(**{**bad.__dict__, **change(bad)})
        with pytest.raises(ValueError, match=message):
            w.append(bad)
        assert w.n_frames == 1
    assert count_frames(tmp_path / "t.h5") == 1


def test_constructor_errors(tmp_path):
    box = make_frame(np.random.default_rng(6), dim=2).box
    with pytest.raises(ValueError, match="box.dim"):
        TrajectoryWriter(tmp_path / "a.h5", 3, box, contacts=False)
    with pytest.raises(ValueError, match="compression"):
        TrajectoryWriter(tmp_path / "a.h5", 2, box, contacts=False, compression="zstd")
    with pytest.raises(ValueError, match="append=True"):
        TrajectoryWriter(tmp_path / "a.h5", 2, box, contacts=False, resume_step=3)
    write(tmp_path / "b.h5", [make_frame(np.random.default_rng(7), dim=2)])
    with pytest.raises(ValueError, match="contacts=True.*contacts=False"):
        TrajectoryWriter(tmp_path / "b.h5", 2, box, contacts=False, append=True)
    (tmp_path / "c.h5").write_bytes(b"not hdf5")
    with pytest.raises(OSError):
        count_frames(tmp_path / "c.h5")


def test_resume_truncates_frames_after_resume_step(tmp_path):
    rng = np.random.default_rng(8)
    frames = [make_frame(rng, step=10 * k) for k in range(8)]
    path = tmp_path / "t.h5"
    write(path, frames)
    later = [make_frame(rng, step=s) for s in (35, 40)]
    with TrajectoryWriter(path, 3, frames[0].box, contacts=True, append=True, resume_step=30) as w:
        assert w.n_frames == 4  # steps 0, 10, 20, 30 kept
        for frame in later:
            w.append(frame)
    got = list(read_frames(path))
    assert [g.step for g in got] == [0, 10, 20, 30, 35, 40]
    for a, b in zip(got, frames[:4] + later):
        assert_frames_equal(a, b)


def test_append_without_resume_step_keeps_everything_and_creates_missing(tmp_path):
    rng = np.random.default_rng(9)
    a, b = make_frame(rng, step=1), make_frame(rng, step=2)
    with TrajectoryWriter(tmp_path / "new.h5", 3, a.box, contacts=True, append=True) as w:
        w.append(a)
    with TrajectoryWriter(tmp_path / "new.h5", 3, a.box, contacts=True, append=True) as w:
        w.append(b)
    assert [f.step for f in read_frames(tmp_path / "new.h5")] == [1, 2]


# --- durability: a writer killed with SIGKILL ----------------------------------------------

WRITER_SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    sys.path.insert(0, sys.argv[2])
    from test_io_h5md import expected_frame
    from grainflow.io.h5md import TrajectoryWriter

    first = expected_frame(0)
    with TrajectoryWriter(sys.argv[1], 3, first.box, contacts=True, append=True,
                          resume_step=int(sys.argv[3])) as w:
        step = int(sys.argv[3]) + 1
        while True:
            w.append(expected_frame(step))
            print(step, flush=True)
            step += 1
    """
)


def expected_frame(step: int) -> Frame:
    """The frame the killed writer writes at ``step``: a few thousand particles and contacts."""
    rng = np.random.default_rng(step)
    frame = make_frame(rng, step=step, n=int(rng.integers(500, 3000)))
    c = frame.contacts
    kind = rng.integers(0, len(CONTACT_KINDS), len(c.i)).astype(np.int8)
    j = np.where(kind == ANCHOR, -1, np.where(kind == WALL, c.j % 4, c.j))
    return Frame(**{**frame.__dict__, "box": Box(np.zeros(3), np.ones(3), (True, False, False)),
                    "contacts": Contacts(c.i, j, c.force, c.branch, kind)})


def run_and_kill(path: Path, resume_step: int, delay: float) -> int:
    """Start the writer, SIGKILL it ``delay`` s after its first frame; return its last confirmed step."""
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER_SCRIPT, str(path), str(Path(__file__).parent), str(resume_step)],
        stdout=subprocess.PIPE, text=True,
    )
    try:
        first = proc.stdout.readline()
        assert first.strip(), "writer subprocess died before its first frame"
        time.sleep(delay)
    finally:
        proc.send_signal(signal.SIGKILL)
        rest = proc.communicate()[0]
    confirmed = [int(line) for line in (first + rest).split()]
    return confirmed[-1]


def test_frames_survive_sigkill_and_resume(tmp_path):
    rng = np.random.default_rng()
    path = tmp_path / "killed.h5"
    resume_step = -1
    for trial in range(3):
        delay = float(rng.uniform(0.0, 0.4))
        last = run_and_kill(path, resume_step, delay)
        stored = count_frames(path)
        frames = list(read_frames(path))
        steps = [f.step for f in frames]
        context = f"trial {trial}, killed {delay:.3f} s in, last confirmed step {last}"
        assert stored == len(frames) and steps == list(range(steps[0], steps[0] + stored)), context
        assert steps[-1] >= last, context  # every confirmed frame is there (one more may be)
        for frame in frames:
            assert_frames_equal(frame, expected_frame(frame.step))
        # resume from a "checkpoint" before the end: later frames are dropped, then rewritten
        resume_step = max(0, last - 2)
    assert count_frames(path) >= 1
    assert [f.step for f in read_frames(path)][0] == 0
