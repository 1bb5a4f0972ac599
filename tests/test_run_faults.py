"""Trustworthy runs (issue 10): physics that goes wrong stops the run before anything broken
is written; nothing of the user's is deleted or replaced; damaged files are named with a way
out; a resumed run's thermo log is the uninterrupted one's; signals at awkward moments."""

from __future__ import annotations

import copy
import json
import math
import os
import signal
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from grainflow.cli import app
from grainflow.engine.forces import Gravity
from grainflow.engine.operations import Force, ForceContext
from grainflow.engine.simulation import InstabilityError, Simulation
from grainflow.frame import Box
from grainflow.io.h5md import read_frames
from grainflow.models.granular import GranularLaw, stiffness_and_damping
from grainflow.runner import (CHECKPOINT, CONFIG, FRAMES, MANIFEST, SNAPSHOT, SUMMARY, THERMO,
                              RunDirError, RunInterrupted, RunUnstable, read_checkpoint,
                              resume_run, run_config)
from grainflow.state import ParticleState
from test_runner import InterruptAt  # a progress display sending a real SIGINT at a step


@pytest.fixture(autouse=True)
def one_thread():
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(before)


#: Disks settling under gravity in a walled 2D box: a healthy run (~0.2 s).
SETTLE: dict[str, Any] = {
    "dim": 2,
    "gravity": [0, -1],
    "run": {"steps": 600, "seed": 3},
    "output": {"thermo_every": 20, "frames_every": 200, "checkpoint_every": 200,
               "snapshot": False},
    "box": {"lo": [0, 0], "hi": [8, 12]},
    "particles": [{"fill": "lattice", "region": {"lo": [0, 0], "hi": [8, 8]},
                   "radius": [0.45, 0.55], "spacing": 1.2, "packing_fraction": 0.5}],
    "contact": {"law": "granular", "restitution": 0.7, "contact_time": 0.05, "mu": 0.5},
    "walls": [{"shape": "plane", "point": [0, 0], "normal": [0, 1]},
              {"shape": "plane", "point": [0, 0], "normal": [1, 0]},
              {"shape": "plane", "point": [8, 0], "normal": [-1, 0]}],
}


def settle(**changes: Any) -> dict[str, Any]:
    config = copy.deepcopy(SETTLE)
    for dotted, value in changes.items():
        section, key = dotted.split("__")
        config.setdefault(section, {})[key] = value
    return config


def thermo_rows(rundir: Path) -> list[list[str]]:
    return [r.split(",") for r in (rundir / THERMO).read_text().splitlines()[1:]]


def assert_all_outputs_finite(rundir: Path) -> None:
    for row in thermo_rows(rundir):
        assert all(math.isfinite(float(v)) for v in row), row
    if (rundir / FRAMES).is_file():
        for frame in read_frames(rundir / FRAMES):
            for name in ("position", "velocity", "omega"):
                assert np.isfinite(getattr(frame, name)).all(), (frame.step, name)


# ------------------------------------------------- physics that goes wrong stops the run
def test_a_periodic_blow_up_writes_no_nan_even_between_health_checks(tmp_path: Path) -> None:
    """Thermo and frames every step, the full health check only every 1000 steps: the
    compiled pre-output scan stops the run before the first broken row or frame."""
    config = {
        "dim": 2, "run": {"steps": 400, "dt": 0.2, "allow_unsafe_dt": True,
                          "check_every": 1000},
        "output": {"thermo_every": 1, "frames_every": 1, "checkpoint_every": 50,
                   "snapshot": False},
        "box": {"lo": [0, 0], "hi": [6, 6], "periodic": [True, True]},
        "particles": [{"fill": "list", "radius": 0.5,
                       "positions": [[1, 1], [3, 1.2], [1, 4], [3.5, 4], [5, 2.5]],
                       "velocities": [[1, 0], [-1, 0], [1, 0.2], [-1, 0], [0, 1]]}],
        "contact": {"law": "granular", "restitution": 1.0, "contact_time": 0.1},
    }
    rundir = tmp_path / "run"
    with pytest.warns(UserWarning, match="stability limit"):
        with pytest.raises(RunUnstable, match=r"unstable at step \d+, particle id \d+"):
            run_config(config, rundir, progress="none")
    assert_all_outputs_finite(rundir)
    result = CliRunner().invoke(app, ["export", str(rundir)])
    assert result.exit_code == 0
    assert "nan" not in (rundir / "frames.dump").read_text().lower()


