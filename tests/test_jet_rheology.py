"""Rheology next to a jet's target (grainflow.analysis.jet.rheology; seed 002, Sano's thesis,
chapters 5 and 6): the seed's meshes, its half-cell strain rate, the wall particles' role, the
equation of state of a gas, pooling, fits, flatness and the figures."""

from __future__ import annotations

from math import pi

import numpy as np
import pytest

from grainflow.analysis.jet import rheology as jr
from grainflow.analysis.cg import Cylindrical, coarse_grain, select_types
from grainflow.analysis.kinetic_theory import pressure_ratio
from grainflow.frame import ANCHOR, BOND, PAIR, Box, Contacts, Frame
from grainflow.plotting import jet_rheology_plots as jp

R_TAR = 11.0  # 3D: D_tar = 22 d
R_TAR_2D = 33.0  # 2D: R_tar = 2.2 R_jet, R_jet = 15 d


def make_frame(pos, vel, *, types=None, contacts=None, time=0.0, radius=0.5, mass=1.0):
    """A frame with ids 100, 101, ... and an empty contact listing unless given."""
    pos = np.asarray(pos, dtype=float)
    n, dim = pos.shape
    if contacts is None:
        contacts = Contacts(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, dim)),
                            np.zeros((0, dim)), np.zeros(0, np.int8))
    box = Box(pos.min(axis=0) - 5, pos.max(axis=0) + 5, (False,) * dim)
    return Frame(step=int(time * 100), time=time, box=box, id=np.arange(n, dtype=np.int64) + 100,
                 type=np.zeros(n, np.int32) if types is None else np.asarray(types, np.int32),
                 body=-np.ones(n, np.int64), radius=np.full(n, radius),
                 mass=np.broadcast_to(mass, (n,)).astype(float), position=pos,
                 velocity=np.asarray(vel, dtype=float), omega=np.zeros((n, 3)),
                 contacts=contacts)


def rings(radii, z_values, n_theta=8):
    """Points on rings of the given radii (n_theta azimuths, offset so none lies on an axis) at
    every z."""
    theta = (np.arange(n_theta) + 0.3) * 2 * pi / n_theta
    pts = [(r * np.cos(t), r * np.sin(t), z) for r in radii for t in theta for z in z_values]
    return np.array(pts)


def cylindrical_velocity(pos, v_r, v_theta, v_z):
    r = np.hypot(pos[:, 0], pos[:, 1])
    safe = np.where(r > 0, r, 1.0)
    c, s = np.where(r > 0, pos[:, 0] / safe, 1.0), np.where(r > 0, pos[:, 1] / safe, 0.0)
    v_r, v_theta, v_z = (np.broadcast_to(v, r.shape) for v in (v_r, v_theta, v_z))
    return np.column_stack([v_r * c - v_theta * s, v_r * s + v_theta * c, v_z])


# --- meshes ----------------------------------------------------------------------------------

def test_mesh_geometry_3d_and_2d():
    dr = R_TAR / 5
    gas = make_frame([[1.0, 0.0, 1.0], [3.0, 0.5, 2.0]], [[0, 0, -1], [0, 0, -1]])
    lay = jr.layer_fields_3d([gas], R_TAR)
    np.testing.assert_allclose(lay.centres, (np.arange(5) + 0.5) * dr)
    np.testing.assert_allclose(lay.scaled_centres, [0.1, 0.3, 0.5, 0.7, 0.9])
    np.testing.assert_allclose(lay.volumes, pi * dr**2 * (2 * np.arange(5) + 1) * 5.0)
    assert lay.layer == (0.0, 5.0) and lay.components == ("r", "theta", "z")
    # the coarse-grained fields are on the seed's grids
    main, half, shifted = lay.sources
    np.testing.assert_allclose(main.coordinates.cell_volumes(), lay.volumes)
    np.testing.assert_allclose(half.coordinates.edges[1], [0, 2.5, 5])
    np.testing.assert_allclose(shifted.coordinates.edges[0],
                               [0, 0.5 * dr, 1.5 * dr, 2.5 * dr, 3.5 * dr, 4.5 * dr, 5.5 * dr])
    flat = make_frame([[1.0, 0.3], [7.0, -4.0]], [[-1, 0], [-1, 0]])
    a, b = jr.layer_fields_2d([flat], R_TAR_2D)
    dy = R_TAR_2D / 5
    np.testing.assert_allclose(a.edges, np.arange(-5, 6) * dy)
    np.testing.assert_allclose(b.centres, (np.arange(-5, 5) + 0.5) * dy)
    np.testing.assert_allclose(a.volumes, np.full(10, dy * 5.0))
    assert (a.layer, b.layer) == ((0.0, 5.0), (5.0, 10.0))
    np.testing.assert_allclose(a.sources[2].coordinates.edges[1], (np.arange(-5, 7) - 0.5) * dy)


