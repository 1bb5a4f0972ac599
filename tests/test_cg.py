"""Coarse-graining library (grainflow.analysis.cg): kernels, branch-line fractions, exact
identities, fields of known flows, and the input checks."""

from __future__ import annotations

from math import pi

import numpy as np
import pytest

from grainflow.analysis.cg import (Cartesian, Cylindrical, Gaussian, Heaviside, Lucy, Polar,
                                   coarse_grain, combine, frame_sums, load_fields,
                                   slab_gradient, strain_rate)
from grainflow.frame import ANCHOR, PAIR, WALL, Box, Contacts, Frame
from grainflow.kernels import cg_deposit


def make_frame(pos, vel, *, radius=0.1, mass=1.0, contacts=None, box=None, step=0, time=0.0):
    pos = np.asarray(pos, dtype=float)
    n, dim = pos.shape
    if box is None:
        box = Box(pos.min(axis=0) - 1, pos.max(axis=0) + 1, (False,) * dim)
    return Frame(step=step, time=time, box=box, id=np.arange(n, dtype=np.int64) + 7,
                 type=np.zeros(n, np.int32), body=-np.ones(n, np.int64),
                 radius=np.full(n, radius), mass=np.broadcast_to(mass, (n,)).astype(float),
                 position=pos, velocity=np.asarray(vel, dtype=float), omega=np.zeros((n, 3)),
                 contacts=contacts)


def random_contacts(pos, rng, *, reach=1.2, kinds=(PAIR,)):
    """Contacts between close pairs (ids offset by 7, as make_frame names them), random forces;
    plus wall/anchor rows whose partner point is a random nearby point."""
    n, dim = pos.shape
    d = pos[:, None, :] - pos[None, :, :]
    i, j = np.nonzero(np.triu(np.linalg.norm(d, axis=2) < reach, k=1))
    branch = pos[i] - pos[j]
    kind = np.zeros(i.size, np.int8)
    rows_i, rows_j, rows_b, rows_k = [i], [j], [branch], [kind]
    for k in kinds:
        if k == PAIR:
            continue
        m = n // 5
        pick = rng.choice(n, m, replace=False)
        rows_i.append(pick)
        rows_j.append(np.zeros(m, np.int64) if k == WALL else -np.ones(m, np.int64))
        rows_b.append(rng.normal(scale=0.3, size=(m, dim)))
        rows_k.append(np.full(m, k, np.int8))
    i = np.concatenate(rows_i)
    branch = np.concatenate(rows_b)
    force = rng.normal(size=branch.shape)
    return Contacts(i + 7, np.concatenate(rows_j) + 7, force, branch, np.concatenate(rows_k))


# --- kernels ---------------------------------------------------------------------------------

@pytest.mark.parametrize("kernel", [Gaussian(0.7), Gaussian(0.7, cutoff=2.0), Lucy(1.3)])
@pytest.mark.parametrize("k", [1, 2, 3])
def test_kernel_integrates_to_one(kernel, k):
    """Radial quadrature int_0^reach S_k r^(k-1) W(r) dr of the compiled kernel (S_k the unit
    sphere's surface: 2, 2 pi, 4 pi), midpoint rule with 20000 points."""
    n = 20000
    r = (np.arange(n) + 0.5) * kernel.reach / n
    w = np.array([cg_deposit.kernel_weight(kernel.code, x * x, kernel.width, kernel.reach,
                                           kernel.norm(k)) for x in r])
    surface = {1: 2.0, 2: 2 * pi, 3: 4 * pi}[k]
    assert (surface * r ** (k - 1) * w).sum() * kernel.reach / n == pytest.approx(1.0, rel=1e-6)


def test_gaussian_kernel_is_the_normalised_gaussian_inside_its_cutoff():
    g = Gaussian(0.5, cutoff=4.0)
    assert cg_deposit.kernel_weight(g.code, 0.0, 0.5, g.reach, g.norm(2)) == pytest.approx(
        1 / (2 * pi * 0.25) / (1 - np.exp(-8.0)))
    assert cg_deposit.kernel_weight(g.code, 4.01**2 * 0.25, 0.5, g.reach, g.norm(2)) == 0.0


