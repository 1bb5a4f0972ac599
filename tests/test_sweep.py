"""Tests of the parameter-sweep subsystem (grainflow.sweep).

The execution tests share one 2-worker LocalCluster (passed as an existing
scheduler); one test drives the CLI in a subprocess, which starts its own
LocalCluster, and interrupts it with SIGINT.
"""

from __future__ import annotations

import csv
import io
import json
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path
from typing import Any

import psutil
import pytest
import tomli_w
from rich.console import Console
from typer.testing import CliRunner

import sweep_helpers as helpers
from grainflow.sweep import (
    Catalog,
    SweepFileError,
    export_csv,
    load_sweep,
    parse_sweep,
    run_point,
    run_sweep,
    run_sweeps_together,
)
from grainflow.sweep.cli import sweep_app
from grainflow.sweep.execute import PointTask, SweepError, _exclusive

TESTS_DIR = Path(__file__).parent


def make_spec(tmp_path: Path, *, runner: str = "sleep_runner", test: dict | None = None, **fields):
    """A 2 (a) x 2 (b) grid with 2 replicates = 8 points, using the helper runners."""
    data = {
        "name": "tiny",
        "base": helpers.base_config(tmp_path, **(test or {})),
        "overrides": {"p.a": [1, 2], "p.b": {"start": 1, "stop": 2, "num": 2}},
        "replicates": 2,
        "runner": f"sweep_helpers:{runner}",
        "analyses": ["sweep_helpers:product"],
        **fields,
    }
    if "seeds" in fields and "replicates" not in fields:
        del data["replicates"]
    return parse_sweep(data)


def quiet() -> Console:
    return Console(file=io.StringIO(), highlight=False)


def rows_by_params(sweepdir: Path) -> dict[tuple, object]:
    with Catalog.in_dir(sweepdir) as catalog:
        return {(r.params["p.a"], r.params["p.b"], r.seed): r for r in catalog.rows()}


@pytest.fixture(scope="module")
def scheduler():
    """Address of a 2-worker LocalCluster, shared by the execution tests."""
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        yield cluster.scheduler_address


# ---------------------------------------------------------------------------------------
# Sweep files


def test_grid_expands_to_product_of_values_and_seeds(tmp_path):
    spec = make_spec(tmp_path, seed_start=5)
    points = spec.points()
    combos = {(p.overrides["p.a"], p.overrides["p.b"], p.seed) for p in points}
    assert combos == {(a, b, s) for a in (1, 2) for b in (1.0, 2.0) for s in (5, 6)}
    config = points[-1].config(spec.base)
    assert config["p"] == {"a": 2, "b": 2.0} and config["run"]["seed"] == 6
    assert spec.base["p"] == {"a": 1.0, "b": 1.0}, "expanding must not modify the base config"


def test_zip_mode_pairs_values_and_ranges_resolve(tmp_path):
    spec = make_spec(
        tmp_path,
        mode="zip",
        replicates=1,
        overrides={"p.a": [1, 2, 3, 4], "p.b": {"start": 0.01, "stop": 10, "num": 4, "scale": "log"}},
    )
    pairs = [(p.overrides["p.a"], p.overrides["p.b"]) for p in spec.points()]
    assert pairs == [(1, 0.01), (2, 0.1), (3, 1.0), (4, 10.0)]


def test_explicit_seeds(tmp_path):
    spec = make_spec(tmp_path, seeds=[11, 3], overrides={"p.a": [1]})
    assert [p.seed for p in spec.points()] == [11, 3]


def test_a_base_seed_the_sweep_replaces_is_warned(tmp_path, recwarn):
    """The sweep sets every point's seed; a non-default base seed outside its seeds would
    silently not run (the stream study's base said seed 1 and ran seed 0), so it warns with
    the fix. The default 0 and a base seed among the sweep's seeds do not."""
    base = helpers.base_config(tmp_path)
    base["run"]["seed"] = 7
    with pytest.warns(UserWarning, match=r"run.seed = 7.*\[0, 1\].*seed_start = 7"):
        make_spec(tmp_path, base=base)
    make_spec(tmp_path, base=base, seed_start=6)  # seeds 6 and 7
    make_spec(tmp_path, seeds=[3])  # base seed 0: the default
    assert not [w for w in recwarn if "run.seed" in str(w.message)]
    spec = make_spec(tmp_path, base=base, seeds=[7])
    assert [spec.point_config(p)["run"]["seed"] for p in spec.points()] == [7] * 4