def test_an_initial_speed_of_1e300_is_refused_before_anything_is_written(tmp_path) -> None:
    config = settle()
    config["particles"] = [{"fill": "list", "positions": [[4, 4]], "radius": 0.5,
                            "velocities": [[1e300, 0]]}]
    rundir = tmp_path / "run"
    with pytest.raises(RunUnstable, match=r"step 0, particle id 0: it moves .* radii per step"):
        run_config(config, rundir, progress="none")
    assert thermo_rows(rundir) == []
    assert not (rundir / CHECKPOINT).exists()
    summary = json.loads((rundir / SUMMARY).read_text())
    assert summary["status"] == "unstable"


def test_grains_tunnelling_through_the_floor_stop_the_run(tmp_path: Path) -> None:
    """dt far past the wall contact time (forced with allow_unsafe_dt): the grains cross the
    floor; the run must stop unstable, never end 'finished'."""
    config = settle(run__dt=0.05, run__allow_unsafe_dt=True, run__steps=4000)
    rundir = tmp_path / "run"
    with pytest.warns(UserWarning):
        with pytest.raises(RunUnstable) as info:
            run_config(config, rundir, progress="none")
    assert json.loads((rundir / SUMMARY).read_text())["status"] == "unstable"
    assert "particle id" in str(info.value) and "dt = 0.05" in str(info.value)
    assert_all_outputs_finite(rundir)


def _law(n_types: int, restitution: float, contact_time: float, mass: float) -> GranularLaw:
    law = GranularLaw(n_types)
    kn, gamma_n = stiffness_and_damping(restitution, contact_time, mass)
    law.set_all(kn=kn, gamma_n=gamma_n, mu=0.5)
    return law


def _lone_grain(box_hi: float = 1.0, y: float = 0.5, dt: float = 1e-3,
                contact_time: float = 0.05) -> Simulation:
    state = ParticleState(2, Box(np.zeros(2), np.full(2, box_hi), (False, False)))
    state.add_particles(np.array([[0.5, y]]), 0.05, density=1.0)
    sim = Simulation(state, dt, _law(2, 0.5, contact_time, float(state.mass[0])))
    sim.add_force(Gravity([0.0, -10.0]))
    return sim


def test_a_grain_falling_away_from_the_box_is_lost() -> None:
    sim = _lone_grain()
    with pytest.raises(InstabilityError, match=r"particle id 0: it left the box: y = -1\.\d+"):
        sim.run(5000)
    assert sim.step < 1000  # it falls out of the box by one box length within ~0.8 s


def test_a_grain_placed_outside_the_box_and_coming_back_is_not_lost() -> None:
    sim = _lone_grain()
    sim.state.x[0, 1] = 3.5  # above the box by 2.5 box lengths, falling towards it
    sim.run(200)


class PushAlong(Force):
    """A force along the velocity that claims to store nothing (a broken model)."""

    def __init__(self, c: float) -> None:
        self.c = c

    def compute(self, ctx: ForceContext, update: bool) -> None:
        ctx.state.force += self.c * ctx.state.v

    def potential_energy(self, ctx: ForceContext) -> float:
        return 0.0


def test_energy_growing_without_a_source_stops_the_run() -> None:
    state = ParticleState(2, Box(np.zeros(2), np.full(2, 10.0), (True, True)))
    state.add_particles(np.array([[2.0, 2.0], [6.0, 7.0]]), 0.5, density=1.0,
                        v=np.array([[0.1, 0.0], [0.0, -0.1]]))
    sim = Simulation(state, 1e-3, _law(1, 0.9, 0.05, float(state.mass[0])),
                     check_every=50)
    sim.add_force(PushAlong(2.0))
    with pytest.raises(InstabilityError, match="mechanical energy grew from .* with no "
                                               "source"):
        sim.run(5000)
    assert np.abs(sim.state.v).max() < 1.0  # slow: neither the speed nor overlap check


def test_the_energy_check_does_not_fire_on_a_settling_pile() -> None:
    """Gravity turns into kinetic energy and then heat: the balance holds (every healthy run
    of the suite checks this too)."""
    sim = _lone_grain(y=0.2, dt=1e-4, contact_time=0.005)
    sim.check_every = 5
    from grainflow.walls import Plane, WallForce

    sim.add_force(WallForce([Plane((0.0, 0.0), (0.0, 1.0))], sim.interactions[0].law,
                            wall_type=1))
    sim.run(6000)  # falls 0.15, bounces, comes to rest: no instability
    assert sim.state.x[0, 1] == pytest.approx(0.05, abs=0.01)


