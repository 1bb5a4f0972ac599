"""The thermo log: one CSV row of global quantities every N steps (LAMMPS's ``thermo``).

:class:`ThermoLog` is an observer (``sim.add_observer(ThermoLog("thermo.csv"), every=100)``);
it also logs the state a run starts from (step 0 of a fresh run), once. The run directory's
``thermo.csv`` is written by it.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from grainflow.engine.operations import ObserverContext
from grainflow.engine.simulation import InstabilityError
from grainflow.io.aside import move_aside
from grainflow.state import speeds
from grainflow.user_warnings import warn_user

__all__ = ["THERMO_COLUMNS", "ThermoLog"]

#: Columns of the log, in order.
THERMO_COLUMNS = ("step", "time", "N", "kinetic_energy", "rotational_energy", "max_overlap",
                  "contacts", "rebuilds", "particle_steps_per_s")


class ThermoLog:
    """Observer writing one CSV row per call (columns :data:`THERMO_COLUMNS`).

    ``contacts`` counts every force between two bodies (pairs, wall contacts, bonds and
    anchors); ``particle_steps_per_s`` is the speed since the previous row (0 in the first).
    With ``resume_step``, rows after that step (and a torn last line) are dropped first and
    new rows are appended. A step is never logged twice.

    Resuming checks the existing file first: its header must be exactly the current
    columns and every row up to ``resume_step`` must parse (the right number of fields,
    integer step and counts, float values, steps increasing). If not (a garbage file, a
    binary blob, a header of another version, rows with other columns), the file is never
    appended to and never deleted: it is moved aside to ``thermo.csv.damaged`` (or
    ``.damaged.1``, ``.2``, ... if taken), a new file with the header is started (its first
    row is the resumed state), and a :class:`RuntimeWarning` names both files. The new
    file then lacks the rows before ``resume_step``; they are in the ``.damaged`` file.

    A row with a non-finite value is never written: :meth:`__call__` raises
    :class:`~grainflow.engine.simulation.InstabilityError` naming the column and the
    particle with the largest speed.
    """

    def __init__(self, path: str | Path, resume_step: int | None = None) -> None:
        path = Path(path)
        self._last_step: int | None = None
        self.path = path
        self.moved_aside: Path | None = None  # where a damaged log went on resume
        problem = _check_csv(path, resume_step) if resume_step is not None and path.is_file() else None
        if problem is not None:
            self.moved_aside = move_aside(path)
            warn_user(
                f"ThermoLog: {path} cannot be continued ({problem}); it was moved to "
                f"{self.moved_aside} and a new {path.name} starts at step {resume_step}",
                RuntimeWarning)
        #: Continuing an existing log: the resumed state is not logged again (the row the
        #: uninterrupted run would have there, if any, is already in the file).
        self._continues = resume_step is not None and problem is None and path.is_file()
        if self._continues:
            self._last_step = _trim_csv(path, resume_step)
            self._file = path.open("a")
        else:
            self._file = path.open("w")
            self._file.write(",".join(THERMO_COLUMNS) + "\n")
            self._file.flush()
        self._last: tuple[int, float] | None = None

    def start(self, ctx: ObserverContext) -> None:
        """A run begins: log its first state, unless this log continues an interrupted one
        (then the row due at that step, if any, is in the file already)."""
        if not self._continues and ctx.step != self._last_step:
            self(ctx)

    def __call__(self, ctx: ObserverContext) -> None:
        if ctx.step == self._last_step:
            return
        now = time.perf_counter()
        rate = 0.0
        if self._last is not None and now > self._last[1]:
            rate = (ctx.particle_steps - self._last[0]) / (now - self._last[1])
        self._last = (ctx.particle_steps, now)
        st = ctx.state
        row = (ctx.step, repr(ctx.time), st.n, repr(st.kinetic_energy()),
               repr(st.rotational_energy()), repr(ctx.max_overlap()),
               len(ctx.contacts().i), ctx.rebuilds, f"{rate:.6g}")
        values = (ctx.time, row[3], row[4], row[5], rate)
        if not all(math.isfinite(float(v)) for v in values):
            self._refuse(ctx, row)
        self._file.write(",".join(map(str, row)) + "\n")
        self._file.flush()
        self._last_step = ctx.step

    def _refuse(self, ctx: ObserverContext, row: tuple) -> None:
        """Raise InstabilityError for a row with a non-finite value (nothing is written)."""
        column = next(name for name, value in zip(THERMO_COLUMNS, row)
                      if not math.isfinite(float(value)))
        st = ctx.state
        particle = int(st.id[int(np.argmax(speeds(st.v)))]) if st.n else -1  # NaN/inf first
        raise InstabilityError(
            ctx.step, particle,
            f"thermo column {column!r} is {row[THERMO_COLUMNS.index(column)]} (particle id "
            f"{particle} has the largest speed); the row was not written to {self.path}")

    def close(self) -> None:
        self._file.close()


def _check_csv(path: Path, step: int) -> str | None:
    """Why ``path`` cannot be continued at ``step`` (None if it can): header and rows up to ``step``.

    A torn last line (a crash mid-write) is not a problem: :func:`_trim_csv` drops it.
    """
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        return "it is not text (a binary blob?)"
    lines = text.splitlines(keepends=True)
    header = ",".join(THERMO_COLUMNS)
    if not lines or lines[0].rstrip("\r\n") != header:
        got = lines[0].rstrip("\r\n")[:80] if lines else "nothing (empty file)"
        return f"its header is {got!r}, expected {header!r}"
    last = None
    for number, line in enumerate(lines[1:], start=2):
        fields = line.rstrip("\n").split(",")
        if not line.endswith("\n") and number == len(lines):
            break  # a torn last line: trimmed below
        try:
            if len(fields) != len(THERMO_COLUMNS):
                raise ValueError(f"{len(fields)} fields, expected {len(THERMO_COLUMNS)}")
            row_step = int(fields[0])
            for name, value in zip(THERMO_COLUMNS[1:], fields[1:]):
                int(value) if name in ("N", "contacts", "rebuilds") else float(value)
        except ValueError as err:
            return f"line {number} does not parse ({err})"
        if row_step > step:
            break
        if last is not None and row_step <= last:
            return f"line {number}: step {row_step} does not follow step {last}"
        last = row_step
    return None


def _trim_csv(path: Path, step: int) -> int | None:
    """Keep the header and the complete rows up to ``step``; return the last kept step."""
    lines = path.read_text().splitlines(keepends=True)
    keep = lines[:1]
    last = None
    for line in lines[1:]:
        fields = line.rstrip("\n").split(",")
        if not line.endswith("\n") or len(fields) != len(THERMO_COLUMNS):
            break
        if int(fields[0]) > step:
            break
        keep.append(line)
        last = int(fields[0])
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text("".join(keep))
    tmp.replace(path)
    return last
