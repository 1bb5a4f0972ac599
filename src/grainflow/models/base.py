"""The contact law: sub-models composed per slot, with a per-type-pair parameter table.

A :class:`ContactLaw` is one choice of sub-model per slot (:mod:`grainflow.models.submodel`:
normal, damping, tangential, cohesion), either a preset (``ContactLaw(law="granular")``,
:class:`~grainflow.models.granular.GranularLaw`) or named slot by slot
(``ContactLaw(normal="hertz", tangential="history")``). It holds

* ``table[type_i, type_j, :]``: the parameters of every type pair, the columns of the
  sub-models one after the other (:attr:`param_names`);
* the per-contact history layout (:attr:`history_size`, :attr:`flip`: which history
  numbers change sign when the roles of i and j swap);
* :attr:`evaluator`: the compiled function (:mod:`grainflow.models.compose`) that the pair
  loop and the wall loop call for particle pairs *and* particle-wall contacts.

The engine sees only this interface; a new sub-model never touches it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grainflow.models.compose import composed_evaluator
from grainflow.models.registry import composition, submodel
from grainflow.models.submodel import SLOTS, Param, SubModel


class ContactLaw:
    """A composed contact law with per-type-pair parameters.

    Parameters
    ----------
    n_types:
        Number of particle (and wall) types the table covers; it grows on demand.
    law:
        A preset (``"granular"``, ``"soft"``; :data:`grainflow.models.registry.PRESETS`).
    normal, damping, tangential, cohesion:
        Sub-model names per slot (:data:`grainflow.models.registry.SUBMODELS`); they
        override the preset's. Slots left open get ``"none"``.
    """

    def __init__(self, n_types: int = 1, *, law: str | None = None, normal: str | None = None,
                 damping: str | None = None, tangential: str | None = None,
                 cohesion: str | None = None) -> None:
        if n_types < 1:
            raise ValueError("n_types: must be >= 1")
        self.models = composition(law, normal=normal, damping=damping, tangential=tangential,
                                  cohesion=cohesion)
        self.parts: dict[str, type[SubModel]] = {s: submodel(s, self.models[s]) for s in SLOTS}
        self.params: tuple[Param, ...] = ()
        self.column_of: dict[str, int] = {}
        history_of: dict[str, int] = {}
        flip: list[float] = []
        for slot in SLOTS:
            part = self.parts[slot]
            self.column_of[slot] = len(self.params)
            history_of[slot] = len(flip)
            for p in part.columns():
                if any(q.name == p.name for q in self.params):
                    raise ValueError(f"{slot} {part.name!r}: parameter {p.name!r} is also a "
                                     "parameter of another slot's sub-model; these cannot be "
                                     "combined")
                self.params += (p,)
            flip += part.history_flip
        self._history_of = history_of
        self.history_size = len(flip)
        self.flip = np.asarray(flip, dtype=np.float64)
        self.table = np.zeros((n_types, n_types, len(self.params)))
        self._set_types: set[tuple[int, int]] = set()
        self._evaluator: Any = None
        self._reach: float | None = None  # cached; every write of the table resets it

    # ------------------------------------------------------------------ description
    @property
    def name(self) -> str:
        """The composition, e.g. ``"hooke/viscous/history/constant"``."""
        return "/".join(self.models[s] for s in SLOTS)

    @property
    def param_names(self) -> tuple[str, ...]:
        """The columns of :attr:`table`."""
        return tuple(p.name for p in self.params)

    @property
    def inputs(self) -> tuple[Param, ...]:
        """Every parameter a user may give: the columns and the config-only inputs."""
        return tuple(p for s in SLOTS for p in self.parts[s].params)

    @property
    def n_types(self) -> int:
        return int(self.table.shape[0])

    @property
    def cohesive(self) -> bool:
        """Whether some type pair attracts: the cohesion sub-model has a parameter that is
        not zero (``cohesion_force = 0`` disables the constant-force model)."""
        first = self.column_of["cohesion"]
        columns = slice(first, first + len(self.parts["cohesion"].columns()))
        return bool(np.any(self.table[:, :, columns] != 0.0))

    @property
    def evaluator(self) -> Any:
        """The compiled pair evaluator of this composition."""
        if self._evaluator is None:
            self._evaluator = composed_evaluator(self.parts, self.column_of, self._history_of)
        return self._evaluator

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name}, n_types={self.n_types})"

    # ------------------------------------------------------------------ parameters
    def set_pair(self, type_i: int, type_j: int, **params: Any) -> None:
        """Set the parameters of one (symmetric) type pair; unspecified ones take their
        defaults. ValueError names a missing, unknown or invalid parameter."""
        if not (0 <= type_i < self.n_types and 0 <= type_j < self.n_types):
            if type_i < 0 or type_j < 0:
                raise ValueError(f"types: ({type_i}, {type_j}) is not valid; types are >= 0")
            self._grow(max(type_i, type_j) + 1)
        row = self._row(params)
        self.table[type_i, type_j] = row
        self.table[type_j, type_i] = row
        self._reach = None
        self._set_types.add((min(type_i, type_j), max(type_i, type_j)))

    def set_all(self, **params: Any) -> None:
        """Set the same parameters for every type pair."""
        row = self._row(params)
        self.table[:, :] = row
        self._reach = None
        for a in range(self.n_types):
            for b in range(a, self.n_types):
                self._set_types.add((a, b))

    def ensure_types(self, n_types: int) -> None:
        """Grow the table to ``n_types``; new pairs copy the (0, 0) parameters."""
        if n_types > self.n_types:
            self._grow(n_types)

    def _grow(self, n: int) -> None:
        old = self.table
        self.table = np.broadcast_to(old[0, 0], (n, n, old.shape[2])).copy()
        self.table[: old.shape[0], : old.shape[1]] = old
        self._reach = None

    def resolve(self, params: dict[str, Any], meff: float) -> dict[str, Any]:
        """Turn config-only inputs (e.g. ``restitution`` and ``contact_time``) into table
        parameters for a type pair of effective mass ``meff``."""
        out = dict(params)
        for slot in SLOTS:
            out = self.parts[slot].resolve(out, meff)
        made = [k for k in out if k not in params and k not in self.param_names]
        if made:  # e.g. a restitution below 1 asks for a dashpot the composition lacks
            first, *others = (k for k in params if k not in out)
            given = f" (with {', '.join(others)})" if others else ""
            raise ValueError(f"{first}: {params[first]!r}{given} gives {', '.join(made)}, which "
                             f"the contact law {self.name} has no place for (its damping "
                             f"model is {self.models['damping']!r}); use model.damping = "
                             "'viscous', or give its own parameters instead")
        return out

    def _row(self, params: dict[str, Any]) -> np.ndarray:
        known = {p.name: p for p in self.inputs}
        for name in params:
            if name not in known:
                raise ValueError(f"{name}: not a parameter of the contact law {self.name}; "
                                 f"its parameters are {', '.join(self.param_names)}")
            if not known[name].column:
                raise ValueError(f"{name}: an input that needs the pair's effective mass; "
                                 "convert it with law.resolve(params, meff) first (or use "
                                 "grainflow.stiffness_and_damping)")
        row: dict[str, Any] = {"normal": self.models["normal"]}
        values = []
        for p in self.params:
            if p.name in params:
                value = params[p.name]
            elif p.default is None:
                raise ValueError(f"{p.name}: missing; the {self._slot_of(p)} model "
                                 f"{self.models[self._slot_of(p)]!r} needs it ({p.description})")
            elif callable(p.default):
                value = p.default(row)
            else:
                value = p.default
            row[p.name] = p.check(value)
            values.append(row[p.name])
        for slot in SLOTS:
            self.parts[slot].check_row(row)
        return np.array(values, dtype=np.float64)

    def _slot_of(self, param: Param) -> str:
        return next(s for s in SLOTS if param in self.parts[s].params)

    def row(self, type_i: int, type_j: int) -> dict[str, float]:
        """The parameters of a type pair by name (choices as their stored numbers)."""
        return dict(zip(self.param_names, self.table[type_i, type_j].tolist()))

    # ------------------------------------------------------------------ physics
    def reach(self) -> float:
        """How far beyond touching (surface gap) the law acts; 0 for pure contact laws.

        Contract with the pair loop: beyond ``r_i + r_j + reach`` the law exerts no force and
        its history for the pair is zero (the loop does not call the evaluator there).
        Computed once per change of the table (it is asked twice per step); change the
        table through :meth:`set_pair` / :meth:`set_all`.
        """
        if self._reach is None:
            best = 0.0
            for slot in SLOTS:
                part = self.parts[slot]
                c = self.column_of[slot]
                best = max(best, part.reach(self.table[:, :, c:c + len(part.columns())]))
            self._reach = best
        return self._reach

    def contact_time(self, type_i: int, type_j: int, meff: float, sigma: float) -> float:
        """Duration of a binary collision of a type pair with effective mass ``meff`` and
        contact distance ``sigma``: half a period of the damped oscillator of the normal
        stiffness and the normal dashpot, ``pi / sqrt(k/meff - b^2)``."""
        row = self.row(type_i, type_j)
        k = self.parts["normal"].stiffness(row, sigma)
        b = self.parts["damping"].normal_rate(row, meff)
        w2 = k / meff - b * b
        if w2 <= 0:
            raise ValueError(f"gamma_n: the contact of types ({type_i}, {type_j}) is "
                             "overdamped (no rebound); lower the damping")
        return math.pi / math.sqrt(w2)

    def relaxation_time(self, type_i: int, type_j: int, meff: float) -> float:
        """Relaxation time of a pair's relative velocity by the damping model's forces
        outside the normal dashpot (kinetic friction); inf if none."""
        return self.parts["damping"].relaxation_time(self.row(type_i, type_j), meff)

    def crossing_time(self, type_i: int, type_j: int, meff: float) -> float:
        """Time a pair that leaves contact at its escape speed takes to cross the cohesion
        model's range (:meth:`~grainflow.models.submodel.CohesionModel.crossing_time`); inf
        without cohesion."""
        return self.parts["cohesion"].crossing_time(self.row(type_i, type_j), meff)

    def rate_times(self, type_i: int, type_j: int, meff: float) -> list[tuple[str, float]]:
        """The pair's times besides its contact time that a step must resolve, as
        ``(kind, time)``: ``"relaxation"`` (:meth:`relaxation_time`) and ``"crossing"``
        (:meth:`crossing_time`), each where it is finite."""
        times = (("relaxation", self.relaxation_time(type_i, type_j, meff)),
                 ("crossing", self.crossing_time(type_i, type_j, meff)))
        return [(kind, t) for kind, t in times if math.isfinite(t)]
