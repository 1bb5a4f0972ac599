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

Initialisation (seed Sec. 2.4), ``initial_packing = "sequential"``: grains are placed at
random without overlap (random sequential addition at packing fraction ``fill_fraction``) in
the hopper above the bottom
(with sloped walls, inside the funnel from the orifice up: :class:`FunnelRegion`), with zero
velocity; FIRE (``run.minimize = true``, gravity off) removes any overlap left
(with walls included); then gravity is on at t = 0. ``initial_packing = "inflated"`` (the
authors' code, the default of their convention) starts dense instead: random positions at
packing fraction 0.6 relaxed by FIRE with radii x 1.2, then restored
(:mod:`grainflow.scenarios.hopper_packing`). Continuous flow and crossing events:
:mod:`grainflow.scenarios.hopper_reinsertion`.

Deformable particles (SPEC M6, ``particles = "dp_rough" | "dp_smooth"``, 2D only; docs/dp.md):
each grain is a ring of ``n_vertices`` vertex particles of the same area and type, with the
shape energy (:class:`~grainflow.engine.deformable.ShapeForce`, K_a, K_l, K_b), vertex-disk
contacts through the same soft law (rough) or circulo-line edges
(:class:`~grainflow.engine.dp_edges.EdgeContacts`, smooth) at the energy E_c, walls at E_c,
drag and kinetic friction per vertex; crossing events and reinsertion move whole rings
(:mod:`grainflow.scenarios.hopper_rings`).

Time step (the seed's value is illegible, PARAMETERS.md "NF"): ``dt = dt_fraction * t_c``
with t_c the shortest contact time of the pair law *and* of the walls (a wall contact of a
small grain, t_c = pi sqrt(m_s r_s^2 / eps_w), is usually the stiffest); ``dt_fraction`` =
1/20 by default, and at most 0.2 m_eff/mu, the relaxation time of the kinetic friction of
two small grains over 5 (:meth:`~grainflow.engine.simulation.Simulation.stable_time_step`
over every interaction). docs/hopper_study.md shows that halving it leaves Q unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, StrictInt, model_validator

from grainflow.scenarios import Scenario, register
from grainflow.scenarios.hopper_reinsertion import HopperReinsertion
from grainflow.scenarios.hopper_rings import RingReinsertion
from grainflow.scenarios.hopper_packing import (AUTHORS_INFLATE, inflated_packing,
                                                uniform_positions)
from grainflow.scenarios.hopper_units import AUTHORS_CODE
from grainflow.engine.minimize import relax

if TYPE_CHECKING:
    from grainflow.engine.minimize import FireResult
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
#: Mass of a grain of diameter sigma_avg (rho = 1): pi/4 in 2D, pi/6 in 3D.
MEAN_GRAIN_MASS = {2: math.pi / 4.0, 3: math.pi / 6.0}
#: Particle types: 0 small, 1 large, 2 walls.
WALL_TYPE = 2
#: File of a run's crossing events (read by :mod:`grainflow.studies.hopper_results`).
EVENTS = "events.csv"


Convention = Literal["grainflow", "authors"]

#: What ``convention`` sets for every SP-model option left unset (None) in the table:
#: today's reading of the printed seed, or the authors' public code (docs/hopper_study.md,
#: :mod:`grainflow.scenarios.hopper_units`).
CONVENTIONS: dict[str, dict[str, Any]] = {
    "grainflow": {"friction_on": "full", "drag_on": "grain", "stiffness": "constant",
                  "lambda_path": "interpolate", "reinsertion": "pile", "count_at": "orifice",
                  "reinsert_depth": 2.0, "lid_time": 0.0, "E_sp": 100.0, "E_w": 1.0e4,
                  "mu_limit": LIMIT_MU, "drag_limit": None, "drag_factor": DRAG_FACTOR,
                  "initial_packing": "sequential"},
    "authors": {"friction_on": "tangential", "drag_on": "mass", "stiffness": "diameter",
                "lambda_path": "authors", "reinsertion": "lanes", "count_at": "reinsertion",
                "reinsert_depth": AUTHORS_CODE.count_depth, "lid_time": AUTHORS_CODE.lid_time,
                "E_sp": AUTHORS_CODE.units.pair_force_scale(AUTHORS_CODE.spK),
                "E_w": AUTHORS_CODE.units.wall_energy(AUTHORS_CODE.K_w),
                "mu_limit": AUTHORS_CODE.units.mu(AUTHORS_CODE.mu_limit), "drag_limit": None,
                "drag_factor": 1.0, "initial_packing": "inflated"},
}


class HopperSection(BaseModel):
    """The ``[hopper]`` table (seed units: sigma_avg = g = rho = 1, see module docstring).

    Counts are strict integers (a string such as ``"1600"`` is refused); every number but
    ``lam`` is finite (``E_sp = inf`` is refused here, naming ``hopper.E_sp``). The SP-model
    options left unset take the values of ``convention`` (:data:`CONVENTIONS`);
    :meth:`resolved` gives the table with every option filled in.
    """

    model_config = ConfigDict(extra="forbid", validate_default=True)

    convention: Convention = Field(
        "grainflow", description="defaults of the SP-model options below: 'grainflow' (the "
        "printed seed as we read it) or 'authors' (the authors' public code, converted to "
        "these units; docs/hopper_study.md)")
    n: StrictInt | None = Field(None, ge=2,
                                description="number of grains; default 1600 (2D), 6400 (3D)")
    orifice_width: float = Field(6.0, gt=0, allow_inf_nan=False,
                                 description="w / sigma_avg (3D: orifice diameter)")
    width: float | None = Field(None, gt=0, allow_inf_nan=False,
                                description="W / sigma_avg: side-wall separation (2D, default "
                                "50 = 60 sigma_s) or cylinder diameter (3D, 25)")
    theta_w: float = Field(90.0, gt=0, le=90, description="2D bottom angle in degrees (90 flat)")
    E_sp: float | None = Field(None, gt=0, allow_inf_nan=False,
                               description="pair stiffness eps_sp/(g rho sigma_avg^(d+1)) (of a "
                               "pair of mean diameter sigma_avg with stiffness = 'diameter'); "
                               "default 100 (grainflow), 139 (authors)")
    E_w: float | None = Field(None, gt=0, allow_inf_nan=False,
                              description="wall stiffness eps_w/(g rho sigma_avg^(d+1)) (of a "
                              "grain of diameter sigma_avg with stiffness = 'diameter'); "
                              "default 1e4 (grainflow), 694 (authors); DP vertices: E_c")
    stiffness: Literal["constant", "diameter"] | None = Field(
        None, description="'constant': one eps for every pair and one for every grain on a "
        "wall (seed eq. 4); 'diameter': eps_mn = E_sp sigma_mn, eps_w = E_w sigma_m, the "
        "authors' code (force E_sp (1 - r/sigma_mn) at every size)")
    lam: float = Field(math.inf, ge=0, description="lambda = zeta/mu; 0 and inf are the "
                       "seed's limits (write inf in TOML)")
    mu_limit: float | None = Field(None, gt=0, allow_inf_nan=False, description="mu/mu0 at "
                                   "lam = 0; default 10 sqrt(10) (grainflow), 8.51 = the "
                                   "code's 10 (authors)")
    drag_limit: float | None = Field(None, gt=0, allow_inf_nan=False, description="drag at "
                                     "lam = inf, in the unit of drag_on (zeta per grain, "
                                     "gamma per unit mass); default zeta = 1/sqrt(10) "
                                     "(grainflow), gamma = 1.96 = the code's b = 0.1 (authors)")
    lambda_path: Literal["interpolate", "authors"] | None = Field(
        None, description="how a finite lam sets mu and the drag: 'interpolate' (both change, "
        "zeta/mu = lam) or 'authors' (mu at its limit while the drag rises to its limit, then "
        "the drag at its limit while mu falls)")
    zeta: float | None = Field(None, ge=0, allow_inf_nan=False,
                               description="explicit drag (overrides lam): per grain with "
                               "drag_on = 'grain', the rate gamma per unit mass with 'mass'")
    drag_on: Literal["grain", "mass"] | None = Field(
        None, description="'grain': F = -drag_factor zeta v; 'mass': F = -gamma M v with the "
        "rate gamma (the authors' code); lam uses zeta = gamma M of a sigma_avg grain")
    drag_factor: float | None = Field(None, gt=0, allow_inf_nan=False,
                               description="drag_on = 'grain' only: drag force on a grain = "
                               "-drag_factor * zeta * v; default 16 (grainflow), 1 (authors). "
                               "Seed eq. (5) is illegible; 16 = N_v "
                               "(the DP model's per-vertex drag, eq. 11, summed over its 16 "
                               "vertices) reproduces the seed's flow rates, 1 is a literal "
                               "-zeta v (docs/hopper_study.md)")
    mu: float | None = Field(None, ge=0, allow_inf_nan=False,
                             description="explicit kinetic friction (overrides lam)")
    friction_on: Literal["full", "tangential"] | None = Field(
        None, description="kinetic friction on the 'full' relative velocity (seed eq. 6) or "
        "its 'tangential' part (the authors' code)")
    initial_packing: Literal["sequential", "inflated"] | None = Field(
        None, description="the start before gravity is on: 'sequential' (random sequential "
        "addition at fill_fraction, nothing overlapping) or 'inflated' (random positions at "
        "fill_fraction relaxed by FIRE with every radius x inflate, then restored: the "
        "authors' code, a dense start); default sequential (grainflow), inflated (authors); "
        "deformable rings are always filled sequentially")
    inflate: float | None = Field(None, gt=1, le=2, allow_inf_nan=False, description="initial_"
                                  "packing = 'inflated': radius factor during its FIRE; "
                                  "default 1.2 (the authors')")
    fill_fraction: float | None = Field(None, gt=0, lt=1, allow_inf_nan=False,
                                        description="packing fraction of the initial fill; "
                                        "default 0.45 sequential (below 0.6; 3D uses 0.6 of "
                                        "it), 0.6 inflated (2D, the authors'; 3D 0.35)")
    lid_time: float | None = Field(None, ge=0, allow_inf_nan=False,
                                   description="the orifice is closed by a lid until this "
                                   "time (t0); default 0 (grainflow), 0.31 = 1200 code steps "
                                   "(authors)")
    reinsertion: Literal["pile", "lanes"] | None = Field(
        None, description="where a grain goes back: 'pile' (a random lateral position, on a "
        "bulk grain: reinsert_bulk_contacts) or 'lanes' (28 fixed lanes in turn, 1 sigma_s "
        "above the lane's highest grain: the authors' code)")
    count_at: Literal["orifice", "reinsertion"] | None = Field(
        None, description="when a grain is counted: 'orifice' (when it first crosses the "
        "orifice plane) or 'reinsertion' (when it is moved back, reinsert_depth diameters "
        "past the orifice: the authors' code)")
    reinsert_depth: float | None = Field(None, gt=0, allow_inf_nan=False,
                                         description="reinsert after falling this many own "
                                         "diameters below the orifice; default 2 (seed), 2.5 "
                                         "(authors)")
    reinsert_every: StrictInt = Field(10, ge=1, description="steps between crossing checks")
    reinsert_bulk_contacts: StrictInt | None = Field(
        None, ge=0, description="reinsertion = 'pile': a reinserted grain's partner must touch "
        "or nearly touch this many grains (a 'bulk particle' of the seed); default d + 1; 0: "
        "the highest grain of the column (docs/hopper_study.md)")
    dt_fraction: float = Field(0.05, gt=0, le=0.25, description="dt = dt_fraction * t_c (pairs "
                               "and walls) unless run.dt is given")
    particles: Literal["sp", "dp_rough", "dp_smooth"] = Field(
        "sp", description="'sp': soft disks/spheres (M3); 'dp_rough' / 'dp_smooth': 2D "
        "deformable rings (M6) with vertex disks of diameter l0 / circulo-line edges "
        "(docs/dp.md)")
    K_a: float = Field(1.0e4, gt=0, allow_inf_nan=False, description="DP area stiffness "
                       "k_a sigma_avg^4/(g rho sigma_avg^3) (docs/dp.md)")
    K_l: float = Field(10.0, ge=0, allow_inf_nan=False, description="DP perimeter-spring "
                       "stiffness k_l sigma_avg^2/(g rho sigma_avg^3)")
    K_b: float = Field(0.1, ge=0, allow_inf_nan=False, description="DP bending rigidity "
                       "k_b/(g rho sigma_avg^5)")
    E_c: float = Field(AUTHORS_CODE.units.contact_energy(AUTHORS_CODE.kint), gt=0,
                       allow_inf_nan=False, description="DP vertex-contact energy "
                       "eps_c/(g rho sigma_avg^3); default 116 = the authors' kint = 10")
    n_vertices: StrictInt = Field(16, ge=3, description="DP vertices per ring (seed: 16)")
    edge_width: float = Field(0.2, gt=0, le=1, description="dp_smooth: edge thickness in "
                              "units of l0 (the authors' code: 0.2)")

    @model_validator(mode="after")
    def _check(self) -> "HopperSection":
        if (self.zeta is None) != (self.mu is None):
            raise ValueError("zeta/mu: give both (explicit dissipation) or neither (use lam)")
        if self.width is not None and not self.orifice_width < self.width:
            raise ValueError(f"orifice_width: {self.orifice_width} must be below the hopper "
                             f"width {self.width}")
        chosen = self.resolved_options()
        if chosen["drag_on"] == "mass" and self.drag_factor is not None:
            raise ValueError("drag_factor: applies to drag_on = 'grain' only; with drag_on = "
                             "'mass' give the rate gamma through zeta or lam")
        if self.particles != "sp" and self.initial_packing == "inflated":
            raise ValueError("initial_packing: 'inflated' is for soft grains (particles = "
                             "'sp'); deformable rings are filled sequentially")
        packing = chosen["initial_packing"] if self.particles == "sp" else "sequential"
        if packing == "sequential" and self.inflate is not None:
            raise ValueError("inflate: applies to initial_packing = 'inflated' only")
        if packing == "sequential" and (self.fill_fraction or 0.0) >= 0.6:
            raise ValueError(f"fill_fraction: {self.fill_fraction} is past what random "
                             "sequential addition reaches; give a value below 0.6, or "
                             "initial_packing = 'inflated' for a denser start")
        if chosen["reinsertion"] == "lanes" and self.reinsert_bulk_contacts is not None:
            raise ValueError("reinsert_bulk_contacts: applies to reinsertion = 'pile' only "
                             "(the lanes rule places a grain above the lane's highest grain)")
        return self

    def resolved_options(self) -> dict[str, Any]:
        """Every option of :data:`CONVENTIONS`: the table's value, or the convention's."""
        defaults = CONVENTIONS[self.convention]
        return {key: default if getattr(self, key) is None else getattr(self, key)
                for key, default in defaults.items()}


@dataclass(frozen=True)
class Dissipation:
    """Kinetic friction ``mu`` and drag of a hopper run: ``drag`` is zeta (the per-grain
    coefficient, before ``drag_factor``) or the rate gamma per unit mass (``per_mass``)."""

    mu: float
    drag: float
    per_mass: bool


def _limits(section: HopperSection, options: dict[str, Any], dim: int) -> tuple[float, float]:
    """``(mu at lambda -> 0, drag at lambda -> inf)``, the drag in the unit of ``drag_on``."""
    if options["drag_limit"] is not None:
        return options["mu_limit"], options["drag_limit"]
    if section.convention == "authors":
        gamma = AUTHORS_CODE.units.gamma(AUTHORS_CODE.b_limit)
        drag = gamma if options["drag_on"] == "mass" else gamma * MEAN_GRAIN_MASS[dim]
    else:
        drag = LIMIT_ZETA / MEAN_GRAIN_MASS[dim] if options["drag_on"] == "mass" else LIMIT_ZETA
    return options["mu_limit"], drag


def dissipation(section: HopperSection, dim: int = 2) -> Dissipation:
    """Friction and drag of ``section``: explicit values, or lambda along ``lambda_path``.

    lambda = zeta/mu with zeta the per-grain drag coefficient of a grain of diameter
    sigma_avg (``gamma M_avg`` for ``drag_on = "mass"``, M_avg = pi/4 in 2D, pi/6 in 3D). With
    mu_l and zeta_l the two limits and lambda* = zeta_l/mu_l:

    * ``"interpolate"``: mu = mu_l/(1 + s), zeta = zeta_l s/(1 + s), s = lambda/lambda*;
    * ``"authors"`` (their lambda sweep, docs/hopper_study.md): mu = mu_l, zeta = lambda mu_l for
      lambda <= lambda*; zeta = zeta_l, mu = zeta_l/lambda above.
    """
    options = section.resolved_options()
    per_mass = options["drag_on"] == "mass"
    if section.zeta is not None and section.mu is not None:
        return Dissipation(section.mu, section.zeta, per_mass)
    mu_l, drag_l = _limits(section, options, dim)
    to_zeta = MEAN_GRAIN_MASS[dim] if per_mass else 1.0  # drag value -> zeta of a sigma_avg grain
    zeta_l = drag_l * to_zeta
    lam = section.lam
    if lam == 0.0:
        return Dissipation(mu_l, 0.0, per_mass)
    if math.isinf(lam):
        return Dissipation(0.0, drag_l, per_mass)
    lam_star = zeta_l / mu_l
    if options["lambda_path"] == "authors":
        if lam <= lam_star:
            return Dissipation(mu_l, lam * mu_l / to_zeta, per_mass)
        return Dissipation(zeta_l / lam, drag_l, per_mass)
    s = lam / lam_star
    return Dissipation(mu_l / (1.0 + s), drag_l * s / (1.0 + s), per_mass)


def _defaults(section: HopperSection, dim: int) -> tuple[int, float]:
    n = section.n if section.n is not None else (1600 if dim == 2 else 6400)
    width = section.width if section.width is not None else (
        60.0 if dim == 2 else 30.0) * SIGMA_SMALL
    if not section.orifice_width < width:
        raise ValueError(f"hopper.orifice_width: {section.orifice_width} must be below the "
                         f"hopper width {width:g}")
    return n, width


#: Verlet skin of a 2D hopper of soft disks, in mean radii (the engine's default is 0.2). The
#: grains leaving the orifice cross half a skin of 0.1 sigma_avg every ten or so steps, and
#: around each rebuild a 1,600-disk step costs several steps' worth of Python; at 0.8 the
#: list is rebuilt 2.7-3.5 times less often and a run takes 1.18-1.37 times less time (the
#: study's hopper at lambda = 0, 0.05 and infinity, w = 3.0-10.6; docs/hopper_study.md, "Cost
#: of the second pass"). In 3D the pair loop dominates and a larger skin gains nothing.
SKIN_2D = 0.8


def build_hopper(section: HopperSection, dim: int, *, seed: int = 0, dt: float | None = None,
                 skin: float | None = None, sort_every: int = 10, check_every: int = 100,
                 max_overlap_fraction: float = 1.0, integrator: str = "verlet",
                 list_check: str | None = None) -> "Simulation":
    """The hopper at t = 0: random fill (not yet relaxed, see :func:`prepare`), walls, law,
    gravity, drag and the reinsertion updater (:func:`hopper_updater` finds it).
    ``integrator`` and ``list_check`` are the ``[run]`` fields of the same names (default
    velocity Verlet and the absolute list check).

    ``max_overlap_fraction`` (the health check) is 1.0 of the smaller radius by default: at
    the seed's E_sp = 100 the grains at the bottom of a 1600-grain pile overlap by about
    0.6 r_s under its weight (overlap/sigma ~ weight of the column / eps_sp), which is the
    physics of the soft model, not an instability.
    """
    from grainflow.engine.forces import Drag, Gravity
    from grainflow.engine.integrators import integrator_by_name
    from grainflow.engine.simulation import Simulation
    from grainflow.frame import Box
    from grainflow.insertion import Bidisperse, BoxRegion, CylinderRegion, random_fill
    from grainflow.insertion.sizes import particle_volume
    from grainflow.models.soft import SoftLaw
    from grainflow.state import ParticleState
    from grainflow.walls import Cylinder, Hopper2D, PlateWithHole, WallForce
    from grainflow.engine.deformable import ShapeForce
    from grainflow.engine.dp_edges import EdgeContacts
    from grainflow.insertion.dp_bodies import add_rings
    from grainflow.rings import rest_length, state_ring_table

    if dim not in (2, 3):
        raise ValueError(f"dim: {dim!r}; the hopper scenarios are 2D or 3D")
    n, width = _defaults(section, dim)
    rng = np.random.default_rng(seed)
    sizes = Bidisperse(SIGMA_SMALL, DIAMETER_RATIO)
    dp = section.particles != "sp"
    if dp and dim != 2:
        raise ValueError("hopper.particles: deformable particles are 2D; use scenario "
                         "hopper2d or particles = 'sp'")
    extent = _ring_extent(section) if dp else 1.0  # rings: see _ring_extent
    radii = sizes.radii(n, rng) * extent
    r_max = sizes.max_radius * extent
    options = section.resolved_options()
    packing = "sequential" if dp else options["initial_packing"]
    fill = _fill_fraction(section, packing, dim)
    total = float(particle_volume(radii, dim).sum())
    w = section.orifice_width
    if dim == 2:
        if section.theta_w == 90.0:
            top = r_max + total / (fill * (width - 2 * r_max))
            region = BoxRegion((-0.5 * width + r_max, r_max), (0.5 * width - r_max, top))
        else:  # fill the funnel itself: a fill above it would fall onto it from far up
            region = _funnel_fill(width, w, section.theta_w, r_max, total / fill)
            top = float(region.y_hi)
        walls = Hopper2D(W=width, theta_w_deg=section.theta_w, orifice_w=w, y_bottom=0.0,
                         height=top + 4.0 * r_max).segments()
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
    if packing == "sequential":
        x, r = random_fill(region, n, radii, rng, max_attempts=100_000)
    else:  # the authors' dense start: hopper_packing
        r = radii
        closed = [*walls, _lid_wall(dim, w), _cap_wall(dim, top)]
        x = inflated_packing(uniform_positions(region, r, rng), r, _grain_types(r), closed,
                             options["E_sp"], _inflate(section), dim=dim, box=box)
    r = r / extent
    types = _grain_types(r)
    state = ParticleState(dim, box)
    if dp:
        add_rings(state, x, np.pi * r**2, n_vertices=section.n_vertices, type=types,
                  contact=section.particles.removeprefix("dp_"), edge_width=section.edge_width,
                  rng=rng)
    else:
        state.add_particles(x, r, density=1.0, type=types)

    friction = dissipation(section, dim)
    scales = "constant" if dp else options["stiffness"]
    # with 'diameter' the wall partner's sigma is r_m, so eps_w,m = epsilon r_m = E_w sigma_m
    wall_epsilon = options["E_w"] * (2.0 if scales == "diameter" else 1.0)
    if dp and section.E_w is None:  # seed 003: K_w = K_c for deformable particles
        wall_epsilon = section.E_c
    law = SoftLaw(n_types=3)
    for ti, tj in ((0, 0), (0, 1), (1, 1)):
        law.set_pair(ti, tj, epsilon=section.E_c if dp else options["E_sp"],
                     epsilon_scales=scales, mu_k=friction.mu, kinetic_on=options["friction_on"])
    for ti in (0, 1, WALL_TYPE):
        law.set_pair(ti, WALL_TYPE, epsilon=wall_epsilon, epsilon_scales=scales, mu_k=0.0)
    smooth = section.particles == "dp_smooth"
    if dp and skin is None:
        # a quarter of the mean rest edge: the default (a fifth of the mean radius, here the
        # vertex's) would rebuild the list every few steps while the rings fall, for 30 %
        # more speed (rough) at 1.35 times the listed pairs
        skin = 0.25 * float(np.mean(rest_length(np.pi * r**2, section.n_vertices)))
    elif dim == 2 and skin is None:
        skin = SKIN_2D * float(np.mean(r))
    sim = Simulation(state, 1.0, None if smooth else law, skin=skin, sort_every=sort_every,
                     integrator=integrator_by_name(integrator),
                     list_check=list_check or "absolute", check_every=check_every,
                     max_overlap_fraction=max_overlap_fraction, seed=seed)
    if dp:
        sim.add_force(ShapeForce(section.K_a, section.K_l, section.K_b,
                                 n_vertices=section.n_vertices))
    if smooth:
        # the initial fall stretches soft rings' edges on impact (K_l = 10: by more than a
        # third at lambda = 0); the list reaches twice the longest rest edge
        sim.add_force(EdgeContacts(section.E_c, mu_k=friction.mu,
                                   kinetic_on=options["friction_on"],
                                   n_vertices=section.n_vertices, reach_factor=2.0))
    sim.add_force(WallForce(walls, law, WALL_TYPE))
    g = np.zeros(dim)
    g[-1] = -1.0
    sim.add_force(Gravity(g))
    if friction.drag > 0:
        if friction.per_mass:
            sim.add_force(Drag(friction.drag, per_mass=True))
        else:  # DP: seed eq. 11's -zeta v on each vertex is drag_factor/N_v of the grain's
            per_body = section.n_vertices if dp else 1
            sim.add_force(Drag(options["drag_factor"] * friction.drag / per_body))
    lid = None
    if options["lid_time"] > 0:
        lid = sim.add_force(WallForce([_lid_wall(dim, w)], law, WALL_TYPE))
    sim.dt = dt if dt is not None else sim.stable_time_step(section.dt_fraction)
    bulk_contacts = section.reinsert_bulk_contacts
    lanes = options["reinsertion"] == "lanes"
    updater = HopperReinsertion(
        dim, 0.0, np.zeros(dim - 1), width, depth=options["reinsert_depth"],
        bulk_contacts=0 if lanes else (dim + 1 if bulk_contacts is None else bulk_contacts),
        count_at=options["count_at"], placement=options["reinsertion"],
        lanes=AUTHORS_CODE.lanes,  # lift and lane reach: the authors' (reinsertion defaults)
        inside=_inside_funnel(width, w, section.theta_w) if dim == 2 else None)
    updater.setup_state(sim.context)
    if dp:
        # ring bodies ascend in fill order, so ring k has the area pi r_k^2 it was built with
        body, _ = state_ring_table(state, section.n_vertices)
        updater = RingReinsertion(updater, section.n_vertices,
                                  dict(zip(body.tolist(), np.pi * r**2)))
    sim.add_updater(updater, section.reinsert_every)
    if lid is not None:
        sim.add_updater(HopperLid(sim, lid, options["lid_time"]),
                        max(1, math.ceil(options["lid_time"] / sim.dt)))
    return sim


def _grain_types(r: np.ndarray) -> np.ndarray:
    """Particle types of grains of radii ``r`` (sigma_avg = 1): 0 small, 1 large."""
    return (r > 0.5).astype(np.int32)


def _fill_fraction(section: HopperSection, packing: str, dim: int) -> float:
    """Packing fraction of the initial fill: ``fill_fraction`` or the packing's default;
    sequential fills in 3D take 0.6 of it (random sequential addition of spheres jams near
    0.38). An inflated fill must stay below 1 at the inflated radii."""
    if packing == "sequential":
        fill = 0.45 if section.fill_fraction is None else section.fill_fraction
        return fill if dim == 2 else 0.6 * fill
    fill = section.fill_fraction
    if fill is None:
        fill = 0.6 if dim == 2 else 0.35
    inflate = _inflate(section)
    if fill * inflate**dim >= 1.0:
        raise ValueError(f"hopper.fill_fraction: {fill:g} with inflate = {inflate:g} "
                         f"fills {fill * inflate**dim:.2f} of the hopper at the "
                         f"inflated radii in {dim}D; lower fill_fraction or inflate so that "
                         "fill_fraction * inflate^d stays below 1")
    return fill


def _inflate(section: HopperSection) -> float:
    """The radius factor of the inflated packing: ``inflate``, or the authors' 1.2."""
    return AUTHORS_INFLATE if section.inflate is None else section.inflate


def _cap_wall(dim: int, top: float) -> Any:
    """A wall over the initial fill at height ``top``, facing down (closes the inflated
    packing's FIRE: with gravity off nothing else holds the grains in)."""
    from grainflow.walls import Plane

    if dim == 2:
        return Plane((0.0, top, 0.0), (0.0, -1.0, 0.0))
    return Plane((0.0, 0.0, top), (0.0, 0.0, -1.0))


def _ring_extent(section: HopperSection) -> float:
    """Radius of the disk a ring is placed in by the random fill, over the radius sigma/2 of
    its area-equivalent disk: the regular polygon's circumradius plus 2 % (no vertex of one
    ring can then lie inside another ring, where nothing would push it out). Vertex disks of
    neighbouring rings may overlap; FIRE removes that (:func:`prepare`). A fill of whole
    outer disks (circumradius plus vertex radius) would start rough rings at a ring-area
    fraction of 0.31 instead of 0.42, a pile that takes tens of t0 to settle at the drag
    limit's terminal speed of 0.5 sigma_avg/t0."""
    nv = section.n_vertices
    return math.sqrt(2.0 * math.pi / (nv * math.sin(2.0 * math.pi / nv))) + 0.02


def _lid_wall(dim: int, w: float) -> Any:
    """The lid over the orifice: a segment one orifice width wider than the opening (2D), or
    the plane of the base (3D)."""
    from grainflow.walls import Plane, Segment

    if dim == 2:
        return Segment((-w, 0.0, 0.0), (w, 0.0, 0.0))
    return Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))


