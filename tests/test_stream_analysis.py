"""Stream analyses of seed 000 (grainflow.analysis.stream) and their plots
(grainflow.plotting.stream_plots): contacts and networks (A5), velocity deviations and the
free-fall model (A6), droplets, tracking and regimes (A7), on hand-built configurations whose
answers are known. No simulation runs here."""

from __future__ import annotations

import numpy as np
import pytest

from grainflow.analysis import stream as st
from grainflow.frame import Box, Frame
from grainflow.plotting import stream_plots as sp

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
D = 200e-6  # grain diameter (m), seed 000
R = D / 2
DELTA = 100e-9  # cohesive shell (m)
G = st.GRAVITY


def make_frame(pos, vel=None, *, ids=None, time=0.0, step=0, radius=R, dim=3):
    pos = np.asarray(pos, dtype=float)
    n = pos.shape[0]
    return Frame(step=step, time=time,
                 box=Box(np.full(dim, -1.0), np.full(dim, 1.0), (False,) * dim),
                 id=np.arange(n, dtype=np.int64) if ids is None else np.asarray(ids, np.int64),
                 type=np.zeros(n, np.int32), body=-np.ones(n, np.int64),
                 radius=np.full(n, radius), mass=np.ones(n),
                 position=pos, velocity=np.zeros_like(pos) if vel is None else
                 np.asarray(vel, dtype=float), omega=np.zeros((n, 3)))


def lattice(shape, spacing=D, origin=(0.0, 0.0, 0.0)):
    """Simple cubic lattice points, (nx*ny*nz, 3)."""
    axes = [np.arange(k) * spacing for k in shape]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return g + np.asarray(origin)


def ball(radius_in_d, centre):
    """Lattice points (spacing D) inside a sphere: a connected droplet."""
    k = int(radius_in_d)
    pts = lattice((2 * k + 1,) * 3) - k * D
    pts = pts[np.linalg.norm(pts, axis=1) <= radius_in_d * D + 1e-12]
    return pts + np.asarray(centre)


def check_png(path):
    data = open(path, "rb").read()
    assert data[:8] == PNG_SIGNATURE and len(data) > 1000


# --------------------------------------------------------------------------- A5 networks


def test_chain_is_one_network_with_z2_inside():
    pos = np.column_stack([np.arange(6) * D, np.zeros(6), np.zeros(6)])
    pairs = st.contact_pairs(pos, R, DELTA)
    assert pairs.tolist() == [[0, 1], [1, 2], [2, 3], [3, 4], [4, 5]]
    assert st.contact_numbers(pos, R, DELTA).tolist() == [1, 2, 2, 2, 2, 1]
    labels, sizes = st.network_labels(pos, R, DELTA)
    assert sizes.tolist() == [6] and np.all(labels == 0)
    assert st.network_sizes(pos, R, DELTA).tolist() == [6] * 6


def test_two_clusters_and_a_lone_grain():
    chain = np.column_stack([np.arange(3) * D, np.zeros(3), np.zeros(3)])
    square = lattice((2, 2, 1), origin=(2 * D + D + 3 * DELTA, 0.0, 0.0))  # gap 3 delta
    lone = np.array([[0.0, 5 * D, 0.0]])
    pos = np.concatenate([chain, square, lone])
    nets = st.find_networks(pos, R, DELTA)
    assert nets.n_networks == 3
    assert nets.network_size.tolist() == [3, 3, 3, 4, 4, 4, 4, 1]
    assert sorted(nets.sizes.tolist()) == [1, 3, 4]
    assert nets.contact_number.tolist() == [1, 2, 1, 2, 2, 2, 2, 0]
    assert len(set(nets.label[:3])) == 1 and nets.label[0] != nets.label[3]
    assert np.all(nets.members(nets.label[3]) == [3, 4, 5, 6])
    # a larger shell bridges the 3 delta gap: one network of 7 plus the lone grain
    assert st.network_sizes(pos, R, 4 * DELTA).tolist() == [7] * 7 + [1]


@pytest.mark.parametrize("factor, touching", [(1 - 1e-6, True), (1 + 1e-6, False)])
def test_gap_just_below_and_above_the_shell(factor, touching):
    r1, r2 = R, 0.6 * R  # unequal radii: reach r1 + r2 + delta
    dist = r1 + r2 + DELTA * factor
    pos = np.array([[0.0, 0.0, 0.0], [dist, 0.0, 0.0], [0.0, 0.0, -1.0]])
    radii = np.array([r1, r2, R])
    assert len(st.contact_pairs(pos, radii, DELTA)) == int(touching)
    assert st.network_sizes(pos, radii, DELTA).tolist() == ([2, 2, 1] if touching
                                                            else [1, 1, 1])


def test_network_errors_name_the_argument():
    pos = np.zeros((3, 3))
    with pytest.raises(ValueError, match="delta"):
        st.contact_pairs(pos, R, -1e-9)
    with pytest.raises(ValueError, match=r"positions.*\(N, 3\)"):
        st.contact_pairs(np.zeros((3, 2)), R, DELTA)
    with pytest.raises(ValueError, match="radii"):
        st.contact_pairs(pos, np.ones(2), DELTA)
    with pytest.raises(ValueError, match="radii"):
        st.contact_pairs(pos, -R, DELTA)
    with pytest.raises(ValueError, match="pairs"):
        st.contact_numbers(pos, R, DELTA, pairs=np.array([[0, 7]]))
    with pytest.raises(ValueError, match="3D"):
        st.contact_profiles(make_frame(np.zeros((2, 2)), dim=2), DELTA)
    with pytest.raises(ValueError, match="bin_width"):
        st.depth_profile(np.zeros(3), np.zeros(3), 0.0)


