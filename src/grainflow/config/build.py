"""From a validated :class:`~grainflow.config.schema.RunConfig` to a ready-to-run Simulation.

:func:`build_simulation` is the entry point: it calls the scenario's builder, then applies
what every scenario shares (the time step, its stability check, FIRE relaxation).
Scenario builders create their :class:`Simulation` with :func:`make_simulation`, which takes
the ``[run]`` settings (integrator, skin, seed, health checks) from the config.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from grainflow.config.regions import region_of
from grainflow.config.schema import (DRAG_BOTH, ConfigError, DataFile, LatticeFill, ListFill,
                                     RandomFill, RunConfig, SizedPopulation)
from grainflow.engine.forces import Drag, Gravity
from grainflow.engine.integrators import integrator_by_name
from grainflow.engine.simulation import Simulation, TimeStepError
from grainflow.frame import Box
from grainflow.models.base import ContactLaw
from grainflow.models.submodel import SLOTS
from grainflow.engine.minimize import relax
from grainflow.state import ParticleState

__all__ = ["build_chute", "build_generic", "build_simulation", "make_laws", "make_simulation",
           "relax", "total_steps"]


def build_simulation(config: RunConfig, *, prepare: bool = True) -> Simulation:
    """Build the run's simulation at step 0.

    ``prepare``: also relax overlaps with FIRE when ``run.minimize`` is set (skip it when a
    checkpoint will be loaded into the result anyway). A ``run.dt`` past the stability limit
    t_c/4 of the built particles is refused here (ConfigError ``run.dt: ...``), unless
    ``run.allow_unsafe_dt``.
    """
    with _config_errors():
        sim = config.scenario_entry.build(config)
    run = config.run
    sim.allow_unsafe_dt = run.allow_unsafe_dt
    try:
        sim.check_time_step()
    except TimeStepError as err:
        raise ConfigError([_time_step_message(config, sim, err)]) from None
    if prepare and run.minimize:
        relax(sim)
    return sim


#: Longest run accepted, in steps (a million particle-steps per second gives 10^12 steps of
#: one particle in 12 days): beyond, a duration or step count is surely a typo.
MAX_STEPS = 10**12


def total_steps(config: RunConfig, sim: Simulation) -> int:
    """The run's length in steps (``run.steps``, or ``ceil(run.duration / dt)``);
    ConfigError past :data:`MAX_STEPS`."""
    run = config.run
    if run.steps is not None:
        steps, field = run.steps, f"run.steps: {run.steps}"
    else:
        steps = max(1, math.ceil(run.duration / sim.dt - 1e-9))
        field = f"run.duration: {run.duration:g} at dt = {sim.dt:g} gives {steps:.3g} steps, which"
    if steps > MAX_STEPS:
        raise ConfigError([f"{field} is more than {MAX_STEPS:.0e} steps; expected a run "
                           "length that can finish (check the units)"])
    return steps


def make_simulation(config: RunConfig, state: ParticleState,
                    laws: ContactLaw | list[tuple[ContactLaw, list | None]] | None, *,
                    default_dt: float | None = None, default_skin: float | None = None
                    ) -> Simulation:
    """A Simulation with the ``[run]`` settings and the given pair interactions.

    ``laws``: one law for every type pair, or ``(law, type pairs)`` items
    (:func:`make_laws`). The time step is ``run.dt``, else the scenario's ``default_dt``,
    else ``run.dt_fraction`` times the shortest oscillation time of the pair interactions
    (capped by their relaxation times, :meth:`Simulation.stable_time_step`); forces added
    later (walls, tethers, drag) are checked against it when the build is done.
    """
    run = config.run
    sim = Simulation(state, run.dt or default_dt or 1.0, skin=run.skin or default_skin,
                     integrator=integrator_by_name(run.integrator), sort_every=run.sort_every,
                     list_check=run.list_check or "absolute", check_every=run.check_every,
                     max_overlap_fraction=run.max_overlap_fraction, seed=run.seed)
    if isinstance(laws, ContactLaw):
        laws = [(laws, None)]
    for law, types in laws or []:
        sim.add_interaction(law, types)
    if run.dt is None and default_dt is None:
        dt = sim.stable_time_step(run.dt_fraction)
        if not math.isfinite(dt):
            cause = ("there are no particles at step 0 (only [[insert]] adds them later)"
                     if state.n == 0 else "without a contact law")
            raise ConfigError([f"run.dt: missing; {cause} there is no contact time to derive "
                               "it from, so give dt explicitly"])
        sim.dt = dt
    return sim


def _time_step_message(config: RunConfig, sim: Simulation, err: TimeStepError) -> str:
    """``run.dt: ...`` for a time step the engine refused: the limit and what to write."""
    run = config.run
    if run.dt is None:  # the scenario's own default dt
        return f"run.{err}"
    if config.scenario == "generic":  # its default is run.dt_fraction x t_c
        fix = "or leave dt out to get dt_fraction x the shortest time scale"
    else:
        fix = f"or leave dt out for the {config.scenario} scenario's default"
    return f"run.{err}, {fix}"


@contextmanager
def _config_errors() -> Iterator[None]:
    """Turn ValueErrors of the engine's constructors into ConfigErrors."""
    try:
        yield
    except ConfigError:
        raise
    except ValueError as err:
        raise ConfigError([str(err)]) from None


