"""Running a sweep on dask.distributed.

Each point is one task: :func:`run_point` calls the point runner (an ordinary
simulation writing its own run directory), then the analysis functions, and
returns a small record. The driving process (:func:`run_sweep`) is the only
one that writes the catalog; workers only need a shared filesystem for the
run directories.

Where tasks run:

* default: a :class:`~distributed.LocalCluster` on this machine, bound to
  127.0.0.1, one single-threaded worker process per core, with numba/OpenMP/BLAS
  limited to one thread per worker so that workers do not oversubscribe cores;
* ``scheduler="tcp://host:port"``: an existing cluster (dask-jobqueue, ``dask
  scheduler`` + ``dask worker``...); see ``docs/sweeps.md``.

A worker that dies (segfault, out of memory, node lost) has its task
rescheduled on another worker by the scheduler, up to the dask setting
``distributed.scheduler.allowed-failures`` (default 3); after that the point is
recorded as failed with ``KilledWorker`` and will be retried by the next sweep
invocation.
"""

from __future__ import annotations

import copy
import fcntl
import importlib
import json
import os
import queue
import shutil
import signal
import sqlite3
import threading
import time
import traceback
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import dask
import tomli_w
from distributed import Client, Future, LocalCluster, as_completed, get_worker
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from grainflow.progress import hms
from grainflow.sweep.catalog import (
    CATALOG_NAME,
    Catalog,
    CatalogError,
    damaged_target,
    move_aside,
    now,
)
from grainflow.sweep.spec import (
    DEFAULT_RUNNER,
    Point,
    SweepError,
    SweepSpec,
    validate_point_configs,
)

#: Environment of LocalCluster workers: one compute thread each (set before each worker
#: process is spawned: :func:`worker_environment`). ``NUMBA_NUM_THREADS`` is the cap of
#: a run's thread count; ``worker_threads`` of :func:`run_sweeps_together` raises it, the
#: others (numpy's linear algebra in the analyses) stay at one.
WORKER_ENV = {
    "NUMBA_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
}
#: dask's default pre-spawn environment sets this glibc variable to 64 KB so that workers
#: give freed memory back to the system at once. It also fixes glibc's thresholds, which
#: otherwise grow to fit a program's allocations: a run's few-hundred-KB temporaries (list
#: builds, per-step arrays) were then returned and faulted in again at every use. On the
#: stream study's run, 40 times the page faults (211 against 5 a step) and 8-15 % of its
#: speed (docs/sweeps.md). Local workers start without it (a value the caller set, other
#: than dask's own, is kept).
MALLOC_TRIM = "MALLOC_TRIM_THRESHOLD_"
POINT_FILE = "sweep_point.json"  # written into a run directory once its runner succeeded
LOCK_FILE = ".sweep.lock"
SWEEP_RECORD = "sweep.toml"
_POLL_SECONDS = 0.2
PROGRESS_MODES = ("auto", "rich", "plain", "none")


# ---------------------------------------------------------------------------------------
# What runs on a worker


@dataclass(frozen=True)
class PointTask:
    """Everything a worker needs to run one point (sent to the worker by pickling)."""

    point_id: str
    params: dict[str, Any]
    config: dict[str, Any]
    rundir: str
    runner: str
    analyses: tuple[str, ...]
    topic: str


def resolve_callable(ref: str) -> Callable[..., Any]:
    """Import ``"package.module:function"`` and return the function."""
    module_name, _, attr = ref.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise SweepError(f"cannot import {module_name!r} (from {ref!r}): {exc}") from None
    try:
        func = getattr(module, attr)
    except AttributeError:
        raise SweepError(f"module {module_name!r} has no function {attr!r} (from {ref!r})") from None
    if not callable(func):
        raise SweepError(f"{ref!r} is not callable")
    return func


