"""Jet analyses of seed 002 chapter 4 (grainflow.analysis.jet) and their plots
(grainflow.plotting.jet_plots): scattering angle, the psi0(X) fit, the azimuthal flux and v2,
the eccentricity of a rectangular jet, and the dead zone, on synthetic frames whose answers are
known."""

from __future__ import annotations

from dataclasses import replace
from math import pi

import numpy as np
import pytest

from grainflow.analysis import jet
from grainflow.analysis.cg import Cartesian, coarse_grain
from grainflow.frame import ANCHOR, BOND, PAIR, WALL, Box, Contacts, Frame
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
# Scattering angle from the force balance on the target (Sec. 4.1.1)
# --------------------------------------------------------------------------------------------

LAMBDA = 8.0  # grains per unit length of the synthetic jets: 4 (3D) or 2 (2D) per layer
ID_OFFSET = 100  # particle ids differ from indices, as after deletions
STEADY = (1.0, 1e9)  # the frames after the initial one (t = 0)


def with_ids(frame, contacts=None):
    return replace(frame, id=frame.id + ID_OFFSET, contacts=contacts)


def initial_jet_3d(*, h0=2.0, length=50.0, mass=1.0, u0=1.0):
    """The undisturbed 3D jet at t = 0: layers of 4 grains every 0.5 d (lambda = 8) from h0,
    moving at u0 along -z, above the target. Its middle 60 % holds exactly 8 grains per d."""
    z = h0 + 0.5 * np.arange(int(round(length / 0.5)) + 1)
    xy = np.array([[0.5, 0.5], [-0.5, 0.5], [0.5, -0.5], [-0.5, -0.5]])
    pos = np.column_stack([np.tile(xy, (z.size, 1)), np.repeat(z, 4)])
    vel = np.tile([0.0, 0.0, -u0], (len(pos), 1))
    pos, vel, types = concat(target_3d(), (pos, vel, 0))
    frame = make_frame(pos, vel, types=types, mass=mass)
    return with_ids(frame, Contacts(*(np.zeros(0, np.int64),) * 2, np.zeros((0, 3)),
                                    np.zeros((0, 3))))


def force_frame(wall_force, *, time, step=0, dim=3, anchors=True, extra_rows=True):
    """Target (type 2) and a few grains, with contacts whose forces on the target along the
    direction of travel (-z in 3D, -x in 2D) sum to ``wall_force``,
    and rows that must not count: grain-grain contacts, target-target contacts and bonds,
    a wall contact, an anchor on a grain. Anchors on the target balance ``wall_force``."""
    axis = dim - 1 if dim == 3 else 0
    if dim == 3:
        t_pos = target_3d()[0]
    else:
        t_pos = np.column_stack([np.full(7, -0.5), np.arange(-3.0, 4.0)])
    g_pos = np.zeros((4, dim))
    g_pos[:, axis] = 0.5
    g_pos[:, 1] = [-1.5, -0.5, 0.5, 1.5]
    pos = np.vstack([t_pos, g_pos])
    types = np.r_[np.full(len(t_pos), jet.TARGET_TYPE), np.zeros(4)]
    frame = make_frame(pos, np.zeros_like(pos), types=types, time=time, step=step)
    ids = frame.id + ID_OFFSET
    tgt, grn = ids[:len(t_pos)], ids[len(t_pos):]

    def along(f, lateral=0.0):
        """force of magnitude f along the direction of travel, plus a lateral part"""
        v = np.zeros(dim)
        v[axis] = -f
        v[1] = lateral
        return v

    rows = [  # (i, j, kind, force on i from j)
        (tgt[0], grn[0], PAIR, along(0.6 * wall_force, lateral=5.0)),
        (grn[1], tgt[1], PAIR, -along(0.4 * wall_force)),  # listed on the grain
    ]
    if extra_rows:
        rows += [(grn[0], grn[1], PAIR, along(100.0)), (grn[2], grn[3], PAIR, along(-40.0)),
                 (tgt[0], tgt[1], PAIR, along(70.0)), (tgt[1], tgt[2], BOND, along(50.0)),
                 (tgt[2], tgt[3], BOND, along(-20.0)), (tgt[3], 0, WALL, along(30.0)),
                 (grn[2], -1, ANCHOR, along(1000.0))]
    if anchors:
        rows += [(t, -1, ANCHOR, -along(wall_force / len(tgt))) for t in tgt]
    i, j, kind, force = zip(*rows)
    contacts = Contacts(np.array(i, np.int64), np.array(j, np.int64), np.array(force),
                        np.zeros((len(rows), dim)), np.array(kind, np.int8))
    return with_ids(frame, contacts)