def test_2d_layers_select_their_grains():
    dy = R_TAR_2D / 5
    # (a): 3 grains in cell k = 0 (0 < y < dy) moving at (-1, 0); (b): 2 grains there at
    # (-2, 0.5); one grain beyond 10 d, one in the target's plane x < 0, one beyond R_tar
    pos = [[1.0, 0.5], [2.0, 1.0], [4.9, 2.0], [5.5, 1.0], [9.9, 3.0], [12.0, 1.0],
           [-0.3, 1.0], [2.0, R_TAR_2D + 1]]
    vel = [[-1, 0]] * 3 + [[-2, 0.5]] * 2 + [[-9, 9]] * 3
    a, b = jr.layer_fields_2d([make_frame(pos, vel)], R_TAR_2D)
    k = 5  # cell 0 < y < dy
    assert a.n[k] == pytest.approx(3 / (5 * dy)) and b.n[k] == pytest.approx(2 / (5 * dy))
    assert a.n.sum() == a.n[k] and b.n.sum() == b.n[k]
    np.testing.assert_allclose(a.velocity[k], [-1, 0])
    np.testing.assert_allclose(b.velocity[k], [-2, 0.5])
    assert a.phi[k] == pytest.approx(3 * pi * 0.25 / (5 * dy))
    # custom layers, in the order given
    (c,) = jr.layer_fields_2d([make_frame(pos, vel)], R_TAR_2D, layers=[(5.0, 12.5)])
    assert c.n[k] == pytest.approx(3 / (7.5 * dy))


# --- the seed's half-cell strain rate --------------------------------------------------------

@pytest.mark.parametrize("a", [0.0, 0.07])
def test_half_cell_d_rz_of_radial_outflow_with_shear(a):
    """v_r = c r + a z (a rigid radial outflow plus a shear in z), v_z constant: the half
    layers give dv_r/dz = a exactly (grains symmetric in each half), the shifted rings
    dv_z/dr = 0, so D_rz = a/2; a = 0 is the pure outflow with D_rz = 0."""
    dr, c = R_TAR / 5, 0.05
    # rings at the cells' centres, and one near the axis for the first shifted ring
    pos = rings(np.r_[0.2, np.arange(5) + 0.5] * dr, 5.0 * np.array([1, 3, 5, 7]) / 8)
    r = np.hypot(pos[:, 0], pos[:, 1])
    vel = cylindrical_velocity(pos, c * r + a * pos[:, 2], 0.0, -0.3)
    lay = jr.layer_fields_3d([make_frame(pos, vel)], R_TAR)
    np.testing.assert_allclose(lay.values["dvr_dz"], a, atol=1e-12)
    np.testing.assert_allclose(lay.values["dvz_dr"], 0.0, atol=1e-12)
    np.testing.assert_allclose(lay.D, a / 2, atol=1e-12)
    np.testing.assert_allclose(lay.velocity[1:, 0], c * lay.centres[1:] + a * 2.5, atol=1e-12)
    # no fluctuation across the rings' azimuths or radii in v_z: T_z = 0
    np.testing.assert_allclose(lay.T_alpha[:, 2], 0.0, atol=1e-12)


def test_half_cell_d_rz_of_a_linear_axial_profile():
    """v_z = v0 + b r on rings at the nominal centres r = 0, dr, 2 dr, ... of the shifted
    cells (the first, 0 < r < dr/2, stands for r = 0): dv_z/dr = b exactly, D_rz = b/2."""
    dr, b = R_TAR / 5, -0.04
    pos = np.vstack([[[0.0, 0.0, z] for z in (1.0, 4.0)],
                     rings(np.arange(1, 6) * dr, (1.0, 4.0))])
    r = np.hypot(pos[:, 0], pos[:, 1])
    vel = cylindrical_velocity(pos, 0.0, 0.0, -1.0 + b * r)
    lay = jr.layer_fields_3d([make_frame(pos, vel)], R_TAR)
    np.testing.assert_allclose(lay.values["dvz_dr"], b, atol=1e-12)
    np.testing.assert_allclose(lay.values["dvr_dz"], 0.0, atol=1e-12)
    np.testing.assert_allclose(lay.D, b / 2, atol=1e-12)


def test_half_cell_d_xy_of_a_linear_shear_in_both_layers():
    """v_x = v0 + b y, v_y = a x with grains placed symmetrically about the centres of the
    half layers and of the shifted cells: D_xy = (a + b)/2 in layers (a) and (b)."""
    dy, a, b = R_TAR_2D / 5, 0.02, 0.01
    xs = np.concatenate([lo + 5.0 * np.array([1, 3, 5, 7]) / 8 for lo in (0.0, 5.0)])
    ys = np.concatenate([[j * dy - dy / 4, j * dy + dy / 4] for j in range(-5, 6)])
    pos = np.array([(x, y) for x in xs for y in ys])
    vel = np.column_stack([-1.0 + b * pos[:, 1], a * pos[:, 0]])
    la, lb = jr.layer_fields_2d([make_frame(pos, vel)], R_TAR_2D)
    for lay in (la, lb):
        np.testing.assert_allclose(lay.values["dvy_dx"], a, atol=1e-12)
        np.testing.assert_allclose(lay.values["dvx_dy"], b, atol=1e-12)
        np.testing.assert_allclose(lay.D, (a + b) / 2, atol=1e-12)
    # I_s = |D_xy| sqrt(m/P): the gas has P = n T_g (kinetic only)
    np.testing.assert_allclose(la.I, np.abs(la.D) * np.sqrt(1.0 / la.P))
    np.testing.assert_allclose(la.I_T, np.sqrt(la.T_g / la.P))


