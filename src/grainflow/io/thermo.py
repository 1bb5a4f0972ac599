"""The thermo log: one CSV row of global quantities every N steps (LAMMPS's ``thermo``).

:class:`ThermoLog` is an observer (``sim.add_observer(ThermoLog("thermo.csv"), every=100)``);
it also logs the state a run starts from (step 0 of a fresh run), once. The run directory's
``thermo.csv`` is written by it.
"""

from __future__ import annotations

import time
from pathlib import Path

from grainflow.engine.operations import ObserverContext

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
    """

    def __init__(self, path: str | Path, resume_step: int | None = None) -> None:
        path = Path(path)
        self._last_step: int | None = None
        if resume_step is not None and path.is_file():
            self._last_step = _trim_csv(path, resume_step)
            self._file = path.open("a")
        else:
            self._file = path.open("w")
            self._file.write(",".join(THERMO_COLUMNS) + "\n")
            self._file.flush()
        self._last: tuple[int, float] | None = None

    def start(self, ctx: ObserverContext) -> None:
        """A run begins: log its first state unless that step is logged already."""
        if ctx.step != self._last_step:
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
        self._file.write(",".join(map(str, row)) + "\n")
        self._file.flush()
        self._last_step = ctx.step

    def close(self) -> None:
        self._file.close()


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
