"""The ``grainflow`` command: run, resume, inspect, export and view simulations.

Exit codes: 0 success; 1 the run failed (unstable, or an unexpected error); 2 bad input
(invalid config or value, unusable run directory, bad option); 128 + signal number when
SIGINT (130) or SIGTERM (143) stopped a run after writing its checkpoint. Failures print one line,
``error: <reason>``, on stderr (an invalid configuration: one line per problem; ``--debug``
shows the traceback instead); warnings print one line each, ``warning: <message>``.

Heavy modules (numba, h5py, matplotlib) are imported inside the verbs, so ``--help`` and
``--version`` answer at once.
"""

from __future__ import annotations

import importlib.util
import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Optional

import typer

from grainflow import __version__, interrupt

if TYPE_CHECKING:
    from grainflow.engine.threads import Threads

app = typer.Typer(
    name="grainflow", no_args_is_help=True, add_completion=False,
    pretty_exceptions_enable=False, rich_markup_mode=None,
    help="DEM simulation of granular flows: run a TOML config, resume, inspect and export runs.")

_state: dict[str, Any] = {"debug": False, "interrupt_reported": False}

ThreadsOption = Annotated[Optional[str], typer.Option(
    "--threads", help="Compute threads: 'auto' (measure during the run whether one thread or "
                      "all cores is faster; the default unless the config says otherwise) or "
                      "a count.")]
ProgressOption = Annotated[str, typer.Option(
    help="Progress display: auto (a bar on a terminal, plain lines otherwise), rich, plain "
         "or none.")]


def _version(value: bool) -> None:
    if value:
        typer.echo(f"grainflow {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
    threads: ThreadsOption = None,
    debug: Annotated[bool, typer.Option(help="Show tracebacks instead of one-line errors.")] = False,
) -> None:
    """DEM simulation of granular flows."""
    _state["debug"] = debug
    if not debug:
        warnings.showwarning = _one_line_warning
    with _errors():
        _state["threads"] = _threads(threads)


# ---------------------------------------------------------------------------------- verbs
@app.command()
def run(
    config: Annotated[Path, typer.Argument(help="Run configuration (TOML).", dir_okay=False)],
    output: Annotated[Optional[Path], typer.Option(
        "--output", "-o", help="Run directory (default: the config's name, here).")] = None,
    overwrite: Annotated[bool, typer.Option(
        help="Replace the outputs of an existing run in the run directory.")] = False,
    threads: ThreadsOption = None,
    progress: ProgressOption = "auto",
) -> None:
    """Run CONFIG into a run directory (refused if it is not empty, unless --overwrite)."""
    from grainflow.runner import run_config

    rundir = output if output is not None else Path.cwd() / config.stem
    with _errors():
        summary = run_config(config, rundir, overwrite=overwrite, progress=progress,
                             threads=_threads(threads), log=lambda line: typer.echo(line, err=True))
    typer.echo(f"finished: {summary.step} steps, N = {summary.n_particles}, "
               f"{summary.wall_time_s:.1f} s, {summary.particle_steps_per_s:.3g} "
               f"particle-steps/s -> {rundir}")


@app.command()
def resume(
    rundir: Annotated[Path, typer.Argument(help="Run directory to continue.", file_okay=False)],
    threads: ThreadsOption = None,
    progress: ProgressOption = "auto",
) -> None:
    """Continue the run in RUNDIR from its last checkpoint."""
    from grainflow.runner import resume_run

    with _errors():
        summary = resume_run(rundir, progress=progress, threads=_threads(threads))
    typer.echo(f"finished: {summary.step} steps, N = {summary.n_particles}, "
               f"{summary.wall_time_s:.1f} s in total -> {rundir}")


@app.command()
def info(
    rundir: Annotated[Path, typer.Argument(help="Run directory.", file_okay=False)],
) -> None:
    """Describe the run in RUNDIR: set-up, status, checkpoint, frames, last thermo row."""
    from grainflow import runner

    with _errors():
        for name, value in _describe(rundir, runner):
            typer.echo(f"{name:<12} {value}")


