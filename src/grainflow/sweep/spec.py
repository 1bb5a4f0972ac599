"""Sweep files: validation and expansion into points.

A sweep file is TOML. Top-level keys configure the sweep, ``[base]`` (or
``base = "file.toml"``) is the configuration every point starts from, and
``[overrides]`` lists the values each overridden field takes::

    name = "q-vs-w"
    base = "hopper2d_tiny.toml"          # relative to this file; or an inline [base] table
    mode = "grid"                         # "grid": Cartesian product, "zip": element-wise
    replicates = 3                        # seeds seed_start, seed_start+1, ... (or seeds = [...])
    seed_field = "run.seed"
    analyses = ["grainflow.analysis.hopper:flow_rate_summary"]

    [overrides]
    "geometry.orifice_width" = {start = 3, stop = 10, num = 8}    # linspace
    "contact.mu" = [0.1, 0.2]                                     # explicit values
    "soft.zeta" = {start = 0.01, stop = 10, num = 4, scale = "log"}  # geometric spacing

Each point is the base config with one value per overridden field plus a seed.
Its identity (:attr:`Point.point_id`) is a hash of those values only, so the
order in which a sweep file lists fields or values does not matter.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Iterable
from typing import Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)

from grainflow.user_warnings import warn_user

DEFAULT_RUNNER = "grainflow.runner:run_config"
_DOTTED_CALLABLE = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")
_SIGNIFICANT_DIGITS = 12  # grid values are rounded to this many digits to drop float noise


class SweepFileError(ValueError):
    """A sweep file (or its base config) is invalid; the message says where and how to fix it."""

    exit_code = 2


class SweepError(RuntimeError):
    """A sweep cannot start (busy or unwritable directory, damaged catalog, unreachable
    scheduler, unknown runner...); the message says what to do. ``exit_code`` is the CLI's."""

    exit_code = 2


def _check_dotted_callable(value: str) -> str:
    if not _DOTTED_CALLABLE.match(value):
        raise ValueError(
            f"{value!r} is not a callable reference; write it as 'package.module:function'"
        )
    return value


class Axis(BaseModel):
    """The values one overridden field takes.

    Written in the sweep file either as a list of values (``[0.1, 0.2]``) or as a
    table: ``{values = [...]}``, ``{start, stop, num}`` (evenly spaced, both ends
    included) or ``{start, stop, num, scale = "log"}`` (geometric spacing).
    """

    model_config = ConfigDict(extra="forbid")

    values: list[Any] | None = None
    start: int | float | None = None
    stop: int | float | None = None
    num: int | None = Field(default=None, ge=1)
    scale: Literal["linear", "log"] = "linear"

    @model_validator(mode="before")
    @classmethod
    def _accept_plain_list(cls, data: Any) -> Any:
        if isinstance(data, list):
            return {"values": data}
        if isinstance(data, dict):
            return data
        raise ValueError(
            "expected a list of values such as [0.1, 0.2] or a range table such as "
            "{start = 3, stop = 10, num = 8} (add scale = \"log\" for geometric spacing)"
        )

    @model_validator(mode="after")
    def _one_form(self) -> Axis:
        range_keys = {"start": self.start, "stop": self.stop, "num": self.num}
        given = [k for k, v in range_keys.items() if v is not None]
        if self.values is not None:
            if given:
                raise ValueError(f"give either 'values' or a range, not both (also got {given})")
            if not self.values:
                raise ValueError("the list of values is empty; give at least one value")
            return self
        missing = [k for k in range_keys if k not in given]
        if missing:
            raise ValueError(f"a range needs start, stop and num; missing {missing}")
        if self.scale == "log" and (self.start <= 0 or self.stop <= 0):
            raise ValueError(
                f"scale = \"log\" needs start > 0 and stop > 0 (got start={self.start}, "
                f"stop={self.stop}); use scale = \"linear\" or positive bounds"
            )
        return self

    def resolve(self) -> list[Any]:
        """The list of values, ranges expanded and rounded to 12 significant digits; a range
        between integers whose values are all whole gives integers (counts stay counts)."""
        if self.values is not None:
            return list(self.values)
        spacing = np.geomspace if self.scale == "log" else np.linspace
        values = [_round(float(v)) for v in spacing(self.start, self.stop, self.num)]
        if (isinstance(self.start, int) and isinstance(self.stop, int)
                and all(v.is_integer() for v in values)):
            return [int(v) for v in values]
        return values


