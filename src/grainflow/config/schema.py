"""Run configuration: pydantic models of the TOML file, validated on load.

:func:`load_config` reads a TOML file (or a dict), validates it against :class:`RunConfig`
and the selected scenario's own section, and raises :class:`ConfigError` whose messages name
the field by its dotted path, the value, and what would be valid::

    particles[0].radius[0]: -0.001 is not valid; expected a value greater than 0

Quantities may carry units (``"200 um"``, ``"100 nN"``); they are converted to SI by
:func:`grainflow.config.units.parse_quantity`. Bare numbers pass unchanged, so studies in
reduced units simply write numbers. The reference of every field is ``docs/config.md``.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from types import NoneType, UnionType
from typing import Annotated, Any, ClassVar, Literal, Union, get_args, get_origin

from pydantic import (AfterValidator, BaseModel, BeforeValidator, ConfigDict, Discriminator,
                      Field, PrivateAttr, Tag, ValidationError, ValidationInfo,
                      field_validator, model_validator)

from grainflow.config.units import parse_quantity
from grainflow.scenarios import COMMON_SECTIONS, Scenario, get_scenario

__all__ = ["ConfigError", "RunConfig", "load_config", "resolved_dict"]


class ConfigError(ValueError):
    """An invalid configuration; ``messages`` holds one line per problem."""

    def __init__(self, messages: list[str]) -> None:
        self.messages = list(messages)
        super().__init__("; ".join(self.messages))


# ------------------------------------------------------------------------- field types
def _to_si(dimension: str | None) -> BeforeValidator:
    def convert(value: Any) -> Any:
        try:
            return parse_quantity(value, dimension, field="\0")
        except ValueError as err:
            raise ValueError(str(err).removeprefix("\0: ")) from None
    return BeforeValidator(convert)


def quantity(dimension: str | None, **constraints: Any) -> Any:
    """A float that may be written with a unit of ``dimension`` (converted to SI)."""
    if constraints.pop("allow_inf_nan", False):  # pydantic's float default
        return Annotated[float, _to_si(dimension), Field(**constraints)]
    return Annotated[float, _to_si(dimension), Field(allow_inf_nan=False, **constraints)]


def _one_per_axis(value: list[Any], info: ValidationInfo) -> list[Any]:
    dim = (info.context or {}).get("dim", 3)
    if len(value) != dim:
        raise ValueError(f"{value!r} has {len(value)} components; expected {dim} "
                         f"(one per axis, dim = {dim})")
    return value


def vector(dimension: str | None, **constraints: Any) -> Any:
    """A list of one quantity per axis (its length is checked against ``dim``)."""
    return Annotated[list[quantity(dimension, **constraints)], AfterValidator(_one_per_axis)]


def _listify(value: Any) -> Any:
    return value if isinstance(value, list) else [value]


def _existing_file(value: Any, info: ValidationInfo) -> str:
    path = Path(str(value)).expanduser()
    if not path.is_absolute():
        path = Path((info.context or {}).get("base_dir", ".")) / path
    if not path.is_file():
        raise ValueError(f"{str(value)!r} is not a file (looked for {path.resolve()})")
    return str(path.resolve())


Length = quantity("length")
PositiveLength = quantity("length", gt=0)
FilePath = Annotated[str, AfterValidator(_existing_file)]
TypeId = Annotated[int, Field(ge=0)]
Steps = Annotated[int, Field(ge=1)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_default=True)


# ---------------------------------------------------------------------------- sections
class RunSection(_Model):
    """How long and how the system is integrated."""

    steps: Steps | None = Field(None, description="number of time steps (or give duration)")
    duration: quantity("time", gt=0) | None = Field(
        None, description="simulated time; steps = ceil(duration / dt)")
    dt: quantity("time", gt=0) | None = Field(
        None, description="time step; default dt_fraction * contact time")
    dt_fraction: float = Field(0.02, gt=0, le=0.25,
                               description="dt = dt_fraction * t_c when dt is not given")
    integrator: Literal["verlet", "adams_bashforth2"] = "verlet"
    seed: int = Field(0, ge=0, description="seed of the run's random-number generator")
    skin: quantity("length", gt=0) | None = Field(None, description="Verlet skin; 0.2 r_mean")
    sort_every: int = Field(10, ge=1, description="re-sort particles every N list builds")
    check_every: Steps = Field(100, description="health check (NaN, overlap) every N steps")
    max_overlap_fraction: float = Field(
        0.5, gt=0, description="overlap / radius beyond which the run is declared unstable")
    allow_unsafe_dt: bool = Field(False, description="run even if dt > t_c/4 (diagnosis only)")
    minimize: bool = Field(False, description="remove overlaps with FIRE before step 0")

    @model_validator(mode="after")
    def _length_given(self) -> "RunSection":
        if (self.steps is None) == (self.duration is None):
            raise ValueError("give exactly one of steps (a count) or duration (a time, "
                             f"e.g. '0.1 s'); got steps = {self.steps}, "
                             f"duration = {self.duration}")
        return self


class OutputSection(_Model):
    """What is written into the run directory, and how often."""

    thermo_every: Steps = Field(100, description="thermo.csv row every N steps")
    frames_every: int = Field(1000, ge=0, description="frame into frames.h5 every N steps; 0: none")
    contacts: bool = Field(False, description="store each frame's contact list")
    compression: Literal["gzip", "lzf", "none"] = "gzip"
    checkpoint_every: int = Field(10000, ge=0, description="checkpoint every N steps; 0: only at "
                                  "the end and on SIGINT/SIGTERM")
    snapshot: bool = Field(True, description="write final.png")
    snapshot_plane: Literal["xz", "xy", "yz"] = Field("xz", description="3D projection plane")
    progress_interval: float = Field(10.0, gt=0, description="seconds between plain progress "
                                     "lines (when stdout is not a terminal)")


class BoxSection(_Model):
    """The simulation box; bounds on non-periodic axes are informational."""

    lo: vector("length")
    hi: vector("length")
    periodic: Annotated[list[bool], AfterValidator(_one_per_axis)] | None = None

    @field_validator("hi")
    @classmethod
    def _hi_above_lo(cls, hi: list[float], info: ValidationInfo) -> list[float]:
        lo = info.data.get("lo")
        if lo is not None and any(h <= low for h, low in zip(hi, lo)):
            raise ValueError(f"{hi!r} is not valid; expected hi > lo = {lo!r} on every axis")
        return hi


def _free_vector(value: list[Any], info: ValidationInfo) -> list[Any]:
    if len(value) not in (2, 3):
        raise ValueError(f"{value!r} has {len(value)} components; expected 2 or 3")
    return value


def free_vector(dimension: str | None) -> Any:
    """A list of 2 or 3 quantities (wall geometry, which may use z in 2D)."""
    return Annotated[list[quantity(dimension)], AfterValidator(_free_vector)]


class BoxRegion(_Model):
    """An axis-aligned block ``lo <= x <= hi``."""

    shape: Literal["box"] = "box"
    lo: vector("length")
    hi: vector("length")

    @field_validator("hi")
    @classmethod
    def _hi_above_lo(cls, hi: list[float], info: ValidationInfo) -> list[float]:
        return BoxSection._hi_above_lo(hi, info)


class CylinderRegion(_Model):
    """A 3D cylinder along coordinate ``axis`` (0, 1, 2) between ``lo`` and ``hi``."""

    shape: Literal["cylinder"]
    center: Annotated[list[Length], Field(min_length=2, max_length=2)] = Field(
        description="position in the two coordinates off the axis")
    radius: PositiveLength
    lo: Length
    hi: Length
    axis: Literal[0, 1, 2] = 2


class DiskRegion(_Model):
    """A 2D disk."""

    shape: Literal["disk"]
    center: Annotated[list[Length], Field(min_length=2, max_length=2)]
    radius: PositiveLength


class HalfSpaceRegion(_Model):
    """The half-space ``(x - point) . normal >= 0`` (e.g. everything above a plane)."""

    shape: Literal["halfspace"]
    point: vector("length")
    normal: vector(None)


def _region_tag(value: Any) -> str:
    return value.get("shape", "box") if isinstance(value, dict) else getattr(value, "shape", "box")


Region = Annotated[Union[Annotated[BoxRegion, Tag("box")],
                         Annotated[CylinderRegion, Tag("cylinder")],
                         Annotated[DiskRegion, Tag("disk")],
                         Annotated[HalfSpaceRegion, Tag("halfspace")]],
                   Discriminator(_region_tag)]


class _Population(_Model):
    """Fields shared by every particle population."""

    type: TypeId = Field(0, description="particle type (selects the contact parameters)")
    velocity: vector("velocity") | None = Field(None, description="initial velocity")
    frozen: bool = Field(False, description="frozen particles never move (rough walls, bases)")


class SizedPopulation(_Population):
    """A population whose sizes and masses the config gives (not read from a file)."""

    radius: Annotated[list[PositiveLength], BeforeValidator(_listify)] = Field(
        description="radius, or a list of radii (polydisperse)")
    fractions: list[Annotated[float, Field(gt=0)]] | None = Field(
        None, description="number fraction of each radius; default equal")
    density: quantity("density", gt=0) | None = Field(None, description="default 1")
    mass: quantity("mass", gt=0) | None = Field(None, description="instead of density")

    @field_validator("fractions")
    @classmethod
    def _fractions_match(cls, fractions: list[float] | None, info: ValidationInfo):
        radius = info.data.get("radius")
        if fractions is not None and radius is not None and len(fractions) != len(radius):
            raise ValueError(f"{fractions!r} has {len(fractions)} entries; expected one per "
                             f"radius ({len(radius)})")
        return fractions

    @field_validator("mass")
    @classmethod
    def _density_or_mass(cls, mass: float | None, info: ValidationInfo) -> float | None:
        if mass is not None and info.data.get("density") is not None:
            raise ValueError(f"{mass!r}: give density or mass, not both")
        return mass


class ListFill(SizedPopulation):
    """Particles at explicit positions."""

    fill: Literal["list"]
    positions: list[vector("length")] = Field(min_length=1)
    velocities: list[vector("velocity")] | None = None

    @field_validator("velocities")
    @classmethod
    def _one_per_particle(cls, velocities: list | None, info: ValidationInfo):
        positions = info.data.get("positions")
        if velocities is not None and positions is not None and len(velocities) != len(positions):
            raise ValueError(f"has {len(velocities)} entries; expected one per position "
                             f"({len(positions)})")
        return velocities


class LatticeFill(SizedPopulation):
    """Particles on a lattice filling a region, optionally thinned at random."""

    fill: Literal["lattice"]
    region: Region | None = Field(None, description="default: the box")
    lattice: Literal["square", "triangular", "simple_cubic", "fcc"] | None = Field(
        None, description="default: triangular in 2D, fcc in 3D")
    spacing: quantity("length", gt=0) | None = Field(
        None, description="nearest-neighbour distance; default 1.1 x the largest diameter")
    packing_fraction: float | None = Field(
        None, gt=0, lt=1, description="remove sites at random down to this packing fraction")


class RandomFill(SizedPopulation):
    """Non-overlapping particles at random positions in a region (none overlaps the
    particles of earlier populations)."""

    fill: Literal["random"]
    region: Region | None = Field(None, description="default: the box")
    count: Steps = Field(description="number of particles")
    max_attempts: Steps = Field(10_000, description="placement trials per particle")


class DataFile(_Population):
    """Particles from a LAMMPS ``atom_style sphere`` data file."""

    fill: Literal["lammps_data"]
    file: FilePath
    frozen_types: list[Annotated[int, Field(ge=1)]] = Field(
        [], description="LAMMPS types (1-based) to freeze, e.g. the chute's rough base")
    type: TypeId = Field(0, description="added to the file's (LAMMPS type - 1)")


Population = Annotated[Union[ListFill, LatticeFill, RandomFill, DataFile],
                       Field(discriminator="fill")]


class _Inserting(_Model):
    """Grains that an updater inserts: one radius, or two in equal numbers."""

    every: Steps = Field(description="steps between calls")
    radius: Annotated[list[PositiveLength], BeforeValidator(_listify),
                      Field(min_length=1, max_length=2)]
    density: quantity("density", gt=0) = 1.0
    velocity: vector("velocity") | None = None
    type: TypeId = 0
    max_attempts: Steps = Field(200, description="placement trials per grain and call")


class PourUpdater(_Inserting):
    """Rain ``per_insertion`` grains into ``region`` every ``every`` steps."""

    kind: Literal["pour"]
    region: Region
    per_insertion: Steps
    total: int | None = Field(None, ge=0, description="stop after this many grains")


class ReplenishUpdater(_Inserting):
    """Keep ``target`` grains in ``count_region`` by adding missing ones in ``region``."""

    kind: Literal["replenish"]
    region: Region = Field(description="where the missing grains are inserted")
    count_region: Region
    target: int = Field(ge=0)
    types: list[TypeId] | None = Field(None, description="count only these types")


Insert = Annotated[Union[PourUpdater, ReplenishUpdater], Field(discriminator="kind")]


class TetherSection(_Model):
    """Tie every particle of ``type`` to its initial position (and to its neighbours)."""

    type: TypeId = Field(description="the tethered particles' type")
    k: quantity("stiffness", ge=0) = Field(description="spring constant k_w")
    eta: quantity("damping", ge=0) = Field(0.0, description="dashpot constant eta_w")
    bond_cutoff: quantity("length", gt=0) | None = Field(
        None, description="also tie pairs closer than this (a little above the spacing)")


class DeleteUpdater(_Model):
    """Remove grains outside (``outside = true``) or inside ``region`` every ``every`` steps."""

    every: Steps
    region: Region
    outside: bool = True
    types: list[TypeId] | None = Field(None, description="only these types")


class _GranularParams(_Model):
    """M1/M2 parameters; see :class:`grainflow.models.granular.GranularLaw`."""

    kn: quantity("stiffness", gt=0) | None = None
    kt: quantity("stiffness", ge=0) | None = Field(None, description="default 2/7 kn")
    gamma_n: quantity(None, ge=0) | None = Field(
        None, description="1/s with damping='mass', kg/s with 'absolute'")
    gamma_t: quantity(None, ge=0) | None = Field(None, description="default gamma_n / 2")
    restitution: float | None = Field(None, gt=0, le=1, description="normal restitution e")
    contact_time: quantity("time", gt=0) | None = None
    mu: float | None = Field(None, ge=0, description="Coulomb friction coefficient")
    cohesion_force: quantity("force", ge=0) | None = None
    cohesion_range: quantity("length", ge=0) | None = None
    damping: Literal["mass", "absolute"] | None = None

    #: Fields that fix the normal spring-dashpot; a pair override replaces all of them.
    NORMAL: ClassVar[tuple[str, ...]] = ("kn", "gamma_n", "restitution", "contact_time")

    def check_complete(self) -> None:
        """Raise ValueError unless the normal force is given one way (and only one)."""
        by_k = self.kn is not None
        by_e = self.restitution is not None or self.contact_time is not None
        if by_k == by_e or (by_e and (self.restitution is None or self.contact_time is None)):
            raise ValueError("give either kn (and optionally gamma_n) or both restitution "
                             "and contact_time")
        if self.gamma_n is not None and not by_k:
            raise ValueError("gamma_n goes with kn; with restitution and contact_time the "
                             "damping follows from them")
        if (self.cohesion_force or 0) > 0 and not (self.cohesion_range or 0) > 0:
            raise ValueError("cohesion_force > 0 needs cohesion_range > 0 (the shell width "
                             f"delta_c in which it acts); got {self.cohesion_range!r}")


class _SoftParams(_Model):
    """M3 parameters; see :class:`grainflow.models.soft.SoftLaw`."""

    epsilon: quantity("energy", gt=0) | None = None
    mu: quantity("damping", ge=0) | None = Field(None, description="kinetic friction")

    NORMAL: ClassVar[tuple[str, ...]] = ("epsilon",)

    def check_complete(self) -> None:
        if self.epsilon is None:
            raise ValueError("epsilon: missing; the soft law needs an energy scale")


class _PairOverride(_Model):
    types: Annotated[list[TypeId], Field(min_length=2, max_length=2)]


class GranularPair(_GranularParams, _PairOverride):
    """Parameters of one type pair, overriding ``[contact]``'s."""


