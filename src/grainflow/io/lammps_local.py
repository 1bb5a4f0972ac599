"""Frames with contacts from LAMMPS: a per-atom dump plus a ``dump local`` of every contact.

The defaults of :func:`frames_from_lammps` expect these lines in the LAMMPS input deck
(``tests/data/lammps_cg/deck.in`` is a complete example)::

    compute contact_ids all property/local patom1 patom2 cutoff radius
    compute contact_forces all pair/local fx fy fz p1 p2 p3 cutoff radius
    dump atoms all custom N atoms.dump id type radius mass x y z vx vy vz &
         omegax omegay omegaz fx fy fz
    dump contacts all local N contacts.dump c_contact_ids[1] c_contact_ids[2] &
         c_contact_forces[1] c_contact_forces[2] c_contact_forces[3] &
         c_contact_forces[4] c_contact_forces[5] c_contact_forces[6]
    dump_modify atoms time yes
    dump_modify contacts time yes

What the columns hold (LAMMPS manual pages of ``compute pair/local``, ``compute
property/local`` and the granular pair styles, checked on the fixture made with LAMMPS
29 Sep 2021):

* ``patom1 patom2``: the ids of atoms i and j of each pair, in the neighbour-list order that
  ``pair/local`` also follows, so the rows of the two computes match when both use the same
  ``cutoff``; each pair is listed once.
* ``fx fy fz`` (quoting the current manual): "the force vector on the first atom i of a
  pair in the neighbor list due to the second atom j", i.e. ``fpair * (x_i - x_j)``. For
  granular pair styles (``gran/hooke``, ``gran/hooke/history``, ``gran/hertz/history``,
  ``granular``) "these values only include the (x,y,z) components of the normal force
  component": their single() "returns only the normal component of the pairwise
  interaction force".
* ``p1 p2 p3`` of those granular styles: "the components of the tangential force between
  particles I and J, acting on particle I". The full contact force is ``fx + p1``, ``fy +
  p2``, ``fz + p3``: the ``force`` plus ``tangential`` columns here. For a pair style with
  central forces pass ``columns={"tangential": None}``; a style whose single() leaves part
  of the force out and offers no ``pN`` for it does not record the full force, which
  :func:`unbalanced_force` shows.
* Branch vectors are ``x_i - x_j`` from the atom positions (minimum image on periodic
  axes). ``pair/local dx dy dz`` (absent in 29 Sep 2021) are ``x_i - x_j`` only from LAMMPS
  12 Jun 2025 on; earlier their sign followed the atom ids, not the order of ``fx fy fz``.
  ``pair_style granular``'s ``p10 p11 p12`` are ``x_I - x_J``. Branch columns named in
  ``columns`` are checked against the positions.

pair/local calls single() when the dump is written, with the positions and velocities of that
moment. In a dump written during a run these are not the ones the forces were computed with
(velocity Verlet has moved v on by half a step; ``fix deform`` has remapped x), so damped or
deforming systems give contact forces that differ slightly (about 5e-4 of the largest force
in the sheared fixture deck) from those that made the dumped per-atom forces. Snapshots
written by a ``run 0`` agree to the dump precision.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grainflow.frame import PAIR, Box, Contacts, Frame
from grainflow.io.lammps_dump import DumpFrame, read_lammps_dump

__all__ = ["DEFAULT_COLUMNS", "LocalBlock", "frames_from_lammps", "read_lammps_local",
           "unbalanced_force"]

#: Our names -> LAMMPS column names (a string, or a tuple of x, y, z columns). Atom dump:
#: id, type, radius, mass, position, velocity, omega, atom_force (per-atom force, into
#: ``frame.extra["force"]``). Local dump: i, j, force, tangential (added to force), branch
#: (None: from the positions).
DEFAULT_COLUMNS: dict[str, str | tuple[str, ...] | None] = {
    "id": "id",
    "type": "type",
    "radius": "radius",
    "mass": "mass",
    "position": ("x", "y", "z"),
    "velocity": ("vx", "vy", "vz"),
    "omega": ("omegax", "omegay", "omegaz"),
    "atom_force": ("fx", "fy", "fz"),
    "i": "c_contact_ids[1]",
    "j": "c_contact_ids[2]",
    "force": ("c_contact_forces[1]", "c_contact_forces[2]", "c_contact_forces[3]"),
    "tangential": ("c_contact_forces[4]", "c_contact_forces[5]", "c_contact_forces[6]"),
    "branch": None,
}
_REQUIRED = ("id", "position", "i", "j", "force")
_VECTORS = ("position", "velocity", "omega", "atom_force", "force", "tangential", "branch")
#: Largest |branch column - branch from positions| / |branch| accepted.
_BRANCH_TOLERANCE = 1e-3


@dataclass(frozen=True)
class LocalBlock:
    """One block of a LAMMPS ``dump local`` file.

    ``bounds`` is (3, 2) ``[[xlo, xhi], [ylo, yhi], [zlo, zhi]]``; ``boundary`` the flags of
    the ``BOX BOUNDS`` line (e.g. ``("pp", "pp", "ff")``); ``label`` the entry label
    (``ENTRIES`` unless changed with ``dump_modify label``); ``columns`` maps each column name
    to a float64 array, in file order. ``time`` is None without ``dump_modify time yes``.
    """

    step: int
    time: float | None
    bounds: np.ndarray
    boundary: tuple[str, ...]
    label: str
    columns: dict[str, np.ndarray]

    @property
    def n(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0


class _Lines:
    """Lines of a file with their numbers, for error messages ``file:line: ...``."""

    def __init__(self, path: Path) -> None:
        self._lines = path.read_text().splitlines()
        self._path = path
        self.number = 0  # 1-based number of the last line returned

    def __iter__(self) -> Iterator[str]:
        while self.number < len(self._lines):
            self.number += 1
            yield self._lines[self.number - 1]

    def next(self, wanted: str) -> str:
        """The next line; ``wanted`` says what was expected if the file ends instead."""
        if self.number >= len(self._lines):
            raise ValueError(f"{self._path}: file ends after line {self.number}; expected {wanted}")
        self.number += 1
        return self._lines[self.number - 1]

    def error(self, message: str) -> ValueError:
        """A ValueError naming the file and the current line."""
        return ValueError(f"{self._path}:{self.number}: {message}")


def read_lammps_local(path: str | os.PathLike[str]) -> list[LocalBlock]:
    """Read every block of a LAMMPS ``dump local`` text file.

    Accepts the optional ``ITEM: UNITS`` and ``ITEM: TIME`` items and any entry label.
    Malformed input raises ValueError naming the file and line.
    """
    lines = _Lines(Path(path))
    blocks = []
    time: float | None = None
    for line in lines:
        item = line.strip()
        if not item:
            continue
        if item == "ITEM: UNITS":
            lines.next("the unit style")
        elif item == "ITEM: TIME":
            time = _number(lines, lines.next("the time"), float, "time")
        elif item == "ITEM: TIMESTEP":
            step = _number(lines, lines.next("the timestep"), int, "timestep")
            blocks.append(_read_block(lines, step, time))
            time = None
        else:
            raise lines.error(f"unexpected line {item!r}; expected 'ITEM: TIMESTEP'")
    return blocks


def _number(lines: _Lines, text: str, kind: type, what: str) -> int | float:
    """``text`` as an int or float, or a ValueError naming the current line."""
    try:
        return kind(text.strip())
    except ValueError:
        raise lines.error(f"expected the {what}, found {text.strip()!r}") from None


def _read_block(lines: _Lines, step: int, time: float | None) -> LocalBlock:
    """Parse the part of a block after its timestep."""
    label = _item(lines, "ITEM: NUMBER OF ")
    n = _number(lines, lines.next(f"the number of {label}"), int, f"number of {label}")
    boundary = tuple(_item(lines, "ITEM: BOX BOUNDS").split())
    bounds = np.array([_floats(lines, lines.next("box bounds"), 2, "box bounds")[:2]
                       for _ in range(3)])
    names = _item(lines, f"ITEM: {label}").split()
    if not names:
        raise lines.error(f"'ITEM: {label}' names no columns")
    first = lines.number + 1
    rows = [_floats(lines, lines.next(f"{n} {label} rows from line {first}"), len(names),
                    f"{label} row", exact=True) for _ in range(n)]
    table = np.array(rows, dtype=float).reshape(n, len(names))
    columns = {name: table[:, c].copy() for c, name in enumerate(names)}
    return LocalBlock(step=step, time=time, bounds=bounds, boundary=boundary, label=label,
                      columns=columns)


def _item(lines: _Lines, prefix: str) -> str:
    """The rest of the next line, which must start with ``prefix``."""
    line = lines.next(f"{prefix.strip()!r}")
    if not line.startswith(prefix):
        raise lines.error(f"expected {prefix.strip()!r}, found {line.strip()!r}")
    return line[len(prefix):].strip()


def _floats(lines: _Lines, line: str, count: int, what: str, *, exact: bool = False) -> list[float]:
    """The numbers of ``line``: ``count`` of them (at least ``count`` unless ``exact``)."""
    words = line.split()
    if len(words) < count or (exact and len(words) != count):
        raise lines.error(f"{what} has {len(words)} values, expected {count}: {line.strip()!r}")
    try:
        return [float(word) for word in words]
    except ValueError:
        raise lines.error(f"{what} has a value that is not a number: {line.strip()!r}") from None


def frames_from_lammps(
    atom_dump: str | os.PathLike[str],
    local_dump: str | os.PathLike[str],
    *,
    dim: int = 3,
    columns: Mapping[str, str | tuple[str, ...] | None] | None = None,
    density: float | None = None,
    timestep: float | None = None,
) -> list[Frame]:
    """Frames with pair contacts from a LAMMPS per-atom dump and a ``dump local`` file.

    Blocks are matched by timestep (both files must hold the same steps); frames come in
    the order of ``atom_dump``, particles sorted by id. ``columns`` overrides entries of
    :data:`DEFAULT_COLUMNS` (None drops an optional one). Contacts are
    ``Contacts(i, j, force, branch, kind=PAIR)``: ``force = force + tangential`` columns,
    the force on ``i`` from ``j``; ``branch = x_i - x_j`` (minimum image on periodic axes),
    or the ``branch`` columns if named (checked against the positions).

    Mass comes from the ``mass`` column; without one, from ``density`` times the sphere
    volume 4/3 pi r^3 (``dim=3``) or the disk area pi r^2 (``dim=2``, ``density`` per unit
    area as LAMMPS's ``set density`` in 2D). Both or neither raise ValueError. Velocity,
    omega and radius missing from the dump are NaN; type defaults to 1. ``dim=2`` drops z
    (the atoms must share one z).
    Periodic axes are those flagged ``pp``. Per-atom forces go to ``frame.extra["force"]``.
    Time is the dump's ``ITEM: TIME``, else ``step * timestep``.
    """
    if dim not in (2, 3):
        raise ValueError(f"frames_from_lammps: dim={dim}; only 2 and 3 are supported")
    names = _columns(columns, dim)
    atoms = _by_step(read_lammps_dump(atom_dump), atom_dump)
    local = _by_step(read_lammps_local(local_dump), local_dump)
    for step in sorted(atoms.keys() ^ local.keys()):
        have, lack = (atom_dump, local_dump) if step in atoms else (local_dump, atom_dump)
        raise ValueError(f"frames_from_lammps: step {step} is in {have} but not in {lack}")
    return [_frame(atoms[step], local[step], names, dim=dim, density=density,
                   timestep=timestep, where=f"{atom_dump} + {local_dump}, step {step}")
            for step in atoms]


def _columns(columns: Mapping[str, str | tuple[str, ...] | None] | None, dim: int) -> dict:
    """DEFAULT_COLUMNS updated with ``columns``, checked."""
    names = dict(DEFAULT_COLUMNS)
    for key, value in (columns or {}).items():
        if key not in names:
            raise ValueError(f"columns: unknown name {key!r}; known: {sorted(names)}")
        if value is None and key in _REQUIRED:
            raise ValueError(f"columns: {key!r} is required and cannot be None")
        names[key] = value if value is None or isinstance(value, str) else tuple(value)
    for key, value in names.items():
        width = 3 if key == "omega" else dim
        vector = key in _VECTORS
        if value is not None and (isinstance(value, str) == vector
                                  or vector and len(value) < width):
            want = f"a tuple of {width} column names" if vector else "one column name"
            raise ValueError(f"columns: {key!r} must be {want}, got {value!r}")
    return names


def _by_step(blocks: list, path: str | os.PathLike[str]) -> dict:
    """Blocks keyed by timestep; a repeated timestep is an error."""
    out: dict = {}
    for block in blocks:
        if block.step in out:
            raise ValueError(f"{path}: timestep {block.step} appears more than once")
        out[block.step] = block
    return out


def _frame(atoms: DumpFrame, local: LocalBlock, names: dict, *, dim: int,
           density: float | None, timestep: float | None, where: str) -> Frame:
    """One Frame from matching atom and local blocks."""
    box = _box(atoms, local, dim, where)
    order = np.argsort(_column(atoms.columns, names["id"], "atom dump", where), kind="stable")
    atom = {key: value[order] for key, value in atoms.columns.items()}
    ids = _ids(atom[names["id"]], where)
    if np.any(np.diff(ids) == 0):
        raise ValueError(f"{where}: atom id {ids[1:][np.diff(ids) == 0][0]} appears twice")
    _check_flat(atom, names["position"], dim, where)
    position = _stack(atom, names["position"], dim, "atom dump", where)
    radius = _optional(atom, names["radius"])
    atom_force = _vectors(atom, names["atom_force"], dim)
    return Frame(
        step=atoms.step,
        time=_time(atoms, timestep, where),
        box=box,
        id=ids,
        type=_optional(atom, names["type"], 1).astype(np.int32),
        body=np.full(len(ids), -1, dtype=np.int64),
        radius=np.full(len(ids), np.nan) if radius is None else radius.astype(float),
        mass=_mass(atom, names["mass"], radius, density, dim, where),
        position=position,
        velocity=_vectors(atom, names["velocity"], dim, missing=np.nan),
        omega=_vectors(atom, names["omega"], 3, missing=np.nan),
        contacts=_contacts(local, names, ids, position, box, dim, where),
        extra={} if atom_force is None else {"force": atom_force},
    )


def _box(atoms: DumpFrame, local: LocalBlock, dim: int, where: str) -> Box:
    """The Box of the atom dump block, which the local block must share."""
    if len(atoms.boundary) != 3:
        raise ValueError(f"{where}: triclinic boxes (BOX BOUNDS {' '.join(atoms.boundary)}) "
                         "are not supported")
    if atoms.boundary != local.boundary or not np.allclose(atoms.bounds, local.bounds,
                                                           rtol=1e-12, atol=0.0):
        raise ValueError(f"{where}: the atom and local dumps have different boxes")
    return Box(lo=atoms.bounds[:dim, 0].copy(), hi=atoms.bounds[:dim, 1].copy(),
               periodic=tuple(flag == "pp" for flag in atoms.boundary[:dim]))


def _column(table: dict[str, np.ndarray], name: str, what: str, where: str) -> np.ndarray:
    """A required column, or a ValueError listing the columns there are."""
    if name not in table:
        raise ValueError(f"{where}: the {what} has no column {name!r}; it has {list(table)}")
    return table[name]


def _optional(table: dict[str, np.ndarray], name: str | None,
              default: float | None = None) -> np.ndarray | None:
    """An optional column; ``default`` filled in (None returned) when it is absent."""
    if name is not None and name in table:
        return table[name]
    if default is None:
        return None
    return np.full(len(next(iter(table.values()))), default)


def _stack(table: dict[str, np.ndarray], names: tuple[str, ...], width: int, what: str,
           where: str) -> np.ndarray:
    """(n, width) float array of the first ``width`` of ``names``, all required."""
    return np.column_stack([_column(table, name, what, where) for name in names[:width]]
                           ).astype(float)


def _vectors(table: dict[str, np.ndarray], names: tuple[str, ...] | None, width: int,
             missing: float | None = None) -> np.ndarray | None:
    """(n, width) array of optional columns; filled with ``missing`` (or None) if absent."""
    if names is not None and all(name in table for name in names[:width]):
        return np.column_stack([table[name] for name in names[:width]]).astype(float)
    if missing is None:
        return None
    return np.full((len(next(iter(table.values()))), width), missing)


def _ids(values: np.ndarray, where: str) -> np.ndarray:
    """Atom ids as int64 (they are floats in local dumps); non-integers are an error."""
    ids = np.asarray(values)
    if ids.dtype.kind == "f" and not np.array_equal(ids, np.round(ids)):
        bad = ids[ids != np.round(ids)]
        raise ValueError(f"{where}: atom ids that are not integers: {bad[:3]}")
    return ids.astype(np.int64)


def _check_flat(atom: dict[str, np.ndarray], position: tuple[str, ...], dim: int,
                where: str) -> None:
    """For dim=2, the atoms must all have the same z."""
    if dim == 2 and len(position) > 2 and position[2] in atom:
        z = atom[position[2]]
        if len(z) and np.ptp(z) > 0:
            raise ValueError(f"{where}: dim=2 but the atoms' z spans [{z.min()}, {z.max()}]")


def _time(atoms: DumpFrame, timestep: float | None, where: str) -> float:
    """The dump's time, or ``step * timestep``."""
    if atoms.time is not None:
        return float(atoms.time)
    if timestep is None:
        raise ValueError(f"{where}: the atom dump has no 'ITEM: TIME' (dump_modify time yes); "
                         "pass timestep=")
    return atoms.step * float(timestep)


def _mass(atom: dict[str, np.ndarray], name: str | None, radius: np.ndarray | None,
          density: float | None, dim: int, where: str) -> np.ndarray:
    """Masses from the mass column, or from radius and density."""
    has_mass = name is not None and name in atom
    if has_mass and density is not None:
        raise ValueError(f"{where}: the atom dump has a {name!r} column and density="
                         f"{density} was given; pass one source of mass")
    if has_mass:
        return atom[name].astype(float)
    if density is None or radius is None:
        raise ValueError(f"{where}: no mass: the atom dump has no mass column; pass density= "
                         "and dump a radius column")
    measure = 4.0 / 3.0 * math.pi * radius**3 if dim == 3 else math.pi * radius**2
    return float(density) * measure


def _contacts(local: LocalBlock, names: dict, ids: np.ndarray, position: np.ndarray,
              box: Box, dim: int, where: str) -> Contacts:
    """Contacts of one block: ids, full force and branch vector of every row."""
    i = _ids(_column(local.columns, names["i"], "local dump", where), where)
    j = _ids(_column(local.columns, names["j"], "local dump", where), where)
    force = _stack(local.columns, names["force"], dim, "local dump", where)
    if names["tangential"] is not None:
        if not all(name in local.columns for name in names["tangential"]):
            raise ValueError(
                f"{where}: the local dump has no tangential force columns "
                f"{names['tangential']}. For granular pair styles pair/local fx fy fz are "
                "only the normal force: add p1 p2 p3 to compute pair/local, or pass "
                "columns={'tangential': None} if the pair style's forces are central"
            )
        force = force + _stack(local.columns, names["tangential"], dim, "local dump", where)
    branch = _minimum_image(position[_rows(ids, i, where)] - position[_rows(ids, j, where)], box)
    if names["branch"] is not None:
        columns = _stack(local.columns, names["branch"], dim, "local dump", where)
        branch = _checked_branch(columns, branch, where)
    return Contacts(i, j, force, branch, np.full(len(i), PAIR, dtype=np.int8))


def _rows(ids: np.ndarray, wanted: np.ndarray, where: str) -> np.ndarray:
    """Row of each of ``wanted`` in the sorted ``ids``; a missing id is an error."""
    rows = np.clip(np.searchsorted(ids, wanted), 0, max(len(ids) - 1, 0))
    missing = (ids[rows] != wanted) if len(ids) else np.ones(len(wanted), dtype=bool)
    if missing.any():
        raise ValueError(f"{where}: contact atom id {int(wanted[missing][0])} is not among the "
                         "atoms")
    return rows


def _minimum_image(vectors: np.ndarray, box: Box) -> np.ndarray:
    """``vectors`` wrapped to the nearest image along periodic axes."""
    out = vectors.copy()
    lengths = box.lengths
    for axis, periodic in enumerate(box.periodic):
        if periodic:
            out[:, axis] -= lengths[axis] * np.round(out[:, axis] / lengths[axis])
    return out


def _checked_branch(columns: np.ndarray, from_positions: np.ndarray, where: str) -> np.ndarray:
    """Branch columns, if they agree with ``x_i - x_j`` from the positions."""
    size = np.linalg.norm(from_positions, axis=1)
    error = np.linalg.norm(columns - from_positions, axis=1) / np.where(size > 0, size, 1.0)
    if len(error) and error.max() > _BRANCH_TOLERANCE:
        row = int(np.argmax(error))
        flipped = np.allclose(columns[row], -from_positions[row], rtol=_BRANCH_TOLERANCE)
        hint = (" (it is x_j - x_i: before 12 Jun 2025 LAMMPS set the sign of pair/local "
                "dx dy dz by atom id; leave the branch columns out)") if flipped else ""
        raise ValueError(f"{where}: branch columns of contact row {row} are {columns[row]}, "
                         f"but x_i - x_j from the positions is {from_positions[row]}{hint}")
    return columns


def unbalanced_force(frame: Frame) -> np.ndarray:
    """(N, dim) dumped per-atom force minus the sum of the frame's contact forces on each atom.

    Zero (to the dump precision) when the contacts hold every force on the atoms; otherwise
    the external forces (gravity, walls, fixes), any part of the contact force the local
    dump lacks, and drift between the force computation and the output (see the module
    docstring). Needs ``frame.extra["force"]`` and pair contacts.
    """
    if "force" not in frame.extra or frame.contacts is None:
        raise ValueError("unbalanced_force: the frame needs extra['force'] and contacts")
    contacts = frame.contacts.of_kind(PAIR)
    order = np.argsort(frame.id)
    i = order[_rows(frame.id[order], contacts.i, "unbalanced_force")]
    j = order[_rows(frame.id[order], contacts.j, "unbalanced_force")]
    total = np.zeros_like(frame.extra["force"])
    np.add.at(total, i, contacts.force)
    np.add.at(total, j, -contacts.force)
    return frame.extra["force"] - total
