"""``python -m grainflow.sweep sweep SWEEP.toml`` / ``python -m grainflow.sweep sweep-status DIR``.

Ctrl-C and SIGTERM interrupt it as they do the ``grainflow`` program
(:func:`grainflow.interrupt.install`), also where the process was started with SIGINT
ignored (a background job of a shell script, a test runner's worker): the sweep then sets
its running points back to pending and exits 130."""

from grainflow import interrupt
from grainflow.sweep.cli import sweep_app

if __name__ == "__main__":  # dask's spawned worker processes import this module too
    interrupt.install()
    sweep_app(prog_name="python -m grainflow.sweep")
