"""Scenario ``stream``: a cohesive granular stream falling out of a hopper aperture (SPEC S1;
seed 000 = Waitukaitis et al., PRE 83, 051302 (2011)).

Units are SI, written out in the ``[stream]`` table (``"200 um"``, ``"100 nN"``).

Geometry (fixed, and what :mod:`grainflow.analysis.stream` assumes): gravity along -z; a
cylindrical hopper of diameter ``D_h`` about the z axis with a flat base whose top surface is
the plane z = 0, pierced by a circular aperture of diameter ``D`` centred on the origin; the
stream falls along -z, so the *depth* below the aperture is ``-z``. Grains are monodisperse
glass spheres (type 0, diameter ``d``, density ``rho``); the walls are analytic
(:class:`~grainflow.walls.Cylinder`, :class:`~grainflow.walls.PlateWithHole`).

Set-up (seed 000, Appendix): grains are "rained into the hopper and allowed to settle under
gravity ... before the aperture is opened". Here ``n_hopper`` grains are placed at random
without overlap (random sequential addition) at a loose packing fraction
``rain_fraction`` in the hopper, with zero velocity, and fall onto the closed base (a lid in
the plane z = 0); the lid is removed at ``open_time``. From then on the hopper is replenished
at the top (:class:`~grainflow.insertion.ReplenishTo`): whenever fewer than ``n_hopper``
grains lie above the aperture plane, the missing ones are added at random in a slab
``REFILL_SLAB`` diameters deep above the bed, moving down at ``refill_speed``, so the fill
height stays constant on average (the seed keeps N_h, hence H,
constant). Grains deeper than ``stream_depth`` below the aperture, or farther than
``stream_radius`` from its axis, are deleted. The neighbour
search uses hashed cells, so the mostly empty 20 cm below the aperture costs nothing.

Contacts (SPEC M1 + M2, PARAMETERS.md seed 000): the linear spring-dashpot
``F_n = k_n delta - m_eff gamma_n v_n`` (the ``"mass"`` damping convention, m_eff = m/2 for
two grains) with ``k_n`` and ``gamma_n`` from the restitution ``e`` and the contact time
``t_c``: ``t_c = pi/sqrt(2 k_n/m - gamma_n^2/4)``, ``e = exp(-gamma_n t_c/2)``
(:func:`~grainflow.models.granular.stiffness_and_damping`); tangential ``k_t = k_n`` and
``gamma_t = gamma_n``, so the tangential restitution, defined by the same formula, equals
``e`` (the seed's "same coefficient of restitution for normal and tangential motion");
Coulomb friction ``mu``; the hysteretic constant-force cohesion ``F_c`` in a shell
``delta`` (:mod:`grainflow.models.cohesion_constant`), acting between grains only (the seed
describes cohesion "between grains"; ``wall_cohesion = true`` extends it to the walls).
The seed's parameter table is lost (PARAMETERS.md: k_n, k_t, gamma, mu, delta, D_h, H, dt
are NF); our choices are the defaults of :class:`StreamSection`, and docs/streams.md
reports what changing them does.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, model_validator

from grainflow.scenarios import Scenario, register
from grainflow.units import quantity

__all__ = ["DEFAULT_SKIN", "GRAVITY", "StreamSection", "build_stream", "grain_mass", "WALL_TYPE"]

#: Standard gravity (m/s^2), along -z.
GRAVITY = 9.81
#: Particle type of the analytic walls (grains are type 0).
WALL_TYPE = 1
#: Default Verlet skin in grain diameters. The engine's default (0.1 d) rebuilds the list
#: every ~8 steps once the stream falls at ~1 m/s; a quarter diameter every ~20. Measured on
#: a 0.12 s run of an 8,400-grain hopper (docs/streams.md): 70.3 s (0.1 d), 60.7 s (0.25 d),
#: 66.0 s (0.5 d, more pairs listed in the bed).
DEFAULT_SKIN = 0.25
#: The neighbour list's default check: the stream falls as a whole, so the list is rebuilt
#: when its grains may have moved a skin against each other, not when one has moved half a
#: skin (:mod:`grainflow.kernels.list_check`; measured in docs/streams.md).
DEFAULT_LIST_CHECK = "relative"
#: Depth of the slab the refill places grains in, in grain diameters (from 2 d above the
#: bed). The refill can add grains only as fast as the slab empties: at rest and 3 d deep it
#: passed about 60 grains/ms in the 5 mm hopper, less than the 3 mm aperture's 95, and the
#: hopper drained to half its N_h in 0.25 s (measured 2026-12-05; docs/streams.md).
REFILL_SLAB = 6.0


class StreamSection(BaseModel):
    """The ``[stream]`` table (SI units; the module docstring gives the model)."""

    model_config = ConfigDict(extra="forbid", validate_default=True)

    grain_diameter: quantity("length", gt=0) = Field(
        200e-6, description="d (seed: 200 um; 100 um for its Fig. 1)")
    density: quantity("density", gt=0) = Field(
        2500.0, description="grain density rho (glass; the seed prints 2.5 kg/m^3 for "
        "2.5e3, PARAMETERS.md)")
    aperture_diameter: quantity("length", gt=0) = Field(
        3e-3, description="D, the aperture in the hopper's base (seed: 3 mm; 2 mm for Fig. 1)")
    hopper_diameter: quantity("length", gt=0) = Field(
        7.5e-3, description="D_h (seed: NF; 2.5 D keeps the flow off the side wall)")
    fill_height: quantity("length", gt=0) = Field(
        6e-3, description="H, the bed height kept constant (seed: NF); sets n_hopper")
    n_hopper: StrictInt | None = Field(
        None, ge=1, description="grains kept above the aperture plane (seed: N_h); default: "
        "those filling H at packing fraction 0.6")
    restitution: float = Field(0.88, gt=0, le=1, allow_inf_nan=False,
                               description="e, normal and tangential (seed: 1.0, 0.88, 0.73, "
                               "0.61, 0.40)")
    contact_time: quantity("time", gt=0) = Field(
        50e-6, description="t_c of a binary collision, sets k_n (seed: NF; 50 us: k_n ~ 20 N/m "
        "at d = 200 um, overlaps below 0.5 % of d in the bed)")
    mu: float = Field(0.5, ge=0, allow_inf_nan=False, description="Coulomb friction (seed: NF)")
    cohesion_force: quantity("force", ge=0) = Field(
        0.0, description="F_c (seed: 1 to 2000 nN); 0: no cohesion")
    cohesion_range: quantity("length", gt=0) = Field(
        100e-9, description="delta, the shell in which F_c acts (seed: 'tens to hundreds of "
        "nm', NF)")
    wall_cohesion: StrictBool = Field(False, description="cohesion with the walls too")
    rain_fraction: float = Field(0.25, gt=0, le=0.3, allow_inf_nan=False,
                                 description="packing fraction of the rained-in grains")
    open_time: quantity("time", ge=0) = Field(
        0.08, description="the aperture opens at this time, after the bed settled")
    stream_depth: quantity("length", gt=0) = Field(
        0.22, description="grains deeper than this below the aperture are deleted (the seed "
        "follows the stream to ~20 cm)")
    stream_radius: quantity("length", gt=0) = Field(
        0.02, description="grains below the aperture farther than this from its axis are "
        "deleted (grains flung out of the stream; 7.6 cm/s sideways at e = 0.40 was seen)")
    replenish_every: StrictInt = Field(100, ge=1, description="steps between refills")
    refill_speed: quantity("velocity", ge=0) = Field(
        0.25, description="downward speed of the grains added above the bed: the refill "
        "must outpace the outflow (a warning says when it does not)")
    delete_every: StrictInt = Field(100, ge=1, description="steps between deletions")

    @model_validator(mode="after")
    def _check(self) -> "StreamSection":
        d = self.grain_diameter
        if not self.aperture_diameter > 2 * d:
            raise ValueError(f"stream.aperture_diameter: {self.aperture_diameter:g} m must "
                             f"exceed two grain diameters ({2 * d:g} m)")
        if not self.hopper_diameter > self.aperture_diameter + 2 * d:
            raise ValueError(f"stream.hopper_diameter: {self.hopper_diameter:g} m must exceed "
                             f"the aperture by two grain diameters "
                             f"({self.aperture_diameter + 2 * d:g} m)")
        if not self.fill_height > 2 * d:
            raise ValueError(f"stream.fill_height: {self.fill_height:g} m must exceed two "
                             "grain diameters")
        if not self.stream_radius >= 0.5 * self.hopper_diameter:
            raise ValueError(f"stream.stream_radius: {self.stream_radius:g} m must be at least "
                             f"the hopper's radius ({0.5 * self.hopper_diameter:g} m)")
        if not self.stream_depth > 2 * d:
            raise ValueError(f"stream.stream_depth: {self.stream_depth:g} m must exceed two "
                             "grain diameters")
        return self

    @property
    def grain_volume(self) -> float:
        return math.pi * self.grain_diameter**3 / 6.0

    def hopper_count(self) -> int:
        """N_h: ``n_hopper``, or the grains that fill H at packing fraction 0.6."""
        if self.n_hopper is not None:
            return self.n_hopper
        area = math.pi * (0.5 * self.hopper_diameter) ** 2
        return max(1, round(0.6 * area * self.fill_height / self.grain_volume))

    def contact_parameters(self) -> tuple[float, float]:
        """``(k_n, gamma_n)`` from ``(e, t_c)`` for two grains (m_eff = m/2, "mass"
        damping: PARAMETERS.md's t_c = pi/sqrt(2k_n/m - gamma_n^2/4), e = exp(-gamma_n t_c/2))."""
        from grainflow.models.granular import stiffness_and_damping

        return stiffness_and_damping(self.restitution, self.contact_time,
                                     0.5 * grain_mass(self), "mass")


def grain_mass(section: StreamSection) -> float:
    """m = rho pi d^3 / 6."""
    return section.density * section.grain_volume


def build_stream(section: StreamSection, *, seed: int = 0, dt: float | None = None,
                 dt_fraction: float = 0.02, skin: float | None = None,
                 sort_every: int = 10, list_check: str | None = None,
                 check_every: int = 100, max_overlap_fraction: float = 0.5,
                 integrator: str = "verlet") -> Any:
    """The hopper at t = 0 (module docstring): rained-in grains over a closed lid, walls,
    the M1 + M2 law, gravity, the lid's opening, replenishment and deletion. The keywords
    are the ``[run]`` fields of the same names."""
    from grainflow.engine.forces import Gravity
    from grainflow.engine.integrators import integrator_by_name
    from grainflow.engine.simulation import Simulation
    from grainflow.frame import Box
    from grainflow.insertion import (CylinderRegion, DeleteRegion, Monodisperse, ReplenishTo,
                                     random_fill)
    from grainflow.models.granular import GranularLaw
    from grainflow.scenarios.hopper import HopperLid
    from grainflow.state import ParticleState
    from grainflow.walls import Cylinder, Plane, PlateWithHole, WallForce

    rng = np.random.default_rng(seed)
    d = section.grain_diameter
    r = 0.5 * d
    r_h = 0.5 * section.hopper_diameter
    n = section.hopper_count()
    area = math.pi * (r_h - r) ** 2
    top = r + n * section.grain_volume / (section.rain_fraction * area)
    sizes = Monodisperse(d)
    x, radius = random_fill(CylinderRegion((0.0, 0.0), r_h - r, lo=r, hi=top), n, sizes, rng,
                            max_attempts=100_000)
    r_s = section.stream_radius
    box = Box(lo=np.array([-r_s, -r_s, -section.stream_depth]),
              hi=np.array([r_s, r_s, top]), periodic=(False, False, False))
    state = ParticleState(3, box)
    state.add_particles(x, radius, density=section.density, type=0)

    k_n, gamma_n = section.contact_parameters()
    law = GranularLaw(n_types=WALL_TYPE + 1)
    cohesion = {"cohesion_force": section.cohesion_force,
                "cohesion_range": section.cohesion_range}
    law.set_all(kn=k_n, kt=k_n, gamma_n=gamma_n, gamma_t=gamma_n, mu=section.mu,
                damping="mass", **cohesion)
    if not section.wall_cohesion:
        law.set_pair(0, WALL_TYPE, kn=k_n, kt=k_n, gamma_n=gamma_n, gamma_t=gamma_n,
                     mu=section.mu, damping="mass", cohesion_force=0.0,
                     cohesion_range=section.cohesion_range)
    step = dt if dt is not None else dt_fraction * section.contact_time
    if skin is None:
        skin = DEFAULT_SKIN * d
    sim = Simulation(state, step, law, skin=skin, sort_every=sort_every,
                     integrator=integrator_by_name(integrator),
                     list_check=list_check or DEFAULT_LIST_CHECK, check_every=check_every,
                     max_overlap_fraction=max_overlap_fraction, seed=seed)
    walls = [Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), r_h, inside=True,
                      axial_range=(0.0, math.inf)),
             PlateWithHole((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.5 * section.aperture_diameter)]
    sim.add_force(WallForce(walls, law, WALL_TYPE))
    sim.add_force(Gravity(np.array([0.0, 0.0, -GRAVITY])))
    if section.open_time > 0:
        lid = sim.add_force(WallForce([Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))], law,
                                      WALL_TYPE))
        sim.add_updater(HopperLid(sim, lid, section.open_time),
                        max(1, math.ceil(section.open_time / sim.dt)))
    bed = n * section.grain_volume / (0.6 * area)
    above = CylinderRegion((0.0, 0.0), r_h, lo=0.0, hi=math.inf)
    slab = CylinderRegion((0.0, 0.0), r_h - r, lo=bed + 2.0 * d,
                          hi=bed + (2.0 + REFILL_SLAB) * d)
    sim.add_updater(ReplenishTo(above, n, slab, sizes, density=section.density,
                                velocity=(0.0, 0.0, -section.refill_speed), type=0,
                                shortfall_warning=0.05),
                    section.replenish_every)
    sim.add_updater(DeleteRegion(CylinderRegion((0.0, 0.0), r_s, lo=-section.stream_depth,
                                                hi=math.inf), outside=True),
                    section.delete_every)
    return sim


def _build(config: Any) -> Any:
    if config.dim != 3:
        raise ValueError(f"dim: scenario stream is 3D; got dim = {config.dim}")
    section = config.section
    if not isinstance(section, StreamSection):
        raise ValueError("stream: the [stream] section is missing")
    run = config.run
    return build_stream(section, seed=run.seed, dt=run.dt, dt_fraction=run.dt_fraction,
                        skin=run.skin, sort_every=run.sort_every, list_check=run.list_check,
                        check_every=run.check_every,
                        max_overlap_fraction=run.max_overlap_fraction,
                        integrator=run.integrator)


register(Scenario("stream", "grainflow.scenarios.stream:_build", section="stream",
                  model=StreamSection,
                  description="seed 000: a cohesive granular stream falling out of a "
                              "replenished cylindrical hopper (SI units)"))
