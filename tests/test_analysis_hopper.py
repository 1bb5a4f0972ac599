"""Tests of the hopper-flow analyses (SPEC A8) on synthetic data with known answers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from grainflow.analysis.coarse_grain import (
    centreline_velocity_profile,
    centreline_velocity_profile_from_frames,
    coarse_grain,
    gaussian_kernel,
    number_density,
    packing_fraction,
    velocity_field,
)
from grainflow.analysis.hopper import (
    beta_sigmoid,
    beverloo,
    fit_beta_sigmoid,
    fit_beverloo,
    flow_rate_from_cumulative,
    flow_rate_from_events,
    mser_truncation,
    orifice_number_density,
    overlap_corrected_flow_rate,
)
from grainflow.frame import Box, Frame
from grainflow.plotting.hopper_plots import (
    plot_beta_sigmoid,
    plot_beverloo,
    plot_flow_rate_timeseries,
    plot_velocity_profiles,
)
from grainflow.studies.hopper_results import fmt_lambda_c

SIGMA_S, SIGMA_L = 1.0 / 1.2, 1.4 / 1.2  # bidisperse 50:50, sigma_avg = 1 (seed 003 Sec. 2.2)
AREAS = np.pi / 4 * np.array([SIGMA_S, SIGMA_L]) ** 2


def poisson_events(rng: np.random.Generator, rate: float, duration: float, tau: float = 0.0):
    """Crossing times of a Poisson process of rate rate (1 - exp(-t/tau)) on [0, duration]."""
    n = rng.poisson(rate * duration)
    t = np.sort(rng.uniform(0.0, duration, n))
    if tau > 0:
        t = t[rng.uniform(size=n) < 1.0 - np.exp(-t / tau)]
    return t


def triangular_lattice(spacing: float, n: int) -> np.ndarray:
    i, j = (a.ravel() for a in np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1)))
    return np.column_stack([(i + 0.5 * (j % 2)) * spacing, j * spacing * np.sqrt(3) / 2])


def cubic_lattice(spacing: float, n: int) -> np.ndarray:
    g = np.arange(-n, n + 1) * spacing
    return np.stack(np.meshgrid(g, g, g), axis=-1).reshape(-1, 3)


# ------------------------------------------------------------------------- flow rate


def test_mser_finds_a_step_transient():
    rng = np.random.default_rng(1)
    series = rng.normal(size=400)
    series[:40] += 4.0
    assert 37 <= mser_truncation(series) <= 43
    assert mser_truncation(rng.normal(size=400)) < 100


def test_stationary_poisson_rate_and_error_bar():
    rng = np.random.default_rng(7)
    rate, duration = 20.0, 500.0
    t = poisson_events(rng, rate, duration)
    sizes = rng.choice(AREAS, t.size)
    fr = flow_rate_from_events(t, sizes, t_begin=0.0, t_end=duration)
    poisson_err = np.sqrt(fr.n_events) / (fr.t_end - fr.t_start)
    assert abs(fr.number_rate - rate) < 3 * fr.number_rate_err
    assert 0.5 < fr.number_rate_err / poisson_err < 2.0
    assert abs(fr.flow_rate - rate * AREAS.mean()) < 3 * fr.flow_rate_err
    assert fr.t_start < 0.2 * duration
    assert fr.n_events + fr.n_transient == t.size
    assert fr.block_number_rates.shape == (10,)
    assert np.isclose(fr.block_number_rates.mean(), fr.number_rate)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_startup_transient_is_cut(seed):
    rng = np.random.default_rng(seed)
    rate, tau, duration = 50.0, 30.0, 1000.0
    t = poisson_events(rng, rate, duration, tau)
    fr = flow_rate_from_events(t, t_begin=0.0, t_end=duration)
    assert tau < fr.t_start < duration / 2
    assert abs(fr.number_rate - rate) < 3 * fr.number_rate_err
    naive = t.size / duration  # keeping the transient biases the rate low by tau/duration
    assert rate - naive > 3 * fr.number_rate_err
    assert np.isnan(fr.flow_rate)


def test_imposed_steady_start_and_cumulative_input():
    rng = np.random.default_rng(3)
    t = poisson_events(rng, 10.0, 400.0)
    fr = flow_rate_from_events(t, 1.5, t_begin=0.0, t_end=400.0, t_steady=100.0)
    assert fr.t_start == 100.0
    assert fr.n_events == np.count_nonzero(t >= 100.0)
    assert np.isclose(fr.flow_rate, 1.5 * fr.number_rate)
    samples = np.linspace(0.0, 400.0, 4001)
    counts = np.searchsorted(t, samples, side="right")
    from_counts = flow_rate_from_cumulative(samples, counts, 1.5 * counts, t_steady=100.0)
    assert abs(from_counts.n_events - fr.n_events) <= 2  # events binned to the 0.1 sampling
    assert np.isclose(from_counts.number_rate, fr.number_rate, rtol=1e-3)
    assert np.isclose(from_counts.flow_rate, fr.flow_rate, rtol=1e-3)


def test_flow_rate_result_is_frozen_copy():
    rng = np.random.default_rng(4)
    t = poisson_events(rng, 5.0, 100.0)
    fr = flow_rate_from_events(t)
    t[:] = 0.0
    assert fr.times[0] > 0.0
    with pytest.raises(ValueError):
        fr.times[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        fr.number_rate = 0.0  # type: ignore[misc]


def test_flow_rate_rejects_bad_input():
    t = np.linspace(0.0, 10.0, 50)
    with pytest.raises(ValueError, match="times"):
        flow_rate_from_events(t)  # 50 < 10 blocks x 10 events
    with pytest.raises(ValueError, match="sizes"):
        flow_rate_from_events(np.linspace(0, 10, 200), -1.0)
    with pytest.raises(ValueError, match="t_steady"):
        flow_rate_from_events(np.linspace(0, 10, 200), t_steady=20.0)
    with pytest.raises(ValueError, match="counts"):
        flow_rate_from_cumulative([0.0, 1.0, 2.0], [0, 5, 3])


# ------------------------------------------------------------------------- Appendix B


def test_orifice_number_density_region_and_corrected_rate():
    # gravity along -x as drawn in the seed: up = +x; orifice at (2, 1), w = 3
    inside = np.array([[2.0, 1.0], [4.9, -1.9], [5.0, 4.0], [3.0, 3.5]])
    outside = np.array([[1.9, 1.0], [5.1, 1.0], [3.0, 4.1], [3.0, -2.1]])
    frame = np.vstack([inside, outside])
    rho, _ = orifice_number_density([frame, frame[:5]], [2.0, 1.0], 3.0, up=[1.0, 0.0])
    assert np.isclose(rho, (4 / 18 + 4 / 18) / 2)

    inside3 = np.array([[0.0, 0.0, 0.5], [1.9, 0.0, 1.9], [0.0, -1.4, 1.4]])
    outside3 = np.array([[1.5, 1.5, 1.0], [0.0, 0.0, -0.1], [0.0, 0.0, 2.1]])
    rho3, _ = orifice_number_density([np.vstack([inside3, outside3])], [0, 0, 0], 2.0)
    assert np.isclose(rho3, 3 / (np.pi * 8.0))

    corrected = overlap_corrected_flow_rate(
        2.0, 1.25, 0.8, flow_rate_err=0.1, number_density_err=0.05
    )
    assert np.isclose(corrected.flow_rate, 2.0 / (1.25 * 0.8))
    assert np.isclose(corrected.effective_size, 0.8)
    assert np.isclose(corrected.flow_rate_err, corrected.flow_rate * np.hypot(0.05, 0.04))
    with pytest.raises(ValueError, match="number_density"):
        overlap_corrected_flow_rate(2.0, 0.0, 0.8)
    with pytest.raises(ValueError, match="w"):
        orifice_number_density([frame], [0.0, 0.0], -1.0)


# ------------------------------------------------------------------------- Beverloo


def noisy_beverloo(rng, C, k, beta, rel_err=0.02):
    x = np.linspace(4.0, 12.0, 12)
    q = beverloo(x, C, k, beta)
    err = rel_err * q
    return x, q + err * rng.normal(size=x.size), err


@pytest.mark.parametrize(("C", "k", "beta"), [(0.14, 1.6, 1.5), (0.42, 3.4, 0.5), (0.1, 2.0, 2.5)])
def test_beverloo_fit_recovers_parameters(C, k, beta):
    x, q, err = noisy_beverloo(np.random.default_rng(11), C, k, beta)
    fit = fit_beverloo(2.0 * x, q, sigma_avg=2.0, Q_err=err)
    estimates = ((fit.C, fit.C_err, C), (fit.k, fit.k_err, k), (fit.beta, fit.beta_err, beta))
    for value, error, true in estimates:
        assert 0 < error < 0.5 * abs(true)
        assert abs(value - true) < 3 * error
    assert fit.k < x.min()
    assert fit.chi2 / fit.dof < 3.0
    assert np.allclose(fit.x, x)
    fixed = fit_beverloo(x, q, Q_err=err, beta=beta)
    assert fixed.beta_fixed and fixed.beta == beta and fixed.beta_err == 0.0
    assert abs(fixed.C - C) < 3 * fixed.C_err and abs(fixed.k - k) < 3 * fixed.k_err
    assert fixed.k_err < fit.k_err


def test_beverloo_uncertainties_are_calibrated():
    rng = np.random.default_rng(5)
    pulls = []
    for _ in range(150):
        x, q, err = noisy_beverloo(rng, 0.42, 3.4, 0.5)
        fit = fit_beverloo(x, q, Q_err=err)
        pulls.append((fit.beta - 0.5) / fit.beta_err)
    inside = np.mean(np.abs(pulls) < 1.0)
    assert 0.55 < inside < 0.82  # 68 % for calibrated standard uncertainties


def test_beverloo_without_errors_and_bad_input():
    x, q, _ = noisy_beverloo(np.random.default_rng(2), 0.14, 1.6, 1.5, rel_err=0.01)
    fit = fit_beverloo(x, q)
    assert np.all(np.isnan(fit.Q_err))
    assert abs(fit.beta - 1.5) < 3 * fit.beta_err
    with pytest.raises(ValueError, match="w: need more than 3"):
        fit_beverloo(x[:3], q[:3])
    with pytest.raises(ValueError, match="w: orifice widths must be positive"):
        fit_beverloo(-x, q)
    with pytest.raises(ValueError, match="Q"):
        fit_beverloo(x, np.where(x < 5, 0.0, q))


def test_bounded_beverloo_fit_as_the_paper_fitted():
    """The seed authors' bounded fit (beta <= 1.58, k >= 0.5): inside the bounds the free
    answer; beyond them the parameter stops on its bound and is marked, and the fit is
    worse than the free one."""
    x, q, err = noisy_beverloo(np.random.default_rng(3), 0.3, 0.8, 1.8, rel_err=0.01)
    free = fit_beverloo(x, q, Q_err=err)
    bounded = fit_beverloo(x, q, Q_err=err, beta_bounds=(1e-6, 1.58), k_min=0.5)
    assert abs(free.beta - 1.8) < 3 * free.beta_err and free.at_bound == ()
    assert bounded.beta == pytest.approx(1.58) and "beta" in bounded.at_bound
    assert bounded.k >= 0.5 and bounded.chi2 > free.chi2
    x, q, err = noisy_beverloo(np.random.default_rng(4), 0.14, 1.6, 1.5, rel_err=0.01)
    inside = fit_beverloo(x, q, Q_err=err, beta_bounds=(1e-6, 1.58), k_min=0.5)
    plain = fit_beverloo(x, q, Q_err=err)
    assert inside.at_bound == () and inside.beta == pytest.approx(plain.beta, rel=1e-4)
    low = fit_beverloo(x, q, Q_err=err, beta_bounds=(1e-6, 1.58), k_min=1.9)
    assert low.k == pytest.approx(1.9) and low.at_bound == ("k",)
    with pytest.raises(ValueError, match="beta_bounds"):
        fit_beverloo(x, q, beta=1.5, beta_bounds=(1.0, 2.0))
    with pytest.raises(ValueError, match="beta_bounds"):
        fit_beverloo(x, q, beta_bounds=(2.0, 1.0))
    with pytest.raises(ValueError, match="k_min"):
        fit_beverloo(x, q, k_min=float(x.min()) + 1.0)


# ------------------------------------------------------------------------- eq. 14


def test_beta_sigmoid_limits():
    for d in (2, 3):
        lam = np.array([1e-14, 0.05, 1e14])
        assert np.allclose(beta_sigmoid(lam, 0.05, 2.0, d), [d - 0.5, d - 1.0, d - 1.5])


@pytest.mark.parametrize(("dim", "lambda_c", "b"), [(2, 0.05, 2.0), (3, 0.07, 3.0)])
def test_sigmoid_fit_recovers_lambda_c_and_b(dim, lambda_c, b):
    rng = np.random.default_rng(dim)
    lam = np.logspace(-4, 4, 17)
    err = np.full(lam.size, 0.03)
    beta = beta_sigmoid(lam, lambda_c, b, dim) + err * rng.normal(size=lam.size)
    fit = fit_beta_sigmoid(lam, beta, dim=dim, beta_err=err)
    assert abs(fit.lambda_c - lambda_c) < 3 * fit.lambda_c_err
    assert abs(fit.b - b) < 3 * fit.b_err
    assert fit.b_err < 0.5 * b and fit.lambda_c_err < lambda_c
    assert np.isclose(fit.lambda_c_err, np.log(10) * fit.lambda_c * fit.log10_lambda_c_err)
    with pytest.raises(ValueError, match="lam"):
        fit_beta_sigmoid(np.r_[0.0, lam], np.r_[dim - 0.5, beta], dim=dim)


# ------------------------------------------------------------------------- coarse graining


def test_gaussian_kernel_integrates_to_one():
    g = np.linspace(-5, 5, 401)
    dx = g[1] - g[0]
    xx, yy = np.meshgrid(g, g)
    assert np.isclose(gaussian_kernel(xx**2 + yy**2, 1.0, 2).sum() * dx**2, 1.0, rtol=1e-3)
    g3 = np.linspace(-5, 5, 101)
    r2 = sum(c**2 for c in np.meshgrid(g3, g3, g3))
    assert np.isclose(gaussian_kernel(r2, 1.0, 3).sum() * (g3[1] - g3[0]) ** 3, 1.0, rtol=1e-3)


def test_uniform_lattice_2d_velocity_density_packing():
    spacing = 1.1
    pos = triangular_lattice(spacing, 30)
    v = np.array([0.3, -1.7])
    vel = np.tile(v, (pos.shape[0], 1))
    points = np.random.default_rng(0).uniform(-12, 12, (40, 2))  # > 4 sigma inside the lattice
    n_lattice = 2.0 / (np.sqrt(3) * spacing**2)
    assert np.allclose(number_density(points, pos, sigma=1.0), n_lattice, rtol=1e-3)
    sizes = np.full(pos.shape[0], np.pi / 4)
    packing = packing_fraction(points, pos, sizes, sigma=1.0)
    assert np.allclose(packing, n_lattice * np.pi / 4, rtol=1e-3)
    assert np.allclose(velocity_field(points, pos, vel, sigma=1.0), v, rtol=1e-12)
    assert np.allclose(coarse_grain(points, pos, vel, sigma=1.0), n_lattice * v, rtol=1e-3)
    far = velocity_field(np.array([[100.0, 0.0]]), pos, vel, sigma=1.0)
    assert np.all(np.isnan(far))


def test_uniform_lattice_3d_velocity_and_density():
    spacing = 0.9
    pos = cubic_lattice(spacing, 11)
    v = np.array([0.1, 0.2, -2.0])
    masses = np.random.default_rng(1).uniform(1.0, 2.0, pos.shape[0])
    points = np.random.default_rng(2).uniform(-4.5, 4.5, (20, 3))
    assert np.allclose(number_density(points, pos, sigma=1.0), spacing**-3, rtol=1e-3)
    vel = np.tile(v, (pos.shape[0], 1))
    assert np.allclose(velocity_field(points, pos, vel, sigma=1.0, masses=masses), v, rtol=1e-12)


def test_centreline_profile_from_frames():
    pos = triangular_lattice(1.0, 25)
    heights = np.linspace(0.0, 15.0, 16)
    frames = []
    for vz in (-1.0, -3.0):  # two frames, downward speeds 1 and 3 (up = +y)
        n = pos.shape[0]
        frames.append(Frame(
            step=0, time=0.0, box=Box(np.full(2, -30.0), np.full(2, 30.0), (False, False)),
            id=np.arange(n), type=np.zeros(n, np.int32), body=np.full(n, -1),
            radius=np.full(n, 0.5), mass=np.ones(n), position=pos,
            velocity=np.column_stack([np.zeros(n), np.full(n, vz)]), omega=np.zeros((n, 3)),
        ))
    prof = centreline_velocity_profile_from_frames(frames, heights, [0.0, -5.0], sigma=1.0)
    assert prof.n_frames == 2 and prof.dim == 2
    assert np.allclose(prof.velocity, 2.0)
    assert np.allclose(prof.number_density, 2 / np.sqrt(3), rtol=1e-3)
    assert np.allclose(prof.flux, 2.0 * prof.number_density)
    sideways = centreline_velocity_profile(
        [pos], [np.tile([-1.5, 0.0], (pos.shape[0], 1))], heights, [-5.0, 0.0], sigma=1.0, up=[1, 0]
    )
    assert np.allclose(sideways.velocity, 1.5)


# ------------------------------------------------------------------------- plots


def _is_png(path) -> bool:
    data = path.read_bytes()
    return data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_plots_write_png_files(tmp_path):
    rng = np.random.default_rng(9)
    fits = [fit_beverloo(*noisy_beverloo(rng, 0.14, 1.6, 1.5)[:2]),
            fit_beverloo(*noisy_beverloo(rng, 0.42, 3.4, 0.5)[:2], beta=0.5)]
    assert _is_png(plot_beverloo(fits, tmp_path / "beverloo.png", labels=["a", "b"]))

    lam = np.logspace(-3, 3, 9)
    sig = fit_beta_sigmoid(lam, beta_sigmoid(lam, 0.05, 2.0, 2) + 0.01 * rng.normal(size=9), dim=2)
    assert _is_png(plot_beta_sigmoid(sig, tmp_path / "sigmoid.png"))

    t = poisson_events(rng, 10.0, 300.0, tau=10.0)
    fr = flow_rate_from_events(t, rng.choice(AREAS, t.size), t_begin=0.0, t_end=300.0)
    assert _is_png(plot_flow_rate_timeseries(fr, tmp_path / "sub" / "flow.png"))

    pos = triangular_lattice(1.0, 20)
    profiles, widths = [], [4.0, 7.0, 10.6]
    for w in widths:
        v_down = np.sqrt(w) * (1 + np.exp(-np.abs(pos[:, 1]) / w))
        vel = np.column_stack([np.zeros(len(pos)), -v_down])
        heights = np.linspace(0, 15, 61)
        profiles.append(centreline_velocity_profile([pos], [vel], heights, [0, 0], sigma=1.0))
    assert _is_png(plot_velocity_profiles(profiles, widths, tmp_path / "v.png"))
    scaled = plot_velocity_profiles(
        profiles, widths, tmp_path / "vs.png", scaled=True, quantity="flux"
    )
    assert _is_png(scaled)
    with pytest.raises(ValueError, match="quantity"):
        plot_velocity_profiles(profiles, widths, tmp_path / "x.png", quantity="speed")


def test_sigmoid_between_measured_limits():
    """limits = (beta_0, beta_inf) replace d - 1/2 and d - 3/2: the midpoint is halfway between
    them at lambda_c, and a fit recovers lambda_c where eq. (14)'s fixed limits put it
    elsewhere (here: later, as the 2D hopper's 1.76 / 0.62 limits do)."""
    lam = np.logspace(-3, 1, 13)
    assert np.allclose(beta_sigmoid(np.array([1e-14, 0.05, 1e14]), 0.05, 1.0, 2, (1.8, 0.6)),
                       [1.8, 1.2, 0.6])
    beta = beta_sigmoid(lam, 0.05, 0.8, 2, (1.8, 0.6))
    fit = fit_beta_sigmoid(lam, beta, dim=2, limits=(1.8, 0.6))
    assert fit.lambda_c == pytest.approx(0.05, rel=1e-6) and fit.levels == (1.8, 1.2, 0.6)
    np.testing.assert_allclose(fit.predict(lam), beta, atol=1e-9)
    fixed = fit_beta_sigmoid(lam, beta, dim=2)
    assert fixed.lambda_c > 0.08 and fixed.levels == (1.5, 1.0, 0.5)
    with pytest.raises(ValueError, match="limits"):
        fit_beta_sigmoid(lam, beta, dim=2, limits=(1.0, 1.0))


def test_sigmoid_step_is_not_resolved(tmp_path):
    """Where beta jumps between two sampled lambdas the fit narrows to a step and its
    curvature error means nothing: ``resolved`` says so and ``bracket`` gives the samples
    around the jump. Data: the free 3D betas of the W = 16.7 sigma_avg lambda sweep
    (2026-12-06), whose fixed-limit fit gave lambda_c = 0.1806 ± 0.0002 with b = 0.001."""
    lam = np.array([0.01, 0.05, 0.180956, 1.0])
    beta, err = np.array([3.74, 3.12, 1.70, 1.21]), np.array([0.39, 0.32, 0.20, 0.11])
    step = fit_beta_sigmoid(lam, beta, dim=3, beta_err=err)
    assert not step.resolved and step.transition_lambdas.size < 2
    low, high = step.bracket
    assert 0.05 <= low < step.lambda_c < high <= 1.0
    assert fmt_lambda_c(step) == f"not resolved: a step between λ = {low:g} and {high:g}"
    between = fit_beta_sigmoid(lam, beta, dim=3, beta_err=err, limits=(3.96, 0.85))
    assert between.resolved and between.transition_lambdas.size >= 2
    assert fmt_lambda_c(between).startswith(f"{between.lambda_c:.3g} ± ")
    assert fmt_lambda_c(None) == "not fit"
    assert plot_beta_sigmoid([step, between], tmp_path / "step.png").stat().st_size > 0


def test_sigmoid_resolution_counts_distinct_lambdas():
    """Two realizations at the same lambdas (a pooled fit) count each lambda once: a smooth
    sigmoid sampled at one lambda per decade has one sample in its transition whatever the
    number of realizations."""
    lam = np.logspace(-4, 2, 7)
    beta = beta_sigmoid(lam, 0.03, 0.3, 2)
    one = fit_beta_sigmoid(lam, beta, dim=2)
    two = fit_beta_sigmoid(np.r_[lam, lam], np.r_[beta, beta], dim=2)
    assert one.transition_lambdas.size == two.transition_lambdas.size
    assert one.resolved == two.resolved
    dense = np.logspace(-4, 2, 25)
    assert fit_beta_sigmoid(dense, beta_sigmoid(dense, 0.03, 0.3, 2), dim=2).resolved