def test_point_ids_do_not_depend_on_listing_order(tmp_path):
    forward = make_spec(tmp_path, overrides={"p.a": [1, 2], "p.b": [1.0, 2.0]})
    backward = make_spec(tmp_path, overrides={"p.b": [2, 1], "p.a": [2.0, 1.0]})
    ids = {p.point_id for p in forward.points()}
    assert len(ids) == 8
    assert ids == {p.point_id for p in backward.points()}
    other_seeds = make_spec(tmp_path, overrides={"p.a": [1, 2], "p.b": [1.0, 2.0]}, seed_start=2)
    assert ids.isdisjoint(p.point_id for p in other_seeds.points())


def test_base_file_is_resolved_relative_to_sweep_file(tmp_path):
    (tmp_path / "conf").mkdir()
    (tmp_path / "conf" / "base.toml").write_text(tomli_w.dumps(helpers.base_config(tmp_path)))
    sweep_file = tmp_path / "conf" / "my_sweep.toml"
    sweep_file.write_text('base = "base.toml"\n[overrides]\n"p.a" = {start = 3, stop = 10, num = 8}\n')
    spec = load_sweep(sweep_file)
    assert spec.name == "my_sweep"
    assert [p.overrides["p.a"] for p in spec.points()] == [3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0]


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"mode": "product"}, ["field mode", "'product'", "'grid' or 'zip'"]),
        ({"replicate": 3}, ["field replicate", "unknown field", "replicates"]),
        ({"overrides": {"p.a": {"start": 1, "stop": 2}}}, ['overrides."p.a"', "missing ['num']"]),
        ({"overrides": {"p.a": {"start": 1, "stop": 2, "nun": 3}}}, ['overrides."p.a".nun', "num"]),
        ({"overrides": {"p.a": 5}}, ['overrides."p.a"', "(got 5)", "list of values"]),
        ({"overrides": {"p.c": [1]}}, ["'p.c'", "not a field of the base config", "['a', 'b']"]),
        ({"overrides": {"p.a": {"start": 0, "stop": 1, "num": 3, "scale": "log"}}}, ["start > 0"]),
        ({"mode": "zip", "overrides": {"p.a": [1, 2], "p.b": [1]}}, ["same number", "'p.b': 1"]),
        ({"runner": "sweep_helpers.sleep_runner"}, ["field runner", "'package.module:function'"]),
        ({"seeds": [1, 2], "replicates": 2}, ["either 'seeds' or 'replicates'"]),
        ({"replicates": 0}, ["field replicates", "(got 0)", "greater than or equal to 1"]),
    ],
)
def test_bad_sweep_files_name_field_value_and_fix(tmp_path, change, expected):
    with pytest.raises(SweepFileError) as info:
        make_spec(tmp_path, **change)
    for text in expected:
        assert text in str(info.value)


def test_missing_base_file_is_reported(tmp_path):
    sweep_file = tmp_path / "s.toml"
    sweep_file.write_text('base = "nope.toml"\n')
    with pytest.raises(SweepFileError, match="field 'base'.*nope.toml.*not found"):
        load_sweep(sweep_file)


def test_repeated_point_is_an_error(tmp_path):
    with pytest.raises(SweepFileError, match="identical.*p.a=1.0"):
        make_spec(tmp_path, overrides={"p.a": [1, 1.0]})


@pytest.mark.parametrize("mode", ["grid", "zip"])
def test_sweep_without_overrides_is_just_replicates(tmp_path, mode):
    spec = make_spec(tmp_path, mode=mode, overrides={}, replicates=3)
    assert [(p.overrides, p.seed) for p in spec.points()] == [({}, 0), ({}, 1), ({}, 2)]