class SoftPair(_SoftParams, _PairOverride):
    """Parameters of one type pair, overriding ``[contact]``'s."""


class _Contact(_Model):
    PARAMS: ClassVar[type]

    def pair_params(self) -> dict[tuple[int, int], dict[str, Any]]:
        """The complete parameters of the default ``(-1, -1)`` and of every override."""
        base = self.model_dump(exclude={"law", "pairs"}, exclude_none=True)
        out = {(-1, -1): base}
        for pair in self.pairs:
            own = pair.model_dump(exclude={"types"}, exclude_none=True)
            inherited = dict(base)
            if any(k in own for k in pair.NORMAL):
                for k in pair.NORMAL:
                    inherited.pop(k, None)
            a, b = pair.types
            out[(min(a, b), max(a, b))] = {**inherited, **own}
        return out

    @model_validator(mode="after")
    def _complete(self) -> "_Contact":
        for (a, b), params in self.pair_params().items():
            where = "" if a < 0 else f"pairs with types [{a}, {b}]: "
            try:
                self.PARAMS(**params).check_complete()
            except ValueError as err:
                raise ValueError(where + str(err)) from None
        return self


class GranularContact(_Contact, _GranularParams):
    """Linear spring-dashpot with tangential history and optional cohesion (M1, M2)."""

    PARAMS: ClassVar[type] = _GranularParams
    law: Literal["granular"]
    pairs: list[GranularPair] = []