def psi_force(psi, j_in=LAMBDA):
    return j_in * (1.0 - np.cos(psi))


def force_series(forces, *, t0=1.0, **kwargs):
    return [force_frame(f, time=t0 + k, step=k + 1, **kwargs) for k, f in enumerate(forces)]


@pytest.mark.parametrize("psi", [0.55, pi / 2, jet.SEED_PSI0_FIT[0], 2.5])
def test_known_force_and_line_density_give_the_angle(psi):
    f0 = psi_force(psi)
    forces = f0 * (1.0 + 0.05 * np.tile([1.0, 1.0, -1.0, -1.0], 5))  # mean f0
    res = jet.force_balance_angle([initial_jet_3d()] + force_series(forces), window=STEADY)
    assert res.lambda_ == pytest.approx(LAMBDA) and res.J_in == pytest.approx(LAMBDA)
    assert res.F_wall == pytest.approx(f0)
    assert res.ratio == pytest.approx(1.0 - np.cos(psi))
    assert res.psi0 == pytest.approx(psi, abs=1e-12)
    assert res.n_frames == 20 and res.n_skipped == 0 and res.blocks == 10
    assert res.force == "contacts" and res.line_density == "initial"
    assert res.J_in_err == pytest.approx(0.0, abs=1e-12)  # the uniform lattice: no scatter
    assert 0 < res.psi0_err < 0.1


def test_the_momentum_flux_scales_with_mass_and_u0_squared():
    f = psi_force(1.2, j_in=LAMBDA * 2.0 * 1.5**2)
    frames = [initial_jet_3d(mass=2.0, u0=1.5)] + force_series([f] * 4)
    res = jet.force_balance_angle(frames, u0=1.5, window=STEADY)
    assert res.lambda_ == pytest.approx(LAMBDA)
    assert res.J_in == pytest.approx(LAMBDA * 2.0 * 1.5**2)
    assert res.psi0 == pytest.approx(1.2, abs=1e-12)
    # the jet moves at 1.5 u0: with u0 = 1 it is not the undisturbed jet
    with pytest.raises(ValueError, match=r"only 0\.0% of the grains move at u0 n"):
        jet.force_balance_angle(frames, window=STEADY)
    # a given line density: lambda m u0^2 with the grains' mass
    given = jet.force_balance_angle(frames, u0=1.5, line_density=LAMBDA, window=STEADY)
    assert given.line_density == "given" and given.J_in == pytest.approx(res.J_in)
    assert given.psi0 == pytest.approx(1.2, abs=1e-12) and given.J_in_err == 0.0


def test_grain_contacts_target_bonds_walls_and_anchors_do_not_count():
    f = psi_force(1.0)
    frames = [initial_jet_3d()] + force_series([f] * 5)
    clean = [initial_jet_3d()] + force_series([f] * 5, extra_rows=False, anchors=False)
    res = jet.force_balance_angle(frames, window=STEADY)
    assert res.F_wall == pytest.approx(f)
    assert res.psi0 == pytest.approx(1.0, abs=1e-12)
    assert jet.force_balance_angle(clean, window=STEADY).F_wall == pytest.approx(f)
    # only the rows that do not count: no force on the target, psi0 = 0
    idle = jet.force_balance_angle([initial_jet_3d()] + force_series([0.0] * 3), window=STEADY)
    assert idle.F_wall == 0.0 and idle.psi0 == 0.0
    # selections: the same target by a callable; grains that exclude those touching it
    picked = jet.force_balance_angle(frames, window=STEADY,
                                     target=lambda fr: fr.type == jet.TARGET_TYPE)
    assert picked.F_wall == pytest.approx(f)
    aloof = jet.force_balance_angle(frames, window=STEADY,
                                    grains=lambda fr: (fr.type == 0) & (fr.position[:, 2] > 1))
    assert aloof.F_wall == 0.0 and aloof.lambda_ == pytest.approx(LAMBDA)
    with pytest.raises(ValueError, match="grains: the frame at step 0 .* holds no grains"):
        jet.force_balance_angle(frames, window=STEADY, line_density=LAMBDA, grains=[1])