def test_depth_profile_pools_frames_with_frame_scatter_error():
    # frame 1: a horizontal chain of 3 at depth 0.5 mm (Z = 1, 2, 1); frame 2: 3 lone grains
    chain = np.column_stack([np.arange(3) * D, np.zeros(3), np.full(3, -0.5e-3)])
    lone = np.column_stack([np.arange(3) * 3 * D, np.zeros(3), np.full(3, -0.5e-3)])
    deep = np.array([[0.0, 0.0, -3.2e-3]])
    frames = [make_frame(np.concatenate([chain, deep])),
              make_frame(np.concatenate([lone, deep]), time=1e-3)]
    prof = st.contact_profiles(frames, DELTA)
    z = prof.contact_number
    assert z.n_frames == 2 and z.edges[0] == 0.0 and z.bin_width == 1e-3
    first = 0  # bin [0, 1 mm)
    assert z.count[first] == 6
    assert z.mean[first] == pytest.approx(4 / 6)
    # S = (4, 0), n = (3, 3), m = 2/3: sqrt(2/1 * (2^2 + 2^2)) / 6
    assert z.err[first] == pytest.approx(4 / 6)
    assert z.frames_with_data[first] == 2
    assert z.count[1] == 0 and np.isnan(z.mean[1])
    assert z.mean[3] == 0 and z.err[3] == 0  # the deep lone grain, in both frames
    n = prof.network_size
    assert n.bin_width == 5e-3 and n.mean[0] == pytest.approx((3 * 3 + 1 + 3 + 1) / 8)
    # pooled (every grain alike) against frame-by-frame (every frame alike) averages
    d, v = [np.full(4, 0.5e-3), np.full(1, 0.5e-3)], [np.ones(4), np.full(1, 3.0)]
    pooled = st.depth_profile(d, v, 1e-3)
    by_frame = st.depth_profile(d, v, 1e-3, average="frames")
    assert (pooled.mean[0], pooled.err[0]) == pytest.approx((1.4, 0.64))
    assert (by_frame.mean[0], by_frame.err[0]) == pytest.approx((2.0, 1.0))
    with pytest.raises(ValueError, match="average"):
        st.depth_profile(d, v, 1e-3, average="median")
    # hopper grains have negative depth and go into bins below 0
    p = st.depth_profile(np.array([-0.3e-3, 0.2e-3]), np.array([2.0, 4.0]), 1e-3)
    assert p.edges.tolist() == pytest.approx([-1e-3, 0.0, 1e-3])
    assert p.mean.tolist() == [2.0, 4.0]


def test_normalised_contact_number_and_saturation_size():
    depths = [np.array([0.2e-3, 0.7e-3, 5.5e-3, 5.6e-3]), np.array([0.4e-3, 5.2e-3])]
    values = [np.array([2.0, 4.0, 6.0, 6.0]), np.array([3.0, 9.0])]
    prof = st.depth_profile(depths, values, 1e-3, quantity="contact number")
    norm = st.normalised_contact_number(prof, reference_depth=0.5e-3)
    assert norm.reference.value == pytest.approx(3.0)
    assert norm.profile.mean[0] == pytest.approx(1.0)
    assert norm.profile.mean[5] == pytest.approx(7.0 / 3.0)
    with pytest.raises(ValueError, match="depth"):
        st.normalised_contact_number(prof, reference_depth=2.5e-3)  # empty bin
    sizes = st.depth_profile(np.array([0.201, 0.203, 0.212]), np.array([10.0, 20.0, 50.0]),
                             5e-3)
    sat = st.saturation_network_size(sizes)
    assert sat.value == pytest.approx(15.0) and sat.depth_range == pytest.approx((0.2, 0.205))
    wide = st.saturation_network_size(sizes, half_width=0.015)
    assert wide.value == pytest.approx(80.0 / 3.0) and wide.count == 3


# --------------------------------------------------------------------------- A6 fluctuations


def test_too_few_neighbours_are_excluded():
    tetra = np.array([[0, 0, 0], [D, 0, 0], [D / 2, D * np.sqrt(3) / 2, 0],
                      [D / 2, D * np.sqrt(3) / 6, D * np.sqrt(2 / 3)]])
    extra = np.array([[-1.2 * D, 0.0, 0.0]])  # near grain 0 only
    far = np.array([[0.0, 0.0, 10 * D]])
    pos = np.concatenate([tetra, extra, far])
    vel = np.random.default_rng(1).normal(size=pos.shape)
    dev = st.velocity_deviations(pos, vel, D)
    assert dev.n_neighbours.tolist() == [4, 3, 3, 3, 1, 0]
    assert dev.valid.tolist() == [True, True, True, True, False, False]
    assert np.all(np.isnan(dev.axial[4:])) and np.all(np.isfinite(dev.axial[:4]))
    strict = st.velocity_deviations(pos, vel, D, min_neighbours=4)
    assert strict.valid.tolist() == [True, False, False, False, False, False]
    # grain 1's axial deviation by hand
    nb = [0, 2, 3]
    assert dev.axial[1] == pytest.approx(np.mean((vel[nb, 2] - vel[1, 2]) ** 2))
    assert dev.transverse[1] == pytest.approx(
        np.mean((vel[nb, 0] - vel[1, 0]) ** 2 + (vel[nb, 1] - vel[1, 1]) ** 2) / 2)