# ------------------------------------------------------------------------------ generic
def build_generic(config: RunConfig) -> Simulation:
    """The ``generic`` scenario: box, particle populations, laws per type pair, forces."""
    if config.box is None:
        raise ConfigError(["box: missing; the generic scenario needs [box] with lo and hi"])
    if config.drag is not None and config.drag_rate is not None:
        raise ConfigError([DRAG_BOTH])  # refused on load too; this is for a config edited since
    box = config.box
    periodic = tuple(box.periodic) if box.periodic is not None else (False,) * config.dim
    state = ParticleState(config.dim, Box(np.array(box.lo), np.array(box.hi), periodic))
    rng = np.random.default_rng([config.run.seed, 0x6275696C64])  # "build": fills, sizes
    errors: list[str] = []
    for k, pop in enumerate(config.particles):
        first = state.n
        try:
            _add_population(state, pop, rng)
        except ValueError as err:
            errors.append(_at(f"particles[{k}]", pop, err))
            continue
        errors += _misplaced(config, state, k, pop, np.arange(first, state.n))
    if not config.particles and not config.insert:
        errors.append("particles: no particles are defined; add a [[particles]] table (fill = "
                      "\"lattice\", \"random\", \"list\" or \"lammps_data\", docs/config.md) "
                      "or an [[insert]] updater")
    if config.walls and config.contact is None:
        errors.append("walls: need a [contact] law (walls touch particles through it); add "
                      "a [contact] table")
    if errors:
        raise ConfigError(errors)
    laws = make_laws(config, _type_masses(state)) if config.contact is not None else None
    sim = make_simulation(config, state, laws)
    _add_walls(config, sim)
    _add_tethers(config, sim)
    _add_updaters(config, sim)
    if config.gravity is not None:
        sim.add_force(Gravity(config.gravity))
    if config.drag is not None:
        sim.add_force(Drag(np.array(config.drag)))
    if config.drag_rate is not None:
        sim.add_force(Drag(np.array(config.drag_rate), per_mass=True))
    return sim


def _at(where: str, pop, err: ValueError) -> str:
    """``where.field: ...`` when the message starts with a field of ``pop``, else
    ``where: ...``; a data file's own message goes to ``where.file``."""
    msg = str(err)
    field = re.match(r"([A-Za-z_]\w*)[\w\[\]]*: ", msg)
    if field and field[1] in type(pop).model_fields:
        return f"{where}.{msg}"
    if isinstance(pop, DataFile):
        return f"{where}.file: {msg}"
    return f"{where}: {msg}"


