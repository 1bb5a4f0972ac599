"""Jet analyses of seed 002 chapter 4 (grainflow.analysis.jet) and their plots
(grainflow.plotting.jet_plots): scattering angle, the psi0(X) fit, the azimuthal flux and v2,
the eccentricity of a rectangular jet, and the dead zone, on synthetic frames whose answers are
known."""

from __future__ import annotations

from math import pi

import numpy as np
import pytest

from grainflow.analysis import jet
from grainflow.analysis.cg import Cartesian, coarse_grain
from grainflow.frame import Box, Frame
from grainflow.plotting.jet_plots import (plot_azimuthal_flux, plot_psi0,
                                          plot_v2_vs_eccentricity)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
C_SEED = dict(zip(("C0", "C1", "C2"), jet.SEED_PSI0_FIT))


def make_frame(pos, vel, *, types=None, mass=1.0, time=0.0, step=0):
    pos = np.asarray(pos, dtype=float)
    n, dim = pos.shape
    return Frame(step=step, time=time,
                 box=Box(np.full(dim, -50.0), np.full(dim, 50.0), (False,) * dim),
                 id=np.arange(n, dtype=np.int64),
                 type=np.zeros(n, np.int32) if types is None else np.asarray(types, np.int32),
                 body=-np.ones(n, np.int64), radius=np.full(n, 0.5),
                 mass=np.broadcast_to(np.asarray(mass, dtype=float), (n,)).copy(),
                 position=pos, velocity=np.asarray(vel, dtype=float), omega=np.zeros((n, 3)))


def concat(*parts):
    """Frame from (pos, vel, type) parts."""
    pos = np.concatenate([p for p, _, _ in parts])
    vel = np.concatenate([v for _, v, _ in parts])
    types = np.concatenate([np.full(len(p), t) for p, _, t in parts])
    return pos, vel, types


# 3D geometry used below: R_tar = 3, R_jet = 2.25 -> shell 7.5 <= r < 9.5 with the defaults
R_TAR, R_JET = 3.0, 2.25
R_SHELL = 1.5 * max(R_TAR, R_JET) + 3.0


def target_3d(r_tar=R_TAR):
    g = np.arange(-r_tar, r_tar + 0.5, 1.0)
    xx, yy = np.meshgrid(g, g)
    keep = np.hypot(xx, yy) <= r_tar
    pos = np.column_stack([xx[keep], yy[keep], np.full(keep.sum(), -0.5)])
    return pos, np.zeros_like(pos), jet.TARGET_TYPE


def incoming_jet_3d(rng, n=400):
    """Jet grains upstream moving at -u0 along z; some of them cross the shell inward."""
    rho = R_JET * np.sqrt(rng.uniform(size=n))
    a = rng.uniform(0, 2 * pi, n)
    pos = np.column_stack([rho * np.cos(a), rho * np.sin(a), rng.uniform(1.0, 12.0, n)])
    vel = np.tile([0.0, 0.0, -1.0], (n, 1))
    return pos, vel, 0


def cone_3d(rng, n, angle, *, speed=0.8, noise=0.0, r_lo=R_SHELL, r_hi=R_SHELL + 2.0):
    """Grains on the cone at ``angle`` from the direction of travel -z, moving along it."""
    a = rng.uniform(0, 2 * pi, n)
    r = rng.uniform(r_lo + 0.01, r_hi - 0.01, n)
    e = np.column_stack([np.sin(angle) * np.cos(a), np.sin(angle) * np.sin(a),
                         np.full(n, -np.cos(angle))])
    return r[:, None] * e, speed * e + rng.normal(scale=noise, size=(n, 3)), 1


# --------------------------------------------------------------------------------------------
# Scattering angle
# --------------------------------------------------------------------------------------------