@app.command()
def export(
    rundir: Annotated[Path, typer.Argument(help="Run directory.", file_okay=False)],
    format: Annotated[str, typer.Option(
        "--format", "-f", help="dump (LAMMPS text dump, for OVITO) or vtk (.vtp series and "
                               ".pvd, for ParaView).")] = "dump",
    output: Annotated[Optional[Path], typer.Option(
        "--output", "-o", help="File (dump) or folder (vtk); default: RUNDIR/frames.dump "
                               "or RUNDIR/vtk.")] = None,
) -> None:
    """Export the frames of RUNDIR (frames.h5) to another format."""
    with _errors():
        path, count = export_frames(rundir, format, output)
    typer.echo(f"wrote {count} frames to {path}")


@app.command()
def view(
    run: Annotated[Path, typer.Argument(help="Run directory (or a frames.h5 trajectory file).")],
    output: Annotated[Optional[Path], typer.Option(
        "--output", "-o", help="Movie file: .mp4 (H.264) or .gif; default RUN/movie.mp4.")] = None,
    poster: Annotated[Optional[Path], typer.Option(
        help="Poster picture (.png) of the last frame shown; default RUN/poster.png.")] = None,
    color_by: Annotated[str, typer.Option(
        "--color-by", help="Grain colour: speed, type, network (contact network size, log "
                           "scale), radius, mass, omega, body, id or depth.")] = "speed",
    delta: Annotated[float, typer.Option(
        help="Contact distance margin of --color-by network, in the run's length unit "
             "(0: touching).")] = 0.0,
    every: Annotated[int, typer.Option(help="Show every K-th frame.")] = 1,
    frames: Annotated[Optional[str], typer.Option(
        help="Range of frame numbers a:b (e.g. 0:50, -20:); default all.")] = None,
    fps: Annotated[float, typer.Option(help="Pictures per second.")] = 10.0,
    size: Annotated[Optional[str], typer.Option(
        help="WIDTHxHEIGHT in pixels (even for MP4); default from the run's extent in 2D, "
             "640x480 in 3D.")] = None,
    plane: Annotated[Optional[str], typer.Option(
        help="3D: an ortho view of two axes (xz: side, xy: top) instead of the perspective "
             "view; with --renderer matplotlib the projection plane (default xz).")] = None,
    renderer: Annotated[str, typer.Option(
        help="auto (OVITO for 3D, matplotlib for 2D), ovito or matplotlib (3D as flat "
             "disks).")] = "auto",
    quality: Annotated[str, typer.Option(
        help="OVITO: fast, or fine (ambient occlusion, about 4x slower).")] = "fast",
    vmin: Annotated[Optional[float], typer.Option(
        help="Colour scale start; default the lowest value over the frames shown (0 for "
             "speeds).")] = None,
    vmax: Annotated[Optional[float], typer.Option(
        help="Colour scale end; default the highest value over the frames shown.")] = None,
    cmap: Annotated[Optional[str], typer.Option(help="A matplotlib colour map.")] = None,
    progress: ProgressOption = "auto",
) -> None:
    """Write a movie and a poster frame of the run in RUN, grains coloured by speed, type or
    contact network; time and step on every frame."""
    with _errors():
        from grainflow.plotting.movie import write_movie

        movie, picture = _view_outputs(run, output, poster)
        write_movie(run, movie, color_by=color_by, delta=delta, every=every, frames=frames,
                    fps=fps, size=size, poster=picture, plane=plane, renderer=renderer,
                    quality=quality, vmin=vmin, vmax=vmax, cmap=cmap, progress=progress)
    typer.echo(f"wrote {movie} and {picture}")


@app.command()
def demo(
    output: Annotated[Path, typer.Option("--output", "-o", help="Run directory.")]
    = Path("grainflow-demo"),
    threads: ThreadsOption = None,
    progress: ProgressOption = "auto",
) -> None:
    """Run a small 2D hopper discharge: flow rate, snapshot.png, flow_rate.png and movie.mp4."""
    with _errors():
        from grainflow.studies.hopper_demo import demo as hopper_demo

        hopper_demo(output, threads=_threads(threads) or "auto", progress=progress)


