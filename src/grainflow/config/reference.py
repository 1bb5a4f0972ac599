"""The configuration reference, rendered from the schema: every table and every field with
its type, SI unit, default and description.

The pydantic models of :mod:`grainflow.config.schema` and the scenarios' own sections
(:data:`grainflow.scenarios.SCENARIOS`) are walked field by field: the type and its limits
come from the annotation (``quantity("length", gt=0)`` reads "length > 0", unit ``m``), the
default from the field, the description from ``Field(description=...)``. ``[contact]`` is
generated from the contact-model registry by :func:`grainflow.config.contact.reference_markdown`,
which this page includes rather than repeats. The documentation site builds this page on
every build (``docs/_hooks/grainflow_docs.py``); print it with::

    python -m grainflow.config.reference            # Markdown on stdout
    python -m grainflow.config.reference OUT.md     # into a file

``docs/config.md`` is the hand-written guide (examples, validation, units, the run
directory); this page is the complete list.
"""

from __future__ import annotations

import inspect
import math
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from types import NoneType, UnionType
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import annotated_types as at
from pydantic import AfterValidator, BaseModel, BeforeValidator
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

from grainflow.config import schema as S
from grainflow.config.contact import Contact, ContactPair, reference_markdown as contact_reference
from grainflow.scenarios import SCENARIOS, get_scenario

__all__ = ["FieldDoc", "TableDoc", "describe_type", "reference_markdown", "tables"]

#: The SI unit a value of each named dimension is stored in.
SI_UNITS = {
    "dimensionless": "—", "length": "m", "time": "s", "mass": "kg", "force": "N",
    "pressure": "Pa", "energy": "J", "velocity": "m/s", "acceleration": "m/s²",
    "density": "kg/m³", "stiffness": "N/m", "frequency": "1/s", "damping": "kg/s",
    "area": "m²", "volume": "m³",
}


@dataclass(frozen=True)
class FieldDoc:
    """One row of a table's reference."""

    name: str
    type: str
    unit: str
    default: str
    description: str


@dataclass(frozen=True)
class TableDoc:
    """One TOML table (or one form of an array of tables, e.g. ``[[walls]]`` of one shape)."""

    anchor: str
    title: str
    model: type[BaseModel]
    intro: str
    fields: tuple[FieldDoc, ...]
    #: Markdown written after the field table (``[contact]``: the registry's reference).
    extra: str = ""
    level: int = 2


# ------------------------------------------------------------------------- the tables
#: The ``model = {normal = ..., ...}`` inline table of ``[contact]`` (built from the registry).
_MODEL_CHOICE = next(a for a in get_args(Contact.model_fields["model"].annotation)
                     if a is not NoneType)
#: (anchor, heading, model, discriminator field shown in the heading or None, level)
_GENERIC: list[tuple[str, str, type[BaseModel], str | None, int]] = [
    ("top-level", "Top level", S.RunConfig, None, 2),
    ("run", "`[run]`", S.RunSection, None, 2),
    ("output", "`[output]`", S.OutputSection, None, 2),
    ("box", "`[box]`", S.BoxSection, None, 2),
    ("particles-list", "`[[particles]]`, `fill = \"list\"`", S.ListFill, None, 3),
    ("particles-lattice", "`[[particles]]`, `fill = \"lattice\"`", S.LatticeFill, None, 3),
    ("particles-random", "`[[particles]]`, `fill = \"random\"`", S.RandomFill, None, 3),
    ("particles-lammps-data", "`[[particles]]`, `fill = \"lammps_data\"`", S.DataFile, None, 3),
    ("region-box", "Region `shape = \"box\"`", S.BoxRegion, None, 3),
    ("region-cylinder", "Region `shape = \"cylinder\"`", S.CylinderRegion, None, 3),
    ("region-disk", "Region `shape = \"disk\"`", S.DiskRegion, None, 3),
    ("region-halfspace", "Region `shape = \"halfspace\"`", S.HalfSpaceRegion, None, 3),
    ("contact", "`[contact]`", Contact, None, 2),
    ("contact-model", "`model = {...}` (in `[contact]` and `[[contact.pairs]]`)", _MODEL_CHOICE,
     None, 3),
    ("contact-pairs", "`[[contact.pairs]]`", ContactPair, None, 3),
    ("walls-plane", "`[[walls]]`, `shape = \"plane\"`", S.PlaneWall, None, 3),
    ("walls-segment", "`[[walls]]`, `shape = \"segment\"`", S.SegmentWall, None, 3),
    ("walls-cylinder", "`[[walls]]`, `shape = \"cylinder\"`", S.CylinderWall, None, 3),
    ("walls-cone", "`[[walls]]`, `shape = \"cone\"`", S.ConeWall, None, 3),
    ("walls-plate-with-hole", "`[[walls]]`, `shape = \"plate_with_hole\"`", S.PlateWithHoleWall,
     None, 3),
    ("walls-hopper2d", "`[[walls]]`, `shape = \"hopper2d\"`", S.Hopper2DWall, None, 3),
    ("tethers", "`[[tethers]]`", S.TetherSection, None, 2),
    ("insert-pour", "`[[insert]]`, `kind = \"pour\"`", S.PourUpdater, None, 3),
    ("insert-replenish", "`[[insert]]`, `kind = \"replenish\"`", S.ReplenishUpdater, None, 3),
    ("delete", "`[[delete]]`", S.DeleteUpdater, None, 2),
]