@pytest.mark.parametrize("k", [1, 2, 3])
def test_separable_gaussian_deposit_is_the_brute_force_sum(k):
    """deposit_gaussian_points (one-point lines, the row-at-a-time path) against the direct
    sum over every (point, cell) pair of weight * W(|q_cell - q|) * values, on uneven centres,
    with points near and beyond the grid's ends, a zero weight, and cells exactly at the
    cutoff (kept, r <= cutoff)."""
    rng = np.random.default_rng(k)
    width, cutoff = 0.5, 1.0
    # uneven centres on multiples of 1/8, so that point 0 lies exactly one cutoff from a cell
    axes = [np.cumsum(rng.integers(1, 5, n) * 0.125) for n in (11, 7, 5)[:k]]
    q = rng.uniform(-1.5, 5.5, (40, k))
    q[0] = [a[2] for a in axes]
    q[0, 0] -= cutoff
    weights = rng.uniform(0.5, 1.5, 40)
    weights[5] = 0.0
    values = rng.normal(size=(40, 4))
    flat = np.concatenate(axes)
    counts = np.array([a.size for a in axes], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    norm = Gaussian(width, cutoff=cutoff / width).norm(k)
    out = np.zeros((int(np.prod(counts)), 4))
    cg_deposit.deposit_gaussian_points(q, weights, values, flat, offsets, counts, width,
                                       cutoff, norm, out)
    cells = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, k)
    r2 = ((cells[:, None, :] - q[None, :, :]) ** 2).sum(axis=-1)
    w = np.where(r2 <= cutoff**2, norm * np.exp(-r2 / (2 * width**2)), 0.0)
    assert (r2[:, 0] == cutoff**2).any()  # the boundary case is present
    np.testing.assert_allclose(out, w @ (weights[:, None] * values), rtol=1e-12, atol=1e-14)


# --- branch-line fractions (seed 002 eq. C.29) -----------------------------------------------

def brute_fractions(coords, start, end, n=200_000):
    """Fraction of each segment in each cell by dense sampling of the line."""
    edges, offsets, counts = coords.packed()
    theta0 = float(coords.edges[1][0]) if isinstance(coords, Polar) else 0.0
    n_cells = int(np.prod(counts))
    out = np.zeros((start.shape[0], n_cells))
    s = (np.arange(n) + 0.5) / n
    for m in range(start.shape[0]):
        pts = start[m] + s[:, None] * (end[m] - start[m])
        cells = cg_deposit.cells_of(coords.system, pts, edges, offsets, counts,
                                    np.zeros(len(counts)), theta0)
        out[m] = np.bincount(cells[cells >= 0], minlength=n_cells) / n
    return out


def exact_fractions(coords, start, end):
    edges, offsets, counts = coords.packed()
    theta0 = float(coords.edges[1][0]) if isinstance(coords, Polar) else 0.0
    dim = start.shape[1]
    n_cells = int(np.prod(counts))
    out = np.zeros((start.shape[0], n_cells))
    for m in range(start.shape[0]):
        acc = np.zeros((n_cells, dim, dim))
        one = np.zeros((1, dim, dim))
        one[0, 0, 0] = 1.0
        cg_deposit.deposit_segments(coords.system, start[m:m + 1], end[m:m + 1], one, False,
                                    edges, offsets, counts, np.zeros(len(counts)), theta0, acc)
        out[m] = acc[:, 0, 0]
    return out


@pytest.mark.parametrize("coords", [
    Cartesian([np.linspace(0, 4, 5), np.linspace(0, 3, 4)]),
    Cartesian([np.linspace(0, 3, 4), [0, 0.5, 1.7, 3], np.linspace(0, 2, 3)]),
    Cylindrical(np.linspace(0, 2.5, 6), np.linspace(-1, 1, 5)),
    Polar(np.linspace(0.2, 2.5, 5), np.linspace(0, 2 * pi, 7)),
    Polar(np.linspace(0, 2, 5), np.linspace(-0.5, 1.5, 5)),
], ids=["cart2", "cart3", "cyl", "polar", "polar-sector"])
def test_branch_fraction_matches_a_brute_force_line_integral(coords):
    rng = np.random.default_rng(3)
    dim = 3 if isinstance(coords, Cylindrical) else coords.dim
    lo = np.array([e[0] for e in coords.edges]) if isinstance(coords, Cartesian) else -2.5
    hi = np.array([e[-1] for e in coords.edges]) if isinstance(coords, Cartesian) else 2.5
    start = rng.uniform(lo, hi, (40, dim))
    end = start + rng.normal(scale=0.8, size=(40, dim))
    exact = exact_fractions(coords, start, end)
    brute = brute_fractions(coords, start, end)
    # sampling error of the brute force: 1/n per crossing
    np.testing.assert_allclose(exact, brute, atol=5e-5)
    assert exact.max() > 0.2 and (exact > 0).sum(axis=1).max() >= 2  # the lines do cross cells


