"""The ``[contact]`` table: contact laws per type pair, generated from the model registry.

Every field of ``[contact]`` and of its ``[[contact.pairs]]`` overrides comes from
:mod:`grainflow.models.registry`: the preset names (``law``), the sub-model names per slot
(``model = {normal = "hertz"}``) and the parameters of every sub-model (with their units,
limits and defaults, :class:`grainflow.models.submodel.Param`). A new sub-model therefore
appears here, and in the reference tables of docs/config.md (:func:`reference_markdown`),
without a change to this file. Regenerate those tables with::

    python -m grainflow.config.contact docs/config.md

A type pair's law is its override's ``law``/``model`` if it gives one, else ``[contact]``'s;
type pairs with the same composition share one
:class:`~grainflow.models.base.ContactLaw`, and each distinct composition becomes one pair
interaction of the simulation.
"""

from __future__ import annotations

import difflib
import sys
from collections.abc import Collection
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (BaseModel, ConfigDict, Field, PrivateAttr, StrictInt, create_model,
                      model_validator)

from grainflow.units import parse_quantity
from grainflow.models.base import ContactLaw
from grainflow.models.registry import PRESETS, SUBMODELS, composition, submodel
from grainflow.models.submodel import SLOTS, Param, SubModel

__all__ = ["Contact", "ContactPair", "reference_markdown", "write_reference"]


def _all_params() -> dict[str, list[tuple[str, str, Param]]]:
    """Parameter name -> [(slot, model, Param)] over the whole registry."""
    out: dict[str, list[tuple[str, str, Param]]] = {}
    for slot, name in SUBMODELS:
        for p in submodel(slot, name).params:
            out.setdefault(p.name, []).append((slot, name, p))
    return out


def _literal(values: list[str]) -> Any:
    return Literal[tuple(values)]  # type: ignore[valid-type]


_ModelChoice = create_model(
    "ModelChoice", __config__=ConfigDict(extra="forbid"),
    __doc__="Sub-model names per slot (override the preset's).",
    **{slot: (_literal([n for s, n in SUBMODELS if s == slot]) | None,
              Field(None, description=f"{slot} sub-model")) for slot in SLOTS})

_PARAM_FIELDS = {
    name: (Any, Field(None, description="; ".join(
        f"{model} ({slot}): {p.description}" for slot, model, p in uses)))
    for name, uses in _all_params().items()}


class _LawEntry(BaseModel):
    """What ``[contact]`` and each override share: a composition and parameters."""

    model_config = ConfigDict(extra="forbid", validate_default=True)

    law: _literal(list(PRESETS)) | None = Field(  # type: ignore[valid-type]
        None, description="preset composition: " + "; ".join(
            f"{p.name}: {p.description}" for p in PRESETS.values()))
    model: _ModelChoice | None = Field(None, description="sub-model per slot")  # type: ignore

    def given(self) -> dict[str, Any]:
        """The parameters written in this table (raw: numbers or quantities with units)."""
        return {k: v for k, v in self.model_dump(exclude={"law", "model", "types", "pairs"},
                                                  exclude_none=True).items()}

    def composition(self, inherited: dict[str, str] | None = None) -> dict[str, str] | None:
        """Slot -> sub-model of this table, or None when it names none (inherits)."""
        chosen = {k: v for k, v in (self.model.model_dump() if self.model else {}).items()
                  if v is not None}
        if self.law is None and not chosen:
            return inherited
        if self.law is None and inherited is not None:
            return composition(None, **{**inherited, **chosen})
        return composition(self.law, **chosen)


_ParamsBase = create_model("_ParamsBase", __base__=_LawEntry, **_PARAM_FIELDS)


class ContactPair(_ParamsBase):  # type: ignore[misc, valid-type]
    """One type pair's override of ``[contact]``."""

    types: list[Annotated[StrictInt, Field(ge=0)]] = Field(
        min_length=2, max_length=2,
        description="the two particle types [a, b] (0-based) whose contacts this entry sets; "
                    "[a, a] for contacts within one type; each unordered pair at most once")