def _round(value: float) -> float:
    return float(f"{value:.{_SIGNIFICANT_DIGITS}g}")


class SweepSpec(BaseModel):
    """A validated sweep file. Build it with :func:`load_sweep` or :func:`parse_sweep`."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(default="sweep", min_length=1)
    base: dict[str, Any]
    mode: Literal["grid", "zip"] = "grid"
    overrides: dict[str, Axis] = Field(default_factory=dict)
    replicates: int = Field(default=1, ge=1)
    seeds: list[int] | None = None
    seed_start: int = 0
    seed_field: str = "run.seed"
    runner: str = DEFAULT_RUNNER
    analyses: list[str] = Field(default_factory=list)

    # folders that relative paths are resolved against (None: the working directory of the
    # driving process): the base config's file for ``base``, the sweep file for overrides
    _base_dir: Path | None = PrivateAttr(None)
    _overrides_dir: Path | None = PrivateAttr(None)

    @field_validator("base", mode="before")
    @classmethod
    def _check_base(cls, value: Any) -> Any:
        if not isinstance(value, dict):
            raise ValueError(
                "give the path of a config TOML file (relative to the sweep file) "
                "or an inline [base] table"
            )
        return value

    @field_validator("runner")
    @classmethod
    def _check_runner(cls, value: str) -> str:
        return _check_dotted_callable(value)

    @field_validator("analyses")
    @classmethod
    def _check_analyses(cls, value: list[str]) -> list[str]:
        return [_check_dotted_callable(v) for v in value]

    @field_validator("seeds")
    @classmethod
    def _check_seeds(cls, value: list[int] | None) -> list[int] | None:
        if value is not None and (not value or len(set(value)) != len(value)):
            raise ValueError("seeds must be a non-empty list of distinct integers")
        return value

    @model_validator(mode="after")
    def _check_consistency(self) -> SweepSpec:
        if self.seeds is not None and {"replicates", "seed_start"} & self.model_fields_set:
            raise ValueError("give either 'seeds' or 'replicates'/'seed_start', not both")
        problems = [p for p in (_override_path_problem(self.base, path) for path in self.overrides) if p]
        if problems:
            raise ValueError("; ".join(problems))
        _check_no_nesting([*self.overrides, self.seed_field])
        _check_seed_field(self.base, self.seed_field)
        self._warn_replaced_base_seed()
        if self.mode == "zip":
            lengths = {path: len(axis.resolve()) for path, axis in self.overrides.items()}
            if len(set(lengths.values())) > 1:
                raise ValueError(
                    f"mode = \"zip\" needs every override to have the same number of values; "
                    f"got {lengths}. Make the lists equally long or use mode = \"grid\""
                )
        self.points()  # rejects repeated points
        return self

    def _warn_replaced_base_seed(self) -> None:
        """Every point's seed comes from the sweep (``seeds`` or ``seed_start``) and replaces
        the base config's. A base seed other than the default 0 that the sweep's seeds leave
        out names a realization the sweep will not run: warn whoever wrote it."""
        try:
            node = get_dotted(self.base, self.seed_field)
        except KeyError:
            return
        seeds = self.seed_values()
        if node != 0 and node not in seeds:
            warn_user(
                f"sweep {self.name!r}: the base config sets {self.seed_field} = {node!r}, but "
                f"every point takes its seed from the sweep ({seeds}); to run "
                f"that realization set seed_start = {node!r} or seeds = [{node!r}]",
                UserWarning)

    def point_config(self, point: Point) -> dict[str, Any]:
        """The config a point runs: :meth:`Point.config` with relative file paths made
        absolute against the folder of the file that wrote them (see :func:`absolute_paths`)."""
        from grainflow.config.reference import file_path_fields

        fields = file_path_fields()
        config = _absolute_paths(self.base, _folder(self._base_dir), None, fields)
        overrides = {k: _absolute_paths(v, _folder(self._overrides_dir), k.rsplit(".", 1)[-1],
                                        fields)
                     for k, v in point.overrides.items()}
        return Point(overrides, point.seed_field, point.seed).config(config)

    def resolved_base(self) -> dict[str, Any]:
        """The base config with its relative file paths made absolute."""
        return absolute_paths(self.base, self._base_dir)

    def seed_values(self) -> list[int]:
        """The seeds of the replicates, in order."""
        if self.seeds is not None:
            return list(self.seeds)
        return list(range(self.seed_start, self.seed_start + self.replicates))

    def points(self) -> list[Point]:
        """Expand the sweep into its points (override combinations x seeds), in file order."""
        paths = list(self.overrides)
        columns = [self.overrides[p].resolve() for p in paths]
        if not columns:
            combos: Iterable[tuple[Any, ...]] = [()]
        elif self.mode == "grid":
            combos = itertools.product(*columns)
        else:
            combos = zip(*columns)
        points: list[Point] = []
        seen: dict[str, int] = {}
        for values in combos:
            for seed in self.seed_values():
                point = Point(dict(zip(paths, values)), self.seed_field, seed)
                if point.point_id in seen:
                    raise SweepFileError(
                        f"points {seen[point.point_id]} and {len(points)} are identical "
                        f"({point.label()}); remove the repeated value from [overrides]"
                    )
                seen[point.point_id] = len(points)
                points.append(point)
        return points


@dataclass(frozen=True, eq=False)
class Point:
    """One run of a sweep: the overridden values and the seed."""

    overrides: dict[str, Any]
    seed_field: str
    seed: int

    @property
    def point_id(self) -> str:
        """Stable 16-hex-digit hash of the override values and the seed."""
        return point_id(self.overrides, self.seed_field, self.seed)

    def config(self, base: dict[str, Any]) -> dict[str, Any]:
        """The fully resolved config: a deep copy of ``base`` with this point's values set."""
        config = copy.deepcopy(base)
        for path, value in {**self.overrides, self.seed_field: self.seed}.items():
            set_dotted(config, path, copy.deepcopy(value))
        return config

    def label(self) -> str:
        """Short human-readable description, e.g. ``contact.mu=0.1 run.seed=2``."""
        items = {**self.overrides, self.seed_field: self.seed}
        return " ".join(f"{k}={v!r}" for k, v in items.items())


