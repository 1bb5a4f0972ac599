"""Tests of the kinetic theory of seed 002 (Sano thesis, ch. 5) against the thesis's formulas.

The reference values are computed here from the printed equations (5.2)-(5.13) and (2.55),
written out again with the ``math`` module, one (phi, e) at a time, not by calling the module.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainflow.analysis.kinetic_theory import (
    c_star,
    effective_restitution,
    eta_k_star,
    eta_mu_star,
    eta_star,
    friction_slope,
    gamma_star,
    nu_eta_star,
    pressure,
    pressure_ratio,
    radial_distribution_contact,
    shear_viscosity,
    zeta_star,
)

PHI_F, PHI_C = 0.49, 0.64  # thesis eq. (5.3)
PHI_F_2D, PHI_C_2D = 0.69, 0.82  # the module's documented disk defaults
PHIS = [0.0, 0.05, 0.2, 0.35, 0.49, 0.55, 0.62]
RESTITUTIONS = [0.0, 0.3, 0.616, 0.75, 0.9, 1.0]
GRID = [(phi, e) for phi in PHIS for e in RESTITUTIONS]


# ---- the thesis's formulas, written out independently ----------------------------------------


def chi_thesis(phi: float) -> float:
    """Eq. (5.3)."""
    if phi < PHI_F:
        return (1 - phi / 2) / (1 - phi) ** 3
    return (1 - PHI_F / 2) * (PHI_C - PHI_F) / ((1 - PHI_F) ** 3 * (PHI_C - phi))


def chi_disks(phi: float) -> float:
    """Henderson's form, continued as 1/(phi_c - phi) above phi_f."""
    if phi < PHI_F_2D:
        return (1 - 7 * phi / 16) / (1 - phi) ** 2
    at_f = (1 - 7 * PHI_F_2D / 16) / (1 - PHI_F_2D) ** 2
    return at_f * (PHI_C_2D - PHI_F_2D) / (PHI_C_2D - phi)


def thesis_coefficients(phi: float, e: float) -> dict[str, float]:
    """Eqs. (5.6)-(5.11) at one (phi, e)."""
    chi = chi_thesis(phi)
    c = 32 * (1 - e) * (1 - 2 * e * e) / (81 - 17 * e + 30 * e * e * (1 - e))
    zeta = 5 / 12 * chi * (1 - e * e) * (1 + 3 * c / 32)
    nu = chi * (1 - (1 - e) ** 2 / 4) * (1 - c / 64)
    gamma = 128 / (5 * math.pi) * phi * phi * chi * (1 + e) * (1 - c / 32)
    eta_k = (1 - 2 * (1 + e) * (1 - 3 * e) * phi * chi / 5) / (nu - zeta / 2)
    eta = eta_k * (1 + 4 * phi * chi * (1 + e) / 5) + 3 * gamma / 5
    return {"c": c, "zeta": zeta, "nu": nu, "gamma": gamma, "eta_k": eta_k, "eta": eta}


# ---- contact value chi -----------------------------------------------------------------------


@pytest.mark.parametrize("phi", PHIS)
def test_chi_matches_eq_5_3(phi):
    assert radial_distribution_contact(phi) == pytest.approx(chi_thesis(phi), rel=1e-13)


def test_chi_known_values():
    assert radial_distribution_contact(0.0) == 1.0
    assert radial_distribution_contact(0.3) == pytest.approx(0.85 / 0.7**3, rel=1e-14)
    assert radial_distribution_contact(0.3, dim=2) == pytest.approx(
        (1 - 2.1 / 16) / 0.49, rel=1e-14)


@pytest.mark.parametrize("phi", [0.0, 0.3, 0.6, 0.69, 0.75, 0.81])
def test_chi_disks_henderson_and_continuation(phi):
    assert radial_distribution_contact(phi, dim=2) == pytest.approx(chi_disks(phi), rel=1e-13)


