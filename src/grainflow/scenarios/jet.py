"""Granular jets hitting a target (SPEC S2; seed 002 = Sano's thesis, Chapters 3, 4 and 6).

Units are the seed's: the largest grain diameter ``d``, the grain mass ``m`` and the jet
speed ``u0`` are 1, so times are in ``d/u0``. Every grain has the mass ``m``, whatever its
diameter (Chapter 3: "DEM for grains with identical mass m"); the wall particles too.

Geometry (fixed, and what :mod:`grainflow.analysis.jet` and
:mod:`grainflow.analysis.jet.rheology` assume):

- 3D (``jet3d``): the jet is a cylinder of diameter ``D_jet`` about the z axis (or a
  rectangle of aspect ratio ``l`` and area ``A_cs`` for the anisotropy runs of Sec. 4.2),
  travelling along -z at ``u0``; the target is one layer of wall particles (type
  :data:`TARGET_TYPE`) on a triangular lattice of spacing ``d`` in the plane z = -d/2,
  inside the disk of diameter ``D_tar``, so its surface is near z = 0.
- 2D (``jet2d``): the jet is a strip of width ``D_jet`` about y = 0 travelling along -x;
  the target is a line of wall particles at x = -d/2 for ``|y| <= D_tar/2``.

The jet is a lattice (3D: fcc with nearest-neighbour distance ``d``, phi_fcc = 0.740; 2D: a
triangular lattice of spacing 1.1 d, monodisperse (d) or bidisperse 50:50 (0.8 d, d))
thinned at random to ``phi_tilde = phi0 / phi_lattice`` of its sites (Chapter 3: "we prepare
fcc crystals and remove particles randomly to reach the desired density"). All grains move
at ``u0`` with no spin, so no two grains touch before the target (zero initial temperature).

Contacts (SPEC M1, seed eqs. 3.1-3.5): ``F_n = -k_n delta - eta_n v_n`` with an absolute
dashpot (``m_d = 1``), ``k_t = 0.2 k_n``, ``eta_t = 0.5 eta_n``, Coulomb ``mu_p``; ``k_n``
and ``eta_n`` follow from ``(e, t_c)`` by ``t_c = pi/sqrt(2 k_n/m - eta_n^2)`` and
``e = exp(-eta_n t_c)`` (eqs. 3.4-3.5; Table 4.1: e = 0.75, t_c = 0.1 gives k_n = 498,
eta_n = 2.88). Grain-wall-particle contacts use the same law. Wall particles are tied to
their initial positions and to their lattice neighbours by ``k_w = 10 m u0^2/d^2`` and
``eta_w = 5 eta_n`` (SPEC M5, :class:`~grainflow.engine.tethers.Tethers`) and share one body
id, so they interact with each other only through the tethers. Integration: Adams-Bashforth 2
with trapezoidal positions (Appendix B.2) at ``dt = 0.02 t_c`` (``run.dt_fraction``); no gravity.

Grains that leave a cylinder (3D) / box (2D) of radius ``removal_radius`` about the target
are removed (they no longer affect the flow near the target), so the cost stays with the
grains near it.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, StrictInt, model_validator

from grainflow.scenarios import Scenario, register

#: Particle type of the target's wall particles (grains are 0, and 1 for the large grains of
#: the 2D bidisperse jets).
TARGET_TYPE = 2
#: Nearest-neighbour spacing of the jet lattice in units of d (3D fcc, 2D triangular).
LATTICE_SPACING = {3: 1.0, 2: 1.1}
#: Small grain diameter of the 2D bidisperse jets (Chapter 6: 0.8 d and d).
SMALL_DIAMETER = 0.8
#: ``[run]`` defaults of the jet scenarios: seed 002 integrates with Adams-Bashforth 2.
RUN_DEFAULTS = {"integrator": "adams_bashforth2"}
#: Seed 002's grain counts (Chapter 3): 20,000 in 3D, 8,000 in 2D.
DEFAULT_COUNT = {3: 20_000, 2: 8_000}


class JetSection(BaseModel):
    """The ``[jet]`` table (units d, m, u0; module docstring)."""

    model_config = ConfigDict(extra="forbid", validate_default=True)

    jet_diameter: float = Field(10.0, gt=0, allow_inf_nan=False,
                                description="D_jet/d (seed: 4.5 scattering runs, 10 3D rheology, "
                                "30 in 2D)")
    target_diameter: float = Field(22.0, gt=0, allow_inf_nan=False,
                                   description="D_tar/d (seed: 22 in 3D, 66 in 2D)")
    phi_tilde: float = Field(0.9, gt=0, le=1, allow_inf_nan=False,
                             description="phi0/phi_lattice: fraction of lattice sites kept")
    n: StrictInt | None = Field(None, ge=1, description="number of grains in the jet; "
                                "default 20,000 (3D) or 8,000 (2D); sets its length")
    sizes: Literal["mono", "bidisperse"] = Field(
        "mono", description="2D: 'mono' (d) or 'bidisperse' (0.8 d and d, 50:50); 3D: 'mono'")
    cross_section: Literal["circle", "rectangle"] = Field(
        "circle", description="3D jet cross-section; 'rectangle' for the anisotropy runs")
    aspect_ratio: float = Field(1.0, ge=1, allow_inf_nan=False,
                                description="rectangle's long/short side l (long side along y)")
    cross_section_area: float = Field(16.0, gt=0, allow_inf_nan=False,
                                      description="rectangle's area in d^2 (seed: 16)")
    restitution: float = Field(0.75, gt=0, le=1, allow_inf_nan=False,
                               description="normal restitution e (Table 4.1)")
    contact_time: float = Field(0.10, gt=0, allow_inf_nan=False,
                                description="t_c in d/u0 (0.10; 2D mu_p = 0.4: 0.05; "
                                "mu_p = 1.0: 0.025, PARAMETERS.md)")
    mu_p: float = Field(0.2, ge=0, allow_inf_nan=False, description="Coulomb friction")
    k_w: float = Field(10.0, gt=0, allow_inf_nan=False, description="tether stiffness")
    eta_w_factor: float = Field(5.0, ge=0, allow_inf_nan=False, description="eta_w/eta_n")
    target_spacing: float = Field(
        1.0, gt=0, le=1, allow_inf_nan=False,
        description="spacing of the target's wall particles in d (1: touching; smaller: a "
        "smoother, denser target, the thesis gives no lattice)")
    gap: float = Field(2.0, ge=0, allow_inf_nan=False,
                       description="distance from the jet's front to the target surface")
    removal_radius: float | None = Field(
        None, gt=0, allow_inf_nan=False,
        description="grains farther than this from the jet axis, or more than this below "
        "the target, are removed; default max(D_tar, D_jet)/2 + 15 d")

    @model_validator(mode="after")
    def _check(self) -> "JetSection":
        if self.cross_section == "rectangle" and self.aspect_ratio < 1:
            raise ValueError("jet.aspect_ratio: must be >= 1 (long side along y)")
        return self

    def contact_parameters(self) -> tuple[float, float]:
        """``(k_n, eta_n)`` from ``(e, t_c)`` for two grains of mass m = 1 (eqs. 3.4-3.5)."""
        from grainflow.models.granular import stiffness_and_damping

        return stiffness_and_damping(self.restitution, self.contact_time, 0.5, "absolute")

    def count(self, dim: int) -> int:
        return self.n if self.n is not None else DEFAULT_COUNT[dim]


def _cross_section_3d(section: JetSection) -> tuple[Any, float, float]:
    """(predicate on (x, y), area, half extent) of the 3D jet's cross-section."""
    if section.cross_section == "circle":
        radius = 0.5 * section.jet_diameter
        return (lambda x, y: x * x + y * y <= radius * radius), math.pi * radius**2, radius
    short = math.sqrt(section.cross_section_area / section.aspect_ratio)
    long = section.cross_section_area / short
    return ((lambda x, y: (np.abs(x) <= 0.5 * short) & (np.abs(y) <= 0.5 * long)),
            section.cross_section_area, 0.5 * long)