def _add_population(state: ParticleState, pop, rng: np.random.Generator) -> None:
    if isinstance(pop, DataFile):
        from grainflow.insertion.lammps_data import read_lammps_data

        data = read_lammps_data(pop.file)
        v = data.v if pop.velocity is None else np.broadcast_to(pop.velocity, data.v[:, :state.dim].shape)
        frozen = np.isin(data.type, pop.frozen_types) | pop.frozen
        idx = state.add_particles(data.x[:, :state.dim], 0.5 * data.diameter, density=data.density,
                                  v=v, omega=data.omega, type=data.type - 1 + pop.type,
                                  frozen=frozen, ids=data.id + _first_free_id(state))
        state.image[idx] = data.image
        return
    v = pop.velocity
    if isinstance(pop, ListFill):
        x = np.array(pop.positions)
        radius = _radii(pop, len(x), rng)
        if pop.velocities is not None:
            v = np.array(pop.velocities)
    elif isinstance(pop, RandomFill):
        from grainflow.insertion.random_fill import random_fill

        x, radius = random_fill(_region(pop.region, state.box), pop.count,
                                _radii(pop, pop.count, rng), rng, existing_x=state.x,
                                existing_radius=state.radius, max_attempts=pop.max_attempts)
    else:
        x = _lattice_sites(pop, state, rng)
        radius = _radii(pop, len(x), rng)
    mass_kw = {"mass": pop.mass} if pop.mass is not None else {"density": pop.density or 1.0}
    state.add_particles(x, radius, v=_velocities(v, len(x), state.dim), type=pop.type,
                        frozen=pop.frozen, **mass_kw)


def _first_free_id(state: ParticleState) -> int:
    return int(state.id.max()) + 1 if state.n else 0


def _lattice_sites(pop: LatticeFill, state: ParticleState, rng: np.random.Generator) -> np.ndarray:
    """The sites of a lattice fill; a fill of more than ``MAX_LATTICE_SITES`` sites is refused
    before anything is allocated, naming the field that sets the spacing."""
    from grainflow.insertion.lattice import MAX_LATTICE_SITES, lattice_fill, lattice_site_count

    rmax = max(pop.radius)
    kind = pop.lattice or ("triangular" if state.dim == 2 else "fcc")
    spacing = pop.spacing or 2.2 * rmax
    region = _region(pop.region, state.box)
    sites = lattice_site_count(region, spacing, kind, rmax)
    if sites > MAX_LATTICE_SITES:
        if pop.packing_fraction is None:
            asked = "every site is a particle"
        else:
            grain = math.pi * rmax**2 if state.dim == 2 else 4.0 / 3.0 * math.pi * rmax**3
            asked = (f"packing_fraction {pop.packing_fraction:g} asks for about "
                     f"{pop.packing_fraction * region.volume / grain:.3g} particles")
        field = (f"spacing: {pop.spacing!r}" if pop.spacing is not None else
                 f"radius: {_show_radius(pop.radius)} (spacing 2.2 x the largest radius)")
        raise ValueError(f"{field} would make {sites:.3g} {kind} lattice sites in the region "
                         f"({asked}); at most {MAX_LATTICE_SITES:,} are allowed: use a larger "
                         "radius or spacing, or a smaller region (check the units)")
    x = lattice_fill(region, spacing, kind, rmax, packing_fraction=pop.packing_fraction,
                     rng=rng)
    if len(x) == 0:
        raise ValueError(f"region: holds no {kind} site of spacing {spacing:g} at least "
                         f"{rmax:g} (the largest radius) from its boundary; enlarge it")
    return x


def _show_radius(radius: list[float]) -> str:
    return f"{radius[0]!r}" if len(radius) == 1 else f"{radius!r}"