#: Group headings written before the first table of a group: anchor prefix -> (anchor, title,
#: text).
_GROUPS = {
    "particles-": ("particles", "`[[particles]]`: populations",
                   "One table per population, added in order; `fill` picks the form."),
    "region-": ("regions", "Regions",
                "An inline table (`region = { ... }`) of a fill or an updater; `shape` "
                "defaults to `\"box\"`."),
    "walls-": ("walls", "`[[walls]]`: analytic walls",
               "One table per wall; `shape` picks the form. Every shape has `type` (the "
               "wall's contact type) and `velocity`."),
    "insert-": ("insert", "`[[insert]]`: inserting updaters",
                "One table per updater; `kind` picks the form."),
}

#: A union of tables is linked to its group's anchor.
_UNION_GROUPS = {
    frozenset({S.BoxRegion, S.CylinderRegion, S.DiskRegion, S.HalfSpaceRegion}): "regions",
    frozenset({S.ListFill, S.LatticeFill, S.RandomFill, S.DataFile}): "particles",
    frozenset({S.PlaneWall, S.SegmentWall, S.CylinderWall, S.ConeWall, S.PlateWithHoleWall,
               S.Hopper2DWall}): "walls",
    frozenset({S.PourUpdater, S.ReplenishUpdater}): "insert",
}


def _scenario_tables() -> list[tuple[str, str, type[BaseModel], str]]:
    """(anchor, heading, model, intro) of each scenario section, scenarios sharing a section
    grouped."""
    get_scenario("generic")  # loads the scenario plug-ins
    by_section: dict[str, list[Any]] = {}
    for sc in SCENARIOS.values():
        if sc.section is not None:
            by_section.setdefault(sc.section, []).append(sc)
    out = []
    for section, entries in by_section.items():
        model = entries[0].section_model()
        names = ", ".join(f"`{sc.name}`" for sc in entries)
        lines = [f"Read by scenario{'s' if len(entries) > 1 else ''} {names}."]
        for sc in entries:
            if sc.description:
                lines.append(f"`{sc.name}`: {sc.description}.")
            if sc.run_defaults:
                given = ", ".join(f"`{k} = {_toml(v)}`" for k, v in sc.run_defaults.items())
                lines.append(f"`{sc.name}` sets the `[run]` defaults {given}.")
        out.append((f"scenario-{section}", f"`[{section}]`", model, " ".join(lines)))
    return out


def tables() -> list[TableDoc]:
    """Every table of a run configuration, in the order of the reference page."""
    out = []
    for anchor, title, model, _, level in _GENERIC:
        extra = ""
        if model is Contact:
            extra = contact_reference().replace("\n### ", "\n#### ")
        shown = _CONTACT_OWN if model in (Contact, ContactPair) else None
        out.append(TableDoc(anchor, title, model, _doc(model), _fields(model, shown), extra,
                            level))
    for anchor, title, model, intro in _scenario_tables():
        out.append(TableDoc(anchor, title, model, f"{_doc(model)}\n\n{intro}".strip(),
                            _fields(model)))
    return out