def test_rigid_translation_has_zero_deviation():
    pos = lattice((5, 5, 5))
    vel = np.tile([0.3, -0.1, -1.2], (len(pos), 1))
    dev = st.velocity_deviations(pos, vel, D)
    assert np.all(dev.valid)
    assert np.allclose(dev.axial, 0) and np.allclose(dev.transverse, 0)


def test_uniform_extension_and_shear_give_the_analytic_deviation():
    pos = lattice((5, 5, 5))
    interior = np.all((pos > 0.5 * D) & (pos < 3.5 * D), axis=1)
    rate = 40.0  # 1/s
    # 18 neighbours within 1.5 d on a cubic lattice; 10 of them are offset by +-d along z:
    # <dz^2> = 10 d^2 / 18
    ext = st.velocity_deviations(pos, np.column_stack([0 * pos[:, 0], 0 * pos[:, 0],
                                                       rate * pos[:, 2]]), D)
    assert np.all(ext.n_neighbours[interior] == 18)
    assert np.allclose(ext.axial[interior], rate ** 2 * D ** 2 * 10 / 18)
    assert np.allclose(ext.transverse[interior], 0)
    shear = st.velocity_deviations(pos, np.column_stack([rate * pos[:, 2], 0 * pos[:, 0],
                                                         0 * pos[:, 0]]), D)
    assert np.allclose(shear.transverse[interior], rate ** 2 * D ** 2 * 10 / 18 / 2)
    assert np.allclose(shear.axial[interior], 0)
    assert np.allclose(shear.total, shear.axial + 2 * shear.transverse, equal_nan=True)


def test_free_fall_fit_recovers_dz_from_noisy_model_data():
    rng = np.random.default_rng(7)
    v0, dz = 0.1, 130e-6
    z = np.geomspace(1e-4, 0.05, 60)
    model = st.free_fall_axial_deviation(z, dz, v0)
    assert model[0] == pytest.approx((G * dz) ** 2 / (v0 ** 2 + 2 * G * 1e-4))
    sigma = 0.05 * model
    data = model + rng.normal(size=z.size) * sigma
    fit = st.fit_free_fall_deviation(z, data, v0, sigma=sigma)
    assert abs(fit.dz - dz) < 3 * fit.dz_err
    assert 0 < fit.dz_err < 0.02 * dz
    assert fit.chi2_dof == pytest.approx(1.0, abs=0.5) and fit.absolute_sigma
    assert np.allclose(fit.predict(z), st.free_fall_axial_deviation(z, fit.dz, v0))
    # a wrong v0 is a worse fit
    bad = st.fit_free_fall_deviation(z, data, 0.3, sigma=sigma)
    assert bad.chi2_dof > 10 * fit.chi2_dof
    # unweighted: errors scaled by the residual variance
    plain = st.fit_free_fall_deviation(z, data, v0)
    assert not plain.absolute_sigma and abs(plain.dz - dz) < 0.1 * dz
    with pytest.raises(ValueError, match="dv2_axial"):
        st.fit_free_fall_deviation(z, data[:-1], v0)
    with pytest.raises(ValueError, match="at least 2"):
        st.fit_free_fall_deviation(z, data, v0, depth_range=(1.0, 2.0))


def test_synthetic_free_falling_stream_gives_back_its_neighbourhood_size():
    """A 2x2 column of grains with v(z) = sqrt(v0^2 + 2 g z) plus an isotropic spread s: the
    axial deviation follows (g dz)^2 / v^2 with dz^2 = <dz_ij^2> = (2/3) d^2 (6 of the 9
    neighbours of a grain sit one layer up or down), the transverse one is 2 s^2."""
    rng = np.random.default_rng(3)
    v0, s = 0.1, 2e-5
    n_layers = 250  # 5 cm
    depth = (np.arange(n_layers) + 0.5) * D
    frames = []
    for k in range(2):
        pos = np.concatenate([np.column_stack([np.full(n_layers, x), np.full(n_layers, y),
                                               -depth]) for x in (0, D) for y in (0, D)])
        speed = np.sqrt(v0 ** 2 + 2 * G * -pos[:, 2])
        vel = np.column_stack([np.zeros(len(pos)), np.zeros(len(pos)), -speed])
        vel += rng.normal(scale=s, size=vel.shape)
        frames.append(make_frame(pos, vel, time=k * 2e-4))
    dev = st.velocity_deviation_profile(frames, bin_width=D)
    assert dev.axial.count[3] == 8 and dev.radius == pytest.approx(1.5 * D)
    inside = (dev.transverse.centres > 1e-3) & (dev.transverse.centres < 0.049)
    assert np.mean(dev.transverse.mean[inside]) == pytest.approx(2 * s ** 2, rel=0.1)
    expected = np.sqrt(2 / 3) * D
    for weighting in ("none", "relative", "err"):
        fit = st.fit_free_fall_profile(dev, v0, weighting=weighting, depth_range=(1e-3, 0.049))
        assert fit.dz == pytest.approx(expected, rel=0.02)
        assert abs(fit.dz - expected) < max(3 * fit.dz_err, 0.01 * expected)
    speed = st.aperture_speed(frames)
    assert speed.count == 8 and speed.slab == pytest.approx(D)
    assert speed.v0 == pytest.approx(np.sqrt(v0 ** 2 + G * D), abs=3 * s)


