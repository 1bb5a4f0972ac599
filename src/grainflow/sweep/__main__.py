"""``python -m grainflow.sweep sweep SWEEP.toml`` / ``python -m grainflow.sweep sweep-status DIR``."""

from grainflow.sweep.cli import sweep_app

if __name__ == "__main__":  # dask's spawned worker processes import this module too
    sweep_app(prog_name="python -m grainflow.sweep")