def test_anchor_forces_balance_the_contact_force():
    f = psi_force(1.4)
    frames = [initial_jet_3d()] + force_series([f, 1.1 * f, 0.9 * f])
    contacts = jet.force_balance_angle(frames, window=STEADY)
    anchors = jet.force_balance_angle(frames, force="anchors", window=STEADY)
    assert anchors.force == "anchors"
    assert anchors.F_wall == pytest.approx(contacts.F_wall)
    assert anchors.psi0 == pytest.approx(1.4, abs=1e-12)
    untethered = [initial_jet_3d()] + force_series([f], anchors=False, extra_rows=False)
    with pytest.raises(ValueError, match="force: 'anchors' needs tether rows"):
        jet.force_balance_angle(untethered, force="anchors", window=STEADY)


def mirrored(frame):
    """The frame with z -> -z (positions, velocities, forces, branches)."""
    flip = np.array([1.0, 1.0, -1.0])
    c = frame.contacts
    contacts = Contacts(c.i, c.j, c.force * flip, c.branch * flip, c.kind)
    return replace(frame, position=frame.position * flip, velocity=frame.velocity * flip,
                   contacts=contacts)


def test_the_direction_of_travel_sets_the_sign():
    f = psi_force(0.8)
    frames = [initial_jet_3d()] + force_series([f] * 4)
    # the same jet travelling along +z onto a target below it
    up = [mirrored(fr) for fr in frames]
    res = jet.force_balance_angle(up, direction=(0, 0, 2.0), window=STEADY)
    assert res.psi0 == pytest.approx(0.8, abs=1e-12) and res.lambda_ == pytest.approx(LAMBDA)
    # a wrong direction: the force along n is negative (and the jet is not undisturbed)
    with pytest.raises(ValueError, match=r"outside \[0, 2\].*check direction"):
        jet.force_balance_angle(frames, direction=(0, 0, 1), line_density=LAMBDA,
                                window=STEADY)
    with pytest.raises(ValueError, match="line_density: 'initial'"):
        jet.force_balance_angle(frames, direction=(0, 0, 1), window=STEADY)
    with pytest.raises(ValueError, match="direction: expected 3 finite components"):
        jet.force_balance_angle(frames, direction=(-1, 0), window=STEADY)


def test_2d_force_balance_along_minus_x():
    x = 2.0 + 0.25 * np.arange(201)  # 2 grains per layer every 0.25 d: lambda = 8
    pos = np.column_stack([np.repeat(x, 2), np.tile([-0.5, 0.5], x.size)])
    first = with_ids(make_frame(pos, np.tile([-1.0, 0.0], (len(pos), 1))),
                     Contacts(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)),
                              np.zeros((0, 2))))
    f = psi_force(pi / 2)
    frames = [first] + force_series([f] * 6, dim=2)
    res = jet.force_balance_angle(frames, window=STEADY)
    assert res.lambda_ == pytest.approx(LAMBDA)
    assert res.psi0 == pytest.approx(pi / 2, abs=1e-12)
    anchors = jet.force_balance_angle(frames, force="anchors", window=STEADY)
    assert anchors.psi0 == pytest.approx(pi / 2)
    # a jet travelling along +x
    flip = np.array([-1.0, 1.0])
    back = [replace(fr, position=fr.position * flip, velocity=fr.velocity * flip,
                    contacts=Contacts(fr.contacts.i, fr.contacts.j, fr.contacts.force * flip,
                                      fr.contacts.branch * flip, fr.contacts.kind))
            for fr in frames]
    res = jet.force_balance_angle(back, direction=(1, 0), window=STEADY)
    assert res.psi0 == pytest.approx(pi / 2)


def test_window_selects_frames_and_the_initial_jet_lies_outside_it():
    early, late = psi_force(0.7), psi_force(1.6)
    first = replace(initial_jet_3d(), contacts=None)  # t = 0 needs no contacts
    frames = [first] + force_series([early] * 10, t0=1.0) + force_series([late] * 10, t0=11.0)
    res = jet.force_balance_angle(iter(frames), window=(11.0, 20.0))
    assert res.n_frames == 10 and res.psi0 == pytest.approx(1.6, abs=1e-12)
    assert res.lambda_ == pytest.approx(LAMBDA)
    res = jet.force_balance_angle(frames, window=(1.0, 10.0), blocks=5)
    assert res.n_frames == 10 and res.blocks == 5 and res.psi0 == pytest.approx(0.7, abs=1e-12)
    # every frame of the window must hold contacts
    with pytest.raises(ValueError, match=r"frames: the frame at step 0 \(t = 0\) holds no "
                                         "contacts"):
        jet.force_balance_angle(frames)
    with pytest.raises(ValueError, match="no frame lies in the window"):
        jet.force_balance_angle(frames, window=(30.0, 40.0))
    with pytest.raises(ValueError, match="frames: no frames given"):
        jet.force_balance_angle([])


