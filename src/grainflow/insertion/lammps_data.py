"""Reader and writer of LAMMPS data files with ``atom_style sphere``.

Atoms line: ``id type diameter density x y z [ix iy iz]``; Velocities line:
``id vx vy vz wx wy wz``. The style is read from the comment of the ``Atoms`` line
(``Atoms # sphere``, as LAMMPS writes it); any other style is refused. Without a comment the
style is inferred from the column count: 7 or 10 columns are read as sphere (``full`` has
as many; write ``Atoms # sphere`` to be explicit), other counts are refused with the styles
they suggest. Atom ids must be unique. Mass is ``density * pi d^3 / 6`` (3D), as LAMMPS computes it
(a diameter of 0 would be a point particle and is refused). Only orthogonal boxes are read.
Gzip-compressed files (``data.chute.gz``) are read as they are: compression is recognised by
the file's first bytes, not its name.

:func:`write_lammps_data` writes the same format with every number to full precision
(``repr``), so LAMMPS and grainflow start a benchmark from bitwise the same state.

Reading particles from a data file is a kind of fill, so the reader lives in
:mod:`grainflow.insertion` (scenarios may use it); :mod:`grainflow.io.lammps_data`
re-exports it.
"""

from __future__ import annotations

import gzip
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grainflow.frame import Box
from grainflow.state import ParticleState


@dataclass
class LammpsData:
    """Contents of a data file, sorted by atom id."""

    lo: np.ndarray
    hi: np.ndarray
    id: np.ndarray
    type: np.ndarray
    diameter: np.ndarray
    density: np.ndarray
    x: np.ndarray
    image: np.ndarray
    v: np.ndarray
    omega: np.ndarray


def read_lammps_data(path: str | Path) -> LammpsData:
    """Parse a LAMMPS ``atom_style sphere`` data file, plain or gzip-compressed."""
    path = Path(path)
    lines = _read_text(path).splitlines()
    lo = np.zeros(3)
    hi = np.zeros(3)
    natoms = None
    tilted = False
    sections: dict[str, list[str]] = {}
    line_numbers: dict[str, list[int]] = {}
    style = None
    current = None
    for number, raw in enumerate(lines[1:], start=2):
        line, _, comment = (part.strip() for part in raw.partition("#"))
        if not line:
            continue
        words = line.split()
        if current is None or words[0] in ("Atoms", "Velocities", "Masses", "Bonds"):
            try:
                if line.endswith("atoms") and len(words) == 2:
                    natoms = int(words[0])
                    continue
                if line.endswith("xy xz yz"):
                    tilted = True
                for a, tag in enumerate(("xlo xhi", "ylo yhi", "zlo zhi")):
                    if line.endswith(tag):
                        lo[a], hi[a] = float(words[0]), float(words[1])
            except ValueError:
                raise ValueError(f"{path}, line {number}: '{line}' is not a valid header line "
                                 "(a number is expected first)") from None
            if words[0] in ("Atoms", "Velocities", "Masses", "Bonds"):
                current = words[0]
                sections[current] = []
                line_numbers[current] = []
                if current == "Atoms":
                    style = (comment.split() or [None])[0]
            continue
        if words[0][0].isalpha():
            current = words[0]
            sections[current] = []
            line_numbers[current] = []
            continue
        sections[current].append(line)
        line_numbers[current].append(number)
    if natoms is None or "Atoms" not in sections:
        raise ValueError(f"{path}: not a LAMMPS data file (no atom count or Atoms section)")
    if tilted:
        raise ValueError(f"{path}: triclinic box (xy xz yz line); only orthogonal boxes are "
                         "read: write the data file from an orthogonal region")
    atoms = _numeric_table(path, "Atoms", sections["Atoms"])
    _check_style(path, style, atoms.shape[1])
    if atoms.shape[0] != natoms:
        raise ValueError(f"{path}: header says {natoms} atoms, Atoms section has "
                         f"{atoms.shape[0]}")
    _check_unique_ids(path, atoms[:, 0], line_numbers["Atoms"])
    order = np.argsort(atoms[:, 0])
    atoms = atoms[order]
    image = atoms[:, 7:10].astype(np.int64) if atoms.shape[1] == 10 else np.zeros((natoms, 3),
                                                                               dtype=np.int64)
    v = np.zeros((natoms, 3))
    omega = np.zeros((natoms, 3))
    if "Velocities" in sections:
        vel = _numeric_table(path, "Velocities", sections["Velocities"])
        if vel.shape[1] != 7:
            raise ValueError(f"{path}: Velocities lines have {vel.shape[1]} columns; atom_style "
                             "sphere needs 7 (id vx vy vz wx wy wz)")
        index = {int(a): k for k, a in enumerate(atoms[:, 0])}
        unknown = [int(a) for a in vel[:, 0] if int(a) not in index]
        if unknown:
            raise ValueError(f"{path}: Velocities section names atom id(s) {unknown[:5]} that "
                             "the Atoms section does not have")
        rows = np.array([index[int(a)] for a in vel[:, 0]], dtype=np.int64)
        v[rows] = vel[:, 1:4]
        omega[rows] = vel[:, 4:7]
    diameter = atoms[:, 2]
    if np.any(diameter <= 0):
        bad = int(np.argmax(diameter <= 0))
        kind = "point particles (diameter 0)" if diameter[bad] == 0 else "negative diameters"
        raise ValueError(f"{path}: atom id {int(atoms[bad, 0])} has diameter {diameter[bad]:g}: "
                         f"{kind} are not supported")
    return LammpsData(lo=lo, hi=hi, id=atoms[:, 0].astype(np.int64),
                      type=atoms[:, 1].astype(np.int32), diameter=diameter, density=atoms[:, 3],
                      x=atoms[:, 4:7], image=image, v=v, omega=omega)


