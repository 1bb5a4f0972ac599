"""grainflow: Discrete Element Method simulation and analysis of granular flows.

>>> import grainflow as gf
>>> summary = gf.run_config("examples/pile3d.toml", "pile3d")   # doctest: +SKIP

The public names below are imported on first use, so ``import grainflow`` stays fast (no
numba, h5py, matplotlib or dask until they are needed).
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

#: Public name -> module that defines it.
_EXPORTS = {
    "ParticleState": "grainflow.state",
    "Simulation": "grainflow.engine.simulation",
    "InstabilityError": "grainflow.engine.simulation",
    "TimeStepError": "grainflow.engine.simulation",
    "Box": "grainflow.frame",
    "Frame": "grainflow.frame",
    "Contacts": "grainflow.frame",
    "GranularLaw": "grainflow.models.granular",
    "stiffness_and_damping": "grainflow.models.granular",
    "restitution_and_contact_time": "grainflow.models.granular",
    "SoftLaw": "grainflow.models.soft",
    "Gravity": "grainflow.engine.forces",
    "Drag": "grainflow.engine.forces",
    "WallForce": "grainflow.walls",
    "Tethers": "grainflow.engine.tethers",
    "VelocityVerlet": "grainflow.engine.integrators",
    "AdamsBashforth2": "grainflow.engine.integrators",
    "minimize_fire": "grainflow.engine.minimize",
    "load_config": "grainflow.config.schema",
    "ConfigError": "grainflow.config.schema",
    "RunConfig": "grainflow.config.schema",
    "build_simulation": "grainflow.config.build",
    "ThermoLog": "grainflow.io.thermo",
    "ContactLaw": "grainflow.models.base",
    "PairInteraction": "grainflow.engine.pair",
    "relax": "grainflow.engine.minimize",
    "run_config": "grainflow.runner",
    "resume_run": "grainflow.runner",
    "read_lammps_data": "grainflow.insertion.lammps_data",
    "state_from_lammps_data": "grainflow.insertion.lammps_data",
    "RunSummary": "grainflow.runner",
}

#: Subpackages reachable as attributes (``gf.walls.Plane``), also imported on first use.
_SUBPACKAGES = ("walls", "insertion", "analysis", "scenarios", "io", "plotting", "sweep")

__all__ = ["__version__", *_EXPORTS, *_SUBPACKAGES]


def __getattr__(name: str) -> Any:
    if name in _SUBPACKAGES:
        return importlib.import_module(f"grainflow.{name}")
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'grainflow' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