def test_branch_fraction_of_a_line_inside_one_cell_is_one_and_of_a_crossing_line_is_eq_c30():
    coords = Cartesian([[0, 10], [0, 1, 2]])
    start = np.array([[3.0, 0.2], [3.0, 0.25]])
    end = np.array([[3.5, 0.7], [3.0, 1.75]])
    frac = exact_fractions(coords, start, end)
    assert frac[0].tolist() == [1.0, 0.0]
    # eq. C.30: A = (z + dz - r_iz) / (r_jz - r_iz)
    assert frac[1] == pytest.approx([(1 - 0.25) / 1.5, (1.75 - 1) / 1.5], abs=1e-15)


def test_seed_c33_product_form_is_not_the_line_fraction():
    """The printed eq. C.33 multiplies per-axis fractions; for a diagonal line through two
    cells of a 2x2 grid that gives 1/4 to each of four cells, while the line lies in two."""
    coords = Cartesian([[0, 1, 2], [0, 1, 2]])
    frac = exact_fractions(coords, np.array([[0.0, 0.0]]), np.array([[2.0, 2.0]]))
    assert frac[0].tolist() == [0.5, 0.0, 0.0, 0.5]


# --- exact identities ------------------------------------------------------------------------

def virial(contacts):
    return (contacts.force[:, :, None] * contacts.branch[:, None, :]).sum(axis=0)


@pytest.mark.parametrize("dim", [2, 3])
def test_volume_integral_of_contact_stress_is_the_virial_sum(dim):
    rng = np.random.default_rng(11)
    pos = rng.uniform(1, 5, (150, dim))
    c = random_contacts(pos, rng, kinds=(PAIR, WALL, ANCHOR))
    fr = make_frame(pos, np.zeros_like(pos), contacts=c)
    grid = Cartesian.uniform([-1] * dim, [7] * dim, [9] * dim)
    f = coarse_grain([fr], grid, Heaviside())
    total = (f.contact_stress() * grid.cell_volumes()[..., None, None]).reshape(-1, dim, dim)
    np.testing.assert_allclose(total.sum(axis=0), virial(c), rtol=1e-12, atol=1e-12)
    for code, kind in ((PAIR, "pair"), (WALL, "wall"), (ANCHOR, "anchor")):
        part = (f.contact_stress(kind) * grid.cell_volumes()[..., None, None]).sum(
            axis=tuple(range(dim)))
        np.testing.assert_allclose(part, virial(c.of_kind(code)), rtol=1e-12, atol=1e-12)
    # the smooth kernels integrate to the same sum up to the grid's quadrature error
    fine = Cartesian.uniform([-2] * dim, [8] * dim, [50 if dim == 2 else 25] * dim)
    for kernel in (Gaussian(0.6), Lucy(1.5)):
        g = coarse_grain([fr], fine, kernel)
        total = (g.contact_stress() * fine.cell_volumes()[..., None, None]).reshape(
            -1, dim, dim).sum(axis=0)
        np.testing.assert_allclose(total, virial(c), rtol=0, atol=2e-3 * np.abs(virial(c)).max())


def test_radial_grids_integrate_to_the_virial_trace_and_zz():
    """Cylindrical r-z and polar cells: tr(sigma) and sigma_zz are invariant under the
    rotation to (r, theta, z), so their volume integrals are the virial's."""
    rng = np.random.default_rng(5)
    pos = rng.uniform(-2, 2, (200, 3))
    c = random_contacts(pos, rng)
    fr = make_frame(pos, np.zeros_like(pos), contacts=c)
    cyl = Cylindrical(np.linspace(0, 6, 7), np.linspace(-5, 5, 4))
    f = coarse_grain([fr], cyl)
    integral = (f.contact_stress() * cyl.cell_volumes()[..., None, None]).sum(axis=(0, 1))
    assert np.trace(integral) == pytest.approx(np.trace(virial(c)), rel=1e-12)
    assert integral[2, 2] == pytest.approx(virial(c)[2, 2], rel=1e-12)
    # a smooth kernel in (r, z), divided by 2 pi r and mirrored at the axis, integrates the
    # same up to the grid's quadrature error
    fine = Cylindrical(np.linspace(0, 6, 61), np.linspace(-5, 5, 101))
    g = coarse_grain([fr], fine, Gaussian(0.3))
    integral = (g.contact_stress() * fine.cell_volumes()[..., None, None]).sum(axis=(0, 1))
    assert np.trace(integral) == pytest.approx(np.trace(virial(c)), rel=1e-3)
    assert integral[2, 2] == pytest.approx(virial(c)[2, 2], rel=1e-3)
    pos2 = pos[:, :2]
    c2 = random_contacts(pos2, rng)
    fr2 = make_frame(pos2, np.zeros_like(pos2), contacts=c2)
    pol = Polar(np.linspace(0, 6, 7), np.linspace(0, 2 * pi, 9))
    g = coarse_grain([fr2], pol)
    integral = (g.contact_stress() * pol.cell_volumes()[..., None, None]).sum(axis=(0, 1))
    assert np.trace(integral) == pytest.approx(np.trace(virial(c2)), rel=1e-12)