def jet_sites(section: JetSection, dim: int, rng: np.random.Generator
              ) -> tuple[np.ndarray, np.ndarray, float]:
    """Lattice sites of the jet before thinning, their radii, and phi_lattice.

    The lattice is cut after the first ``round(n / phi_tilde)`` sites from the front, so that
    thinning to ``phi_tilde`` leaves ``n`` grains (within one, or one grain's volume when
    bidisperse); its front is ``gap + r`` above the target surface. 3D: fcc sites whose centres lie in
    the cross-section; 2D: triangular rows whose centres lie in ``|y| <= D_jet/2``.
    """
    from grainflow.insertion.lattice import IDEAL_PACKING, lattice_points
    from grainflow.insertion.regions import BoxRegion

    n_target = section.count(dim)
    spacing = LATTICE_SPACING[dim]
    if dim == 3:
        inside, area, half = _cross_section_3d(section)
        per_length = math.sqrt(2.0) / spacing**3 * area  # fcc: sqrt(2)/s^3 sites per volume
        length = 1.2 * n_target / (section.phi_tilde * per_length) + 4.0 * spacing
        box = BoxRegion((-half - spacing, -half - spacing, 0.0),
                        (half + spacing, half + spacing, length))
        pts = lattice_points(box, spacing, "fcc")
        pts = pts[inside(pts[:, 0], pts[:, 1])]
        pts[:, 2] += section.gap + 0.5 - pts[:, 2].min()
        radius = np.full(len(pts), 0.5)
        phi_lattice = IDEAL_PACKING["fcc"]
    else:
        half = 0.5 * section.jet_diameter
        per_length = 2.0 / (math.sqrt(3.0) * spacing**2) * section.jet_diameter
        length = 1.2 * n_target / (section.phi_tilde * per_length) + 4.0 * spacing
        box = BoxRegion((0.0, -half - spacing), (length, half + spacing))
        pts = lattice_points(box, spacing, "triangular")
        pts = pts[np.abs(pts[:, 1]) <= half]
        if section.sizes == "bidisperse":
            radius = np.where(rng.random(len(pts)) < 0.5, 0.5 * SMALL_DIAMETER, 0.5)
        else:
            radius = np.full(len(pts), 0.5)
        pts[:, 0] += section.gap - (pts[:, 0] - radius).min()
        site_area = math.sqrt(3.0) / 2.0 * spacing**2
        phi_lattice = float(np.mean(math.pi * radius**2) / site_area)
    if len(pts) == 0:
        raise ValueError("jet.jet_diameter: the jet's cross-section holds no lattice site; "
                         "use a diameter of at least one spacing")
    axis = dim - 1 if dim == 3 else 0
    order = np.argsort(pts[:, axis], kind="stable")[:round(n_target / section.phi_tilde)]
    order.sort()
    return pts[order], radius[order], phi_lattice


