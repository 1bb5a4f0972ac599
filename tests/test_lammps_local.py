"""Frames with contacts from LAMMPS dumps (grainflow.io.lammps_local).

The fixture in ``tests/data/lammps_cg`` was made by a real LAMMPS run (``deck.in`` there):
216 granular spheres, fully periodic, no gravity or walls, so every force on a grain is a
contact force. These tests only read the shipped files; they never run LAMMPS.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grainflow.frame import PAIR
from grainflow.io.lammps_local import frames_from_lammps, read_lammps_local, unbalanced_force

DATA = Path(__file__).parent / "data" / "lammps_cg"
ATOMS, CONTACTS = DATA / "atoms.dump", DATA / "contacts.dump"
STEPS = [22500, 25000, 27500]
#: pair_style granular's p10 p11 p12 (x_I - x_J), columns 7-9 of compute contact_forces.
BRANCH_COLUMNS = ("c_contact_forces[7]", "c_contact_forces[8]", "c_contact_forces[9]")
#: First line of the first block's entry rows in contacts.dump.
FIRST_ROW = 12


@pytest.fixture(scope="module")
def frames():
    return frames_from_lammps(ATOMS, CONTACTS)


def write_copy(tmp_path: Path, source: Path, edit) -> Path:
    """A copy of ``source`` whose list of lines ``edit`` has changed in place."""
    lines = source.read_text().splitlines()
    edit(lines)
    path = tmp_path / source.name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_read_lammps_local_blocks():
    blocks = read_lammps_local(CONTACTS)
    assert [b.step for b in blocks] == STEPS
    assert [b.time for b in blocks] == pytest.approx([4.5, 5.0, 5.5])
    assert [b.n for b in blocks] == [709, 703, 705]
    first = blocks[0]
    assert first.label == "ENTRIES" and first.boundary == ("pp", "pp", "pp")
    assert first.bounds.shape == (3, 2)
    assert list(first.columns)[:3] == ["c_contact_ids[1]", "c_contact_ids[2]",
                                       "c_contact_forces[1]"]
    assert len(first.columns) == 11
    assert first.columns["c_contact_ids[1]"][0] == 2


def test_frames_count_ids_and_shapes(frames):
    assert [f.step for f in frames] == STEPS
    assert [f.time for f in frames] == pytest.approx([4.5, 5.0, 5.5])
    for frame in frames:
        assert frame.dim == 3 and frame.n == 216 and frame.box.periodic == (True, True, True)
        np.testing.assert_array_equal(frame.id, np.arange(1, 217))
        assert set(np.unique(frame.type)) == {1, 2}
        for array in (frame.position, frame.velocity, frame.omega, frame.extra["force"]):
            assert array.shape == (216, 3) and np.isfinite(array).all()
        assert frame.radius.min() >= 0.4 and frame.radius.max() <= 0.6
        contacts = frame.contacts
        m = len(contacts.i)
        assert m > 700 and contacts.force.shape == contacts.branch.shape == (m, 3)
        assert (contacts.kind == PAIR).all() and contacts.i.dtype == np.int64
        assert np.isin(contacts.i, frame.id).all() and np.isin(contacts.j, frame.id).all()
        pairs = {tuple(sorted(p)) for p in zip(contacts.i, contacts.j)}
        assert len(pairs) == m  # each contact once


def test_mass_column_is_the_sphere_mass(frames):
    """The dumped masses are those of density-1 spheres; density= gives the same."""
    np.testing.assert_allclose(frames[0].mass, 4 / 3 * np.pi * frames[0].radius**3, rtol=1e-7)
    by_density = frames_from_lammps(ATOMS, CONTACTS, columns={"mass": None}, density=1.0)
    np.testing.assert_allclose(by_density[0].mass, frames[0].mass, rtol=1e-7)


def test_branch_is_minimum_image_of_positions(frames):
    """branch = r_i - r_j (minimum image); LAMMPS's own x_I - x_J columns agree."""
    with_columns = frames_from_lammps(ATOMS, CONTACTS, columns={"branch": BRANCH_COLUMNS})
    for frame, other in zip(frames, with_columns):
        index = {atom: row for row, atom in enumerate(frame.id)}
        i = np.array([index[a] for a in frame.contacts.i])
        j = np.array([index[a] for a in frame.contacts.j])
        lengths = frame.box.lengths
        expected = frame.position[i] - frame.position[j]
        expected -= lengths * np.round(expected / lengths)
        assert np.abs(expected).max() < 0.5 * lengths.min()
        np.testing.assert_allclose(frame.contacts.branch, expected, rtol=0, atol=1e-12)
        size = np.linalg.norm(expected, axis=1, keepdims=True)
        np.testing.assert_allclose(other.contacts.branch / size, expected / size, atol=1e-6)
        # some contacts cross the periodic boundary
        raw = frame.position[i] - frame.position[j]
        assert (np.abs(raw) > 0.5 * lengths).any()
        # grains overlap: |branch| < r_i + r_j
        assert (size[:, 0] < frame.radius[i] + frame.radius[j]).all()