@pytest.mark.parametrize("kernel", [Heaviside(), Gaussian(0.5), Lucy(1.0)])
def test_one_averaged_cell_holds_the_whole_virial(kernel):
    rng = np.random.default_rng(12)
    pos = rng.uniform(1, 5, (100, 2))
    c = random_contacts(pos, rng, kinds=(PAIR, WALL))
    fr = make_frame(pos, np.zeros_like(pos), contacts=c)
    grid = Cartesian([[-2, 8], [-2, 8]])
    f = coarse_grain([fr], grid, kernel)
    assert f.shape == ()
    np.testing.assert_allclose(f.contact_stress() * 100.0, virial(c), rtol=1e-12)
    assert f.number_density * 100.0 == pytest.approx(100)


def test_periodic_axis_keeps_lines_that_cross_the_boundary():
    box = Box(np.array([0.0, 0.0]), np.array([4.0, 4.0]), (True, False))
    pos = np.array([[0.1, 1.0], [3.9, 1.2]])
    branch = np.array([[0.2, -0.2]])  # minimum image: 0.1 - (3.9 - 4)
    c = Contacts(np.array([7]), np.array([8]), np.array([[1.0, 0.5]]), branch)
    fr = make_frame(pos, np.zeros_like(pos), contacts=c, box=box)
    grid = Cartesian([[0, 4], np.linspace(0, 4, 5)])
    f = coarse_grain([fr], grid)
    total = (f.contact_stress() * grid.cell_volumes()[..., None, None]).sum(axis=0)
    np.testing.assert_allclose(total, virial(c), rtol=1e-14)
    # smooth kernels: lines and grains near the faces get periodic images along x
    fine = Cartesian([np.linspace(0, 4, 81), np.linspace(-2, 6, 161)])
    for kernel in (Gaussian(0.3), Lucy(0.6)):
        g = coarse_grain([fr], fine, kernel)
        total = (g.contact_stress() * fine.cell_volumes()[..., None, None]).sum(axis=(0, 1))
        np.testing.assert_allclose(total, virial(c), rtol=1e-3)
        assert (g.number_density * fine.cell_volumes()).sum() == pytest.approx(2, rel=1e-3)
        # the field does not see the seam: the grain at x = 0.1 spreads across it
        assert g.number_density[-1].max() > 0.1 * g.number_density[0].max()


def reference_kernel(kernel, r2):
    """The kernels written out independently of the compiled ones (2D)."""
    r = np.sqrt(r2)
    if isinstance(kernel, Gaussian):
        w, c = kernel.width, kernel.cutoff
        peak = 1 / (2 * pi * w * w) / (1 - np.exp(-c * c / 2))
        return np.where(r <= c * w, peak * np.exp(-r2 / (2 * w * w)), 0.0)
    s_ = r / kernel.cutoff
    return np.where(s_ <= 1, 5 / (pi * kernel.cutoff**2) * (1 + 3 * s_) * (1 - s_)**3, 0.0)


@pytest.mark.parametrize("kernel, tolerance", [
    (Gaussian(0.4), 1.4e-4), (Gaussian(0.4, line_points=8), 6e-5), (Lucy(0.9), 1.1e-4),
    (Lucy(0.9, line_points=12), 1.3e-5)])
def test_smooth_line_integral_matches_a_brute_force_integral(kernel, tolerance):
    """sigma_c = F (x) b int_0^1 W(r - r_i + s b) ds by Gauss-Legendre against a 5000-point
    midpoint rule. The tolerances are 1.5 times the quadrature errors measured here (kernels.py
    docstring): 9.2e-5 and 3.6e-5 for the Gaussian with 4 and 8 points, 7.5e-5 and 8.3e-6 for
    Lucy with 8 and 12."""
    rng = np.random.default_rng(2)
    start = rng.uniform(0, 3, (5, 2))
    end = start + rng.normal(scale=0.8, size=(5, 2))
    grid = Cartesian.uniform([-1, -1], [4, 4], [25, 25])
    xs, ys = np.meshgrid(*grid.centres, indexing="ij")
    s = (np.arange(5000) + 0.5) / 5000
    c = Contacts(np.arange(5) + 7, np.arange(5) + 100, np.ones((5, 2)), end - start)
    f = coarse_grain([make_frame(end, np.zeros_like(end), contacts=c)], grid, kernel)
    brute = np.zeros(grid.shape)
    for m in range(5):
        line = start[m] + s[:, None] * (end[m] - start[m])
        r2 = (xs[..., None] - line[:, 0])**2 + (ys[..., None] - line[:, 1])**2
        brute += reference_kernel(kernel, r2).mean(axis=-1) * (end[m] - start[m])[0]
    got = f.contact_stress()[..., 0, 0]  # force x = 1 times branch x
    assert np.abs(got - brute).max() < tolerance * np.abs(brute).max()