# ---------------------------------------------------------------------------------------
# Catalog


def test_catalog_status_lifecycle_and_csv(tmp_path):
    points = make_spec(tmp_path).points()
    with Catalog.in_dir(tmp_path) as catalog:
        assert catalog._conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        assert catalog.register(points) == 8
        assert catalog.register(points[:3]) == 0
        first, second = points[0].point_id, points[1].point_id
        catalog.mark_started(first, "w1", "t0")
        catalog.mark_started(second, "w2", "t0")
        catalog.mark_finished(first, "done", summary={"x": 1.5}, wall_time=2.0)
        assert catalog.counts() == {"pending": 6, "running": 1, "done": 1, "failed": 0}
        assert catalog.reset_running() == 1
        catalog.mark_finished(second, "failed", error="boom")
        catalog.requeue([first, second])
        assert catalog.statuses()[first] == "done" and catalog.statuses()[second] == "pending"
        with pytest.raises(ValueError):
            catalog.mark_finished(first, "running")
        rows = catalog.rows()
    stream = io.StringIO()
    export_csv(rows, stream)
    table = list(csv.DictReader(io.StringIO(stream.getvalue())))
    assert len(table) == 8
    assert table[0]["x"] == "1.5" and table[0]["status"] == "done" and table[0]["attempts"] == "1"
    assert table[1]["error"] == "boom" and table[1]["x"] == ""
    assert {"p.a", "p.b", "run.seed", "wall_time", "rundir"} <= set(table[0])


# ---------------------------------------------------------------------------------------
# One point without a cluster


def test_run_point_records_summary_or_traceback(tmp_path):
    def task(a: float, runner: str) -> PointTask:
        config = helpers.base_config(tmp_path, fail_a=2)
        config["p"]["a"] = a
        return PointTask(
            point_id=f"id{a}", params={"p.a": a}, config=config,
            rundir=str(tmp_path / f"run{a}"), runner=f"sweep_helpers:{runner}",
            analyses=("sweep_helpers:product", "sweep_helpers:total"), topic="unused",
        )

    ok = run_point(task(3, "failing_runner"))
    assert ok["status"] == "done" and ok["error"] is None
    assert ok["summary"] == {"ab_plus_seed": 3.0, "a_plus_b": 4.0}
    bad = run_point(task(2, "failing_runner"))
    assert bad["status"] == "failed" and "deliberate failure at a=2" in bad["error"]
    assert "Traceback" in bad["error"]


# ---------------------------------------------------------------------------------------
# Sweeps on a cluster


def test_sweep_finishes_all_points_and_rerun_recomputes_nothing(tmp_path, scheduler):
    sweepdir = tmp_path / "sweep"
    result = run_sweep(make_spec(tmp_path), sweepdir, scheduler=scheduler, console=quiet())
    assert result.ok and result.counts["done"] == 8 and result.skipped == 0
    rows = rows_by_params(sweepdir)
    assert len(rows) == 8
    for (a, b, seed), row in rows.items():
        assert row.status == "done" and row.error is None
        assert row.summary == {"ab_plus_seed": a * b + seed}
        assert row.wall_time > 0 and row.attempts == 1 and row.worker.startswith("tcp://")
        assert (sweepdir / row.rundir / helpers.RESULT_FILE).is_file()
    assert len(helpers.runner_calls(tmp_path)) == 8
    recorded = load_sweep(sweepdir / "sweep.toml")
    assert {p.point_id for p in recorded.points()} == {r.point_id for r in rows.values()}

    reordered = make_spec(tmp_path, overrides={"p.b": [2, 1], "p.a": [2.0, 1.0]})
    again = run_sweep(reordered, sweepdir, scheduler=scheduler, console=quiet())
    assert again.ok and again.skipped == 8
    assert len(helpers.runner_calls(tmp_path)) == 8, "a second invocation must not rerun points"