def file_path_fields() -> frozenset[str]:
    """Names of the fields, in any table of a run configuration, that hold a file path
    (:data:`grainflow.config.schema.FilePath`, a list of them or an optional one). A sweep makes
    only these absolute against the folder of the file that wrote them
    (:func:`grainflow.sweep.spec.absolute_paths`): any other string, a scenario's name or a
    unit, stays what it is even where a file or folder of that name exists."""
    models = ([model for _, _, model, _, _ in _GENERIC]
              + [model for _, _, model, _ in _scenario_tables()])
    return frozenset(name for model in models for name, info in model.model_fields.items()
                     if _holds_file_path(info.annotation, list(info.metadata)))


def _holds_file_path(tp: Any, meta: list[Any]) -> bool:
    origin = get_origin(tp)
    if origin is Annotated:
        base, *inner = get_args(tp)
        return _holds_file_path(base, [*inner, *meta])
    if origin in (Union, UnionType, list, tuple):
        return any(_holds_file_path(arg, meta if origin in (Union, UnionType) else [])
                   for arg in get_args(tp) if arg is not NoneType and arg is not Ellipsis)
    return tp is str and _has_validator(_flat(meta), "_existing_file")


#: The fields of ``[contact]`` documented in its own table; the parameters of the
#: sub-models come after it, from the registry.
_CONTACT_OWN = ("law", "model", "pairs", "types")


#: Fields that pick the form of a table in an array of tables; listed first.
_DISCRIMINATORS = ("fill", "shape", "kind")


def _fields(model: type[BaseModel], only: tuple[str, ...] | None = None) -> tuple[FieldDoc, ...]:
    rows = []
    items = sorted(model.model_fields.items(),
                   key=lambda item: item[0] not in _DISCRIMINATORS)  # stable: else in order
    for name, info in items:
        if only is not None and name not in only:
            continue
        kind, unit = describe_type(info.annotation, info.metadata)
        rows.append(FieldDoc(name, kind, unit or "—", _default(info),
                             _text(info.description or _fallback(name, info))))
    return tuple(rows)


def _fallback(name: str, info: FieldInfo) -> str:
    """A description for a field without one: the first sentence of the table it holds, or
    what a discriminator does."""
    if name in _DISCRIMINATORS and get_origin(info.annotation) is Literal:
        return "selects this form of the table"
    inner = _unwrap(info.annotation)
    if get_origin(inner) in (Union, UnionType):
        members = [a for a in get_args(inner) if a is not NoneType]
        inner = _unwrap(members[0]) if len(members) == 1 else None
    if get_origin(inner) is list:
        item = _unwrap(get_args(inner)[0])
        if get_origin(item) in (Union, UnionType):
            group = _UNION_GROUPS.get(frozenset(_unwrap(m) for m in get_args(item)))
            text = next((g[2] for g in _GROUPS.values() if g[0] == group), "")
            return text.split("; ")[0].rstrip(".") + "." if text else ""
        inner = item
    doc = _doc(inner) if _is_model(inner) else ""
    return doc.split("\n\n")[0].replace("\n", " ") if doc else ""


# ------------------------------------------------------------------------------- types
def describe_type(annotation: Any, metadata: list[Any] | tuple[Any, ...] = ()) -> tuple[str, str]:
    """``(type, unit)`` of a field annotation in words, e.g. ``("length > 0", "m")``,
    ``("`dim` lengths", "m")``, ``('"verlet" or "adams_bashforth2"', "")``."""
    text, unit = _describe(annotation, list(metadata))
    return text, unit or ""