def _misplaced(config: RunConfig, state: ParticleState, k: int, pop,
               idx: np.ndarray) -> list[str]:
    """Particles of population ``k`` (rows ``idx``, frozen ones left out) that start where
    they surely should not: a data file's atoms outside the box on a non-periodic axis
    (the fills are checked on load), and any centre behind a wall that divides space: behind
    a plane, or on the wrong side of an infinite cylinder (outside a tube, inside a post)."""
    where = f"particles[{k}]"
    x = state.x[idx, :state.dim]
    out = []
    if isinstance(pop, DataFile):
        box = state.box
        for a in range(state.dim):
            if box.periodic[a]:
                continue
            bad = (x[:, a] < box.lo[a]) | (x[:, a] > box.hi[a])
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                out.append(f"{where}.file: {int(bad.sum())} atom(s) lie outside the box on "
                           f"axis {'xyz'[a]} (box {box.lo[a]:g} to {box.hi[a]:g}, not periodic), "
                           f"e.g. atom id {int(state.id[idx[i]])} at {x[i].tolist()}; enlarge "
                           "[box] or make the axis periodic")
    moving = ~state.frozen[idx]
    x3 = np.zeros((len(idx), 3))
    x3[:, :state.dim] = x
    for w, wall in enumerate(config.walls):
        behind, side, shape = _behind_wall(wall, x3)
        bad = behind & moving
        if not bad.any():
            continue
        rows = np.flatnonzero(bad)
        if isinstance(pop, ListFill):
            more = f" (and {rows.size - 1} more)" if rows.size > 1 else ""
            out.append(f"{where}.positions[{rows[0]}]: {pop.positions[rows[0]]!r} lies {side} "
                       f"walls[{w}] ({shape}){more}; move it to the wall's acting side or "
                       "change the wall")
        else:
            field = "file" if isinstance(pop, DataFile) else "region"
            out.append(f"{where}.{field}: {rows.size} of {len(idx)} particles lie {side} "
                       f"walls[{w}] ({shape}), e.g. at {x[rows[0]].tolist()}; move them to "
                       "the wall's acting side or change the wall")
    return out


def _behind_wall(wall, x3: np.ndarray) -> tuple[np.ndarray, str, str]:
    """Which centres ``x3`` (N, 3) lie on the side of ``wall`` that it never acts on, for the
    walls that divide space (planes, infinite cylinders); where that is and the wall, in
    words. A wall whose fields do not make a shape is left to :func:`_add_walls`."""
    from grainflow.walls import Cylinder, Plane

    none = np.zeros(len(x3), dtype=bool)
    try:
        shapes = wall_shapes(wall)
    except ValueError:
        return none, "", ""
    shape = shapes[0] if len(shapes) == 1 else None
    if isinstance(shape, Plane):
        return ((x3 - shape.point) @ np.array(shape.normal) < 0, "behind",
                f"a plane through {wall.point!r} acting on the side its normal "
                f"{wall.normal!r} points to")
    if isinstance(shape, Cylinder) and not any(map(math.isfinite, shape.axial_range)):
        a = np.array(shape.axis_direction)
        d = x3 - shape.axis_point
        r = np.linalg.norm(d - np.outer(d @ a, a), axis=1)
        kind = "tube" if shape.inside else "post"
        return ((r > shape.radius) if shape.inside else (r < shape.radius),
                "outside" if shape.inside else "inside",
                f"an infinite {kind} of radius {shape.radius:g} around {wall.axis_point!r}, "
                f"inside = {str(shape.inside).lower()}")
    return none, "", ""


def _region(region, box: Box):
    return region_of(region, box.lo, box.hi)


def _add_tethers(config: RunConfig, sim: Simulation) -> None:
    """One Tethers force per ``[[tethers]]``; its particles become one body (wall-wall pairs
    then interact only through the tethers, as M5 requires)."""
    from grainflow.engine.tethers import Tethers, neighbor_bonds

    st = sim.state
    for k, tether in enumerate(config.tethers):
        mine = st.type == tether.type
        if not mine.any():
            raise ConfigError([f"tethers[{k}].type: {tether.type} is not valid; no particle "
                               "has this type"])
        st.body[mine] = int(st.body.max()) + 1
        ids = st.id[mine].copy()
        bonds = (neighbor_bonds(st, ids, tether.bond_cutoff)
                 if tether.bond_cutoff is not None else None)
        sim.add_force(Tethers(ids, tether.k, tether.eta, bonds=bonds))