@pytest.mark.parametrize("dim, phi_f, phi_c", [(3, None, None), (2, None, None),
                                               (3, 0.45, 0.60), (2, 0.70, 0.84)])
def test_chi_is_continuous_at_phi_f(dim, phi_f, phi_c):
    f = phi_f if phi_f is not None else {2: PHI_F_2D, 3: PHI_F}[dim]
    below, at, above = radial_distribution_contact([f - 1e-10, f, f + 1e-10], dim, phi_f, phi_c)
    assert below == pytest.approx(at, rel=1e-8)
    assert above == pytest.approx(at, rel=1e-8)


@pytest.mark.parametrize("dim, chi_ref, phi_f, phi_c", [(3, chi_thesis, PHI_F, PHI_C),
                                                        (2, chi_disks, PHI_F_2D, PHI_C_2D)])
def test_chi_diverges_as_one_over_distance_to_phi_c(dim, chi_ref, phi_f, phi_c):
    phi = phi_c - np.array([1e-2, 1e-4, 1e-6])
    chi = radial_distribution_contact(phi, dim=dim)
    assert np.all(np.diff(chi) > 0) and chi[-1] > 1e5
    residue = chi_ref(phi_f) * (phi_c - phi_f)  # chi (phi_c - phi) on the dense branch
    assert chi * (phi_c - phi) == pytest.approx(np.full(3, residue), rel=1e-12)


# ---- equation of state -----------------------------------------------------------------------


@pytest.mark.parametrize("phi, e", GRID)
def test_pressure_ratio_matches_eq_5_2(phi, e):
    expected = 1 + 2 * phi * (1 + e) * chi_thesis(phi)
    assert pressure_ratio(phi, e) == pytest.approx(expected, rel=1e-13)


@pytest.mark.parametrize("phi, e", [(0.1, 0.5), (0.5, 0.9), (0.75, 1.0), (0.8, 0.0)])
def test_pressure_ratio_disks(phi, e):
    expected = 1 + (1 + e) * phi * chi_disks(phi)
    assert pressure_ratio(phi, e, dim=2) == pytest.approx(expected, rel=1e-13)


@pytest.mark.parametrize("dim", [2, 3])
def test_pressure_ratio_dilute_limit_is_ideal_gas(dim):
    assert pressure_ratio(1e-9, 0.8, dim=dim) == pytest.approx(1.0, abs=1e-8)
    assert pressure_ratio(0.0, 0.3, dim=dim) == 1.0


def test_pressure_is_n_t_times_ratio():
    n, temp, phi, e = 1.7, 0.3, 0.4, 0.616
    expected = n * temp * (1 + 2 * phi * (1 + e) * chi_thesis(phi))
    assert pressure(n, temp, phi, e) == pytest.approx(expected, rel=1e-13)


# ---- shear viscosity -------------------------------------------------------------------------


@pytest.mark.parametrize("phi, e", GRID)
def test_viscosity_coefficients_match_eqs_5_6_to_5_11(phi, e):
    ref = thesis_coefficients(phi, e)
    assert c_star(e) == pytest.approx(ref["c"], rel=1e-13, abs=1e-15)
    assert zeta_star(phi, e) == pytest.approx(ref["zeta"], rel=1e-13, abs=1e-15)
    assert nu_eta_star(phi, e) == pytest.approx(ref["nu"], rel=1e-13)
    assert gamma_star(phi, e) == pytest.approx(ref["gamma"], rel=1e-13, abs=1e-15)
    assert eta_k_star(phi, e) == pytest.approx(ref["eta_k"], rel=1e-12)
    assert eta_star(phi, e) == pytest.approx(ref["eta"], rel=1e-12)