class HopperLid:
    """Removes the lid over the orifice at the first check at or after ``open_time`` (the
    authors' code keeps the orifice closed for its first 1200 steps). A checkpoint written
    after the opening resumes without the lid (:meth:`load_state_dict`)."""

    def __init__(self, sim: "Simulation", lid: Any, open_time: float) -> None:
        self.sim = sim
        self.lid = lid
        self.open_time = float(open_time)
        self.opened = False

    def update(self, ctx: Any) -> None:
        if not self.opened and ctx.time >= self.open_time:
            self._open()

    def _open(self) -> None:
        self.sim.remove_force(self.lid)
        self.opened = True

    def state_dict(self) -> dict[str, Any]:
        return {"opened": self.opened}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        if bool(data.get("opened", False)) and not self.opened:
            self._open()


@dataclass(frozen=True)
class FunnelRegion:
    """The inside of a 2D hopper with sloped walls (a :class:`~grainflow.insertion.Region`):
    side walls at x = +-W/2, walls at ``theta_deg`` from the vertical (90: a flat bottom, as
    :class:`~grainflow.walls.Hopper2D`) rising from the orifice lips (x = +-w/2, y = 0),
    between heights ``y_lo`` and ``y_hi``; ``margin`` is a distance from every wall
    (perpendicular to the sloped ones)."""

    W: float
    w: float
    theta_deg: float
    y_lo: float
    y_hi: float
    dim: int = 2

    def _half_width(self, y: np.ndarray | float, margin: float) -> np.ndarray:
        theta = math.radians(self.theta_deg)
        slope = 0.5 * self.w + np.asarray(y, dtype=float) * math.tan(theta) - margin / math.cos(
            theta)
        return np.minimum(0.5 * self.W - margin, slope)

    def contains(self, x: np.ndarray, margin: float = 0.0) -> np.ndarray:
        x = np.atleast_2d(x)
        y = x[:, 1]
        return ((np.abs(x[:, 0]) <= self._half_width(y, margin)) & (y >= self.y_lo + margin)
                & (y <= self.y_hi - margin))

    def area(self, margin: float = 0.0) -> float:
        """The area of the part at least ``margin`` from the walls, over y_lo .. y_hi
        (trapezoidal rule on 2001 heights; the width is piecewise linear)."""
        y = np.linspace(self.y_lo, self.y_hi, 2001)
        return float(np.trapezoid(2.0 * np.clip(self._half_width(y, margin), 0.0, None), y))

    def volume(self) -> float:
        return self.area()

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([-0.5 * self.W, self.y_lo]), np.array([0.5 * self.W, self.y_hi]))