def test_a_perfect_sheet_scatters_at_half_pi_and_the_incoming_jet_is_ignored():
    rng = np.random.default_rng(1)
    pos, vel, types = concat(target_3d(), incoming_jet_3d(rng), cone_3d(rng, 300, pi / 2))
    frame = make_frame(pos, vel, types=types)
    res = jet.scattering_angle(frame, target_radius=R_TAR, jet_radius=R_JET)
    assert res.psi0 == pytest.approx(pi / 2, abs=1e-12)
    assert res.n_grains == 300
    assert res.shell_radius == pytest.approx(R_SHELL)
    assert res.X == pytest.approx(R_TAR / R_JET)
    assert res.blocks == 1 and np.isfinite(res.psi0_err)


def test_a_2d_sheet_along_the_target_line_is_half_pi():
    rng = np.random.default_rng(2)
    n = 200
    y = rng.uniform(R_SHELL + 0.1, R_SHELL + 1.9, n) * rng.choice([-1.0, 1.0], n)
    pos = np.column_stack([rng.uniform(0.4, 0.6, n), y])
    vel = np.column_stack([np.zeros(n), 0.7 * np.sign(y)])
    jet_pos = np.column_stack([rng.uniform(1, 12, 100), rng.uniform(-R_JET, R_JET, 100)])
    frame = make_frame(np.vstack([pos, jet_pos]),
                       np.vstack([vel, np.tile([-1.0, 0.0], (100, 1))]))
    res = jet.scattering_angle(frame, target_radius=R_TAR, jet_radius=R_JET)
    assert res.psi0 == pytest.approx(pi / 2, abs=1e-12)
    assert res.n_grains == n


@pytest.mark.parametrize("angle", [0.6, 1.2, jet.SEED_PSI0_FIT[0]])
def test_a_cone_gives_its_angle_forward_and_backward(angle):
    rng = np.random.default_rng(3)
    frame = make_frame(*concat(cone_3d(rng, 400, angle), incoming_jet_3d(rng))[:2])
    res = jet.scattering_angle(frame, target_radius=R_TAR, jet_radius=R_JET)
    assert res.psi0 == pytest.approx(angle, abs=1e-9)
    assert res.axial == pytest.approx(0.8 * np.cos(angle))
    assert res.radial == pytest.approx(0.8 * np.sin(angle))


def test_a_2d_cone_gives_its_angle():
    rng = np.random.default_rng(4)
    n, angle = 300, 0.9
    side = rng.choice([-1.0, 1.0], n)
    e = np.column_stack([-np.full(n, np.cos(angle)), side * np.sin(angle)])
    r = rng.uniform(R_SHELL + 0.1, R_SHELL + 1.9, n)
    frame = make_frame(r[:, None] * e, 0.6 * e)
    res = jet.scattering_angle(frame, target_radius=R_TAR, jet_radius=R_JET)
    assert res.psi0 == pytest.approx(angle, abs=1e-9)


def test_undeflected_jet_grains_beside_a_small_target_are_ignored():
    rng = np.random.default_rng(5)
    r_tar, r_jet = 1.0, 2.25
    r_s = 1.5 * r_jet + 3.0
    cone = cone_3d(rng, 300, 0.8, r_lo=r_s, r_hi=r_s + 2.0)
    # jet grains passing the target's edge undeflected, below it and inside the shell
    n = 500
    rho = rng.uniform(r_tar + 0.1, r_jet, n)
    a = rng.uniform(0, 2 * pi, n)
    z = -np.sqrt(rng.uniform(r_s**2 + 0.1, (r_s + 1.9) ** 2, n) - rho**2)
    beside = (np.column_stack([rho * np.cos(a), rho * np.sin(a), z]),
              np.tile([0.0, 0.0, -1.0], (n, 1)) + rng.normal(scale=0.02, size=(n, 3)), 0)
    frame = make_frame(*concat(cone, beside)[:2])
    kwargs = dict(target_radius=r_tar, jet_radius=r_jet)
    res = jet.scattering_angle(frame, **kwargs)
    assert res.psi0 == pytest.approx(0.8, abs=1e-9)
    assert res.n_grains == 300
    # without the deflection filter they would pull psi0 towards zero
    unfiltered = jet.scattering_angle(frame, deflection=0.0, **kwargs)
    assert unfiltered.n_grains == 800
    assert unfiltered.psi0 < 0.5


