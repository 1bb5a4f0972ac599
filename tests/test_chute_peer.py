"""Agreement with LAMMPS on its granular chute benchmark, and the LAMMPS data reader.

The chute run (the files shipped in ``grainflow/data/chute``: 32,000 spheres,
``gran/hooke/history``, 100 steps) must reproduce the kinetic and rotational kinetic energies
of LAMMPS's own log at steps 0 and 100 to 5e-8 relative (the log prints 8 significant
digits); the numbers are read from the log, not copied here.
"""

from __future__ import annotations

import gzip
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

from conftest import PEERS
from grainflow.io.lammps_data import read_lammps_data, state_from_lammps_data
from grainflow.scenarios.chute import CHUTE, chute_files

DATA, DECK, LOG = chute_files()


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
    from grainflow.scenarios.chute import chute_simulation

    ref = parse_thermo(LOG)
    assert {0, 100} <= set(ref), f"log has steps {sorted(ref)}"
    sim = chute_simulation()  # the shipped data.chute.gz
    st = sim.state
    # the log prints 8 significant digits: 5e-8 allows for its rounding (measured: <= 2e-8)
    assert st.n == int(ref[0]["Atoms"])
    assert st.kinetic_energy() == pytest.approx(ref[0]["KinEng"], rel=5e-8)
    assert st.rotational_energy() == pytest.approx(ref[0]["c_1"], rel=5e-8)
    sim.run(100)
    assert sim.step == 100
    assert st.kinetic_energy() == pytest.approx(ref[100]["KinEng"], rel=5e-8)
    assert st.rotational_energy() == pytest.approx(ref[100]["c_1"], rel=5e-8)
    # the frozen base did not move
    assert np.all(st.v[st.frozen] == 0.0)


def test_parse_thermo_reads_reference_log():
    ref = parse_thermo(LOG)
    assert set(ref) == {0, 100}
    assert set(ref[0]) == {"Step", "Atoms", "KinEng", "c_1", "Volume"}
    assert ref[0]["KinEng"] > 0 and ref[100]["c_1"] > 0


def test_benchmark_files_ship_with_the_package():
    assert PEERS == DATA.parent
    assert {p.name for p in PEERS.iterdir()} >= {DATA.name, DECK.name, LOG.name, "README.md"}
    assert PEERS.parts[-3:] == ("grainflow", "data", "chute")


def _deck_commands(path: Path) -> dict[str, list[list[str]]]:
    """LAMMPS input commands: {command: [arguments of each occurrence]}, comments dropped."""
    commands: dict[str, list[list[str]]] = {}
    for line in path.read_text().splitlines():
        words = line.split("#", 1)[0].split()
        if words:
            commands.setdefault(words[0], []).append(words[1:])
    return commands


def test_scenario_uses_the_decks_parameters():
    """The shipped in.chute is the model the chute scenario (CHUTE) implements."""
    deck = _deck_commands(DECK)
    assert deck["read_data"] == [["data.chute"]]
    assert deck["boundary"] == [["p", "p", "fs"]]
    # pair_style gran/hooke/history kn kt gamma_n gamma_t mu dampflag
    (style, kn, kt, gamma_n, gamma_t, mu, dampflag), = deck["pair_style"]
    assert style == "gran/hooke/history"
    assert float(kn) == CHUTE["kn"] and kt == "NULL"  # kt = 2/7 kn, grainflow's default
    assert float(gamma_n) == CHUTE["gamma_n"] and gamma_t == "NULL"
    assert dampflag == "0"  # no tangential damping: the scenario sets gamma_t = 0
    assert float(mu) == CHUTE["mu"]
    assert float(deck["timestep"][0][0]) == CHUTE["dt"]
    assert deck["neighbor"] == [[str(CHUTE["skin"]), "bin"]]
    gravity = next(f for f in deck["fix"] if f[2] == "gravity")
    assert gravity[3:] == ["1.0", "chute", str(CHUTE["angle"])]
    assert ["bottom", "type", "2"] in deck["group"]  # type 2 is the frozen base
    assert ["2", "bottom", "freeze"] in deck["fix"]
    assert deck["run"] == [["100"]]


def test_chute_config_defaults_to_the_shipped_data():
    """``examples/chute.toml`` names no data file: the scenario reads the shipped copy."""
    from grainflow.config.build import build_simulation
    from grainflow.config.schema import load_config

    example = Path(__file__).resolve().parents[1] / "examples" / "chute.toml"
    config = load_config(example)
    assert Path(config.section.data_file) == DATA.resolve()
    assert load_config({"scenario": "chute", "run": {"steps": 1}}).section.data_file == \
        config.section.data_file
    sim = build_simulation(config)
    assert sim.state.n == 32000 and sim.dt == CHUTE["dt"]


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


def test_reader_reads_gzip_files(tmp_path):
    text = textwrap.dedent(HEADER + ATOMS_IMAGES + VELOCITIES)
    plain = read_lammps_data(_write(tmp_path, text))
    packed = tmp_path / "test.data.gz"
    packed.write_bytes(gzip.compress(text.encode()))
    d = read_lammps_data(packed)
    for name in ("lo", "hi", "id", "type", "diameter", "density", "x", "image", "v", "omega"):
        np.testing.assert_array_equal(getattr(d, name), getattr(plain, name))


@pytest.mark.parametrize("case", ["not_data", "count_mismatch", "truncated", "binary"])
def test_reader_bad_gzip_files_name_the_file(tmp_path, case):
    path = tmp_path / f"{case}.data.gz"
    if case == "truncated":
        path.write_bytes(gzip.compress(textwrap.dedent(HEADER + ATOMS_PLAIN).encode())[:-20])
    elif case == "binary":
        path.write_bytes(gzip.compress(bytes(range(256))))
    else:
        path.write_bytes(gzip.compress(textwrap.dedent(BAD_FILES[case][0]).encode()))
    with pytest.raises(ValueError) as info:
        read_lammps_data(path)
    assert path.name in str(info.value), str(info.value)


def test_reader_import_paths():
    """The reader lives in grainflow.insertion; grainflow.io and grainflow re-export it."""
    import grainflow
    import grainflow.insertion.lammps_data as low
    from grainflow.io import read_lammps_data as from_io

    assert read_lammps_data is low.read_lammps_data is from_io is grainflow.read_lammps_data
    assert state_from_lammps_data is grainflow.state_from_lammps_data


def test_reader_reads_the_chute_file_header():
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


def test_a_written_data_file_reads_back_exactly(tmp_path) -> None:
    """write_lammps_data (the size benchmark hands LAMMPS the cut chutes with it) and
    read_lammps_data round-trip every number bit for bit; the cut keeps its box and ids."""
    from grainflow.insertion.lammps_data import write_lammps_data
    from grainflow.scenarios.chute import chute_cut, chute_cut_data

    data = chute_cut_data(0.25, 0.16)
    data.image[::7] = [1, -2, 0]  # image flags survive too
    back = read_lammps_data(write_lammps_data(tmp_path / "data.cut", data, n_types=2))
    for name in ("lo", "hi", "id", "type", "diameter", "density", "x", "image", "v", "omega"):
        assert np.array_equal(getattr(back, name), getattr(data, name)), name
    assert 1000 < data.id.size < 1100
    assert np.allclose(data.hi[:2] - data.lo[:2], [10.0, 3.2])
    assert chute_cut(0.25, 0.16).state.n == data.id.size