def test_failing_point_is_recorded_while_others_finish(tmp_path, scheduler):
    sweepdir = tmp_path / "sweep"
    spec = make_spec(tmp_path, runner="failing_runner", test={"fail_a": 2})
    output = quiet()
    result = run_sweep(spec, sweepdir, scheduler=scheduler, console=output)
    assert not result.ok and result.counts == {"pending": 0, "running": 0, "done": 4, "failed": 4}
    for (a, _, _), row in rows_by_params(sweepdir).items():
        if a == 2:
            assert row.status == "failed" and "RuntimeError: deliberate failure at a=2" in row.error
            assert row.summary == {}
        else:
            assert row.status == "done" and row.error is None
    assert "of sweep 'tiny'" in output.file.getvalue()
    assert "failed: RuntimeError: deliberate failure at a=2" in output.file.getvalue()

    rerun = run_sweep(spec, sweepdir, scheduler=scheduler, console=quiet())
    assert rerun.skipped == 4 and rerun.counts["failed"] == 4
    calls = helpers.runner_calls(tmp_path)
    assert len(calls) == 12, "only the 4 failed points run again"
    assert all(c["a"] == 2 for c in calls[8:])


def test_sweeps_run_together_share_the_workers(tmp_path, scheduler):
    """The first sweep's only point waits for a file that only the second sweep's point
    creates: run one sweep after the other, it would wait out its 60 s and log its call
    first; run together, the second sweep's point takes the idle worker and opens the gate."""
    gate = tmp_path / "gate"
    waiting = make_spec(tmp_path, runner="gated_runner", test={"gate": str(gate)},
                        overrides={"p.a": [2]}, replicates=1)
    opening = make_spec(tmp_path, runner="gate_opening_runner", test={"opens": str(gate)},
                        name="opening", overrides={"p.a": [1]}, replicates=1)
    results = run_sweeps_together([(waiting, tmp_path / "waiting"),
                                   (opening, tmp_path / "opening")],
                                  scheduler=scheduler, console=quiet())
    assert [r.ok for r in results] == [True, True]
    assert [r.sweepdir.name for r in results] == ["waiting", "opening"]
    assert [c["a"] for c in helpers.runner_calls(tmp_path)] == [1, 2]
    for name, a in (("waiting", 2), ("opening", 1)):
        with Catalog.in_dir(tmp_path / name) as catalog:
            (row,) = catalog.rows()
        assert row.params["p.a"] == a and row.status == "done"


def test_sweeps_run_together_need_their_own_directories(tmp_path):
    spec = make_spec(tmp_path)
    with pytest.raises(SweepError, match="give each its own sweep directory"):
        run_sweeps_together([(spec, tmp_path / "s"), (spec, tmp_path / "x" / ".." / "s")])
    assert not (tmp_path / "s").exists(), "nothing may be written before the check"


def test_killed_worker_does_not_lose_the_sweep(tmp_path, scheduler):
    sweepdir = tmp_path / "sweep"
    marker = tmp_path / "killed"
    spec = make_spec(tmp_path, runner="killing_runner", test={"kill_a": 2, "kill_marker": str(marker)})
    output = Console(file=io.StringIO(), force_terminal=True, width=120)
    result = run_sweep(spec, sweepdir, scheduler=scheduler, progress="rich", console=output)
    assert marker.exists(), "the runner should have killed one worker"
    assert result.ok and result.counts["done"] == 8
    calls = helpers.runner_calls(tmp_path)
    killed = tuple(json.loads(marker.read_text()))
    assert killed[0] == 2
    assert sum((c["a"], c["b"], c["seed"]) == killed for c in calls) == 2
    assert len(calls) == 9
    rows = rows_by_params(sweepdir)
    assert rows[killed].attempts >= 2
    assert rows[killed].summary == {"ab_plus_seed": killed[0] * killed[1] + killed[2]}
    assert "8/8" in output.file.getvalue()