def test_superficial_speed_spreads_the_outflow_at_the_bulk_packing():
    """Q V_grain / (phi_b A) on a simple cubic bed of spacing 1.25 d (phi_b = (pi/6)/1.25^3 =
    0.268) filling a 20 mm hopper 3 mm high (wide enough that the lattice counts the bulk's
    volume to 1 %): grains outside the bulk region (the side wall's ring, the base, the top)
    do not count, and a bed twice as dense halves the speed."""
    hopper, height, aperture = 20e-3, 3e-3, 3e-3
    a = 1.25 * D
    n = int(hopper / a) + 1
    bed = lattice((n, n, int(height / a)), spacing=a, origin=(-hopper / 2, -hopper / 2, a / 2))
    bed = bed[np.hypot(bed[:, 0], bed[:, 1]) < hopper / 2]
    outflow = 1.0e5  # grains per second
    got = st.superficial_speed([make_frame(bed)] * 3, outflow, aperture_diameter=aperture,
                               hopper_diameter=hopper, fill_height=height)
    phi_b = np.pi / 6 / 1.25 ** 3
    assert got.phi_b == pytest.approx(phi_b, rel=0.03) and got.n_frames == 3
    expected = outflow * np.pi / 6 * D ** 3 / (phi_b * np.pi / 4 * aperture ** 2)
    assert got.speed == pytest.approx(expected, rel=0.03)
    stream = np.column_stack([np.zeros(50), np.zeros(50), -np.linspace(1e-3, 5e-2, 50)])
    with_stream = st.superficial_speed(make_frame(np.vstack([bed, stream])), outflow,
                                       aperture_diameter=aperture, hopper_diameter=hopper,
                                       fill_height=height)
    assert with_stream.phi_b == pytest.approx(got.phi_b, rel=1e-12)  # the stream is not bulk
    shifted = bed + [a / 2, 0.0, 0.0]  # a second interleaved lattice: twice as dense
    dense = st.superficial_speed(make_frame(np.vstack([bed, shifted])), outflow,
                                 aperture_diameter=aperture, hopper_diameter=hopper,
                                 fill_height=height)
    assert dense.speed == pytest.approx(got.speed / 2, rel=0.03)
    with pytest.raises(ValueError, match="bulk"):
        st.superficial_speed(make_frame(stream), outflow, aperture_diameter=aperture,
                             hopper_diameter=hopper, fill_height=height)
    with pytest.raises(ValueError, match="fill_height"):
        st.superficial_speed(make_frame(bed), outflow, aperture_diameter=aperture,
                             hopper_diameter=hopper, fill_height=0.0)


def test_fluctuation_errors():
    pos = lattice((2, 2, 2))
    with pytest.raises(ValueError, match="velocities"):
        st.velocity_deviations(pos, np.zeros((3, 3)), D)
    with pytest.raises(ValueError, match="min_neighbours"):
        st.velocity_deviations(pos, np.zeros_like(pos), D, min_neighbours=0)
    with pytest.raises(ValueError, match="diameter"):
        st.velocity_deviations(pos, np.zeros_like(pos), -D)
    with pytest.raises(ValueError, match="slab"):
        st.aperture_speed(make_frame(pos + [0, 0, 1.0]))
    with pytest.raises(ValueError, match="depth"):
        st.free_fall_speed(-1.0, 0.1)


# --------------------------------------------------------------------------- A7 droplets