# --- fields of known flows -------------------------------------------------------------------

def test_uniform_gas_density_temperature_and_zero_mean_velocity():
    rng = np.random.default_rng(7)
    temperature, mass, n_grains, side = 2.5, 3.0, 4000, 20.0
    box = Box(np.zeros(2), np.full(2, side), (True, True))
    frames = [make_frame(rng.uniform(0, side, (n_grains, 2)),
                         rng.normal(scale=np.sqrt(temperature / mass), size=(n_grains, 2)),
                         mass=mass, radius=0.05, box=box, time=float(t), contacts=None)
              for t in range(40)]
    grid = Cartesian.uniform([0, 0], [side, side], [4, 4])
    for kernel in (Heaviside(), Gaussian(1.5)):
        f = coarse_grain(frames, grid, kernel, blocks=4, contacts=False)
        n = n_grains / side**2
        # Poisson counting error per cell: sqrt(n V / frames) / V
        assert f.number_density == pytest.approx(np.full(grid.shape, n), rel=0.05)
        assert f.packing_fraction == pytest.approx(np.full(grid.shape, n * pi * 0.05**2),
                                                   rel=0.05)
        assert f.mass_density == pytest.approx(np.full(grid.shape, n * mass), rel=0.05)
        assert f.temperature == pytest.approx(np.full(grid.shape, temperature), rel=0.05)
        assert f.temperature_components == pytest.approx(
            np.full(grid.shape + (2,), temperature), rel=0.06)
        assert np.abs(f.velocity).max() < 0.05
        shear = f.kinetic_stress[..., 0, 1]
        assert np.abs(shear).max() < 0.05 * n * temperature
        assert np.allclose(f.contact_stress(), 0.0)
        err = f.errors("temperature")
        assert np.all((err > 0) & (err < 0.05 * temperature))


def per_bin(values, cells, n_cells):
    return np.bincount(cells, weights=values, minlength=n_cells)