# ------------------------------------------------------------ info and resume when unstable
def test_info_says_unstable_and_resume_refuses(tmp_path: Path) -> None:
    config = settle(run__dt=0.05, run__allow_unsafe_dt=True, run__steps=4000)
    rundir = tmp_path / "run"
    with pytest.warns(UserWarning), pytest.raises(RunUnstable):
        run_config(config, rundir, progress="none")
    result = CliRunner().invoke(app, ["info", str(rundir)])
    assert result.exit_code == 0
    assert "unstable at step" in result.stdout
    assert "grainflow resume" not in result.stdout
    assert "resuming would repeat the failure" in result.stdout
    with pytest.raises(RunDirError, match="went unstable"):
        resume_run(rundir, progress="none")
    result = CliRunner().invoke(app, ["resume", str(rundir)])
    assert result.exit_code == 2 and "Traceback" not in result.output


# ------------------------------------------------------------- never delete the user's files
def _quick() -> dict[str, Any]:
    return settle(run__steps=40, output__frames_every=20, output__checkpoint_every=20)


def test_overwrite_removes_only_what_grainflow_wrote_and_says_so(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    run_config(_quick(), rundir, progress="none")
    assert CliRunner().invoke(app, ["export", str(rundir), "-f", "vtk"]).exit_code == 0
    (rundir / "notes.txt").write_text("mine")
    (rundir / "frames.dump").write_text("my own dump")  # not grainflow's: kept
    mine = rundir / "analysis"
    mine.mkdir()
    (mine / "fig.png").write_bytes(b"png")
    messages: list[str] = []
    run_config(_quick(), rundir, overwrite=True, progress="none", log=messages.append)
    assert (rundir / "notes.txt").read_text() == "mine"
    assert (rundir / "frames.dump").read_text() == "my own dump"
    assert (mine / "fig.png").read_bytes() == b"png"
    assert not (rundir / "vtk").exists()  # grainflow's export: removed, and said so
    assert len(messages) == 1 and "vtk" in messages[0] and THERMO in messages[0]
    assert "notes.txt" not in messages[0]


def test_exporting_over_a_users_file_is_refused(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    run_config(_quick(), rundir, progress="none")
    (rundir / "frames.dump").write_text("my own dump")
    result = CliRunner().invoke(app, ["export", str(rundir)])
    assert result.exit_code == 2 and "not written by grainflow" in result.stderr
    assert (rundir / "frames.dump").read_text() == "my own dump"


def test_a_hand_written_config_in_the_run_directory_is_never_replaced(tmp_path) -> None:
    import tomli_w

    rundir = tmp_path / "run"
    rundir.mkdir()
    mine = rundir / CONFIG
    mine.write_text(tomli_w.dumps(_quick()))
    before = mine.read_text()
    result = CliRunner().invoke(app, ["run", str(mine), "-o", str(rundir), "--overwrite",
                                      "--progress", "none"])
    assert result.exit_code == 2, result.output
    assert "did not write: config.toml" in result.stderr
    assert mine.read_text() == before


def test_a_config_edited_after_the_run_is_not_replaced(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    run_config(_quick(), rundir, progress="none")
    edited = (rundir / CONFIG).read_text() + "\n# my notes\n"
    (rundir / CONFIG).write_text(edited)
    with pytest.raises(RunDirError, match="edited since grainflow wrote it"):
        run_config(_quick(), rundir, overwrite=True, progress="none")
    assert (rundir / CONFIG).read_text() == edited
    assert (rundir / THERMO).is_file()  # nothing was removed either


def test_a_damaged_manifest_removes_nothing(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    run_config(_quick(), rundir, progress="none")
    (rundir / MANIFEST).write_text("{garbage")
    with pytest.raises(RunDirError, match=r"\.grainflow-manifest: .* damaged.*nothing was "
                                          "removed"):
        run_config(_quick(), rundir, overwrite=True, progress="none")
    assert (rundir / THERMO).is_file()


# ------------------------------------------------------------------------- damaged files
@pytest.mark.parametrize("damage", ["empty", "truncated", "garbage"])
def test_a_damaged_checkpoint_is_named_with_a_way_out(tmp_path: Path, damage: str) -> None:
    rundir = tmp_path / "run"
    config = _quick()
    config["run"]["steps"] = 60
    with pytest.raises(RunInterrupted):
        run_config(config, rundir, progress=InterruptAt(30))
    path = rundir / CHECKPOINT
    data = path.read_bytes()
    path.write_bytes({"empty": b"", "truncated": data[: len(data) // 2],
                      "garbage": os.urandom(len(data))}[damage])
    expected = "empty" if damage == "empty" else "truncated or not a checkpoint"
    with pytest.raises(RunDirError, match=f"checkpoint.npz: the checkpoint is damaged: "
                                          f"{expected}.*--overwrite"):
        read_checkpoint(path)
    result = CliRunner().invoke(app, ["resume", str(rundir)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert "checkpoint is damaged" in result.stderr and "zip file" not in result.stderr.split(
        "(")[0]
    info = CliRunner().invoke(app, ["info", str(rundir)])
    assert info.exit_code == 0 and "checkpoint is damaged" in info.stdout


# --------------------------------------------------------------------------------- also
def test_thermo_after_a_resume_equals_the_uninterrupted_log(tmp_path: Path) -> None:
    """Every column but the speed, bitwise (the rebuild counter is in the checkpoint)."""
    whole = tmp_path / "whole"
    run_config(settle(), whole, progress="none")
    parts = tmp_path / "parts"
    with pytest.raises(RunInterrupted):
        run_config(settle(), parts, progress=InterruptAt(310))  # not a thermo step
    resume_run(parts, progress="none")
    a, b = thermo_rows(whole), thermo_rows(parts)
    assert [r[:-1] for r in a] == [r[:-1] for r in b]
    assert int(a[-1][7]) > 1  # the rebuild counter moved


def test_sigint_while_the_snapshot_is_drawn_leaves_a_complete_run(tmp_path, monkeypatch):
    import grainflow.plotting.snapshot as snapshot_module

    drawn = snapshot_module.snapshot

    def interrupted_snapshot(*args: Any, **kw: Any) -> Any:
        os.kill(os.getpid(), signal.SIGINT)  # a real signal, mid-drawing
        return drawn(*args, **kw)

    monkeypatch.setattr(snapshot_module, "snapshot", interrupted_snapshot)
    rundir = tmp_path / "run"
    summary = run_config(settle(output__snapshot=True, run__steps=100), rundir,
                         progress="none")
    assert summary.status == "finished"
    assert json.loads((rundir / SUMMARY).read_text())["status"] == "finished"
    assert (rundir / SNAPSHOT).stat().st_size > 1000
    assert not (rundir / "final.tmp.png").exists()


def test_a_bad_progress_mode_is_refused_before_the_run_directory_is_touched(tmp_path):
    rundir = tmp_path / "run"
    with pytest.raises(ValueError, match="progress"):
        run_config(_quick(), rundir, progress="fancy")
    assert not rundir.exists()


def test_warnings_are_one_clean_line(tmp_path: Path) -> None:
    import tomli_w

    config = settle(run__steps=10, run__dt=0.01)  # warned: few steps per contact time
    path = tmp_path / "c.toml"
    path.write_text(tomli_w.dumps(config))
    result = CliRunner().invoke(app, ["run", str(path), "-o", str(tmp_path / "run"),
                                      "--progress", "none"])
    assert result.exit_code == 0, result.output
    warnings_ = [line for line in result.stderr.splitlines() if line.strip()]
    assert warnings_ and all(line.startswith("warning: dt = 0.01") for line in warnings_)
    assert "UserWarning" not in result.stderr and ".py:" not in result.stderr


def test_several_config_problems_print_one_per_line(tmp_path: Path) -> None:
    import tomli_w

    config = settle()
    config["run"]["dt_fraction"] = -1
    config["contact"]["restitution"] = 2.0
    path = tmp_path / "c.toml"
    path.write_text(tomli_w.dumps(config))
    result = CliRunner().invoke(app, ["run", str(path), "-o", str(tmp_path / "run")])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 2 and all(line.startswith("error: ") for line in lines)
    assert any("run.dt_fraction" in line for line in lines)
    assert any("contact.restitution" in line for line in lines)
    assert not (tmp_path / "run").exists()


def test_a_truncated_frames_file_is_repaired_on_resume(tmp_path: Path) -> None:
    """frames.h5 cut short (a full disk) after an interruption: resume keeps its whole
    frames up to the cut, moves the original aside, and the run completes."""
    config = settle(run__steps=2000, output__frames_every=50, output__checkpoint_every=1000)
    whole = tmp_path / "whole"
    run_config(config, whole, progress="none")
    rundir = tmp_path / "run"
    with pytest.raises(RunInterrupted):
        run_config(config, rundir, progress=InterruptAt(1500))
    frames = rundir / FRAMES
    size = frames.stat().st_size
    os.truncate(frames, int(0.8 * size))
    with pytest.warns(RuntimeWarning, match="damaged original is kept"):
        resume_run(rundir, progress="none")
    assert (rundir / (FRAMES + ".damaged")).stat().st_size == int(0.8 * size)
    got = {f.step: f for f in read_frames(frames)}
    reference = {f.step: f for f in read_frames(whole / FRAMES)}
    salvaged = [s for s in got if s <= 1500]  # the checkpoint's step
    assert salvaged == list(reference)[: len(salvaged)] and len(salvaged) >= 15
    # the frames after the cut, up to the checkpoint, are lost; the resumed run adds the rest
    assert [s for s in got if s > 1500] == [s for s in reference if s > 1500]
    for step, frame in got.items():
        assert np.array_equal(frame.position, reference[step].position), step


def test_a_frame_larger_than_the_file_was_made_for_is_refused(tmp_path: Path) -> None:
    from grainflow.io.h5md import TrajectoryWriter

    state = ParticleState(2, Box(np.zeros(2), np.full(2, 10.0), (False, False)))
    state.add_particles(np.random.default_rng(0).uniform(1, 9, (10, 2)), 0.01, density=1.0)
    with TrajectoryWriter(tmp_path / "f.h5", 2, state.box, contacts=False,
                          max_rows=8) as writer:
        with pytest.raises(ValueError, match="10 particles, more than the 8 rows"):
            writer.append(state.to_frame(0, 0.0))
        assert writer.n_frames == 0


def test_a_garbage_summary_is_named_and_resume_still_continues(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    with pytest.raises(RunInterrupted):
        run_config(_quick(), rundir, progress=InterruptAt(20))
    (rundir / SUMMARY).write_bytes(b'{"status": "\xff')
    info = CliRunner().invoke(app, ["info", str(rundir)])
    assert info.exit_code == 0 and "summary.json: damaged" in info.stdout
    assert resume_run(rundir, progress="none").status == "finished"
    assert json.loads((rundir / SUMMARY).read_text())["status"] == "finished"


def test_a_run_that_can_never_finish_is_refused_before_the_directory_is_touched(tmp_path):
    config = settle()
    del config["run"]["steps"]
    config["run"]["duration"] = 1e300
    with pytest.raises(ValueError, match=r"run.duration: 1e\+300 .* more than 1e\+12 steps"):
        run_config(config, tmp_path / "run", progress="none")
    assert not (tmp_path / "run").exists()


def test_overwrite_with_a_config_that_fails_to_build_keeps_the_previous_run(tmp_path):
    rundir = tmp_path / "run"
    run_config(_quick(), rundir, progress="none")
    before = sorted(p.name for p in rundir.iterdir())
    broken = settle(run__dt=1.0)  # refused when built: far past the contact time
    with pytest.raises(ValueError, match="run.dt"):
        run_config(broken, rundir, overwrite=True, progress="none")
    assert sorted(p.name for p in rundir.iterdir()) == before


@pytest.mark.parametrize("args, message", [
    (["--threads", "0", "info", "."], "error: --threads: 0 is not valid; expected 'auto' or a"),
    (["run", "."], "error: Invalid value for 'config'"),
    (["nonsense"], "error: No such command 'nonsense'"),
])
def test_usage_errors_of_the_program_are_one_line(args: list[str], message: str) -> None:
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-m", "grainflow", *args], capture_output=True,
                            text=True)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [result.stderr.strip()]
    assert result.stderr.startswith(message)


@pytest.mark.parametrize("delay", [0.15, 0.3, 0.5])
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_while_the_program_starts_is_one_line(tmp_path: Path, delay: float,
                                                     signum: int) -> None:
    """A real SIGINT or SIGTERM while grainflow's modules are still imported: one error
    line, no traceback (before Python itself has started, ~0.05 s, nothing of ours runs
    yet: then the process just ends by the signal)."""
    import subprocess
    import sys
    import time

    proc = subprocess.Popen(
        [sys.executable, "-m", "grainflow", "info", str(tmp_path)], stderr=subprocess.PIPE,
        stdout=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(delay)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    if err.startswith("Fatal Python error: init_import_site"):
        # the signal landed while the interpreter was still starting (site.py running the
        # installed packages' .pth files takes longer than the delay on a loaded machine):
        # Python's own report, from before any line of grainflow ran
        import grainflow

        assert str(Path(grainflow.__file__).parent) not in err, err
        return
    assert "Traceback" not in err, err
    # 130 (or killed by the signal, as Python ends on an interrupt it re-raises, or before
    # our handler is in place); 2: done already
    assert proc.returncode in (130, -signal.SIGINT, -signum, 2), (proc.returncode, err)
    if proc.returncode != -signum:
        assert len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("interrupted", [True, False])
def test_an_import_the_interrupt_broke_is_reported_as_the_interrupt(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        interrupted: bool) -> None:
    """numba's C import turns a KeyboardInterrupt raised inside it into ImportError
    ("numba._devicearray failed to import", seen in CI): after an interrupt that is
    "interrupted", exit 130; without one the ImportError is a real failure and propagates."""
    import grainflow.__main__ as program
    import grainflow.cli as cli
    from grainflow import interrupt

    def entry() -> None:
        if interrupted:
            try:
                interrupt._handler(signal.SIGTERM, None)
            except KeyboardInterrupt:
                pass
        raise ImportError("numba._devicearray failed to import")

    monkeypatch.setattr(interrupt, "install", lambda: None)  # keep pytest's own handlers
    monkeypatch.setattr(interrupt, "_received", [])
    monkeypatch.setattr(cli, "entry", entry)
    if interrupted:
        with pytest.raises(SystemExit) as exit_:
            program.main()
        assert exit_.value.code == 130
        assert capsys.readouterr().err == "error: interrupted\n"
    else:
        with pytest.raises(ImportError, match="devicearray"):
            program.main()


def test_an_interrupt_python_could_not_raise_is_quiet_and_reported(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """An interrupt that lands in a callback of Python's import machinery (a module lock's
    weak-reference callback: seen when the test above ran beside another process) cannot be
    raised there: Python prints it as "Exception ignored" with a traceback and goes on. The
    start-up hook keeps it quiet, and the program reports it, exit 130, once the imports
    are done, instead of running the command."""
    import gc
    import weakref

    import grainflow.__main__ as program
    import grainflow.cli as cli
    from grainflow import interrupt

    class Lock:
        pass

    seen: list[type] = []  # what the hook before grainflow's is given
    monkeypatch.setattr(interrupt, "_received", [])
    monkeypatch.setattr(sys, "unraisablehook", lambda info: seen.append(info.exc_type))
    monkeypatch.setattr(signal, "signal", lambda signum, handler: None)  # keep pytest's own
    interrupt.install()
    lock = Lock()
    ref = weakref.ref(lock, lambda _: interrupt._handler(signal.SIGINT, None))
    del lock  # the callback raises KeyboardInterrupt where Python cannot raise it
    gc.collect()
    assert ref() is None
    assert seen == [] and interrupt.received()
    monkeypatch.setattr(interrupt, "install", lambda: None)
    monkeypatch.setattr(cli, "entry", lambda: pytest.fail("the command ran"))
    with pytest.raises(SystemExit) as exit_:
        program.main()
    assert exit_.value.code == 130
    assert capsys.readouterr().err == "error: interrupted\n"
    # any other exception Python could not raise still goes to the hook before
    weakref.ref(Lock(), lambda _: 1 / 0)
    gc.collect()
    assert seen == [ZeroDivisionError]


def test_a_verb_whose_import_the_interrupt_broke_exits_130(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The same inside a verb's own error handling (its lazy imports run there)."""
    import typer

    import grainflow.cli as cli
    from grainflow import interrupt

    monkeypatch.setattr(interrupt, "_received", [signal.SIGINT])
    with pytest.raises(typer.Exit) as exit_:
        with cli._errors():
            raise ImportError("numba._devicearray failed to import")
    assert exit_.value.exit_code == 130


def test_an_interrupt_inside_a_verb_is_reported_once(monkeypatch: pytest.MonkeyPatch,
                                                     capsys: pytest.CaptureFixture[str],
                                                     tmp_path: Path) -> None:
    """A Ctrl-C inside a verb (seen when a SIGINT at 0.5 s of start-up met numba compiling
    the verb's modules on a cold cache): the verb says "interrupted" and exits 130, and the
    program does not say it again for that exit code."""
    import grainflow.cli as cli

    def interrupted(rundir, runner):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_describe", interrupted)
    monkeypatch.setitem(cli._state, "interrupt_reported", False)
    with pytest.raises(SystemExit) as exit_:
        cli.entry(["info", str(tmp_path)])
    assert exit_.value.code == 130
    assert capsys.readouterr().err == "error: interrupted\n"
