"""The registry of contact sub-models and law presets.

One row per sub-model: ``(slot, name) -> "module:Class"``. A new sub-model is one file in
this package plus one row here; the configuration schema (:mod:`grainflow.config.contact`)
and the reference tables of docs/config.md are generated from this table, and the engine
never names a sub-model.
"""

from __future__ import annotations

import importlib
from functools import cache

from grainflow.models.submodel import SLOTS, Preset, SubModel

#: (slot, name) -> "module:Class", in the order the reference lists them.
SUBMODELS: dict[tuple[str, str], str] = {
    ("normal", "hooke"): "grainflow.models.normal_hooke:Hooke",
    ("normal", "hertz"): "grainflow.models.normal_hertz:Hertz",
    ("normal", "harmonic"): "grainflow.models.normal_harmonic:Harmonic",
    ("damping", "none"): "grainflow.models.none:NoDamping",
    ("damping", "viscous"): "grainflow.models.damping_viscous:Viscous",
    ("damping", "kinetic"): "grainflow.models.damping_kinetic:KineticFriction",
    ("tangential", "none"): "grainflow.models.none:NoTangential",
    ("tangential", "history"): "grainflow.models.tangential_history:TangentialHistory",
    ("cohesion", "none"): "grainflow.models.none:NoCohesion",
    ("cohesion", "constant"): "grainflow.models.cohesion_constant:ConstantCohesion",
}

#: Named compositions (``law = "granular"`` in config files, :class:`GranularLaw` ...).
PRESETS: dict[str, Preset] = {
    "granular": Preset("granular", "linear spring-dashpot with tangential history and "
                       "optional cohesion (SPEC M1 + M2)",
                       {"normal": "hooke", "damping": "viscous", "tangential": "history",
                        "cohesion": "constant"}),
    "soft": Preset("soft", "soft harmonic particles with kinetic friction (SPEC M3)",
                   {"normal": "harmonic", "damping": "kinetic", "tangential": "none",
                    "cohesion": "none"}),
}

#: The sub-model a slot gets when a composition does not name one.
DEFAULT = {"damping": "none", "tangential": "none", "cohesion": "none"}


@cache
def submodel(slot: str, name: str) -> type[SubModel]:
    """The sub-model class registered as ``(slot, name)``; ValueError listing the choices."""
    if slot not in SLOTS:
        raise ValueError(f"{slot!r} is not a slot; the slots are {', '.join(SLOTS)}")
    ref = SUBMODELS.get((slot, name))
    if ref is None:
        raise ValueError(f"{slot}: {name!r} is not valid; use one of "
                         f"{', '.join(repr(n) for s, n in SUBMODELS if s == slot)}")
    module, _, attr = ref.partition(":")
    cls = getattr(importlib.import_module(module), attr)
    if cls.slot != slot or cls.name != name:
        raise TypeError(f"registry row ({slot!r}, {name!r}) names {ref}, which declares "
                        f"({cls.slot!r}, {cls.name!r})")
    return cls


def names(slot: str) -> list[str]:
    """The registered sub-model names of ``slot``."""
    return [n for s, n in SUBMODELS if s == slot]


def composition(law: str | None = None, **models: str) -> dict[str, str]:
    """Slot -> sub-model name: the preset ``law`` (if any), then the given slots, then the
    defaults; ValueError for an unknown preset, slot or name, or a missing normal model."""
    if law is not None and law not in PRESETS:
        raise ValueError(f"law: {law!r} is not valid; use one of "
                         f"{', '.join(repr(p) for p in PRESETS)} or name the sub-models")
    chosen = dict(DEFAULT)
    if law is not None:
        chosen.update(PRESETS[law].models)
    for slot, name in models.items():
        if slot not in SLOTS:
            raise ValueError(f"{slot}: not a slot; the slots are {', '.join(SLOTS)}")
        if name is not None:
            chosen[slot] = name
    if "normal" not in chosen:
        raise ValueError("normal: missing; choose a preset (law = 'granular' or 'soft') or a "
                         f"normal model ({', '.join(repr(n) for n in names('normal'))})")
    for slot in SLOTS:
        submodel(slot, chosen[slot])
    return {slot: chosen[slot] for slot in SLOTS}