def test_normal_rates_of_a_stagnation_flow_with_shear():
    """v_x = v0 + b y - e x, v_y = a x + e y (incompressible, the extension e along the axes
    of a stagnation line): dv_x/dx = -e and dv_y/dy = e by the same half-cell differences,
    D_ext = -e, D_dev = hypot(D_xy, e), shear fraction |D_xy| / D_dev, I_dev = D_dev sqrt(m/P).
    With a = b = 0 the flow is a pure extension: D_xy = 0, shear fraction 0, yet I_dev > 0."""
    dy = R_TAR_2D / 5
    xs = np.concatenate([lo + 5.0 * np.array([1, 3, 5, 7]) / 8 for lo in (0.0, 5.0)])
    ys = np.concatenate([[j * dy - dy / 4, j * dy + dy / 4] for j in range(-5, 6)])
    pos = np.array([(x, y) for x in xs for y in ys])
    for a, b, e in ((0.02, 0.01, 0.03), (0.0, 0.0, 0.03)):
        vel = np.column_stack([-1.0 + b * pos[:, 1] - e * pos[:, 0], a * pos[:, 0] + e * pos[:, 1]])
        for lay in jr.layer_fields_2d([make_frame(pos, vel)], R_TAR_2D):
            v = lay.values
            np.testing.assert_allclose(v["dvx_dx"], -e, atol=1e-12)
            np.testing.assert_allclose(v["dvy_dy"], e, atol=1e-12)
            np.testing.assert_allclose(lay.D, (a + b) / 2, atol=1e-12)
            np.testing.assert_allclose(v["D_ext"], -e, atol=1e-12)
            np.testing.assert_allclose(v["D_dev"], np.hypot((a + b) / 2, e), atol=1e-12)
            np.testing.assert_allclose(v["shear_fraction"],
                                       abs(a + b) / 2 / np.hypot((a + b) / 2, e), atol=1e-9)
            np.testing.assert_allclose(v["I_dev"], v["D_dev"] * np.sqrt(1.0 / lay.P))
        if a == b == 0:
            assert np.all(lay.I < 1e-9) and np.all(v["I_dev"] > 0)


@pytest.mark.parametrize("a", [0.0, 0.05])
def test_normal_rates_of_an_axisymmetric_stagnation_flow(a):
    """v_r = c r + a z, v_z = v0 - 2 c z (incompressible: dv_r/dr + v_r/r + dv_z/dz = 0, an
    extension in r, a compression in z, plus a shear a), grains symmetric about the nominal
    centres of the rings, half layers and shifted rings: dv_z/dz = -2c, v_r/r = c (+ a z/r),
    dv_r/dr = c on every shifted difference but the first (its ring 0 < r < dr/2 stands for
    r = 0), D_rz = a/2, and D_dev = sqrt(3 c^2 + D_rz^2) where the rates are exact."""
    dr, c = R_TAR / 5, 0.02
    # the last shifted ring reaches to 5.5 dr: a ring at 5.25 dr completes it
    radii = np.r_[np.concatenate([(k + np.array([0.25, 0.75])) * dr for k in range(5)]),
                  5.25 * dr]
    pos = rings(radii, 5.0 * np.array([1, 3, 5, 7]) / 8)
    r = np.hypot(pos[:, 0], pos[:, 1])
    vel = cylindrical_velocity(pos, c * r + a * pos[:, 2], 0.0, -0.5 - 2 * c * pos[:, 2])
    lay = jr.layer_fields_3d([make_frame(pos, vel)], R_TAR)
    v = lay.values
    np.testing.assert_allclose(v["dvz_dz"], -2 * c, atol=1e-12)
    np.testing.assert_allclose(v["dvr_dr"][1:], c, atol=1e-12)
    np.testing.assert_allclose(v["vr_over_r"], c + a * 2.5 / lay.centres, atol=1e-12)
    np.testing.assert_allclose(lay.D, a / 2, atol=1e-12)
    if a == 0:
        np.testing.assert_allclose(v["D_dev"][1:], np.sqrt(3) * c, atol=1e-12)
        np.testing.assert_allclose(v["shear_fraction"], 0.0, atol=1e-12)
    else:
        assert np.all(v["D_dev"] >= np.abs(lay.D)) and np.all(v["shear_fraction"] <= 1)
    np.testing.assert_allclose(v["I_dev"], v["D_dev"] * np.sqrt(1.0 / lay.P))