def test_flux_weighting_gives_the_direction_of_the_momentum_flux():
    """Fast grains on a forward cone and slow ones on a sheet: the flux weighting weights each
    grain by m v_r (momentum flux, speed^2 per grain), the count weighting by m (speed)."""
    rng = np.random.default_rng(6)
    a1, s1, n1 = 0.5, 1.0, 200
    a2, s2, n2 = 1.5, 0.3, 400
    frame = make_frame(*concat(cone_3d(rng, n1, a1, speed=s1),
                               cone_3d(rng, n2, a2, speed=s2))[:2])
    flux = jet.scattering_angle(frame, target_radius=R_TAR, jet_radius=R_JET)
    count = jet.scattering_angle(frame, target_radius=R_TAR, jet_radius=R_JET,
                                 weighting="count")

    def expected(p):
        return np.arctan2(n1 * s1**p * np.sin(a1) + n2 * s2**p * np.sin(a2),
                          n1 * s1**p * np.cos(a1) + n2 * s2**p * np.cos(a2))

    assert flux.psi0 == pytest.approx(expected(2), abs=1e-9)
    assert count.psi0 == pytest.approx(expected(1), abs=1e-9)
    assert count.psi0 - flux.psi0 > 0.1
    # one speed for all: the weightings agree
    same = make_frame(*concat(cone_3d(rng, n1, a1), cone_3d(rng, n2, a2))[:2])
    both = [jet.scattering_angle(same, target_radius=R_TAR, jet_radius=R_JET, weighting=w).psi0
            for w in ("flux", "count")]
    assert both[0] == pytest.approx(both[1], abs=1e-12)


def test_noisy_cone_over_frames_error_matches_the_scatter_of_repeats():
    angle = 1.2

    def run(seed):
        rng = np.random.default_rng(seed)
        frames = [make_frame(*cone_3d(rng, 40, angle, noise=0.15)[:2], time=float(t), step=t)
                  for t in range(20)]
        return jet.scattering_angle(frames, target_radius=R_TAR, jet_radius=R_JET)

    results = [run(seed) for seed in range(40)]
    psi = np.array([r.psi0 for r in results])
    err = np.array([r.psi0_err for r in results])
    assert results[0].blocks == 10 and results[0].n_frames == 20
    assert abs(psi.mean() - angle) < 4 * psi.std(ddof=1) / np.sqrt(psi.size)
    assert 0.7 < err.mean() / psi.std(ddof=1) < 1.4
    assert abs(psi[0] - angle) < 4 * err[0]


def test_window_and_grain_selection():
    rng = np.random.default_rng(7)
    frames = []
    for t in range(10):
        angle = 0.6 if t < 5 else 1.2
        fast = cone_3d(rng, 50, angle)
        other = cone_3d(rng, 50, 1.5)
        pos, vel, _ = concat(fast, other)
        types = np.r_[np.zeros(50), np.ones(50)]
        frames.append(make_frame(pos, vel, types=types, time=float(t), step=t))
    kwargs = dict(target_radius=R_TAR, jet_radius=R_JET)
    late = jet.scattering_angle(iter(frames), window=(5.0, 9.0), grains=[0], **kwargs)
    assert late.n_frames == 5 and late.n_grains == 250
    assert late.psi0 == pytest.approx(1.2, abs=1e-9)
    only_ones = jet.scattering_angle(frames, grains=lambda f: f.type == 1, **kwargs)
    assert only_ones.psi0 == pytest.approx(1.5, abs=1e-9)


# --------------------------------------------------------------------------------------------
# psi0(X) and its fit
# --------------------------------------------------------------------------------------------


def test_interpolation_function_has_the_thesis_asymptotes():
    c0, c1, c2 = jet.SEED_PSI0_FIT
    assert jet.psi0_interpolation(0.0, c0, c1, c2) == pytest.approx(c2)
    assert jet.psi0_interpolation(1e-3, c0, c1, c2) == pytest.approx(c1 * 1e-3 + c2, rel=1e-6)
    assert jet.psi0_interpolation(50.0, c0, c1, c2) == pytest.approx(c0)
    x = np.linspace(0.1, 5, 50)
    assert np.all(np.diff(jet.psi0_interpolation(x, c0, c1, c2)) > 0)