def test_jackknife_errors_over_blocks_of_frames():
    rng = np.random.default_rng(20)
    f0 = psi_force(1.3)
    forces = f0 * (1.0 + 0.1 * rng.standard_normal(20))
    frames = [initial_jet_3d()] + force_series(forces)
    res = jet.force_balance_angle(frames, window=(1.0, 20.0))
    assert res.n_frames == 20 and res.blocks == 10
    means = forces.reshape(10, 2).mean(axis=1)
    assert res.F_wall == pytest.approx(forces.mean())
    assert res.F_wall_err == pytest.approx(np.std(means, ddof=1) / np.sqrt(10), rel=1e-9)
    assert res.ratio_err == pytest.approx(res.F_wall_err / res.J_in, rel=1e-9)
    assert res.psi0_err == pytest.approx(res.ratio_err / np.sin(res.psi0), rel=0.05)
    single = jet.force_balance_angle(frames, window=(1.0, 20.0), blocks=1)
    assert single.F_wall_err == pytest.approx(np.std(forces, ddof=1) / np.sqrt(20), rel=1e-9)
    one = jet.force_balance_angle(frames[:2], window=(1.0, 1.0))
    assert one.n_frames == 1 and np.isnan(one.psi0_err)


def slab_frame(wall_force, *, time, step, tail=40.0, stray=None):
    """A frame in the steady state: the undisturbed jet (lambda = 8) from h = 1 to ``tail``,
    disturbed grains next to the target, and optionally one disturbed grain at ``stray``."""
    frame = force_frame(wall_force, time=time, step=step)
    z = 1.0 + 0.5 * np.arange(int(round((tail - 1.0) / 0.5)) + 1)
    xy = np.array([[0.5, 0.5], [-0.5, 0.5], [0.5, -0.5], [-0.5, -0.5]])
    jet_pos = np.column_stack([np.tile(xy, (z.size, 1)), np.repeat(z, 4)])
    jet_vel = np.tile([0.0, 0.0, -1.0], (len(jet_pos), 1))
    hot = np.array([[1.0, 0.0, 0.6], [-2.0, 1.0, 0.7], [0.0, 2.0, 0.5]])
    hot_vel = np.array([[0.5, 0.0, 0.1], [-0.4, 0.2, 0.0], [0.0, 0.6, -0.2]])
    extra = [(jet_pos, jet_vel), (hot, hot_vel)]
    if stray is not None:
        extra.append((np.array([stray]), np.array([[0.3, 0.0, 0.4]])))
    pos = np.vstack([frame.position] + [p for p, _ in extra])
    vel = np.vstack([frame.velocity] + [v for _, v in extra])
    n_new = len(pos) - frame.n
    return replace(frame, id=np.r_[frame.id, 10_000 + np.arange(n_new)],
                   type=np.r_[frame.type, np.zeros(n_new, np.int32)],
                   body=np.r_[frame.body, -np.ones(n_new, np.int64)],
                   radius=np.r_[frame.radius, np.full(n_new, 0.5)],
                   mass=np.r_[frame.mass, np.ones(n_new)], position=pos, velocity=vel,
                   omega=np.zeros((len(pos), 3)))


def test_line_density_from_the_upstream_slab_skips_frames_it_cannot_use():
    f = psi_force(1.1)
    frames = [slab_frame(f, time=float(t), step=t) for t in range(1, 9)]
    frames += [slab_frame(2 * f, time=9.0, step=9, tail=15.0),  # the tail is in the slab
               slab_frame(2 * f, time=10.0, step=10, tail=8.0),  # the slab is empty
               slab_frame(2 * f, time=11.0, step=11, stray=(0.5, 0.0, 12.0)),  # disturbed
               slab_frame(f, time=12.0, step=12, stray=(12.0, 0.0, 12.0))]  # far off: kept
    res = jet.force_balance_angle(frames, line_density="window")
    assert res.line_density == "window"
    assert res.lambda_ == pytest.approx(LAMBDA) and res.J_in == pytest.approx(LAMBDA)
    assert res.n_frames == 9 and res.n_skipped == 3
    assert res.psi0 == pytest.approx(1.1, abs=1e-12)
    assert res.J_in_err == pytest.approx(0.0, abs=1e-12)
    assert jet.force_balance_angle(frames, line_density="window", upstream=(2.0, 6.0),
                                   window=(1.0, 8.0)).lambda_ == pytest.approx(LAMBDA)
    with pytest.raises(ValueError, match="no frame of the window has the undisturbed jet"):
        jet.force_balance_angle(frames, line_density="window", window=(9.0, 11.0))


