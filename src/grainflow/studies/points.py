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
               n_workers: int | None = None, progress: str = "auto") -> dict[str, SweepPoints]:
    """Run (or continue) each sweep into ``out/NAME`` and return its done points by name;
    finished points are never recomputed (:func:`grainflow.sweep.run_sweep`).

    ``progress`` is each sweep's display (``"auto"``: a bar with the time left on a terminal,
    a plain line every 30 s otherwise; ``"rich"``, ``"plain"``, ``"none"``); a line before
    each sweep says which of the study's sweeps it is."""
    from grainflow.sweep import run_sweep

    out.mkdir(parents=True, exist_ok=True)
    points: dict[str, SweepPoints] = {}
    for k, (name, spec) in enumerate(specs.items(), start=1):
        if progress != "none":
            print(f"study: sweep {k}/{len(specs)} '{name}' into {out / name}", flush=True)
        run_sweep(spec, out / name, scheduler=scheduler, n_workers=n_workers, progress=progress)
        points[name] = done_points(out / name)
    return points