def test_fit_psi0_recovers_its_parameters_within_errors():
    rng = np.random.default_rng(8)
    x = np.linspace(0.2, 4.0, 30)
    sigma = 0.02
    y = jet.psi0_interpolation(x, **C_SEED) + rng.normal(scale=sigma, size=x.size)
    fit = jet.fit_psi0(x, y, sigma)
    # the parameters are strongly correlated: test jointly, d^T cov^-1 d below the 99.9%
    # quantile of chi^2 with 3 degrees of freedom, and each within 4 standard errors
    d = np.array([getattr(fit, name) - true for name, true in C_SEED.items()])
    assert d @ np.linalg.solve(fit.covariance, d) < 16.27
    for k, name in enumerate(C_SEED):
        assert abs(d[k]) < 4 * getattr(fit, f"{name}_err"), name
        assert 0 < getattr(fit, f"{name}_err") < 0.05
    assert fit.absolute_sigma and fit.dof == 27 and fit.n_points == 30
    assert 0.4 < fit.chi2_dof < 1.8
    assert fit.covariance.shape == (3, 3)
    np.testing.assert_allclose(np.sqrt(np.diag(fit.covariance)),
                               [fit.C0_err, fit.C1_err, fit.C2_err])
    np.testing.assert_allclose(fit.predict(x), jet.psi0_interpolation(x, fit.C0, fit.C1, fit.C2))
    # without errors: scaled by the residual variance, close to the absolute ones
    scaled = jet.fit_psi0(x, y)
    assert not scaled.absolute_sigma
    assert scaled.C0 == pytest.approx(fit.C0, abs=1e-6)
    assert scaled.C0_err == pytest.approx(fit.C0_err * np.sqrt(fit.chi2_dof), rel=1e-3)


def test_fit_psi0_errors_are_calibrated_over_repeats():
    rng = np.random.default_rng(9)
    x = np.linspace(0.2, 4.0, 20)
    fits = [jet.fit_psi0(x, jet.psi0_interpolation(x, **C_SEED)
                         + rng.normal(scale=0.03, size=x.size), 0.03) for _ in range(60)]
    for name in C_SEED:
        values = np.array([getattr(f, name) for f in fits])
        errs = np.array([getattr(f, f"{name}_err") for f in fits])
        assert 0.7 < errs.mean() / values.std(ddof=1) < 1.4, name


def test_fit_psi0_rejects_bad_data():
    x = np.linspace(0.2, 4, 10)
    y = jet.psi0_interpolation(x, **C_SEED)
    with pytest.raises(ValueError, match="psi0: expected shape"):
        jet.fit_psi0(x, y[:-1])
    with pytest.raises(ValueError, match="X: values must be finite and > 0"):
        jet.fit_psi0(x - 1.0, y)
    with pytest.raises(ValueError, match="X: need more than 3 points"):
        jet.fit_psi0(x[:3], y[:3])
    with pytest.raises(ValueError, match="psi0_err"):
        jet.fit_psi0(x, y, -0.1)
    with pytest.raises(ValueError, match="psi0: contains NaN"):
        jet.fit_psi0(x, np.where(x > 3, np.nan, y))


# --------------------------------------------------------------------------------------------
# Azimuthal flux and v2
# --------------------------------------------------------------------------------------------


def elliptic_sample(rng, n, v2):
    """phi distributed as (1 + 2 v2 cos 2 phi) / 2 pi, by rejection."""
    out = np.empty(0)
    while out.size < n:
        phi = rng.uniform(-pi, pi, 2 * n)
        keep = rng.uniform(0, 1 + 2 * abs(v2), 2 * n) < 1 + 2 * v2 * np.cos(2 * phi)
        out = np.concatenate([out, phi[keep]])
    return out[:n]