class SoftContact(_Contact, _SoftParams):
    """Soft harmonic particles with kinetic friction (M3)."""

    PARAMS: ClassVar[type] = _SoftParams
    law: Literal["soft"]
    pairs: list[SoftPair] = []


Contact = Annotated[Union[GranularContact, SoftContact], Field(discriminator="law")]


class _Wall(_Model):
    type: TypeId = Field(0, description="wall type: particle-wall parameters are the contact "
                         "parameters of (particle type, wall type)")
    velocity: free_vector("velocity") | None = Field(None, description="constant velocity")


class PlaneWall(_Wall):
    """Infinite plane; particles on the side ``normal`` points to."""

    shape: Literal["plane"]
    point: free_vector("length")
    normal: free_vector(None)


class SegmentWall(_Wall):
    """Finite segment ``p0``-``p1`` (2D)."""

    shape: Literal["segment"]
    p0: free_vector("length")
    p1: free_vector("length")


class CylinderWall(_Wall):
    """Infinite cylinder; ``inside`` holds grains inside (a tube), else outside (a post)."""

    shape: Literal["cylinder"]
    axis_point: free_vector("length")
    axis_direction: free_vector(None) = [0.0, 0.0, 1.0]
    radius: PositiveLength
    inside: bool = True


class ConeWall(_Wall):
    """Finite cone: apex, axis towards the wide end, half angle, axial range from the apex."""

    shape: Literal["cone"]
    apex: free_vector("length")
    axis: free_vector(None)
    half_angle_deg: float = Field(gt=0, lt=90)
    inside: bool = True
    axial_range: Annotated[list[quantity("length", ge=0, allow_inf_nan=True)],
                           Field(min_length=2, max_length=2)] = [0.0, math.inf]