def tilted_ellipsoid(a_d, c_d, axis):
    """Lattice points inside an ellipsoid of semi-axes (a, a, c) (in grain diameters) whose
    c axis is rotated onto ``axis``, centred at depth 25 cm."""
    k = int(c_d)
    pts = lattice((2 * k + 1,) * 3) - k * D
    inside = (pts[:, 0] ** 2 + pts[:, 1] ** 2) / (a_d * D) ** 2 + pts[:, 2] ** 2 / (
        c_d * D) ** 2 <= 1 + 1e-9
    pts = pts[inside]
    u = np.asarray(axis, float) / np.linalg.norm(axis)
    e1 = np.cross(u, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    rot = np.column_stack([e1, e2, u])  # body (x, y, z) -> world
    return pts @ rot.T + [0.0, 0.0, -0.25]


def test_tilted_ellipsoid_shape():
    a, c = 4, 10
    u = np.array([np.sin(0.5), 0.0, -np.cos(0.5)])
    pts = tilted_ellipsoid(a, c, u)
    drops = st.find_droplets(make_frame(pts), DELTA)
    assert len(drops) == 1
    drop = drops[0]
    assert drop.n_grains == len(pts) and drop.depth == pytest.approx(0.25)
    assert abs(drop.axis @ u) > 0.9999 and drop.axis[2] < 0
    assert drop.length == pytest.approx(2 * c * D, rel=1e-9)
    assert drop.width == pytest.approx(a * D, rel=0.12)
    assert drop.aspect_ratio == pytest.approx(c / a, rel=0.12)
    assert drop.eigenvalues[0] > drop.eigenvalues[1] >= drop.eigenvalues[2]
    surf = st.find_droplets(make_frame(pts), DELTA, include_grain_size=True)[0]
    assert surf.length == pytest.approx(drop.length + D)
    assert surf.width == pytest.approx(drop.width + D / 2)
    sphere = st.droplet_shape(ball(5, (0, 0, 0)))
    assert sphere.aspect_ratio == pytest.approx(1.0, rel=0.1)
    with pytest.raises(ValueError, match="n_azimuth_bins"):
        st.droplet_shape(pts, n_azimuth_bins=0)


def test_droplets_need_min_grains_and_selection_rules():
    big = ball(3, (0, 0, -0.25))  # 123 grains
    small = lattice((3, 3, 1), origin=(0, 0, -0.30))  # 9 grains
    frame = make_frame(np.concatenate([big, small]))
    assert [d.n_grains for d in st.find_droplets(frame, DELTA)] == [len(big)]
    assert [d.n_grains for d in st.find_droplets(frame, DELTA, min_grains=5)] == [len(big), 9]
    assert st.find_droplets(frame, DELTA, min_depth=0.26) == []
    drops = []
    for k, depth in enumerate([0.05, 0.21, 0.22, 0.30, 0.40]):
        drops += st.find_droplets(make_frame(ball(2, (0, 0, -depth)), time=k * 1e-3), DELTA)
    sel = st.select_droplets(drops, exclude_farthest=1)
    assert [round(d.depth, 2) for d in sel.droplets] == [0.21, 0.22, 0.30]
    assert (sel.n_input, sel.n_excluded_farthest, sel.n_too_shallow) == (5, 1, 1)
    assert len(st.select_droplets(drops).droplets) == 0  # seed default drops 1000
    with pytest.raises(ValueError, match="exclude_farthest"):
        st.select_droplets(drops, exclude_farthest=-1)


def test_aspect_ratio_histogram():
    values = [1.5] * 3 + [2.1] * 5 + [3.5] * 2 + [np.nan]
    h = st.aspect_ratio_histogram(values)
    assert h.n == 10 and h.counts.sum() == 10
    assert h.mode == pytest.approx(2.125)
    assert h.fraction_1_3 == pytest.approx(0.8)
    assert h.fraction_1_3_err == pytest.approx(np.sqrt(0.8 * 0.2 / 10))
    assert np.sum(h.density * np.diff(h.edges)) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="aspect_ratios"):
        st.aspect_ratio_histogram([np.nan])


def pair_frames(dv, v=1.0, n=10, dt=1e-3):
    """Two balls falling at v and v + dv, 1 cm apart at t = 0."""
    upper, lower = ball(3, (0, 0, 0)), ball(3, (0, 0, 0))
    frames = []
    for k in range(n):
        t = k * dt
        pos = np.concatenate([upper + [0, 0, -(0.21 + v * t)],
                              lower + [0, 0, -(0.22 + (v + dv) * t)]])
        frames.append(make_frame(pos, time=t, step=k))
    return frames


def test_separation_velocity_of_two_droplets():
    dv = 0.014
    frames = pair_frames(dv)
    per_frame = [st.find_droplets(f, DELTA) for f in frames]
    tracks = st.track_droplets(per_frame)
    assert len(tracks) == 2
    assert all(t.start == "first" and t.end == "end" and len(t.droplets) == 10
               for t in tracks)
    seps = st.droplet_separations(tracks, v0=0.1)
    assert len(seps) == 1
    s = seps[0]
    assert s.velocity == pytest.approx(dv, rel=1e-9) and s.velocity_err < 1e-9
    assert s.dz[0] == pytest.approx(0.01) and s.n_grains_mean == 123
    assert tracks[s.upper].depths[0] < tracks[s.lower].depths[0]
    # free-fall estimates: t0 from the pair's mean depth; dz0 on the fitted line
    assert s.t0 < 0 and s.dz0 == pytest.approx(0.01 + dv * s.t0)
    assert s.predicted_velocity == pytest.approx(
        np.sqrt(0.1 ** 2 + 2 * G * s.dz0) - 0.1)
    assert st.free_fall_separation_velocity(1e-6, 0.1) == pytest.approx(G * 1e-6 / 0.1,
                                                                       rel=1e-3)
    assert st.droplet_separations(tracks, min_points=11) == []


