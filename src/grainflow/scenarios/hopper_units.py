"""The authors' code units of seed 003 and their conversion to the study's units.

Seed 003's numbers (Cheng et al., Soft Matter 18, 8071 (2022)) were produced by the authors'
2D code (the facts read from it are restated in docs/hopper_study.md, "Second pass"). In
that code lengths are in sigma_s = 1 (sigma_l = 1.4), a grain of area a0 = pi r^2 has the
inertial mass ``mass_factor`` a0 = 16 a0 but the weight g a0 with g = 0.05, the pair force is
spK (1 - r/sigma_mn), the wall force K_w (1 - 2 d/sigma_m), the kinetic friction -mu v_t,
the drag -b M v, and the flow rate is plotted as grains per 1000 steps of dt = 0.005.

Derivation (ours, not the paper's printed conversion). The code's grains are a consistent
mechanical system with areal mass density rho_c = 16 and the real gravitational acceleration
g_c = g a0 / (16 a0) = g/16: the weight enters only through g a0. Our study units are
sigma_avg = g = rho = 1 (:mod:`grainflow.scenarios.hopper`), so one of our units is, in code
units,

=================  =====================================  ============================
quantity            our unit in code units                 value (default code)
=================  =====================================  ============================
length              L = sigma_avg = (1 + 1.4)/2 sigma_s    1.2
acceleration        g_c = g / mass_factor                  0.003125
time                T = t0 = sqrt(L / g_c)                 19.60
mass                M = rho_c L^2 = mass_factor L^2        23.04
force               F = M g_c = M L / T^2                  0.0720
damping (F/v)       mu0 = zeta0 = M / T                    1.1755
rate                1 / T                                  0.0510
=================  =====================================  ============================

Hence, for the code's committed values: mu = 10 is mu/mu0 = 8.51 (the paper prints 10 sqrt(10));
b = 0.1 is a drag rate gamma t0 = 1.96 per unit mass; spK = 10 is a force scale spK/F = 139 =
E_sp of a pair of mean diameter sigma_avg (``epsilon_scales = "diameter"``); K_w = 100 is a
wall force scale 1389, i.e. E_w = 694 for a grain of diameter sigma_avg; dt = 0.005 is
2.6e-4 t0; and a plotted Q (grains per 1000 steps) is an area rate 3.16 Q in Q0 = sigma_avg^2/t0
(mean grain area 0.807 sigma_avg^2 of the 50:50 mixture). ``tests/test_hopper_units.py`` runs
the same two-grain collision under gravity, drag and friction in both unit systems and checks
that the converted trajectories coincide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["AUTHORS_3D_SPK", "AUTHORS_3D_UNITS", "AUTHORS_CODE", "CodeUnits", "AuthorsCode"]


@dataclass(frozen=True)
class CodeUnits:
    """The authors' code units (module docstring): lengths in sigma_s, inertial mass
    ``mass_factor`` times the area pi r^2, weight ``g`` times the area.

    ``dim = 3``: the authors' 3D branch gives its spheres the mass pi r^2 too (``mass_factor``
    1 after its "bug fix"). Our spheres have the mass rho pi sigma^3/6, so our mass unit is set
    by the sigma_avg grain (code mass pi sigma_avg^2/4 = our pi/6): M = 1.5 mass_factor L^2.
    The two sizes' masses then differ by 1.4^3 in our model and 1.4^2 in the code's, which no
    choice of units removes. The 3D branch's g is not known; 0.05, the 2D code's, is assumed.
    """

    g: float = 0.05
    mass_factor: float = 16.0
    diameter_ratio: float = 1.4
    dim: int = 2

    @property
    def length(self) -> float:
        """sigma_avg in code lengths."""
        return 0.5 * (1.0 + self.diameter_ratio)

    @property
    def acceleration(self) -> float:
        """The real gravitational acceleration g / mass_factor."""
        return self.g / self.mass_factor

    @property
    def time(self) -> float:
        """t0 = sqrt(sigma_avg / g_real) in code time."""
        return math.sqrt(self.length / self.acceleration)

    @property
    def mass(self) -> float:
        """Our mass unit rho sigma_avg^d in code mass: mass_factor L^2 in 2D (rho =
        mass_factor per unit area), 1.5 mass_factor L^2 in 3D (class docstring)."""
        return self.mass_factor * self.length**2 * (1.0 if self.dim == 2 else 1.5)

    @property
    def force(self) -> float:
        return self.mass * self.acceleration

    @property
    def energy(self) -> float:
        """Our energy unit g rho sigma_avg^3 (weight times diameter) in code energy."""
        return self.force * self.length

    @property
    def damping(self) -> float:
        """mu0 = zeta0 = rho sigma_avg^2 / t0 (force per velocity)."""
        return self.mass / self.time

    @property
    def mean_grain_area(self) -> float:
        """Mean area of the 50:50 mixture in sigma_avg^2."""
        return math.pi / 8.0 * (1.0 + self.diameter_ratio**2) / self.length**2

    # ---------------------------------------------------------------- conversions
    def mu(self, mu_code: float) -> float:
        """Kinetic friction mu/mu0."""
        return mu_code / self.damping

    def gamma(self, b: float) -> float:
        """Drag rate per unit mass, gamma t0."""
        return b * self.time

    def pair_force_scale(self, spK: float) -> float:
        """E_sp of ``epsilon_scales = "diameter"``: the force scale spK / F."""
        return spK / self.force

    def wall_energy(self, K_w: float) -> float:
        """E_w: eps_w of a grain of diameter sigma_avg (wall force scale K_w/F times 1/2)."""
        return 0.5 * K_w / self.force

    def contact_energy(self, kint: float) -> float:
        """E_c of the DP vertex contacts: the code's energy scale ``kint`` (its vertex
        energy ``(kint/2)(1 - d/sigma)^2``) over our energy unit."""
        return kint / self.energy

    def duration(self, t_code: float) -> float:
        """A code time in t0."""
        return t_code / self.time

    def flow_rate(self, grains_per_1000_steps: float, dt_code: float) -> float:
        """The paper's plotted Q (grains per 1000 steps) as an area rate in Q0."""
        per_t0 = grains_per_1000_steps / (1000.0 * dt_code) * self.time
        return per_t0 * self.mean_grain_area

    def lam(self, b: float, mu_code: float) -> float:
        """lambda = zeta/mu of a grain of diameter sigma_avg (zeta = b M): 18.1 b/mu in 2D."""
        area = math.pi / 4.0 * self.length**2
        return b * self.mass_factor * area / mu_code