@app.command()
def study(
    name: Annotated[str, typer.Argument(help="Which study: 'hopper' (seed 003, soft "
                                        "particles), 'hopper-dp' (seed 003, deformable "
                                        "rings; docs/dp.md), 'jet' (seed 002, granular "
                                        "jets; docs/jets.md) or 'stream' (seed 000, "
                                        "cohesive streams; docs/streams.md).")],
    output: Annotated[Path | None, typer.Option("--output", "-o",
                                                help="Study directory (default: NAME_study).")]
    = None,
    full: Annotated[bool, typer.Option("--full", help="The full study instead of the reduced "
                                       "one (see docs/hopper_study.md for its cost).")] = False,
    scheduler: Annotated[str | None, typer.Option(
        "--scheduler", help="dask scheduler address (default: a local cluster).")] = None,
    convention: Annotated[str, typer.Option(
        "--convention", help="hopper: 'authors' (the second pass, on the authors' code "
        "conventions) or 'grainflow' (the first pass, the printed seed as we read it).")]
    = "authors",
    progress: ProgressOption = "auto",
) -> None:
    """Reproduce a seed study through the sweep engine and write its report.md."""
    with _errors():
        if name not in ("hopper", "hopper-dp", "jet", "stream"):
            raise UsageError(f"study: {name!r} is not known; available: hopper, hopper-dp, "
                             "jet, stream")
        if convention not in ("authors", "grainflow"):
            raise UsageError(f"--convention: {convention!r} is not valid; use 'authors' or "
                             "'grainflow'")
        if name == "jet":
            from grainflow.studies.jet_study import reproduce
        elif name == "stream":
            from grainflow.studies.stream_study import reproduce
        elif name == "hopper-dp":
            if convention != "authors":
                raise UsageError("--convention: the DP study runs on the authors' "
                                 "conventions only")
            from grainflow.studies.hopper_dp import reproduce_dp as reproduce
        elif convention == "authors":
            from grainflow.studies.hopper_authors import reproduce_authors as reproduce
        else:
            from grainflow.studies.hopper_study import reproduce

        if progress not in ("auto", "rich", "plain", "none"):
            raise UsageError(f"--progress: {progress!r} is not valid; use auto, rich, plain "
                             "or none")
        report = reproduce(output or Path(f"{name}_study"), reduced=not full,
                           scheduler=scheduler, progress=progress)
        typer.echo(f"report: {report}")


@app.command()
def docs(
    gallery: Annotated[bool, typer.Option(
        "--gallery/--no-gallery", help="Run the gallery scripts (minutes) or only show "
        "their code (seconds).")] = True,
    open_browser: Annotated[bool, typer.Option(
        "--open/--no-open", help="Open the built site in a web browser.")] = True,
    site_dir: Annotated[Optional[Path], typer.Option(
        "--site-dir", help="Where to build (default: site/ in the checkout).")] = None,
) -> None:
    """Build the documentation site from this source checkout (needs the docs extra:
    pip install -e '.[docs]') and open it."""
    with _errors():
        from grainflow.docs_site import build_site, open_site

        index = build_site(site_dir, gallery=gallery)
        typer.echo(f"site: {index}")
        if open_browser and not open_site(index):
            typer.echo(f"no web browser here; open {index.as_uri()} in one")