def test_separation_gradient_recovers_the_aperture_speed_of_free_fall():
    """Pairs that separate at the free-fall rate of their spacing for V = 0.115 m/s give the
    seed's predicted gradient g d / V = 1.71 cm/s (d = 200 um), also at spacings where the
    linearised form g dz0 / V is 40 % off; noise of 1 mm/s leaves it within its error."""
    d, speed = 200e-6, 0.115
    dz0 = np.linspace(0.2e-3, 6e-3, 12)  # 1-30 grain diameters
    exact = np.sqrt(speed ** 2 + 2 * G * dz0) - speed
    assert G * dz0[-1] / speed / exact[-1] > 1.4
    fit = st.fit_separation_gradient(dz0, exact, grain_diameter=d)
    assert fit.speed == pytest.approx(speed, rel=1e-6) and fit.pairs == 12
    assert fit.gradient == pytest.approx(G * d / speed, rel=1e-6)
    assert fit.gradient == pytest.approx(0.01706, rel=1e-3)
    noise = np.random.default_rng(3).normal(0.0, 1e-3, dz0.size)
    fit = st.fit_separation_gradient(np.r_[dz0, np.nan, -1e-4], np.r_[exact + noise, 0.01, 0.01],
                                     grain_diameter=d)
    assert fit.pairs == 12
    assert abs(fit.gradient - G * d / speed) < 3 * fit.gradient_err
    assert 0 < fit.gradient_err < 0.1 * fit.gradient
    # one fitted parameter takes a little of the noise's rms
    assert 0.8 * np.sqrt(np.mean(noise ** 2)) < fit.rms_residual <= np.sqrt(np.mean(noise ** 2))
    with pytest.raises(ValueError, match="at least two pairs"):
        st.fit_separation_gradient([1e-3], [0.01], grain_diameter=d)
    with pytest.raises(ValueError, match="no pair separates"):
        st.fit_separation_gradient([1e-3, 2e-3], [-0.01, 0.0], grain_diameter=d)
    with pytest.raises(ValueError, match="grain_diameter"):
        st.fit_separation_gradient([1e-3, 2e-3], [0.01, 0.02], grain_diameter=0.0)
    with pytest.raises(ValueError, match="dv0"):
        st.fit_separation_gradient([1e-3, 2e-3], [0.01], grain_diameter=d)


def traced_frames(u=0.5, dv=0.03, dz_start=2e-3, n=101, dt=2e-3):
    """Two balls (123 grains each) leaving the hopper: the upper one's centre at depth
    -4 mm + u t, the lower one dz_start + dv t below it; a block of hopper grains above the
    aperture; particles stored in a shuffled order; one grain of the upper ball missing from
    the first frame (not yet inserted)."""
    upper, lower = ball(3, (0, 0, 0)), ball(3, (0, 0, 0))
    hopper = lattice((4, 4, 2), origin=(2e-3, 0, 1e-3))
    n_ball = len(upper)
    ids = np.arange(2 * n_ball + len(hopper))
    frames = []
    rng = np.random.default_rng(0)
    for k in range(n):
        t = k * dt
        z_u = -4e-3 + u * t
        pos = np.concatenate([upper + [0, 0, -z_u], lower + [0, 0, -(z_u + dz_start + dv * t)],
                              hopper])
        keep = np.ones(len(pos), bool)
        keep[0] = k > 0
        order = rng.permutation(np.flatnonzero(keep))
        frames.append(make_frame(pos[order], ids=ids[order], time=t, step=k))
    return frames


def test_traced_pair_measures_the_spacing_and_velocity_at_the_aperture():
    u, dv, dz_start = 0.5, 0.03, 2e-3
    frames = traced_frames(u, dv, dz_start)
    pairs = st.trace_droplet_pairs(frames, DELTA, identify=[-1, -2, 50], min_depth=0.05,
                                   v0=u)
    assert len(pairs) == 1  # found again in frame -2, and too shallow in frame 50 (2.3 cm)
    p = pairs[0]
    assert p.identified_at == pytest.approx(0.2) and p.n_grains_mean == 123
    assert p.times.size == 100 and p.times[0] == pytest.approx(2e-3)  # frame 0 lacks a grain
    assert np.allclose(p.dz, dz_start + dv * p.times, rtol=0, atol=1e-12)
    # the pair's centre, -4 mm + dz_start/2 + (u + dv/2) t, crosses the aperture at t0
    t0 = (4e-3 - dz_start / 2) / (u + dv / 2)
    assert 4e-3 < t0 < 6e-3  # between frames
    assert p.t0 == pytest.approx(t0, rel=1e-9)
    assert p.dz0 == pytest.approx(dz_start + dv * t0, rel=1e-9)
    assert p.initial_velocity == pytest.approx(dv, rel=1e-9)
    assert p.final_velocity == pytest.approx(dv, rel=1e-9)
    assert p.predicted_velocity == pytest.approx(np.sqrt(u ** 2 + 2 * G * p.dz0) - u)
    assert st.aperture_length(pairs).mean == pytest.approx(p.dz0)
    # the same pair seen only after it left the aperture: no t0, no initial velocity
    late = st.trace_droplet_pairs(frames[6:], DELTA, min_depth=0.05, v0=u)[0]
    assert np.isnan(late.t0) and np.isnan(late.initial_velocity)
    assert late.final_velocity == pytest.approx(dv, rel=1e-9)
    assert st.trace_droplet_pairs(frames, DELTA, min_depth=0.2) == []
    with pytest.raises(ValueError, match="identify"):
        st.trace_droplet_pairs(frames, DELTA, identify=[101])
    with pytest.raises(ValueError, match="increasing time"):
        st.trace_droplet_pairs(frames[::-1], DELTA)


