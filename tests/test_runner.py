"""Run directories: contents, thermo log, frames (plain h5py), exports, checkpoints,
SIGKILL/SIGTERM and resume (bitwise), instability, overwrite protection."""

from __future__ import annotations

import copy
import io
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from grainflow.config.schema import load_config
from grainflow.io.h5md import read_frames
from grainflow.progress import PlainProgress, Progress, RichProgress, make_progress
from grainflow.runner import (CHECKPOINT, CHECKPOINT_VERSION, CONFIG, FRAMES, SNAPSHOT, SUMMARY, THERMO,
                              THERMO_COLUMNS, UNSTABLE, RunDirError, RunInterrupted,
                              RunUnstable, checkpoint_step, read_checkpoint, resume_run,
                              run_config)

#: About 130 disks settling in a 2D box with walls and gravity: ~1 s for 8,000 steps.
STEPS = 8000
SETTLE: dict[str, Any] = {
    "dim": 2,
    "gravity": [0, -1],
    "run": {"steps": STEPS, "seed": 7},
    "output": {"thermo_every": 20, "frames_every": 500, "checkpoint_every": 1000,
               "contacts": True, "snapshot": True},
    "box": {"lo": [0, 0], "hi": [12, 30]},
    "particles": [{"fill": "lattice", "region": {"lo": [0, 0], "hi": [12, 20]},
                   "radius": [0.45, 0.55], "spacing": 1.2, "packing_fraction": 0.5}],
    "contact": {"law": "granular", "restitution": 0.7, "contact_time": 0.05, "mu": 0.5},
    "walls": [{"shape": "segment", "p0": [0, 0], "p1": [12, 0]},
              {"shape": "plane", "point": [0, 0], "normal": [1, 0]},
              {"shape": "plane", "point": [12, 0], "normal": [-1, 0]}],
}

#: Two disks flying at each other; dt = 0.3 is far past the stability limit (t_c = 0.1).
COLLIDE: dict[str, Any] = {
    "dim": 2,
    "run": {"steps": 20, "dt": 0.3, "allow_unsafe_dt": True, "check_every": 1},
    "output": {"thermo_every": 1, "frames_every": 1, "checkpoint_every": 2},
    "box": {"lo": [0, 0], "hi": [10, 10]},
    "particles": [{"fill": "list", "positions": [[1, 5], [4, 5]],
                   "velocities": [[0.8, 0], [-0.8, 0]], "radius": 0.5}],
    "contact": {"law": "granular", "restitution": 0.9, "contact_time": 0.1},
}


def settle(steps: int | None = None, **output: Any) -> dict[str, Any]:
    config = copy.deepcopy(SETTLE)
    if steps is not None:
        config["run"]["steps"] = steps
    config["output"].update(output)
    return config


def write_toml(path: Path, config: dict[str, Any]) -> Path:
    import tomli_w

    path.write_text(tomli_w.dumps(config))
    return path


def final_arrays(rundir: Path) -> dict[str, np.ndarray]:
    sim = read_checkpoint(rundir / CHECKPOINT)["sim"]
    return {**sim["arrays"], "step": np.array(sim["step"]), "time": np.array(sim["time"])}


def assert_same_frames(a: Path, b: Path) -> None:
    fa, fb = list(read_frames(a)), list(read_frames(b))
    assert [f.step for f in fa] == [f.step for f in fb]
    for x, y in zip(fa, fb):
        for name in ("id", "type", "radius", "position", "velocity", "omega"):
            assert np.array_equal(getattr(x, name), getattr(y, name)), (x.step, name)
        assert np.array_equal(x.contacts.force, y.contacts.force)


class InterruptAt(Progress):
    """A progress display that sends this process SIGINT when the run reaches ``step``."""

    def __init__(self, step: int) -> None:
        self.step = step

    def update(self, step: int, n: int, rate: float) -> None:
        if step == self.step:
            os.kill(os.getpid(), signal.SIGINT)