def _inside_funnel(W: float, w: float, theta_deg: float) -> Any:
    """For reinsertion: whether a grain of radius r at x lies inside the funnel, clear of its
    walls (None for a flat bottom: every position above the pile does)."""
    if theta_deg == 90.0:
        return None
    region = FunnelRegion(W, w, theta_deg, 0.0, math.inf)
    return lambda x, r: bool(region.contains(x[None, :], margin=r)[0])


def _funnel_fill(W: float, w: float, theta_deg: float, r_max: float,
                 area: float) -> FunnelRegion:
    """The funnel region from y = r_max up to the height that holds ``area`` (bisection on
    the area of the region inset by ``r_max``, where centres may go)."""

    def inset_area(top: float) -> float:
        return FunnelRegion(W, w, theta_deg, r_max, top).area(margin=r_max)

    lo, hi = r_max, r_max + 1.0
    while inset_area(hi) < area:
        hi = r_max + 2.0 * (hi - r_max)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if inset_area(mid) < area else (lo, mid)
    return FunnelRegion(W, w, theta_deg, r_max, hi)


def hopper_updater(sim: "Simulation") -> HopperReinsertion:
    """The reinsertion updater of a hopper simulation (it holds the crossing events)."""
    for scheduled in sim.updaters:
        owner = getattr(scheduled.owner, "inner", scheduled.owner)  # rings: RingReinsertion
        if isinstance(owner, HopperReinsertion):
            return owner
    raise ValueError("simulation: has no HopperReinsertion updater; not a hopper run")