def thin_jet(radius: np.ndarray, dim: int, phi_tilde: float, rng: np.random.Generator
             ) -> np.ndarray:
    """Indices of the sites kept: a random subset holding ``phi_tilde`` of the sites' volume
    (:func:`~grainflow.insertion.lattice.thin_to_packing_fraction` relative to the full
    lattice, i.e. phi0 = phi_tilde * phi_lattice)."""
    from grainflow.insertion.lattice import thin_to_packing_fraction
    from grainflow.insertion.sizes import particle_volume

    full = float(particle_volume(radius, dim).sum())
    if phi_tilde >= 1.0:
        return np.arange(radius.size)
    return thin_to_packing_fraction(radius, dim, full, phi_tilde, rng)


def target_sites(section: JetSection, dim: int) -> np.ndarray:
    """Centres of the target's wall particles: a triangular lattice of spacing
    ``target_spacing`` (default d) in the plane z = -d/2 within the disk of radius D_tar/2
    (3D), or a row at x = -d/2 for ``|y| <= D_tar/2`` (2D)."""
    from grainflow.insertion.lattice import lattice_points
    from grainflow.insertion.regions import BoxRegion

    radius = 0.5 * section.target_diameter
    spacing = section.target_spacing
    if dim == 3:
        plane = lattice_points(BoxRegion((-radius - 1.0, -radius - 1.0),
                                         (radius + 1.0, radius + 1.0)), spacing, "triangular")
        plane -= plane[np.argmin(np.hypot(plane[:, 0] - 0.0, plane[:, 1] - 0.0))]
        plane = plane[np.hypot(plane[:, 0], plane[:, 1]) <= radius + 1e-9]
        return np.column_stack([plane, np.full(len(plane), -0.5)])
    count = int(math.floor(radius / spacing + 1e-9))
    y = spacing * np.arange(-count, count + 1, dtype=float)
    return np.column_stack([np.full(y.size, -0.5), y])


