"""docs/config.md against the schema.

(a) every field that a section's tables document exists in the schema, and every schema
field is documented in its section; (b) every wall shape loads with all its documented
fields (from the TOML examples of its subsection), builds, and pushes a grain placed on it;
(c) every complete TOML example loads.

``[contact]`` and its subsections are left out of (a): that section is generated from the
contact-model registry and checked where it is generated.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from grainflow.config import schema as S
from grainflow.config.schema import load_config

DOC = (Path(__file__).resolve().parents[1] / "docs" / "config.md").read_text()

#: a backticked identifier
NAME = re.compile(r"`([A-Za-z_][A-Za-z0-9_]*)`")
#: a table name in backticks: `[run]`, `[[walls]]`
TABLE = re.compile(r"`\[\[?([A-Za-z_][A-Za-z0-9_.]*)\]?\]`")

WALL_MODELS = [S.PlaneWall, S.SegmentWall, S.CylinderWall, S.ConeWall, S.PlateWithHoleWall,
               S.Hopper2DWall]
#: keys every wall shape has (documented once, in the ``[[walls]]`` section's first table)
SHARED_WALL_KEYS = {"shape", *S._Wall.model_fields}

#: section title (its start) -> the schema models whose fields it documents
SECTIONS: dict[str, list[type[BaseModel]]] = {
    "Top level": [S.RunConfig],
    "`[run]`": [S.RunSection],
    "`[output]`": [S.OutputSection],
    "`[box]`": [S.BoxSection],
    "`[[particles]]`": [S.ListFill, S.LatticeFill, S.RandomFill, S.DataFile],
    "Regions": [S.BoxRegion, S.CylinderRegion, S.DiskRegion, S.HalfSpaceRegion],
    "`[[walls]]`": WALL_MODELS,
    "`[[tethers]]`": [S.TetherSection],
    "`[[insert]]` and `[[delete]]`": [S.PourUpdater, S.ReplenishUpdater, S.DeleteUpdater],
    "`[chute]`": [S.ChuteSection],
}
#: sections without fields of their own
PROSE = ("Run configuration", "Validation", "Units", "Adding a scenario", "The run directory",
         "Checkpoints and resuming", "Instability", "The command")
#: generated from the contact-model registry (its subsections too)
SKIPPED = "`[contact]`"


# ------------------------------------------------------------------------------ parsing
@dataclass
class Section:
    level: int
    title: str
    body: str

    @property
    def tables(self) -> list[tuple[list[str], list[list[str]]]]:
        """Markdown tables: (header cells, rows of cells)."""
        out, lines = [], self.body.splitlines()
        k = 0
        while k < len(lines):
            if lines[k].startswith("|") and k + 1 < len(lines) and lines[k + 1].startswith("|---"):
                header = _cells(lines[k])
                rows = []
                k += 2
                while k < len(lines) and lines[k].startswith("|"):
                    rows.append(_cells(lines[k]))
                    k += 1
                out.append((header, rows))
            else:
                k += 1
        return out

    def key_rows(self) -> dict[str, list[str]]:
        """``key`` -> its row, from the tables whose first column is ``key``."""
        out = {}
        for header, rows in self.tables:
            if header[0] == "key":
                for row in rows:
                    for name in names(row[0]):
                        out[name] = row
        return out

    def documented(self) -> set[str]:
        """Keys the section documents: table keys, and ``name`` (...) in prose."""
        keys = set(self.key_rows())
        for header, rows in self.tables:
            if header[:2] == ["shape", "keys"]:
                keys |= {n for row in rows for n in names(row[1])}
        prose = "\n".join(line for line in self.body.splitlines() if not line.startswith("|"))
        prose = re.sub(r"```.*?```", "", prose, flags=re.S)
        keys |= set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)` \(", prose))
        return keys

    def mentioned(self) -> set[str]:
        return set(NAME.findall(self.body))

    def toml_blocks(self) -> list[str]:
        return re.findall(r"```toml\n(.*?)```", self.body, flags=re.S)


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def names(cell: str) -> list[str]:
    """Backticked identifiers of a table cell, leaving out those in parentheses."""
    depth, kept = 0, []
    for ch in cell:
        depth += ch == "("
        if depth == 0:
            kept.append(ch)
        depth -= ch == ")" and depth > 0
    return NAME.findall("".join(kept))


def sections(text: str) -> list[Section]:
    """The document split at its headings (outside code blocks)."""
    out: list[Section] = []
    fenced = False
    for line in text.splitlines():
        if line.startswith("```"):
            fenced = not fenced
        match = None if fenced else re.match(r"(#+) (.*)", line)
        if match:
            out.append(Section(len(match.group(1)), match.group(2), ""))
        elif out:
            out[-1].body += line + "\n"
    return out


def grouped() -> dict[str, Section]:
    """Each level-2 section with its subsections folded in, except the subsections mapped
    on their own (``Regions``); ``[contact]`` left out."""
    out: dict[str, Section] = {}
    parent = None
    for sec in sections(DOC):
        if sec.level == 1:
            out[sec.title] = sec
            parent = None
            continue
        own = sec.level == 2 or _key(sec.title) is not None
        if own:
            out[sec.title] = Section(sec.level, sec.title, sec.body)
            parent = out[sec.title] if sec.level == 2 else parent
        elif parent is not None:
            parent.body += sec.body
    return {t: s for t, s in out.items() if not t.startswith(SKIPPED)}


def _key(title: str) -> str | None:
    return next((k for k in SECTIONS if title.startswith(k)), None)


def fields(models: list[type[BaseModel]]) -> set[str]:
    return {name for m in models for name in m.model_fields}


def wall_sections() -> dict[str, Section]:
    """``shape`` value -> its ``### `shape = "..."` `` subsection."""
    out = {}
    for sec in sections(DOC):
        match = re.match(r'`shape = "(\w+)"`', sec.title)
        if match:
            out[match.group(1)] = sec
    return out