def test_rigid_rotation_velocity_field_and_zero_temperature():
    rng = np.random.default_rng(8)
    omega = 0.7
    pos = rng.uniform(-5, 5, (60000, 2))
    pos = pos[np.hypot(*pos.T) < 5]
    vel = omega * np.column_stack([-pos[:, 1], pos[:, 0]])
    fr = make_frame(pos, vel, contacts=None)
    r_edges = np.linspace(0.5, 4.5, 9)
    polar = Polar(r_edges, np.linspace(0, 2 * pi, 13))
    f = coarse_grain([fr], polar, contacts=False)
    # (r, theta) components: v_r = 0 and T_r = 0 exactly; v_theta = omega <r> over the cell
    assert np.abs(f.velocity[..., 0]).max() < 1e-12
    assert np.abs(f.temperature_components[..., 0]).max() < 1e-12
    r = np.hypot(*pos.T)
    theta = np.mod(np.arctan2(pos[:, 1], pos[:, 0]), 2 * pi)
    inside = (r >= 0.5) & (r < 4.5)
    cells = (np.digitize(r[inside], r_edges) - 1) * 12 + (theta[inside] // (pi / 6)).astype(int)
    mean_r = per_bin(r[inside], cells, 96) / per_bin(np.ones(inside.sum()), cells, 96)
    np.testing.assert_allclose(f.velocity[..., 1].ravel(), omega * mean_r, rtol=1e-12)
    # Cartesian bins: V = omega x <r> of the cell, and T the velocity spread inside it
    cart = Cartesian.uniform([-2, -2], [2, 2], [8, 8])
    g = coarse_grain([fr], cart, contacts=False)
    xs, ys = np.meshgrid(*cart.centres, indexing="ij")
    inside = np.all(np.abs(pos) < 2, axis=1)
    ix, iy = (((pos[inside, a] + 2) // 0.5).astype(int) for a in range(2))
    cells = ix * 8 + iy
    count = per_bin(np.ones(inside.sum()), cells, 64)
    mean_x, mean_y = (per_bin(pos[inside, a], cells, 64) / count for a in range(2))
    np.testing.assert_allclose(g.velocity[..., 0].ravel(), -omega * mean_y, rtol=1e-12)
    np.testing.assert_allclose(g.velocity[..., 1].ravel(), omega * mean_x, rtol=1e-12)
    assert np.abs(g.velocity[..., 1] - omega * xs).max() < 0.05  # <x> ~ the centre
    spread = sum(per_bin(vel[inside, a]**2, cells, 64) / count
                 - (per_bin(vel[inside, a], cells, 64) / count)**2 for a in range(2))
    np.testing.assert_allclose(g.temperature.ravel(), spread / 2, rtol=1e-9)
    # ... which for uniform density is m omega^2 h^2 / 12 (h = 0.5); ~150 grains per cell
    # give a sampling scatter of about 12 % per cell, 1.5 % over the 64 cells
    assert g.temperature.mean() == pytest.approx(omega**2 * 0.5**2 / 12, rel=0.05)
    # smooth kernel: the field is the same rotation
    s = coarse_grain([fr], cart, Gaussian(0.3), contacts=False)
    np.testing.assert_allclose(s.velocity[..., 1], omega * xs, atol=0.02)


def test_strain_rate_of_linear_fields_is_exact():
    cart = Cartesian([np.linspace(0, 4, 9), [0, 1, 2.5, 3], [0, 1]])
    xs, ys = np.meshgrid(*cart.centres, indexing="ij")
    v = np.stack([0.3 * ys + 0.1 * xs, -0.2 * xs, np.zeros_like(xs)], axis=-1)
    d = strain_rate(v, cart)
    np.testing.assert_allclose(d[..., 0, 0], 0.1, atol=1e-12)
    np.testing.assert_allclose(d[..., 0, 1], 0.05, atol=1e-12)
    np.testing.assert_allclose(d[..., 1, 1], 0.0, atol=1e-12)
    assert np.all(d[..., 2, :] == 0) and np.all(d == np.swapaxes(d, -1, -2))
    # polar rigid rotation V_theta = omega r: no strain
    polar = Polar(np.linspace(0.5, 3, 6), np.linspace(0, 2 * pi, 5))
    rr = np.multiply.outer(polar.centres[0], np.ones(4))
    d = strain_rate(np.stack([np.zeros_like(rr), 0.7 * rr], axis=-1), polar)
    assert np.abs(d).max() < 1e-12
    # cylindrical radial expansion V_r = a r and axial shear V_z = b r
    cyl = Cylindrical(np.linspace(0.5, 3, 6), np.linspace(0, 2, 5))
    rr = np.multiply.outer(cyl.centres[0], np.ones(4))
    d = strain_rate(np.stack([0.4 * rr, np.zeros_like(rr), -0.6 * rr], axis=-1), cyl)
    np.testing.assert_allclose(d[..., 0, 0], 0.4, atol=1e-12)
    np.testing.assert_allclose(d[..., 1, 1], 0.4, atol=1e-12)
    np.testing.assert_allclose(d[..., 0, 2], -0.3, atol=1e-12)
    np.testing.assert_allclose(d[..., 2, 2], 0.0, atol=1e-12)


def test_slab_gradient_restores_the_shear_across_a_one_cell_layer():
    """A layer one cell thick (seed 002's meshes) averages its velocity over z, so the
    derivative across it is zero unless measured from its halves (Sec. 5.3.3). V_r = a z
    (and V_z = c r) inside the layer 0 < z < 1: the half layers' mean V_r differ by a/2 over
    half a layer, so D_rz = (a + c)/2 exactly for grains placed symmetrically in each half."""
    a, c = 0.8, -0.3
    r = np.repeat(np.linspace(0.55, 2.95, 9), 4)  # 9 radii, 4 grains at each
    z = np.tile([0.1, 0.4, 0.6, 0.9], 9)
    phi = np.linspace(0, 2 * pi, r.size, endpoint=False)
    pos = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    v_r, v_z = a * z, c * r
    vel = np.column_stack([v_r * np.cos(phi), v_r * np.sin(phi), v_z])
    layer = Cylindrical(np.linspace(0.4, 3.1, 10), [0.0, 1.0])
    frames = [make_frame(pos, vel, contacts=None)]
    velocity = coarse_grain(frames, layer, contacts=False).velocity
    # without the halves d v_r/dz is taken as zero: D_rz is dv_z/dr / 2 = c/2 alone
    np.testing.assert_allclose(strain_rate(velocity, layer)[..., 0, 2], 0.5 * c, rtol=1e-9)
    across = slab_gradient(frames, layer, 1)
    np.testing.assert_allclose(across[..., 0], a, rtol=1e-12)  # d v_r / dz
    np.testing.assert_allclose(across[..., 2], 0.0, atol=1e-12)
    d = strain_rate(velocity, layer, across={1: across})
    np.testing.assert_allclose(d[..., 0, 2], 0.5 * (a + c), rtol=1e-9)
    np.testing.assert_allclose(d[..., 2, 0], d[..., 0, 2])
    # a Cartesian slab (x resolved, y one bin): V_x = g y gives D_xy = g/2
    g = 0.5
    xy = np.column_stack([np.repeat(np.linspace(0.1, 3.9, 20), 4), np.tile(z, 20)[:80]])
    slab = Cartesian([np.linspace(0, 4, 5), [0.0, 1.0]])
    fr = [make_frame(xy, np.column_stack([g * xy[:, 1], np.zeros(80)]), contacts=None)]
    grad = slab_gradient(fr, slab, 1)
    d = strain_rate(coarse_grain(fr, slab, contacts=False).velocity, slab, across={1: grad})
    np.testing.assert_allclose(d[..., 0, 1], g / 2, rtol=1e-12)
    with pytest.raises(ValueError, match="coordinate"):
        slab_gradient(fr, slab, 0)  # x is resolved
    with pytest.raises(ValueError, match="across"):
        strain_rate(velocity, layer, across={0: across})


def test_cylindrical_components_of_a_swirling_jet():
    """v = (u_r e_r + u_th e_th + u_z e_z) at every grain: the cylindrical fields give back
    the three components, with the axis along x to exercise the rotation."""
    rng = np.random.default_rng(9)
    pos = rng.uniform(-3, 3, (30000, 3))
    axis = np.array([1.0, 0.0, 0.0])
    perp = pos - np.outer(pos @ axis, axis)
    rho = np.linalg.norm(perp, axis=1)
    e_r = perp / rho[:, None]
    e_t = np.cross(axis, e_r)
    vel = 0.3 * e_r + 0.8 * e_t + np.outer(np.full(len(pos), -1.2), axis)
    fr = make_frame(pos, vel, contacts=None)
    cyl = Cylindrical(np.linspace(0.2, 2.8, 6), np.linspace(-2, 2, 5), axis=axis)
    for kernel in (Heaviside(), Gaussian(0.3)):
        f = coarse_grain([fr], cyl, kernel, contacts=False)
        np.testing.assert_allclose(f.velocity[..., 0], 0.3, atol=1e-9 if not kernel.smooth
                                   else 1e-9)
        np.testing.assert_allclose(f.velocity[..., 1], 0.8, atol=1e-9)
        np.testing.assert_allclose(f.velocity[..., 2], -1.2, atol=1e-9)
        assert np.abs(f.temperature).max() < 1e-12
    # the smooth kernel with its mirror image at -r still integrates to the grain count
    fine = Cylindrical(np.linspace(0, 5, 101), np.linspace(-4, 4, 81))
    g = coarse_grain([fr], fine, Gaussian(0.3), contacts=False)
    count = (g.number_density * fine.smooth_divisor() * 0.05 * 0.1).sum()
    assert count == pytest.approx(len(pos), rel=1e-3)


def test_time_window_blocks_combine_and_save_load(tmp_path):
    rng = np.random.default_rng(4)
    box = Box(np.zeros(2), np.full(2, 5.0), (True, True))
    frames = []
    for t in range(12):
        pos = rng.uniform(0, 5, (300, 2))
        frames.append(make_frame(pos, rng.normal(size=(300, 2)) + [t, 0], box=box,
                                 time=float(t), contacts=random_contacts(pos, rng, reach=0.5)))
    grid = Cartesian([[0, 5], np.linspace(0, 5, 6)])
    f = coarse_grain(frames, grid, window=(2.0, 9.0), blocks=2)
    assert f.n_frames == 8 and f.time == (2.0, 9.0) and f.blocks == 2
    # the window's mean velocity is the mean of its frames' mean drift (2..9)
    assert np.nanmean(f.velocity[..., 0]) == pytest.approx(5.5, abs=0.2)
    # the drift between frames is a fluctuation about the window mean: T grows by its variance
    assert np.nanmean(f.temperature_components[..., 0]) > 5.0
    both = combine(f, coarse_grain(frames, grid, window=(10.0, 11.0)))
    assert both.n_frames == 10 and both.blocks == 3
    path = f.save(tmp_path / "fields.npz")
    g = load_fields(path)
    for name in ("stress", "velocity", "temperature", "strain_rate"):
        np.testing.assert_array_equal(g.field(name), f.field(name))
        np.testing.assert_array_equal(g.errors(name), f.errors(name))
    sums = frame_sums(frames[0], grid, Heaviside())
    assert set(sums) >= {"number", "mass", "volume", "momentum", "mvv", "contact_pair"}


# --- bad input ---------------------------------------------------------------------------------

def test_bad_input_names_the_field():
    pos = np.zeros((2, 2))
    fr = make_frame(pos, pos, contacts=None)
    grid = Cartesian.uniform([0, 0], [1, 1], [2, 2])
    with pytest.raises(ValueError, match="contact listing"):
        coarse_grain([fr], grid)
    with pytest.raises(ValueError, match="3D system"):
        coarse_grain([fr], Cylindrical([0, 1], [0, 1]), contacts=False)
    with pytest.raises(ValueError, match="blocks"):
        coarse_grain([fr], grid, blocks=2, contacts=False)
    with pytest.raises(ValueError, match="window"):
        coarse_grain([fr], grid, window=(1.0, 2.0), contacts=False)
    with pytest.raises(ValueError, match="edges\\[1\\]"):
        Cartesian([[0, 1], [1, 0]])
    with pytest.raises(ValueError, match="r_edges"):
        Polar([-1, 1])
    with pytest.raises(ValueError, match="theta_edges"):
        Polar([0, 1], [0, 7])
    with pytest.raises(ValueError, match="width"):
        Gaussian(0.0)
    with pytest.raises(ValueError, match="line_points"):
        Lucy(1.0, line_points=0)
    with pytest.raises(ValueError, match="axis"):
        Cylindrical([0, 1], [0, 1], axis=(0, 0, 0))
    with pytest.raises(ValueError, match="field"):
        coarse_grain([fr], grid, contacts=False).field("presure")
    bad = Contacts(np.array([99]), np.array([7]), np.ones((1, 2)), np.ones((1, 2)))
    with pytest.raises(ValueError, match="ids \\[99\\]"):
        coarse_grain([make_frame(pos, pos, contacts=bad)], grid)


def test_lammps_frames_coarse_grain_to_their_own_virial_pressure():
    """Frames read from a LAMMPS run (tests/data/lammps_cg: atom dump + dump local of the
    contacts) coarse-grain like grainflow's: over a grid spanning the periodic box the
    integrated stress is LAMMPS's virial sum plus the kinetic sum, exactly."""
    from pathlib import Path

    from grainflow.io.lammps_local import frames_from_lammps
    data = Path(__file__).parent / "data" / "lammps_cg"
    frames = frames_from_lammps(data / "atoms.dump", data / "contacts.dump")
    for frame in frames:  # the deck deforms its box: one grid per frame
        assert all(frame.box.periodic)
        grid = Cartesian.uniform(frame.box.lo, frame.box.hi, (3, 3, 2))
        f = coarse_grain([frame], grid)
        integral = (f.contact_stress() * grid.cell_volumes()[..., None, None]).sum(axis=(0, 1, 2))
        np.testing.assert_allclose(integral, virial(frame.contacts), rtol=1e-12,
                                   atol=1e-12 * np.abs(virial(frame.contacts)).max())
        assert np.isfinite(f.pressure).all() and (f.pressure > 0).all()  # compressed packing
    g = coarse_grain(frames, grid, Lucy(3 * float(frames[0].radius.max())), blocks=3)
    assert np.isfinite(g.stress).all() and np.isfinite(g.errors("pressure")).all()


def test_a_cell_crossed_only_by_a_branch_line_has_its_contact_stress():
    """No grain in the middle bin: its kinetic stress is zero, not NaN, so its stress is the
    contact stress of the line crossing it (velocity and temperature are NaN there)."""
    pos = np.array([[0.5, 0.5], [2.5, 0.5]])
    c = Contacts(np.array([8]), np.array([7]), np.array([[1.0, 0.0]]), np.array([[2.0, 0.0]]))
    f = coarse_grain([make_frame(pos, [[1.0, 0.0], [0.0, 1.0]], contacts=c)],
                     Cartesian([[0, 1, 2, 3], [0, 1]]))
    np.testing.assert_allclose(f.stress[1], [[1.0, 0], [0, 0]])  # F b A / V = 1 * 2 * 1/2
    np.testing.assert_array_equal(f.kinetic_stress[1], 0.0)
    assert np.isnan(f.velocity[1]).all() and np.isnan(f.temperature[1])
    np.testing.assert_allclose(f.contact_stress()[:, 0, 0], [0.5, 1.0, 0.5])


def test_contacts_select_keeps_the_chosen_rows_whole():
    c = Contacts(i=np.array([1, 2, 3]), j=np.array([4, 0, 5]),
                 force=np.arange(9.0).reshape(3, 3), branch=-np.arange(9.0).reshape(3, 3),
                 kind=np.array([PAIR, WALL, PAIR], dtype=np.int8))
    for rows in (np.array([True, False, True]), np.array([0, 2])):
        s = c.select(rows)
        np.testing.assert_array_equal(s.i, [1, 3])
        np.testing.assert_array_equal(s.j, [4, 5])
        np.testing.assert_array_equal(s.force, c.force[[0, 2]])
        np.testing.assert_array_equal(s.branch, c.branch[[0, 2]])
        np.testing.assert_array_equal(s.kind, [PAIR, PAIR])
    np.testing.assert_array_equal(c.of_kind(WALL).i, [2])
