"""Fault cases of the sweep verbs: damaged catalogs, unwritable sweep directories, invalid
point configurations, relative data paths, interrupted / unstable / damaged run directories.

Every command-line case asserts a one-line ``error: ...`` (no traceback) and the exit code.
The sweeps that run use one in-process LocalCluster (threads, bound to 127.0.0.1) passed
as an existing scheduler: its workers share this process's compiled numba kernels and its
working directory, so the relative-path test is a real test of where paths resolve.
"""

from __future__ import annotations

import copy
import io
import json
import os
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
from rich.console import Console
from typer.testing import CliRunner

import sweep_helpers as helpers
from grainflow.progress import Progress
from grainflow.runner import (CHECKPOINT, CONFIG, SUMMARY, THERMO, RunInterrupted,
                              checkpoint_step, read_checkpoint, run_config)
from grainflow.sweep import Catalog, SweepFileError, parse_sweep, run_sweep
from grainflow.sweep.cli import sweep_app

TESTS_DIR = Path(__file__).parent

#: 18 disks settling on a floor: well under a second for 400 steps once compiled.
TINY: dict[str, Any] = {
    "dim": 2,
    "gravity": [0, -1],
    "run": {"steps": 400, "seed": 0},
    "output": {"thermo_every": 20, "frames_every": 100, "checkpoint_every": 100,
               "snapshot": False},
    "box": {"lo": [0, 0], "hi": [6, 10]},
    "particles": [{"fill": "lattice", "region": {"lo": [0, 0], "hi": [6, 5]},
                   "radius": [0.45, 0.55], "spacing": 1.2}],
    "contact": {"law": "granular", "restitution": 0.7, "contact_time": 0.05, "mu": 0.5},
    "walls": [{"shape": "segment", "p0": [0, 0], "p1": [6, 0]}],
}

#: Two disks flying at each other with dt far past the stability limit: unstable at once.
COLLIDE: dict[str, Any] = {
    "dim": 2,
    "run": {"steps": 20, "dt": 0.3, "allow_unsafe_dt": True, "check_every": 1, "seed": 0},
    "output": {"thermo_every": 1, "frames_every": 0, "checkpoint_every": 2, "snapshot": False},
    "box": {"lo": [0, 0], "hi": [10, 10]},
    "particles": [{"fill": "list", "positions": [[1, 5], [4, 5]],
                   "velocities": [[1, 0], [-1, 0]], "radius": 0.5}],
    "contact": {"law": "granular", "restitution": 0.9, "contact_time": 0.1},
}


class InterruptAt(Progress):
    """A progress display that sends this process SIGINT when the run reaches ``step``
    (the runner then writes a checkpoint and stops, like a killed batch job)."""

    def __init__(self, step: int) -> None:
        self.step = step

    def update(self, step: int, n: int, rate: float) -> None:
        if step == self.step:
            os.kill(os.getpid(), signal.SIGINT)


