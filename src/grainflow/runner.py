"""Running a configuration into a run directory, with checkpoints, and resuming it.

Run directory (see ``docs/config.md``)::

    config.toml         the resolved configuration (defaults filled in, paths absolute)
    thermo.csv          step, time, N, energies, max overlap, contacts, rebuilds, rate
    frames.h5           frames in the H5MD layout (docs/output_format.md)
    checkpoint.npz      the whole state at the last healthy checkpoint (written atomically)
    unstable_state.npz  the state where a run went unstable (diagnosis only)
    final.png           snapshot of the final state, coloured by speed
    summary.json        status, steps, N, wall time, particle-steps/s, message
    .grainflow-manifest every file grainflow wrote here (with the config's checksum)

A run that is killed loses only the steps since its last checkpoint: :func:`resume_run`
rebuilds the simulation from ``config.toml``, loads ``checkpoint.npz``, trims ``thermo.csv``
and ``frames.h5`` back to the checkpoint's step and continues; the final state is bitwise
the one of an uninterrupted run. SIGINT and SIGTERM write a checkpoint before the run stops.

Nothing of the user's is deleted or replaced: ``overwrite`` removes only the files the
manifest lists, and refuses when a file grainflow would write is not its own (or the config
it wrote was edited since). A run that goes unstable stops before anything non-finite is
written, keeps its last healthy checkpoint, and is not resumed (it would fail again).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Mapping

import numba
import numpy as np
import tomli_w

from grainflow import __version__
from grainflow.config.build import build_simulation, total_steps
from grainflow.config.schema import RunConfig, load_config, resolved_dict
from grainflow.engine.simulation import InstabilityError, Simulation
from grainflow.engine.threads import Threads, check_threads
from grainflow.io.h5md import RUN_TRAJECTORY
from grainflow.io.thermo import THERMO_COLUMNS, ThermoLog
from grainflow.progress import Progress, make_progress

Log = Callable[[str], None]

__all__ = ["CHECKPOINT_VERSION", "RunDirError", "RunError", "RunInterrupted", "RunSummary",
           "RunUnstable", "checkpoint_step", "read_checkpoint", "read_manifest",
           "read_summary", "record_outputs", "resume_run", "run_config", "write_checkpoint"]

#: Layout version of checkpoint files; a resume refuses other versions.
CHECKPOINT_VERSION = 2

CONFIG = "config.toml"
THERMO = "thermo.csv"
FRAMES = RUN_TRAJECTORY
CHECKPOINT = "checkpoint.npz"
UNSTABLE = "unstable_state.npz"
SNAPSHOT = "final.png"
SUMMARY = "summary.json"
MANIFEST = ".grainflow-manifest"
#: Temporary names only grainflow uses (removed by ``overwrite`` wherever they come from).
TEMPORARY = ("checkpoint.tmp", CONFIG + ".tmp", SUMMARY + ".tmp", MANIFEST + ".tmp",
             FRAMES + ".recover", FRAMES + ".repair", THERMO + ".tmp", "final.tmp.png")


class RunError(RuntimeError):
    """A run could not start or did not finish; ``exit_code`` is the CLI's status."""

    exit_code = 1


class RunDirError(RunError):
    """The run directory cannot be used (not empty, nothing to resume ...)."""

    exit_code = 2


class RunInterrupted(RunError):
    """SIGINT/SIGTERM stopped the run after writing a checkpoint."""

    def __init__(self, message: str, signum: int) -> None:
        super().__init__(message)
        self.exit_code = 128 + signum


class RunUnstable(RunError):
    """The health check failed; the last healthy checkpoint is kept."""


@dataclass
class RunSummary:
    """What ``summary.json`` holds."""

    status: str  # "finished", "interrupted" or "unstable"
    step: int
    steps: int
    time: float
    dt: float
    n_particles: int
    wall_time_s: float
    particle_steps_per_s: float
    message: str = ""
    version: str = __version__

    def write(self, rundir: Path) -> None:
        _atomic_write_text(rundir / SUMMARY, json.dumps(asdict(self), indent=2) + "\n")


#: Steps between two looks at the stop flag that SIGINT/SIGTERM set, and between progress
#: reports.
UNTIL_EVERY = 10