def _describe(tp: Any, meta: list[Any]) -> tuple[str, str | None]:
    origin = get_origin(tp)
    if origin is Annotated:
        base, *inner = get_args(tp)
        return _describe(base, [*inner, *meta])
    dimension = _dimension(meta)
    bounds = _bounds(meta)
    if origin in (Union, UnionType):
        members = [a for a in get_args(tp) if a is not NoneType]
        models = [_unwrap(m) for m in members]
        if all(_is_model(m) for m in models) and len(models) > 1:
            return _union_link(models), None
        parts = [_describe(m, []) for m in members]
        texts = [p[0] for p in parts]
        unit = next((p[1] for p in parts if p[1]), None)
        # ``X | None``: optional; the default (none) says so
        return (" or ".join(texts) + bounds if len(texts) > 1 else texts[0] + bounds), unit
    if origin is Literal:
        return " or ".join(f"`{_toml(v)}`" for v in get_args(tp)), None
    if origin is list:
        (item,) = get_args(tp) or (Any,)
        item_text, unit = _describe(item, [])
        item_text = _plural(item_text)
        if _has_validator(meta, "_one_per_axis"):
            return f"`dim` {item_text}", unit
        if _has_validator(meta, "_free_vector"):
            return f"2 or 3 {item_text}", unit
        lo, hi = _lengths(meta)
        if _has_validator(meta, "_listify", before=True):
            single, _ = _describe(item, [])
            return f"{single}, or a list of them", unit
        if lo is not None and lo == hi:
            return f"{lo} {item_text}", unit
        count = (f" ({lo} to {hi})" if lo is not None and hi is not None
                 else f" (at least {lo})" if lo else "")
        return f"list of {item_text}{count}", unit
    if _is_model(tp):
        return _model_link(tp), None
    if dimension is not None:
        name = dimension if dimension else "number"
        return f"{_dimension_word(name)}{bounds}", _unit(dimension)
    if tp is bool:
        return "bool", None
    if tp is int:
        return f"integer{bounds}", None
    if tp is float:
        return f"number{bounds}", None
    if tp is str:
        if _has_validator(meta, "_existing_file"):
            return "file path (relative to the config file)", None
        return "string", None
    if tp is Any:
        return "any", None
    return getattr(tp, "__name__", str(tp)), None


def _dimension(meta: list[Any]) -> str | None:
    """The dimension of a :func:`grainflow.units.quantity` field ("" for a bare number),
    or None if the field is not a quantity."""
    for m in meta:
        if isinstance(m, BeforeValidator) and hasattr(m.func, "dimension"):
            return m.func.dimension or ""
    return None


def _unit(dimension: str) -> str | None:
    if not dimension:
        return None
    if dimension in SI_UNITS:
        return SI_UNITS[dimension]
    return dimension  # a unit expression given as the dimension


def _dimension_word(name: str) -> str:
    return "number" if name == "dimensionless" else name


def _bounds(meta: list[Any]) -> str:
    words = []
    for m in _flat(meta):
        for cls, attr, sign in ((at.Gt, "gt", ">"), (at.Ge, "ge", "≥"), (at.Lt, "lt", "<"),
                                (at.Le, "le", "≤")):
            if isinstance(m, cls):
                words.append(f"{sign} {_number(getattr(m, attr))}")
    return (" " + ", ".join(words)) if words else ""


def _lengths(meta: list[Any]) -> tuple[int | None, int | None]:
    lo = hi = None
    for m in _flat(meta):
        if isinstance(m, at.MinLen):
            lo = m.min_length
        if isinstance(m, at.MaxLen):
            hi = m.max_length
    return lo, hi


def _flat(meta: list[Any]) -> list[Any]:
    """Metadata with the constraints of nested ``Field(...)`` objects spliced in."""
    out = []
    for m in meta:
        if isinstance(m, FieldInfo):
            out += list(m.metadata)
        else:
            out.append(m)
    return out


def _has_validator(meta: list[Any], name: str, before: bool = False) -> bool:
    kind = BeforeValidator if before else AfterValidator
    return any(isinstance(m, kind) and getattr(m.func, "__name__", "") == name for m in meta)


_PLURALS = {"velocity": "velocities", "density": "densities", "frequency": "frequencies",
            "mass": "masses"}


def _plural(text: str) -> str:
    """``"length > 0"`` -> ``"lengths > 0"``; a union in parentheses."""
    if " or " in text:
        return f"({text})"
    head, sep, tail = text.partition(" ")
    if head.isalpha() and head.islower():
        return f"{_PLURALS.get(head, head + 's')}{sep}{tail}"
    return text


def _unwrap(tp: Any) -> Any:
    while get_origin(tp) is Annotated:
        tp = get_args(tp)[0]
    return tp