class PlateWithHoleWall(_Wall):
    """Infinite plate with a circular orifice centred on ``point``."""

    shape: Literal["plate_with_hole"]
    point: free_vector("length")
    normal: free_vector(None)
    hole_radius: PositiveLength


class Hopper2DWall(_Wall):
    """Seed 003's 2D hopper: side walls ``W`` apart, bottom at ``theta_w``, orifice ``w``."""

    shape: Literal["hopper2d"]
    W: PositiveLength
    theta_w_deg: float = Field(90.0, gt=0, le=90, description="90 = flat bottom")
    orifice_w: PositiveLength
    y_bottom: Length = 0.0
    height: PositiveLength
    x_center: Length = 0.0


Wall = Annotated[Union[PlaneWall, SegmentWall, CylinderWall, ConeWall, PlateWithHoleWall,
                       Hopper2DWall], Field(discriminator="shape")]


class ChuteSection(_Model):
    """The ``chute`` scenario: LAMMPS's ``bench/in.chute`` deck."""

    data_file: FilePath = Field(description="LAMMPS data file, e.g. peers/data.chute")
    replicate: Annotated[list[Steps], Field(min_length=2, max_length=2)] = Field(
        [1, 1], description="copies along x and y")
    angle: float = Field(26.0, gt=-90, lt=90, description="chute inclination in degrees")