# --------------------------------------------------------------------------- public API
def run_config(config: RunConfig | Mapping[str, Any] | str | os.PathLike[str],
               rundir: str | os.PathLike[str], *, overwrite: bool = False,
               resume: bool = False, threads: Threads | None = None,
               progress: str | Progress | None = None, log: Log | None = None) -> RunSummary:
    """Run a configuration (RunConfig, dict or TOML path) into ``rundir``.

    An existing non-empty ``rundir`` is refused unless ``overwrite`` (the outputs grainflow
    wrote there are deleted first, nothing else; ``log`` is told which) or ``resume``
    (continue from its checkpoint if it has one). ``threads`` (``"auto"`` or a count)
    overrides the config's ``run.threads`` (:mod:`grainflow.engine.threads`);
    ``progress`` is ``"auto"`` (default), ``"rich"``, ``"plain"``, ``"none"`` or a
    :class:`~grainflow.progress.Progress`. Everything is validated before the run
    directory is touched. Raises :class:`~grainflow.config.schema.ConfigError`,
    :class:`RunDirError`, :class:`RunInterrupted` or :class:`RunUnstable`.
    """
    rundir = Path(rundir)
    if resume and (rundir / CHECKPOINT).is_file():
        return resume_run(rundir, threads=threads, progress=progress)
    cfg = config if isinstance(config, RunConfig) else load_config(config)
    display = _progress(progress, cfg)
    threads = check_threads(cfg.run.threads if threads is None else threads)
    outputs = _outputs_of(cfg)
    removed = _check_rundir(rundir, overwrite, outputs)
    sim = build_simulation(cfg)
    _use_threads(sim, threads)
    total_steps(cfg, sim)  # a run that can never finish is refused here
    _prepare_rundir(rundir, removed)  # only now, when everything is known to be valid
    if removed and log is not None:
        log(f"removed the previous run's outputs from {rundir}: {', '.join(removed)}")
    text = tomli_w.dumps(resolved_dict(cfg))
    record_outputs(rundir, outputs, config_text=text)
    _atomic_write_text(rundir / CONFIG, text)
    return _Run(cfg, sim, rundir, display).execute(fresh=True)


def resume_run(rundir: str | os.PathLike[str], *, threads: Threads | None = None,
               progress: str | Progress | None = None) -> RunSummary:
    """Continue the run in ``rundir`` from its last checkpoint."""
    rundir = Path(rundir)
    for name in (CONFIG, CHECKPOINT):
        if not (rundir / name).is_file():
            raise RunDirError(f"{rundir}: no {name}; is it a grainflow run directory "
                              "(written by 'grainflow run')?")
    try:
        summary = read_summary(rundir)
    except RunDirError:
        summary = None  # cut short by a kill: the checkpoint decides, the summary is rewritten
    if summary is not None and summary.get("status") == "unstable":
        raise RunDirError(f"{rundir}: the run went unstable ({summary.get('message')}); "
                          "resuming from its last healthy checkpoint would repeat the "
                          f"failure. Fix the configuration and start again: grainflow run "
                          f"CONFIG -o {rundir} --overwrite")
    cfg = load_config(rundir / CONFIG, saved=True)
    threads = check_threads(cfg.run.threads if threads is None else threads)
    saved = read_checkpoint(rundir / CHECKPOINT)
    sim = build_simulation(cfg, prepare=False)
    _use_threads(sim, threads)
    sim.load_state_dict(saved["sim"])
    run = _Run(cfg, sim, rundir, _progress(progress, cfg))
    run.load_state_dict(saved["runner"])
    return run.execute(fresh=False)


def _use_threads(sim: Simulation, threads: Threads) -> None:
    """``"auto"``, or a fixed count that also becomes numba's (for the work between runs:
    set-up, outputs)."""
    sim.threads = threads
    if threads != "auto":
        numba.set_num_threads(threads)