class Contact(_ParamsBase):  # type: ignore[misc, valid-type]
    """``[contact]``: the law of every type pair, with per-pair overrides."""

    pairs: list[ContactPair] = Field(
        default_factory=list,
        description="[[contact.pairs]] entries: per type pair, its own parameters (with "
                    "the same law, the other parameter groups are inherited from [contact]) "
                    "or another law or model (then nothing is inherited)")
    _entries: dict[tuple[int, int], tuple[dict[str, str], dict[str, Any]]] = PrivateAttr(
        default_factory=dict)

    @model_validator(mode="after")
    def _resolve(self) -> "Contact":
        base_models = self.composition()
        if base_models is None:
            raise ValueError("law: missing; choose a preset (law = "
                             f"{' or '.join(repr(p) for p in PRESETS)}) or name the "
                             "sub-models (model = {normal = ...})")
        base_given = self.given()
        base = _checked(base_models, base_given, "")
        entries = {(-1, -1): (base_models, base)}
        for k, pair in enumerate(self.pairs):
            where = f"pairs[{k}]."
            models = pair.composition(base_models)
            own = pair.given()
            if models == base_models:
                groups = {_group(models, n) for n in own} - {None}
                inherited = {n: v for n, v in base_given.items()
                             if _group(models, n) not in groups}
                # inherited values are checked again: a unit may depend on an option
                # (Param.dimension_by) that this table chooses otherwise
                params = _checked(models, {**inherited, **own}, where,
                                  set(inherited) - set(own))
            else:  # another law: nothing of [contact]'s parameters applies
                params = _checked(models, own, where)
            _complete(models, params, where)
            a, b = sorted(pair.types)
            if (a, b) in entries:
                raise ValueError(f"{where}types: [{a}, {b}] is overridden twice; merge the "
                                 "two [[contact.pairs]] tables")
            entries[(a, b)] = (models, params)
        _complete(base_models, base, "")
        self._entries = entries
        return self

    def entry(self, a: int, b: int) -> tuple[dict[str, str], dict[str, Any]]:
        """Composition and parameters (SI values, inputs unresolved) of the type pair."""
        return self._entries.get((min(a, b), max(a, b)), self._entries[(-1, -1)])

    def pair_params(self) -> dict[tuple[int, int], dict[str, Any]]:
        """The parameters of the default ``(-1, -1)`` and of every override."""
        return {k: dict(v[1]) for k, v in self._entries.items()}


def _owner(models: dict[str, str], name: str) -> tuple[type[SubModel], Param] | None:
    """The sub-model of a composition that has the parameter ``name``, and the parameter."""
    for slot in SLOTS:
        cls = submodel(slot, models[slot])
        for p in cls.params:
            if p.name == name:
                return cls, p
    return None


def _slot_param(models: dict[str, str], name: str) -> Param | None:
    found = _owner(models, name)
    return found[1] if found is not None else None


def _group(models: dict[str, str], name: str) -> str | None:
    p = _slot_param(models, name)
    return p.group if p is not None else None