def walls_intro() -> Section:
    """The ``[[walls]]`` section without its subsections (the keys every shape has)."""
    return next(s for s in sections(DOC) if s.title.startswith("`[[walls]]`"))


def wall_model(shape: str) -> type[BaseModel]:
    return next(m for m in WALL_MODELS if m.model_fields["shape"].annotation.__args__ == (shape,))


# ---------------------------------------------------------------------------- (a) fields
def test_every_section_is_known() -> None:
    unknown = [t for t, s in grouped().items() if s.level <= 2 and _key(t) is None
               and not t.startswith(PROSE)]
    assert not unknown, f"map these sections to schema models in SECTIONS: {unknown}"


@pytest.mark.parametrize("title", list(SECTIONS))
def test_documented_fields_exist_and_schema_fields_are_documented(title: str) -> None:
    matches = [s for t, s in grouped().items() if t.startswith(title)]
    assert len(matches) == 1, f"no single section {title!r} in docs/config.md"
    sec = matches[0]
    schema_fields = fields(SECTIONS[title])
    if title == "Top level":  # the tables are documented by their own sections
        mentioned = sec.mentioned() | {m for s in sections(DOC) for m in TABLE.findall(s.title)}
    else:
        mentioned = sec.mentioned()
    assert sec.documented() - schema_fields == set(), "documented but not in the schema"
    assert schema_fields - mentioned == set(), "in the schema but not documented"


def test_every_wall_shape_has_a_section_with_exactly_its_fields() -> None:
    assert set(walls_intro().key_rows()) == SHARED_WALL_KEYS
    shapes = wall_sections()
    assert set(shapes) == {m.model_fields["shape"].annotation.__args__[0] for m in WALL_MODELS}
    for shape, sec in shapes.items():
        own = set(wall_model(shape).model_fields) - SHARED_WALL_KEYS
        assert set(sec.key_rows()) == own, shape


def _toml_value(text: str) -> Any:
    text = text.replace("`", "").strip()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return PydanticUndefined  # prose, e.g. "at rest"