def test_elastic_limits():
    assert c_star(1.0) == 0.0
    assert np.all(zeta_star([0.0, 0.3, 0.6], 1.0) == 0.0)
    assert c_star(0.0) == pytest.approx(32 / 81, rel=1e-14)
    # dilute elastic gas: eta* = 1, eta_kin = 5/(16 d^2) sqrt(m T / pi) (Chapman-Enskog)
    assert eta_star(0.0, 1.0) == pytest.approx(1.0, rel=1e-14)
    assert shear_viscosity(0.0, 2.0, 1.0, 0.5, 3.0) == pytest.approx(
        5 / (16 * 0.25) * math.sqrt(6.0 / math.pi), rel=1e-14)


@pytest.mark.parametrize("phi, e", [(0.1, 0.75), (0.45, 0.616), (0.6, 0.9)])
def test_shear_viscosity_matches_eq_5_5(phi, e):
    temp, diameter, mass = 0.04, 1.3, 2.5
    expected = (5 / (16 * diameter**2) * math.sqrt(mass * temp / math.pi)
                * thesis_coefficients(phi, e)["eta"])
    assert shear_viscosity(phi, temp, e, diameter, mass) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("phi, a, e", [(0.2, 0.223, 0.75), (0.5, 0.240, 0.616)])
def test_eta_mu_star_matches_eq_5_13(phi, a, e):
    expected = 16 * a / 5 * math.sqrt(6 * phi * (1 + 2 * phi * (1 + e) * chi_thesis(phi)))
    assert eta_mu_star(phi, a, e) == pytest.approx(expected, rel=1e-13)


@pytest.mark.parametrize("phi, e", [(0.2, 0.75), (0.45, 0.616), (0.58, 0.9)])
def test_friction_slope_is_mu_over_I_of_a_kinetic_flow(phi, e):
    """mu*/I = (-sigma_rz / P) / (D_rz sqrt(m / (P d))) with sigma_rz = -eta_kin D_rz and P
    of eq. 5.2 at n = 6 phi/(pi d^3), for any temperature, mass and diameter."""
    for temp, diameter, mass in ((0.04, 1.0, 1.0), (3.0, 1.3, 2.5)):
        n = 6 * phi / (math.pi * diameter**3)
        P = n * temp * (1 + 2 * phi * (1 + e) * chi_thesis(phi))
        eta = (5 / (16 * diameter**2) * math.sqrt(mass * temp / math.pi)
               * thesis_coefficients(phi, e)["eta"])
        D_rz = 0.07
        mu_over_I = (eta * D_rz / P) / (D_rz * math.sqrt(mass / (P * diameter)))
        assert friction_slope(phi, e) == pytest.approx(mu_over_I, rel=1e-12)
    # the converse of eq. (5.13): a flow at this slope has the kinetic-theory viscosity
    assert eta_mu_star(phi, friction_slope(phi, e), e) == pytest.approx(eta_star(phi, e),
                                                                         rel=1e-12)


def test_the_seeds_slopes_lie_below_kinetic_theory_at_every_density():
    phi = np.linspace(0.01, 0.63, 400)
    for e, a in ((0.75, 0.223), (0.616, 0.240)):  # frictionless, frictional (e renormalised)
        slope = friction_slope(phi, e)
        assert slope.min() > 1.4 * a and 0.1 < phi[np.argmin(slope)] < 0.3


def test_arrays_broadcast_and_scalars_stay_scalar():
    phi = np.array([[0.1], [0.3], [0.55]])
    e = np.array([0.616, 0.75, 1.0])
    out = eta_star(phi, e)
    assert out.shape == (3, 3)
    assert out[2, 1] == pytest.approx(thesis_coefficients(0.55, 0.75)["eta"], rel=1e-12)
    assert pressure_ratio(phi, e, dim=2).shape == (3, 3)
    assert np.ndim(eta_star(0.3, 0.75)) == 0
    assert isinstance(pressure_ratio(0.3, 0.75), float)


# ---- frictional grains -----------------------------------------------------------------------