def _checked(models: dict[str, str], given: dict[str, Any], where: str,
             inherited: Collection[str] = ()) -> dict[str, Any]:
    """Parse units and limits of the given parameters of a composition (as written: numbers,
    quantities with units, option names). The options are checked first: a parameter whose
    dimension depends on one (:attr:`Param.dimension_by`) is parsed in the dimension of the
    option in effect, the given one or the default. ``inherited``: the names whose values
    come from ``[contact]`` (so said in a message)."""
    owner = {}
    for name in given:
        found = _owner(models, name)
        if found is None:
            owners = ", ".join(f"{m} ({s})" for s, m, _ in _all_params()[name])
            own = [q.name for s in SLOTS for q in submodel(s, models[s]).params]
            close = difflib.get_close_matches(name, own, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ValueError(f"{where}{name}: not a parameter of the law "
                             f"{'/'.join(models[s] for s in SLOTS)}; it belongs to "
                             f"{owners}{hint}")
        owner[name] = found
    options: dict[str, Any] = {}
    for name, value in given.items():
        if owner[name][1].choices is not None:
            try:
                owner[name][1].check(value)
            except ValueError as err:
                raise ValueError(f"{where}{err}") from None
            options[name] = value
    out: dict[str, Any] = {}
    for name, value in given.items():
        cls, p = owner[name]
        if p.choices is not None:
            out[name] = value
            continue
        try:
            x = parse_quantity(value, p.dimension_for(cls.options(options)), field=name)
        except ValueError as err:
            origin = (f"; {name} = {value!r} is inherited from [contact]: give {name} in "
                      "this table" if name in inherited else "")
            raise ValueError(f"{where}{err}{_option_note(cls, p, options)}{origin}") from None
        try:
            out[name] = p.check(x)
        except ValueError as err:
            raise ValueError(f"{where}{err}") from None
    return out


def _option_note(cls: type[SubModel], p: Param, options: dict[str, Any]) -> str:
    """For a parameter whose dimension depends on an option: which one applies and why
    (``"; with epsilon_scales = 'diameter', epsilon is a force (with 'constant', an
    energy)"``); "" for any other."""
    if p.dimension_by is None:
        return ""
    choice, dimensions = p.dimension_by
    chosen = cls.options(options)[choice]
    others = ", ".join(f"with {o!r}, {_a(d)}" for o, d in dimensions.items() if o != chosen)
    return (f"; with {choice} = {chosen!r}, {p.name} is {_a(dimensions[chosen])}"
            + (f" ({others})" if others else ""))


def _a(dimension: str | None) -> str:
    """``"a force"``, ``"an energy"``, ``"a number"``."""
    word = dimension or "number"
    return f"{'an' if word[0] in 'aeiou' else 'a'} {word}"


def _complete(models: dict[str, str], params: dict[str, Any], where: str) -> None:
    """Build one table row (effective mass 1) to report a missing or inconsistent
    parameter now rather than when the simulation is built."""
    law = ContactLaw(**models)
    try:
        law.set_pair(0, 0, **law.resolve(params, 1.0))
    except ValueError as err:
        raise ValueError(f"{where}{err}") from None


# ---------------------------------------------------------------------------- reference
_START = "<!-- contact-reference: generated by python -m grainflow.config.contact -->"
_END = "<!-- end of contact-reference -->"


def reference_markdown() -> str:
    """The reference of the registry's presets, sub-models and parameters (Markdown)."""
    lines = ["| `law` | `normal` | `damping` | `tangential` | `cohesion` | what |",
             "|---|---|---|---|---|---|"]
    for p in PRESETS.values():
        models = composition(p.name)
        lines.append(f"| `\"{p.name}\"` | " + " | ".join(f"`{models[s]}`" for s in SLOTS)
                     + f" | {p.description} |")
    for slot in SLOTS:
        lines += ["", f"### `model.{slot}`", ""]
        for s, name in SUBMODELS:
            if s != slot:
                continue
            cls = submodel(slot, name)
            lines.append(f"- `\"{name}\"`: {cls.summary} (`{cls.__module__}`)")
            for p in cls.params:
                unit = (" / ".join(f'`"{c}"`' for c in p.choices) if p.choices is not None
                        else _reference_dimension(p))
                bound = "" if p.choices is not None else (
                    f"{', ' if p.dimension_by is None else '; '}"
                    f"{'>' if p.strict else '>='} {p.lower:g}"
                    + (f", <= {p.upper:g}" if p.upper != float("inf") else ""))
                lines.append(f"  - `{p.name}` ({unit}{bound}; default {p.describe_default()}):"
                             f" {p.description}")
    return "\n".join(lines) + "\n"


def _reference_dimension(p: Param) -> str:
    """The dimension of a parameter for the reference: one, or one per option of the choice
    it depends on (``energy if `epsilon_scales = "constant"`, force if ...``)."""
    if p.dimension_by is None:
        return p.dimension or "number"
    choice, dimensions = p.dimension_by
    return ", ".join(f'{d or "number"} if `{choice} = "{o}"`' for o, d in dimensions.items())


def write_reference(path: str | Path) -> bool:
    """Replace the generated block of ``path`` (docs/config.md); True if it changed."""
    path = Path(path)
    text = path.read_text()
    if _START not in text or _END not in text:
        raise ValueError(f"{path}: no generated block ({_START} ... {_END})")
    head, rest = text.split(_START, 1)
    _, tail = rest.split(_END, 1)
    new = f"{head}{_START}\n\n{reference_markdown()}\n{_END}{tail}"
    if new != text:
        path.write_text(new)
    return new != text


if __name__ == "__main__":  # pragma: no cover
    for target in sys.argv[1:]:
        print(f"{target}: {'updated' if write_reference(target) else 'up to date'}")