def test_wall_defaults_are_documented() -> None:
    """Required fields show "—"; a literal default (number, bool, list) is the schema's."""
    for shape, sec in [("", None), *wall_sections().items()]:
        if sec is None:
            rows, model = walls_intro().key_rows(), S.PlaneWall
        else:
            rows, model = sec.key_rows(), wall_model(shape)
        for name, row in rows.items():
            info = model.model_fields[name]
            assert len(row) == 4, (shape, name)
            default = row[2]
            if info.is_required():
                assert default == "—", (shape, name, default)
            elif shape != "cone" or name not in S.ConeWall.APEX_FORM + S.ConeWall.LAMMPS_FORM:
                assert default != "—", (shape, name)
            value = _toml_value(default)
            if value is not PydanticUndefined and info.default not in (None, PydanticUndefined):
                assert value == info.default, (shape, name, value, info.default)


# ------------------------------------------------------------------- (b) walls that run
def _wall_examples() -> list[tuple[str, dict[str, Any]]]:
    out = []
    for shape, sec in wall_sections().items():
        for block in sec.toml_blocks():
            data = tomllib.loads(block)
            assert list(data) == ["walls"] and len(data["walls"]) == 1, block
            out.append((shape, data["walls"][0]))
    return out


WALL_EXAMPLES = _wall_examples()
#: shapes run in 2D (the others in 3D)
PLANAR = {"segment", "hopper2d"}


def test_the_wall_examples_use_every_documented_field() -> None:
    for shape, sec in wall_sections().items():
        used = {k for s, wall in WALL_EXAMPLES if s == shape for k in wall}
        assert set(sec.key_rows()) - used == set(), shape
        assert all(wall["shape"] == shape for s, wall in WALL_EXAMPLES if s == shape)


def _config(dim: int, wall: dict[str, Any], x: list[float] | None = None) -> dict[str, Any]:
    return {
        "dim": dim,
        "run": {"steps": 30},
        "box": {"lo": [-50.0] * dim, "hi": [50.0] * dim},
        "particles": [{"fill": "list", "positions": [x or [0.3, 0.2, 5.0][-dim:]],
                       "radius": 0.5}],
        "contact": {"law": "granular", "restitution": 0.8, "contact_time": 0.05},
        "walls": [wall],
    }


@pytest.mark.parametrize("shape, wall", WALL_EXAMPLES,
                         ids=[f"{s}-{k}" for k, (s, _) in enumerate(WALL_EXAMPLES)])
def test_every_wall_example_loads_builds_and_pushes_a_grain(shape: str, wall: dict) -> None:
    """The documented wall with the shared keys too (type 1, a slow velocity): a grain placed
    half a radius into it, on its acting side, is pushed out along the wall's normal."""
    from grainflow.config.build import build_simulation, wall_shapes

    dim = 2 if shape in PLANAR else 3
    wall = {**wall, "type": 1, "velocity": [0.0, 0.01, 0.0][:dim]}
    assert set(wall) >= SHARED_WALL_KEYS
    config = load_config(_config(dim, wall))
    shapes = wall_shapes(config.walls[0])
    ref = np.array([0.3, 5.0, 0.0] if dim == 2 else [0.3, 0.2, 5.0])
    hits = [s.closest_point(ref) for s in shapes]
    c, _, n = min(hits, key=lambda h: np.linalg.norm(ref - h.point))
    x0 = c + 0.25 * n  # radius 0.5: overlapping by half a radius
    sim = build_simulation(load_config(_config(dim, wall, x0[:dim].tolist())))
    sim.run(30)
    x = sim.state.x[0, :dim]
    assert np.all(np.isfinite(x))
    assert (x - x0[:dim]) @ n[:dim] > 0.05


# --------------------------------------------------------------------- (c) the examples
def _complete_examples() -> list[str]:
    blocks = re.findall(r"```toml\n(.*?)```", DOC, flags=re.S)
    return [b for b in blocks if "run" in tomllib.loads(b)]


def test_there_is_a_complete_example() -> None:
    assert _complete_examples()


@pytest.mark.parametrize("block", _complete_examples())
def test_every_complete_example_loads(block: str) -> None:
    config = load_config(tomllib.loads(block))
    assert config.run.steps or config.run.duration


def test_every_toml_block_parses() -> None:
    for block in re.findall(r"```toml\n(.*?)```", DOC, flags=re.S):
        tomllib.loads(block)
