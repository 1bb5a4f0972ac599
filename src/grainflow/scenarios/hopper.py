"""Scenarios ``hopper2d`` and ``hopper3d``: continuous hopper flow of soft particles after seed
003 (Cheng et al., "Hopper flows of deformable particles", Soft Matter 18, 8071 (2022)).

Units (the seed's): lengths in sigma_avg = (sigma_s + sigma_l)/2 = 1.2 sigma_s, gravity g = 1,
and the areal (2D) / volume (3D) mass density rho = 1, so a grain's mass is its area
pi sigma^2/4 (2D) or volume pi sigma^3/6 (3D) (seed Sec. 2.2: M_m = rho a_m, rho V_m; the
average-sized grain is *not* of mass 1). Then

    t0 = sqrt(sigma_avg / g) = 1,   zeta0 = mu0 = rho sigma_avg^d / t0 = 1,
    E_sp = eps_sp / (g rho sigma_avg^(d+1)) = eps_sp,   E_w = eps_w,   Q0 = sigma_avg^d/t0 = 1,

so every number of the seed is used as written. Gravity points along -y (2D) and -z (3D)
(the seed's Fig. 1 has it left to right); the orifice lies in the plane y = 0 (z = 0) and the
analyses take ``up`` = +y (+z), their default.

Model (SPEC M3): bidisperse 50:50 disks/spheres, sigma_l/sigma_s = 1.4 (particle types 0 =
small, 1 = large; the walls are type 2). Pair energy (eps_sp/2)(1 - r/sigma_mn)^2, wall energy
(eps_w/2)(1 - 2 d_w/sigma_m)^2, both through :class:`~grainflow.models.soft.SoftLaw`; drag
F = -f_d zeta v (:class:`~grainflow.engine.forces.Drag`; f_d = ``drag_factor`` = 16 by
default, see :class:`HopperSection`: our reading of the illegible eq. 5); kinetic friction
-mu sum (v_m - v_n) between touching grains (not with walls). lambda = zeta/mu; the seed's
limits are lambda -> 0: mu/mu0 = 10 sqrt(10), zeta = 0 and lambda -> inf: zeta/zeta0 = 1/sqrt(10),
mu = 0. For finite lambda the seed gives no magnitudes; we interpolate between the limits::

    mu = mu_0lim / (1 + lambda/lambda*),  zeta = zeta_inflim (lambda/lambda*) / (1 + lambda/lambda*),
    lambda* = zeta_inflim / mu_0lim = 1/100,

so that zeta/mu = lambda exactly and both limits are recovered.

Geometry: 2D side walls W apart (default 60 sigma_s = 50 sigma_avg, PARAMETERS.md) and a
bottom at angle theta_w (:class:`~grainflow.walls.Hopper2D`) with a centred orifice w; 3D an
infinite cylinder of diameter W (default 30 sigma_s = 25 sigma_avg) with a flat base with a
circular orifice of diameter w (:class:`~grainflow.walls.PlateWithHole`).

Initialisation (seed Sec. 2.4): grains are placed at random without overlap (random
sequential addition at packing fraction ``fill_fraction``) in the hopper above the bottom,
with zero velocity; FIRE (``run.minimize = true``, gravity off) removes any overlap left
(with walls included); then gravity is on at t = 0. Continuous flow and crossing events:
:mod:`grainflow.scenarios.hopper_reinsertion`.

Time step (the seed's value is illegible, PARAMETERS.md "NF"): ``dt = dt_fraction * t_c``
with t_c the shortest contact time of the pair law *and* of the walls (a wall contact of a
small grain, t_c = pi sqrt(m_s r_s^2 / eps_w), is usually the stiffest); ``dt_fraction`` =
1/20 by default, and at most 0.2 m_eff/mu, the relaxation time of the kinetic friction of
two small grains over 5 (:meth:`~grainflow.engine.simulation.Simulation.stable_time_step`
over every interaction). docs/hopper_study.md shows that halving it leaves Q unchanged.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, StrictInt, model_validator

from grainflow.scenarios import Scenario, register
from grainflow.scenarios.hopper_reinsertion import HopperReinsertion
from grainflow.engine.minimize import relax

if TYPE_CHECKING:
    from grainflow.engine.simulation import Simulation

__all__ = ["DIAMETER_RATIO", "HopperSection", "LIMIT_MU", "LIMIT_ZETA", "SIGMA_SMALL",
           "build_hopper", "build_hopper2d", "build_hopper3d", "dissipation",
           "hopper_segments", "hopper_updater", "prepare"]

#: Large/small diameter ratio (seed Sec. 2.2).
DIAMETER_RATIO = 1.4
#: Small diameter in units of sigma_avg = (sigma_s + sigma_l)/2 = 1.2 sigma_s.
SIGMA_SMALL = 2.0 / (1.0 + DIAMETER_RATIO)
#: mu/mu0 in the lambda -> 0 limit and zeta/zeta0 in the lambda -> inf limit (seed Sec. 4).
LIMIT_MU = 10.0 * math.sqrt(10.0)
LIMIT_ZETA = 1.0 / math.sqrt(10.0)
#: Default drag multiplier: the SP drag on a grain is -DRAG_FACTOR * zeta * v (see
#: :class:`HopperSection` ``drag_factor`` and docs/hopper_study.md). 16 = N_v, the number of
#: vertices of the seed's DP particles, each of which feels -zeta v (seed eq. 11).
DRAG_FACTOR = 16.0
#: Particle types: 0 small, 1 large, 2 walls.
WALL_TYPE = 2
#: File of a run's crossing events (read by :mod:`grainflow.studies.hopper_results`).
EVENTS = "events.csv"


class HopperSection(BaseModel):
    """The ``[hopper]`` table (seed units: sigma_avg = g = rho = 1, see module docstring).

    Counts are strict integers (a string such as ``"1600"`` is refused); every number but
    ``lam`` is finite (``E_sp = inf`` is refused here, naming ``hopper.E_sp``).
    """

    model_config = ConfigDict(extra="forbid", validate_default=True)

    n: StrictInt | None = Field(None, ge=2,
                                description="number of grains; default 1600 (2D), 6400 (3D)")
    orifice_width: float = Field(6.0, gt=0, allow_inf_nan=False,
                                 description="w / sigma_avg (3D: orifice diameter)")
    width: float | None = Field(None, gt=0, allow_inf_nan=False,
                                description="W / sigma_avg: side-wall separation (2D, default "
                                "50 = 60 sigma_s) or cylinder diameter (3D, 25)")
    theta_w: float = Field(90.0, gt=0, le=90, description="2D bottom angle in degrees (90 flat)")
    E_sp: float = Field(100.0, gt=0, allow_inf_nan=False,
                        description="pair stiffness eps_sp/(g rho sigma_avg^(d+1))")
    E_w: float = Field(1.0e4, gt=0, allow_inf_nan=False,
                       description="wall stiffness eps_w/(g rho sigma_avg^(d+1))")
    lam: float = Field(math.inf, ge=0, description="lambda = zeta/mu; 0 and inf are the "
                       "seed's limits (write inf in TOML)")
    zeta: float | None = Field(None, ge=0, allow_inf_nan=False,
                               description="explicit drag (overrides lam)")
    drag_factor: float = Field(DRAG_FACTOR, gt=0, allow_inf_nan=False,
                               description="drag force on a grain = "
                               "-drag_factor * zeta * v. Seed eq. (5) is illegible; 16 = N_v "
                               "(the DP model's per-vertex drag, eq. 11, summed over its 16 "
                               "vertices) reproduces the seed's flow rates, 1 is a literal "
                               "-zeta v (docs/hopper_study.md)")
    mu: float | None = Field(None, ge=0, allow_inf_nan=False,
                             description="explicit kinetic friction (overrides lam)")
    fill_fraction: float = Field(0.45, gt=0, lt=0.6, description="packing fraction of the "
                                 "initial random fill (2D; 3D uses 0.6 of it)")
    reinsert_depth: float = Field(2.0, gt=0, allow_inf_nan=False,
                                  description="reinsert after falling this many own "
                                  "diameters below the orifice (seed: 2)")
    reinsert_every: StrictInt = Field(10, ge=1, description="steps between crossing checks")
    reinsert_bulk_contacts: StrictInt | None = Field(
        None, ge=0, description="a reinserted grain's partner must touch or nearly touch this "
        "many grains (a 'bulk particle' of the seed); default d + 1; 0: the highest grain of "
        "the column (docs/hopper_study.md)")
    dt_fraction: float = Field(0.05, gt=0, le=0.25, description="dt = dt_fraction * t_c (pairs "
                               "and walls) unless run.dt is given")

    @model_validator(mode="after")
    def _check(self) -> "HopperSection":
        if (self.zeta is None) != (self.mu is None):
            raise ValueError("zeta/mu: give both (explicit dissipation) or neither (use lam)")
        if self.width is not None and not self.orifice_width < self.width:
            raise ValueError(f"orifice_width: {self.orifice_width} must be below the hopper "
                             f"width {self.width}")
        return self


def dissipation(section: HopperSection) -> tuple[float, float]:
    """``(zeta, mu)`` from ``section`` (explicit values, or lambda as in the module docs)."""
    if section.zeta is not None and section.mu is not None:
        return section.zeta, section.mu
    lam = section.lam
    if lam == 0.0:
        return 0.0, LIMIT_MU
    if math.isinf(lam):
        return LIMIT_ZETA, 0.0
    s = lam / (LIMIT_ZETA / LIMIT_MU)
    return LIMIT_ZETA * s / (1.0 + s), LIMIT_MU / (1.0 + s)


def _defaults(section: HopperSection, dim: int) -> tuple[int, float]:
    n = section.n if section.n is not None else (1600 if dim == 2 else 6400)
    width = section.width if section.width is not None else (
        60.0 if dim == 2 else 30.0) * SIGMA_SMALL
    if not section.orifice_width < width:
        raise ValueError(f"hopper.orifice_width: {section.orifice_width} must be below the "
                         f"hopper width {width:g}")
    return n, width


def build_hopper(section: HopperSection, dim: int, *, seed: int = 0, dt: float | None = None,
                 skin: float | None = None, sort_every: int = 10, check_every: int = 100,
                 max_overlap_fraction: float = 1.0) -> "Simulation":
    """The hopper at t = 0: random fill (not yet relaxed, see :func:`prepare`), walls, law,
    gravity, drag and the reinsertion updater (:func:`hopper_updater` finds it).

    ``max_overlap_fraction`` (the health check) is 1.0 of the smaller radius by default: at
    the seed's E_sp = 100 the grains at the bottom of a 1600-grain pile overlap by about
    0.6 r_s under its weight (overlap/sigma ~ weight of the column / eps_sp), which is the
    physics of the soft model, not an instability.
    """
    from grainflow.engine.forces import Drag, Gravity
    from grainflow.engine.simulation import Simulation
    from grainflow.frame import Box
    from grainflow.insertion import Bidisperse, BoxRegion, CylinderRegion, random_fill
    from grainflow.insertion.sizes import particle_volume
    from grainflow.models.soft import SoftLaw
    from grainflow.state import ParticleState
    from grainflow.walls import Cylinder, Hopper2D, PlateWithHole, WallForce

    if dim not in (2, 3):
        raise ValueError(f"dim: {dim!r}; the hopper scenarios are 2D or 3D")
    n, width = _defaults(section, dim)
    rng = np.random.default_rng(seed)
    sizes = Bidisperse(SIGMA_SMALL, DIAMETER_RATIO)
    radii = sizes.radii(n, rng)
    r_max = sizes.max_radius
    fill = section.fill_fraction if dim == 2 else 0.6 * section.fill_fraction
    total = float(particle_volume(radii, dim).sum())
    w = section.orifice_width
    if dim == 2:
        rise = 0.0 if section.theta_w == 90.0 else 0.5 * (width - w) / math.tan(
            math.radians(section.theta_w))
        fill_height = total / (fill * (width - 2 * r_max))
        bottom = rise + r_max
        top = bottom + fill_height
        walls = Hopper2D(W=width, theta_w_deg=section.theta_w, orifice_w=w, y_bottom=0.0,
                         height=top + 4.0 * r_max).segments()
        region = BoxRegion((-0.5 * width + r_max, bottom), (0.5 * width - r_max, top))
        box = Box(lo=np.array([-0.5 * width, -10.0]), hi=np.array([0.5 * width, top]),
                  periodic=(False, False))
    else:
        radius = 0.5 * width
        area = math.pi * (radius - r_max) ** 2
        top = r_max + total / (fill * area)
        walls = [Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius, inside=True),
                 PlateWithHole((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.5 * w)]
        region = CylinderRegion((0.0, 0.0), radius - r_max, lo=r_max, hi=top, axis=2)
        box = Box(lo=np.array([-radius, -radius, -10.0]), hi=np.array([radius, radius, top]),
                  periodic=(False, False, False))
    x, r = random_fill(region, n, radii, rng, max_attempts=100_000)
    state = ParticleState(dim, box)
    state.add_particles(x, r, density=1.0, type=(r > 0.5).astype(np.int32))  # 0 small, 1 large

    zeta, mu = dissipation(section)
    law = SoftLaw(n_types=3)
    for ti, tj in ((0, 0), (0, 1), (1, 1)):
        law.set_pair(ti, tj, epsilon=section.E_sp, mu_k=mu)
    for ti in (0, 1):
        law.set_pair(ti, WALL_TYPE, epsilon=section.E_w, mu_k=0.0)
    law.set_pair(WALL_TYPE, WALL_TYPE, epsilon=section.E_w, mu_k=0.0)
    sim = Simulation(state, 1.0, law, skin=skin, sort_every=sort_every,
                     check_every=check_every, max_overlap_fraction=max_overlap_fraction,
                     seed=seed)
    sim.add_force(WallForce(walls, law, WALL_TYPE))
    g = np.zeros(dim)
    g[-1] = -1.0
    sim.add_force(Gravity(g))
    if zeta > 0:
        sim.add_force(Drag(section.drag_factor * zeta))
    sim.dt = dt if dt is not None else sim.stable_time_step(section.dt_fraction)
    bulk_contacts = section.reinsert_bulk_contacts
    updater = HopperReinsertion(dim, 0.0, np.zeros(dim - 1), width,
                                depth=section.reinsert_depth,
                                bulk_contacts=dim + 1 if bulk_contacts is None else bulk_contacts)
    updater.setup_state(sim.context)
    sim.add_updater(updater, section.reinsert_every)
    return sim


def hopper_updater(sim: "Simulation") -> HopperReinsertion:
    """The reinsertion updater of a hopper simulation (it holds the crossing events)."""
    for scheduled in sim.updaters:
        if isinstance(scheduled.owner, HopperReinsertion):
            return scheduled.owner
    raise ValueError("simulation: has no HopperReinsertion updater; not a hopper run")


def hopper_segments(sim: "Simulation") -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The 2D walls as line segments for :func:`grainflow.plotting.snapshot.snapshot`."""
    from grainflow.walls import Segment, WallForce

    return [((w.p0[0], w.p0[1]), (w.p1[0], w.p1[1])) for f in sim.forces
            if isinstance(f, WallForce) for w in f.walls if isinstance(w, Segment)]