def sheet_frames(rng, n_frames, n_per_frame, v2):
    frames = []
    for t in range(n_frames):
        phi = elliptic_sample(rng, n_per_frame, v2)
        r = rng.uniform(R_SHELL + 0.1, R_SHELL + 1.9, phi.size)
        e = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(phi.size)])
        pos = r[:, None] * e + np.array([0.0, 0.0, 0.5])
        frames.append(make_frame(pos, 0.7 * e, time=float(t), step=t))
    return frames


def test_v2_of_a_sampled_elliptic_distribution_is_recovered_within_its_error():
    rng = np.random.default_rng(10)
    v2, n = 0.16, 20000
    frames = sheet_frames(rng, 1, n, v2)
    res = jet.anisotropy_v2(frames, target_radius=R_TAR, jet_radius=R_JET)
    expected_err = np.sqrt((0.5 - v2**2) / n)  # var cos 2phi = 1/2 - v2^2 for this law
    assert res.v_err == pytest.approx(expected_err, rel=0.15)
    assert abs(res.v - v2) < 3 * res.v_err
    assert res.n_grains == n and res.order == 2 and res.weighting == "flux"
    # measured from the long axis (y) the sign flips exactly
    from_y = jet.anisotropy_v2(frames, target_radius=R_TAR, jet_radius=R_JET,
                               reference_axis=(0, 1, 0))
    assert from_y.v == pytest.approx(-res.v, abs=1e-12)
    # radial velocities: the velocity azimuth is the position azimuth
    by_velocity = jet.anisotropy_v2(frames, target_radius=R_TAR, jet_radius=R_JET,
                                    azimuth="velocity")
    assert by_velocity.v == pytest.approx(res.v, abs=1e-12)
    # block errors over 10 frames of the same total size
    blocked = jet.anisotropy_v2(sheet_frames(rng, 10, n // 10, v2), target_radius=R_TAR,
                                jet_radius=R_JET)
    assert blocked.blocks == 10
    assert 0.5 < blocked.v_err / expected_err < 1.6
    assert abs(blocked.v - v2) < 3 * blocked.v_err


def test_azimuthal_flux_histogram_and_harmonics():
    rng = np.random.default_rng(11)
    v2 = 0.2
    frames = sheet_frames(rng, 8, 3000, v2)
    flux = jet.azimuthal_flux(frames, target_radius=R_TAR, jet_radius=R_JET, n_bins=24)
    assert flux.density.shape == (24,) and flux.edges[0] == -pi and flux.edges[-1] == pi
    assert np.sum(flux.density * np.diff(flux.edges)) == pytest.approx(1.0)
    # histogram follows (1 + 2 v2 cos 2phi) / 2 pi within its errors (binning is 1% here)
    expected = (1 + 2 * v2 * np.cos(2 * flux.centres)) / (2 * pi)
    pulls = (flux.density - expected) / flux.density_err
    assert np.all(np.isfinite(pulls)) and np.sqrt(np.mean(pulls**2)) < 1.6
    v = dict(zip(flux.orders.tolist(), flux.v))
    verr = dict(zip(flux.orders.tolist(), flux.v_err))
    assert abs(v[2] - v2) < 3 * verr[2]
    for k in (1, 3, 4):
        assert abs(v[k]) < 3 * verr[k]
    same = jet.anisotropy_v2(frames, target_radius=R_TAR, jet_radius=R_JET)
    assert same.v == pytest.approx(v[2])
    np.testing.assert_allclose(flux.model(flux.centres), (1 + 2 * v[2] * np.cos(2 * flux.centres))
                               / (2 * pi))


def test_flux_weighted_v2_counts_crossings_not_lingering_grains():
    """Grains along x move slowly (they are oversampled in a snapshot): counted v2 > 0, but
    weighted by v_r the flux is isotropic."""
    rng = np.random.default_rng(12)
    n = 4000
    phi = rng.uniform(-pi, pi, n)
    speed = 1.0 / (1.0 + 0.5 * np.cos(2 * phi))  # density ~ 1/speed at equal flux
    extra = rng.uniform(size=n) < 0.5 * np.cos(2 * phi)  # more grains where slow
    phi = np.concatenate([phi, phi[extra]])
    speed = np.concatenate([speed, speed[extra]])
    r = rng.uniform(R_SHELL + 0.1, R_SHELL + 1.9, phi.size)
    e = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(phi.size)])
    frame = make_frame(r[:, None] * e, speed[:, None] * e)
    kwargs = dict(target_radius=R_TAR, jet_radius=R_JET)
    counted = jet.anisotropy_v2(frame, weighting="count", **kwargs)
    flux = jet.anisotropy_v2(frame, **kwargs)
    w = speed
    assert flux.v == pytest.approx(np.sum(w * np.cos(2 * phi)) / np.sum(w))
    assert counted.v == pytest.approx(np.mean(np.cos(2 * phi)))
    assert counted.v - flux.v > 5 * counted.v_err


