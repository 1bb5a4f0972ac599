"""A script run through :func:`grainflow.interrupt.run` stops on SIGTERM (a batch scheduler's
stop) or Ctrl-C with exit 130 and one line, so that a sweep inside it sets its running points
back to pending and closes its workers (docs/sweeps.md), as the ``grainflow`` program does;
also when it was started with SIGINT ignored."""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest

SCRIPT = """
import os, signal, time
from grainflow import interrupt

def main():
    print("started", flush=True)
    os.kill(os.getpid(), signal.{name})
    time.sleep(30)
    print("not interrupted", flush=True)

interrupt.run(main)
"""


@pytest.mark.parametrize("name", ["SIGTERM", "SIGINT"])
def test_a_script_stops_on_the_signal_with_exit_130_and_no_traceback(name: str) -> None:
    proc = subprocess.run([sys.executable, "-c", SCRIPT.format(name=name)],
                          capture_output=True, text=True, timeout=60,
                          # started with SIGINT ignored, as a shell script's background job is
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    assert proc.returncode == 130, proc.stderr
    assert proc.stdout.strip() == "started"
    assert proc.stderr.strip() == "interrupted"
