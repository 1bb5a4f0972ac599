"""The ``grainflow`` command: verbs, --help, --version, --threads, exit codes, overwrite."""

from __future__ import annotations

import copy
import subprocess
import sys
from pathlib import Path
from typing import Any

import numba
import pytest
import tomli_w
from typer.testing import CliRunner

from conftest import SIX_DISKS
from grainflow import __version__
from grainflow.cli import app

VERBS = ["run", "resume", "info", "export", "view", "demo", "bench", "study", "sweep",
         "sweep-status", "docs"]

#: Six disks colliding in a periodic 2D box; 300 steps.
TINY: dict[str, Any] = {
    **SIX_DISKS, "output": {"thermo_every": 50, "frames_every": 100, "checkpoint_every": 100}}


@pytest.fixture(autouse=True)
def restore_threads():
    """``--threads`` changes numba's thread count for the whole process; put it back."""
    before = numba.get_num_threads()
    yield
    numba.set_num_threads(before)


def invoke(*args: str):
    """Run the command in-process with one numba thread (the test machine is shared)."""
    return CliRunner().invoke(app, ["--threads", "1", *args])


def config_file(tmp_path: Path, config: dict[str, Any] = TINY, name: str = "tiny.toml") -> Path:
    path = tmp_path / name
    path.write_text(tomli_w.dumps(config))
    return path