def test_tracking_ends_at_a_merge_and_survives_small_losses():
    left, right = ball(3, (0, 0, -0.25)), ball(3, (7.5 * D, 0, -0.25))
    apart = np.concatenate([left, right])
    joined = np.concatenate([left, right - [0.5 * D, 0, 0]])  # gap 0: one network
    frames = [make_frame(apart, time=0.0), make_frame(apart, time=1e-3),
              make_frame(joined, time=2e-3)]
    per_frame = [st.find_droplets(f, DELTA) for f in frames]
    assert [len(p) for p in per_frame] == [2, 2, 1]
    tracks = st.track_droplets(per_frame)
    assert [(len(t.droplets), t.start, t.end) for t in tracks] == [
        (2, "first", "merged"), (2, "first", "merged"), (1, "merged", "end")]
    halves = [st.find_droplets(make_frame(joined, time=0.0), DELTA),
              st.find_droplets(make_frame(apart, time=1e-3), DELTA)]
    split = st.track_droplets(halves)  # one droplet breaking into two halves
    assert [(t.start, t.end) for t in split] == [("first", "split"), ("split", "end"),
                                                 ("split", "end")]
    # losing five grains keeps the track
    ids = np.arange(len(left))
    keep = ids >= 5
    shed = [make_frame(left, ids=ids, time=0.0),
            make_frame(left[keep], ids=ids[keep], time=1e-3)]
    kept = st.track_droplets([st.find_droplets(f, DELTA) for f in shed])
    assert len(kept) == 1 and len(kept[0].droplets) == 2
    with pytest.raises(ValueError, match="overlap"):
        st.track_droplets(per_frame, overlap=0.3)
    with pytest.raises(ValueError, match="time order"):
        st.track_droplets(per_frame[::-1])


# --------------------------------------------------------------------------- regimes


def profile(values, width=5e-3):
    values = np.asarray(values, float)
    return st.depth_profile((np.arange(values.size) + 0.5) * width, values, width,
                            quantity="network size")


Z = (np.arange(40) + 0.5) * 5e-3  # 0-20 cm
SPRAY = 1 + 5 * np.exp(-Z / 0.02)
CLUSTER = np.where(Z < 0.01, 8.0, 1.5 + 10.5 * (1 - np.exp(-(Z - 0.01) / 0.04)))
DROPLETS = np.where(Z < 0.03, 100 + 1000 * Z / 0.03, 200 + 900 * np.exp(-(Z - 0.03) / 0.02))


@pytest.mark.parametrize("values, regime", [(SPRAY, "spray"), (CLUSTER, "clustering"),
                                            (DROPLETS, "droplets")])
def test_regime_classifier_on_profile_shapes(values, regime):
    decision = st.classify_regime(profile(values))
    assert decision.regime == regime, decision.reason
    assert decision.numbers()["regime"] == regime
    assert decision.n_inf == pytest.approx(np.mean(values[-3:]))


def test_regime_classifier_edge_cases():
    dripping = st.classify_regime(profile(DROPLETS), outflow_cv=1.2)
    assert dripping.regime == "dripping" and dripping.outflow_cv == 1.2
    assert st.classify_regime(profile(DROPLETS), outflow_cv=0.1).regime == "droplets"
    # no droplet found: a falling profile is not the droplet regime
    assert st.classify_regime(profile(DROPLETS), droplet_count=0).regime == "clustering"
    # a large first bin (grains still joined to the hopper), then dip and regrowth
    start_high = CLUSTER.copy()
    start_high[0] = 50.0
    d = st.classify_regime(profile(start_high))
    assert d.regime == "clustering" and d.droplets_present and d.growth > 1.2
    with pytest.raises(ValueError, match="network_size"):
        st.classify_regime(profile(SPRAY[:3]))
    with pytest.raises(ValueError, match="min_drop"):
        st.RegimeThresholds(min_drop=0)


def falling_grains(depths, v=0.2, dt=1e-3, n=40):
    """Grains on the axis at initial ``depths``, all falling at v."""
    frames = []
    for k in range(n):
        z = -(np.asarray(depths) + v * k * dt)
        pos = np.column_stack([np.zeros(z.size), np.zeros(z.size), z])
        frames.append(make_frame(pos, time=k * dt, step=k))
    return frames


def test_outflow_steadiness():
    v, dt = 0.2, 1e-3
    steady = falling_grains(D - np.arange(200) * v * dt / 2 - 0.25 * v * dt, v, dt)
    out = st.outflow_steadiness(steady, crossing_depth=D)
    assert out.mean_rate == pytest.approx(2 / dt)
    assert out.cv == pytest.approx(0.0, abs=1e-9) and len(out.window_rates) == 7
    clumps = np.repeat(-np.arange(4) * 10 * v * dt - 0.25 * v * dt, 20)
    bursty = st.outflow_steadiness(falling_grains(clumps, v, dt), crossing_depth=D)
    assert bursty.cv > 0.5
    stuck = st.outflow_steadiness(falling_grains(-np.ones(5), 0.0, dt), crossing_depth=D)
    assert stuck.mean_rate == 0 and stuck.cv == np.inf
    assert st.classify_regime(profile(CLUSTER), outflow_cv=bursty.cv).regime == "dripping"
    with pytest.raises(ValueError, match="2 frames"):
        st.outflow_steadiness(steady[:1])


# --------------------------------------------------------------------------- plots