# ------------------------------------------------------------------------- the run itself
class _Run:
    """One segment of a run (from step 0 or from a checkpoint) with its observers."""

    def __init__(self, config: RunConfig, sim: Simulation, rundir: Path,
                 progress: Progress) -> None:
        self.config = config
        self.sim = sim
        self.rundir = rundir
        self.progress = progress
        self.total = total_steps(config, sim)
        self.previous_wall = 0.0
        self.checkpoint_step = -1
        self.start = (time.perf_counter(), sim.particle_steps)
        # observers a scenario attached; their accumulators go into checkpoints
        self.user_observers = {str(k): o.owner for k, o in enumerate(sim.observers)
                               if hasattr(o.owner, "state_dict")}

    # ------------------------------------------------------------ checkpoint contents
    def state_dict(self) -> dict[str, Any]:
        return {"version": CHECKPOINT_VERSION, "grainflow": __version__,
                "wall_seconds": self.elapsed(),
                "observers": {k: o.state_dict() for k, o in self.user_observers.items()}}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        if data.get("version") != CHECKPOINT_VERSION:
            raise RunDirError(f"checkpoint version {data.get('version')} is not "
                              f"{CHECKPOINT_VERSION}; it was written by another grainflow "
                              f"({data.get('grainflow')}) and cannot be resumed by this one")
        self.previous_wall = float(data["wall_seconds"])
        for k, obs in self.user_observers.items():
            obs.load_state_dict(data["observers"].get(k, {}))

    def checkpoint(self, sim: Simulation) -> None:
        """Observer: health check, then write the checkpoint atomically."""
        sim.check_health()
        write_checkpoint(self.rundir / CHECKPOINT,
                         {"sim": sim.state_dict(), "runner": self.state_dict()})
        self.checkpoint_step = sim.step

    # --------------------------------------------------------------------- the loop
    def execute(self, fresh: bool) -> RunSummary:
        sim, out = self.sim, self.config.output
        resume_step = None if fresh else sim.step
        self.start = (time.perf_counter(), sim.particle_steps)
        thermo = ThermoLog(self.rundir / THERMO, resume_step)
        frames = self._frames(resume_step) if out.frames_every else None

        def save_frame(s: Simulation) -> None:
            if frames is not None and s.time >= out.frames_from * (1 - 1e-12):
                frames.append(s.frame(contacts=out.contacts))
        stop = _StopRequest()
        try:
            with stop.installed():
                if fresh:
                    sim.compute_forces(update=False)
                    self.checkpoint(sim)  # its health check comes before anything is written
                    thermo(sim.observer_context)
                    save_frame(sim)
                else:
                    self.checkpoint_step = sim.step
                sim.add_observer(thermo, out.thermo_every)
                if frames is not None:
                    sim.add_observer(save_frame, out.frames_every)
                sim.add_observer(lambda s: self.progress.update(s.step, s.state.n,
                                                                self.rate()), UNTIL_EVERY,
                                 checked=False)
                if out.checkpoint_every:
                    sim.add_observer(lambda _: self.checkpoint(sim), out.checkpoint_every)
                self.progress.start(self.total, sim.step)
                # a signal is noticed within UNTIL_EVERY steps (runs of quiet steps between
                # the checks go through the compiled step loop)
                sim.run(max(0, self.total - sim.step), until=lambda s: stop.signum is not None,
                        until_every=UNTIL_EVERY)
                if self.checkpoint_step != sim.step:
                    self.checkpoint(sim)
                interrupted = stop.signum if sim.step < self.total else None
                if interrupted is None:
                    # complete from here on: a signal while the snapshot is drawn is ignored
                    summary = self._summary("finished", "")
                    summary.write(self.rundir)
                    if out.snapshot:
                        self._snapshot()
        except InstabilityError as err:
            self._unstable(err)
        finally:
            self.progress.close()
            thermo.close()
            if frames is not None:
                frames.close()
        if interrupted is not None:
            name = signal.Signals(interrupted).name
            message = (f"stopped by {name} at step {sim.step}; checkpoint written, continue "
                       f"with: grainflow resume {self.rundir}")
            self._summary("interrupted", message).write(self.rundir)
            raise RunInterrupted(message, interrupted)
        return summary

    def _frames(self, resume_step: int | None) -> Any:
        """The trajectory writer; on resume a damaged ``frames.h5`` is first repaired to its
        last whole frame up to the checkpoint (the original kept as ``frames.h5.damaged``)."""
        from grainflow.io.h5md import (DamagedFileError, TrajectoryWriter, max_rows_for,
                                       repair_frames)

        sim, out = self.sim, self.config.output

        def writer() -> TrajectoryWriter:
            return TrajectoryWriter(
                self.rundir / FRAMES, sim.state.dim, sim.state.box, contacts=out.contacts,
                compression=None if out.compression == "none" else out.compression,
                append=resume_step is not None, resume_step=resume_step,
                max_rows=max_rows_for(sim.state.n))
        try:
            return writer()
        except DamagedFileError:
            if resume_step is None:
                raise
            repair_frames(self.rundir / FRAMES, resume_step)  # warns: what was kept
            return writer()

    def elapsed(self) -> float:
        """Wall-clock seconds of the whole run so far (all segments)."""
        return self.previous_wall + time.perf_counter() - self.start[0]

    def rate(self) -> float:
        """Particle-steps per wall-clock second of this segment."""
        seconds = time.perf_counter() - self.start[0]
        return (self.sim.particle_steps - self.start[1]) / seconds if seconds > 0 else 0.0

    def _unstable(self, err: InstabilityError) -> None:
        sim = self.sim
        record_outputs(self.rundir, [UNSTABLE])
        write_checkpoint(self.rundir / UNSTABLE, {"sim": sim.state_dict(),
                                                  "runner": self.state_dict()})
        kept = (f"last healthy checkpoint: step {self.checkpoint_step} ({CHECKPOINT})"
                if self.checkpoint_step >= 0 else "no healthy checkpoint exists")
        message = f"{err}; {kept}; state at the failure saved to {UNSTABLE}"
        self._summary("unstable", message).write(self.rundir)
        raise RunUnstable(message) from None

    def _summary(self, status: str, message: str) -> RunSummary:
        sim = self.sim
        return RunSummary(status=status, step=sim.step, steps=self.total, time=sim.time,
                          dt=sim.dt, n_particles=sim.state.n,
                          wall_time_s=self.elapsed(),
                          particle_steps_per_s=self.rate(), message=message)

    def _snapshot(self) -> None:
        from grainflow.plotting.snapshot import snapshot

        plane = self.config.output.snapshot_plane
        tmp = self.rundir / "final.tmp.png"
        snapshot(self.sim.frame(), tmp, plane=plane, walls=wall_lines(self.sim, plane))
        os.replace(tmp, self.rundir / SNAPSHOT)