class RunConfig(_Model):
    """A whole run: ``scenario`` picks the builder; see ``docs/config.md``."""

    scenario: str = "generic"
    dim: Literal[2, 3] = 3
    run: RunSection
    output: OutputSection = OutputSection()
    box: BoxSection | None = None
    particles: list[Population] = []
    contact: Contact | None = None
    walls: list[Wall] = []
    tethers: list[TetherSection] = []
    insert: list[Insert] = []
    delete: list[DeleteUpdater] = []
    gravity: vector("acceleration") | None = None
    drag: Annotated[list[quantity("damping", ge=0)], BeforeValidator(_listify)] | None = Field(
        None, description="drag coefficient zeta (F = -zeta v), one value or one per type")

    _section: BaseModel | None = PrivateAttr(None)

    @property
    def section(self) -> BaseModel | None:
        """The validated scenario section (e.g. ``[hopper]``), or None."""
        return self._section

    @property
    def scenario_entry(self) -> Scenario:
        return get_scenario(self.scenario)

    def n_types(self) -> int:
        """Number of particle types the populations and contact pairs mention."""
        types = [p.type for p in [*self.particles, *self.walls, *self.insert]]
        if self.contact is not None:
            types += [t for pair in self.contact.pairs for t in pair.types]
        return max(types, default=0) + 1