def run_point(task: PointTask) -> dict[str, Any]:
    """Run one point on a worker: runner, then analyses. Never raises for a failing point.

    If a previous attempt's runner already completed (its ``sweep_point.json`` is
    present), the simulation is not repeated and only the analyses run again.
    Otherwise a stale run directory left by an interrupted attempt is removed first.
    The record's ``wall_time`` is what the point's result cost: this attempt, and the
    seconds earlier attempts spent on the part of the run it kept (a resumed run's segments
    before its checkpoint; a killed attempt's steps after its last checkpoint are computed
    again, and counted once).
    """
    started = time.perf_counter()
    worker = _announce_start(task)
    rundir = Path(task.rundir)
    notes: list[str] = []
    earlier = 0.0  # seconds earlier attempts spent on the part of the run this one keeps
    try:
        completed = _completed_run_seconds(rundir, task.point_id)
        if completed is not None:
            earlier = completed
        else:
            earlier = _run_or_resume(task, rundir, notes)
            _write_point_file(rundir, task, earlier + time.perf_counter() - started)
        summary = run_analyses(rundir, task.analyses)
        status, error = "done", None
    except PointFailed as exc:  # an expected failure: its message says it all
        status, summary, error = "failed", {}, f"{type(exc).__name__}: {exc}"
    except Exception:  # the point failed; the record carries the traceback
        status, summary, error = "failed", {}, traceback.format_exc()
    if notes and status == "done":
        error = "note: " + " ".join(notes)
    elif notes:
        error = f"note: {' '.join(notes)}\n{error}"
    return {
        "point_id": task.point_id,
        "status": status,
        "summary": summary,
        "error": error,
        "wall_time": earlier + time.perf_counter() - started,
        "worker": worker,
    }


class PointFailed(RuntimeError):
    """A point that cannot succeed as it is (recorded without a traceback)."""


def _run_or_resume(task: PointTask, rundir: Path, notes: list[str]) -> float:
    """Run the point, continuing what an earlier attempt left in ``rundir`` when possible;
    return the seconds earlier attempts spent on the part of the run that is kept.

    With grainflow's own runner, an earlier attempt of the same configuration is

    * finished (``summary.json`` says so; only the point file was missing): kept as it is;
    * interrupted or killed (a checkpoint, no finished summary): resumed from its checkpoint
      with :func:`grainflow.runner.resume_run`, so no step is computed twice;
    * unstable: not run again (it would fail the same way); the point fails with the reason
      and the run directory is kept for diagnosis;
    * unreadable (damaged checkpoint, config or summary): the run directory is moved aside
      to ``<point_id>.damaged-<time>`` (nothing is deleted) and the point runs from step 0,
      which gives the same result a resume would have given; ``notes`` says so.

    A run directory written for another configuration (the base config changed since), or
    one without a checkpoint (killed before its first step), or any run directory of another
    runner, is removed and the point runs from scratch, as before.
    """
    runner = resolve_callable(task.runner)
    if rundir.exists() and task.runner == DEFAULT_RUNNER:
        from grainflow.runner import (CHECKPOINT, RunDirError, checkpoint_wall_seconds,
                                      read_summary, resume_run)

        state, reason = _previous_attempt(rundir, task.config)
        if state == "finished":
            return float((read_summary(rundir) or {}).get("wall_time_s") or 0.0)
        if state == "unstable":
            raise PointFailed(
                f"an earlier attempt went unstable and is not resumed ({reason}); its run "
                f"directory {rundir} is kept for diagnosis. Change the configuration (e.g. a "
                "smaller run.dt) and run the sweep again, or delete that directory to run the "
                "point again unchanged"
            )
        if state == "resume":
            try:
                earlier = checkpoint_wall_seconds(rundir / CHECKPOINT)
                resume_run(rundir)
                return earlier
            except RunDirError as exc:  # the checkpoint turned out to be unreadable
                state, reason = "damaged", str(exc)
        if state == "damaged":
            moved = _move_damaged(rundir)
            notes.append(
                f"the earlier attempt's run directory could not be resumed ({reason}); it was "
                f"moved to {moved} and the point ran again from step 0"
            )
    if rundir.exists():
        shutil.rmtree(rundir)
    runner(copy.deepcopy(task.config), rundir)
    return 0.0