def wall_lines(sim: Simulation, plane: str = "xz") -> list[tuple[tuple[float, float], ...]]:
    """Segments and planes seen edge-on, as line segments in the snapshot's plot axes
    (2D: x, y; 3D: ``plane``); planes are clipped to the box. Other shapes are left out."""
    from grainflow.walls import Plane, Segment, WallForce

    axes = [0, 1] if sim.state.dim == 2 else ["xyz".index(c) for c in plane]
    hidden = ({0, 1, 2} - set(axes)).pop()
    lo, hi = np.zeros(3), np.zeros(3)
    lo[: sim.state.dim], hi[: sim.state.dim] = sim.state.box.lo, sim.state.box.hi
    lines = []
    for force in sim.forces:
        if not isinstance(force, WallForce):
            continue
        for wall in force.walls:
            shift = np.asarray(wall.velocity) * sim.time
            if isinstance(wall, Segment):
                ends = [np.asarray(p) + shift for p in (wall.p0, wall.p1)]
            elif isinstance(wall, Plane) and wall.normal[hidden] == 0.0:
                along = np.zeros(3)
                along[axes[0]], along[axes[1]] = -wall.normal[axes[1]], wall.normal[axes[0]]
                ends = _clip(np.asarray(wall.point) + shift, along, lo, hi, axes)
                if ends is None:
                    continue
            else:
                continue
            lines.append(tuple((float(e[axes[0]]), float(e[axes[1]])) for e in ends))
    return lines


def _progress(progress: str | Progress | None, config: RunConfig) -> Progress:
    if isinstance(progress, Progress):
        return progress
    return make_progress(progress or "auto", interval=config.output.progress_interval)