def _add_updaters(config: RunConfig, sim: Simulation) -> None:
    """``[[insert]]`` (Pour, ReplenishTo) then ``[[delete]]`` (DeleteRegion) updaters."""
    from grainflow import insertion

    box = sim.state.box
    for k, ins in enumerate(config.insert):
        r = sorted(ins.radius)
        sizes = (insertion.Monodisperse(2 * r[0]) if len(r) == 1 else
                 insertion.Bidisperse(2 * r[0], r[1] / r[0]))
        common = {"density": ins.density, "velocity": ins.velocity, "type": ins.type,
                  "max_attempts": ins.max_attempts}
        try:
            if ins.kind == "pour":
                updater = insertion.Pour(_region(ins.region, box), sizes, ins.per_insertion,
                                         total=ins.total, **common)
            else:
                updater = insertion.ReplenishTo(
                    _region(ins.count_region, box), ins.target, _region(ins.region, box), sizes,
                    types=ins.types, **common)
        except ValueError as err:
            raise ConfigError([f"insert[{k}].{err}"]) from None
        sim.add_updater(updater, ins.every)
    for k, rule in enumerate(config.delete):
        try:
            region = _region(rule.region, box)
        except ValueError as err:
            raise ConfigError([f"delete[{k}].region.{err}"]) from None
        sim.add_updater(insertion.DeleteRegion(region, outside=rule.outside, types=rule.types),
                        rule.every)


def _add_walls(config: RunConfig, sim: Simulation) -> None:
    """One WallForce per wall type and pair law: the particles of each type meet the walls
    through the law of their (particle type, wall type) pair."""
    if not config.walls:
        return
    from grainflow.walls import WallForce

    by_type: dict[int, list] = {}
    for k, wall in enumerate(config.walls):
        try:
            shapes = wall_shapes(wall)
        except ValueError as err:
            raise ConfigError([f"walls[{k}].{err}"]) from None
        if config.dim == 2 and not all(shape.planar() for shape in shapes):
            raise ConfigError([f"walls[{k}]: a {wall.shape!r} wall with these fields does not "
                               "lie in the z = 0 plane of a 2D run; expected a segment, a plane "
                               "with a normal in the plane, or a cylinder along z without lids"])
        by_type.setdefault(wall.type, []).extend(shapes)
    particle_types = sorted({int(t) for t in np.unique(sim.state.type)}
                            | {p.type for p in config.particles} | {i.type for i in config.insert})
    for wall_type, shapes in by_type.items():
        by_law: dict[int, tuple[ContactLaw, list[int]]] = {}
        for t in particle_types:
            law = _law_of(sim, t, wall_type)
            by_law.setdefault(id(law), (law, []))[1].append(t)
        for law, types in by_law.values():
            try:
                sim.add_force(WallForce(shapes, law, wall_type,
                                        None if len(by_law) == 1 else types))
            except ValueError as err:
                raise ConfigError([f"walls (type {wall_type}): {err}"]) from None


def _law_of(sim: Simulation, a: int, b: int) -> ContactLaw:
    """The law of the interaction that owns the type pair (a, b)."""
    pair = (min(a, b), max(a, b))
    for interaction in sim.interactions:
        if interaction.types is not None and pair in interaction.types:
            return interaction.law
    return next(i.law for i in sim.interactions if i.types is None)


def wall_shapes(wall) -> list:
    """The :mod:`grainflow.walls` shapes of one ``[[walls]]`` entry."""
    from grainflow.walls import geometry as g

    velocity = tuple(wall.velocity) if wall.velocity is not None else (0.0, 0.0, 0.0)
    params = wall.model_dump(exclude={"type", "velocity", "shape"}, exclude_none=True)
    if wall.shape == "hopper2d":
        return g.Hopper2D(**params, velocity=velocity).segments()
    if wall.shape == "cone" and wall.lammps_form:  # may be a Cylinder (equal radii)
        return [g.Cone.from_lammps(wall.axis, *wall.center, wall.radius_lo, wall.radius_hi,
                                   wall.lo, wall.hi, inside=wall.inside, lid_lo=wall.lid_lo,
                                   lid_hi=wall.lid_hi, velocity=velocity)]
    cls = {"plane": g.Plane, "segment": g.Segment, "cylinder": g.Cylinder, "cone": g.Cone,
           "plate_with_hole": g.PlateWithHole}[wall.shape]
    return [cls(**params, velocity=velocity)]


