"""Parameter sweeps: many ordinary runs on dask.distributed, with a SQLite results catalog.

>>> from grainflow.sweep import load_sweep, run_sweep        # doctest: +SKIP
>>> result = run_sweep(load_sweep("q_vs_w.toml"), "q_vs_w")  # doctest: +SKIP

See ``docs/sweeps.md`` for the sweep file format and running on a cluster.
``run_sweep``, ``run_sweeps_together`` and their helpers import dask on first use.
"""

from typing import Any

from grainflow.sweep.catalog import Catalog, CatalogRow, export_csv
from grainflow.sweep.spec import Point, SweepFileError, SweepSpec, load_sweep, parse_sweep

_EXECUTE_NAMES = ("run_sweep", "run_sweeps_together", "run_point", "run_analyses",
                  "SweepResult", "SweepError")

__all__ = [
    "Catalog",
    "CatalogRow",
    "Point",
    "SweepFileError",
    "SweepSpec",
    "export_csv",
    "load_sweep",
    "parse_sweep",
    *_EXECUTE_NAMES,
]


def __getattr__(name: str) -> Any:
    """Import the dask-backed names lazily, so that ``import grainflow.sweep`` stays fast."""
    if name in _EXECUTE_NAMES:
        from grainflow.sweep import execute

        return getattr(execute, name)
    raise AttributeError(f"module 'grainflow.sweep' has no attribute {name!r}")
