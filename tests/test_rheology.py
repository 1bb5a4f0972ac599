"""Rheology analyses of seed 002 (grainflow.analysis.rheology): stress measures, dimensionless
numbers, the friction-law and divergence fits, and velocity distributions.

Synthetic data use the thesis's fitted values as truths (Sano 2013, Secs. 5.3.3 and 6.1).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from grainflow.analysis import rheology as rh

MU_OF_I = {"mu_s": 0.0153, "mu_max": 0.521, "I0": 0.082}
POWER_LAW = {"b": 1.18, "beta": 0.592}
DIVERGENCE = {"phi_c": 0.834, "a": 3.94, "alpha": 1.36}
LINEAR = {"a": 0.240}

I_MU = np.geomspace(0.005, 1.0, 30)  # inertial numbers of the friction-law data
I_PHI = np.geomspace(0.01, 0.15, 30)  # I_s of the divergence data, phi from ~0.67 to 0.83


# --------------------------------------------------------------------------------------------
# Stress, pressure, dimensionless numbers
# --------------------------------------------------------------------------------------------


def test_pressure_and_effective_friction_of_a_2d_tensor():
    stress = np.array([[2.0, -0.3], [-0.3, 1.0]])
    assert rh.pressure(stress) == pytest.approx(1.5)
    assert rh.effective_friction(stress) == pytest.approx(0.2)  # -sigma_xy / P


def test_effective_friction_picks_cylindrical_rz_and_broadcasts_over_fields():
    # (r, theta, z) components: P = (1 + 2 + 3)/3 = 2, sigma_rz = -0.06 -> mu* = 0.03
    tensor = np.diag([1.0, 2.0, 3.0])
    tensor[0, 2] = tensor[2, 0] = -0.06
    field = np.broadcast_to(tensor, (4, 5, 3, 3))
    mu = rh.effective_friction(field, axes=(0, 2))
    assert mu.shape == (4, 5)
    np.testing.assert_allclose(mu, 0.03)
    assert rh.pressure(field).shape == (4, 5)
    # with the strain rate, mu* is positive where the stress opposes the deformation
    flipped = tensor.copy()
    flipped[0, 2] = flipped[2, 0] = 0.06
    both = np.stack([tensor, flipped])
    np.testing.assert_allclose(rh.effective_friction(both, (0, 2)), [0.03, -0.03])
    np.testing.assert_allclose(
        rh.effective_friction(both, (0, 2), strain_rate=[0.5, -0.5]), [0.03, 0.03]
    )


def test_empty_cells_give_nan_without_warnings():
    stress = np.zeros((3, 2, 2))
    stress[1] = [[1.0, -0.1], [-0.1, 1.0]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mu = rh.effective_friction(stress)
        inertial = rh.inertial_number(np.ones(3), rh.pressure(stress), 1.0, 1.0, 2)
        i_t = rh.temperature_number(np.ones(3), rh.pressure(stress), 1.0, 2)
    for values in (mu, inertial, i_t):
        assert np.isnan(values[[0, 2]]).all() and np.isfinite(values[1])


def test_inertial_and_temperature_numbers_values():
    # 2D: I_s = D_xy sqrt(m/P), I_T = sqrt(T/(P d^2)) (Sec. 6.1.3)
    assert rh.inertial_number(-0.3, 4.0, 2.0, 9.0, 2) == pytest.approx(0.3 * 1.5)
    assert rh.temperature_number(8.0, 0.5, 2.0, 2) == pytest.approx(2.0)
    # 3D: I = D_rz sqrt(m/(P d)), I_T = sqrt(T/(P d^3))
    assert rh.inertial_number(0.3, 4.0, 2.0, 8.0, 3) == pytest.approx(0.3)
    assert rh.temperature_number(8.0, 0.5, 2.0, 3) == pytest.approx(np.sqrt(2.0))
    # gamma_dot = 2 D_ab doubles I
    assert rh.inertial_number(0.3, 4.0, 2.0, 8.0, 3, use_shear_rate=True) == pytest.approx(0.6)


@pytest.mark.parametrize("dim", [2, 3])
def test_inertial_and_temperature_numbers_are_dimensionless(dim):
    rng = np.random.default_rng(dim)
    rate, pressure, temperature = rng.uniform(0.1, 2.0, (3, 7))
    d, m = 0.8, 1.3
    length, mass, time = 3.7, 0.21, 5.3  # new units: values scale as their dimensions
    new_pressure = pressure * mass * length ** (2 - dim) / time**2  # energy / length^D
    new_temperature = temperature * mass * length**2 / time**2  # energy
    np.testing.assert_allclose(
        rh.inertial_number(rate / time, new_pressure, d * length, m * mass, dim),
        rh.inertial_number(rate, pressure, d, m, dim),
    )
    np.testing.assert_allclose(
        rh.temperature_number(new_temperature, new_pressure, d * length, dim),
        rh.temperature_number(temperature, pressure, d, dim),
    )


# --------------------------------------------------------------------------------------------
# Fits
# --------------------------------------------------------------------------------------------


def _mu_of_i_data(rng, noise=0.01):
    return I_MU, rh.mu_of_I(I_MU, **MU_OF_I) + rng.normal(0, noise, I_MU.size)


def _power_law_data(rng, noise=0.01):
    return I_MU, rh.mu_power_law(I_MU, 0.0, **POWER_LAW) + rng.normal(0, noise, I_MU.size)


def _linear_data(rng, noise=0.01):
    return I_MU, LINEAR["a"] * I_MU + rng.normal(0, noise, I_MU.size)


def _divergence_data(rng, noise=0.002):
    return I_PHI, rh.phi_of_I(I_PHI, **DIVERGENCE) + rng.normal(0, noise, I_PHI.size)


CASES = {  # name: (make data, fit, truths)
    "mu_of_I": (_mu_of_i_data, rh.fit_mu_of_I, MU_OF_I),
    "power_law_fixed_mu_s": (
        _power_law_data, lambda x, y, s=None: rh.fit_mu_power_law(x, y, s, mu_s=0.0), POWER_LAW
    ),
    "power_law_free_mu_s": (
        _power_law_data, rh.fit_mu_power_law, {"mu_s": 0.0, **POWER_LAW}
    ),
    "linear": (_linear_data, rh.fit_mu_linear, LINEAR),
    "divergence": (_divergence_data, rh.fit_divergence, DIVERGENCE),
}


def _pulls(fit, truths):
    return np.array([(getattr(fit, k) - v) / getattr(fit, f"{k}_err") for k, v in truths.items()])


@pytest.mark.parametrize("case", CASES)
def test_fit_recovers_thesis_parameters(case):
    make, fit_fn, truths = CASES[case]
    fit = fit_fn(*make(np.random.default_rng(1)))
    assert np.all(np.abs(_pulls(fit, truths)) < 3)
    assert fit.n_points == I_MU.size and fit.dof == fit.n_points - fit.covariance.shape[0]
    assert not fit.absolute_sigma
    x, exact = make(np.random.default_rng(1), 0.0)  # the noiseless curve
    noise = 0.002 if case == "divergence" else 0.01
    assert np.max(np.abs(fit.predict(x) - exact)) < noise


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("absolute", [False, True])
def test_fit_standard_errors_cover_the_truth(case, absolute):
    """Over 40 noise realisations the pulls (fit - truth)/err have unit spread."""
    make, fit_fn, truths = CASES[case]
    noise = 0.002 if case == "divergence" else 0.01
    pulls, chi2 = [], []
    for seed in range(40):
        x, y = make(np.random.default_rng(100 + seed), noise)
        fit = fit_fn(x, y, noise) if absolute else fit_fn(x, y)
        pulls.append(_pulls(fit, truths))
        chi2.append(fit.chi2_dof)
    pulls = np.concatenate(pulls)
    assert 0.75 < np.sqrt(np.mean(pulls**2)) < 1.35
    assert 0.55 < np.mean(np.abs(pulls) < 1) < 0.82  # 68 % expected
    # chi^2/dof is ~1 with the true sigma, the residual variance ~noise^2 without
    assert np.mean(chi2) == pytest.approx(1.0 if absolute else noise**2, rel=0.15)


def test_mu_of_i_is_the_eq_2_57_form_not_the_misprinted_product():
    mu_s, mu_max, i0 = MU_OF_I.values()
    assert rh.mu_of_I(1e-12, mu_s, mu_max, i0) == pytest.approx(mu_s)
    assert rh.mu_of_I(i0, mu_s, mu_max, i0) == pytest.approx((mu_s + mu_max) / 2)
    assert rh.mu_of_I(1e12, mu_s, mu_max, i0) == pytest.approx(mu_max)


def test_power_law_with_fixed_mu_s_fits_two_parameters():
    fit = rh.fit_mu_power_law(*_power_law_data(np.random.default_rng(2)), mu_s=0.0)
    assert fit.mu_s_fixed and fit.mu_s == 0.0 and fit.mu_s_err == 0.0
    assert fit.covariance.shape == (2, 2) and fit.dof == I_MU.size - 2
    np.testing.assert_allclose(fit.predict([0.1]), fit.b * 0.1**fit.beta)


def test_linear_fit_with_sigma_matches_weighted_least_squares():
    x, y = _linear_data(np.random.default_rng(3))
    sigma = np.full(x.size, 0.01)
    fit = rh.fit_mu_linear(x, y, sigma)
    assert fit.a == pytest.approx(np.sum(x * y) / np.sum(x * x))
    assert fit.a_err == pytest.approx(0.01 / np.sqrt(np.sum(x * x)))
    assert fit.absolute_sigma


def test_divergence_equations_of_state():
    fit = rh.fit_divergence(*_divergence_data(np.random.default_rng(4)))
    inertial = np.array([0.02, 0.05, 0.1])
    phi = fit.predict(inertial)
    np.testing.assert_allclose(fit.number(phi), inertial)
    # eq. (6.5): P/(m D^2) = 1/I_s^2 = a^alpha / (phi_c - phi)^alpha
    np.testing.assert_allclose(fit.scaled_pressure(phi), inertial**-2.0)
    np.testing.assert_allclose(
        fit.scaled_pressure(phi), fit.a**fit.alpha / (fit.phi_c - phi) ** fit.alpha
    )
    assert np.isnan(fit.number(fit.phi_c + 0.01))


def test_scaled_shear_stress_is_eq_6_11():
    divergence = rh.DivergenceFit(
        **DIVERGENCE, phi_c_err=0.0, a_err=0.0, alpha_err=0.0, covariance=np.zeros((3, 3)),
        chi2_dof=1.0, dof=1, n_points=4, absolute_sigma=True,
    )
    friction = rh.MuPowerLawFit(
        mu_s=0.0, **POWER_LAW, mu_s_err=0.0, b_err=0.0, beta_err=0.0, mu_s_fixed=True,
        covariance=np.zeros((2, 2)), chi2_dof=1.0, dof=1, n_points=3, absolute_sigma=True,
    )
    phi = np.array([0.70, 0.80, 0.83])
    b, beta = POWER_LAW.values()
    phi_s, a_s, alpha_s = DIVERGENCE.values()
    exponent = (1 - beta / 2) * alpha_s
    assert exponent == pytest.approx(0.96, abs=0.005)  # the thesis's beta_s
    np.testing.assert_allclose(
        rh.scaled_shear_stress(phi, friction, divergence),
        -b * a_s**exponent / (phi_s - phi) ** exponent,
    )


def test_drop_nan_only_when_asked():
    x, y = _mu_of_i_data(np.random.default_rng(5))
    y = y.copy()
    y[3] = np.nan
    with pytest.raises(ValueError, match=r"^mu: .*drop_nan=True"):
        rh.fit_mu_of_I(x, y)
    fit = rh.fit_mu_of_I(x, y, drop_nan=True)
    assert fit.n_points == x.size - 1
    sigma = np.full(x.size, 0.01)
    sigma[5] = np.nan
    assert rh.fit_mu_linear(x, y, sigma, drop_nan=True).n_points == x.size - 2


# --------------------------------------------------------------------------------------------
# Velocity distributions
# --------------------------------------------------------------------------------------------


def test_flatness_of_gaussian_and_laplace_samples():
    rng = np.random.default_rng(6)
    gauss = rng.normal(2.0, 0.3, 400_000)
    laplace = rng.laplace(-1.0, 0.5, 400_000)
    assert rh.flatness(gauss) == pytest.approx(3.0, abs=0.05)
    assert rh.flatness(laplace) == pytest.approx(6.0, abs=0.25)
    per_component = rh.flatness(np.column_stack([gauss, laplace]))
    assert per_component.shape == (2,)
    np.testing.assert_allclose(per_component, [rh.flatness(gauss), rh.flatness(laplace)])


def test_mass_weighting_equals_repeating_grains():
    rng = np.random.default_rng(7)
    v = rng.normal(0.0, 1.0, (50, 2))
    masses = rng.integers(1, 4, 50)
    repeated = np.repeat(v, masses, axis=0)
    np.testing.assert_allclose(rh.flatness(v, masses), rh.flatness(repeated))
    weighted = rh.velocity_distribution(v, 10, masses=masses.astype(float))
    plain = rh.velocity_distribution(repeated, 10)
    np.testing.assert_allclose(weighted.density, plain.density)
    np.testing.assert_allclose(weighted.v0, plain.v0)


def test_reference_curves_have_unit_variance_and_flatness_3_and_6():
    c, dc = np.linspace(-40, 40, 400_001, retstep=True)
    for curve, flat in ((rh.gaussian_vdf, 3.0), (rh.exponential_vdf, 6.0)):
        f = curve(c)
        assert np.sum(f) * dc == pytest.approx(1.0, rel=1e-6)
        assert np.sum(c**2 * f) * dc == pytest.approx(1.0, rel=1e-6)
        assert np.sum(c**4 * f) * dc == pytest.approx(flat, rel=1e-6)


def test_scaled_vdf_collapses_components_onto_the_unit_gaussian():
    rng = np.random.default_rng(8)
    v = rng.normal([3.0, -1.0, 0.0], [0.7, 0.2, 2.5], (200_000, 3))
    vdf = rh.velocity_distribution(v, 40)
    assert vdf.centres.shape == (40,) and vdf.density.shape == (40, 3)
    np.testing.assert_allclose(vdf.mean, [3.0, -1.0, 0.0], atol=0.02)
    np.testing.assert_allclose(vdf.v0, [0.7, 0.2, 2.5], rtol=0.01)
    width = np.diff(vdf.centres)[0]
    for k in range(3):
        f = vdf.density[:, k]
        np.testing.assert_allclose(f, rh.gaussian_vdf(vdf.centres), atol=0.01)
        assert np.sum(f) * width == pytest.approx(1.0, abs=0.01)  # int f~ dc
        assert np.sum(vdf.centres * f) * width == pytest.approx(0.0, abs=0.01)  # int c f~ dc
        assert np.sum(vdf.centres**2 * f) * width == pytest.approx(1.0, abs=0.02)  # int c^2 f~


def test_unscaled_vdf_is_in_velocity_units():
    rng = np.random.default_rng(9)
    v = rng.normal(5.0, 2.0, 100_000)
    vdf = rh.velocity_distribution(v, 50, temperature_scaled=False)
    assert vdf.density.shape == (50,) and not vdf.temperature_scaled
    assert vdf.centres[-1] == pytest.approx(5 * float(vdf.v0), rel=0.05)
    np.testing.assert_allclose(
        vdf.density, rh.gaussian_vdf(vdf.centres / vdf.v0) / vdf.v0, atol=0.006
    )


# --------------------------------------------------------------------------------------------
# Bad inputs
# --------------------------------------------------------------------------------------------

_X = np.geomspace(0.01, 1.0, 8)
_Y = 0.3 * _X


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: rh.pressure(np.ones((3, 2))), r"^stress:"),
        (lambda: rh.pressure(np.ones((4, 4))), r"^stress:"),
        (lambda: rh.effective_friction(np.eye(2), axes=(1, 1)), r"^axes:"),
        (lambda: rh.effective_friction(np.eye(2), axes=(0, 2)), r"^axes:"),
        (lambda: rh.inertial_number(1.0, 1.0, 0.0, 1.0, 2), r"^diameter:"),
        (lambda: rh.inertial_number(1.0, 1.0, 1.0, -1.0, 2), r"^mass:"),
        (lambda: rh.inertial_number(1.0, 1.0, 1.0, 1.0, 4), r"^dim:"),
        (lambda: rh.temperature_number(-1.0, 1.0, 1.0, 2), r"^T:"),
        (lambda: rh.fit_mu_of_I(_X, _Y[:-1]), r"^mu:"),
        (lambda: rh.fit_mu_of_I(_X[:, None], _Y), r"^I:"),
        (lambda: rh.fit_mu_of_I(np.r_[_X[:-1], np.inf], _Y), r"^I:"),
        (lambda: rh.fit_mu_of_I(np.r_[0.0, _X[1:]], _Y), r"^I: must be > 0"),
        (lambda: rh.fit_mu_of_I(_X[:3], _Y[:3]), r"^I: need more than 3 points"),
        (lambda: rh.fit_mu_power_law(_X[:2], _Y[:2], mu_s=0.0), r"^I: need more than 2"),
        (lambda: rh.fit_mu_power_law(_X, _Y, mu_s=np.nan), r"^mu_s:"),
        (lambda: rh.fit_mu_linear(_X[:1], _Y[:1]), r"^I: need more than 1"),
        (lambda: rh.fit_mu_linear(_X, _Y, sigma=np.ones(3)), r"^sigma:"),
        (lambda: rh.fit_mu_linear(_X, _Y, sigma=0.0), r"^sigma:"),
        (lambda: rh.fit_divergence(-_X, _Y), r"^I: must be > 0"),
        (lambda: rh.fit_divergence(_X, np.r_[_Y[:-1], np.nan]), r"^phi:"),
        (lambda: rh.fit_divergence(np.full(8, 0.1), _Y), r"^I: the data do not determine"),
        (lambda: rh.flatness(np.ones(10)), r"^velocities: a component has no spread"),
        (lambda: rh.flatness(np.ones((2, 2, 2))), r"^velocities:"),
        (lambda: rh.flatness(np.arange(4.0), masses=[1, 1, 1]), r"^masses:"),
        (lambda: rh.flatness(np.arange(4.0), masses=[1, 0, 1, 1]), r"^masses:"),
        (lambda: rh.velocity_distribution(np.arange(4.0), 0), r"^bins:"),
        (lambda: rh.velocity_distribution(np.arange(4.0), [1, 0]), r"^bins:"),
        (lambda: rh.velocity_distribution(np.arange(4.0), [0, 1], limits=(0, 1)), r"^limits:"),
        (lambda: rh.velocity_distribution(np.arange(4.0), 4, limits=(1, 0)), r"^limits:"),
    ],
)
def test_bad_inputs_raise_value_error_naming_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_a_fit_that_does_not_converge_raises_value_error(monkeypatch):
    """curve_fit's RuntimeError (its evaluations used up) becomes a ValueError naming the
    axis, so that a study's report can mark the fit as not made rather than stop."""
    def exhausted(*args, **kwargs):
        raise RuntimeError("Optimal parameters not found: The maximum number of function "
                           "evaluations is exceeded.")

    monkeypatch.setattr(rh, "curve_fit", exhausted)
    I = np.geomspace(0.005, 1.0, 12)  # noqa: E741
    with pytest.raises(ValueError, match="I: the fit of .* did not converge"):
        rh.fit_mu_of_I(I, 0.1 + 0.4 / (1 + 0.08 / I))
