"""Command-line verbs ``sweep`` and ``sweep-status``.

The main CLI registers the two functions::

    from grainflow.sweep.cli import sweep_command, sweep_status_command
    app.command("sweep")(sweep_command)
    app.command("sweep-status")(sweep_status_command)

``sweep_app`` bundles them for ``python -m grainflow.sweep sweep|sweep-status ...``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from grainflow.sweep.catalog import CATALOG_NAME, STATUSES, Catalog, CatalogRow, export_csv
from grainflow.sweep.spec import SweepFileError, load_sweep

sweep_app = typer.Typer(help="Parameter sweeps on dask.distributed.", no_args_is_help=True)


def sweep_command(
    sweep_file: Annotated[Path, typer.Argument(help="Sweep file (TOML).", dir_okay=False)],
    output: Annotated[
        Optional[Path],
        typer.Option("--output", "-o", help="Sweep directory (default: the sweep file's name, in the current directory)."),
    ] = None,
    scheduler: Annotated[
        Optional[str],
        typer.Option(help="Address of a running dask scheduler, e.g. tcp://host:8786. "
                     "Default: a local cluster on this machine."),
    ] = None,
    workers: Annotated[
        Optional[int],
        typer.Option("--workers", "-n", min=1, help="Local cluster size (default: one worker per core)."),
    ] = None,
    progress: Annotated[
        str, typer.Option(help="Progress display: auto, rich or plain.")
    ] = "auto",
    progress_interval: Annotated[
        float, typer.Option(min=0.0, help="Seconds between plain progress lines.")
    ] = 30.0,
) -> None:
    """Run every point of SWEEP_FILE not yet done; results go to the sweep directory's catalog."""
    from grainflow.sweep.execute import PROGRESS_MODES, SweepError, run_sweep  # slow import

    if progress not in PROGRESS_MODES:
        typer.echo(f"error: --progress must be one of {', '.join(PROGRESS_MODES)}", err=True)
        raise typer.Exit(2)
    try:
        spec = load_sweep(sweep_file)
        sweepdir = output if output is not None else Path.cwd() / sweep_file.stem
        result = run_sweep(
            spec, sweepdir, scheduler=scheduler, n_workers=workers,
            progress=progress, progress_interval=progress_interval,
        )
    except (SweepFileError, SweepError) as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    except KeyboardInterrupt:
        raise typer.Exit(130) from None
    if not result.ok:
        raise typer.Exit(1)


def sweep_status_command(
    sweepdir: Annotated[Path, typer.Argument(help="Sweep directory.", file_okay=False)],
    csv: Annotated[
        Optional[str], typer.Option("--csv", help="Write the catalog as CSV to this file ('-': stdout).")
    ] = None,
    status: Annotated[
        Optional[str], typer.Option(help=f"Show only points with this status ({', '.join(STATUSES)}).")
    ] = None,
) -> None:
    """Print the catalog of a sweep directory (or export it with --csv)."""
    if status is not None and status not in STATUSES:
        typer.echo(f"error: --status must be one of {', '.join(STATUSES)}, not {status!r}", err=True)
        raise typer.Exit(2)
    if not (sweepdir / CATALOG_NAME).is_file():
        typer.echo(f"error: {sweepdir} has no {CATALOG_NAME}; is it a sweep directory?", err=True)
        raise typer.Exit(2)
    with Catalog.in_dir(sweepdir) as catalog:
        rows = catalog.rows(status)
        counts = catalog.counts()
    if csv == "-":
        export_csv(rows, sys.stdout)
        return
    if csv is not None:
        with open(csv, "w", newline="") as stream:
            export_csv(rows, stream)
        typer.echo(f"wrote {len(rows)} rows to {csv}")
        return
    console = Console(highlight=False)
    console.print(status_table(rows))
    console.out(", ".join(f"{counts[s]} {s}" for s in STATUSES) + f" ({sum(counts.values())} points)")


def status_table(rows: list[CatalogRow]) -> Table:
    """A rich table: id, parameters, seed, status, summary numbers, wall time, error."""
    params = list(dict.fromkeys(k for r in rows for k in r.params))
    summaries = list(dict.fromkeys(k for r in rows for k in r.summary))
    table = Table(show_lines=False)
    table.add_column("point", no_wrap=True)
    for name in [*params, "seed", "status", *summaries, "wall (s)", "tries", "error"]:
        table.add_column(name, overflow="fold")
    colour = {"done": "green", "failed": "red", "running": "yellow", "pending": "dim"}
    for r in rows:
        table.add_row(
            r.point_id,
            *(_fmt(r.params.get(k)) for k in params),
            str(r.seed),
            f"[{colour[r.status]}]{r.status}[/]",
            *(_fmt(r.summary.get(k)) for k in summaries),
            _fmt(r.wall_time),
            str(r.attempts),
            r.error.strip().splitlines()[-1] if r.error else "",
        )
    return table


def _fmt(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


sweep_app.command("sweep")(sweep_command)
sweep_app.command("sweep-status")(sweep_status_command)