# --- the target's wall particles -------------------------------------------------------------

def _target_frame():
    """Grains 100-103 (type 0) and wall particles 104-107 (type 2): three target particles at
    z = -0.5 and one put inside the layer with a large velocity (it must not count). Contacts:
    wall 104 -> grain 100 listed from the wall's side (to be flipped), grain 101 -> wall 105
    listed from the grain's side, a tether bond between two wall particles, an anchor of a
    wall particle, and a grain-grain pair."""
    pos = np.array([[0.5, 0.2, 0.3], [1.5, -0.4, 0.4], [4.0, 1.0, 2.0], [4.2, 0.5, 2.8],
                    [0.5, 0.2, -0.5], [1.5, -0.4, -0.5], [2.5, 0.0, -0.5], [1.0, 1.0, 1.0]])
    vel = np.array([[0.1, 0.0, -0.5], [0.0, 0.2, -0.3], [0.3, 0.1, -0.2], [0.2, -0.1, -0.4],
                    [0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, -4.0, 3.0]])
    ids = np.arange(8) + 100
    f_on_100 = np.array([0.1, 0.0, 2.0])  # from wall 104
    f_on_101 = np.array([-0.2, 0.1, 1.5])  # from wall 105
    f_on_102 = np.array([-0.3, -0.1, -0.6])  # from grain 103
    i = np.array([104, 101, 104, 105, 102])
    j = np.array([100, 105, 105, -1, 103])
    force = np.array([-f_on_100, f_on_101, [0.5, 0, 0], [0, 0, 0.7], f_on_102])
    branch = np.array([pos[4] - pos[0], pos[1] - pos[5], pos[4] - pos[5], [0, 0, 0.05],
                       pos[2] - pos[3]])
    kind = np.array([PAIR, PAIR, BOND, ANCHOR, PAIR], np.int8)
    frame = make_frame(pos, vel, types=[0, 0, 0, 0, 2, 2, 2, 2],
                       contacts=Contacts(i, j, force, branch, kind))
    return frame, (f_on_100, f_on_101, f_on_102)


def test_select_types_keeps_every_grain_contact_from_the_grain_side():
    frame, (f100, f101, _) = _target_frame()
    grains = select_types(frame, jr.GRAIN_TYPES)
    assert grains.n == 4 and set(grains.type) == {0}
    c = grains.contacts
    assert set(c.i) <= set(grains.id) and c.i.size == 3  # bond and anchor dropped
    row = int(np.nonzero(c.i == 100)[0][0])  # the flipped row
    assert c.j[row] == 104 and c.kind[row] == PAIR
    np.testing.assert_allclose(c.force[row], f100)
    np.testing.assert_allclose(c.branch[row], frame.position[0] - frame.position[4])
    # F (x) b is unchanged by the flip
    np.testing.assert_allclose(np.outer(c.force[row], c.branch[row]),
                               np.outer(frame.contacts.force[0], frame.contacts.branch[0]))
    # the library itself cannot drop particles whose id a contact names as i
    naive = Frame(**{**grains.__dict__, "contacts": frame.contacts})
    with pytest.raises(ValueError, match="contacts name particle ids"):
        coarse_grain([naive], Cylindrical([0, 11], [0, 5]))
    assert select_types(grains, jr.GRAIN_TYPES) is grains  # nothing to drop
    # coarse_grain's types= is the same selection, frame by frame
    grid = Cylindrical([0, 2, 11], [0, 5])
    by_types = coarse_grain([frame], grid, types=jr.GRAIN_TYPES)
    selected = coarse_grain([grains], grid)
    for name in ("number_density", "velocity", "stress"):
        np.testing.assert_array_equal(getattr(by_types, name), getattr(selected, name))
    assert not np.allclose(coarse_grain([frame], grid).number_density, selected.number_density)
    with pytest.raises(ValueError, match="types"):
        coarse_grain([frame], grid, types=[])


def test_target_particles_left_out_of_kinetic_sums_but_their_contacts_count():
    frame, (f100, f101, f102) = _target_frame()
    lay = jr.layer_fields_3d([frame], R_TAR)
    dr = R_TAR / 5
    v0 = pi * dr**2 * 5.0
    # cell 0 holds grains 100, 101 (the wall particle at r = 1.41, z = 1 is not counted)
    assert lay.n[0] == pytest.approx(2 / v0)
    assert lay.n[1] == pytest.approx(2 / (3 * v0))
    vel = frame.velocity[:2]
    mean_vz = vel[:, 2].mean()
    assert lay.velocity[0, 2] == pytest.approx(mean_vz)
    assert lay.T_alpha[0, 2] == pytest.approx(np.mean((vel[:, 2] - mean_vz) ** 2))
    # zz contact stress of cell 0: the two grain-wall contacts, each by the fraction of its
    # branch line in z > 0 (grain at z = 0.3 resp. 0.4 above a wall centre at -0.5); the
    # kinetic zz stress adds sum m (v_z - V_z)^2 / V
    frac = np.array([0.3 / 0.8, 0.4 / 0.9])
    fb_zz = np.array([f100[2] * 0.8, f101[2] * 0.9])
    kinetic_zz = np.sum((vel[:, 2] - mean_vz) ** 2) / v0
    assert lay.sigma[0, 2, 2] == pytest.approx((fb_zz * frac).sum() / v0 + kinetic_zz)
    # the same as coarse-graining the grains alone with the contacts written grain-first
    ref = coarse_grain([frame], Cylindrical(lay.edges, [0, 5]), types=jr.GRAIN_TYPES)
    np.testing.assert_allclose(lay.sigma, ref.stress, atol=1e-14)
    # the grain-grain contact in cell 1 (both grains at r ~ 4.1, 4.2)
    assert abs(lay.sigma[1, 2, 2] - ref.stress[1, 2, 2]) < 1e-14 and lay.sigma[1, 2, 2] != 0