def test_force_balance_bad_arguments_raise_clear_errors():
    frames = [initial_jet_3d()] + force_series([psi_force(1.0)] * 3)
    with pytest.raises(ValueError, match="force: 'contacts' or 'anchors'"):
        jet.force_balance_angle(frames, force="bonds", window=STEADY)
    with pytest.raises(ValueError, match="line_density: 'initial', 'window' or a positive"):
        jet.force_balance_angle(frames, line_density="theory", window=STEADY)
    with pytest.raises(ValueError, match="line_density: expected a positive"):
        jet.force_balance_angle(frames, line_density=-1.0, window=STEADY)
    with pytest.raises(ValueError, match=r"upstream: \(h_lo, h_hi\) with 0 <= h_lo < h_hi"):
        jet.force_balance_angle(frames, upstream=(15.0, 5.0), window=STEADY)
    with pytest.raises(ValueError, match="upstream"):
        jet.force_balance_angle(frames, upstream=5.0, window=STEADY)
    with pytest.raises(ValueError, match="undisturbed"):
        jet.force_balance_angle(frames, undisturbed=-0.1, window=STEADY)
    with pytest.raises(ValueError, match="u0"):
        jet.force_balance_angle(frames, u0=0.0, window=STEADY)
    with pytest.raises(ValueError, match="target: the frame at step 1"):
        jet.force_balance_angle(frames, target=[7], window=STEADY)
    with pytest.raises(ValueError, match="target: the selection must return"):
        jet.force_balance_angle(frames, target=lambda f: np.ones(2, bool), window=STEADY)
    with pytest.raises(ValueError, match="blocks: 5 blocks need"):
        jet.force_balance_angle(frames, blocks=5, window=STEADY)
    with pytest.raises(ValueError, match=r"F_wall / J_in = 2\.5 .*outside \[0, 2\]"):
        jet.force_balance_angle([initial_jet_3d()] + force_series([2.5 * LAMBDA]),
                                window=STEADY)
    short = initial_jet_3d(length=1.0)  # 4 grains in its middle 60 %
    with pytest.raises(ValueError, match="too short"):
        jet.force_balance_angle([short] + force_series([1.0]), window=STEADY)


@pytest.fixture(scope="module")
def sheet_run(tmp_path_factory: pytest.TempPathFactory):
    """A 400-grain 3D jet (D_jet = 4.5 d) onto a target 2.5 times wider, with contacts saved
    five times per d/u0 (~5 s)."""
    from grainflow.io.h5md import read_frames
    from grainflow.runner import run_config

    rundir = tmp_path_factory.mktemp("jet_force") / "run"
    config = {"scenario": "jet3d", "dim": 3, "run": {"duration": 16.0},
              "output": {"thermo_every": 1000, "frames_every": 100, "contacts": True,
                         "checkpoint_every": 0, "snapshot": False},
              "jet": {"jet_diameter": 4.5, "target_diameter": 11.25, "n": 400}}
    run_config(config, rundir, progress="none")
    return list(read_frames(rundir / "frames.h5"))


def test_force_balance_on_a_real_sheet_run(sheet_run):
    """X = 2.5: a sheet, psi0 near the thesis's C0 = 1.68 (eq. 4.4); the contact and the
    anchor forces agree; the jet's line density is that of the thinned fcc lattice."""
    window = (10.0, 16.0)
    res = jet.force_balance_angle(sheet_run, window=window)
    assert 1.2 < res.psi0 < 2.0
    assert 0 < res.psi0_err < 0.3 and res.n_frames == 30
    theory = 0.9 * np.sqrt(2.0) * pi * 2.25**2  # phi_tilde * fcc sites per d^3 * area
    assert res.lambda_ == pytest.approx(theory, rel=0.05)
    anchors = jet.force_balance_angle(sheet_run, window=window, force="anchors")
    assert anchors.ratio == pytest.approx(res.ratio, rel=0.1)
    # the 20 d long jet's tail has entered the slab 10-20 d by t = 10
    with pytest.raises(ValueError, match="the jet's tail may have passed"):
        jet.force_balance_angle(sheet_run, window=window, line_density="window")


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