class _StopRequest:
    """SIGINT/SIGTERM handler: remember the signal; the run stops after the current step.

    A second signal stops at once (KeyboardInterrupt). Handlers are only installed in the
    main thread (signals cannot be handled elsewhere, e.g. in dask worker threads).
    """

    def __init__(self) -> None:
        self.signum: int | None = None

    def __call__(self, signum: int, frame: Any) -> None:
        if self.signum is not None:
            raise KeyboardInterrupt
        self.signum = signum

    @contextmanager
    def installed(self) -> Iterator[None]:
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        old = {s: signal.signal(s, self) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for s, handler in old.items():
                signal.signal(s, handler)


def _clip(point: np.ndarray, along: np.ndarray, lo: np.ndarray, hi: np.ndarray,
          axes: list[int]) -> list[np.ndarray] | None:
    """Ends of the line ``point + t along`` inside the box (on ``axes``), or None."""
    t0, t1 = -np.inf, np.inf
    for a in axes:
        if along[a] == 0.0:
            if not lo[a] <= point[a] <= hi[a]:
                return None
            continue
        ta, tb = sorted(((lo[a] - point[a]) / along[a], (hi[a] - point[a]) / along[a]))
        t0, t1 = max(t0, ta), min(t1, tb)
    return None if t0 > t1 else [point + t0 * along, point + t1 * along]


# ---------------------------------------------------------------------------- checkpoints
def write_checkpoint(path: Path, data: dict[str, Any]) -> None:
    """Write nested ``data`` (arrays and plain values) atomically: a temporary file, fsync,
    then ``os.replace``. Arrays go into an ``.npz`` archive; every other value into one JSON
    entry (exact for floats and Python's big integers, e.g. the random-generator state)."""
    arrays: dict[str, np.ndarray] = {}
    plain: dict[str, Any] = {}
    _flatten(data, "", arrays, plain)
    arrays["__plain__"] = np.array(json.dumps(plain))
    tmp = path.with_name("checkpoint.tmp")
    with tmp.open("wb") as f:
        np.savez(f, **arrays)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)


def read_checkpoint(path: Path) -> dict[str, Any]:
    """Read a file written by :func:`write_checkpoint` back into nested dicts."""
    data: dict[str, Any] = {}
    with _checkpoint_archive(path) as (z, plain):
        for key in z.files:
            if key != "__plain__":
                _set(data, key, z[key])
    for key, value in plain.items():
        _set(data, key, value)
    return data


def _flatten(obj: Any, prefix: str, arrays: dict[str, np.ndarray], plain: dict[str, Any]) -> None:
    if isinstance(obj, dict) and obj:
        for k, v in obj.items():
            if "/" in str(k):
                raise ValueError(f"checkpoint key {k!r} contains '/'")
            _flatten(v, f"{prefix}/{k}" if prefix else str(k), arrays, plain)
    elif isinstance(obj, np.ndarray):
        arrays[prefix] = obj
    elif isinstance(obj, np.generic):
        plain[prefix] = obj.item()
    else:
        json.dumps(obj)  # raises for values that cannot be stored
        plain[prefix] = obj


def _set(data: dict[str, Any], key: str, value: Any) -> None:
    *parents, last = key.split("/")
    for p in parents:
        data = data.setdefault(p, {})
    data[last] = value


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


# ------------------------------------------------------------------------ run directory
def _outputs_of(config: RunConfig) -> list[str]:
    """The files a run of ``config`` writes (besides the unstable state, if it fails)."""
    out = config.output
    names = [CONFIG, THERMO, CHECKPOINT, SUMMARY]
    if out.frames_every:
        names.append(FRAMES)
    if out.snapshot:
        names.append(SNAPSHOT)
    return names


def _check_rundir(rundir: Path, overwrite: bool, outputs: list[str]) -> list[str]:
    """What must go from ``rundir`` before a fresh run writes ``outputs`` there (with
    ``overwrite``: what the manifest says grainflow wrote, sorted); RunDirError when it is
    not empty without ``overwrite``, or when an output would replace a file of the user's.
    Nothing is changed."""
    if rundir.exists() and not rundir.is_dir():
        raise RunDirError(f"{rundir} exists and is not a directory")
    if rundir.is_dir() and any(rundir.iterdir()):
        if not overwrite:
            raise RunDirError(f"{rundir} exists and is not empty; pass --overwrite to replace "
                              f"its run, or continue it with: grainflow resume {rundir}")
        ours = read_manifest(rundir)
        foreign = [name for name in outputs
                   if (rundir / name).exists() and name not in ours]
        config = rundir / CONFIG
        if (CONFIG in ours and config.is_file()
                and _checksum(config.read_bytes()) != ours[CONFIG].get("sha256")):
            foreign.append(f"{CONFIG} (edited since grainflow wrote it)")
        if foreign:
            raise RunDirError(
                f"{rundir}: --overwrite would replace files grainflow did not write: "
                f"{', '.join(foreign)}; move them away or choose another run directory")
        return sorted(name for name in set(ours) | set(TEMPORARY)
                      if (rundir / name).exists() or (rundir / name).is_symlink())
    return []