def _is_model(tp: Any) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _anchors() -> dict[type[BaseModel], str]:
    out = {model: anchor for anchor, _, model, _, _ in _GENERIC}
    out[S.BoxSection] = "box"
    return out


def _model_link(model: type[BaseModel]) -> str:
    anchor = _anchors().get(model)
    return f"table ([{model.__name__}](#{anchor}))" if anchor else "table"


def _union_link(models: list[Any]) -> str:
    group = _UNION_GROUPS.get(frozenset(models))
    if group is not None:
        return f"table ([{group}](#{group}))"
    return " or ".join(_model_link(m) for m in models)


# ------------------------------------------------------------------------- values, text
def _default(info: FieldInfo) -> str:
    if info.default_factory is not None:
        return "computed (see the description)"
    if info.default is PydanticUndefined:
        return "required"
    if info.default is None:
        return "none"
    if isinstance(info.default, BaseModel):
        return "all defaults"
    return f"`{_toml(info.default)}`"


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        return ("inf" if value > 0 else "-inf") if math.isinf(value) else _number(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, BaseModel):
        return "{}"
    return str(value)


def _number(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


_ROLE = re.compile(r":(?:class|func|meth|data|mod|attr|obj):`~?([^`]+)`")


def _text(text: str) -> str:
    """Docstring or description text for a Markdown table cell or paragraph: Sphinx roles
    as code, pipes escaped in cells."""
    return _ROLE.sub(lambda m: f"`{m.group(1)}`", text).replace("|", "\\|")


def _doc(model: type[BaseModel]) -> str:
    doc = model.__doc__ or ""
    if not doc or doc == BaseModel.__doc__:
        return ""
    return _ROLE.sub(lambda m: f"`{m.group(1)}`", inspect.cleandoc(doc))


# ---------------------------------------------------------------------------- the page
_INTRO = """\
Every table and field of a run configuration, generated from the schema
(`grainflow.config.schema`, the scenarios' sections and the contact-model registry) when
this site is built. [Configuration files](config.md) is the guide: a complete example,
validation, units and the run directory.

A value with a unit (column *SI unit*) may be a bare number, taken as it is (SI, or the
reduced units of a study), or a string with any unit of its dimension (`"200 um"`,
`"2.5 g/cm^3"`), converted to the SI unit shown. Integers and booleans are strict
(`steps = 1e3` and `snapshot = "no"` are refused). "required" fields have no default;
"none" means the field is optional and absent unless given.
"""


def reference_markdown() -> str:
    """The whole reference page (Markdown, with ``{#anchor}`` heading ids)."""
    out = ["# Configuration reference", "", _INTRO]
    started: set[str] = set()
    scenario_heading = False
    for table in tables():
        group = next((g for prefix, g in _GROUPS.items() if table.anchor.startswith(prefix)),
                     None)
        if group is not None and group[0] not in started:
            started.add(group[0])
            out += [f"## {group[1]} {{#{group[0]}}}", "", group[2], ""]
        if table.anchor.startswith("scenario-") and not scenario_heading:
            scenario_heading = True
            out += ["## Scenario tables {#scenario-tables}", "",
                    "A scenario's own table; the `scenario` key selects the scenario, and a "
                    "table of another scenario is refused.", ""]
        level = 3 if table.anchor.startswith("scenario-") else table.level
        out += [f"{'#' * level} {table.title} {{#{table.anchor}}}", ""]
        if table.intro:
            out += [table.intro, ""]
        out += ["| key | type | SI unit | default | description |", "|---|---|---|---|---|"]
        out += [f"| `{f.name}` | {f.type} | {f.unit} | {f.default} | {f.description} |"
                for f in table.fields]
        out.append("")
        if table.extra:
            out += ["Parameters of the sub-models (generated from "
                    "`grainflow.models.registry`; one value for every type pair, overridden "
                    "per pair in `[[contact.pairs]]`):", "", table.extra.strip(), ""]
    return "\n".join(out).rstrip() + "\n"


if __name__ == "__main__":  # pragma: no cover
    page = reference_markdown()
    if len(sys.argv) > 1:
        Path(sys.argv[1]).write_text(page)
    else:
        sys.stdout.write(page)