def hopper_segments(sim: "Simulation") -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The 2D walls as line segments for :func:`grainflow.plotting.snapshot.snapshot`."""
    from grainflow.walls import Segment, WallForce

    return [((w.p0[0], w.p0[1]), (w.p1[0], w.p1[1])) for f in sim.forces
            if isinstance(f, WallForce) for w in f.walls if isinstance(w, Segment)]


def prepare(sim: "Simulation") -> "FireResult":
    """Seed 003's initialisation: FIRE with gravity off (the same
    :func:`~grainflow.engine.minimize.relax` that ``run.minimize = true`` applies); returns
    how FIRE ended."""
    return relax(sim)


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
                        max_overlap_fraction=run.max_overlap_fraction,
                        integrator=run.integrator, list_check=run.list_check)


def build_hopper2d(config: Any) -> "Simulation":
    """Builder of the ``hopper2d`` scenario (set ``run.minimize = true`` for FIRE)."""
    return _build(config, 2)


def build_hopper3d(config: Any) -> "Simulation":
    """Builder of the ``hopper3d`` scenario (set ``run.minimize = true`` for FIRE)."""
    return _build(config, 3)


#: The hopper's time step is its own section's: dt = hopper.dt_fraction x t_c (pairs and
#: walls), or run.dt.
RUN_ELSEWHERE = {"dt_fraction": "the hopper's time step is dt = hopper.dt_fraction x t_c "
                                f"(default {HopperSection.model_fields['dt_fraction'].default:g}); "
                                "set hopper.dt_fraction instead, or run.dt"}

register(Scenario(
    "hopper2d", "grainflow.scenarios.hopper:build_hopper2d", section="hopper",
    model=HopperSection, run_elsewhere=RUN_ELSEWHERE,
    description="seed 003: 2D hopper of soft bidisperse disks, continuous flow by reinsertion"))
register(Scenario(
    "hopper3d", "grainflow.scenarios.hopper:build_hopper3d", section="hopper",
    model=HopperSection, run_elsewhere=RUN_ELSEWHERE,
    description="seed 003: 3D cylindrical hopper with a flat base, continuous flow by "
                "reinsertion"))
