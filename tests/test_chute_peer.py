"""Agreement with LAMMPS on its granular chute benchmark, and the LAMMPS data reader.

The chute run (``../shared/peers``: 32,000 spheres, ``gran/hooke/history``, 100 steps) must
reproduce the kinetic and rotational kinetic energies of LAMMPS's own log at steps 0 and
100 to 1e-6 relative; the numbers are read from the log, not copied here.
"""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

from conftest import PEERS
from grainflow.io.lammps_data import read_lammps_data, state_from_lammps_data

DATA = PEERS / "data.chute"
LOG = PEERS / "log.6Oct16.chute.fixed.icc.1.upstream_reference"


def parse_thermo(path: Path) -> dict[int, dict[str, float]]:
    """Thermo rows of a LAMMPS log: {step: {column: value}} for every 'Step ...' block."""
    rows: dict[int, dict[str, float]] = {}
    header = None
    for line in path.read_text().splitlines():
        words = line.split()
        if words and words[0] == "Step":
            header = words
            continue
        if header is not None:
            if len(words) == len(header) and re.fullmatch(r"-?\d+", words[0]):
                rows[int(words[0])] = {h: float(w) for h, w in zip(header, words)}
            else:
                header = None
    return rows


@pytest.mark.usefixtures("numba_one_thread")
def test_chute_matches_lammps_log():
    if not (DATA.is_file() and LOG.is_file()):
        pytest.skip(f"LAMMPS chute benchmark files not found in {PEERS} "
                    "(data.chute and the upstream reference log)")
    from grainflow.scenarios.chute import chute_simulation

    ref = parse_thermo(LOG)
    assert {0, 100} <= set(ref), f"log has steps {sorted(ref)}"
    sim = chute_simulation(DATA)
    st = sim.state
    assert st.n == int(ref[0]["Atoms"])
    assert st.kinetic_energy() == pytest.approx(ref[0]["KinEng"], rel=1e-6)
    assert st.rotational_energy() == pytest.approx(ref[0]["c_1"], rel=1e-6)
    sim.run(100)
    assert sim.step == 100
    assert st.kinetic_energy() == pytest.approx(ref[100]["KinEng"], rel=1e-6)
    assert st.rotational_energy() == pytest.approx(ref[100]["c_1"], rel=1e-6)
    # the frozen base did not move
    assert np.all(st.v[st.frozen] == 0.0)


def test_parse_thermo_reads_reference_log():
    if not LOG.is_file():
        pytest.skip(f"LAMMPS reference log not found in {PEERS}")
    ref = parse_thermo(LOG)
    assert set(ref) == {0, 100}
    assert set(ref[0]) == {"Step", "Atoms", "KinEng", "c_1", "Volume"}
    assert ref[0]["KinEng"] > 0 and ref[100]["c_1"] > 0


# ---------------------------------------------------------------------- data reader
HEADER = """\
LAMMPS data file written by hand

3 atoms
2 atom types

-1.0 4.0 xlo xhi
0.0 5.0 ylo yhi
0.5 6.0 zlo zhi
"""

ATOMS_IMAGES = """
Atoms # sphere

3 2 1.5 2.0 3.0 3.5 4.0 1 -2 0
1 1 1.0 1.0 0.5 1.0 1.5 0 0 0
2 1 0.8 3.0 1.5 2.0 2.5 -1 0 3
"""

ATOMS_PLAIN = """
Atoms # sphere

1 1 1.0 1.0 0.5 1.0 1.5
2 1 0.8 3.0 1.5 2.0 2.5
3 2 1.5 2.0 3.0 3.5 4.0
"""

VELOCITIES = """
Velocities

2 0.1 0.2 0.3 1.0 2.0 3.0
3 -1 -2 -3 -4 -5 -6
1 7 8 9 10 11 12
"""