def prepare(sim: "Simulation") -> None:
    """Seed 003's initialisation: FIRE with gravity off (the same
    :func:`~grainflow.engine.minimize.relax` that ``run.minimize = true`` applies)."""
    relax(sim)


# The builders' ``config`` is the validated grainflow.config.schema.RunConfig (typed Any:
# scenarios do not import the config layer above them).
def _section(config: Any) -> HopperSection:
    section = config.section
    if not isinstance(section, HopperSection):
        raise ValueError("hopper: the [hopper] section is missing")
    return section


def _build(config: Any, dim: int) -> "Simulation":
    if config.dim != dim:
        raise ValueError(f"dim: scenario hopper{dim}d needs dim = {dim}, got {config.dim}")
    run = config.run
    return build_hopper(_section(config), dim, seed=run.seed, dt=run.dt, skin=run.skin,
                        sort_every=run.sort_every, check_every=run.check_every,
                        max_overlap_fraction=run.max_overlap_fraction)


def build_hopper2d(config: Any) -> "Simulation":
    """Builder of the ``hopper2d`` scenario (set ``run.minimize = true`` for FIRE)."""
    return _build(config, 2)


def build_hopper3d(config: Any) -> "Simulation":
    """Builder of the ``hopper3d`` scenario (set ``run.minimize = true`` for FIRE)."""
    return _build(config, 3)


register(Scenario(
    "hopper2d", "grainflow.scenarios.hopper:build_hopper2d", section="hopper",
    model=HopperSection,
    description="seed 003: 2D hopper of soft bidisperse disks, continuous flow by reinsertion"))
register(Scenario(
    "hopper3d", "grainflow.scenarios.hopper:build_hopper3d", section="hopper",
    model=HopperSection,
    description="seed 003: 3D cylindrical hopper with a flat base, continuous flow by "
                "reinsertion"))