# ----------------------------------------------------------------------------- loading
def load_config(source: str | Path | Mapping[str, Any]) -> RunConfig:
    """Read and validate a run configuration (TOML path or dict).

    Relative file names inside a TOML file are resolved against the file's folder (against
    the working directory for a dict). Raises :class:`ConfigError`.
    """
    if isinstance(source, Mapping):
        data, base_dir = dict(source), Path.cwd()
    else:
        path = Path(source)
        try:
            data = tomllib.loads(path.read_text())
        except FileNotFoundError:
            raise ConfigError([f"{path}: no such file"]) from None
        except tomllib.TOMLDecodeError as err:
            raise ConfigError([f"{path}: not valid TOML: {err}"]) from None
        base_dir = path.resolve().parent

    name = data.get("scenario", "generic")
    try:
        scenario = get_scenario(str(name))
    except ValueError as err:
        raise ConfigError([str(err)]) from None
    section_data = data.pop(scenario.section, {}) if scenario.section else None
    errors = _unused_sections(data, scenario)
    context = {"base_dir": base_dir, "dim": data.get("dim", 3) if data.get("dim") in (2, 3) else 3}
    config: RunConfig | None = None
    try:
        config = RunConfig.model_validate(data, context=context)
    except ValidationError as err:
        errors += format_errors(err, RunConfig)
    model = scenario.section_model()
    if model is not None:
        try:
            section = model.model_validate(section_data, context=context)
        except ValidationError as err:
            errors += format_errors(err, model, prefix=scenario.section)
        else:
            if config is not None:
                config._section = section
    if errors:
        raise ConfigError(errors)
    assert config is not None
    _check_time_step(config)
    return config


def _unused_sections(data: dict[str, Any], scenario: Scenario) -> list[str]:
    allowed = COMMON_SECTIONS | scenario.uses
    known = set(RunConfig.model_fields)
    return [f"{key}: not used by scenario {scenario.name!r}; remove it (this scenario reads "
            f"{', '.join(sorted(allowed | ({scenario.section} - {None})))})"
            for key in data if key in known and key not in allowed]


def resolved_dict(config: RunConfig) -> dict[str, Any]:
    """The configuration with defaults filled in, as plain data (TOML-writable)."""
    data = config.model_dump(exclude_none=True)
    entry = config.scenario_entry
    if config.section is not None and entry.section:
        data[entry.section] = config.section.model_dump(exclude_none=True)
    return data


