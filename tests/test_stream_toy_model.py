"""Seed 000's droplet-length toy model (:mod:`grainflow.analysis.stream.toy_model`).

* The slice's kinetic energy (pi/96) rho phi0 D^2 gamma^2 L0^3 equals the integral it
  stands for.
* The fit L0 = (F_c / Sigma)^(1/2) recovers Sigma from noisy synthetic lengths, and its
  standard error covers the truth about as often as one should.
* The length at the aperture averages the pairs' dz0 and leaves out those without one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from grainflow.analysis.stream import (DropletSeparation, aperture_length, fit_toy_model,
                                       gradient_kinetic_energy)


def test_slice_energy_is_the_integral_of_the_gradient_s_kinetic_energy():
    rho, phi, d_ap, gamma, length = 2500.0, 0.55, 3e-3, 40.0, 1.3e-3
    line_density = rho * phi * math.pi * d_ap ** 2 / 4
    integral, _ = quad(lambda z: 0.5 * line_density * (gamma * z) ** 2,
                       -length / 2, length / 2)
    value = gradient_kinetic_energy(length, density=rho, packing_fraction=phi,
                                    diameter=d_ap, shear_rate=gamma)
    assert value == pytest.approx(integral, rel=1e-12)
    with pytest.raises(ValueError, match="packing_fraction"):
        gradient_kinetic_energy(length, density=rho, packing_fraction=0.0, diameter=d_ap,
                                shear_rate=gamma)


def test_fit_recovers_sigma_and_its_error_covers_the_truth():
    sigma = 2.5  # N/m^2 = 2.5e-6 nN/um^2
    forces = np.array([100e-9, 300e-9, 1000e-9, 2000e-9])
    truth = np.sqrt(forces / sigma)
    rng = np.random.default_rng(11)
    covered = 0
    trials = 400
    for _ in range(trials):
        err = 0.08 * truth
        fit = fit_toy_model(forces, truth + rng.normal(0, err), err, grain_diameter=200e-6)
        covered += abs(fit.sigma - sigma) < fit.sigma_err
    assert 0.6 < covered / trials < 0.85  # one standard error: 68 %
    exact = fit_toy_model(forces, truth, grain_diameter=200e-6)
    assert exact.sigma == pytest.approx(sigma, rel=1e-12)
    assert exact.crossover_force == pytest.approx(sigma * (200e-6) ** 2, rel=1e-12)
    assert np.allclose(exact.length(forces), truth)


def test_fit_refuses_what_it_cannot_fit():
    with pytest.raises(ValueError, match="cohesion_force"):
        fit_toy_model([0.0, 1e-7], [1e-4, 2e-4], grain_diameter=2e-4)
    with pytest.raises(ValueError, match="length_err"):
        fit_toy_model([1e-7, 2e-7], [1e-4, 2e-4], [1e-5], grain_diameter=2e-4)
    with pytest.raises(ValueError, match="length"):
        fit_toy_model([1e-7, 2e-7], [1e-4, np.nan], grain_diameter=2e-4)


def _separation(dz0: float) -> DropletSeparation:
    t = np.array([0.0, 1e-3, 2e-3])
    return DropletSeparation(upper=0, lower=1, times=t, dz=1e-3 + 0.01 * t, velocity=0.01,
                             velocity_err=0.0, intercept=1e-3, n_grains_mean=50.0, t0=-0.01,
                             dz0=dz0, predicted_velocity=float("nan"))


def test_aperture_length_averages_the_pairs_with_a_length():
    result = aperture_length([_separation(2e-4), _separation(4e-4), _separation(float("nan")),
                              _separation(-1e-4)])
    assert result.pairs == 2
    assert result.mean == pytest.approx(3e-4)
    assert result.err == pytest.approx(np.std([2e-4, 4e-4], ddof=1) / math.sqrt(2))
    assert aperture_length([]).pairs == 0