def test_progress_none_prints_no_status_lines(tmp_path, scheduler):
    """``progress="none"`` (what a study passes on for a silent run) prints no status lines,
    while the plain display of the same sweep does."""
    output = Console(file=io.StringIO(), force_terminal=False, width=120)
    result = run_sweep(make_spec(tmp_path), tmp_path / "quiet", scheduler=scheduler,
                       progress="none", console=output)
    assert result.ok and result.counts["done"] == 8
    assert "pending" not in output.file.getvalue() and "ETA" not in output.file.getvalue()
    plain = Console(file=io.StringIO(), force_terminal=False, width=120)
    run_sweep(make_spec(tmp_path), tmp_path / "plain", scheduler=scheduler, progress="plain",
              console=plain)
    assert "8/8 done" in plain.file.getvalue() and "ETA" in plain.file.getvalue()


def test_failed_analysis_is_redone_without_rerunning_the_simulation(tmp_path, scheduler):
    sweepdir = tmp_path / "sweep"
    spec = make_spec(tmp_path, analyses=["sweep_helpers:flaky_analysis"])
    first = run_sweep(spec, sweepdir, scheduler=scheduler, console=quiet())
    assert first.counts["failed"] == 8
    assert all("deliberate analysis failure" in r.error for r in rows_by_params(sweepdir).values())
    second = run_sweep(spec, sweepdir, scheduler=scheduler, console=quiet())
    assert second.ok
    assert all(r.summary == {"ok": 1.0} for r in rows_by_params(sweepdir).values())
    assert len(helpers.runner_calls(tmp_path)) == 8


def test_busy_sweep_directory_and_unknown_runner_are_refused(tmp_path):
    sweepdir = tmp_path / "sweep"
    sweepdir.mkdir()
    with _exclusive(sweepdir), pytest.raises(SweepError, match="another 'grainflow sweep'"):
        run_sweep(make_spec(tmp_path), sweepdir, scheduler="tcp://127.0.0.1:1", console=quiet())
    spec = make_spec(tmp_path, runner="no_such_runner")
    with pytest.raises(SweepError, match="no function 'no_such_runner'"):
        run_sweep(spec, sweepdir, console=quiet())


# ---------------------------------------------------------------------------------------
# Command line


def write_sweep_file(tmp_path: Path, sleep: float, runner: str = "sleep_runner",
                     **test: Any) -> Path:
    path = tmp_path / "tiny.toml"
    data = {
        "base": helpers.base_config(tmp_path, sleep=sleep, **test),
        "overrides": {"p.a": [1, 2, 3, 4], "p.b": [1.0, 2.0]},
        "runner": f"sweep_helpers:{runner}",
        "analyses": ["sweep_helpers:product"],
    }
    path.write_text(tomli_w.dumps(data))
    return path


def wait_for(condition, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError("condition not reached")
        time.sleep(0.1)


def alive(process: psutil.Process) -> bool:
    try:
        return process.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def test_ctrl_c_leaves_a_consistent_catalog_and_the_sweep_resumes(tmp_path, scheduler):
    # the six points with p.a >= 2 wait for the gate, so the interrupt always finds the sweep
    # unfinished (with plain sleeps a loaded machine's polling once saw the second point done
    # only as the last one finished)
    gate = tmp_path / "gate"
    sweep_file = write_sweep_file(tmp_path, sleep=0.2, runner="gated_runner", gate=str(gate))
    sweepdir = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS_DIR), os.environ.get("PYTHONPATH", "")])}
    command = [sys.executable, "-m", "grainflow.sweep", "sweep", str(sweep_file), "-o", str(sweepdir),
               "-n", "2", "--progress", "plain", "--progress-interval", "0.5"]
    # started with SIGINT ignored, as a shell script's background job is: Ctrl-C must still
    # interrupt the sweep (grainflow.interrupt.install), not leave it running to the end
    proc = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        catalog_file = sweepdir / "catalog.sqlite"

        def some_done() -> bool:
            if not catalog_file.exists():
                return False
            with Catalog(catalog_file) as catalog:
                return catalog.counts()["done"] >= 2

        wait_for(some_done, timeout=40)
        children = psutil.Process(proc.pid).children(recursive=True)
        assert children, "the local cluster's workers should be child processes"
        proc.send_signal(signal.SIGINT)
        output, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, output
    assert "set back to pending" in output
    wait_for(lambda: not any(alive(c) for c in children), timeout=10)

    with Catalog(catalog_file) as catalog:
        counts = catalog.counts()
        rows = catalog.rows()
    assert counts["running"] == 0 and counts["failed"] == 0 and counts["done"] < 8
    done_before = {(r.params["p.a"], r.params["p.b"]) for r in rows if r.status == "done"}
    assert all(r.summary for r in rows if r.status == "done")

    gate.touch()

    result = CliRunner().invoke(
        sweep_app, ["sweep", str(sweep_file), "-o", str(sweepdir), "--scheduler", scheduler]
    )
    assert result.exit_code == 0, result.output
    assert f"{len(done_before)} already done" in result.output
    with Catalog(catalog_file) as catalog:
        assert catalog.counts()["done"] == 8
    calls = [(c["a"], c["b"]) for c in helpers.runner_calls(tmp_path)]
    assert all(calls.count(p) == 1 for p in done_before), "finished points must not run again"