def test_the_2d_jet_has_no_azimuth():
    frame = make_frame([[-8.0, 0.5], [-8.0, -0.5]], [[0.0, 0.5], [0.0, -0.5]])
    with pytest.raises(ValueError, match="3D frames; a 2D jet has no azimuth"):
        jet.anisotropy_v2(frame, target_radius=R_TAR, jet_radius=R_JET)
    with pytest.raises(ValueError, match="3D frames"):
        jet.azimuthal_flux(frame, target_radius=R_TAR, jet_radius=R_JET)


def test_eccentricity_round_trip():
    l_ = np.array([1.0, 1.5, 2.0, 4.0, 0.5])
    eps = jet.eccentricity(l_)
    np.testing.assert_allclose(jet.aspect_ratio(eps), l_)
    assert jet.eccentricity(1.0) == 0.0
    assert jet.eccentricity(0.5) == pytest.approx(-jet.eccentricity(2.0))
    l_exp = jet.aspect_ratio(jet.SEED_V2[0])
    assert l_exp == pytest.approx(2.048, abs=1e-3)
    short, long = jet.rectangle_sides(l_exp)
    assert short * long == pytest.approx(jet.JET_AREA) and long / short == pytest.approx(l_exp)
    # eps of the uniform rectangle from its second moments
    xs, ys = np.meshgrid(np.linspace(-short / 2, short / 2, 401),
                         np.linspace(-long / 2, long / 2, 401))
    mx, my = np.mean(xs**2), np.mean(ys**2)
    assert (my - mx) / (my + mx) == pytest.approx(jet.SEED_V2[0], rel=1e-2)
    with pytest.raises(ValueError, match="aspect"):
        jet.eccentricity(0.0)
    with pytest.raises(ValueError, match="eps"):
        jet.aspect_ratio(1.0)
    with pytest.raises(ValueError, match="aspect"):
        jet.rectangle_sides(0.5)


# --------------------------------------------------------------------------------------------
# Dead zone
# --------------------------------------------------------------------------------------------


def layered_2d(rng, *, frozen: bool, r_tar=10.0, n_frames=10):
    """Grains on a triangular-ish lattice over |y| <= r_tar: layer (a) 0 < x <= 5 frozen (or
    hot), layer (b) 5 < x <= 10 flowing and hot; target particles at x = -0.5."""
    ys = np.arange(-r_tar + 0.5, r_tar, 1.0)
    frames = []
    for t in range(n_frames):
        pa = np.array([(x, y) for x in np.arange(0.55, 5.0, 1.0) for y in ys])
        pb = np.array([(x, y) for x in np.arange(5.55, 10.0, 1.0) for y in ys])
        va = rng.normal(scale=0.005 if frozen else 0.3, size=pa.shape)
        vb = np.column_stack([np.full(len(pb), -0.2), 0.5 * np.sign(pb[:, 1])])
        vb = vb + rng.normal(scale=0.2, size=pb.shape)
        wall = np.column_stack([np.full(ys.size, -0.5), ys])
        pos = np.vstack([pa, pb, wall])
        vel = np.vstack([va, vb, np.zeros_like(wall)])
        types = np.r_[np.zeros(len(pa) + len(pb)), np.full(len(wall), jet.TARGET_TYPE)]
        frames.append(make_frame(pos, vel, types=types, time=float(t), step=t))
    return frames


