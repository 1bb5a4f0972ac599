"""Running a configuration into a run directory, with checkpoints, and resuming it.

Run directory (see ``docs/config.md``)::

    config.toml         the resolved configuration (defaults filled in, paths absolute)
    thermo.csv          step, time, N, energies, max overlap, contacts, rebuilds, rate
    frames.h5           frames in the H5MD layout (docs/output_format.md)
    checkpoint.npz      the whole state at the last healthy checkpoint (written atomically)
    unstable_state.npz  the state where a run went unstable (diagnosis only)
    final.png           snapshot of the final state, coloured by speed
    summary.json        status, steps, N, wall time, particle-steps/s, message

A run that is killed loses only the steps since its last checkpoint: :func:`resume_run`
rebuilds the simulation from ``config.toml``, loads ``checkpoint.npz``, trims ``thermo.csv``
and ``frames.h5`` back to the checkpoint's step and continues; the final state is bitwise
the one of an uninterrupted run. SIGINT and SIGTERM write a checkpoint before the run stops.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import tomli_w

from grainflow import __version__
from grainflow.config.build import build_simulation, total_steps
from grainflow.config.schema import RunConfig, load_config, resolved_dict
from grainflow.engine.simulation import InstabilityError, Simulation
from grainflow.io.thermo import THERMO_COLUMNS, ThermoLog
from grainflow.progress import Progress, make_progress

__all__ = ["CHECKPOINT_VERSION", "RunDirError", "RunError", "RunInterrupted", "RunSummary",
           "RunUnstable", "checkpoint_step", "read_checkpoint", "read_summary", "resume_run",
           "run_config", "set_threads", "write_checkpoint"]

#: Layout version of checkpoint files; a resume refuses other versions.
CHECKPOINT_VERSION = 2

CONFIG = "config.toml"
THERMO = "thermo.csv"
FRAMES = "frames.h5"
CHECKPOINT = "checkpoint.npz"
UNSTABLE = "unstable_state.npz"
SNAPSHOT = "final.png"
SUMMARY = "summary.json"
#: Everything a run writes (what ``overwrite`` removes; nothing else is touched).
OUTPUTS = (CONFIG, THERMO, FRAMES, CHECKPOINT, UNSTABLE, SNAPSHOT, SUMMARY, "checkpoint.tmp",
           FRAMES + ".recover", "frames.dump", "vtk")


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


# --------------------------------------------------------------------------- public API
def run_config(config: RunConfig | Mapping[str, Any] | str | os.PathLike[str],
               rundir: str | os.PathLike[str], *, overwrite: bool = False,
               resume: bool = False, threads: int | None = None,
               progress: str | Progress | None = None) -> RunSummary:
    """Run a configuration (RunConfig, dict or TOML path) into ``rundir``.

    An existing non-empty ``rundir`` is refused unless ``overwrite`` (grainflow's outputs
    in it are deleted first) or ``resume`` (continue from its checkpoint if it has one).
    ``threads`` sets numba's thread count; ``progress`` is ``"auto"`` (default), ``"rich"``,
    ``"plain"``, ``"none"`` or a :class:`~grainflow.progress.Progress`.
    Raises :class:`~grainflow.config.schema.ConfigError`, :class:`RunDirError`,
    :class:`RunInterrupted` or :class:`RunUnstable`.
    """
    rundir = Path(rundir)
    if resume and (rundir / CHECKPOINT).is_file():
        return resume_run(rundir, threads=threads, progress=progress)
    cfg = config if isinstance(config, RunConfig) else load_config(config)
    _prepare_rundir(rundir, overwrite)
    set_threads(threads)
    sim = build_simulation(cfg)
    _atomic_write_text(rundir / CONFIG, tomli_w.dumps(resolved_dict(cfg)))
    return _Run(cfg, sim, rundir, _progress(progress, cfg)).execute(fresh=True)


def resume_run(rundir: str | os.PathLike[str], *, threads: int | None = None,
               progress: str | Progress | None = None) -> RunSummary:
    """Continue the run in ``rundir`` from its last checkpoint."""
    rundir = Path(rundir)
    for name in (CONFIG, CHECKPOINT):
        if not (rundir / name).is_file():
            raise RunDirError(f"{rundir}: no {name}; is it a grainflow run directory "
                              "(written by 'grainflow run')?")
    cfg = load_config(rundir / CONFIG)
    set_threads(threads)
    saved = read_checkpoint(rundir / CHECKPOINT)
    sim = build_simulation(cfg, prepare=False)
    sim.load_state_dict(saved["sim"])
    run = _Run(cfg, sim, rundir, _progress(progress, cfg))
    run.load_state_dict(saved["runner"])
    return run.execute(fresh=False)


def set_threads(threads: int | None) -> None:
    """Set numba's number of threads (None: leave it)."""
    if threads is None:
        return
    import numba

    available = numba.config.NUMBA_NUM_THREADS
    if not 1 <= threads <= available:
        raise ValueError(f"threads: {threads} is not valid; expected 1 to {available} "
                         "(NUMBA_NUM_THREADS)")
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
        frames = None
        if out.frames_every:
            from grainflow.io.h5md import TrajectoryWriter

            frames = TrajectoryWriter(
                self.rundir / FRAMES, sim.state.dim, sim.state.box, contacts=out.contacts,
                compression=None if out.compression == "none" else out.compression,
                append=not fresh, resume_step=resume_step)
        stop = _StopRequest()
        try:
            with stop.installed():
                if fresh:
                    sim.compute_forces(update=False)
                    thermo(sim.observer_context)
                    if frames is not None:
                        frames.append(sim.frame(contacts=out.contacts))
                    self.checkpoint(sim)
                else:
                    self.checkpoint_step = sim.step
                sim.add_observer(thermo, out.thermo_every)
                if frames is not None:
                    sim.add_observer(lambda s: frames.append(s.frame(contacts=out.contacts)),
                                     out.frames_every)
                sim.add_observer(lambda s: self.progress.update(s.step, s.state.n,
                                                                self.rate()), 10)
                if out.checkpoint_every:
                    sim.add_observer(lambda _: self.checkpoint(sim), out.checkpoint_every)
                self.progress.start(self.total, sim.step)
                sim.run(max(0, self.total - sim.step), until=lambda s: stop.signum is not None)
                if self.checkpoint_step != sim.step:
                    self.checkpoint(sim)
        except InstabilityError as err:
            self._unstable(err)
        finally:
            self.progress.close()
            thermo.close()
            if frames is not None:
                frames.close()
        if stop.signum is not None:
            name = signal.Signals(stop.signum).name
            message = (f"stopped by {name} at step {sim.step}; checkpoint written, continue "
                       f"with: grainflow resume {self.rundir}")
            self._summary("interrupted", message).write(self.rundir)
            raise RunInterrupted(message, stop.signum)
        if out.snapshot:
            self._snapshot()
        summary = self._summary("finished", "")
        summary.write(self.rundir)
        return summary

    def elapsed(self) -> float:
        """Wall-clock seconds of the whole run so far (all segments)."""
        return self.previous_wall + time.perf_counter() - self.start[0]

    def rate(self) -> float:
        """Particle-steps per wall-clock second of this segment."""
        seconds = time.perf_counter() - self.start[0]
        return (self.sim.particle_steps - self.start[1]) / seconds if seconds > 0 else 0.0

    def _unstable(self, err: InstabilityError) -> None:
        sim = self.sim
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
        snapshot(self.sim.frame(), self.rundir / SNAPSHOT, plane=plane,
                 walls=wall_lines(self.sim, plane))


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
    try:
        with np.load(path, allow_pickle=False) as z:
            plain = json.loads(str(z["__plain__"]))
            data: dict[str, Any] = {}
            for key in z.files:
                if key != "__plain__":
                    _set(data, key, z[key])
    except (OSError, ValueError, KeyError) as err:
        raise RunDirError(f"{path}: not a readable checkpoint ({err})") from None
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
def _prepare_rundir(rundir: Path, overwrite: bool) -> None:
    if rundir.exists() and not rundir.is_dir():
        raise RunDirError(f"{rundir} exists and is not a directory")
    if rundir.is_dir() and any(rundir.iterdir()):
        if not overwrite:
            raise RunDirError(f"{rundir} exists and is not empty; pass --overwrite to replace "
                              f"its run, or continue it with: grainflow resume {rundir}")
        for name in OUTPUTS:
            target = rundir / name
            if target.is_dir():
                shutil.rmtree(target)
            elif target.exists():
                target.unlink()
    rundir.mkdir(parents=True, exist_ok=True)


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def checkpoint_step(path: Path) -> int | None:
    """Step of the checkpoint at ``path`` (None if there is none), without loading arrays."""
    if not path.is_file():
        return None
    with np.load(path, allow_pickle=False) as z:
        return int(json.loads(str(z["__plain__"]))["sim/step"])


def read_summary(rundir: Path) -> dict[str, Any] | None:
    """``summary.json`` of a run directory, or None before the run ended."""
    path = Path(rundir) / SUMMARY
    return json.loads(path.read_text()) if path.is_file() else None