# --- equation of state of a gas, kinetic theory, pooling --------------------------------------

def _gas(rng, n=4000, temperature=0.04, drift=(0.0, 0.0, -1.0), time=0.0):
    r = R_TAR * np.sqrt(rng.random(n))
    t = 2 * pi * rng.random(n)
    pos = np.column_stack([r * np.cos(t), r * np.sin(t), 5.0 * rng.random(n)])
    vel = np.asarray(drift) + np.sqrt(temperature) * rng.normal(size=(n, 3))
    return make_frame(pos, vel, time=time, radius=0.2)


def test_uniform_gas_has_p_over_nt_one_and_its_temperature():
    rng = np.random.default_rng(1)
    frames = [_gas(rng, time=t) for t in range(4)]
    lay = jr.layer_fields_3d(frames, R_TAR, blocks=2)
    np.testing.assert_allclose(lay.values["P_over_nT"], 1.0, rtol=1e-12)
    np.testing.assert_allclose(lay.values["P_alpha_over_nT_alpha"], 1.0, rtol=1e-12)
    np.testing.assert_allclose(lay.T_g, 0.04, rtol=0.1)
    np.testing.assert_allclose(lay.n, 4000 / (pi * R_TAR**2 * 5), rtol=0.15)
    np.testing.assert_allclose(lay.phi, lay.n * 4 / 3 * pi * 0.2**3, rtol=1e-12)
    assert np.all(np.isfinite(lay.error("T_g"))) and np.all(lay.error("T_g") > 0)
    check = jr.kinetic_theory_check(lay, 0.75)
    np.testing.assert_allclose(check.measured, 1.0)
    np.testing.assert_allclose(check.theory, pressure_ratio(lay.phi, 0.75, 3))
    assert np.all(check.theory > 1) and check.components == ("r", "theta", "z")
    np.testing.assert_allclose(check.curve([0.3]), 1 + 2 * 0.3 * 1.75 * (1 - 0.15) / 0.7**3)
    assert np.isnan(check.curve([0.7]))[0]  # beyond phi_c = 0.64


def test_pool_gives_the_replica_mean_and_spread():
    rng = np.random.default_rng(2)
    reps = [jr.layer_fields_3d([_gas(rng, drift=(0, 0, vz))], R_TAR) for vz in (-1.0, -0.8)]
    pooled = jr.pool(reps)
    assert pooled.blocks == 2
    np.testing.assert_allclose(pooled.n, 0.5 * (reps[0].n + reps[1].n))
    spread = np.abs(reps[0].n - reps[1].n) / np.sqrt(2)
    np.testing.assert_allclose(pooled.spread("n"), spread, rtol=1e-10)
    np.testing.assert_allclose(pooled.error("n"), spread / np.sqrt(2), rtol=1e-10)
    with pytest.raises(ValueError, match="share the mesh"):
        jr.pool([reps[0], jr.layer_fields_3d([_gas(rng)], R_TAR, n_r=4)])


# --- fits ------------------------------------------------------------------------------------

def _table(dim, **values):
    n = len(next(iter(values.values())))
    edges = np.linspace(0, 1, n + 1)
    errs = {k: np.full(n, 0.01 if k in ("phi",) else 0.005) for k in values}
    return jr.LayerFields(dim=dim, target_radius=1.0, layer=(0.0, 5.0), edges=edges,
                          values={k: np.asarray(v, float) for k, v in values.items()},
                          errors=errs)