def test_contact_forces_sum_to_per_atom_force(frames):
    """Sum of contact forces on each grain = its dumped force: full force, right sign."""
    for frame in frames:
        unbalanced = np.abs(unbalanced_force(frame)).max()
        assert unbalanced < 1e-6 * np.abs(frame.contacts.force).max()  # the dump precision
        assert unbalanced < 1e-3 * np.abs(frame.extra["force"]).max()


def test_normal_part_alone_does_not_balance():
    """pair/local fx fy fz of a granular style are the normal force only (p1-p3 needed)."""
    normal_only = frames_from_lammps(ATOMS, CONTACTS, columns={"tangential": None})
    for frame in normal_only:
        contacts = frame.contacts
        scale = np.abs(contacts.force).max()
        assert np.abs(unbalanced_force(frame)).max() > 0.1 * scale
        # ... and it is central and repulsive: along +branch (from j to i)
        cosine = np.sum(contacts.force * contacts.branch, axis=1) / (
            np.linalg.norm(contacts.force, axis=1) * np.linalg.norm(contacts.branch, axis=1))
        assert cosine.min() > 1 - 1e-9


def test_custom_column_names_and_dim_2(tmp_path):
    """A hand-made 2D pair: z dropped, disk-area mass, minimum image on the periodic x only."""
    atoms = tmp_path / "atoms.dump"
    atoms.write_text(
        "ITEM: TIMESTEP\n10\nITEM: NUMBER OF ATOMS\n3\nITEM: BOX BOUNDS pp ff pp\n"
        "0 10\n0 5\n-0.5 0.5\nITEM: ATOMS id x y z radius fx fy fz\n"
        "7 9.6 1 0 0.5 1 2 0\n3 0.2 1.5 0 0.5 -1 -2 0\n5 5 4 0 0.25 0 0 0\n")
    local = tmp_path / "pairs.dump"
    local.write_text(
        "ITEM: TIMESTEP\n10\nITEM: NUMBER OF BONDS\n1\nITEM: BOX BOUNDS pp ff pp\n"
        "0 10\n0 5\n-0.5 0.5\nITEM: BONDS a b f1 f2 f3\n7 3 1 2 0\n")
    (frame,) = frames_from_lammps(
        atoms, local, dim=2, density=2.0, timestep=0.5,
        columns={"i": "a", "j": "b", "force": ("f1", "f2", "f3"), "tangential": None})
    assert frame.time == 5.0 and frame.box.periodic == (True, False)
    np.testing.assert_array_equal(frame.id, [3, 5, 7])
    np.testing.assert_allclose(frame.position, [[0.2, 1.5], [5, 4], [9.6, 1]])
    np.testing.assert_allclose(frame.mass, 2.0 * np.pi * np.array([0.25, 0.0625, 0.25]))
    assert np.isnan(frame.velocity).all() and frame.velocity.shape == (3, 2)
    assert np.isnan(frame.omega).all() and frame.omega.shape == (3, 3)
    np.testing.assert_allclose(frame.contacts.branch, [[-0.6, -0.5]])
    np.testing.assert_allclose(frame.contacts.force, [[1, 2]])
    np.testing.assert_allclose(unbalanced_force(frame), 0.0)