def _radii(pop: SizedPopulation, n: int, rng: np.random.Generator) -> np.ndarray:
    """Radii of ``n`` particles: exact number fractions, randomly assigned."""
    radii = np.array(pop.radius)
    if radii.size == 1:
        return np.full(n, radii[0])
    frac = np.array(pop.fractions) if pop.fractions is not None else np.ones(radii.size)
    counts = np.floor(frac / frac.sum() * n).astype(int)
    counts[: n - counts.sum()] += 1
    return rng.permutation(np.repeat(radii, counts))


def _velocities(v, n: int, dim: int) -> np.ndarray:
    if v is None:
        return np.zeros((n, dim))
    return np.broadcast_to(np.asarray(v, dtype=float), (n, dim)).copy()


def _type_masses(state: ParticleState) -> dict[int, float]:
    """Mean particle mass of every type present."""
    return {int(t): float(state.mass[state.type == t].mean()) for t in np.unique(state.type)}


def make_laws(config: RunConfig, type_mass: dict[int, float]
              ) -> list[tuple[ContactLaw, list[tuple[int, int]] | None]]:
    """The pair laws of ``[contact]``: one :class:`ContactLaw` per distinct composition with
    its type pairs (None for the only one: it owns every pair), one table row per pair.

    A type pair given by restitution and contact time is converted with the effective mass
    of the two types' mean masses; a type without particles (a wall) is infinitely heavy.
    """
    contact = config.contact
    n = config.n_types()
    fallback = float(np.mean(list(type_mass.values()))) if type_mass else 1.0
    groups: dict[tuple[str, ...], tuple[ContactLaw, list[tuple[int, int]]]] = {}
    for a in range(n):
        for b in range(a, n):
            models, params = contact.entry(a, b)
            key = tuple(models[s] for s in SLOTS)
            if key not in groups:
                groups[key] = (ContactLaw(n, **models), [])
            law, pairs = groups[key]
            where = ("contact" if contact.entry(a, b) is contact.entry(-1, -1)
                     else f"contact.pairs (types [{a}, {b}])")
            try:
                meff = _meff(type_mass.get(a), type_mass.get(b), fallback)
                law.set_pair(a, b, **law.resolve(params, meff))
            except ValueError as err:
                raise ConfigError([f"{where}: {err}"]) from None
            pairs.append((a, b))
    if len(groups) == 1:
        return [(law, None) for law, _ in groups.values()]
    return list(groups.values())


def _meff(ma: float | None, mb: float | None, fallback: float) -> float:
    if ma is None and mb is None:
        return fallback / 2
    if ma is None or mb is None:
        return ma if mb is None else mb
    return ma * mb / (ma + mb)


# -------------------------------------------------------------------------------- chute
def build_chute(config: RunConfig) -> Simulation:
    """The ``chute`` scenario: LAMMPS's granular chute deck on its data file."""
    from grainflow.insertion.lammps_data import read_lammps_data
    from grainflow.scenarios.chute import CHUTE, chute_law, chute_state

    if config.dim != 3:
        raise ConfigError([f"dim: {config.dim} is not valid; the chute is 3D (dim = 3)"])
    section = config.section
    try:
        data = read_lammps_data(section.data_file)
    except ValueError as err:
        raise ConfigError([f"chute.data_file: {err}"]) from None
    state = chute_state(data, tuple(section.replicate))
    law = chute_law()
    sim = make_simulation(config, state, law, default_dt=CHUTE["dt"], default_skin=CHUTE["skin"])
    sim.add_force(Gravity.chute(1.0, section.angle))
    return sim
