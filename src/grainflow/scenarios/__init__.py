"""Scenarios: ready-made studies, each selected by the ``scenario`` key of a run config.

A scenario is a builder ``build(config) -> Simulation`` plus, optionally, its own config
section (a pydantic model validated from the TOML table named ``section``). Register one with
:func:`register`; scenario modules outside this file register themselves when imported, and
:func:`get_scenario` imports the known ones (:data:`PLUGINS`) on first use::

    # grainflow/scenarios/hopper.py
    from grainflow.scenarios import Scenario, register

    class HopperSection(BaseModel): ...

    def build_hopper2d(config): ...      # config.section is the validated HopperSection

    register(Scenario("hopper2d", "grainflow.scenarios.hopper:build_hopper2d",
                      section="hopper", model=HopperSection,
                      uses=frozenset({"contact", "drag", "gravity"})))

Builders are named by import path (``"module:function"``) so that this registry, which the
config schema reads, does not import the engine. Nor does it import :mod:`grainflow.config`,
which sits above it (config reads this registry, scenario modules register into it).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable

if TYPE_CHECKING:
    from pydantic import BaseModel

    from grainflow.engine.simulation import Simulation

#: Top-level config sections every scenario accepts.
COMMON_SECTIONS = frozenset({"scenario", "dim", "run", "output"})

#: Modules that register further scenarios when imported (absent ones are skipped).
PLUGINS = ("grainflow.scenarios.hopper", "grainflow.scenarios.stream", "grainflow.scenarios.jet")


@dataclass(frozen=True)
class Scenario:
    """One entry of :data:`SCENARIOS`.

    ``builder``: ``"module:function"`` of ``build(config: RunConfig) -> Simulation``
    (:class:`grainflow.config.schema.RunConfig`, not imported here: config sits above).
    ``section``/``model``: the name of the scenario's own TOML table and the pydantic model
    that validates it (a class, or ``"module:Class"``); ``config.section`` holds the result. ``uses``: the optional generic
    sections (``box``, ``particles``, ``contact``, ``walls``, ``gravity``, ``drag``,
    ``tethers``, ``insert``, ``delete``) the builder reads; any other one in a config is
    refused so that nothing a user writes is silently ignored. ``run_defaults``: ``[run]``
    settings the scenario's study uses unless the config sets them (e.g. seed 002's
    Adams-Bashforth integrator), applied before validation so the saved config shows them.
    ``run_elsewhere``: ``[run]`` fields the builder does not read, each with where the
    setting comes from instead (e.g. the hopper's time-step fraction is
    ``hopper.dt_fraction``); a config that sets one is refused with that text, and the
    saved config leaves them out.
    """

    name: str
    builder: str
    section: str | None = None
    model: "type[BaseModel] | str | None" = None
    uses: frozenset[str] = field(default_factory=frozenset)
    description: str = ""
    run_defaults: dict[str, Any] = field(default_factory=dict)
    run_elsewhere: dict[str, str] = field(default_factory=dict)

    def build(self, config: Any) -> "Simulation":
        """Import the builder and build the simulation."""
        fn: Callable[[Any], Simulation] = _resolve(self.builder)
        return fn(config)

    def section_model(self) -> "type[BaseModel] | None":
        """The pydantic model of the scenario's section (imported if given by name)."""
        return _resolve(self.model) if isinstance(self.model, str) else self.model


def _resolve(ref: str) -> Any:
    module, _, name = ref.partition(":")
    return getattr(importlib.import_module(module), name)


#: Every registered scenario by name.
SCENARIOS: dict[str, Scenario] = {}
_plugins_loaded = False


def register(scenario: Scenario) -> Scenario:
    """Add ``scenario`` to :data:`SCENARIOS` (replacing one of the same name)."""
    if scenario.section is not None and scenario.model is None:
        raise ValueError(f"scenario {scenario.name!r}: a section needs a model to validate it")
    if scenario.section in COMMON_SECTIONS:
        raise ValueError(f"scenario {scenario.name!r}: section name {scenario.section!r} is reserved")
    SCENARIOS[scenario.name] = scenario
    return scenario


def get_scenario(name: str) -> Scenario:
    """The scenario called ``name``; ValueError listing the known ones otherwise."""
    _load_plugins()
    if name not in SCENARIOS:
        raise ValueError(f"scenario: {name!r} is not known; use one of {sorted(SCENARIOS)}")
    return SCENARIOS[name]


def _load_plugins() -> None:
    global _plugins_loaded
    if _plugins_loaded:
        return
    _plugins_loaded = True
    for module in PLUGINS:
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as err:
            if err.name != module:  # the plug-in exists but something it needs is missing
                raise


_GENERIC_SECTIONS = frozenset({"box", "particles", "contact", "walls", "gravity", "drag",
                               "drag_rate", "tethers", "insert", "delete"})

register(Scenario(
    "generic", "grainflow.config.build:build_generic", uses=_GENERIC_SECTIONS,
    description="particles from fills or a LAMMPS data file, walls, laws per type pair, "
                "gravity, drag, updaters"))
register(Scenario(
    "chute", "grainflow.config.build:build_chute", section="chute",
    model="grainflow.config.schema:ChuteSection",
    description="LAMMPS's granular chute benchmark (reads data.chute)"))