def _check_time_step(config: RunConfig) -> None:
    """Refuse ``run.dt`` past the stability limit t_c/4 of the generic set-up."""
    run = config.run
    if run.dt is None or run.allow_unsafe_dt or config.contact is None:
        return
    from grainflow.config.build import estimate_contact_time  # imports the engine

    tc = estimate_contact_time(config)
    if tc is not None and run.dt > tc / 4:
        raise ConfigError([
            f"run.dt: {run.dt:g} is past the stability limit t_c/4 = {tc / 4:g} (binary "
            f"contact time t_c = {tc:g}); expected dt <= {tc * run.dt_fraction:g} "
            f"(dt_fraction x t_c), or leave dt out to get that value"])


# ------------------------------------------------------------------------------ errors
def format_errors(err: ValidationError, root: type[BaseModel], prefix: str = "") -> list[str]:
    """One ``path: value ... expected ...`` line per pydantic error."""
    lines = []
    for e in err.errors(include_url=False):
        path, parent = _path(root, e["loc"])
        if prefix:
            path = f"{prefix}.{path}" if path else prefix
        kind = e["type"]
        if kind == "extra_forbidden":
            keys = sorted(parent.model_fields) if _is_model(parent) else []
            hint = f"; valid keys here: {', '.join(keys)}" if keys else ""
            lines.append(f"{path}: unknown key{hint}")
        elif kind == "missing":
            lines.append(f"{path}: missing; this field is required")
        elif kind in ("union_tag_invalid", "union_tag_not_found"):
            ctx = e.get("ctx", {})
            key = str(ctx.get("discriminator", "")).strip("'")
            tag = ctx.get("tag")
            shown = "missing" if tag is None else f"{tag!r} is not valid"
            lines.append(f"{path}.{key}: {shown}; expected one of {ctx.get('expected_tags')}")
        elif kind in ("value_error", "assertion_error"):
            lines.append(f"{path}: {e['msg'].removeprefix('Value error, ')}")
        else:
            msg = e["msg"]
            if msg.startswith("Input should be "):
                expected = msg.removeprefix("Input should be ")
                if expected.startswith(("greater", "less")):
                    expected = "a value " + expected
                lines.append(f"{path}: {_show(e.get('input'))} is not valid; expected {expected}")
            else:
                lines.append(f"{path}: {_show(e.get('input'))} is not valid ({msg[:1].lower()}{msg[1:]})")
    return lines


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_model(t: Any) -> bool:
    return isinstance(t, type) and issubclass(t, BaseModel)


def _path(root: type[BaseModel], loc: tuple[Any, ...]) -> tuple[str, Any]:
    """Dotted path of a pydantic ``loc`` (union tags dropped) and the type it ends in."""
    text, t, parent = "", root, root
    for item in loc:
        parent = t
        t = _unwrap(t)
        members = _union_members(t)
        if members:
            t = next((m for m in members if _has_tag(m, item)), None)
            continue
        if isinstance(item, int):
            args = get_args(t)
            t = args[0] if args else None
            text += f"[{item}]"
            continue
        if _is_model(t):
            field = t.model_fields.get(item)
            t = field.annotation if field is not None else None
        else:
            t = None
        text += f".{item}"
    return text.lstrip("."), _unwrap(parent)


def _unwrap(t: Any) -> Any:
    while True:
        origin = get_origin(t)
        if origin is Annotated:
            t = get_args(t)[0]
        elif origin in (Union, UnionType):
            args = [a for a in get_args(t) if a is not NoneType]
            if len(args) != 1:
                return t
            t = args[0]
        else:
            return t


def _union_members(t: Any) -> list[Any]:
    if get_origin(t) in (Union, UnionType):
        return [_unwrap(a) for a in get_args(t) if a is not NoneType]
    return []


def _has_tag(model: Any, tag: Any) -> bool:
    if not _is_model(model):
        return False
    for field in model.model_fields.values():
        if get_origin(field.annotation) is Literal and tag in get_args(field.annotation):
            return True
    return False