@pytest.fixture(scope="module")
def scheduler():
    """An in-process 1-worker LocalCluster on loopback (shares numba's compiled kernels)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://",
                      host="127.0.0.1", dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        yield cluster.scheduler_address


@pytest.fixture(scope="module", autouse=True)
def one_thread():
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(before)


def quiet() -> Console:
    return Console(file=io.StringIO(), highlight=False)


def cli(*args: str) -> Any:
    result = CliRunner().invoke(sweep_app, list(args))
    assert "Traceback" not in result.output, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result


def error_line(result: Any) -> str:
    """The output must be one ``error: ...`` line (lists follow it on indented lines)."""
    lines = [line for line in result.output.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("error: ")]
    assert len(errors) == 1, result.output
    return errors[0]


def tiny_sweep_file(tmp_path: Path) -> Path:
    """8 points of the helper runners (sleep_runner + product analysis)."""
    path = tmp_path / "tiny.toml"
    path.write_text(tomli_w.dumps({
        "base": helpers.base_config(tmp_path, sleep=0.0),
        "overrides": {"p.a": [1, 2, 3, 4], "p.b": [1.0, 2.0]},
        "runner": "sweep_helpers:sleep_runner",
        "analyses": ["sweep_helpers:product"],
    }))
    return path


def final_arrays(rundir: Path) -> dict[str, np.ndarray]:
    sim = read_checkpoint(rundir / CHECKPOINT)["sim"]
    return {**sim["arrays"], "step": np.array(sim["step"]), "time": np.array(sim["time"])}


def assert_same_final_state(a: Path, b: Path) -> None:
    ref, got = final_arrays(a), final_arrays(b)
    assert ref.keys() == got.keys()
    for name in ref:
        assert np.array_equal(ref[name], got[name]), name


def thermo_steps(rundir: Path) -> list[int]:
    return [int(r.split(",")[0]) for r in (rundir / THERMO).read_text().splitlines()[1:]]


# ---------------------------------------------------------------------------------------
# 1. Damaged catalog


def damage(catalog: Path, how: str) -> None:
    if how == "garbage":
        catalog.write_bytes(os.urandom(4096) + b"this is not sqlite" * 100)
    elif how == "truncated":
        data = catalog.read_bytes()
        catalog.write_bytes(data[: len(data) // 2])
    elif how == "empty":
        catalog.write_bytes(b"")
    for side in ("-wal", "-shm"):
        catalog.with_name(catalog.name + side).unlink(missing_ok=True)


def healthy_catalog(sweepdir: Path, tmp_path: Path) -> Path:
    spec = parse_sweep({"base": helpers.base_config(tmp_path), "overrides": {"p.a": [1, 2]},
                        "runner": "sweep_helpers:sleep_runner"})
    sweepdir.mkdir()
    with Catalog.in_dir(sweepdir) as catalog:
        catalog.register(spec.points())
        for i in range(40):  # several pages, so that half the file is a real truncation
            catalog.set_meta(f"k{i}", "x" * 500)
    return sweepdir / "catalog.sqlite"


@pytest.mark.parametrize("how", ["garbage", "truncated", "empty"])
def test_damaged_catalog_is_one_error_naming_the_file_and_the_way_out(tmp_path, how):
    sweepdir = tmp_path / "sweep"
    catalog = healthy_catalog(sweepdir, tmp_path)
    damage(catalog, how)
    before = catalog.read_bytes()

    status = cli("sweep-status", str(sweepdir))
    assert status.exit_code == 2
    line = error_line(status)
    assert str(catalog) in line and "damaged" in line and "--rebuild-catalog" in line
    assert "runs" in line and "not affected" in line

    run = cli("sweep", str(tiny_sweep_file(tmp_path)), "-o", str(sweepdir),
              "--scheduler", "tcp://127.0.0.1:1")
    assert run.exit_code == 2
    assert str(catalog) in error_line(run) and "--rebuild-catalog" in run.output
    assert catalog.read_bytes() == before, "a damaged catalog is left as it is"


def test_rebuild_catalog_reuses_the_finished_runs(tmp_path, scheduler):
    sweep_file = tiny_sweep_file(tmp_path)
    sweepdir = tmp_path / "out"
    first = cli("sweep", str(sweep_file), "-o", str(sweepdir), "--scheduler", scheduler)
    assert first.exit_code == 0, first.output
    assert len(helpers.runner_calls(tmp_path)) == 8
    catalog = sweepdir / "catalog.sqlite"
    damage(catalog, "garbage")

    again = cli("sweep", str(sweep_file), "-o", str(sweepdir), "--scheduler", scheduler,
                "--rebuild-catalog")
    assert again.exit_code == 0, again.output
    assert "moved to" in again.output
    assert len(helpers.runner_calls(tmp_path)) == 8, "finished runs must not run again"
    with Catalog(catalog) as rebuilt:
        rows = rebuilt.rows()
    assert len(rows) == 8 and all(r.status == "done" for r in rows)
    assert sorted(r.summary["ab_plus_seed"] for r in rows) == sorted(
        a * b for a in (1, 2, 3, 4) for b in (1.0, 2.0))
    assert len(list(sweepdir.glob("catalog.sqlite.damaged-*"))) == 1, "kept for inspection"


def test_catalog_of_another_program_is_refused(tmp_path):
    sweepdir = tmp_path / "sweep"
    sweepdir.mkdir()
    with sqlite3.connect(sweepdir / "catalog.sqlite") as conn:
        conn.execute("CREATE TABLE something (x)")
    result = cli("sweep-status", str(sweepdir))
    assert result.exit_code == 2 and "without the catalog's tables" in error_line(result)


# ---------------------------------------------------------------------------------------
# 2. Unwritable sweep directory


def test_read_only_sweep_directory_is_one_error(tmp_path):
    sweepdir = tmp_path / "ro"
    sweepdir.mkdir()
    sweepdir.chmod(0o555)
    try:
        probe = sweepdir / "probe"
        try:
            probe.write_text("")
        except OSError:
            pass
        else:
            probe.unlink()
            pytest.skip("running as root: chmod does not stop writes (see the next test)")
        result = cli("sweep", str(tiny_sweep_file(tmp_path)), "-o", str(sweepdir),
                     "--scheduler", "tcp://127.0.0.1:1")
        assert result.exit_code == 2
        line = error_line(result)
        assert str(sweepdir) in line and "not writable" in line and "chmod" in line
    finally:
        sweepdir.chmod(0o755)


def test_sweep_directory_that_cannot_be_created_is_one_error(tmp_path):
    """Works as root too: the sweep directory would have to be made inside a file."""
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    for target in (blocker, blocker / "sweep"):
        result = cli("sweep", str(tiny_sweep_file(tmp_path)), "-o", str(target),
                     "--scheduler", "tcp://127.0.0.1:1")
        assert result.exit_code == 2, result.output
        line = error_line(result)
        assert str(target) in line and "-o" in line


def test_read_only_catalog_file_is_one_error(tmp_path):
    """A catalog opened read-only by SQLite itself (immutable to this process): the same
    error path as a catalog on a read-only filesystem; works as root."""
    sweepdir = tmp_path / "sweep"
    catalog = healthy_catalog(sweepdir, tmp_path)
    reader = Catalog(catalog, readonly=True)
    try:
        with pytest.raises(sqlite3.OperationalError) as info:
            reader._conn.execute("INSERT INTO meta (key, value) VALUES ('a', 'b')")
        err = reader.error(info.value)
    finally:
        reader.close()
    assert str(catalog) in str(err) and "cannot write" in str(err)


# ---------------------------------------------------------------------------------------
# 3. Invalid point configurations are all reported before anything runs


def test_every_invalid_point_is_reported_before_anything_runs(tmp_path):
    sweep_file = tmp_path / "bad_points.toml"
    sweep_file.write_text(tomli_w.dumps({
        "base": TINY, "replicates": 2,
        "overrides": {"contact.mu": [0.5, -0.2], "run.steps": [10, 0]},
    }))
    sweepdir = tmp_path / "out"
    result = cli("sweep", str(sweep_file), "-o", str(sweepdir), "--scheduler", "tcp://127.0.0.1:1")
    assert result.exit_code == 2, result.output
    line = error_line(result)
    assert "6 of 8 point(s) have an invalid configuration" in line
    listed = [entry for entry in result.output.splitlines() if entry.startswith("  - point")]
    assert len(listed) == 3, result.output  # (mu=-0.2, 10), (0.5, 0), (-0.2, 0); seeds merged
    bad_mu = [e for e in listed if "contact.mu=-0.2 run.steps=10 " in e]
    assert bad_mu and "run.seed=0, 1" in bad_mu[0] and "contact.mu: -0.2 is not valid" in bad_mu[0]
    both = [e for e in listed if "contact.mu=-0.2 run.steps=0 " in e]
    assert both and "contact.mu:" in both[0] and "run.steps:" in both[0]
    assert not sweepdir.exists(), "nothing may start before every point is valid"


def test_invalid_base_config_is_reported_once(tmp_path):
    base = copy.deepcopy(TINY)
    base["contact"]["muu"] = 0.5  # a key the schema does not know
    spec = parse_sweep({"base": base, "overrides": {"contact.mu": [0.1, 0.2, 0.3]}})
    with pytest.raises(SweepFileError) as info:
        run_sweep(spec, tmp_path / "out", scheduler="tcp://127.0.0.1:1", console=quiet())
    message = str(info.value)
    assert "3 of 3 point(s)" in message and "every point (the base config)" in message
    assert "contact.muu" in message and message.count("\n  - ") == 1


def test_unknown_override_keys_are_all_named(tmp_path):
    with pytest.raises(SweepFileError) as info:
        parse_sweep({"base": TINY, "overrides": {"contact.muu": [1], "run.stepz": [1]}})
    assert "'contact.muu'" in str(info.value) and "'run.stepz'" in str(info.value)


# ---------------------------------------------------------------------------------------
# 4. Relative paths resolve against the file that wrote them, not the worker's directory


def write_data_file(path: Path) -> None:
    """A LAMMPS atom_style sphere data file: 6 disks on a row (z = 0)."""
    atoms = "\n".join(f"{i + 1} 1 1.0 1.0 {0.6 + 1.1 * i} 1.0 0.0" for i in range(6))
    path.write_text("LAMMPS data file\n\n6 atoms\n1 atom types\n\n0 8 xlo xhi\n0 5 ylo yhi\n"
                    f"-0.5 0.5 zlo zhi\n\nAtoms # sphere\n\n{atoms}\n")


def test_relative_data_path_is_resolved_at_the_driver(tmp_path, scheduler, monkeypatch):
    conf = tmp_path / "conf"
    (conf / "bases").mkdir(parents=True)
    write_data_file(conf / "bases" / "grains.data")
    base = copy.deepcopy(TINY)
    base["run"]["steps"] = 50
    base["box"] = {"lo": [0, 0], "hi": [8, 5]}
    base["particles"] = [{"fill": "lammps_data", "file": "grains.data"}]
    (conf / "bases" / "base.toml").write_text(tomli_w.dumps(base))
    sweep_file = conf / "sweep.toml"
    sweep_file.write_text('base = "bases/base.toml"\n[overrides]\n"contact.mu" = [0.3, 0.5]\n')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # the driver's and the (in-process) worker's directory

    result = cli("sweep", str(sweep_file), "-o", "out", "--scheduler", scheduler)
    assert result.exit_code == 0, result.output
    with Catalog.in_dir(elsewhere / "out") as catalog:
        rows = catalog.rows()
    assert [r.status for r in rows] == ["done", "done"], [r.error for r in rows]
    written = (elsewhere / "out" / rows[0].rundir / CONFIG).read_text()
    assert str((conf / "bases" / "grains.data").resolve()) in written
    recorded = (elsewhere / "out" / "sweep.toml").read_text()
    assert str((conf / "bases" / "grains.data").resolve()) in recorded


def test_names_and_units_are_not_taken_for_paths(tmp_path, monkeypatch):
    """Only file-path fields are resolved: a scenario's name, a law or a unit stays as it is
    even where a file or folder of that name exists in the folder (a folder ``jet2d`` beside
    a sweep of the ``jet2d`` scenario once failed every point: "scenario: '/.../jet2d' is not
    known")."""
    (tmp_path / "granular").write_text("")  # a file named like a contact law
    (tmp_path / "jet2d").mkdir()  # a folder named like a scenario
    (tmp_path / "grains.data").write_text("")
    monkeypatch.chdir(tmp_path)
    from grainflow.sweep.spec import absolute_paths

    value = {"scenario": "jet2d", "contact": {"law": "granular"}, "x": "1.5 mm",
             "f": ["grains.data", "granular"],
             "particles": [{"fill": "lammps_data", "file": "grains.data"}],
             "chute": {"data_file": "grains.data"}}
    assert absolute_paths(value, tmp_path / "sub") == value, "nothing exists under sub/"
    out = absolute_paths(value, tmp_path)
    resolved = str(tmp_path / "grains.data")
    assert out["particles"][0]["file"] == resolved and out["chute"]["data_file"] == resolved
    assert {k: out[k] for k in ("scenario", "contact", "x", "f")} == \
        {k: value[k] for k in ("scenario", "contact", "x", "f")}
    # one field's value, as an override gives it
    assert absolute_paths("grains.data", tmp_path, "data_file") == resolved
    assert absolute_paths("jet2d", tmp_path, "scenario") == "jet2d"


def test_a_sweep_beside_folders_named_like_its_scenario_and_law(tmp_path, monkeypatch):
    """The point's config keeps the names and validates (it once named the folders)."""
    from grainflow.config.schema import load_config

    (tmp_path / "generic").mkdir()
    (tmp_path / "granular").mkdir()
    monkeypatch.chdir(tmp_path)
    spec = parse_sweep({"base": {**TINY, "scenario": "generic"},
                        "overrides": {"contact.law": ["granular"]}})
    config = spec.point_config(spec.points()[0])
    assert config["scenario"] == "generic" and config["contact"]["law"] == "granular"
    load_config(config)


# ---------------------------------------------------------------------------------------
# 5. Interrupted, unstable and damaged run directories of sweep points


def one_point(base: dict[str, Any]) -> tuple[Any, Any]:
    spec = parse_sweep({"base": base, "overrides": {"contact.mu": [0.5]}})
    return spec, spec.points()[0]


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """An uninterrupted run of the single point's configuration."""
    spec, point = one_point(TINY)
    rundir = tmp_path_factory.mktemp("ref") / "run"
    run_config(spec.point_config(point), rundir, progress="none")
    return rundir


def interrupted_point(tmp_path: Path, killed: bool) -> tuple[Any, Path, Path]:
    """A sweep directory whose only point stopped at step 250 (checkpoint written).
    ``killed``: no summary.json either, as after kill -9 of the worker."""
    spec, point = one_point(TINY)
    sweepdir = tmp_path / "sweep"
    rundir = sweepdir / "runs" / point.point_id
    with pytest.raises(RunInterrupted):
        run_config(spec.point_config(point), rundir, progress=InterruptAt(250))
    assert checkpoint_step(rundir / CHECKPOINT) == 250
    if killed:
        (rundir / SUMMARY).unlink()
    (rundir / "sentinel").write_text("a run from scratch deletes this file")
    return spec, sweepdir, rundir


@pytest.mark.parametrize("killed", [False, True], ids=["sigterm", "kill9"])
def test_interrupted_point_resumes_from_its_checkpoint(tmp_path, scheduler, reference, killed,
                                                     capsys):
    spec, sweepdir, rundir = interrupted_point(tmp_path, killed)
    assert max(thermo_steps(rundir)) == 240  # thermo rows every 20 steps up to the stop
    capsys.readouterr()
    result = run_sweep(spec, sweepdir, scheduler=scheduler, console=quiet())
    assert result.ok, [r.error for r in Catalog.in_dir(sweepdir).rows()]
    assert "resuming at step 250" in capsys.readouterr().out  # the runner's progress line
    assert (rundir / "sentinel").exists(), "the point must continue, not start again"
    assert json.loads((rundir / SUMMARY).read_text())["status"] == "finished"
    steps = thermo_steps(rundir)
    # the rows before the stop are the first attempt's, the rest the resumed segment's: the
    # log is the uninterrupted run's (no row at the checkpoint's step 250)
    assert steps == thermo_steps(reference)
    assert thermo_steps(reference) == list(range(0, 401, 20))
    assert_same_final_state(reference, rundir)


class SlowThenInterruptAt(InterruptAt):
    """:class:`InterruptAt`, after spending ``pause`` seconds at step ``slow`` (so the
    first attempt's segment costs at least that much before its checkpoint)."""

    def __init__(self, step: int, slow: int, pause: float) -> None:
        super().__init__(step)
        self.slow, self.pause = slow, pause

    def update(self, step: int, n: int, rate: float) -> None:
        if step == self.slow:
            import time

            time.sleep(self.pause)
        super().update(step, n, rate)


def test_a_resumed_point_records_what_every_kept_segment_cost(tmp_path, scheduler):
    """The catalog's wall_time of a resumed point counts the first attempt's segment up to
    its checkpoint (0.6 s here, in a sleep), not only the resumed part; the point file and
    a rerun of the analyses alone keep it."""
    spec, point = one_point(TINY)
    sweepdir = tmp_path / "sweep"
    rundir = sweepdir / "runs" / point.point_id
    with pytest.raises(RunInterrupted):
        run_config(spec.point_config(point), rundir,
                   progress=SlowThenInterruptAt(250, slow=120, pause=0.6))
    (rundir / SUMMARY).unlink()  # as after kill -9 of the worker
    assert run_sweep(spec, sweepdir, scheduler=scheduler, console=quiet()).ok
    row = Catalog.in_dir(sweepdir).rows()[0]
    total = json.loads((rundir / SUMMARY).read_text())["wall_time_s"]  # both segments
    assert total >= 0.6
    assert row.wall_time >= total
    point_file = json.loads((rundir / "sweep_point.json").read_text())
    assert point_file["run_wall_time"] >= total
    # the run is complete: a new attempt (a new catalog) only runs the analyses, and still
    # counts the run
    for path in sweepdir.glob("catalog.sqlite*"):
        path.unlink()
    assert run_sweep(spec, sweepdir, scheduler=scheduler, console=quiet()).ok
    assert Catalog.in_dir(sweepdir).rows()[0].wall_time >= total


def test_finished_run_without_point_file_is_not_run_again(tmp_path, scheduler, reference):
    spec, point = one_point(TINY)
    sweepdir = tmp_path / "sweep"
    rundir = sweepdir / "runs" / point.point_id
    run_config(spec.point_config(point), rundir, progress="none")
    (rundir / "sentinel").write_text("")
    mtime = (rundir / CHECKPOINT).stat().st_mtime_ns
    assert run_sweep(spec, sweepdir, scheduler=scheduler, console=quiet()).ok
    assert (rundir / "sentinel").exists() and (rundir / CHECKPOINT).stat().st_mtime_ns == mtime


def test_unstable_point_is_reported_not_resumed(tmp_path, scheduler):
    sweep_file = tmp_path / "collide.toml"
    sweep_file.write_text(tomli_w.dumps({"base": COLLIDE, "overrides": {"contact.restitution": [0.9]}}))
    sweepdir = tmp_path / "out"
    first = cli("sweep", str(sweep_file), "-o", str(sweepdir), "--scheduler", scheduler)
    assert first.exit_code == 1, first.output
    assert "RunUnstable" in first.output
    with Catalog.in_dir(sweepdir) as catalog:
        (row,) = catalog.rows()
    rundir = sweepdir / row.rundir
    assert json.loads((rundir / SUMMARY).read_text())["status"] == "unstable"
    (rundir / "sentinel").write_text("")
    stamp = (rundir / "unstable_state.npz").stat().st_mtime_ns

    second = cli("sweep", str(sweep_file), "-o", str(sweepdir), "--scheduler", scheduler)
    assert second.exit_code == 1, second.output
    assert "went unstable and is not resumed" in second.output, second.output[-3000:]
    assert (rundir / "sentinel").exists(), "the run directory is kept for diagnosis"
    assert (rundir / "unstable_state.npz").stat().st_mtime_ns == stamp, "nothing ran"
    with Catalog.in_dir(sweepdir) as catalog:
        (row,) = catalog.rows()
    assert row.status == "failed" and "Traceback" not in row.error and str(rundir) in row.error


def test_damaged_checkpoint_is_moved_aside_and_the_point_reruns(tmp_path, scheduler, reference):
    spec, sweepdir, rundir = interrupted_point(tmp_path, killed=True)
    (rundir / CHECKPOINT).write_bytes(b"PK\x03\x04 not really a zip archive" * 10)
    output = quiet()
    result = run_sweep(spec, sweepdir, scheduler=scheduler, console=output)
    assert result.ok
    assert not (rundir / "sentinel").exists(), "ran again from step 0 in a fresh directory"
    (moved,) = rundir.parent.glob(f"{rundir.name}.damaged-*")
    assert (moved / "sentinel").exists(), "nothing of the damaged attempt is deleted"
    assert_same_final_state(reference, rundir)
    with Catalog.in_dir(sweepdir) as catalog:
        (row,) = catalog.rows()
    assert row.status == "done" and "could not be resumed" in row.error
    assert str(moved) in row.error
    assert "could not be resumed" in output.file.getvalue()


# ---------------------------------------------------------------------------------------
# The module entry point reports the same way


def test_python_m_sweep_reports_a_damaged_catalog_without_traceback(tmp_path):
    sweepdir = tmp_path / "sweep"
    catalog = healthy_catalog(sweepdir, tmp_path)
    damage(catalog, "garbage")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS_DIR), os.environ.get("PYTHONPATH", "")])}
    for args in (["sweep-status", str(sweepdir)],
                 ["sweep", str(tiny_sweep_file(tmp_path)), "-o", str(sweepdir)]):
        proc = subprocess.run([sys.executable, "-m", "grainflow.sweep", *args], env=env,
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stderr
        assert "Traceback" not in proc.stdout + proc.stderr
        assert proc.stderr.startswith("error: ") and str(catalog) in proc.stderr