def test_fits_recover_the_seed_parameters():
    rng = np.random.default_rng(3)
    # 3D mu* = a I, two "layers" (replicas); NaN cells and I = 0 are left out
    I3 = np.linspace(0.01, 0.3, 12)
    mu3 = 0.240 * I3 + 0.002 * rng.normal(size=I3.size)
    tables = [_table(3, I=I3[:6], mu_folded=mu3[:6]),
              _table(3, I=np.r_[I3[6:], 0.0, np.nan], mu_folded=np.r_[mu3[6:], 0.1, 0.1])]
    fit = jr.fit_friction_3d(tables)
    assert fit.a == pytest.approx(0.240, abs=0.01) and fit.n_points == 12
    assert jr.fit_friction_3d(tables, weighted=False).a == pytest.approx(0.240, abs=0.01)
    # 2D: the divergences of eqs. 6.2 and 6.3 and the friction laws (noise-free)
    I_s = np.geomspace(0.01, 0.15, 20)
    phi = 0.834 - 3.94 * I_s ** (2 / 1.36)
    I_T = ((0.858 - phi) / 0.980) ** (1.15 / 2)
    I_mu = np.geomspace(0.005, 1.0, 20)
    mu = 0.0153 + (0.521 - 0.0153) / (1 + 0.082 / I_mu)
    t = _table(2, I=I_s, I_T=I_T, phi=phi)
    ds = jr.fit_divergence_2d(t, "I")
    assert (ds.phi_c, ds.a, ds.alpha) == pytest.approx((0.834, 3.94, 1.36), rel=1e-4)
    dt = jr.fit_divergence_2d([t], "I_T")
    assert (dt.phi_c, dt.a, dt.alpha) == pytest.approx((0.858, 0.980, 1.15), rel=1e-4)
    f = jr.fit_friction_2d(_table(2, I=I_mu, mu_folded=mu))
    assert (f.mu_s, f.mu_max, f.I0) == pytest.approx((0.0153, 0.521, 0.082), rel=1e-4)
    p = jr.fit_friction_2d(_table(2, I=I_mu, mu_folded=1.18 * I_mu**0.592), "power_law")
    assert (p.mu_s, p.b, p.beta) == pytest.approx((0.0, 1.18, 0.592), rel=1e-6, abs=1e-12)
    with pytest.raises(ValueError, match="law"):
        jr.fit_friction_2d(t, "linear")


def _layer_2d(lo, **values):
    t = _table(2, **values)
    return jr.LayerFields(dim=2, target_radius=1.0, layer=(lo, lo + 5.0), edges=t.edges,
                          values=t.values, errors=t.errors)


def test_fit_choices_2d_tell_the_layers_weights_and_strain_rates_apart():
    """Layer (a) follows phi = 0.85 - I^(2/2), layer (b) phi = 0.81 - 3 I^(2/1.2), with the
    same I_T and I_dev = I; cells of (b) with I < 0.02 flow by extension (shear fraction 0.1).
    Each choice gives back what it selects."""
    I = np.geomspace(0.005, 0.12, 16)  # noqa: E741
    mu = 0.01 + 0.5 / (1 + 0.08 / I)
    phi_a = 0.85 - I
    phi_b = 0.81 - 3.0 * I ** (2 / 1.2)
    frac_b = np.where(I < 0.02, 0.1, 0.9)
    a = _layer_2d(0.0, I=I, I_dev=I, I_T=((0.87 - phi_a) / 0.5) ** (1.5 / 2), phi=phi_a,
                  mu_folded=mu, shear_fraction=np.full(I.size, 0.9))
    b = _layer_2d(5.0, I=I, I_dev=I, I_T=((0.87 - phi_b) / 0.5) ** (1.5 / 2), phi=phi_b,
                  mu_folded=mu, shear_fraction=frac_b)
    rows = {r.label: r for r in jr.fit_choices_2d([a, b])}
    assert set(rows) == {"every cell, weighted (the table)", "every cell, unweighted",
                         "layer (a) alone", "layer (b) alone",
                         "cells with shear fraction >= 0.5", "I_dev in place of I_s"}
    ra, rb = rows["layer (a) alone"], rows["layer (b) alone"]
    assert (ra.I_s.phi_c, ra.I_s.alpha) == pytest.approx((0.85, 2.0), rel=1e-4)
    assert (rb.I_s.phi_c, rb.I_s.alpha) == pytest.approx((0.81, 1.2), rel=1e-4)
    assert ra.I_T.phi_c == pytest.approx(0.87, rel=1e-4) and ra.cells == rb.cells == 16
    assert ra.friction.I0 == pytest.approx(0.08, rel=1e-4)
    both = rows["every cell, weighted (the table)"]
    assert both.cells == 32 and 0.81 < both.I_s.phi_c < 0.85
    assert rows["cells with shear fraction >= 0.5"].cells == 32 - int(np.sum(I < 0.02))
    assert rows["I_dev in place of I_s"].I_s.phi_c == pytest.approx(both.I_s.phi_c)
    with pytest.raises(ValueError, match="layers"):
        jr.fit_choices_2d([_table(3, I=I, phi=phi_a)])
    with pytest.raises(ValueError, match="number"):
        jr.fit_friction_2d(a, number="I_T")
    with pytest.raises(ValueError, match="layers"):
        jr.fit_choices_3d([a])
    with pytest.raises(ValueError, match="number"):
        jr.fit_friction_3d(_table(3, I=I, mu_folded=mu), number="I_T")