def write_lammps_data(path: str | Path, data: LammpsData, n_types: int | None = None,
                      title: str = "written by grainflow") -> Path:
    """Write ``data`` as an ``atom_style sphere`` data file (Atoms with image flags, and
    Velocities); ``n_types``: the ``atom types`` count (default: the largest type).
    :func:`read_lammps_data` reads it back exactly."""
    path = Path(path)
    n = int(data.id.shape[0])
    types = int(data.type.max()) if n else 1
    n_types = types if n_types is None else int(n_types)
    if n_types < types:
        raise ValueError(f"n_types: {n_types} is less than the largest atom type {types}")
    lines = [f"LAMMPS data file {title}", "", f"{n} atoms", f"{n_types} atom types", ""]
    for a, tag in enumerate(("xlo xhi", "ylo yhi", "zlo zhi")):
        lines.append(f"{float(data.lo[a])!r} {float(data.hi[a])!r} {tag}")
    lines += ["", "Atoms # sphere", ""]
    for k in range(n):
        x = data.x[k]
        im = data.image[k]
        lines.append(f"{int(data.id[k])} {int(data.type[k])} {float(data.diameter[k])!r} "
                     f"{float(data.density[k])!r} {float(x[0])!r} {float(x[1])!r} "
                     f"{float(x[2])!r} {int(im[0])} {int(im[1])} {int(im[2])}")
    lines += ["", "Velocities", ""]
    for k in range(n):
        v, w = data.v[k], data.omega[k]
        lines.append(f"{int(data.id[k])} " + " ".join(repr(float(c)) for c in (*v, *w)))
    path.write_text("\n".join(lines) + "\n")
    return path


#: Columns of an Atoms line (without the 3 image flags) of LAMMPS's common atom styles.
STYLE_COLUMNS = {"atomic": 5, "charge": 6, "bond": 6, "angle": 6, "molecular": 6, "full": 7,
                 "sphere": 7, "ellipsoid": 7, "dipole": 9}


def _check_style(path: Path, style: str | None, columns: int) -> None:
    """Refuse an Atoms section of another style than sphere: the style named by the comment
    of the ``Atoms`` line, else the one the column count suggests."""
    sphere = "atom_style sphere: id type diameter density x y z, optionally + ix iy iz"
    if style is not None:
        if style != "sphere":
            raise ValueError(f"{path}: the Atoms section is atom_style {style!r} ('Atoms # "
                             f"{style}'); only {sphere} is read: write the data file with "
                             "atom_style sphere")
        if columns not in (7, 10):
            raise ValueError(f"{path}: Atoms lines have {columns} columns; {sphere} (7 or 10)")
        return
    if columns in (7, 10):
        return  # sphere's count (full and ellipsoid have as many; the comment would say)
    guesses = sorted(s for s, n in STYLE_COLUMNS.items() if columns in (n, n + 3))
    suggests = (f"which suggests atom_style {' or '.join(guesses)}" if guesses else
                "which matches no common atom style")
    raise ValueError(f"{path}: Atoms lines have {columns} columns and the Atoms line names no "
                     f"style (no '# style' comment), {suggests}; only {sphere} (7 or 10 "
                     "columns) is read: write the data file with atom_style sphere")


def _check_unique_ids(path: Path, ids: np.ndarray, line_numbers: list[int]) -> None:
    """Refuse an atom id that two Atoms lines share, naming both lines."""
    first: dict[int, int] = {}
    for atom_id, number in zip(ids.astype(np.int64).tolist(), line_numbers):
        if atom_id in first:
            raise ValueError(f"{path}: atom id {atom_id} appears twice in the Atoms section, "
                             f"on lines {first[atom_id]} and {number}; atom ids must be unique")
        first[atom_id] = number


def _read_text(path: Path) -> str:
    """The file's text, decompressed if it is gzip; unreadable content names the file."""
    raw = path.read_bytes()
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError, zlib.error) as exc:
            raise ValueError(f"{path}: damaged gzip file ({exc})") from None
    try:
        return raw.decode()
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a LAMMPS data file (not text)") from None


def _numeric_table(path: Path, section: str, rows: list[str]) -> np.ndarray:
    """The lines of one section as a float table; ragged or non-numeric lines are named."""
    counts = [len(r.split()) for r in rows]
    if len(set(counts)) > 1:
        width = max(set(counts), key=counts.count)  # the most common line length
        bad, n_bad = next((r, c) for r, c in zip(rows, counts) if c != width)
        raise ValueError(f"{path}: {section} line '{bad}' has {n_bad} columns, the others "
                         f"{width}")
    try:
        return np.array([r.split() for r in rows], dtype=float).reshape(len(rows), -1)
    except ValueError as exc:
        raise ValueError(f"{path}: {section} section has a non-numeric entry ({exc})") from None


def state_from_lammps_data(data: LammpsData, periodic: tuple[bool, bool, bool],
                           type_offset: int = 1) -> ParticleState:
    """Build a 3D :class:`ParticleState`; LAMMPS types 1.. become 0.. (``type_offset``)."""
    box = Box(lo=data.lo.copy(), hi=data.hi.copy(), periodic=tuple(periodic))
    st = ParticleState(3, box)
    st.add_particles(data.x, 0.5 * data.diameter, density=data.density, v=data.v,
                     omega=data.omega, type=data.type - type_offset, ids=data.id)
    st.image[:] = data.image
    return st