def test_sweep_status_prints_and_exports(tmp_path, scheduler):
    sweepdir = tmp_path / "sweep"
    spec = make_spec(tmp_path, runner="failing_runner", test={"fail_a": 1})
    run_sweep(spec, sweepdir, scheduler=scheduler, console=quiet())
    cli = CliRunner()

    shown = cli.invoke(sweep_app, ["sweep-status", str(sweepdir)], env={"COLUMNS": "200"})
    assert shown.exit_code == 0, shown.output
    assert "4 done" in shown.output and "4 failed" in shown.output and "ab_plus_seed" in shown.output

    failed = cli.invoke(sweep_app, ["sweep-status", str(sweepdir), "--status", "failed", "--csv", "-"])
    table = list(csv.DictReader(io.StringIO(failed.output)))
    assert len(table) == 4 and {r["p.a"] for r in table} == {"1"}
    assert all("deliberate failure" in r["error"] for r in table)

    out = tmp_path / "all.csv"
    exported = cli.invoke(sweep_app, ["sweep-status", str(sweepdir), "--csv", str(out)])
    assert exported.exit_code == 0
    table = list(csv.DictReader(out.open()))
    assert len(table) == 8
    assert sorted(float(r["ab_plus_seed"]) for r in table if r["status"] == "done") == [2, 3, 4, 5]

    missing = cli.invoke(sweep_app, ["sweep-status", str(tmp_path / "nothing")])
    assert missing.exit_code == 2 and "has no catalog.sqlite" in missing.output