def _prepare_rundir(rundir: Path, remove: list[str]) -> None:
    """Remove ``remove`` (names :func:`_check_rundir` gave) and the manifest from
    ``rundir``, or create it; RunDirError if it cannot be written."""
    for name in remove:
        target = rundir / name
        if target.is_dir() and not target.is_symlink():
            shutil.rmtree(target)
        else:
            target.unlink(missing_ok=True)
    (rundir / MANIFEST).unlink(missing_ok=True)
    try:
        rundir.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise RunDirError(f"{rundir}: cannot create the run directory ({err.strerror})") from None
    if not os.access(rundir, os.W_OK):
        raise RunDirError(f"{rundir}: the run directory is not writable; choose another "
                          "with --output")


def record_outputs(rundir: Path, names: list[str] | tuple[str, ...], *,
                   config_text: str | None = None) -> None:
    """Add ``names`` (files or folders directly in ``rundir``) to the manifest of what
    grainflow wrote there; ``config_text``: the config it is about to write (checksummed,
    so a later hand edit is noticed)."""
    rundir = Path(rundir)
    entries = read_manifest(rundir)
    for name in names:
        entries.setdefault(name, {})
    if config_text is not None:
        entries[CONFIG] = {"sha256": _checksum(config_text.encode())}
    _atomic_write_text(rundir / MANIFEST, json.dumps({"version": 1, "files": entries},
                                                     indent=1, sort_keys=True) + "\n")


def read_manifest(rundir: Path) -> dict[str, dict[str, Any]]:
    """What grainflow wrote in ``rundir``: name -> details (the config's ``sha256``)."""
    path = Path(rundir) / MANIFEST
    if not path.is_file():
        return {}
    try:
        files = json.loads(path.read_text())["files"]
        if not isinstance(files, dict) or any("/" in k or k in ("", ".", "..") for k in files):
            raise ValueError("unexpected entries")
    except (ValueError, KeyError, TypeError, UnicodeDecodeError) as err:
        raise RunDirError(f"{path}: the list of files grainflow wrote here is damaged ({err}); "
                          "nothing was removed. Delete the files of the old run yourself, "
                          "or choose another run directory") from None
    return files


def _checksum(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def checkpoint_step(path: Path) -> int | None:
    """Step of the checkpoint at ``path`` (None if there is none), without loading arrays;
    :class:`RunDirError` if it is damaged."""
    if not path.is_file():
        return None
    with _checkpoint_archive(path) as (_, plain):
        return int(plain["sim/step"])


def checkpoint_wall_seconds(path: Path) -> float:
    """Wall-clock seconds the run had spent, over all its segments, when it wrote the
    checkpoint at ``path``; :class:`RunDirError` if it is damaged."""
    with _checkpoint_archive(path) as (_, plain):
        return float(plain["runner/wall_seconds"])


@contextmanager
def _checkpoint_archive(path: Path) -> Iterator[tuple[Any, dict[str, Any]]]:
    """The open archive of a checkpoint and its plain values; :class:`RunDirError` naming
    the file and the way out if it cannot be read (zip, npy, JSON and I/O errors alike)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            yield z, json.loads(str(z["__plain__"]))
    except Exception as err:
        size = path.stat().st_size if path.is_file() else 0
        what = ("empty" if size == 0 else
                f"truncated or not a checkpoint ({type(err).__name__}: {err})")
        raise RunDirError(f"{path}: the checkpoint is damaged: {what}. The run cannot "
                          "continue from it; move it aside and start the run again: "
                          f"grainflow run {path.parent / CONFIG} -o {path.parent} "
                          "--overwrite") from None


def read_summary(rundir: Path) -> dict[str, Any] | None:
    """``summary.json`` of a run directory, or None before the run ended;
    :class:`RunDirError` if it is damaged."""
    path = Path(rundir) / SUMMARY
    if not path.is_file():
        return None
    try:
        summary = json.loads(path.read_text())
        if not isinstance(summary, dict) or not isinstance(summary.get("status"), str):
            raise ValueError("no status")
    except (OSError, ValueError) as err:  # JSON and UTF-8 errors are ValueErrors
        raise RunDirError(f"{path}: damaged ({type(err).__name__}: {err}); it is rewritten "
                          "when the run resumes or ends (grainflow resume "
                          f"{path.parent})") from None
    return summary