@pytest.fixture(scope="module", autouse=True)
def one_thread():
    """One numba thread: on the shared 2-core test machine two spinning threads make small
    systems many times slower (results do not depend on the thread count)."""
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(before)


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An uninterrupted run of SETTLE (in-process)."""
    rundir = tmp_path_factory.mktemp("reference") / "run"
    run_config(settle(), rundir, progress="none")
    return rundir


def launch(config_path: Path, rundir: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "grainflow", "--threads", "1", "run", str(config_path),
         "-o", str(rundir)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_step(proc: subprocess.Popen, rundir: Path, step: int, timeout: float = 120) -> int:
    """Poll thermo.csv until it reaches ``step``; return the step seen."""
    start = time.monotonic()
    thermo = rundir / THERMO
    while time.monotonic() - start < timeout:
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"the run ended (rc {proc.returncode}) before step {step}: {err}")
        if thermo.is_file():
            rows = [r for r in thermo.read_text().splitlines()[1:]
                    if r.count(",") == len(THERMO_COLUMNS) - 1]
            if rows and int(rows[-1].split(",")[0]) >= step:
                return int(rows[-1].split(",")[0])
        time.sleep(0.005)
    proc.kill()
    pytest.fail(f"step {step} not reached in {timeout} s")


# ----------------------------------------------------------------------- run directory
def test_run_directory_contents(reference: Path) -> None:
    names = {p.name for p in reference.iterdir()}
    assert {CONFIG, THERMO, FRAMES, CHECKPOINT, SNAPSHOT, SUMMARY} <= names
    assert UNSTABLE not in names
    summary = json.loads((reference / SUMMARY).read_text())
    assert summary["status"] == "finished"
    assert summary["step"] == summary["steps"] == STEPS
    assert summary["n_particles"] > 100
    assert summary["particle_steps_per_s"] > 0 and summary["wall_time_s"] > 0
    assert checkpoint_step(reference / CHECKPOINT) == STEPS
    assert (reference / SNAPSHOT).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_resolved_config_is_written_and_reloads(reference: Path) -> None:
    written = load_config(reference / CONFIG)
    assert written.model_dump() == load_config(settle()).model_dump()
    text = (reference / CONFIG).read_text()
    assert "check_every = 100" in text  # a default, filled in


def test_thermo_csv_columns(reference: Path) -> None:
    lines = (reference / THERMO).read_text().splitlines()
    assert lines[0].split(",") == list(THERMO_COLUMNS)
    rows = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    assert np.array_equal(rows[:, 0], np.arange(0, STEPS + 1, 20))
    assert np.all(rows[:, 2] == rows[0, 2])  # N
    assert np.all(rows[:, 3] >= 0) and np.all(rows[:, 5] >= 0)
    assert rows[-1, 6] > 0  # contacts in the settled pile
    assert np.all(np.diff(rows[:, 7]) >= 0)  # list rebuilds only grow


def test_frames_are_readable_with_plain_h5py(reference: Path) -> None:
    with h5py.File(reference / FRAMES, "r") as f:
        steps = f["particles/all/position/step"][:]
        assert list(steps) == list(range(0, STEPS + 1, 500))
        k = len(steps) - 1
        n = int(f["observables/particle_number/value"][k])
        position = f["particles/all/position/value"][k, :n]
        ids = f["particles/all/id/value"][k, :n]
        radius = f["particles/all/radius/value"][k, :n]
        velocity = f["particles/all/velocity/value"][k, :n]
        omega = f["particles/all/omega/value"][k, :n]
        species = f["particles/all/species/value"][k, :n]
        body = f["particles/all/body/value"][k, :n]
        m = int(f["observables/contact_number/value"][k])
        pairs = f["connectivity/contacts/value"][k, :m]
        force = f["observables/contacts/force/value"][k, :m]
        branch = f["observables/contacts/branch/value"][k, :m]
    assert position.shape == (n, 2) and velocity.shape == (n, 2) and omega.shape == (n, 3)
    assert np.all(np.isfinite(position)) and np.all(radius > 0)
    assert sorted(ids) == list(range(n)) and np.all(species == 0) and np.all(body == -1)
    assert m > 0 and pairs.shape == (m, 2) and force.shape == branch.shape == (m, 2)
    assert np.all(np.isin(pairs, ids))


def test_export_round_trip(reference: Path, tmp_path: Path) -> None:
    from grainflow.cli import export_frames
    from grainflow.io.lammps_dump import read_lammps_dump

    frames = list(read_frames(reference / FRAMES))
    path, count = export_frames(reference, "dump", tmp_path / "run.dump")
    dumped = read_lammps_dump(path)
    assert count == len(dumped) == len(frames)
    for frame, block in zip(frames, dumped):
        assert block.step == frame.step
        assert np.array_equal(block.columns["id"], frame.id)
        assert np.allclose(block.columns["x"], frame.position[:, 0], rtol=1e-9, atol=0)
        assert np.allclose(block.columns["vy"], frame.velocity[:, 1], rtol=1e-9, atol=1e-300)
    pvd, count = export_frames(reference, "vtk", tmp_path / "vtk")
    assert count == len(frames)
    assert len(list((tmp_path / "vtk").glob("*.vtp"))) == len(frames)
    assert pvd.read_text().count("<DataSet") == len(frames)


def test_snapshot_walls_are_the_edge_on_walls_clipped_to_the_box() -> None:
    from grainflow.config.build import build_simulation
    from grainflow.runner import wall_lines

    lines = wall_lines(build_simulation(load_config(settle())))
    assert lines == [((0.0, 0.0), (12.0, 0.0)), ((0.0, 0.0), (0.0, 30.0)),
                     ((12.0, 30.0), (12.0, 0.0))]


# ------------------------------------------------------------------- kill and resume
def test_sigkill_at_a_random_step_then_resume_is_bitwise(reference: Path, tmp_path: Path) -> None:
    seed = random.randrange(1 << 30)
    kill_at = random.Random(seed).randrange(1001, STEPS * 3 // 4)
    rundir = tmp_path / "run"
    proc = launch(write_toml(tmp_path / "settle.toml", settle()), rundir)
    seen = wait_for_step(proc, rundir, kill_at)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    assert proc.returncode == -signal.SIGKILL, f"seed {seed}"
    saved = checkpoint_step(rundir / CHECKPOINT)
    assert saved is not None and 1000 <= saved <= seen

    # every frame written before the kill reads back, equal to the uninterrupted run's
    ref_frames = {f.step: f for f in read_frames(reference / FRAMES)}
    with h5py.File(rundir / FRAMES, "r", swmr=True) as f:
        n_frames = len(f["particles/all/position/step"])
        assert n_frames >= seen // 500, f"seed {seed}"
        for k in range(n_frames):
            step = int(f["particles/all/position/step"][k])
            n = int(f["observables/particle_number/value"][k])
            assert np.array_equal(f["particles/all/position/value"][k, :n],
                                  ref_frames[step].position), (seed, step)

    result = subprocess.run([sys.executable, "-m", "grainflow", "resume", str(rundir),
                             "--threads", "1", "--progress", "none"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    ref, got = final_arrays(reference), final_arrays(rundir)
    assert ref.keys() == got.keys()
    for name in ref:
        assert np.array_equal(ref[name], got[name]), f"{name} differs (seed {seed})"
    assert_same_frames(reference / FRAMES, rundir / FRAMES)
    steps = [int(r.split(",")[0]) for r in (rundir / THERMO).read_text().splitlines()[1:]]
    assert steps == list(range(0, STEPS + 1, 20))


def test_sigterm_writes_a_checkpoint_and_resume_finishes(reference: Path, tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    proc = launch(write_toml(tmp_path / "settle.toml", settle()), rundir)
    wait_for_step(proc, rundir, 1500)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signal.SIGTERM
    assert out.startswith(f"run: {STEPS} steps")  # stdout is a pipe: plain progress lines
    assert err.strip().count("\n") == 0 and "SIGTERM" in err
    summary = json.loads((rundir / SUMMARY).read_text())
    assert summary["status"] == "interrupted"
    assert checkpoint_step(rundir / CHECKPOINT) == summary["step"] >= 1500
    resume_run(rundir, progress="none")
    ref, got = final_arrays(reference), final_arrays(rundir)
    for name in ref:
        assert np.array_equal(ref[name], got[name]), name
    assert_same_frames(reference / FRAMES, rundir / FRAMES)


def test_checkpoint_holds_the_whole_state(reference: Path) -> None:
    data = read_checkpoint(reference / CHECKPOINT)
    sim = data["sim"]
    assert {"x", "v", "omega", "force", "torque", "id", "wall_history_0"} <= sim["arrays"].keys()
    assert sim["interactions"]["0"]["history"].shape[1] == 4  # tangential spring + cohesion flag
    assert sim["rng"]["bit_generator"] == "PCG64"
    assert data["runner"]["version"] == CHECKPOINT_VERSION and data["runner"]["wall_seconds"] > 0


def test_adams_bashforth_history_survives_a_checkpoint(tmp_path: Path) -> None:
    config = settle(steps=600, checkpoint_every=0, frames_every=0, snapshot=False)
    config["run"]["integrator"] = "adams_bashforth2"
    run_config(config, tmp_path / "ref", progress="none")
    with pytest.raises(RunInterrupted):
        run_config(config, tmp_path / "run", progress=InterruptAt(300))
    assert np.isfinite(read_checkpoint(tmp_path / "run" / CHECKPOINT)
                       ["sim"]["arrays"]["ab2_force_prev"]).all()
    resume_run(tmp_path / "run", progress="none")
    ref, got = final_arrays(tmp_path / "ref"), final_arrays(tmp_path / "run")
    for name in ref:
        assert np.array_equal(ref[name], got[name]), name


def test_soft_law_run_resumes_bitwise(tmp_path: Path) -> None:
    config = settle(steps=600, checkpoint_every=0, frames_every=0, snapshot=False)
    config["contact"] = {"law": "soft", "epsilon": 1000.0, "mu_k": 0.5}
    assert_resume_is_bitwise(config, tmp_path, 300)


def assert_resume_is_bitwise(config: dict, tmp_path: Path, at: int) -> None:
    """A run interrupted at step ``at`` and resumed ends bitwise where the whole run ends."""
    run_config(config, tmp_path / "ref", progress="none")
    with pytest.raises(RunInterrupted):
        run_config(config, tmp_path / "run", progress=InterruptAt(at))
    resume_run(tmp_path / "run", progress="none")
    ref, got = final_arrays(tmp_path / "ref"), final_arrays(tmp_path / "run")
    for name in ref:
        assert np.array_equal(ref[name], got[name]), name


def test_resume_refuses_a_directory_without_checkpoint(tmp_path: Path) -> None:
    with pytest.raises(RunDirError, match="no config.toml"):
        resume_run(tmp_path)


def test_run_config_resume_continues_an_existing_run(tmp_path: Path) -> None:
    config = settle(steps=400, checkpoint_every=100, frames_every=100, snapshot=False)
    summary = run_config(config, tmp_path / "run", progress="none")
    again = run_config(config, tmp_path / "run", resume=True, progress="none")
    assert again.step == summary.step == 400


# ----------------------------------------------------------------------- overwriting
def test_a_non_empty_run_directory_is_not_overwritten(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    rundir.mkdir()
    (rundir / "notes.txt").write_text("mine")
    config = settle(steps=100, frames_every=0, snapshot=False)
    with pytest.raises(RunDirError, match="--overwrite"):
        run_config(config, rundir, progress="none")
    assert not (rundir / CONFIG).exists()
    run_config(config, rundir, overwrite=True, progress="none")
    run_config(config, rundir, overwrite=True, progress="none")
    assert (rundir / "notes.txt").read_text() == "mine"
    assert (rundir / CHECKPOINT).is_file()


# ---------------------------------------------------------------------- instability
def test_an_unstable_run_stops_naming_step_and_particle(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    with pytest.warns(UserWarning, match="stability limit"):
        with pytest.raises(RunUnstable) as info:
            run_config(COLLIDE, rundir, progress="none")
    message = str(info.value)
    assert "unstable at step 5, particle id" in message
    assert "radii per step" in message
    assert "dt = 0.3" in message and "oscillation time" in message
    assert "last healthy checkpoint: step 4" in message
    assert checkpoint_step(rundir / CHECKPOINT) == 4
    assert checkpoint_step(rundir / UNSTABLE) == 5
    summary = json.loads((rundir / SUMMARY).read_text())
    assert summary["status"] == "unstable" and summary["step"] == 5
    assert len(list(read_frames(rundir / FRAMES))) == 5  # steps 0-4; frames stay readable


def test_particles_placed_overlapping_fail_at_step_zero(tmp_path: Path) -> None:
    config = copy.deepcopy(COLLIDE)
    config["run"] = {"steps": 10, "check_every": 1}
    config["particles"][0]["positions"] = [[5, 5], [5.1, 5]]  # 90 % overlap
    with pytest.raises(RunUnstable, match=r"step 0, particle id [01]: overlap 1\.8 of the "
                                          r"radius.*no healthy checkpoint"):
        run_config(config, tmp_path / "run", progress="none")
    assert not (tmp_path / "run" / CHECKPOINT).exists()
    assert (tmp_path / "run" / UNSTABLE).exists()


def test_interrupt_in_process(tmp_path: Path) -> None:
    """A SIGINT arriving during the run checkpoints the current step and stops."""
    config = settle(steps=1000, frames_every=0, snapshot=False)
    with pytest.raises(RunInterrupted) as info:
        run_config(config, tmp_path / "run", progress=InterruptAt(300))
    assert info.value.exit_code == 130
    assert checkpoint_step(tmp_path / "run" / CHECKPOINT) == 300
    assert "grainflow resume" in str(info.value)


# -------------------------------------------------------------------------- progress
class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_is_a_bar_on_a_terminal_and_lines_elsewhere() -> None:
    out = io.StringIO()
    plain = make_progress("auto", stream=out, interval=0.0)
    assert isinstance(plain, PlainProgress)
    plain.start(1000)
    plain.update(500, 120, 2.5e5)
    plain.close()
    lines = out.getvalue().splitlines()
    assert lines[0] == "run: 1000 steps"
    assert lines[1].startswith("step 500/1000 (50.0%)  N=120  2.5e+05 particle-steps/s  eta ")
    terminal = FakeTerminal()
    bar = make_progress("auto", stream=terminal)
    assert isinstance(bar, RichProgress)
    bar.start(1000, done=200)
    bar.update(500, 120, 2.5e5)
    bar.close()
    assert "500/1000" in terminal.getvalue() and "particle-steps/s" in terminal.getvalue()
    with pytest.raises(ValueError, match="progress: 'fancy'"):
        make_progress("fancy")


@pytest.mark.parametrize("config", [
    {"scenario": "jet3d", "dim": 3, "run": {"steps": 200},
     "jet": {"jet_diameter": 3.0, "target_diameter": 4.0, "n": 60, "gap": 0.0}},
    {"scenario": "hopper2d", "dim": 2, "run": {"steps": 200},
     "hopper": {"n": 40, "width": 8.0, "orifice_width": 3.0}},
], ids=["jet3d", "hopper2d"])
def test_a_scenario_run_interrupted_then_resumed_is_bitwise(config: dict, tmp_path: Path
                                                            ) -> None:
    """Scenarios with their own section resume: the saved config.toml holds only the
    sections the scenario reads (it once held empty generic ones, which load_config refuses,
    so every interrupted jet or hopper run failed to resume)."""
    config = {**config, "output": {"checkpoint_every": 0, "frames_every": 0,
                                   "snapshot": False}}
    assert_resume_is_bitwise(config, tmp_path, 100)


def test_frames_from_skips_the_transient(tmp_path: Path) -> None:
    """output.frames_from: no frame before that time, then one every frames_every steps,
    starting with the first due step at or after it."""
    config = settle(steps=600, frames_every=100, checkpoint_every=0, snapshot=False,
                    frames_from=0.25)
    rundir = tmp_path / "run"
    run_config(config, rundir, progress="none")
    frames = list(read_frames(rundir / FRAMES))
    times = [f.time for f in frames]
    steps = [f.step for f in frames]
    assert len(frames) >= 2 and min(times) >= 0.25 * (1 - 1e-12)
    assert steps == list(range(steps[0], 601, 100))
    every = times[1] - times[0]
    assert times[0] - every < 0.25  # the due frame before it was skipped