def test_points_select_cells_and_drop_weights_when_errors_are_missing():
    t = _table(3, I=[0.1, 0.2, 0.3], mu_folded=[0.02, 0.05, 0.07])
    x, y, s = jr.rheology_points(t, "I", "mu_folded", select=lambda lay: lay.centres > 0.4)
    np.testing.assert_allclose(x, [0.2, 0.3])
    np.testing.assert_allclose(s, [0.005, 0.005])
    nan_errors = jr.LayerFields(dim=3, target_radius=1.0, layer=(0, 5), edges=t.edges,
                                values=t.values, errors={k: np.full(3, np.nan) for k in t.values})
    assert jr.rheology_points(nan_errors, "I", "mu_folded")[2] is None


def test_mu_is_folded_by_the_sign_of_the_strain_rate_in_2d():
    """v_x = -1 + c |y| (D_xy has the sign of y) and in every cell a contact with the viscous
    shear stress sigma_xy ~ -sgn(y): mu* = -sigma_xy / P changes sign with y, mu_folded is
    positive everywhere."""
    dy = R_TAR_2D / 5
    ys = np.concatenate([[j * dy - dy / 4, j * dy + dy / 4] for j in range(-5, 6)])
    xs = 5.0 * np.array([1, 3, 5, 7]) / 8
    pos = np.array([(x, y) for x in xs for y in ys])  # column x = 5/8 first
    vel = np.column_stack([-1.0 + 0.01 * np.abs(pos[:, 1]), np.zeros(len(pos))])
    k = np.arange(-5, 5)  # cell k dy < y < (k+1) dy holds the grains 2(k+5)+1 and 2(k+6)
    lower, upper = 2 * (k + 5) + 1, 2 * (k + 6)
    branch = pos[lower] - pos[upper]  # (0, -dy/2)
    force = np.column_stack([0.05 * np.sign(pos[lower, 1]), np.full(k.size, -1.0)])
    frame = make_frame(pos, vel, contacts=Contacts(lower + 100, upper + 100, force, branch))
    (a,) = jr.layer_fields_2d([frame], R_TAR_2D, layers=[(0.0, 5.0)])
    assert np.all(np.sign(a.D) == np.sign(a.centres))
    assert np.all(np.sign(a.mu) == np.sign(a.centres)) and np.all(a.mu_folded > 0)
    np.testing.assert_allclose(a.mu_folded, np.abs(a.mu))
    np.testing.assert_allclose(a.mu, -a.sigma[:, 0, 1] / a.P)
    np.testing.assert_allclose(a.shear_ratio, np.abs(a.sigma[:, 0, 1] / a.sigma[:, 0, 0]))


# --- velocity distributions ------------------------------------------------------------------

def test_layer_flatness_is_three_for_gaussian_and_six_for_exponential_fluctuations():
    rng = np.random.default_rng(4)
    n = 60000
    r = R_TAR * np.sqrt(rng.random(n))
    t = 2 * pi * rng.random(n)
    pos = np.column_stack([r * np.cos(t), r * np.sin(t), 5.0 * rng.random(n)])
    # cells of different temperature and mean flow: scaling per cell removes both
    scale = 0.1 + 0.1 * r / R_TAR
    v_r = 0.3 * r / R_TAR + scale * rng.normal(size=n)
    v_t = scale * rng.laplace(scale=1 / np.sqrt(2), size=n)
    v_z = -1 + scale * rng.normal(size=n)
    frame = make_frame(pos, cylindrical_velocity(pos, v_r, v_t, v_z))
    flat = jr.layer_flatness([frame], R_TAR, n_cells=10)
    assert flat["r"] == pytest.approx(3.0, abs=0.15)
    assert flat["z"] == pytest.approx(3.0, abs=0.15)
    assert flat["theta"] == pytest.approx(6.0, abs=0.6)
    u, m, comps = jr.layer_fluctuations([frame], R_TAR, n_cells=10, cells=[0, 1])
    assert comps == ("r", "theta", "z") and u.shape[1] == 3 and u.shape[0] == m.size
    np.testing.assert_allclose(np.mean(u**2, axis=0), 1.0, rtol=1e-10)
    flat2 = jr.layer_flatness([make_frame(pos[:, :2], rng.normal(size=(n, 2)))], R_TAR_2D,
                              dim=2, layer=(0.0, 11.0))
    assert set(flat2) == {"x", "y"} and flat2["x"] == pytest.approx(3.0, abs=0.2)


# --- figures ---------------------------------------------------------------------------------