def test_plots_write_pngs(tmp_path):
    chain = np.column_stack([np.arange(3) * D, np.zeros(3), np.full(3, -0.5e-3)])
    frames = [make_frame(chain + [0, 0, -k * 1e-3], time=k * 1e-3) for k in range(4)]
    prof = st.contact_profiles(frames, DELTA)
    norm = st.normalised_contact_number(prof)
    check_png(sp.plot_contact_number([norm, norm], tmp_path / "z.png", labels=["a", "b"]))
    sat = st.saturation_network_size(profile(CLUSTER), depth=0.19)
    check_png(sp.plot_network_size([profile(CLUSTER), profile(DROPLETS)], tmp_path / "n.png",
                                   labels=["clustering", "droplets"], saturation=sat))
    rng = np.random.default_rng(0)
    z = (np.arange(200) + 0.5) * 1e-4
    pos = np.concatenate([np.column_stack([np.full(z.size, x), np.full(z.size, y), -z])
                          for x in (0, D) for y in (0, D)])
    vel = np.column_stack([np.zeros(len(pos)), np.zeros(len(pos)),
                           -st.free_fall_speed(-pos[:, 2], 0.1)]) + rng.normal(
        scale=1e-4, size=pos.shape)
    dev = st.velocity_deviation_profile([make_frame(pos, vel), make_frame(pos, vel, time=1)],
                                        bin_width=D)
    fit = st.fit_free_fall_profile(dev, 0.1, weighting="relative", depth_range=(3e-4, 1))
    check_png(sp.plot_velocity_deviations(dev, tmp_path / "dv.png", fit=fit))
    check_png(sp.plot_aspect_histogram(st.aspect_ratio_histogram(rng.gamma(4, 0.5, 200)),
                                       tmp_path / "a.png"))
    tracks = st.track_droplets([st.find_droplets(f, DELTA) for f in pair_frames(0.014, n=4)])
    check_png(sp.plot_droplet_separations(st.droplet_separations(tracks, v0=0.1),
                                          tmp_path / "sep.png"))
    traced = st.trace_droplet_pairs(traced_frames(n=40), DELTA, min_depth=0.01, v0=0.5)
    check_png(sp.plot_traced_pairs(traced, tmp_path / "traced.png"))
    dz0 = np.array([2e-4, 5e-4, 1e-3])
    fit = st.fit_separation_gradient(dz0, np.sqrt(0.01 + 2 * G * dz0) - 0.1, grain_diameter=D)
    check_png(sp.plot_separation_gradient(dz0, np.sqrt(0.01 + 2 * G * dz0) - 0.1, fit,
                                          tmp_path / "gradient.png", grain_diameter=D))
    with pytest.raises(ValueError, match="t0 is NaN"):
        sp.plot_traced_pairs(st.trace_droplet_pairs(traced_frames(n=40)[6:], DELTA,
                                                    min_depth=0.01), tmp_path / "x.png")
    check_png(sp.plot_phase_diagram([0, 1e-9, 1e-7, 1e-6, 3e-6], [0.9, 0.88, 0.4, 0.4, 0.4],
                                    [0.1, 0.5, 2.0, np.nan, 4.0],
                                    ["spray", "clustering", "droplets", "droplets",
                                     "dripping"], tmp_path / "phase.png"))
    with pytest.raises(ValueError, match="labels"):
        sp.plot_contact_number(norm, tmp_path / "x.png", labels=["a", "b"])
    with pytest.raises(ValueError, match="regimes"):
        sp.plot_phase_diagram([1e-9], [0.5], [1.0], [], tmp_path / "x.png")
    with pytest.raises(ValueError, match="cohesive_force"):
        sp.plot_phase_diagram([-1e-9], [0.5], [1.0], ["spray"], tmp_path / "x.png")


def test_stream_side_view_and_movie(tmp_path):
    """The side view is a PNG; the movie is a GIF with one picture per frame, all of the
    same size; grains above the aperture are left out by stream_grains."""
    from PIL import Image

    from grainflow.plotting.stream_plots import plot_stream_side, write_stream_movie

    drop = ball(3, (0.0, 0.0, -0.01))
    hopper = ball(2, (0.0, 0.0, 0.002))
    frames = [make_frame(np.concatenate([drop - [0, 0, 1e-3 * k], hopper]), time=1e-3 * k,
                         step=k) for k in range(3)]
    below = st.stream_grains(frames[0])
    assert below.n == len(drop) and np.all(below.position[:, 2] < 0)
    check_png(plot_stream_side(below, tmp_path / "side.png", DELTA, depth_range=(0, 0.02),
                               columns=2))
    gif = write_stream_movie([st.stream_grains(f) for f in frames], tmp_path / "s.gif", DELTA,
                             depth_range=(0, 0.02), columns=2)
    with Image.open(gif) as movie:
        assert movie.n_frames == 3
        size = movie.size
        sizes = set()
        for k in range(movie.n_frames):
            movie.seek(k)
            sizes.add(movie.size)
        assert sizes == {size} and size[0] > 100 and size[1] > 100


def test_contact_against_capture_velocity_plot(tmp_path):
    from grainflow.plotting.stream_plots import plot_contact_vs_capture

    check_png(plot_contact_vs_capture([0.0, 1e-3, 3e-3, 0.0, 2e-3], [0.0, 0.5, 2.0, 0.1, 1.0],
                                      [0.88, 0.88, 0.88, 0.4, 0.4], tmp_path / "c.png"))
    with pytest.raises(ValueError, match="capture_velocity"):
        plot_contact_vs_capture([1.0, 2.0], [1.0], [0.4, 0.4], tmp_path / "bad.png")