def _previous_attempt(rundir: Path, config: dict[str, Any]) -> tuple[str, str]:
    """Classify what an earlier attempt of grainflow's runner left in ``rundir``.

    Returns ``(state, reason)`` with state ``"finished"``, ``"resume"``, ``"unstable"``,
    ``"damaged"`` or ``"stale"`` (start again from scratch: nothing worth keeping).
    """
    import tomllib

    from grainflow.runner import CHECKPOINT, CONFIG, RunDirError, checkpoint_step, read_summary

    has_checkpoint = (rundir / CHECKPOINT).is_file()
    try:
        written = tomllib.loads((rundir / CONFIG).read_text())
    except FileNotFoundError:
        if not has_checkpoint:
            return "stale", "killed before it started"
        return "damaged", f"{CONFIG} is missing"
    except (OSError, ValueError) as exc:
        return "damaged", f"{CONFIG} is unreadable: {exc}"
    if not _same_config(written, config):
        return "stale", "written for another configuration"
    try:
        summary = read_summary(rundir)
    except RunDirError:
        summary = None  # a summary cut short by a kill: the checkpoint decides
    status = summary.get("status") if isinstance(summary, dict) else None
    if status == "unstable":  # with or without a healthy checkpoint
        return "unstable", str(summary.get("message") or "summary.json says unstable")
    if not has_checkpoint:
        return "stale", "no checkpoint"  # killed before its first checkpoint (step 0)
    try:
        step = checkpoint_step(rundir / CHECKPOINT)
    except Exception as exc:  # noqa: BLE001 - numpy/zipfile raise many kinds for bad files
        return "damaged", f"checkpoint unreadable: {type(exc).__name__}: {exc}"
    if step is None:
        return "damaged", "checkpoint unreadable"
    if status == "finished" and step == summary.get("step"):
        return "finished", ""
    return "resume", f"checkpoint at step {step}"


def _same_config(written: dict[str, Any], config: dict[str, Any]) -> bool:
    """Whether ``written`` (a run's config.toml) is what ``config`` resolves to."""
    import tomllib

    from grainflow.config.schema import load_config, resolved_dict, saved_config_upgraded

    try:
        resolved = tomllib.loads(tomli_w.dumps(resolved_dict(load_config(copy.deepcopy(config)))))
    except Exception:  # noqa: BLE001 - an invalid config: the runner will say why
        return False
    return resolved == saved_config_upgraded(written)


def _move_damaged(rundir: Path) -> Path:
    target = damaged_target(rundir)
    rundir.rename(target)
    return target


def run_analyses(rundir: Path, analyses: tuple[str, ...] | list[str]) -> dict[str, float]:
    """Call each ``f(rundir) -> {name: number}`` and merge the results."""
    summary: dict[str, float] = {}
    source: dict[str, str] = {}
    for ref in analyses:
        result = resolve_callable(ref)(rundir)
        if not isinstance(result, Mapping):
            raise TypeError(f"analysis {ref} returned {type(result).__name__}, not a dict")
        for key, value in result.items():
            if key in summary:
                raise ValueError(f"analyses {source[key]} and {ref} both return {key!r}")
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"analysis {ref} returned {key}={value!r}; values must be numbers")
            summary[str(key)], source[key] = float(value), ref
    return summary


def _announce_start(task: PointTask) -> str:
    """Tell the driving process that this point started; returns the worker address.

    The report travels on the worker's batched stream to the scheduler (a few
    milliseconds); a worker that dies within that time takes it along, and the
    attempt is not counted.
    """
    try:
        worker = get_worker()
    except ValueError:  # called outside a dask worker (e.g. directly in a test)
        return ""
    worker.log_event(task.topic, {"point_id": task.point_id, "worker": worker.address, "at": now()})
    return worker.address