# --- malformed input --------------------------------------------------------------------


@pytest.mark.parametrize("line, text, message", [
    (FIRST_ROW + 5, "2 95 1.0 2.0", "ENTRIES row has 4 values, expected 11"),
    (FIRST_ROW + 5, "2 95 1 2 3 4 5 6 7 8 x", "not a number"),
    (4, "22500.5", "expected the timestep"),
    (5, "ITEM: NUMBER ENTRIES", "expected 'ITEM: NUMBER OF'"),
    (8, "0.0", "box bounds has 1 values"),
    (1, "ITEM: SOMETHING", "unexpected line"),
])
def test_malformed_local_dump_names_the_line(tmp_path, line, text, message):
    def edit(lines):
        lines[line - 1] = text
    path = write_copy(tmp_path, CONTACTS, edit)
    with pytest.raises(ValueError, match=f"contacts.dump:{line}: .*{message}"):
        read_lammps_local(path)


def test_truncated_local_dump(tmp_path):
    path = write_copy(tmp_path, CONTACTS, lambda lines: lines.__delitem__(slice(100, None)))
    with pytest.raises(ValueError, match=f"ends after line 100; expected 709 ENTRIES rows "
                                         f"from line {FIRST_ROW}"):
        read_lammps_local(path)


def test_step_missing_from_one_file(tmp_path):
    blocks = CONTACTS.read_text().split("ITEM: TIME\n")
    path = tmp_path / "contacts.dump"
    path.write_text("".join("ITEM: TIME\n" + b for b in blocks[1:3]))  # drop step 27500
    with pytest.raises(ValueError, match="step 27500 is in .*atoms.dump but not in"):
        frames_from_lammps(ATOMS, path)


def test_missing_tangential_columns_are_explained():
    with pytest.raises(ValueError, match="only the normal force: add p1 p2 p3"):
        frames_from_lammps(ATOMS, CONTACTS, columns={"tangential": ("c_x[1]", "c_x[2]", "c_x[3]")})


def test_flipped_branch_columns_are_refused(tmp_path):
    def flip(lines):
        for k in range(FIRST_ROW - 1, FIRST_ROW - 1 + 709):
            values = lines[k].split()
            values[8:11] = [str(-float(v)) for v in values[8:11]]
            lines[k] = " ".join(values)
    path = write_copy(tmp_path, CONTACTS, flip)
    with pytest.raises(ValueError, match="step 22500: branch columns .*it is x_j - x_i"):
        frames_from_lammps(ATOMS, path, columns={"branch": BRANCH_COLUMNS})


def test_contact_with_unknown_atom(tmp_path):
    def edit(lines):
        lines[FIRST_ROW - 1] = "999 " + lines[FIRST_ROW - 1].split(maxsplit=1)[1]
    path = write_copy(tmp_path, CONTACTS, edit)
    with pytest.raises(ValueError, match="step 22500: contact atom id 999 is not among the atoms"):
        frames_from_lammps(ATOMS, path)


@pytest.mark.parametrize("kwargs, message", [
    ({"density": 1.0}, "has a 'mass' column and density=1.0 was given"),
    ({"columns": {"mass": None}}, "no mass"),
    ({"dim": 2}, "dim=2 but the atoms' z spans"),
    ({"columns": {"velocty": ("vx", "vy", "vz")}}, "unknown name 'velocty'"),
    ({"columns": {"position": "x"}}, "'position' must be a tuple of 3 column names"),
    ({"columns": {"i": None}}, "'i' is required"),
    ({"columns": {"position": ("xu", "yu", "zu")}}, "atom dump has no column 'xu'"),
])
def test_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        frames_from_lammps(ATOMS, CONTACTS, **kwargs)