@dataclass(frozen=True)
class AuthorsCode:
    """The code's committed values (docs/hopper_study.md, "Second pass"): friction limit mu = 10 (b = 0), drag limit
    b = 0.1 (mu = 0), spK = 10, K_w = 100, dt = 0.005, the orifice closed for 1200 steps, a
    grain counted and moved ~2.5 of its diameters past the orifice, 28 reinsertion lanes, and
    the DP vertex-contact energy kint = 10 (E_c = 116 in our units)."""

    units: CodeUnits = CodeUnits()
    mu_limit: float = 10.0
    b_limit: float = 0.1
    spK: float = 10.0
    K_w: float = 100.0
    dt: float = 0.005
    lid_steps: int = 1200
    count_depth: float = 2.5
    lanes: int = 28
    kint: float = 10.0

    @property
    def lid_time(self) -> float:
        return self.units.duration(self.lid_steps * self.dt)


#: The committed values of the authors' 2D code, with their conversion.
AUTHORS_CODE = AuthorsCode()
#: The units of the authors' 3D branch (masses pi r^2, g assumed 0.05; :class:`CodeUnits`):
#: its spK = 100 is E_sp = 926, its mu = 10 would be mu/mu0 = 22.7.
AUTHORS_3D_UNITS = CodeUnits(mass_factor=1.0, dim=3)
#: The 3D branch's pair force scale spK.
AUTHORS_3D_SPK = 100.0