def _completed_run_seconds(rundir: Path, point_id: str) -> float | None:
    """The recorded cost of this point's run if an earlier attempt completed it (its point
    file is there); None if the run is still to be done."""
    try:
        record = json.loads((rundir / POINT_FILE).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("point_id") != point_id:
        return None
    return float(record.get("run_wall_time") or 0.0)


def _write_point_file(rundir: Path, task: PointTask, run_wall_time: float) -> None:
    record = {"point_id": task.point_id, "params": task.params, "run_wall_time": run_wall_time}
    rundir.mkdir(parents=True, exist_ok=True)
    (rundir / POINT_FILE).write_text(json.dumps(record, indent=2) + "\n")


# ---------------------------------------------------------------------------------------
# The driving process


@dataclass
class SweepResult:
    """Outcome of :func:`run_sweep` for the points of this sweep."""

    sweepdir: Path
    total: int
    skipped: int  # already done before this invocation
    counts: dict[str, int] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when every point of the sweep is done."""
        return self.counts.get("done", 0) == self.total


def run_sweep(
    spec: SweepSpec,
    sweepdir: str | Path,
    *,
    scheduler: str | None = None,
    n_workers: int | None = None,
    progress: str = "auto",
    progress_interval: float = 30.0,
    console: Console | None = None,
    rebuild_catalog: bool = False,
    worker_threads: int = 1,
) -> SweepResult:
    """Run every point of ``spec`` not yet done in ``sweepdir`` and record it in the catalog.

    Parameters
    ----------
    spec : the validated sweep (:func:`grainflow.sweep.load_sweep`).
    sweepdir : sweep directory; holds ``catalog.sqlite``, ``sweep.toml`` and ``runs/<point_id>/``.
    scheduler : address of an existing dask scheduler; ``None`` starts a LocalCluster.
    n_workers : LocalCluster size (default: one worker per core); ignored with ``scheduler``.
    progress : ``"rich"`` (progress bar), ``"plain"`` (a status line every
        ``progress_interval`` seconds), ``"auto"`` (rich on a terminal, plain otherwise) or
        ``"none"`` (no status lines; messages about failed points still print).
    rebuild_catalog : if the catalog is damaged, move it aside and start a new one; the
        points whose runs finished are not run again (only their analyses).
    worker_threads : the most threads one run may use on a LocalCluster worker
        (``NUMBA_NUM_THREADS``; ignored with ``scheduler``). 1 (default) pins every run to
        one thread. More lets a run whose config says ``threads = "auto"`` take the cores
        other workers leave idle, as the last runs of a sweep do
        (:mod:`grainflow.engine.threads` measures, and stays on one thread while the
        other workers are busy).

    Before anything starts, every point's configuration is validated (grainflow's runner),
    relative file paths are made absolute (against the file that wrote them), and the sweep
    directory is checked to be writable; problems raise :class:`SweepFileError` or
    :class:`SweepError`.

    Ctrl-C (or SIGTERM) stops the sweep: running points go back to ``pending``,
    the cluster is closed and KeyboardInterrupt is re-raised. Running the same
    sweep again continues where it stopped.
    """
    return run_sweeps_together([(spec, sweepdir)], scheduler=scheduler, n_workers=n_workers,
                               progress=progress, progress_interval=progress_interval,
                               console=console, rebuild_catalog=rebuild_catalog,
                               worker_threads=worker_threads)[0]


def run_sweeps_together(
    sweeps: Sequence[tuple[SweepSpec, str | Path]],
    *,
    scheduler: str | None = None,
    n_workers: int | None = None,
    progress: str = "auto",
    progress_interval: float = 30.0,
    console: Console | None = None,
    rebuild_catalog: bool = False,
    worker_threads: int = 1,
) -> list[SweepResult]:
    """Run several sweeps, each ``(spec, sweepdir)``, on one set of workers at once.

    Each sweep keeps what :func:`run_sweep` gives it (its directory, lock, catalog, resumable
    points); the arguments are :func:`run_sweep`'s. Only the workers are shared: every
    sweep's points are submitted together, sweep by sweep in the order given, and the dask
    scheduler starts independent tasks in the order they were submitted. So a later sweep's
    points take the workers an earlier sweep's last points leave idle, where sweeps run one
    after the other leave them idle until each sweep's slowest point ends (a study whose last
    sweep is one long point ran it alone on one of two cores). Every sweep is validated and
    its directory locked before any point starts; two sweeps may not share a directory.
    Returns one :class:`SweepResult` per sweep, in the order given.
    """
    if progress not in PROGRESS_MODES:
        raise ValueError(f"progress must be one of {PROGRESS_MODES}, not {progress!r}")
    worker_env(worker_threads)  # a bad count is refused before anything starts
    console = console or Console(highlight=False)
    chosen = [(spec, Path(sweepdir).resolve()) for spec, sweepdir in sweeps]
    dirs = [sweepdir for _, sweepdir in chosen]
    for sweepdir in dirs:
        if dirs.count(sweepdir) > 1:
            raise SweepError(f"two of the sweeps run together write into {sweepdir}; give each "
                             "its own sweep directory")
    listed = []
    for spec, sweepdir in chosen:
        points = spec.points()
        resolve_callable(spec.runner)
        for ref in spec.analyses:
            resolve_callable(ref)
        validate_point_configs(spec, points, where=f"sweep {spec.name!r}: ")
        _prepare_sweepdir(sweepdir)
        listed.append((spec, sweepdir, points))
    with ExitStack() as stack:
        opened = [_open_sweep(stack, spec, sweepdir, points, rebuild_catalog, console)
                  for spec, sweepdir, points in listed]
        if any(o.tasks for o in opened):
            total = sum(len(o.ids) for o in opened)
            reporter = _make_reporter(progress, console, total, progress_interval)
            with _sigterm_as_interrupt(), open_client(scheduler, n_workers, console,
                                                              worker_threads) as client:
                _drive(client, opened, reporter)
        for o in opened:
            with _catalog_errors(o.catalog):
                o.result.counts = o.catalog.counts(o.ids)
    for o in opened:
        console.out(
            f"sweep {o.spec.name!r}: {o.result.counts['done']} done, "
            f"{o.result.counts['failed']} failed of {o.result.total}"
        )
    return [o.result for o in opened]


@dataclass
class _OpenSweep:
    """A sweep being driven: its catalog (open and locked), point ids and tasks to run."""

    spec: SweepSpec
    catalog: Catalog
    ids: list[str]
    tasks: list[PointTask]
    result: SweepResult


def _open_sweep(stack: ExitStack, spec: SweepSpec, sweepdir: Path, points: list[Point],
                rebuild_catalog: bool, console: Console) -> _OpenSweep:
    """Lock the sweep directory and open its catalog (both until ``stack`` closes), record
    the sweep, and set every point not yet done back to pending."""
    stack.enter_context(_exclusive(sweepdir))
    catalog = stack.enter_context(_open_catalog(sweepdir, rebuild_catalog, console))
    with _catalog_errors(catalog):
        _record_sweep(spec, sweepdir, catalog, console)
        catalog.register(points)
        catalog.reset_running()
        statuses = catalog.statuses()
        todo = [p for p in points if statuses[p.point_id] != "done"]
        catalog.requeue(p.point_id for p in todo)
    result = SweepResult(sweepdir, len(points), len(points) - len(todo))
    console.out(
        f"sweep {spec.name!r}: {len(points)} points, {result.skipped} already done, "
        f"{len(todo)} to run; catalog {catalog.path}"
    )
    return _OpenSweep(spec, catalog, [p.point_id for p in points],
                      _tasks(spec, todo, sweepdir), result)


def _tasks(spec: SweepSpec, points: list[Point], sweepdir: Path) -> list[PointTask]:
    topic = f"grainflow-sweep-{uuid.uuid4().hex}"
    return [
        PointTask(
            point_id=p.point_id,
            params={**p.overrides, p.seed_field: p.seed},
            config=spec.point_config(p),
            rundir=str(sweepdir / "runs" / p.point_id),
            runner=spec.runner,
            analyses=tuple(spec.analyses),
            topic=topic,
        )
        for p in points
    ]


def worker_env(threads: int = 1) -> dict[str, str]:
    """:data:`WORKER_ENV` with a run's thread cap ``NUMBA_NUM_THREADS = threads``."""
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"worker_threads: {threads!r} is not valid; expected a thread count "
                         ">= 1 (1 pins every run to one thread)")
    return {**WORKER_ENV, "NUMBA_NUM_THREADS": str(threads)}