def test_effective_restitution_gives_thesis_value():
    e_bar = effective_restitution(0.75, 0.2)
    assert e_bar == pytest.approx(0.75 - math.pi / 2 * 0.2 + 4.5 * 0.04, rel=1e-14)
    assert round(float(e_bar), 3) == 0.616
    assert effective_restitution(0.9, 0.0) == 0.9


# ---- bad input -------------------------------------------------------------------------------


@pytest.mark.parametrize("call, name", [
    (lambda: radial_distribution_contact(-0.1), "phi"),
    (lambda: radial_distribution_contact(1.0), "phi"),
    (lambda: radial_distribution_contact([0.3, 1.2]), "phi"),
    (lambda: radial_distribution_contact(float("nan")), "phi"),
    (lambda: radial_distribution_contact("dense"), "phi"),
    (lambda: radial_distribution_contact(0.3, dim=1), "dim"),
    (lambda: radial_distribution_contact(0.3, phi_f=0.7), "phi_f"),
    (lambda: radial_distribution_contact(0.3, phi_c=1.2), "phi_c"),
    (lambda: pressure_ratio(0.3, 1.1), "restitution"),
    (lambda: pressure_ratio(0.3, [0.5, -0.1]), "restitution"),
    (lambda: pressure_ratio(0.3, 0.5, dim=4), "dim"),
    (lambda: pressure(-1.0, 1.0, 0.3, 0.5), "number_density"),
    (lambda: pressure(1.0, -1.0, 0.3, 0.5), "temperature"),
    (lambda: c_star(2.0), "restitution"),
    (lambda: eta_star(1.5, 0.5), "phi"),
    (lambda: shear_viscosity(0.3, 1.0, 0.5, 0.0, 1.0), "diameter"),
    (lambda: shear_viscosity(0.3, 1.0, 0.5, 1.0, -2.0), "mass"),
    (lambda: shear_viscosity(0.3, -1.0, 0.5, 1.0, 1.0), "temperature"),
    (lambda: eta_mu_star(0.3, -0.2, 0.5), "a"),
    (lambda: effective_restitution(0.75, -0.1), "mu_p"),
    (lambda: effective_restitution(0.1, 0.2), "mu_p"),
    (lambda: effective_restitution(1.5, 0.1), "restitution"),
])
def test_bad_input_raises_value_error_naming_argument(call, name):
    with pytest.raises(ValueError, match=rf"^{name}:"):
        call()


def test_packing_beyond_random_close_packing_has_no_value():
    """chi diverges at phi_c: a measured cell packed at or beyond it gets NaN from chi and from
    everything built on it, while the other cells of the same array keep their values."""
    chi = radial_distribution_contact([0.3, PHI_C, 0.7])
    assert np.isfinite(chi[0]) and np.isnan(chi[1:]).all()
    assert np.isnan(radial_distribution_contact(0.82, dim=2))
    ratio = pressure_ratio([0.3, 0.66], 0.75)
    assert ratio[0] == pytest.approx(1 + 2 * 0.3 * 1.75 * chi_thesis(0.3), rel=1e-13)
    assert np.isnan(ratio[1])
    assert np.isnan(eta_star(0.7, 0.5)) and np.isnan(shear_viscosity(0.65, 1.0, 0.5, 1.0, 1.0))


@pytest.mark.parametrize("call", [
    lambda: c_star(0.5, dim=2),
    lambda: zeta_star(0.3, 0.5, dim=2),
    lambda: nu_eta_star(0.3, 0.5, dim=2),
    lambda: gamma_star(0.3, 0.5, dim=2),
    lambda: eta_k_star(0.3, 0.5, dim=2),
    lambda: eta_star(0.3, 0.5, dim=2),
    lambda: shear_viscosity(0.3, 1.0, 0.5, 1.0, 1.0, dim=2),
    lambda: effective_restitution(0.75, 0.2, dim=2),
])
def test_disk_transport_is_not_guessed(call):
    with pytest.raises(NotImplementedError, match="could not be checked"):
        call()