def one_line_error(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    return lines[0]


def test_version() -> None:
    result = invoke("--version")
    assert result.exit_code == 0 and result.stdout.strip() == f"grainflow {__version__}"


def test_python_dash_m_runs_the_same_command() -> None:
    out = subprocess.run([sys.executable, "-m", "grainflow", "--version"],
                         capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == f"grainflow {__version__}"


@pytest.mark.parametrize("verb", [None, *VERBS])
def test_help_on_every_verb(verb: str | None) -> None:
    result = CliRunner().invoke(app, ["--help"] if verb is None else [verb, "--help"])
    assert result.exit_code == 0, result.output
    assert "Usage:" in result.stdout
    if verb is None:
        for name in VERBS:
            assert name in result.stdout
        assert "--threads" in result.stdout and "--version" in result.stdout


def test_run_info_export_resume(tmp_path: Path) -> None:
    rundir = tmp_path / "run"
    result = invoke("run", str(config_file(tmp_path)), "-o", str(rundir), "--progress", "plain")
    assert result.exit_code == 0, result.stderr
    assert "finished: 300 steps" in result.stdout
    assert numba.get_num_threads() == 1

    info = invoke("info", str(rundir))
    assert info.exit_code == 0
    assert "finished at step 300 of 300" in info.stdout
    assert "4 in frames.h5" in info.stdout and "step 300" in info.stdout

    dump = invoke("export", str(rundir), "--format", "dump")
    assert dump.exit_code == 0 and (rundir / "frames.dump").is_file()
    vtk = invoke("export", str(rundir), "--format", "vtk", "-o", str(tmp_path / "vtk"))
    assert vtk.exit_code == 0 and (tmp_path / "vtk" / "frame.pvd").is_file()

    again = invoke("resume", str(rundir))  # a finished run resumes to its end at once
    assert again.exit_code == 0, again.stderr


def test_existing_run_directory_needs_overwrite(tmp_path: Path) -> None:
    config = config_file(tmp_path)
    rundir = tmp_path / "run"
    assert invoke("run", str(config), "-o", str(rundir)).exit_code == 0
    refused = invoke("run", str(config), "-o", str(rundir))
    assert refused.exit_code == 2
    assert "--overwrite" in one_line_error(refused)
    replaced = invoke("run", str(config), "-o", str(rundir), "--overwrite")
    assert replaced.exit_code == 0, replaced.stderr


def test_default_run_directory_is_the_config_name(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    config = copy.deepcopy(TINY)
    config["run"]["steps"] = 10
    assert invoke("run", str(config_file(tmp_path, config, "short.toml"))).exit_code == 0
    assert (tmp_path / "short" / "summary.json").is_file()


BAD = [
    # (arguments, exit code, text in the one-line error); {cfg}: a valid config file,
    # {bad}: one with a negative radius, {dir}: an empty directory
    (["run", "{bad}", "-o", "{dir}/out"], 2, "particles[0].radius[0]: -0.5 is not valid"),
    (["run", "{dir}/missing.toml"], 2, "no such file"),
    (["resume", "{dir}"], 2, "no config.toml"),
    (["info", "{dir}"], 2, "no config.toml"),
    (["export", "{dir}", "--format", "csv"], 2, "--format: 'csv' is not valid"),
    (["run", "{cfg}", "-o", "{dir}/out", "--threads", "999"], 2, "threads: 999 is not valid"),
    (["run", "{cfg}", "-o", "{dir}/out", "--threads", "0"], 2, "--threads: 0 is not valid"),
    (["study", "jets", "-o", "{dir}/s"], 2, "study: 'jets' is not known"),
    (["study", "hopper", "-o", "{dir}/s", "--convention", "paper"], 2,
     "--convention: 'paper' is not valid"),
    (["study", "stream", "-o", "{dir}/s", "--progress", "loud"], 2,
     "--progress: 'loud' is not valid"),
    (["view", "{dir}"], 2, "no frames.h5 in this run directory"),
]


@pytest.mark.parametrize(("args", "code", "text"), BAD, ids=[b[2][:30] for b in BAD])
def test_failures_exit_non_zero_with_one_line(tmp_path: Path, args: list[str], code: int,
                                              text: str) -> None:
    bad = copy.deepcopy(TINY)
    bad["particles"][0]["radius"] = -0.5
    paths = {"cfg": str(config_file(tmp_path)), "bad": str(config_file(tmp_path, bad, "bad.toml")),
             "dir": str(tmp_path / "empty")}
    (tmp_path / "empty").mkdir()
    result = invoke(*[a.format(**paths) for a in args])
    assert result.exit_code == code
    assert text in one_line_error(result)


@pytest.mark.filterwarnings("ignore:dt = .* is past the stability limit")
def test_unstable_run_exits_1(tmp_path: Path) -> None:
    config = copy.deepcopy(TINY)
    config["run"].update(dt=0.5, allow_unsafe_dt=True, check_every=1)
    result = invoke("run", str(config_file(tmp_path, config)), "-o", str(tmp_path / "run"))
    assert result.exit_code == 1
    warning, error = result.stderr.strip().splitlines()  # the dt warning: one line too
    assert warning.startswith("warning: dt: 0.5 exceeds the stability limit")
    assert error.startswith("error: unstable at step")


def test_threads_out_of_range_is_a_usage_error() -> None:
    result = CliRunner().invoke(app, ["--threads", "0", "info", "."])
    assert result.exit_code == 2


def test_demo_verb_calls_the_hopper_demo(tmp_path: Path, monkeypatch) -> None:
    import grainflow.studies.hopper_demo as hopper_demo

    calls = []
    monkeypatch.setattr(hopper_demo, "demo", lambda out, **kw: calls.append((out, kw)))
    result = invoke("demo", "-o", str(tmp_path / "demo"))
    assert result.exit_code == 0, result.output
    assert calls == [(tmp_path / "demo", {"threads": 1, "progress": "auto"})]
    result = CliRunner().invoke(app, ["demo", "-o", str(tmp_path / "d2"), "--threads", "auto",
                                      "--progress", "plain"])
    assert result.exit_code == 0, result.output
    assert calls[-1] == (tmp_path / "d2", {"threads": "auto", "progress": "plain"})


@pytest.mark.parametrize("value", ["two", "0", "-1", "1.5", "99999"])
def test_bad_threads_is_a_usage_error(value: str) -> None:
    result = CliRunner().invoke(app, ["--threads", value, "info", "."])
    assert result.exit_code == 2
    assert "threads:" in result.output and "expected 'auto' or a count" in result.output
