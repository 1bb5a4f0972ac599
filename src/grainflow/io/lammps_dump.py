"""LAMMPS text dumps of frames (for OVITO), and a small reader of the same format.

Each frame becomes one block::

    ITEM: TIME
    ITEM: TIMESTEP
    ITEM: NUMBER OF ATOMS
    ITEM: BOX BOUNDS pp ff ff
    ITEM: ATOMS id type radius x y z vx vy vz omegax omegay omegaz

2D frames get ``z = vz = 0`` and a thin periodic z slab ``[-r_max, r_max]`` (LAMMPS requires
z to be periodic in 2D). Non-periodic axes are written as ``ff``.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from grainflow.frame import Frame
from grainflow.io.h5md import check_finite_frame

__all__ = ["COLUMNS", "DumpFrame", "read_lammps_dump", "write_lammps_dump"]

COLUMNS = ("id", "type", "radius", "x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz")
_INTEGER_COLUMNS = frozenset({"id", "type"})


@dataclass(frozen=True)
class DumpFrame:
    """One block of a LAMMPS dump as read back.

    ``bounds`` is (3, 2) ``[[xlo, xhi], [ylo, yhi], [zlo, zhi]]``; ``boundary`` the three
    flag pairs (e.g. ``("pp", "ff", "ff")``); ``columns`` maps each ``ITEM: ATOMS`` column
    name to an array (int64 for ``id`` and ``type``, float64 otherwise), in file order.
    ``time`` is None when the block has no ``ITEM: TIME``.
    """

    step: int
    time: float | None
    bounds: np.ndarray
    boundary: tuple[str, ...]
    columns: dict[str, np.ndarray]

    @property
    def n(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0


def write_lammps_dump(
    path: str | os.PathLike[str],
    frames: Frame | Iterable[Frame],
    *,
    append: bool = False,
    digits: int = 10,
) -> Path:
    """Write one frame or a sequence of frames to ``path`` (appending if ``append``).

    ``digits`` is the number of significant digits of floats. Returns the path. A frame
    with a non-finite value raises :class:`~grainflow.io.h5md.NonFiniteFrameError` (a
    ValueError naming the array and particle id) before any of its lines is written.
    """
    path = Path(path)
    frames = [frames] if isinstance(frames, Frame) else frames
    with path.open("a" if append else "w") as out:
        for frame in frames:
            _write_block(out, frame, digits)
    return path


def _write_block(out: TextIO, frame: Frame, digits: int) -> None:
    """Write one frame as a dump block."""
    if frame.dim not in (2, 3):
        raise ValueError(f"write_lammps_dump: frame.dim={frame.dim}; only 2 and 3 are supported")
    check_finite_frame("write_lammps_dump", frame, contacts=False)
    bounds, flags = _box_bounds(frame)
    out.write(f"ITEM: TIME\n{float(frame.time)!r}\nITEM: TIMESTEP\n{int(frame.step)}\n")
    out.write(f"ITEM: NUMBER OF ATOMS\n{frame.n}\n")
    out.write(f"ITEM: BOX BOUNDS {' '.join(flags)}\n")
    out.writelines(f"{lo:.{digits}g} {hi:.{digits}g}\n" for lo, hi in bounds)
    out.write(f"ITEM: ATOMS {' '.join(COLUMNS)}\n")
    if frame.n:
        np.savetxt(out, _atom_table(frame), fmt=["%d", "%d"] + [f"%.{digits}g"] * (len(COLUMNS) - 2))


def _box_bounds(frame: Frame) -> tuple[np.ndarray, list[str]]:
    """(3, 2) bounds and boundary flags; 2D gets a thin periodic z slab."""
    flags = ["pp" if p else "ff" for p in frame.box.periodic]
    bounds = np.zeros((3, 2))
    bounds[: frame.dim, 0] = frame.box.lo
    bounds[: frame.dim, 1] = frame.box.hi
    if frame.dim == 2:
        half = float(frame.radius.max()) if frame.n else 0.5e-3 * float(frame.box.lengths.max())
        bounds[2] = (-half, half)
        flags.append("pp")
    return bounds, flags


def _atom_table(frame: Frame) -> np.ndarray:
    """(N, 12) float table in COLUMNS order (ids are exact up to 2**53)."""
    position = np.zeros((frame.n, 3))
    velocity = np.zeros((frame.n, 3))
    position[:, : frame.dim] = frame.position
    velocity[:, : frame.dim] = frame.velocity
    return np.column_stack(
        [frame.id, frame.type, frame.radius, position, velocity, frame.omega]
    ).astype(float)


def read_lammps_dump(path: str | os.PathLike[str]) -> list[DumpFrame]:
    """Read every block of a LAMMPS text dump (any column set, ``ITEM: TIME`` optional)."""
    with Path(path).open() as lines:
        return list(_read_blocks(lines, str(path)))


def _read_blocks(lines: Iterator[str], where: str) -> Iterator[DumpFrame]:
    """Parse blocks one after another from an iterator of lines."""
    time: float | None = None
    for line in lines:
        item = line.strip()
        if not item:
            continue
        if item == "ITEM: TIME":
            time = float(_next(lines, where))
        elif item == "ITEM: TIMESTEP":
            yield _read_block_body(lines, int(_next(lines, where)), time, where)
            time = None
        else:
            raise ValueError(f"{where}: unexpected line {item!r}; expected 'ITEM: TIMESTEP'")


def _read_block_body(lines: Iterator[str], step: int, time: float | None, where: str) -> DumpFrame:
    """Parse the part of a block after its timestep."""
    _expect(_next(lines, where), "ITEM: NUMBER OF ATOMS", where)
    n = int(_next(lines, where))
    boundary = tuple(_expect(_next(lines, where), "ITEM: BOX BOUNDS", where).split())
    bounds = np.array([[float(v) for v in _next(lines, where).split()[:2]] for _ in range(3)])
    names = _expect(_next(lines, where), "ITEM: ATOMS", where).split()
    rows = [_next(lines, where) for _ in range(n)]
    table = np.loadtxt(rows, ndmin=2) if n else np.empty((0, len(names)))
    if table.shape != (n, len(names)):
        raise ValueError(
            f"{where}: step {step}: atom table has shape {table.shape}, expected {(n, len(names))}"
        )
    columns = {
        name: table[:, c].astype(np.int64 if name in _INTEGER_COLUMNS else float)
        for c, name in enumerate(names)
    }
    return DumpFrame(step=step, time=time, bounds=bounds, boundary=boundary, columns=columns)


def _next(lines: Iterator[str], where: str) -> str:
    """The next line, or a ValueError for a truncated file."""
    line = next(lines, None)
    if line is None:
        raise ValueError(f"{where}: file ends in the middle of a block (truncated dump?)")
    return line


def _expect(line: str, item: str, where: str) -> str:
    """Check that ``line`` starts with ``item`` and return the rest of it."""
    if not line.startswith(item):
        raise ValueError(f"{where}: expected {item!r}, found {line.strip()!r}")
    return line[len(item):]