def test_dead_zone_found_in_a_frozen_layer_and_absent_in_a_hot_one():
    rng = np.random.default_rng(13)
    frozen = jet.dead_zone(layered_2d(rng, frozen=True), target_radius=10.0, lateral_bins=5)
    assert frozen.mask.shape == (2, 5)
    assert frozen.mask[0].all() and not frozen.mask[1].any()
    assert frozen.found and frozen.height == 5.0
    np.testing.assert_allclose(frozen.thickness, 5.0)
    assert frozen.extent == ((0.0, 5.0), (-10.0, 10.0))
    assert np.all(frozen.samples > 0)
    hot = jet.dead_zone(layered_2d(rng, frozen=False), target_radius=10.0, lateral_bins=5)
    assert not hot.mask.any() and not hot.found and hot.height == 0.0
    # the mean speed of the hot layer is small: the temperature decides
    assert np.all(hot.speed[0] < hot.speed_threshold)
    assert np.all(hot.thermal_speed[0] > 3 * hot.thermal_threshold)


def test_dead_zone_from_coarse_grained_fields_agrees():
    rng = np.random.default_rng(14)
    frames = layered_2d(rng, frozen=True)
    grains_only = [make_frame(f.position[f.type != 2], f.velocity[f.type != 2], time=f.time)
                   for f in frames]
    fields = coarse_grain(grains_only, Cartesian([[0.0, 5.0, 10.0], np.linspace(-10, 10, 6)]),
                          contacts=False)
    from_fields = jet.dead_zone(fields)
    direct = jet.dead_zone(frames, target_radius=10.0, lateral_bins=5)
    np.testing.assert_array_equal(from_fields.mask, direct.mask)
    np.testing.assert_allclose(from_fields.thermal_speed, direct.thermal_speed, rtol=1e-9)
    np.testing.assert_allclose(from_fields.speed, direct.speed, rtol=1e-9)
    assert from_fields.found and from_fields.extent[0] == (0.0, 5.0)


def test_no_dead_zone_at_a_hot_3d_stagnation_point():
    rng = np.random.default_rng(15)
    n = 3000
    rho = 5.0 * np.sqrt(rng.uniform(size=n))
    a = rng.uniform(0, 2 * pi, n)
    pos = np.column_stack([rho * np.cos(a), rho * np.sin(a), rng.uniform(0.5, 10.0, n)])
    vel = rng.normal(scale=0.25, size=(n, 3))
    res = jet.dead_zone(make_frame(pos, vel), target_radius=5.0)
    assert res.mask.shape == (2, 5) and not res.found
    cold = jet.dead_zone(make_frame(pos, 0.01 * vel), target_radius=5.0)
    assert cold.mask.all() and cold.height == 10.0


# --------------------------------------------------------------------------------------------
# Bad arguments
# --------------------------------------------------------------------------------------------