@contextmanager
def worker_environment(threads: int = 1) -> Iterator[None]:
    """:func:`worker_env` in the environment each local worker process is spawned with.

    A LocalCluster's ``env`` reaches a worker only after the new process has imported the
    caller's main module (multiprocessing's spawn imports it again). A script that imports
    numba (or grainflow) at the top has then sized numba's thread pool from the machine, and
    the later ``NUMBA_NUM_THREADS = 1`` makes numba refuse every compilation in that worker
    ("Cannot set NUMBA_NUM_THREADS to a different value once the threads have been
    launched"): every point failed. dask's pre-spawn environment is put into this process's
    environment before each spawn (a restarted worker's too) and into the worker's own;
    this process's own values come back when the block ends. dask's own
    :data:`MALLOC_TRIM` is left out, also where an earlier dask cluster of this process put
    it into this process's environment (a nanny does so before it spawns)."""
    env = worker_env(threads)
    saved = {key: os.environ.get(key) for key in (*env, MALLOC_TRIM)}
    dask_default = dask.config.get("distributed.nanny.pre-spawn-environ", default={})
    pre_spawn = {**{k: v for k, v in dask_default.items() if k != MALLOC_TRIM}, **env}
    if MALLOC_TRIM in dask_default and os.environ.get(MALLOC_TRIM) == str(
            dask_default[MALLOC_TRIM]):
        del os.environ[MALLOC_TRIM]
    try:
        with dask.config.set({"distributed.nanny.pre-spawn-environ": pre_spawn}):
            yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