@app.command(context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def bench(ctx: typer.Context) -> None:
    """Run the chute peer benchmark (benchmarks/chute.py) against LAMMPS.

    Arguments are passed on to the script; 'grainflow bench -- --help' lists them.
    """
    with _errors():
        _benchmark_main()(list(ctx.args))


def entry(argv: list[str] | None = None) -> None:
    """The ``grainflow`` program: :data:`app`, with click's own usage errors (a bad option,
    a directory given for a file) turned into one ``error:`` line and exit code 2 as well."""
    try:
        code = app(args=argv, prog_name="grainflow", standalone_mode=False)
    except (typer.Abort, KeyboardInterrupt):  # the latter while typer builds the command
        typer.echo("error: interrupted", err=True)
        sys.exit(130)
    except typer.TyperException as err:  # click's usage errors (typer's own copy of click)
        message = err.format_message() if hasattr(err, "format_message") else str(err)
        typer.echo(f"error: {' '.join(message.split())}", err=True)
        sys.exit(getattr(err, "exit_code", 2))
    if code == 130 and not _state["interrupt_reported"]:
        # typer turns a Ctrl-C outside our verbs into a silent exit 130 (inside them,
        # _errors has said it already)
        typer.echo("error: interrupted", err=True)
    sys.exit(code if isinstance(code, int) else 0)


def _register_sweep() -> None:
    """Add ``sweep`` and ``sweep-status`` when the sweep subsystem is importable."""
    try:
        from grainflow.sweep.cli import sweep_command, sweep_status_command
    except ImportError:
        return
    app.command("sweep")(sweep_command)
    app.command("sweep-status")(sweep_status_command)


_register_sweep()


# -------------------------------------------------------------------------------- helpers
class UsageError(ValueError):
    """Bad command-line input (exit code 2)."""


@contextmanager
def _errors() -> Iterator[None]:
    """Turn exceptions into ``error: <one line>`` and the documented exit codes."""
    try:
        yield
    except typer.Exit:
        raise
    except Exception as err:  # every failure ends in one line and a non-zero status
        if interrupt.received():  # an import the start-up interrupt broke
            _report_interrupt()
            raise typer.Exit(130) from None
        if _state["debug"]:
            raise
        code = getattr(err, "exit_code", None)
        if isinstance(err, (ValueError, FileNotFoundError)):  # bad input: ConfigError, UsageError
            code = 2
        for line in getattr(err, "messages", None) or [str(err)]:
            message = " ".join(str(line).split()) or type(err).__name__
            typer.echo(f"error: {message}", err=True)
        raise typer.Exit(code if code is not None else 1) from None
    except KeyboardInterrupt:
        _report_interrupt()
        raise typer.Exit(130) from None


def _report_interrupt() -> None:
    """Say "interrupted", once (:func:`entry` does not repeat it for the exit code 130)."""
    typer.echo("error: interrupted", err=True)
    _state["interrupt_reported"] = True


def _one_line_warning(message: Warning | str, category: type[Warning], filename: str,
                      lineno: int, file: Any = None, line: str | None = None) -> None:
    """``warning: <message>`` on one line (not Python's file, line and source form)."""
    text = " ".join(str(message).split())
    print(f"warning: {text}", file=file if file is not None else sys.stderr)


def _threads(text: str | None) -> "Threads | None":
    """``--threads``: ``"auto"`` or a count (a count also becomes numba's, as a cap for the
    whole process); None: the verb's own option was not given, so the global one, if any."""
    if text is None:
        return _state.get("threads")
    import numba

    from grainflow.engine.threads import check_threads

    try:
        value = check_threads("auto" if text == "auto" else int(text) if text.isdigit()
                              else text)
    except ValueError as err:  # name the option the user typed
        raise UsageError(f"--{err}") from None
    if value != "auto":
        numba.set_num_threads(value)
    return value


def _benchmark_main() -> Callable[[list[str]], Any]:
    """``main`` of ``benchmarks/chute.py`` in the source tree (not part of the package)."""
    import grainflow

    script = Path(grainflow.__file__).resolve().parents[2] / "benchmarks" / "chute.py"
    if not script.is_file():
        raise RuntimeError(f"the benchmark needs {script}, which is only in a source checkout "
                           "of grainflow (install it with pip install -e)")
    spec = importlib.util.spec_from_file_location("grainflow_bench_chute", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if not hasattr(module, "main"):
        raise RuntimeError(f"{script} has no main(argv) function")
    return module.main


def _view_outputs(run: Path, output: Path | None, poster: Path | None) -> tuple[Path, Path]:
    """The movie and poster paths of ``grainflow view``: given ones as they are; defaults
    ``RUN/movie.mp4`` and ``RUN/poster.png`` (beside the file for a trajectory file).

    A default path is only replaced if grainflow wrote it (the run directory's manifest,
    :func:`grainflow.runner.read_manifest`), and is recorded there; a file of the user's in
    its place is refused (give ``-o`` / ``--poster``, or move it away)."""
    from grainflow.runner import read_manifest, record_outputs

    if not run.exists():
        raise UsageError(f"{run}: no such run directory or trajectory file")
    folder = run if run.is_dir() else run.parent
    paths = {"movie.mp4": output, "poster.png": poster}
    defaults = [name for name, given in paths.items() if given is None]
    if defaults:
        ours = read_manifest(folder)
        for name in defaults:
            if (folder / name).exists() and name not in ours:
                option = "-o" if name == "movie.mp4" else "--poster"
                raise UsageError(f"{folder / name} exists and was not written by grainflow; "
                                 f"move it away or give {option}")
        record_outputs(folder, defaults)
    return (output if output is not None else folder / "movie.mp4",
            poster if poster is not None else folder / "poster.png")


def export_frames(rundir: Path, format: str, output: Path | None) -> tuple[Path, int]:
    """Write the frames of ``rundir/frames.h5`` as a LAMMPS dump or a VTK series."""
    from grainflow.io.h5md import read_frames
    from grainflow.runner import FRAMES, read_manifest, record_outputs

    if format not in ("dump", "vtk"):
        raise UsageError(f"--format: {format!r} is not valid; use dump or vtk")
    source = rundir / FRAMES
    if not source.is_file():
        raise UsageError(f"{rundir}: no {FRAMES} (was output.frames_every = 0?)")
    if output is None:
        # the default target in the run directory: only ever replace our own export
        name = "frames.dump" if format == "dump" else "vtk"
        if (rundir / name).exists() and name not in read_manifest(rundir):
            raise UsageError(f"{rundir / name} exists and was not written by grainflow; move "
                             "it away or give --output")
        record_outputs(rundir, [name])
    count = 0
    if format == "dump":
        from grainflow.io.lammps_dump import write_lammps_dump

        path = output or rundir / "frames.dump"
        path.write_text("")
        for frame in read_frames(source):
            write_lammps_dump(path, frame, append=True)
            count += 1
        return path, count
    from grainflow.io.vtk import VtkSeries

    path = output or rundir / "vtk"
    series = VtkSeries(path)
    for frame in read_frames(source):
        series.append(frame)
        count += 1
    return series.pvd_path, count


def _describe(rundir: Path, runner: Any) -> list[tuple[str, str]]:
    """(label, value) lines of ``grainflow info``."""
    import tomllib

    config_path = rundir / runner.CONFIG
    if not config_path.is_file():
        raise UsageError(f"{rundir}: no {runner.CONFIG}; is it a grainflow run directory?")
    config = tomllib.loads(config_path.read_text())
    run = config.get("run", {})
    length = f"{run['steps']} steps" if "steps" in run else f"duration {run.get('duration')}"
    lines = [("run dir", str(rundir.resolve())),
             ("scenario", f"{config.get('scenario', 'generic')}, {config.get('dim', 3)}D, "
                          f"{length}, integrator {run.get('integrator')}")]
    try:
        summary = runner.read_summary(rundir)
    except runner.RunDirError as err:
        summary = None
        lines.append(("summary", str(err)))
    else:
        if summary is None:
            lines.append(("status", "running, or stopped without a summary (killed?)"))
        else:
            lines.append(("status", f"{summary['status']} at step {summary['step']} of "
                                    f"{summary['steps']} (t = {summary['time']:.6g}, "
                                    f"dt = {summary['dt']:.6g})"))
            lines.append(("particles", str(summary["n_particles"])))
            lines.append(("wall time", f"{summary['wall_time_s']:.1f} s, "
                                       f"{summary['particle_steps_per_s']:.3g} "
                                       "particle-steps/s"))
            if summary["message"]:
                lines.append(("message", summary["message"]))
    try:
        step = runner.checkpoint_step(rundir / runner.CHECKPOINT)
    except runner.RunDirError as err:
        lines.append(("checkpoint", str(err)))
    else:
        if step is None:
            lines.append(("checkpoint", "none"))
        elif summary is not None and summary["status"] == "unstable":
            lines.append(("checkpoint", f"step {step}, the last healthy state; the run is "
                                        "unstable: resuming would repeat the failure. Fix "
                                        "the configuration and run it again with "
                                        "--overwrite"))
        elif summary is not None and summary["status"] == "finished":
            lines.append(("checkpoint", f"step {step} (the run is complete)"))
        else:
            lines.append(("checkpoint", f"step {step} (resume with: grainflow resume "
                                        f"{rundir})"))
    if (rundir / runner.FRAMES).is_file():
        from grainflow.io.h5md import count_frames

        lines.append(("frames", f"{count_frames(rundir / runner.FRAMES)} in {runner.FRAMES}"))
    thermo = rundir / runner.THERMO
    if thermo.is_file():
        rows = thermo.read_text().splitlines()
        if len(rows) > 1:
            last = dict(zip(rows[0].split(","), rows[-1].split(",")))
            lines.append(("thermo", ", ".join(f"{k}={_short(v)}" for k, v in last.items())))
    return lines


def _short(value: str) -> str:
    try:
        return f"{float(value):.6g}"
    except ValueError:
        return value

