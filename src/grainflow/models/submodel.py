"""The parts a contact law is made of: sub-models in four slots, and their parameters.

In the spirit of LAMMPS's ``pair granular``, a contact law (:class:`~grainflow.models.base.
ContactLaw`) is composed of one sub-model per slot:

=============  ==========================================================================
slot           what it contributes (see :mod:`grainflow.models.compose` for the equations)
=============  ==========================================================================
``normal``     the elastic normal force while the surfaces overlap
``damping``    the dissipative force of the relative motion (normal dashpot, kinetic
               friction), and the mass factor ``m_d`` every dashpot is multiplied by
``tangential`` the tangential force at the contact point (spring with Coulomb cap ...)
``cohesion``   attraction across a gap beyond touching (the law's *reach*)
=============  ==========================================================================

A sub-model is one class in one file: its :class:`Param` list (the columns it adds to the
law's per-type-pair table, with units and limits for the configuration schema), its
per-contact history size, its reach beyond contact, and its compiled functions with the
signature of its slot (documented on each base class below). It becomes usable — from
Python, from config files, in docs/config.md — by one row in :mod:`grainflow.models.registry`.
Nothing in the engine or the configuration code changes for a new sub-model.

Compiled functions receive the whole parameter table ``tab`` (n_types, n_types, n_cols), the
two types, and ``c``, the sub-model's first column (a compile-time constant in the composed
law), so ``tab[ti, tj, c + m]`` is the sub-model's parameter ``m``; history functions
receive the pair's history ``hist`` (n_pairs, H), the pair's row ``k`` and ``h``, the
sub-model's first history column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar

import numpy as np

#: The slots, in the order their columns and history appear in a law's table.
SLOTS = ("normal", "damping", "tangential", "cohesion")


@dataclass(frozen=True)
class Param:
    """One parameter of a sub-model (one column of the law's table, or a config-only input).

    ``dimension``: the physical dimension of the value (``"stiffness"``, ``"time"`` ...; see
    :mod:`grainflow.units`) so that config files may write units; None for numbers
    whose unit depends on a convention. ``dimension_by``: instead of ``dimension``, for a
    value whose dimension depends on the option chosen for another parameter of the same
    sub-model (one with ``choices``): ``(that parameter's name, {option: dimension})``, one
    entry per option (the harmonic ``epsilon`` is an energy with ``epsilon_scales =
    "constant"``, a force with ``"diameter"``); :meth:`dimension_for` gives the one that
    applies. ``default``: a number, a function of the other parameters of the row (e.g.
    ``kt = 2/7 kn``), or None for a required parameter.
    ``lower``/``strict``: the value must be ``> lower`` (strict) or ``>= lower``;
    ``upper`` likewise ``<= upper``. ``choices``: a named option stored as a number (e.g.
    ``{"mass": 1.0, "absolute": 0.0}``). ``group``: in a per-type-pair override, giving one
    parameter of a group drops every inherited parameter of the same group (the normal
    force given by ``kn`` or by ``restitution`` and ``contact_time`` is one group).
    ``column``: False for a config-only input that :meth:`SubModel.resolve` turns into
    columns (e.g. ``restitution``).
    """

    name: str
    description: str
    dimension: str | None = None
    default: float | str | Callable[[dict[str, float]], float] | None = None
    lower: float = 0.0
    strict: bool = False
    upper: float = math.inf
    choices: dict[str, float] | None = None
    group: str | None = None
    column: bool = True
    dimension_by: tuple[str, dict[str, str | None]] | None = None

    def __post_init__(self) -> None:
        if self.dimension_by is not None and (self.dimension is not None
                                              or self.choices is not None):
            raise TypeError(f"Param {self.name!r}: dimension_by replaces dimension and does "
                            "not apply to a parameter with choices")

    def dimension_for(self, options: dict[str, str]) -> str | None:
        """The dimension that applies given the options in effect of the sub-model's choice
        parameters (name -> option name, defaults included: :meth:`SubModel.options`)."""
        if self.dimension_by is None:
            return self.dimension
        choice, dimensions = self.dimension_by
        return dimensions[options[choice]]

    def check(self, value: Any) -> float:
        """The value as a table number; ValueError naming the parameter if invalid."""
        if self.choices is not None:
            if value not in self.choices:
                raise ValueError(f"{self.name}: {value!r} is not valid; use one of "
                                 f"{', '.join(repr(c) for c in self.choices)}")
            return self.choices[value]
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{self.name}: {value!r} is not valid; expected a number") from None
        ok = (x > self.lower if self.strict else x >= self.lower) and x <= self.upper
        if not ok or not math.isfinite(x):
            relation = ">" if self.strict else ">="
            upper = f" and <= {self.upper:g}" if math.isfinite(self.upper) else ""
            raise ValueError(f"{self.name}: {value!r} is not valid; expected a finite value "
                             f"{relation} {self.lower:g}{upper}")
        return x

    @property
    def required(self) -> bool:
        return self.default is None

    def describe_default(self) -> str:
        """The default as text for the reference tables."""
        if not self.column:
            return "none (an alternative input)"
        if self.default is None:
            return "required"
        if callable(self.default):
            return getattr(self.default, "__doc__", None) or "derived"
        return repr(self.default) if isinstance(self.default, str) else f"{self.default:g}"


class SubModel:
    """Base of all sub-models: name, slot, parameters, history and reach."""

    slot: ClassVar[str]
    name: ClassVar[str]
    #: One line for the reference tables, with the equation and its source.
    summary: ClassVar[str] = ""
    params: ClassVar[tuple[Param, ...]] = ()
    history_size: ClassVar[int] = 0
    #: Per history column: the factor applied when the roles of i and j swap.
    history_flip: ClassVar[tuple[float, ...]] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Check that every ``dimension_by`` names a choice parameter of this sub-model and
        gives a dimension for each of its options."""
        super().__init_subclass__(**kwargs)
        params = {p.name: p for p in cls.params}
        for p in cls.params:
            if p.dimension_by is None:
                continue
            choice, dimensions = p.dimension_by
            options = params[choice].choices if choice in params else None
            if options is None or set(dimensions) != set(options):
                raise TypeError(f"{cls.__name__}.{p.name}: dimension_by must name a parameter "
                                f"of {cls.__name__} with choices and give a dimension for each "
                                f"of its options; got {p.dimension_by!r}")

    @classmethod
    def options(cls, params: dict[str, Any]) -> dict[str, str]:
        """The option in effect of each choice parameter: its option name in ``params`` (as
        written in a config table), else its default."""
        return {p.name: params.get(p.name, p.default) for p in cls.params
                if p.choices is not None}

    @classmethod
    def columns(cls) -> tuple[Param, ...]:
        """The parameters stored in the law's table, in column order."""
        return tuple(p for p in cls.params if p.column)

    @classmethod
    def resolve(cls, params: dict[str, Any], meff: float) -> dict[str, Any]:
        """Turn config-only inputs into table parameters (``meff``: the pair's effective
        mass). The default passes ``params`` through."""
        return params

    @classmethod
    def check_row(cls, row: dict[str, float]) -> None:
        """Relations between parameters (ValueError naming the field)."""

    @classmethod
    def reach(cls, cols: np.ndarray) -> float:
        """How far beyond touching (surface gap) the sub-model acts, given its columns
        ``cols[..., m]`` over all type pairs."""
        return 0.0


class NormalModel(SubModel):
    """Slot ``normal``. Compiled function (``inline='always'``)::

        force(tab, ti, tj, c, r, rinv, radsum, radi, radj) -> f_over_r

    the repulsive elastic force divided by the centre distance ``r`` (``radsum > r``;
    ``radj == 0`` for a wall).
    """

    slot = "normal"
    force: ClassVar[Any]

    @classmethod
    def stiffness(cls, row: dict[str, float], sigma: float) -> float:
        """Linear(ised) stiffness dF/d(overlap) for the time-step check (``sigma``: the
        contact distance)."""
        raise NotImplementedError


class DampingModel(SubModel):
    """Slot ``damping``. Compiled functions (``inline='always'``)::

        mass_factor(tab, ti, tj, c, meff) -> m_d
        force(tab, ti, tj, c, md, vnnr, rsqinv, vr1, vr2, vr3, vt1, vt2, vt3)
            -> (dn, ex, ey, ez)

    ``m_d`` multiplies every dashpot coefficient of the law (the tangential one too);
    ``dn`` is the normal dashpot force divided by ``r`` (subtracted from the elastic
    ``f_over_r``; ``vnnr = v_rel . d``), ``e`` an additional force vector on i (kinetic
    friction). ``vr`` is the relative translational velocity, ``vt`` its part
    perpendicular to ``d``.
    """

    slot = "damping"
    mass_factor: ClassVar[Any]
    force: ClassVar[Any]

    @classmethod
    def normal_rate(cls, row: dict[str, float], meff: float) -> float:
        """Decay rate ``b`` of the normal overlap (``meff u'' + 2 meff b u' + k u = 0``)."""
        return 0.0

    @classmethod
    def relaxation_time(cls, row: dict[str, float], meff: float) -> float:
        """Relaxation time of the relative velocity by forces outside the normal dashpot
        (kinetic friction); inf if none."""
        return math.inf


class TangentialModel(SubModel):
    """Slot ``tangential``. Compiled functions (``inline='always'``)::

        force(tab, ti, tj, c, hist, k, h, md, fn, dx, dy, dz, rsqinv, vtr1, vtr2, vtr3,
              dt, update) -> (fs1, fs2, fs3)
        release(hist, k, h, update)

    ``force``: the tangential force on i given the normal force magnitude ``fn`` and the
    tangential relative velocity at the contact point ``vtr``; the history is written
    only when ``update`` is true (a read-only evaluation changes nothing). ``release``:
    the surfaces no longer touch (forget the history when ``update``).
    """

    slot = "tangential"
    force: ClassVar[Any]
    release: ClassVar[Any]


class CohesionModel(SubModel):
    """Slot ``cohesion``. Compiled functions (``inline='always'``)::

        touch(tab, ti, tj, c, hist, k, h, update)
        gap_force(tab, ti, tj, c, hist, k, h, rsq, radsum, update) -> s

    ``touch`` runs while the surfaces overlap; ``gap_force`` while they do not (but the
    pair is within the law's reach): the force on i is ``s d``. History is written only
    when ``update`` is true.
    """

    slot = "cohesion"
    touch: ClassVar[Any]
    gap_force: ClassVar[Any]

    @classmethod
    def crossing_time(cls, row: dict[str, float], meff: float) -> float:
        """Time a pair of effective mass ``meff`` leaving contact at the slowest speed that
        escapes the attraction takes to cross the range it acts in (for the time-step
        check: the step must resolve it, or the step decides which pairs stay bound); inf
        if the sub-model attracts nothing."""
        return math.inf


@dataclass(frozen=True)
class Preset:
    """A named choice of sub-models (``law = "granular"`` in config files)."""

    name: str
    description: str
    models: dict[str, str] = field(default_factory=dict)
