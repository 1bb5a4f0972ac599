"""Run configuration: pydantic models of the TOML file, validated on load.

:func:`load_config` reads a TOML file (or a dict), validates it against :class:`RunConfig`
and the selected scenario's own section, and raises :class:`ConfigError` whose messages name
the field by its dotted path, the value, and what would be valid::

    particles[0].radius[0]: -0.001 is not valid; expected a value greater than 0

Quantities may carry units (``"200 um"``, ``"100 nN"``); they are converted to SI by
:func:`grainflow.units.parse_quantity`. Bare numbers pass unchanged, so studies in
reduced units simply write numbers. The reference of every field is ``docs/config.md``.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from types import NoneType, UnionType
from typing import Annotated, Any, ClassVar, Literal, Union, get_args, get_origin

from pydantic import (AfterValidator, BaseModel, BeforeValidator, ConfigDict, Discriminator,
                      Field, PrivateAttr, StrictBool, StrictInt, Tag, ValidationError,
                      ValidationInfo, field_validator, model_validator)

from grainflow.config.contact import Contact
from grainflow.config.regions import region_of
from grainflow.units import parse_quantity, quantity
from grainflow.scenarios import COMMON_SECTIONS, Scenario, get_scenario

__all__ = ["ConfigError", "RunConfig", "load_config", "resolved_dict"]


class ConfigError(ValueError):
    """An invalid configuration; ``messages`` holds one line per problem."""

    def __init__(self, messages: list[str]) -> None:
        self.messages = list(messages)
        super().__init__("; ".join(self.messages))


# ------------------------------------------------------------------------- field types
def _one_per_axis(value: list[Any], info: ValidationInfo) -> list[Any]:
    dim = (info.context or {}).get("dim", 3)
    if len(value) != dim:
        raise ValueError(f"{value!r} has {len(value)} components; expected {dim} "
                         f"(one per axis, dim = {dim})")
    return value


def vector(dimension: str | None, **constraints: Any) -> Any:
    """A list of one quantity per axis (its length is checked against ``dim``)."""
    return Annotated[list[quantity(dimension, **constraints)], AfterValidator(_one_per_axis)]


def _grain_density(value: Any, info: ValidationInfo) -> Any:
    """A grain density to SI: mass per volume in 3D, mass per area in 2D (a 2D grain is a
    disk), so a unit of the other kind is refused rather than converted by the wrong power of
    length (``"1 g/cm^3"`` in a 2D run)."""
    dim = (info.context or {}).get("dim", 3)
    try:
        return parse_quantity(value, "areal density" if dim == 2 else "density", field="\0")
    except ValueError as err:
        raise ValueError(str(err).removeprefix("\0: ") + (
            " (a 2D grain's density is its mass per unit area)" if dim == 2 else "")) from None


# the SI unit the configuration reference shows (the 3D one; descriptions give the 2D one)
_grain_density.dimension = "density"  # type: ignore[attr-defined]
#: Grain density: kg/m^3 in 3D, kg/m^2 in 2D; finite and > 0.
GrainDensity = Annotated[float, BeforeValidator(_grain_density),
                         Field(gt=0, allow_inf_nan=False)]


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
# Counts, ids and switches are strict: a string ("500", "no") or a float is refused, not
# coerced; quantities (floats) accept integers and unit strings.
TypeId = Annotated[StrictInt, Field(ge=0)]
Steps = Annotated[StrictInt, Field(ge=1)]
Count = Annotated[StrictInt, Field(ge=0)]
#: A finite float (no inf or nan).
Finite = Annotated[float, Field(allow_inf_nan=False)]


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
                               description="dt = dt_fraction * t_c when dt is not given "
                               "(hopper2d/3d refuse it: theirs is hopper.dt_fraction)")
    integrator: Literal["verlet", "adams_bashforth2"] = Field(
        "verlet", description="'verlet': velocity Verlet (LAMMPS nve/sphere); "
        "'adams_bashforth2': AB2 velocities with trapezoidal positions (seed 002)")
    seed: Count = Field(0, description="seed of the run's random-number generator")
    skin: quantity("length", gt=0) | None = Field(None, description="Verlet skin; 0.2 r_mean")
    sort_every: Steps = Field(10, description="re-sort particles every N list builds")
    list_check: Literal["absolute", "relative"] | None = Field(
        None, description="when the neighbour list is rebuilt: 'absolute' once a particle "
        "moved half the skin, 'relative' once a pair may have moved the skin against each "
        "other (flows that move as a whole: streams, jets); same forces either way; "
        "default: the scenario's ('relative' for stream, else 'absolute')")
    check_every: Steps = Field(100, description="full health check every N steps (docs/config.md)")
    max_overlap_fraction: Finite = Field(
        0.5, gt=0, description="overlap / radius beyond which the run is declared unstable")
    allow_unsafe_dt: StrictBool = Field(False, description="run even if dt > t_c/4 (diagnosis only)")
    minimize: StrictBool = Field(False, description="remove overlaps with FIRE before step 0")
    threads: Literal["auto"] | int = Field(
        "auto", description="compute threads: 'auto' (measure whether 1 or all is faster, "
        "during the run) or a count; results are the same either way")

    @field_validator("threads", mode="before")
    @classmethod
    def _threads(cls, value: Any) -> Any:
        if value == "auto" or (isinstance(value, int) and not isinstance(value, bool)
                               and value >= 1):
            return value
        raise ValueError("expected 'auto' or a thread count >= 1, e.g. threads = 2")

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
    frames_every: Count = Field(1000, description="frame into frames.h5 every N steps; 0: none")
    frames_from: quantity("time", ge=0) = Field(
        0.0, description="no frames before this simulated time (a transient not kept)")
    contacts: StrictBool = Field(False, description="store each frame's contact list")
    compression: Literal["gzip", "lzf", "none"] = Field(
        "gzip", description="compression of frames.h5: 'gzip' (level 4, readable by every "
        "HDF5 build), 'lzf' (faster, readable by h5py only) or 'none' (fastest to write)")
    checkpoint_every: Count = Field(10000, description="checkpoint every N steps; 0: only at "
                                  "the end and on SIGINT/SIGTERM")
    snapshot: StrictBool = Field(True, description="write final.png")
    snapshot_plane: Literal["xz", "xy", "yz"] = Field("xz", description="3D projection plane")
    progress_interval: Finite = Field(10.0, gt=0, description="seconds between plain progress "
                                     "lines (when stdout is not a terminal)")


class BoxSection(_Model):
    """The simulation box; bounds on non-periodic axes are informational."""

    lo: vector("length") = Field(description="lower corner, one coordinate per axis")
    hi: vector("length") = Field(
        description="upper corner, above lo on every axis; on non-periodic axes particles "
        "start inside the box and may leave it later (walls hold them)")
    periodic: Annotated[list[StrictBool], AfterValidator(_one_per_axis)] | None = Field(
        None, description="whether each axis is periodic (period hi - lo); default: none")

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


def _not_zero(value: list[float]) -> list[float]:
    if not any(v != 0.0 for v in value):
        raise ValueError(f"{value!r} is not a direction; expected a vector with a non-zero "
                         "component (any length)")
    return value


def direction(per_axis: bool = False) -> Any:
    """A direction (a plane's normal, an axis): numbers without a unit, not all zero, any
    length; 2 or 3 components (walls), or one per axis (``per_axis``, regions)."""
    check = _one_per_axis if per_axis else _free_vector
    return Annotated[list[quantity("dimensionless")], AfterValidator(check),
                     AfterValidator(_not_zero)]


class BoxRegion(_Model):
    """An axis-aligned block ``lo <= x <= hi``."""

    shape: Literal["box"] = Field(
        "box", description="'box' (the default when shape is left out): an axis-aligned block")
    lo: vector("length") = Field(description="lower corner, one coordinate per axis")
    hi: vector("length") = Field(description="upper corner, above lo on every axis")

    @field_validator("hi")
    @classmethod
    def _hi_above_lo(cls, hi: list[float], info: ValidationInfo) -> list[float]:
        return BoxSection._hi_above_lo(hi, info)


class CylinderRegion(_Model):
    """A 3D cylinder along coordinate ``axis`` (0, 1, 2) between ``lo`` and ``hi``."""

    shape: Literal["cylinder"] = Field(
        description="'cylinder': a 3D cylinder along a coordinate axis")
    center: Annotated[list[Length], Field(min_length=2, max_length=2)] = Field(
        description="position in the two coordinates off the axis")
    radius: PositiveLength = Field(description="radius of the cylinder")
    lo: Length = Field(description="lower end: a coordinate along axis")
    hi: Length = Field(description="upper end: a coordinate along axis, above lo")
    axis: Literal[0, 1, 2] = Field(
        2, description="the coordinate the cylinder runs along: 0, 1 or 2 for x, y or z")

    @field_validator("hi")
    @classmethod
    def _hi_above_lo(cls, hi: float, info: ValidationInfo) -> float:
        lo = info.data.get("lo")
        if lo is not None and hi <= lo:
            raise ValueError(f"{hi!r} is not valid; expected hi > lo = {lo!r}")
        return hi


class DiskRegion(_Model):
    """A 2D disk."""

    shape: Literal["disk"] = Field(description="'disk': a 2D disk")
    center: Annotated[list[Length], Field(min_length=2, max_length=2)] = Field(
        description="centre (x, y)")
    radius: PositiveLength = Field(description="radius of the disk")


class HalfSpaceRegion(_Model):
    """The half-space ``(x - point) . normal >= 0`` (e.g. everything above a plane)."""

    shape: Literal["halfspace"] = Field(
        description="'halfspace': the side of a plane (a line in 2D) that normal points to; "
        "unbounded, so not a fill or insertion region (e.g. for [[delete]])")
    point: vector("length") = Field(description="a point of the bounding plane (line in 2D)")
    normal: direction(per_axis=True) = Field(
        description="direction pointing into the half-space, not all 0 (any length)")


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
    frozen: StrictBool = Field(False, description="frozen particles never move (rough walls, bases)")


class SizedPopulation(_Population):
    """A population whose sizes and masses the config gives (not read from a file)."""

    radius: Annotated[list[PositiveLength], BeforeValidator(_listify)] = Field(
        min_length=1, description="radius, or a list of radii (polydisperse)")
    fractions: list[Annotated[Finite, Field(gt=0)]] | None = Field(
        None, description="number fraction of each radius; default equal")
    density: GrainDensity | None = Field(
        None, description="mass density of the grains: per volume in 3D (kg/m^3), per area in "
        "2D (kg/m^2; a 2D grain is a disk); default 1")
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

    fill: Literal["list"] = Field(description="'list': particles at explicit positions")
    positions: list[vector("length")] = Field(
        min_length=1, description="centre of each particle (one entry per particle), inside "
        "the box on non-periodic axes")
    velocities: list[vector("velocity")] | None = Field(
        None, description="initial velocity of each particle, one per position; overrides "
        "velocity")

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

    fill: Literal["lattice"] = Field(
        description="'lattice': particles on the sites of a lattice in region")
    region: Region | None = Field(None, description="default: the box")
    lattice: Literal["square", "triangular", "simple_cubic", "fcc"] | None = Field(
        None, description="default: triangular in 2D, fcc in 3D")
    spacing: quantity("length", gt=0) | None = Field(
        None, description="nearest-neighbour distance; default 1.1 x the largest diameter")
    packing_fraction: float | None = Field(
        None, gt=0, lt=1, description="remove sites at random down to this packing fraction")

    @field_validator("spacing")
    @classmethod
    def _no_overlap(cls, spacing: float | None, info: ValidationInfo) -> float | None:
        radius = info.data.get("radius")
        if spacing is not None and radius and spacing < 2 * max(radius):
            raise ValueError(f"{spacing:g} is less than the largest diameter {2 * max(radius):g}: "
                             "neighbouring grains would overlap; expected a spacing of at "
                             "least the largest diameter (default 1.1 x)")
        return spacing


class RandomFill(SizedPopulation):
    """Non-overlapping particles at random positions in a region (none overlaps the
    particles of earlier populations)."""

    fill: Literal["random"] = Field(
        description="'random': particles at random, non-overlapping positions in region")
    region: Region | None = Field(None, description="default: the box")
    count: Steps = Field(description="number of particles")
    max_attempts: Steps = Field(10_000, description="placement trials per particle")


class DataFile(_Population):
    """Particles from a LAMMPS ``atom_style sphere`` data file."""

    fill: Literal["lammps_data"] = Field(
        description="'lammps_data': the atoms of a LAMMPS data file")
    file: FilePath = Field(
        description="LAMMPS atom_style sphere data file, plain or gzip-compressed; ids, "
        "types, diameters, densities, positions, images, velocities and spins are taken from it")
    frozen_types: list[Annotated[StrictInt, Field(ge=1)]] = Field(
        [], description="LAMMPS types (1-based) to freeze, e.g. the chute's rough base")
    type: TypeId = Field(0, description="added to the file's (LAMMPS type - 1)")


Population = Annotated[Union[ListFill, LatticeFill, RandomFill, DataFile],
                       Field(discriminator="fill")]


class _Inserting(_Model):
    """Grains that an updater inserts: one radius, or two in equal numbers."""

    every: Steps = Field(description="steps between calls")
    radius: Annotated[list[PositiveLength], BeforeValidator(_listify),
                      Field(min_length=1, max_length=2)] = Field(
        description="radius of the inserted grains; two radii: inserted in equal numbers")
    density: GrainDensity = Field(
        1.0, description="mass density of the inserted grains (2D: mass per unit area)")
    velocity: vector("velocity") | None = Field(
        None, description="initial velocity of the inserted grains; default at rest")
    type: TypeId = Field(0, description="particle type of the inserted grains (selects the "
                         "contact parameters)")
    max_attempts: Steps = Field(200, description="placement trials per grain and call")


class PourUpdater(_Inserting):
    """Rain ``per_insertion`` grains into ``region`` every ``every`` steps."""

    kind: Literal["pour"] = Field(
        description="'pour': add per_insertion grains in region at every call")
    region: Region = Field(description="where the grains are inserted, at random without "
                           "overlap; bounded, inside the box on non-periodic axes")
    per_insertion: Steps = Field(description="grains added per call; those that do not fit "
                                 "are tried again at the next call")
    total: Count | None = Field(None, description="stop after this many grains")


class ReplenishUpdater(_Inserting):
    """Keep ``target`` grains in ``count_region`` by adding missing ones in ``region``."""

    kind: Literal["replenish"] = Field(
        description="'replenish': keep target grains in count_region, adding the missing "
        "ones in region")
    region: Region = Field(description="where the missing grains are inserted")
    count_region: Region = Field(description="where the grains are counted (by centre)")
    target: Count = Field(description="grains (of types) to keep in count_region; each call "
                          "inserts the missing ones")
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

    every: Steps = Field(description="steps between calls")
    region: Region = Field(description="the region the grain centres are tested against")
    outside: StrictBool = Field(
        True, description="true: remove the grains outside region; false: those inside it "
        "(a sink); frozen grains are never removed")
    types: list[TypeId] | None = Field(None, description="only these types")


class _Wall(_Model):
    type: TypeId = Field(0, description="wall type: particle-wall parameters are the contact "
                         "parameters of (particle type, wall type)")
    velocity: free_vector("velocity") | None = Field(None, description="constant velocity")


class PlaneWall(_Wall):
    """Infinite plane; particles on the side ``normal`` points to."""

    shape: Literal["plane"] = Field(description="'plane': an infinite plane acting on one side")
    point: free_vector("length") = Field(description="a point of the plane")
    normal: direction() = Field(description="towards the grains")


class SegmentWall(_Wall):
    """Finite segment ``p0``-``p1`` (2D)."""

    shape: Literal["segment"] = Field(
        description="'segment': a finite segment (2D walls; a thin rod in 3D) acting from "
        "both sides")
    p0: free_vector("length") = Field(description="one end")
    p1: free_vector("length") = Field(description="the other end")


def _ordered_range(value: list[float]) -> list[float]:
    if not value[0] < value[1]:
        raise ValueError(f"{value!r} is not valid; expected [s_min, s_max] with s_min < s_max")
    return value


def range_along_axis(**constraints: Any) -> Any:
    """``[s_min, s_max]``: two lengths (``inf`` allowed) along a wall's axis."""
    return Annotated[list[quantity("length", allow_inf_nan=True, **constraints)],
                     Field(min_length=2, max_length=2), AfterValidator(_ordered_range)]


def _lid_on_a_finite_end(lid: bool, info: ValidationInfo) -> bool:
    """A lid (``lid_lo``/``lid_hi``) closes a finite end of ``axial_range``."""
    ends = info.data.get("axial_range")
    if isinstance(info.data.get("axis"), str):  # a cone in LAMMPS's form: lo, hi are finite
        return lid
    if ends is None:  # the cone's default [0, inf], or an invalid range (reported already)
        ends = [0.0, math.inf] if "axial_range" in info.data else [0.0, 0.0]
    k = 0 if info.field_name == "lid_lo" else 1
    if lid and not math.isfinite(ends[k]):
        raise ValueError(f"a lid needs a finite end; axial_range[{k}] is {ends[k]!r}")
    return lid


class CylinderWall(_Wall):
    """Cylinder, infinite or over ``axial_range``; ``inside`` holds grains inside (a tube),
    else outside (a post); ``lid_lo``/``lid_hi`` close finite ends."""

    shape: Literal["cylinder"] = Field(description="'cylinder': a circular tube or post")
    axis_point: free_vector("length") = Field(description="a point of the axis (s = 0)")
    axis_direction: direction() = Field(
        [0.0, 0.0, 1.0], description="direction of the axis, in which s grows (normalised; "
        "not all 0)")
    radius: PositiveLength = Field(description="radius of the cylinder")
    inside: StrictBool = Field(
        True, description="true: grains inside (a tube); false: grains outside (a post)")
    axial_range: range_along_axis() = Field(
        [-math.inf, math.inf], description="[s_min, s_max] from axis_point along the axis")
    lid_lo: StrictBool = Field(False, description="close the end s_min with a flat disk")
    lid_hi: StrictBool = Field(False, description="close the end s_max with a flat disk")

    _lids = field_validator("lid_lo", "lid_hi")(_lid_on_a_finite_end)


class ConeWall(_Wall):
    """Finite cone, given by apex, axis towards the wide end, half angle and axial range from
    the apex, or in LAMMPS's ``region cone`` form (axis letter, centre, radii at lo and hi)."""

    #: The fields of each form (``axis`` and the shared keys belong to both).
    APEX_FORM: ClassVar[tuple[str, ...]] = ("apex", "half_angle_deg", "axial_range")
    LAMMPS_FORM: ClassVar[tuple[str, ...]] = ("center", "radius_lo", "radius_hi", "lo", "hi")

    shape: Literal["cone"] = Field(
        description="'cone': a conical hopper or funnel, in the apex form or LAMMPS's form")
    axis: Literal["x", "y", "z"] | direction() = Field(
        description="apex form: the axis vector, towards the wide end; LAMMPS form: x, y or z")
    apex: free_vector("length") | None = Field(
        None, description="apex form: the cone's tip, where s = 0 (need not be part of the "
        "surface)")
    half_angle_deg: float | None = Field(
        None, gt=0, lt=90, description="apex form: angle between the axis and the surface, "
        "in degrees")
    axial_range: range_along_axis(ge=0) | None = Field(
        None, description="[s_min, s_max] from the apex; default [0, inf]")
    center: Annotated[list[Length], Field(min_length=2, max_length=2)] | None = Field(
        None, description="LAMMPS c1 c2: the axis' coordinates off the axis")
    radius_lo: quantity("length", ge=0) | None = Field(None, description="radius at lo")
    radius_hi: quantity("length", ge=0) | None = Field(None, description="radius at hi")
    lo: Length | None = Field(None, description="lower end along the axis")
    hi: Length | None = Field(None, description="upper end along the axis")
    inside: StrictBool = Field(
        True, description="true: grains inside the cone (a hopper); false: outside it")
    lid_lo: StrictBool = Field(False, description="close the lower end with a flat disk")
    lid_hi: StrictBool = Field(False, description="close the upper end with a flat disk")

    _lids = field_validator("lid_lo", "lid_hi")(_lid_on_a_finite_end)

    @property
    def lammps_form(self) -> bool:
        """Given in LAMMPS's ``region cone`` form (``axis`` is a letter)."""
        return isinstance(self.axis, str)

    @model_validator(mode="after")
    def _one_form(self) -> "ConeWall":
        apex = [k for k in self.APEX_FORM if getattr(self, k) is not None]
        lammps = [k for k in self.LAMMPS_FORM if getattr(self, k) is not None]
        both = ("give either apex, axis (a vector), half_angle_deg and optionally "
                "axial_range, or LAMMPS's form axis ('x', 'y' or 'z'), center, radius_lo, "
                "radius_hi, lo, hi")
        if apex and lammps:
            raise ValueError(f"{', '.join(apex)} and {', '.join(lammps)} mix the two forms of "
                             f"a cone; {both}")
        if lammps and not self.lammps_form:
            raise ValueError(f"axis: {self.axis!r} is not valid with {', '.join(lammps)} (a "
                             "cone in LAMMPS's form); expected 'x', 'y' or 'z'")
        if self.lammps_form:
            missing = [k for k in self.LAMMPS_FORM if getattr(self, k) is None]
            if missing:
                raise ValueError(f"{', '.join(missing)}: missing for a cone in LAMMPS's form "
                                 f"(axis = {self.axis!r}); {both}")
            if not self.lo < self.hi:
                raise ValueError(f"hi: {self.hi!r} is not valid; expected hi > lo = {self.lo!r}")
            if self.radius_lo == self.radius_hi == 0:
                raise ValueError("radius_lo, radius_hi: both 0; expected at least one radius > 0")
            return self
        missing = [k for k in ("apex", "half_angle_deg") if getattr(self, k) is None]
        if missing:
            raise ValueError(f"{', '.join(missing)}: missing; {both}")
        return self


class PlateWithHoleWall(_Wall):
    """Infinite plate with a circular orifice centred on ``point``."""

    shape: Literal["plate_with_hole"] = Field(
        description="'plate_with_hole': an infinite plate with a circular orifice")
    point: free_vector("length") = Field(description="the centre of the hole")
    normal: direction() = Field(description="towards the grains")
    hole_radius: PositiveLength = Field(description="radius of the orifice")


class Hopper2DWall(_Wall):
    """Seed 003's 2D hopper: side walls ``W`` apart, bottom at ``theta_w``, orifice ``w``."""

    shape: Literal["hopper2d"] = Field(
        description="'hopper2d': seed 003's 2D hopper (four segments; upright for gravity "
        "along -y)")
    W: PositiveLength = Field(description="distance between the two vertical side walls")
    theta_w_deg: float = Field(90.0, gt=0, le=90, description="90 = flat bottom")
    orifice_w: PositiveLength = Field(
        description="width of the centred orifice between the bottom walls; less than W")
    y_bottom: Length = Field(0.0, description="height (y) of the orifice")
    height: PositiveLength = Field(
        description="height of the side walls' tops above y_bottom; more than the rise "
        "(W - orifice_w) / (2 tan theta_w) of the bottom walls")
    x_center: Length = Field(0.0, description="x of the hopper's axis, midway between the "
                             "side walls")


Wall = Annotated[Union[PlaneWall, SegmentWall, CylinderWall, ConeWall, PlateWithHoleWall,
                       Hopper2DWall], Field(discriminator="shape")]


class ChuteSection(_Model):
    """The ``chute`` scenario: LAMMPS's ``bench/in.chute`` deck.

    ``data_file`` defaults to the copy of LAMMPS's ``data.chute`` shipped with grainflow
    (``grainflow/data/chute/data.chute.gz``, see :func:`grainflow.scenarios.chute.chute_files`).
    """

    @staticmethod
    def _shipped_data_file() -> str:
        from grainflow.scenarios.chute import chute_files  # imported only when defaulted

        return str(chute_files().data)

    data_file: FilePath = Field(
        default_factory=_shipped_data_file,
        description="LAMMPS data file, plain or gzip; default: the shipped data.chute.gz")
    replicate: Annotated[list[Steps], Field(min_length=2, max_length=2)] = Field(
        [1, 1], description="copies along x and y")
    angle: float = Field(26.0, gt=-90, lt=90, description="chute inclination in degrees")


#: The error when both forms of the background drag are given.
DRAG_BOTH = ("drag and drag_rate: both given; give one: drag = zeta (per grain, F = -zeta v, "
             "e.g. '2 kg/s') or drag_rate = gamma (per unit mass, F = -gamma m v, e.g. '5 1/s')")


class RunConfig(_Model):
    """A whole run: ``scenario`` picks the builder; see ``docs/config.md``."""

    scenario: str = Field(
        "generic", description="the builder: 'generic' (from [box], [[particles]], [contact], "
        "[[walls]] and the other generic tables) or a ready-made study with its own table "
        "('chute', 'hopper2d', 'hopper3d', 'stream', 'jet2d', 'jet3d'); a table the "
        "scenario does not read is refused")
    dim: Literal[2, 3] = Field(
        3, description="2: disks moving in the xy plane; 3: spheres; the number of "
        "components of every per-axis vector")
    run: RunSection = Field(
        description="[run]: how long (steps or duration) and how the system is integrated")
    output: OutputSection = Field(
        OutputSection(), description="[output]: what is written into the run directory, "
        "and how often")
    box: BoxSection | None = Field(
        None, description="[box]: the simulation box; required by the generic scenario")
    particles: list[Population] = Field(
        [], description="[[particles]]: the particle populations at step 0, added in order")
    contact: Contact | None = Field(
        None, description="[contact]: the contact law of every type pair; none: particles do "
        "not touch, walls are refused and run.dt must be given")
    walls: list[Wall] = Field(
        [], description="[[walls]]: analytic walls, one table per wall (needs [contact])")
    tethers: list[TetherSection] = Field(
        [], description="[[tethers]]: tie every particle of a type to its initial position "
        "(a tethered particle wall)")
    insert: list[Insert] = Field(
        [], description="[[insert]]: updaters that add grains during the run")
    delete: list[DeleteUpdater] = Field(
        [], description="[[delete]]: updaters that remove grains during the run")
    gravity: vector("acceleration") | None = Field(
        None, description="uniform gravitational acceleration g, one component per axis "
        "(F = m g); default: no gravity")
    drag: Annotated[list[quantity("damping", ge=0)], BeforeValidator(_listify)] | None = Field(
        None, description="drag coefficient zeta (F = -zeta v), one value or one per type")
    drag_rate: Annotated[list[quantity("frequency", ge=0)], BeforeValidator(_listify)] | None = (
        Field(None, description="drag rate gamma per unit mass, F = -gamma m v, one value or "
                                "one per type"))

    _section: BaseModel | None = PrivateAttr(None)

    @model_validator(mode="after")
    def _one_drag(self) -> "RunConfig":
        if self.drag is not None and self.drag_rate is not None:
            raise ValueError(DRAG_BOTH)
        return self

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
def load_config(source: str | Path | Mapping[str, Any], *, saved: bool = False) -> RunConfig:
    """Read and validate a run configuration (TOML path or dict).

    Relative file names inside a TOML file are resolved against the file's folder (against
    the working directory for a dict). Raises :class:`ConfigError`. ``saved``: ``source``
    is a run directory's ``config.toml`` (:func:`saved_config_upgraded` is applied first).

    What needs the built particles is checked by
    :func:`grainflow.config.build.build_simulation` instead (``run.dt`` against the
    stability limit of the contact time).
    """
    if isinstance(source, Mapping):
        data, base_dir = dict(source), Path.cwd()
    else:
        path = Path(source)
        data = _read_toml(path)
        base_dir = path.resolve().parent
    if saved:
        data = saved_config_upgraded(data)

    name = data.get("scenario", "generic")
    try:
        scenario = get_scenario(str(name))
    except ValueError as err:
        raise ConfigError([str(err)]) from None
    section_data = data.pop(scenario.section, {}) if scenario.section else None
    if scenario.run_defaults and isinstance(data.get("run", {}), dict):
        data["run"] = {**scenario.run_defaults, **data.get("run", {})}
    errors = _unused_sections(data, scenario) + _run_fields_elsewhere(data, scenario)
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
    if config is not None:
        errors += _placement_problems(config)
    if errors:
        raise ConfigError(errors)
    assert config is not None
    return config


def _read_toml(path: Path) -> dict[str, Any]:
    """The TOML table of the file ``path``; ConfigError if it is missing, not UTF-8 text
    (binary, UTF-16) or not valid TOML (naming the line)."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ConfigError([f"{path}: no such file"]) from None
    except OSError as err:
        raise ConfigError([f"{path}: cannot be read ({err.strerror or err})"]) from None
    fix = "save the configuration as UTF-8 text"
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise ConfigError([f"{path}: not UTF-8 TOML text (it starts with a UTF-16 byte order "
                           f"mark); {fix}"])
    if b"\x00" in raw:
        raise ConfigError([f"{path}: not UTF-8 TOML text (it holds NUL bytes: UTF-16 without "
                           f"a byte order mark, or a binary file); {fix}"])
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise ConfigError([f"{path}: not UTF-8 TOML text (byte {err.object[err.start]:#04x} at "
                           f"offset {err.start} is not UTF-8; a binary file?); {fix}"]) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        where = re.search(r"\(at line (\d+), column (\d+)\)", str(err))
        line = f", line {where[1]}" if where else ""
        raise ConfigError([f"{path}{line}: not valid TOML: {err}"]) from None


# -------------------------------------------------------------------- cross-field checks
#: Densest packing fraction of equal disks (2D) and spheres (3D): a random fill asking for
#: more cannot be placed.
DENSEST_PACKING = {2: math.pi / (2 * math.sqrt(3)), 3: math.pi / (3 * math.sqrt(2))}
#: Lattice kinds of each dimension.
LATTICES = {2: ("square", "triangular"), 3: ("simple_cubic", "fcc")}


def _placement_problems(config: RunConfig) -> list[str]:
    """Where the fills put particles, against the box and each other's dimension.

    On non-periodic axes a ``list`` position must lie in the box and a ``lattice``/``random``
    region inside it (periodic axes wrap, so they do not count); a fill region must be
    bounded (not a half-space) and of the run's dimension, the lattice kind too; a random
    fill may not ask for more grain volume than the densest packing of its region holds.
    """
    problems: list[str] = []
    dim = config.dim
    box = config.box
    for k, pop in enumerate(config.particles):
        where = f"particles[{k}]"
        if isinstance(pop, ListFill) and box is not None:
            for i, x in enumerate(pop.positions):
                axes = _outside_box(box, dim, x, x)
                if axes:
                    problems.append(f"{where}.positions[{i}]: {x!r} is outside the box on "
                                    f"{axes}; expected a position inside the box on "
                                    "non-periodic axes (or make the axis periodic)")
        if not isinstance(pop, (LatticeFill, RandomFill)):
            continue
        if isinstance(pop, LatticeFill) and pop.lattice not in (None, *LATTICES[dim]):
            problems.append(f"{where}.lattice: {pop.lattice!r} is not valid in {dim}D; "
                            f"expected one of {LATTICES[dim]}")
        region = pop.region
        if region is None:
            if isinstance(pop, RandomFill) and box is not None:
                problems += _overfull(pop, where, _region_volume(None, box), dim)
            continue
        bounds = _region_bounds(region, dim)
        if isinstance(bounds, str):
            problems.append(f"{where}.region: {bounds}")
            continue
        axes = _outside_box(box, dim, *bounds) if box is not None else ""
        if axes:
            problems.append(f"{where}.region: {_show_region(region)} reaches outside the box "
                            f"on {axes}; expected a region inside the box on non-periodic "
                            "axes (shrink the region, enlarge the box or make the axis "
                            "periodic)")
        if isinstance(pop, RandomFill):
            problems += _overfull(pop, where, _region_volume(region, box), dim)
    for k, updater in enumerate(config.insert):
        # as LAMMPS's fix pour: grains are inserted inside the box
        bounds = _region_bounds(updater.region, dim)
        if isinstance(bounds, str):
            problems.append(f"insert[{k}].region: {bounds.replace('filled', 'inserted into')}")
            continue
        axes = _outside_box(box, dim, *bounds) if box is not None else ""
        if axes:
            problems.append(f"insert[{k}].region: {_show_region(updater.region)} reaches "
                            f"outside the box on {axes}; expected an insertion region inside "
                            "the box on non-periodic axes")
    return problems


def _outside_box(box: BoxSection, dim: int, lo: list[float], hi: list[float]) -> str:
    """The non-periodic axes on which ``[lo, hi]`` leaves the box, described ("" if none)."""
    periodic = box.periodic or [False] * dim
    names = "xyz"
    out = []
    for a in range(dim):
        slack = 1e-9 * (box.hi[a] - box.lo[a])
        if not periodic[a] and (lo[a] < box.lo[a] - slack or hi[a] > box.hi[a] + slack):
            out.append(f"axis {names[a]} (box {box.lo[a]:g} to {box.hi[a]:g}, not periodic)")
    return ", ".join(out)


def _region_bounds(region: Any, dim: int) -> tuple[list[float], list[float]] | str:
    """Bounding box of a fill region, or why the region cannot be filled."""
    if region.shape == "halfspace":
        return ("'halfspace' is unbounded and cannot be filled; expected a region of shape "
                f"'box' or {'disk' if dim == 2 else 'cylinder'!r}")
    if region.shape != "box" and (region.shape == "disk") != (dim == 2):
        return (f"shape {region.shape!r} is {5 - dim}D but the run is {dim}D (dim = {dim}); "
                f"expected 'box' or {'disk' if dim == 2 else 'cylinder'!r}")
    lo, hi = region_of(region).bounds()
    return list(lo), list(hi)


def _region_volume(region: Any, box: BoxSection) -> float:
    """Volume (area in 2D) of a bounded fill region, or of the box (``region`` None)."""
    return float((region_of(None, box.lo, box.hi) if region is None else region_of(region)).volume)


def _show_region(region: Any) -> str:
    if region.shape == "box":
        return f"lo {region.lo!r}, hi {region.hi!r}"
    return f"{region.shape} of radius {region.radius:g} around {region.center!r}"


def _overfull(pop: "RandomFill", where: str, volume: float, dim: int) -> list[str]:
    """A random fill whose grains would fill more than the densest packing of the region."""
    n = pop.count
    fractions = pop.fractions or [1.0] * len(pop.radius)
    each = [math.pi * r**2 if dim == 2 else 4.0 / 3.0 * math.pi * r**3 for r in pop.radius]
    grains = n * sum(f * v for f, v in zip(fractions, each)) / sum(fractions)
    densest = DENSEST_PACKING[dim]
    if grains <= densest * volume:
        return []
    return [f"{where}.count: {n} grains (radius {_show(pop.radius)}) would fill {grains:.4g} "
            f"of a region of {'area' if dim == 2 else 'volume'} {volume:.4g} (packing fraction "
            f"{grains / volume:.3g}); no packing exceeds {densest:.3f} and a random fill jams "
            f"near {0.55 if dim == 2 else 0.38}: ask for fewer grains or enlarge the region"]


def _unused_sections(data: dict[str, Any], scenario: Scenario) -> list[str]:
    allowed = COMMON_SECTIONS | scenario.uses
    known = set(RunConfig.model_fields)
    return [f"{key}: not used by scenario {scenario.name!r}; remove it (this scenario reads "
            f"{', '.join(sorted(allowed | ({scenario.section} - {None})))})"
            for key in data if key in known and key not in allowed]


def _run_fields_elsewhere(data: dict[str, Any], scenario: Scenario) -> list[str]:
    """``[run]`` fields the scenario takes from elsewhere (:attr:`Scenario.run_elsewhere`):
    refused, so that a value written there is never silently ignored."""
    run = data.get("run")
    if not isinstance(run, Mapping):
        return []
    return [f"run.{key}: not read by scenario {scenario.name!r}; {where}"
            for key, where in scenario.run_elsewhere.items() if key in run]


def saved_config_upgraded(data: Mapping[str, Any]) -> dict[str, Any]:
    """A run directory's saved config (``config.toml``) in today's form. Before the hopper
    scenarios refused ``run.dt_fraction`` (:attr:`Scenario.run_elsewhere`),
    :func:`resolved_dict` wrote the ``[run]`` default of such a field into every saved
    config; that default, never read, is dropped so that the run resumes and its sweep
    point still counts as the same configuration."""
    data = dict(data)
    run = data.get("run")
    try:
        scenario = get_scenario(str(data.get("scenario", "generic")))
    except ValueError:
        return data  # load_config names the unknown scenario
    if isinstance(run, Mapping):
        data["run"] = {key: value for key, value in run.items()
                       if not (key in scenario.run_elsewhere
                               and value == RunSection.model_fields[key].default)}
    return data


def resolved_dict(config: RunConfig) -> dict[str, Any]:
    """The configuration with defaults filled in, as plain data (TOML-writable): only the
    sections its scenario reads, so that the result loads again (a run directory's
    ``config.toml`` is what ``resume`` reads)."""
    entry = config.scenario_entry
    allowed = COMMON_SECTIONS | entry.uses
    data = {key: value for key, value in config.model_dump(exclude_none=True).items()
            if key in allowed or key not in RunConfig.model_fields}
    if config.section is not None and entry.section:
        data[entry.section] = config.section.model_dump(exclude_none=True)
    for key in entry.run_elsewhere:
        data["run"].pop(key, None)
    return data


# ------------------------------------------------------------------------------ errors
def format_errors(err: ValidationError, root: type[BaseModel], prefix: str = "") -> list[str]:
    """One ``path: value ... expected ...`` line per pydantic error."""
    lines = []
    for e in err.errors(include_url=False):
        path, parent, here = _path(root, e["loc"])
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
            if key == f"{_region_tag.__name__}()":  # the region union's tag is its shape
                key = "shape"
            tag = ctx.get("tag")
            shown = "missing" if tag is None else f"{tag!r} is not valid"
            tags = ctx.get("expected_tags") or ", ".join(repr(t) for t in _tags(here, key))
            lines.append(f"{path}.{key}: {shown}; expected one of {tags}")
        elif kind in ("value_error", "assertion_error"):
            msg = e["msg"].removeprefix("Value error, ")
            field = re.match(r"([A-Za-z_]\w*)[\w\[\]\.]*: ", msg)
            if path and field and _is_model(here) and field[1] in here.model_fields:
                lines.append(f"{path}.{msg}")  # a model validator naming one of its fields
            else:
                lines.append(f"{path}: {msg}" if path else msg)  # "": a top-level check
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


def _path(root: type[BaseModel], loc: tuple[Any, ...]) -> tuple[str, Any, Any]:
    """Dotted path of a pydantic ``loc`` (union tags dropped), the type holding its last
    item, and the type it ends in."""
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
    return text.lstrip("."), _unwrap(parent), _unwrap(t)


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


def _tags(union: Any, key: str) -> list[Any]:
    """The values of the discriminator ``key`` that the members of ``union`` accept."""
    return [tag for m in _union_members(union) if _is_model(m) and key in m.model_fields
            for tag in get_args(m.model_fields[key].annotation)]


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