def _write(tmp_path: Path, text: str, name: str = "test.data") -> Path:
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def test_reader_with_images_and_velocities(tmp_path):
    d = read_lammps_data(_write(tmp_path, HEADER + ATOMS_IMAGES + VELOCITIES))
    np.testing.assert_array_equal(d.lo, [-1.0, 0.0, 0.5])
    np.testing.assert_array_equal(d.hi, [4.0, 5.0, 6.0])
    np.testing.assert_array_equal(d.id, [1, 2, 3])  # sorted by id
    np.testing.assert_array_equal(d.type, [1, 1, 2])
    np.testing.assert_array_equal(d.diameter, [1.0, 0.8, 1.5])
    np.testing.assert_array_equal(d.density, [1.0, 3.0, 2.0])
    np.testing.assert_array_equal(d.x, [[0.5, 1.0, 1.5], [1.5, 2.0, 2.5], [3.0, 3.5, 4.0]])
    np.testing.assert_array_equal(d.image, [[0, 0, 0], [-1, 0, 3], [1, -2, 0]])
    # velocities matched by id, not by line order
    np.testing.assert_array_equal(d.v, [[7, 8, 9], [0.1, 0.2, 0.3], [-1, -2, -3]])
    np.testing.assert_array_equal(d.omega, [[10, 11, 12], [1, 2, 3], [-4, -5, -6]])
    st = state_from_lammps_data(d, (True, True, False))
    assert st.dim == 3 and st.box.periodic == (True, True, False)
    np.testing.assert_array_equal(st.type, [0, 0, 1])
    np.testing.assert_array_equal(st.id, [1, 2, 3])
    np.testing.assert_allclose(st.radius, [0.5, 0.4, 0.75])
    # LAMMPS: mass = density * pi d^3 / 6, I = 0.4 m r^2
    mass = np.array([1.0, 3.0, 2.0]) * np.pi * np.array([1.0, 0.8, 1.5]) ** 3 / 6
    np.testing.assert_allclose(st.mass, mass, rtol=1e-14)
    np.testing.assert_allclose(st.inertia, 0.4 * mass * st.radius**2, rtol=1e-14)
    np.testing.assert_array_equal(st.image, d.image)
    np.testing.assert_array_equal(st.v, d.v)
    np.testing.assert_array_equal(st.omega, d.omega)


def test_reader_without_images_or_velocities(tmp_path):
    d = read_lammps_data(_write(tmp_path, HEADER + ATOMS_PLAIN))
    np.testing.assert_array_equal(d.id, [1, 2, 3])
    np.testing.assert_array_equal(d.image, np.zeros((3, 3)))
    np.testing.assert_array_equal(d.v, np.zeros((3, 3)))
    np.testing.assert_array_equal(d.omega, np.zeros((3, 3)))
    np.testing.assert_array_equal(d.x[2], [3.0, 3.5, 4.0])


def test_reader_reads_the_chute_file_header():
    if not DATA.is_file():
        pytest.skip(f"data.chute not found in {PEERS}")
    d = read_lammps_data(DATA)
    assert d.id.shape[0] == 32000
    np.testing.assert_allclose(d.hi - d.lo, [40.0, 20.0, 37.2886])
    assert set(np.unique(d.type).tolist()) == {1, 2}
    assert np.any(d.image != 0) and np.any(d.v != 0)


BAD_FILES = {
    "count_mismatch": (HEADER.replace("3 atoms", "4 atoms") + ATOMS_PLAIN, "header says 4"),
    "wrong_columns": (HEADER + ATOMS_PLAIN.replace("1 1 1.0 1.0 0.5 1.0 1.5",
                                                   "1 1 1.0 1.0 0.5 1.0 1.5 0")
                      .replace("2 1 0.8 3.0 1.5 2.0 2.5", "2 1 0.8 3.0 1.5 2.0 2.5 0")
                      .replace("3 2 1.5 2.0 3.0 3.5 4.0", "3 2 1.5 2.0 3.0 3.5 4.0 0"),
                      "columns"),
    "no_atoms": (HEADER, "not a LAMMPS data file"),
    "not_data": ("just some text\nwith words\n", "not a LAMMPS data file"),
    "zero_diameter": (HEADER + ATOMS_PLAIN.replace("2 1 0.8 3.0", "2 1 0.0 3.0"),
                      "point particles"),
    # one line cut short: the error must name the file, not be a numpy shape message
    "ragged_line": (HEADER + ATOMS_PLAIN.replace("3 2 1.5 2.0 3.0 3.5 4.0", "3 2 1.5 2.0 3.0"),
                    None),
    "non_numeric": (HEADER + ATOMS_PLAIN.replace("2.0 2.5\n", "2.0 abc\n"), None),
    # a triclinic box: the reader is documented to read orthogonal boxes only
    "triclinic": (HEADER + "0.5 0.0 0.0 xy xz yz\n" + ATOMS_PLAIN, None),
    # velocities for an atom that does not exist
    "velocity_unknown_id": (HEADER + ATOMS_PLAIN + VELOCITIES.replace("3 -1 -2", "9 -1 -2"),
                            None),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_reader_bad_files_give_clear_errors(tmp_path, case):
    text, message = BAD_FILES[case]
    path = _write(tmp_path, text, name=f"{case}.data")
    with pytest.raises(ValueError) as info:
        read_lammps_data(path)
    # a clear error names the file and what is wrong with it
    assert path.name in str(info.value), str(info.value)
    if message is not None:
        assert message in str(info.value)
