"""Command-line verbs ``sweep`` and ``sweep-status``.

The main CLI registers the two functions::

    from grainflow.sweep.cli import sweep_command, sweep_status_command
    app.command("sweep")(sweep_command)
    app.command("sweep-status")(sweep_status_command)

``sweep_app`` bundles them for ``python -m grainflow.sweep sweep|sweep-status ...``.

Exit codes, as for the other verbs: 0 success; 1 some points failed (or an unexpected
error); 2 bad input (sweep file, invalid point configs, unusable sweep directory or
catalog, unreachable scheduler); 130 interrupted. Every failure is reported as
``error: ...`` on stderr, never as a traceback (``grainflow --debug`` or
``GRAINFLOW_DEBUG=1`` shows the traceback of an unexpected error).
"""

from __future__ import annotations

import os
import sqlite3
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from grainflow.sweep.catalog import (
    CATALOG_NAME,
    STATUSES,
    Catalog,
    CatalogError,
    CatalogRow,
    damaged_catalog_message,
    export_csv,
)
from grainflow.sweep.spec import SweepError, SweepFileError, load_sweep

sweep_app = typer.Typer(
    help="Parameter sweeps on dask.distributed.", no_args_is_help=True,
    pretty_exceptions_enable=False,
)


def _debug() -> bool:
    """``grainflow --debug`` (the main command's flag) or GRAINFLOW_DEBUG=1."""
    main = sys.modules.get("grainflow.cli")
    state = getattr(main, "_state", None)
    return bool(os.environ.get("GRAINFLOW_DEBUG")) or bool(
        isinstance(state, dict) and state.get("debug")
    )


@contextmanager
def _errors() -> Iterator[None]:
    """Turn every failure into ``error: ...`` on stderr and the documented exit code."""
    try:
        yield
    except typer.Exit:
        raise
    except (SweepFileError, SweepError) as exc:  # expected: the message says what to do
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(getattr(exc, "exit_code", 2)) from None
    except KeyboardInterrupt:
        raise typer.Exit(130) from None
    except Exception as exc:
        if _debug():
            raise
        if isinstance(exc, sqlite3.Error):
            message = f"the sweep catalog: {exc}"
        elif isinstance(exc, OSError) and exc.filename:
            message = f"{exc.filename}: {exc.strerror or exc}"
        else:
            message = " ".join(str(exc).split()) or type(exc).__name__
        code = 2 if isinstance(exc, (ValueError, OSError)) else 1
        typer.echo(f"error: {message} ({type(exc).__name__}; GRAINFLOW_DEBUG=1 shows the "
                   "traceback)", err=True)
        raise typer.Exit(code) from None


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
    worker_threads: Annotated[
        int,
        typer.Option("--worker-threads", min=1,
                     help="Most threads one run may use on a local worker (default 1: every "
                          "run on one thread). More lets runs with threads = 'auto' take "
                          "the cores other workers leave idle, as the sweep's last runs do."),
    ] = 1,
    progress: Annotated[
        str, typer.Option(help="Progress display: auto, rich, plain or none.")
    ] = "auto",
    progress_interval: Annotated[
        float, typer.Option(min=0.0, help="Seconds between plain progress lines.")
    ] = 30.0,
    rebuild_catalog: Annotated[
        bool, typer.Option(
            "--rebuild-catalog",
            help="If the catalog is damaged, move it aside and rebuild it from the run "
                 "directories (finished runs are not repeated, only their analyses).")
    ] = False,
) -> None:
    """Run every point of SWEEP_FILE not yet done; results go to the sweep directory's catalog."""
    with _errors():
        from grainflow.sweep.execute import PROGRESS_MODES, run_sweep  # slow import

        if progress not in PROGRESS_MODES:
            raise SweepFileError(f"--progress must be one of {', '.join(PROGRESS_MODES)}")
        spec = load_sweep(sweep_file)
        sweepdir = output if output is not None else Path.cwd() / sweep_file.stem
        try:
            result = run_sweep(
                spec, sweepdir, scheduler=scheduler, n_workers=workers,
                progress=progress, progress_interval=progress_interval,
                rebuild_catalog=rebuild_catalog, worker_threads=worker_threads,
            )
        except CatalogError as exc:  # name this sweep file in the command to run
            raise CatalogError(str(exc).replace("SWEEP.toml", str(sweep_file))) from None
    if not result.ok:
        done = result.counts.get("done", 0)
        typer.echo(f"error: {result.total - done} of {result.total} points did not finish; "
                   f"their reasons: grainflow sweep-status {result.sweepdir}", err=True)
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
    with _errors():
        if status is not None and status not in STATUSES:
            raise SweepFileError(f"--status must be one of {', '.join(STATUSES)}, not {status!r}")
        path = sweepdir / CATALOG_NAME
        if not path.exists():
            raise SweepError(f"{sweepdir} has no {CATALOG_NAME}; is it a sweep directory?")
        # read only where nothing may be written (a read-only directory or file)
        readonly = not (os.access(sweepdir, os.W_OK) and os.access(path, os.W_OK))
        with Catalog(path, readonly=readonly) as catalog:
            try:
                rows = catalog.rows(status)
                counts = catalog.counts()
            except (sqlite3.Error, ValueError, KeyError) as exc:  # bad rows: JSON, statuses
                raise SweepError(damaged_catalog_message(path, f"{type(exc).__name__}: {exc}")) from None
        if csv == "-":
            export_csv(rows, sys.stdout)
            return
        if csv is not None:
            try:
                with open(csv, "w", newline="") as stream:
                    export_csv(rows, stream)
            except OSError as exc:
                raise SweepError(f"cannot write {csv}: {exc.strerror or exc}") from None
            typer.echo(f"wrote {len(rows)} rows to {csv}")
            return
        console = Console(highlight=False)
        console.print(status_table(rows))
        console.out(", ".join(f"{counts[s]} {s}" for s in STATUSES)
                    + f" ({sum(counts.values())} points)")


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