def point_id(overrides: dict[str, Any], seed_field: str, seed: int) -> str:
    """Hash of a point's values; key order and int/float spelling (3 vs 3.0) do not matter."""
    items = {**overrides, seed_field: seed}
    text = json.dumps(_canonical(items), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _canonical(value: Any) -> Any:
    """Normalise numbers so that equal values hash equally."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
        return int(value)
    if isinstance(value, (int, float)):
        return value
    if isinstance(value, dict):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    return str(value)  # TOML dates and times


def get_dotted(config: dict[str, Any], path: str) -> Any:
    """Value at a dotted path such as ``"contact.mu"``; raises KeyError if absent."""
    node: Any = config
    for key in path.split("."):
        if not isinstance(node, dict) or key not in node:
            raise KeyError(path)
        node = node[key]
    return node


def set_dotted(config: dict[str, Any], path: str, value: Any) -> None:
    """Set the value at a dotted path, creating intermediate tables as needed."""
    *parents, leaf = path.split(".")
    node = config
    for key in parents:
        node = node.setdefault(key, {})
    node[leaf] = value


def absolute_paths(value: Any, folder: Path | None, key: str | None = None) -> Any:
    """A deep copy of ``value`` (a config, a table or one field's value, ``key`` its field
    name) in which every relative path in a file-path field
    (:func:`grainflow.config.reference.file_path_fields`: ``file``, ``data_file``) naming an
    existing file or folder under ``folder`` (default: the working directory) is made
    absolute.

    A config's relative paths (a LAMMPS data file, ...) mean "next to the file that wrote
    them"; a worker resolves them against its own working directory, which on a cluster is
    anywhere. Only the file-path fields are touched, so a scenario's name, a unit or any
    other string passes unchanged even where a file or folder of that name exists (a folder
    ``jet2d`` beside a sweep of the ``jet2d`` scenario).
    """
    from grainflow.config.reference import file_path_fields

    return _absolute_paths(value, _folder(folder), key, file_path_fields())


def _folder(folder: Path | None) -> Path:
    return Path.cwd() if folder is None else folder


def _absolute_paths(value: Any, folder: Path, key: str | None, fields: frozenset[str]) -> Any:
    if isinstance(value, dict):
        return {k: _absolute_paths(v, folder, k, fields) for k, v in value.items()}
    if isinstance(value, list):
        return [_absolute_paths(v, folder, key, fields) for v in value]
    if key in fields and isinstance(value, str) and value and "\n" not in value \
            and len(value) < 4096:
        path = Path(value).expanduser()
        if not path.is_absolute():
            try:
                if (folder / path).exists():
                    return str((folder / path).resolve())
            except (OSError, ValueError):  # a name too long for the filesystem, a NUL...
                pass
    return copy.deepcopy(value)


def _override_path_problem(base: dict[str, Any], path: str) -> str | None:
    """An override must name a field that the base config sets (catches typos)."""
    try:
        get_dotted(base, path)
    except KeyError:
        return (
            f"override {path!r} is not a field of the base config; "
            f"{_nearby_keys(base, path)} "
            "(to sweep a field the base config leaves at its default, add it to the base config)"
        )
    return None


def _nearby_keys(base: dict[str, Any], path: str) -> str:
    """Describe the keys present where a dotted path stops matching the config."""
    node: Any = base
    walked: list[str] = []
    for key in path.split("."):
        if not isinstance(node, dict) or key not in node:
            break
        node = node[key]
        walked.append(key)
    where = ".".join(walked) or "the top level"
    if not isinstance(node, dict):
        return f"{where!r} is a value, not a table"
    return f"keys at {where}: {sorted(node) or 'none'}"


def _check_seed_field(base: dict[str, Any], seed_field: str) -> None:
    """The seed field may be absent, but its parent must not be a plain value."""
    parents = seed_field.split(".")[:-1]
    node: Any = base
    for key in parents:
        node = node.get(key, {}) if isinstance(node, dict) else None
        if not isinstance(node, dict):
            raise ValueError(
                f"seed_field {seed_field!r} runs through {key!r}, which the base config sets "
                "to a value, not a table; point seed_field at the config's seed setting"
            )


def _check_no_nesting(paths: list[str]) -> None:
    """Two overridden fields must not contain one another (e.g. 'a' and 'a.b')."""
    for a, b in itertools.permutations(paths, 2):
        if b.startswith(a + ".") or a == b:
            raise ValueError(f"overrides {a!r} and {b!r} address the same field; keep one")


# ---------------------------------------------------------------------------------------
# Loading


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and validate a sweep file; ``base = "x.toml"`` is resolved relative to it."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise SweepFileError(f"{path}: sweep file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepFileError(f"{path}: not valid TOML: {exc}") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as exc:
        raise SweepFileError(f"{path}: cannot read the sweep file ({exc})") from None
    return parse_sweep(data, source=path)


def validate_point_configs(spec: SweepSpec, points: list[Point], where: str = "") -> None:
    """Check every point's config with grainflow's config schema before anything runs.

    Only for sweeps run by grainflow's own runner (other runners take other configs).
    Raises :class:`SweepFileError` listing every invalid point, with its parameters, the
    config field and what is wrong; points sharing the same problems are listed once.
    """
    if spec.runner != DEFAULT_RUNNER or not points:
        return
    from grainflow.config.schema import ConfigError, load_config

    problems: dict[tuple[str, ...], list[Point]] = {}
    for point in points:
        try:
            load_config(spec.point_config(point))
        except ConfigError as exc:
            problems.setdefault(tuple(exc.messages), []).append(point)
        except Exception as exc:  # noqa: BLE001 - a validator that fails unexpectedly
            problems.setdefault((f"{type(exc).__name__}: {exc}",), []).append(point)
    if not problems:
        return
    bad = sum(len(p) for p in problems.values())
    lines = [
        f"{where}{bad} of {len(points)} point(s) have an invalid configuration; nothing was "
        "run. Fix the base config or the [overrides] values:"
    ]
    for messages, group in problems.items():
        text = "; ".join(messages)
        if len(group) == len(points) and len(points) > 1:
            lines.append(f"  - every point (the base config): {text}")
            continue
        by_values: dict[str, list[int]] = {}
        for point in group:
            label = " ".join(f"{k}={v!r}" for k, v in point.overrides.items())
            by_values.setdefault(label, []).append(point.seed)
        for label, seeds in by_values.items():
            seed_text = f"{spec.seed_field}={', '.join(map(str, seeds))}"
            lines.append(f"  - point {label + ' ' if label else ''}({seed_text}): {text}")
    if len(lines) > 41:
        lines = [*lines[:41], f"  ... and {len(lines) - 41} more"]
    raise SweepFileError("\n".join(lines))


def parse_sweep(data: dict[str, Any], source: Path | None = None) -> SweepSpec:
    """Validate a parsed sweep file. ``source`` locates relative base paths and names the file."""
    data = dict(data)
    where = f"{source}: " if source else ""
    if source is not None:
        data.setdefault("name", source.stem)
    sweep_dir = Path(source).resolve().parent if source is not None else None
    base_dir = sweep_dir
    if isinstance(data.get("base"), str):
        data["base"], base_dir = _load_base(data["base"], source, where)
    try:
        spec = SweepSpec.model_validate(data)
    except ValidationError as exc:
        raise SweepFileError(where + format_validation_error(exc)) from None
    spec._base_dir, spec._overrides_dir = base_dir, sweep_dir
    return spec


def _load_base(name: str, source: Path | None, where: str) -> tuple[dict[str, Any], Path | None]:
    base_path = Path(name).expanduser()
    if not base_path.is_absolute() and source is not None:
        base_path = source.parent / base_path
    try:
        return tomllib.loads(base_path.read_text()), base_path.resolve().parent
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as exc:
        raise SweepFileError(
            f"{where}field 'base': cannot read the base config {str(base_path)!r} ({exc})"
        ) from None
    except FileNotFoundError:
        raise SweepFileError(
            f"{where}field 'base': base config {str(base_path)!r} not found; give a path "
            "relative to the sweep file or an inline [base] table"
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepFileError(f"{where}field 'base': {base_path} is not valid TOML: {exc}") from None


def format_validation_error(exc: ValidationError) -> str:
    """One line per problem: dotted field, the offending value and what is valid."""
    lines = [f"{exc.error_count()} problem(s) in the sweep file:"]
    for err in exc.errors():
        field = _format_loc(err["loc"])
        message = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            valid = _valid_keys(err["loc"])
            message = f"unknown field; valid fields here: {', '.join(valid)}"
        shown = _short(err["input"])
        value = "" if not err["loc"] or shown in message else f" (got {shown})"
        lines.append(f"  - {field}: {message}{value}")
    return "\n".join(lines)


def _format_loc(loc: tuple[Any, ...]) -> str:
    """('overrides', 'contact.mu', 'num') -> 'field overrides."contact.mu".num'."""
    if not loc:
        return "sweep file"
    parts = [f'"{p}"' if isinstance(p, str) and "." in p else str(p) for p in loc]
    return "field " + ".".join(parts)


def _valid_keys(loc: tuple[Any, ...]) -> list[str]:
    model = Axis if len(loc) >= 3 and loc[0] == "overrides" else SweepSpec
    return list(model.model_fields)


def _short(value: Any, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