def test_figures_write_pngs(tmp_path):
    rng = np.random.default_rng(5)
    lay = jr.layer_fields_3d([_gas(rng, n=1500, time=t) for t in range(2)], R_TAR, blocks=2)
    check = jr.kinetic_theory_check(lay, 0.616)
    I = np.linspace(0.02, 0.3, 8)
    t3 = _table(3, I=I, mu_folded=0.24 * I)
    I_s = np.geomspace(0.01, 0.15, 10)
    phi = 0.834 - 3.94 * I_s ** (2 / 1.36)
    mu = 0.0153 + 0.5057 / (1 + 0.082 / I_s)
    t2 = _table(2, I=I_s, I_T=((0.858 - phi) / 0.98) ** (1.15 / 2), phi=phi, mu_folded=mu)
    paths = [
        jp.plot_stress_profiles(lay, tmp_path / "stress.png"),
        jp.plot_velocity_profiles([lay, lay], tmp_path / "velocity.png", labels=["a", "b"]),
        jp.plot_pressure_ratio(check, tmp_path / "eos.png", per_direction=True),
        jp.plot_friction_3d(t3, tmp_path / "mu3d.png", fit=jr.fit_friction_3d(t3)),
        jp.plot_divergence_2d([t2, t2], tmp_path / "phi2d.png", labels=["(a)", "(b)"],
                              fits={"I": jr.fit_divergence_2d(t2),
                                    "I_T": jr.fit_divergence_2d(t2, "I_T")}),
        jp.plot_friction_2d(t2, tmp_path / "mu2d.png",
                            fits=[jr.fit_friction_2d(t2),
                                  jr.fit_friction_2d(t2, "power_law", mu_s=None)]),
    ]
    for p in paths:
        assert p.exists() and p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    flat_layers = jr.layer_fields_2d([make_frame([[1.0, 0.3], [7.0, -4.0]], [[-1, 0]] * 2)],
                                     R_TAR_2D)
    assert jp.plot_stress_profiles(flat_layers, tmp_path / "stress2d.png").exists()
    with pytest.raises(ValueError, match="labels"):
        jp.plot_friction_3d(t3, tmp_path / "x.png", labels=["a", "b"])


# --- bad inputs ------------------------------------------------------------------------------

@pytest.mark.parametrize("call, match", [
    (lambda f: jr.layer_fields_3d(f, -1.0), "target_radius"),
    (lambda f: jr.layer_fields_3d(f, R_TAR, layer=0.0), "layer"),
    (lambda f: jr.layer_fields_3d(f, R_TAR, n_r=0), "n_r"),
    (lambda f: jr.layer_fields_3d(f, R_TAR, blocks=3), "blocks"),
    (lambda f: jr.layer_fields_3d(f, R_TAR, window=(5.0, 6.0)), "window"),
    (lambda f: jr.layer_fields_2d(f, R_TAR_2D, n_y=9), "n_y"),
    (lambda f: jr.layer_fields_2d(f, R_TAR_2D, layers=[(5.0, 1.0)]), "layers"),
    (lambda f: jr.kinetic_theory_check(jr.layer_fields_3d(f, R_TAR), 0.75, dim=4), "dim"),
    (lambda f: jr.layer_fluctuations(f, R_TAR, cells=[7]), "cells"),
])
def test_bad_inputs_raise_value_error_naming_the_argument(call, match):
    gas = _gas(np.random.default_rng(6), n=200)
    frames = [gas, Frame(**{**gas.__dict__, "time": 1.0})]
    if match in ("n_y", "layers"):
        frames = [make_frame([[1.0, 0.3], [7.0, -4.0]], [[-1, 0]] * 2)]
    with pytest.raises(ValueError, match=match):
        call(frames)


def test_viscosity_check_finds_a_kinetic_layer_kinetic():
    """Rings built with the kinetic theory's pressure and viscosity (sigma_rz = -eta_kin D_rz,
    eqs. 5.2, 5.5, 5.12) give eta/eta_kin = 1 and mu*/I = friction_slope; a layer with twice
    the shear stress gives 2 and twice the slope."""
    from grainflow.analysis import kinetic_theory as kt

    phi = np.array([0.2, 0.35, 0.5])
    T = np.array([0.03, 0.02, 0.01])
    D = np.array([0.04, -0.02, 0.01])
    e = 0.75
    P = 6 * phi / np.pi * T * kt.pressure_ratio(phi, e)
    for factor in (1.0, 2.0):
        shear = -factor * kt.shear_viscosity(phi, T, e, 1.0, 1.0) * D
        sigma = np.zeros((3, 3, 3))
        sigma[:, 0, 2] = sigma[:, 2, 0] = shear
        table = _table(3, phi=phi, T_g=T, P=P, D=D, mu=-shear / P, I=np.abs(D) / np.sqrt(P))
        layer = jr.LayerFields(dim=3, target_radius=1.0, layer=(0.0, 5.0), edges=table.edges,
                               values={**table.values, "sigma": sigma}, errors=table.errors)
        check = jr.viscosity_check(layer, e)
        np.testing.assert_allclose(check.ratio, factor, rtol=1e-12)
        np.testing.assert_allclose(check.slope * np.sign(D), factor * kt.friction_slope(phi, e),
                                   rtol=1e-12)
        np.testing.assert_allclose(check.slope_kin, kt.friction_slope(phi, e), rtol=1e-12)
    with pytest.raises(ValueError, match="3D layer"):
        jr.viscosity_check(_table(2, phi=phi), e)