def build_jet(section: JetSection, dim: int, *, seed: int = 0, dt: float | None = None,
              dt_fraction: float = 0.02, skin: float | None = None, integrator: str = "adams_bashforth2",
              sort_every: int = 10, list_check: str | None = None, check_every: int = 100,
              max_overlap_fraction: float = 0.5) -> "Any":
    """The jet at t = 0 (module docstring): lattice jet, tethered target, M1 law, AB2."""
    from grainflow.engine.integrators import integrator_by_name
    from grainflow.engine.simulation import Simulation
    from grainflow.engine.tethers import Tethers, neighbor_bonds
    from grainflow.frame import Box
    from grainflow.insertion.pour import DeleteRegion
    from grainflow.insertion.regions import BoxRegion, CylinderRegion
    from grainflow.models.granular import GranularLaw
    from grainflow.state import ParticleState

    if dim not in (2, 3):
        raise ValueError(f"dim: {dim!r}; the jet scenarios are 2D or 3D")
    if dim == 3 and section.sizes != "mono":
        raise ValueError("jet.sizes: 3D jets are monodisperse (seed 002); use 'mono'")
    if dim == 2 and section.cross_section != "circle":
        raise ValueError("jet.cross_section: a 2D jet is a strip; 'rectangle' is for jet3d")
    rng = np.random.default_rng(seed)
    sites, radius, _ = jet_sites(section, dim, rng)
    keep = thin_jet(radius, dim, section.phi_tilde, rng)
    x, r = sites[keep], radius[keep]
    wall = target_sites(section, dim)
    velocity = np.zeros((len(x), dim))
    velocity[:, 0 if dim == 2 else 2] = -1.0

    reach = max(0.5 * section.target_diameter, 0.5 * section.jet_diameter)
    removal = section.removal_radius if section.removal_radius is not None else reach + 15.0
    axis = 0 if dim == 2 else 2
    top = float(x[:, axis].max()) + 1.0
    lo = np.full(dim, -removal)
    hi = np.full(dim, removal)
    lo[axis], hi[axis] = -removal, top
    state = ParticleState(dim, Box(lo=lo, hi=hi, periodic=(False,) * dim))
    types = (r > 0.5 * (0.5 + 0.5 * SMALL_DIAMETER)).astype(np.int32) \
        if section.sizes == "bidisperse" else np.zeros(len(r), dtype=np.int32)
    state.add_particles(x, r, mass=1.0, v=velocity, type=types)
    wall_idx = state.add_particles(wall, 0.5, mass=1.0, type=TARGET_TYPE, body=0)

    k_n, eta_n = section.contact_parameters()
    law = GranularLaw(n_types=TARGET_TYPE + 1)
    law.set_all(kn=k_n, kt=0.2 * k_n, gamma_n=eta_n, gamma_t=0.5 * eta_n, mu=section.mu_p,
                damping="absolute")
    step = dt if dt is not None else dt_fraction * section.contact_time
    sim = Simulation(state, step, law, skin=skin, integrator=integrator_by_name(integrator),
                     sort_every=sort_every, list_check=list_check or "absolute",
                     check_every=check_every, max_overlap_fraction=max_overlap_fraction,
                     seed=seed)
    ids = state.id[wall_idx]
    sim.add_force(Tethers(ids, section.k_w, section.eta_w_factor * eta_n,
                          bonds=neighbor_bonds(state, ids, 1.05 * section.target_spacing)))
    if dim == 3:
        keep_region: Any = CylinderRegion((0.0, 0.0), removal, lo=-removal, hi=np.inf)
    else:
        keep_region = BoxRegion((-removal, -removal), (np.inf, removal))
    # a grain moves at most ~u0 dt per step: checking every 1/(2 u0 dt) steps is enough
    sim.add_updater(DeleteRegion(keep_region, outside=True, types=[0, 1]),
                    max(1, int(0.5 / step)))
    return sim


def _build(config: Any, dim: int) -> Any:
    if config.dim != dim:
        raise ValueError(f"dim: scenario jet{dim}d needs dim = {dim}, got {config.dim}")
    section = config.section
    if not isinstance(section, JetSection):
        raise ValueError("jet: the [jet] section is missing")
    run = config.run
    return build_jet(section, dim, seed=run.seed, dt=run.dt, dt_fraction=run.dt_fraction,
                     skin=run.skin,
                     integrator=run.integrator, sort_every=run.sort_every,
                     list_check=run.list_check, check_every=run.check_every,
                     max_overlap_fraction=run.max_overlap_fraction)


def build_jet3d(config: Any) -> Any:
    """Builder of the ``jet3d`` scenario."""
    return _build(config, 3)


def build_jet2d(config: Any) -> Any:
    """Builder of the ``jet2d`` scenario."""
    return _build(config, 2)


register(Scenario("jet3d", "grainflow.scenarios.jet:build_jet3d", section="jet",
                  model=JetSection,
                  description="seed 002: 3D fcc jet on a tethered particle target (AB2, no "
                              "gravity)", run_defaults=RUN_DEFAULTS))
register(Scenario("jet2d", "grainflow.scenarios.jet:build_jet2d", section="jet",
                  model=JetSection,
                  description="seed 002: 2D triangular-lattice jet on a tethered particle "
                              "target", run_defaults=RUN_DEFAULTS))