def test_bad_arguments_raise_clear_errors():
    rng = np.random.default_rng(16)
    frame = make_frame(*cone_3d(rng, 50, 1.0)[:2])
    ok = dict(target_radius=R_TAR, jet_radius=R_JET)
    with pytest.raises(ValueError, match="target_radius"):
        jet.scattering_angle(frame, target_radius=0.0, jet_radius=R_JET)
    with pytest.raises(ValueError, match="jet_radius"):
        jet.scattering_angle(frame, target_radius=R_TAR, jet_radius=float("nan"))
    with pytest.raises(ValueError, match="direction: expected 3 finite components"):
        jet.scattering_angle(frame, direction=(0, -1), **ok)
    with pytest.raises(ValueError, match="direction: must not be the zero vector"):
        jet.scattering_angle(frame, direction=(0, 0, 0), **ok)
    with pytest.raises(ValueError, match="weighting"):
        jet.scattering_angle(frame, weighting="mass", **ok)
    with pytest.raises(ValueError, match="blocks"):
        jet.scattering_angle(frame, blocks=0, **ok)
    with pytest.raises(ValueError, match="blocks: 3 blocks need"):
        jet.scattering_angle(frame, blocks=3, **ok)
    with pytest.raises(ValueError, match="window"):
        jet.scattering_angle(frame, window=(2.0, 1.0), **ok)
    with pytest.raises(ValueError, match="no frame lies in the window"):
        jet.scattering_angle(frame, window=(5.0, 6.0), **ok)
    with pytest.raises(ValueError, match="frames: no frames given"):
        jet.scattering_angle([], **ok)
    with pytest.raises(ValueError, match="no scattered grains in the shell"):
        jet.scattering_angle(frame, target_radius=20.0, jet_radius=R_JET)
    with pytest.raises(ValueError, match="grains: the selection must return"):
        jet.scattering_angle(frame, grains=lambda f: np.ones(3, bool), **ok)
    with pytest.raises(ValueError, match="deflection"):
        jet.scattering_angle(frame, deflection=-0.1, **ok)
    with pytest.raises(ValueError, match="frames: expected Frame objects"):
        jet.scattering_angle([frame, "frame"], **ok)
    with pytest.raises(ValueError, match="n_bins"):
        jet.azimuthal_flux(frame, n_bins=2, **ok)
    with pytest.raises(ValueError, match="reference_axis: must not be parallel"):
        jet.anisotropy_v2(frame, reference_axis=(0, 0, 1), **ok)
    with pytest.raises(ValueError, match="azimuth"):
        jet.anisotropy_v2(frame, azimuth="momentum", **ok)
    with pytest.raises(ValueError, match="order"):
        jet.anisotropy_v2(frame, order=0, **ok)
    with pytest.raises(ValueError, match="target_radius: required"):
        jet.dead_zone(frame)
    with pytest.raises(ValueError, match="depth"):
        jet.dead_zone(frame, target_radius=3.0, depth=2.0)
    with pytest.raises(ValueError, match="speed_threshold"):
        jet.dead_zone(frame, target_radius=3.0, speed_threshold=0.0)


# --------------------------------------------------------------------------------------------
# Plots
# --------------------------------------------------------------------------------------------


def assert_png(path):
    with open(path, "rb") as f:
        assert f.read(8) == PNG_SIGNATURE


def test_plots_write_png_files(tmp_path):
    rng = np.random.default_rng(17)
    x = np.linspace(0.2, 4.0, 15)
    err = np.full(x.size, 0.03)
    y = jet.psi0_interpolation(x, **C_SEED) + rng.normal(scale=0.03, size=x.size)
    fit = jet.fit_psi0(x, y, err)
    assert_png(plot_psi0(x, y, tmp_path / "psi0.png", psi0_err=err, fit=fit))
    frames = sheet_frames(rng, 4, 1000, 0.16)
    flux = jet.azimuthal_flux(frames, target_radius=R_TAR, jet_radius=R_JET)
    v2 = jet.anisotropy_v2(frames, target_radius=R_TAR, jet_radius=R_JET)
    assert_png(plot_azimuthal_flux(flux, tmp_path / "flux.png"))
    assert_png(plot_azimuthal_flux(flux, tmp_path / "flux_v2.png", anisotropy=v2))
    eps = jet.eccentricity([1.0, 1.5, 2.0, 3.0])
    assert_png(plot_v2_vs_eccentricity(eps, [0.0, 0.03, 0.05, 0.07], tmp_path / "sub" / "v2.png",
                                       v2_err=[0.01] * 4))
    with pytest.raises(ValueError, match="psi0: expected shape"):
        plot_psi0(x, y[:-1], tmp_path / "bad.png")
    with pytest.raises(ValueError, match="fit: expected a Psi0Fit"):
        plot_psi0(x, y, tmp_path / "bad.png", fit=v2)
    with pytest.raises(ValueError, match="flux: expected an AzimuthalFlux"):
        plot_azimuthal_flux(v2, tmp_path / "bad.png")