def test_sweep_command_reports_bad_files(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('mode = "grdi"\n[base]\nx = 1\n')
    result = CliRunner().invoke(sweep_app, ["sweep", str(bad)])
    assert result.exit_code == 2
    assert "field mode" in result.output and "'grdi'" in result.output


# ---------------------------------------------------------------------------------------
# Documentation and example


def toml_blocks(markdown: str) -> list[str]:
    blocks = markdown.split("```toml\n")[1:]
    return [b.split("```", 1)[0] for b in blocks]


def test_inline_base_example_of_the_docs_is_valid():
    docs = (TESTS_DIR.parent / "docs" / "sweeps.md").read_text()
    inline = [b for b in toml_blocks(docs) if "[base.run]" in b]
    assert len(inline) == 1
    spec = parse_sweep(tomllib.loads(inline[0]))
    assert sorted(p.overrides["geometry.orifice_width"] for p in spec.points()) == [3, 3, 4, 4, 5, 5]


def test_example_sweep_file_is_valid(tmp_path):
    example = TESTS_DIR.parent / "examples" / "sweep_tiny.toml"
    data = tomllib.loads(example.read_text())
    if not (example.parent / data["base"]).exists():  # the base config is written separately
        data["base"] = {"run": {"seed": 0}, "geometry": {"orifice_width": 4.0}}
    spec = parse_sweep(data, source=example)
    assert len(spec.points()) == 6 and spec.runner == "grainflow.runner:run_config"


def test_worker_threads_cap_a_runs_threads_on_a_local_cluster(tmp_path, monkeypatch):
    """Local workers run each point with numba's thread cap at ``worker_threads`` (1 by
    default: every run on one thread), numpy's libraries at one thread either way, and
    without dask's 64 KB ``MALLOC_TRIM_THRESHOLD_`` (even where an earlier dask nanny of
    this process left it in the environment); a cap below one is refused before any worker
    starts."""
    import dask

    dask_trim = dask.config.get("distributed.nanny.pre-spawn-environ")["MALLOC_TRIM_THRESHOLD_"]
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", str(dask_trim))  # as a nanny leaves it
    for threads in (1, 2):
        log = tmp_path / f"threads{threads}.log"
        spec = make_spec(tmp_path, runner="threads_runner", test={"threads_log": str(log)},
                         replicates=1)
        extra = {} if threads == 1 else {"worker_threads": threads}
        result = run_sweep(spec, tmp_path / f"sweep{threads}", n_workers=1, progress="none",
                           console=quiet(), **extra)
        assert result.ok
        seen = [json.loads(line) for line in log.read_text().splitlines()]
        assert len(seen) == 4
        assert all(s == {"numba": threads, "omp": "1", "trim": None} for s in seen), seen
        assert os.environ["MALLOC_TRIM_THRESHOLD_"] == str(dask_trim)  # the caller's, back
    with pytest.raises(ValueError, match="worker_threads"):
        run_sweep(make_spec(tmp_path), tmp_path / "sweep0", n_workers=1, worker_threads=0,
                  console=quiet())
    assert not (tmp_path / "sweep0").exists()


SCRIPT_IMPORTING_NUMBA = '''
import os, sys
import numba  # at the top, as a user's script does: spawned workers import it again
import numpy as np
from pathlib import Path
from grainflow.sweep import parse_sweep, run_sweep


@numba.njit(parallel=True)
def total(x):
    s = 0.0
    for i in numba.prange(x.size):
        s += x[i]
    return s


def main():
    before = os.environ.get("NUMBA_NUM_THREADS")
    total(np.ones(10))  # this process's thread pool runs before the sweep
    spec = parse_sweep({"name": "s", "mode": "grid", "base": {
        "scenario": "jet2d", "dim": 2, "run": {"duration": 0.5, "seed": 0},
        "output": {"frames_every": 0, "checkpoint_every": 0},
        "jet": {"jet_diameter": 4.0, "target_diameter": 8.0, "n": 60, "phi_tilde": 0.9}},
        "overrides": {"jet.phi_tilde": [0.5, 0.9]}})
    result = run_sweep(spec, Path(sys.argv[1]), n_workers=2, progress="none")
    numba.njit(lambda x: x + 1)(1)  # and compiles after it
    print("done", result.counts["done"], "environment kept",
          os.environ.get("NUMBA_NUM_THREADS") == before)


if __name__ == "__main__":
    main()
'''


def test_sweep_from_a_script_that_imports_numba_at_the_top(tmp_path):
    """A script importing numba at the top runs its sweep on a local cluster: the workers'
    one-thread environment is set before they are spawned (they import the script again
    first; set after, numba refused every compilation and every point failed), and the
    script's own environment and numba are as before once the sweep ends."""
    import subprocess
    import sys

    script = tmp_path / "script.py"
    script.write_text(SCRIPT_IMPORTING_NUMBA)
    src = Path(__file__).resolve().parents[1] / "src"
    env = {**os.environ, "PYTHONPATH": str(src), "PYTHONWARNINGS": "ignore"}
    env.pop("NUMBA_NUM_THREADS", None)
    out = subprocess.run([sys.executable, str(script), str(tmp_path / "sweep")], env=env,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "done 2 environment kept True" in out.stdout, out.stdout[-3000:]
