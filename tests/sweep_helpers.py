"""Tiny point runners and analyses for tests/test_sweep.py.

They must be importable on dask workers: the workers of a LocalCluster started
from the test process inherit its ``sys.path`` (which holds ``tests/``).

The runners take their instructions from the ``[test]`` table of the config:
``log`` (a file each call appends a line to, counting runner calls across
processes), ``sleep`` (seconds), ``fail_a`` (value of ``p.a`` that raises),
``kill_a`` and ``kill_marker`` (value of ``p.a`` whose first call kills its
worker process; the marker file records (a, b, seed) of the killed call).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

RESULT_FILE = "result.json"


def base_config(tmp_path: Path, **test: Any) -> dict[str, Any]:
    """A base config for the helper runners; ``test`` entries go into its [test] table."""
    return {
        "run": {"seed": 0},
        "p": {"a": 1.0, "b": 1.0},
        "test": {"log": str(tmp_path / "calls.log"), "sleep": 0.05, **test},
    }


def runner_calls(tmp_path: Path) -> list[dict[str, Any]]:
    """The (a, b, seed) of every runner call so far."""
    log = tmp_path / "calls.log"
    if not log.exists():
        return []
    return [json.loads(line) for line in log.read_text().splitlines()]


def _log_call(config: dict[str, Any]) -> None:
    entry = {"a": config["p"]["a"], "b": config["p"]["b"], "seed": config["run"]["seed"]}
    with open(config["test"]["log"], "a") as log:  # one short append: atomic across processes
        log.write(json.dumps(entry) + "\n")


def sleep_runner(config: dict[str, Any], rundir: Path) -> None:
    """Sleep briefly, then write the point's parameters to result.json."""
    _log_call(config)
    time.sleep(config["test"]["sleep"])
    rundir.mkdir(parents=True)
    (rundir / RESULT_FILE).write_text(json.dumps(
        {"a": config["p"]["a"], "b": config["p"]["b"], "seed": config["run"]["seed"]}
    ))


def threads_runner(config: dict[str, Any], rundir: Path) -> None:
    """Like sleep_runner, and appends to test.threads_log the worker's thread caps: numba's
    (``NUMBA_NUM_THREADS`` as numba read it) and ``OMP_NUM_THREADS``, and its
    ``MALLOC_TRIM_THRESHOLD_``."""
    import numba

    with open(config["test"]["threads_log"], "a") as log:
        log.write(json.dumps({"numba": numba.config.NUMBA_NUM_THREADS,
                              "omp": os.environ.get("OMP_NUM_THREADS"),
                              "trim": os.environ.get("MALLOC_TRIM_THRESHOLD_")}) + "\n")
    sleep_runner(config, rundir)


def gated_runner(config: dict[str, Any], rundir: Path) -> None:
    """Like sleep_runner, but a point with p.a >= 2 first waits (up to 60 s) for the file
    test.gate to exist: the points with p.a = 1 finish, and the sweep cannot finish before
    the test creates the gate, however slowly the machine polls."""
    if config["p"]["a"] >= 2:
        gate = Path(config["test"]["gate"])
        deadline = time.monotonic() + 60.0
        while not gate.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
    sleep_runner(config, rundir)


def gate_opening_runner(config: dict[str, Any], rundir: Path) -> None:
    """Like sleep_runner, then creates the file test.opens (the gate a gated_runner waits
    for)."""
    sleep_runner(config, rundir)
    Path(config["test"]["opens"]).touch()


def failing_runner(config: dict[str, Any], rundir: Path) -> None:
    """Like sleep_runner, but raises for p.a == test.fail_a."""
    if config["p"]["a"] == config["test"]["fail_a"]:
        _log_call(config)
        raise RuntimeError(f"deliberate failure at a={config['p']['a']}")
    sleep_runner(config, rundir)


def killing_runner(config: dict[str, Any], rundir: Path) -> None:
    """Like sleep_runner, but the first call with p.a == test.kill_a kills its worker process
    after sleeping (a simulation that crashes part-way)."""
    if config["p"]["a"] == config["test"]["kill_a"] and _first_to_create(config):
        _log_call(config)
        time.sleep(config["test"]["sleep"])
        os._exit(1)
    sleep_runner(config, rundir)


def _first_to_create(config: dict[str, Any]) -> bool:
    """Atomically create the kill marker, holding (a, b, seed); False if it already exists."""
    try:
        fd = os.open(config["test"]["kill_marker"], os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return False
    with os.fdopen(fd, "w") as marker:
        marker.write(json.dumps([config["p"]["a"], config["p"]["b"], config["run"]["seed"]]))
    return True


def product(rundir: Path) -> dict[str, float]:
    """Analysis: a * b + seed, read back from the run directory."""
    r = json.loads((rundir / RESULT_FILE).read_text())
    return {"ab_plus_seed": r["a"] * r["b"] + r["seed"]}


def total(rundir: Path) -> dict[str, float]:
    """Analysis: a + b."""
    r = json.loads((rundir / RESULT_FILE).read_text())
    return {"a_plus_b": r["a"] + r["b"]}


def flaky_analysis(rundir: Path) -> dict[str, float]:
    """Analysis that fails the first time it sees a run directory, then works."""
    marker = rundir / "analysed_once"
    if not marker.exists():
        marker.write_text("")
        raise ValueError("deliberate analysis failure")
    return {"ok": 1.0}