@contextmanager
def open_client(
    scheduler: str | None, n_workers: int | None, console: Console, worker_threads: int = 1
) -> Iterator[Client]:
    """A client on ``scheduler``, or on a fresh LocalCluster closed on exit whose workers
    run one task each, on up to ``worker_threads`` threads (:func:`worker_env`)."""
    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, ValueError) as exc:
            raise SweepError(f"cannot reach the dask scheduler at {scheduler}: {exc}") from None
        with client:
            console.out(f"using the dask cluster at {scheduler}")
            yield client
        return
    n_workers = n_workers or os.cpu_count() or 1
    with worker_environment(worker_threads), LocalCluster(
        n_workers=n_workers,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster, Client(cluster) as client:
        if worker_threads == 1:
            console.out(f"started a local cluster: {n_workers} single-threaded workers")
        else:
            console.out(f"started a local cluster: {n_workers} workers, one run each on up "
                        f"to {worker_threads} threads (a run with threads = 'auto' takes "
                        "cores the others leave idle)")
        yield client


def _drive(client: Client, sweeps: list[_OpenSweep], reporter: _Reporter) -> None:
    """Submit every sweep's tasks and record starts and results in each sweep's catalog
    until all finish."""
    started: queue.SimpleQueue[tuple[int, tuple[float, dict[str, str]]]] = queue.SimpleQueue()
    topics = []
    futures: dict[Future, tuple[int, PointTask]] = {}
    for k, sweep in enumerate(sweeps):
        if not sweep.tasks:
            continue
        topics.append(sweep.tasks[0].topic)
        client.subscribe_topic(topics[-1], lambda event, k=k: started.put((k, event)))
        for t in sweep.tasks:
            key = f"point-{t.point_id}-{uuid.uuid4().hex[:8]}"
            futures[client.submit(run_point, t, key=key, pure=False)] = (k, t)
    unfinished = as_completed(futures)
    reporter.start(_counts(sweeps))
    try:
        while not unfinished.is_empty():
            for future in unfinished.next_batch(block=False):
                k, task = futures[future]
                with _catalog_errors(sweeps[k].catalog):
                    recorded = _record_result(sweeps[k], future, task, reporter)
                if recorded:
                    del futures[future]
                else:
                    unfinished.add(future)
            _record_starts(sweeps, started)
            reporter.update(_counts(sweeps))
            time.sleep(_POLL_SECONDS)
        time.sleep(_POLL_SECONDS)  # start reports travel separately from results
        _record_starts(sweeps, started)
    except KeyboardInterrupt:
        client.cancel(list(futures))
        returned = 0
        for sweep in sweeps:
            with _catalog_errors(sweep.catalog):
                returned += sweep.catalog.reset_running()
        reporter.message(
            f"interrupted: {returned} running point(s) set back to pending; "
            "run the same command again to continue"
        )
        raise
    finally:
        reporter.stop(_counts(sweeps))
        for topic in topics:
            client.unsubscribe_topic(topic)


def _counts(sweeps: list[_OpenSweep]) -> dict[str, int]:
    """Points by status, summed over the sweeps."""
    total: dict[str, int] = {}
    for sweep in sweeps:
        with _catalog_errors(sweep.catalog):
            for status, n in sweep.catalog.counts(sweep.ids).items():
                total[status] = total.get(status, 0) + n
    return total


@contextmanager
def _catalog_errors(catalog: Catalog) -> Iterator[None]:
    """SQLite errors of ``catalog`` as :class:`CatalogError` naming its file (with several
    sweeps open, the error names the catalog that raised it)."""
    try:
        yield
    except sqlite3.Error as exc:
        raise catalog.error(exc) from None


def _record_starts(
    sweeps: list[_OpenSweep], started: queue.SimpleQueue[tuple[int, tuple[float, dict[str, str]]]]
) -> None:
    while not started.empty():
        k, (_, msg) = started.get()
        with _catalog_errors(sweeps[k].catalog):
            sweeps[k].catalog.mark_started(msg["point_id"], msg["worker"], msg["at"])


def _record_result(sweep: _OpenSweep, future: Future, task: PointTask,
                   reporter: _Reporter) -> bool:
    """Store a finished task; returns False if its result was lost and is being recomputed.

    A task that never returned (its worker died too often, or it was cancelled)
    is recorded as failed.
    """
    catalog = sweep.catalog
    if future.status == "finished":
        try:
            record = future.result(timeout=60)
        except Exception:  # the worker holding the result died meanwhile; wait again
            return False
        catalog.mark_finished(
            task.point_id,
            record["status"],
            summary=record["summary"],
            wall_time=record["wall_time"],
            error=record["error"],
            worker=record["worker"],
        )
        error = record["error"]
    elif future.status in ("error", "cancelled"):
        exc = future.exception() if future.status == "error" else None
        error = f"{type(exc).__name__}: {exc}" if exc else "task cancelled"
        catalog.mark_finished(task.point_id, "failed", error=error)
    else:  # "lost": the worker holding the result died; the scheduler recomputes it
        return False
    future.release()
    if error:
        last_line = error.strip().splitlines()[-1]
        reporter.message(f"point {task.point_id} of sweep {sweep.spec.name!r} "
                         f"({_label(task.params)}) failed: {last_line}")
    return True


def _label(params: dict[str, Any]) -> str:
    return " ".join(f"{k}={v!r}" for k, v in params.items())


def _prepare_sweepdir(sweepdir: Path) -> None:
    """Create the sweep directory and check that files can be written in it and in runs/."""
    fix = (
        "make it writable (e.g. chmod u+w) or choose another sweep directory with -o"
    )
    try:
        sweepdir.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise SweepError(f"{sweepdir} exists and is not a directory; choose another sweep "
                         "directory with -o") from None
    except OSError as exc:
        raise SweepError(f"cannot create the sweep directory {sweepdir} ({exc.strerror or exc}); "
                         "choose another with -o") from None
    if not sweepdir.is_dir():
        raise SweepError(f"{sweepdir} exists and is not a directory; choose another sweep "
                         "directory with -o")
    for folder in (sweepdir, sweepdir / "runs"):
        if not folder.is_dir():
            continue
        probe = folder / f".write-test-{uuid.uuid4().hex[:8]}"
        try:
            probe.write_text("")
            probe.unlink()
        except OSError as exc:
            raise SweepError(
                f"{folder} is not writable ({exc.strerror or exc}); {fix}"
            ) from None
    runs = sweepdir / "runs"
    if runs.exists() and not runs.is_dir():
        raise SweepError(f"{runs} is not a directory; move it away")


@contextmanager
def _open_catalog(sweepdir: Path, rebuild: bool, console: Console) -> Iterator[Catalog]:
    """The sweep's catalog; a damaged one is moved aside first when ``rebuild``.

    SQLite errors while the sweep runs (disk full, a file changed underneath) become
    :class:`CatalogError` naming the file."""
    path = sweepdir / CATALOG_NAME
    try:
        catalog = Catalog(path)
    except CatalogError:
        if not rebuild:
            raise
        moved = move_aside(path)
        console.out(f"the damaged catalog was moved to {moved}; rebuilding it from the run "
                    f"directories in {sweepdir / 'runs'}")
        catalog = Catalog(path)
    else:
        if rebuild:
            console.out(f"{path} is readable; nothing to rebuild")
    with _catalog_errors(catalog), catalog:
        yield catalog


@contextmanager
def _exclusive(sweepdir: Path) -> Iterator[None]:
    """Hold a lock on the sweep directory so two sweeps cannot drive it at once."""
    with open(sweepdir / LOCK_FILE, "w") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise SweepError(
                f"another 'grainflow sweep' is running in {sweepdir}; wait for it or stop it"
            ) from None
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _record_sweep(spec: SweepSpec, sweepdir: Path, catalog: Catalog, console: Console) -> None:
    """Save the resolved sweep file; warn if the base config changed since the last run."""
    # python mode: JSON mode would turn lambda = inf into null, which TOML cannot hold
    record = spec.model_dump(mode="python", exclude_none=True)
    record["base"] = spec.resolved_base()  # relative file paths would not resolve from here
    (sweepdir / SWEEP_RECORD).write_text(tomli_w.dumps(record))
    base = json.dumps(spec.base, sort_keys=True, default=str)
    previous = catalog.get_meta("base_config")
    if previous is not None and previous != base:
        console.out(
            "warning: the base config differs from the one this sweep directory was run with; "
            "points already done keep their old results (use a new sweep directory to redo them)"
        )
    catalog.set_meta("base_config", base)


@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """Treat SIGTERM (e.g. a batch system's time limit) like Ctrl-C while the sweep runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


# ---------------------------------------------------------------------------------------
# Progress


class _Reporter:
    """Tracks progress of the whole sweep and estimates the time left."""

    def __init__(self, console: Console, total: int) -> None:
        self.console = console
        self.total = total
        self._t0 = time.monotonic()
        self._finished_before = 0

    def start(self, counts: dict[str, int]) -> None:
        """Begin timing; ``counts`` are the statuses before any point of this run finished."""
        self._t0 = time.monotonic()
        self._finished_before = counts["done"] + counts["failed"]

    def message(self, text: str) -> None:
        self.console.out(text)

    def update(self, counts: dict[str, int]) -> None:
        raise NotImplementedError

    def stop(self, counts: dict[str, int]) -> None:
        raise NotImplementedError

    def status_line(self, counts: dict[str, int]) -> str:
        """'D/N done, F failed, R running, P pending; elapsed h:mm:ss, ETA h:mm:ss'."""
        return (
            f"{counts['done']}/{self.total} done, {self.activity(counts)}, "
            f"{counts['pending']} pending; elapsed {hms(time.monotonic() - self._t0)}, "
            f"ETA {self.eta_text(counts)}"
        )

    def activity(self, counts: dict[str, int]) -> str:
        return f"{counts['failed']} failed, {counts['running']} running"

    def eta_text(self, counts: dict[str, int]) -> str:
        eta = self._eta(counts)
        return hms(eta if eta is not None else float("inf"))

    def _eta(self, counts: dict[str, int]) -> float | None:
        """Remaining points times the mean time per point finished in this invocation."""
        finished = counts["done"] + counts["failed"]
        finished_now = finished - self._finished_before
        if finished_now <= 0:
            return None
        return (self.total - finished) * (time.monotonic() - self._t0) / finished_now


class _PlainReporter(_Reporter):
    """A status line every ``interval`` seconds (for logs and batch jobs)."""

    def __init__(self, console: Console, total: int, interval: float) -> None:
        super().__init__(console, total)
        self.interval = interval
        self._last = -float("inf")

    def update(self, counts: dict[str, int]) -> None:
        if time.monotonic() - self._last >= self.interval:
            self.console.out(self.status_line(counts))
            self._last = time.monotonic()

    def stop(self, counts: dict[str, int]) -> None:
        self.console.out(self.status_line(counts))


class _QuietReporter(_Reporter):
    """No progress lines (``progress="none"``); messages about points still print."""

    def update(self, counts: dict[str, int]) -> None:
        pass

    def stop(self, counts: dict[str, int]) -> None:
        pass


class _RichReporter(_Reporter):
    """A live progress bar (for terminals)."""

    def __init__(self, console: Console, total: int) -> None:
        super().__init__(console, total)
        self._progress = Progress(
            TextColumn("sweep"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.description}"),
            TimeElapsedColumn(),
            console=console,
        )
        self._task = self._progress.add_task("", total=total)

    def start(self, counts: dict[str, int]) -> None:
        super().start(counts)
        self._progress.start()
        self.update(counts)

    def message(self, text: str) -> None:
        self._progress.console.out(text)

    def update(self, counts: dict[str, int]) -> None:
        self._progress.update(
            self._task,
            completed=counts["done"] + counts["failed"],
            description=f"{self.activity(counts)}, ETA {self.eta_text(counts)}",
        )

    def stop(self, counts: dict[str, int]) -> None:
        self.update(counts)
        self._progress.stop()


def _make_reporter(mode: str, console: Console, total: int, interval: float) -> _Reporter:
    if mode == "none":
        return _QuietReporter(console, total)
    if mode == "rich" or (mode == "auto" and console.is_terminal):
        return _RichReporter(console, total)
    return _PlainReporter(console, total, interval)
