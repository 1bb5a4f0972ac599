"""A study's sweeps: running them, and their finished points read back from the results
catalogs."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["SweepPoints", "done_points", "run_sweeps"]


@dataclass
class SweepPoints:
    """Done points of one sweep: parameters, summaries, run directories, and the sum of
    their run times (``cpu``, seconds: one worker thread per run)."""

    params: list[dict[str, Any]] = field(default_factory=list)
    summaries: list[dict[str, float]] = field(default_factory=list)
    rundirs: list[Path] = field(default_factory=list)
    cpu: float = 0.0


def done_points(sweepdir: Path) -> SweepPoints:
    """Every point of the sweep in ``sweepdir`` whose run and analyses finished."""
    from grainflow.sweep import Catalog

    out = SweepPoints()
    with Catalog.in_dir(sweepdir) as catalog:
        for row in catalog.rows("done"):
            out.params.append(dict(row.params))
            out.summaries.append(dict(row.summary))
            out.rundirs.append(sweepdir / row.rundir)
            out.cpu += float(row.wall_time or 0.0)
    return out


def run_sweeps(specs: dict[str, Any], out: Path, *, scheduler: str | None = None,
               n_workers: int | None = None, progress: str = "auto",
               worker_threads: int = 1) -> dict[str, SweepPoints]:
    """Run (or continue) each sweep into ``out/NAME`` and return its done points by name;
    finished points are never recomputed (:func:`grainflow.sweep.run_sweep`).

    The sweeps run together on one set of workers
    (:func:`grainflow.sweep.run_sweeps_together`), their points started in the order of
    ``specs``: a later sweep's points fill the workers an earlier sweep's last points leave
    idle. ``progress`` is the display (``"auto"``: a bar with the time left on a terminal, a
    plain line every 30 s otherwise; ``"rich"``, ``"plain"``, ``"none"``), counting the
    points of every sweep. ``worker_threads``: the most threads a run may take on a local
    worker (:func:`grainflow.sweep.run_sweeps_together`)."""
    from grainflow.sweep import run_sweeps_together

    out.mkdir(parents=True, exist_ok=True)
    if progress != "none":
        names = ", ".join(f"'{name}'" for name in specs)
        print(f"study: sweeps {names} into {out}, run together", flush=True)
    run_sweeps_together([(spec, out / name) for name, spec in specs.items()],
                        scheduler=scheduler, n_workers=n_workers, progress=progress,
                        worker_threads=worker_threads)
    return {name: done_points(out / name) for name in specs}
