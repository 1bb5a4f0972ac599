"""Analytic walls (SPEC M4): closest points, restitution, hoppers, orifice rims, moving walls."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from grainflow.engine.forces import Gravity
from grainflow.engine.simulation import Simulation
from grainflow.frame import WALL, Box
from grainflow.models.granular import (
    GranularLaw,
    restitution_and_contact_time,
    stiffness_and_damping,
)
from grainflow.models.soft import SoftLaw
from grainflow.state import ParticleState
from grainflow.walls import (
    Cone,
    Cylinder,
    Hopper2D,
    Plane,
    PlateWithHole,
    Segment,
    WallForce,
)

S2 = math.sqrt(0.5)
#: a can of radius 1 from z = 0 to 4, closed at the bottom, grains inside
TUBE = Cylinder((0, 0, 0), (0, 0, 1), 1.0, axial_range=(0, 4), lid_lo=True)


#: one grain or a few gain nothing from threads (see conftest.numba_one_thread)
pytestmark = pytest.mark.usefixtures("numba_one_thread")


def make_state(dim: int, x, radius, v=None, **kw) -> ParticleState:
    box = Box(np.full(dim, -20.0), np.full(dim, 20.0), (False,) * dim)
    st = ParticleState(dim, box)
    st.add_particles(np.atleast_2d(x), radius, density=1.0, v=v, **kw)
    return st


CASES = [
    (Plane((0, 0, 1), (0, 0, 2)), (1, 2, 3), (1, 2, 1), True),
    (Plane((0, 0, 1), (0, 0, 2)), (1, 2, 0), (1, 2, 1), False),
    (Plane((0, 0), (1, 1)), (2, 0), (1, -1, 0), True),
    (Segment((0, 0), (2, 0)), (1, 1), (1, 0, 0), True),
    (Segment((0, 0), (2, 0)), (0.5, -0.3), (0.5, 0, 0), True),
    (Segment((0, 0), (2, 0)), (3, 1), (2, 0, 0), True),
    (Segment((0, 0), (2, 0)), (-1, -2), (0, 0, 0), True),
    (Cylinder((0, 0, 0), (0, 0, 1), 2.0), (1, 0, 5), (2, 0, 5), True),
    (Cylinder((0, 0, 0), (0, 0, 1), 2.0), (3, 0, 1), (2, 0, 1), False),
    (Cylinder((0, 0, 0), (0, 0, 1), 2.0, inside=False), (3, 0, 1), (2, 0, 1), True),
    (Cylinder((0, 0, 0), (1, 1, 0), 1.0), (1, 1, 0.5), (1, 1, 1), True),
    (Cylinder((0, 0), (0, 0, 1), 2.0), (0, -0.5), (0, -2, 0), True),
    (Cone((0, 0, 0), (0, 0, 1), 45, axial_range=(1, 3)), (0.5, 0, 2), (1.25, 0, 1.25), True),
    (Cone((0, 0, 0), (0, 0, 1), 45, axial_range=(1, 3)), (0, 0.3, 0.2), (0, 1, 1), True),
    (Cone((0, 0, 0), (0, 0, 1), 45, axial_range=(1, 3)), (3, 0, 2), (2.5, 0, 2.5), False),
    (Cone((0, 0, 0), (0, 0, 1), 45, inside=False, axial_range=(1, 3)), (3, 0, 2),
     (2.5, 0, 2.5), True),
    (Cone((0, 0, 0), (0, 0, 1), 45, axial_range=(1, 3)), (0, 4, 5), (0, 3, 3), True),
    (Cone((0, 0, 1), (0, 0, -1), 60, axial_range=(0, 2)), (1, 0, 0),
     ((3 + math.sqrt(3)) / 4, 0, (3 - math.sqrt(3)) / 4), True),
    (PlateWithHole((0, 0, 0), (0, 0, 1), 1.0), (2, 0, 0.3), (2, 0, 0), True),
    (PlateWithHole((0, 0, 0), (0, 0, 1), 1.0), (2, 0, -0.3), (2, 0, 0), False),
    (PlateWithHole((0, 0, 0), (0, 0, 1), 1.0), (0.6, 0, 0.2), (1, 0, 0), True),
    (PlateWithHole((0, 0, 0), (0, 0, 1), 1.0), (0, 0.5, -0.4), (0, 1, 0), True),
    # on the acting surface: in contact (the force then uses the normal)
    (Plane((0, 0, 1), (0, 0, 2)), (1, 2, 1), (1, 2, 1), True),
    (PlateWithHole((0, 0, 0), (0, 0, 1), 1.0), (2, 0, 0), (2, 0, 0), True),
    (Cylinder((0, 0, 0), (0, 0, 1), 2.0), (0, 0, 1), (0, 2, 1), True),  # on the axis
    (Cylinder((0, 0, 0), (0, 0, 1), 2.0, inside=False), (0, 0, 1), (0, 2, 1), False),
    # finite tubes: the open rim acts from every side, lids on the inside
    (TUBE, (0.5, 0, 5), (1, 0, 4), True),  # beyond the open end
    (TUBE, (1.5, 0, -0.5), (1, 0, 0), False),  # a closed end's rim, from outside
    (TUBE, (1.5, 0, 4.5), (1, 0, 4), True),  # the open end's rim
    (TUBE, (0.2, 0, 0.1), (0.2, 0, 0), True),  # above the lid
    (TUBE, (0.2, 0, 3.9), (1, 0, 3.9), True),
    (Cylinder((0, 0, 0), (0, 0, 1), 1.0, inside=False, axial_range=(0, 4), lid_hi=True),
     (0.2, 0.3, 4.5), (0.2, 0.3, 4), True),
    (Cone((0, 0, 0), (0, 0, 1), 45, axial_range=(1, 3), lid_lo=True), (0.2, 0, 0.7),
     (0.2, 0, 1), False),
    (Cone((0, 0, 0), (0, 0, 1), 45, axial_range=(1, 3), lid_lo=True), (0.2, 0, 1.3),
     (0.2, 0, 1), True),
    (Cone((0, 0, 0), (0, 0, 1), 45, axial_range=(1, 3), lid_hi=True), (1, 0, 3.5),
     (1, 0, 3), False),
]


@pytest.mark.parametrize("wall, x, expected, ok", CASES)
def test_closest_point(wall, x, expected, ok):
    c, inside_ok, n = wall.closest_point(x)
    np.testing.assert_allclose(c, expected, atol=1e-12)
    assert inside_ok is ok
    assert np.linalg.norm(n) == pytest.approx(1.0)


def test_closest_point_on_axis_of_hole_and_of_moving_wall():
    c, ok, n = PlateWithHole((0, 0, 0), (0, 0, 1), 1.0).closest_point((0, 0, 1))
    assert ok and abs(np.linalg.norm(c) - 1.0) < 1e-12 and c[2] == 0.0
    np.testing.assert_allclose(n, ((0, 0, 1) - c) / np.linalg.norm((0, 0, 1) - c))
    c, ok, n = Plane((0, 0, 0), (0, 0, 1), velocity=(0, 0, 2)).closest_point((1, 1, 3),
                                                                             time=0.5)
    np.testing.assert_allclose(c, (1, 1, 1))
    assert ok and tuple(n) == (0, 0, 1)


@pytest.mark.parametrize("theta, rise", [(90.0, 0.0), (45.0, 4.0), (60.0, 4.0 / math.sqrt(3))])
def test_hopper2d_segments(theta, rise):
    hopper = Hopper2D(W=10.0, theta_w_deg=theta, orifice_w=2.0, y_bottom=1.0, height=20.0)
    left_bottom, right_bottom, left_side, right_side = hopper
    assert left_bottom.p1 == (-1.0, 1.0, 0.0) and right_bottom.p0 == (1.0, 1.0, 0.0)
    np.testing.assert_allclose(left_bottom.p0, (-5.0, 1.0 + rise, 0.0), atol=1e-12)
    np.testing.assert_allclose(right_side.p0, (5.0, 1.0 + rise, 0.0), atol=1e-12)
    assert left_side.p0 == (-5.0, 21.0, 0.0)
    # the bottom wall makes the angle theta_w with the side wall (the direction of gravity)
    e = np.subtract(left_bottom.p0, left_bottom.p1)
    angle = math.degrees(math.acos(e[1] / np.linalg.norm(e)))
    assert angle == pytest.approx(theta)
    # every left normal points into the hopper, towards (0, 1 + height/2)
    for seg in hopper:
        middle = 0.5 * (np.add(seg.p0, seg.p1))
        assert np.dot(seg.left_normal, np.subtract((0.0, 11.0, 0.0), middle)) > 0


def test_hopper2d_moves_with_its_velocity():
    hopper = Hopper2D(W=4.0, theta_w_deg=60.0, orifice_w=1.0, height=5.0, velocity=(0.5, 0))
    assert all(seg.velocity == (0.5, 0.0, 0.0) for seg in hopper)
    assert all(seg.planar() for seg in hopper)


@pytest.mark.parametrize("kwargs, field", [
    (dict(W=4.0, theta_w_deg=45, orifice_w=5.0), "orifice_w"),
    (dict(W=4.0, theta_w_deg=0.0, orifice_w=1.0), "theta_w_deg"),
    (dict(W=4.0, theta_w_deg=30, orifice_w=1.0, height=1.0), "height"),
])
def test_hopper2d_rejects_bad_geometry(kwargs, field):
    with pytest.raises(ValueError, match=field):
        Hopper2D(**kwargs)


def test_normal_impact_restitution_uses_the_wall_type_parameters():
    """A sphere hits a Plane head-on: e = exp(-b t_c) of the particle-wall parameters."""
    st = make_state(3, [0, 0, 0.51], 0.5, v=[[0, 0, -1.0]])
    m = float(st.mass[0])
    law = GranularLaw(2)
    law.set_all(kn=1e4, gamma_n=0.0)
    kn, gn = stiffness_and_damping(0.8, 0.01, m)
    law.set_pair(0, 1, kn=kn, gamma_n=gn)
    e, tc = restitution_and_contact_time(kn, gn, m)
    sim = Simulation(st, tc / 100, law)
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))], law, wall_type=1))
    sim.run(400)
    assert st.x[0, 2] > 0.5
    assert st.v[0, 2] == pytest.approx(e, rel=5e-3)
    assert abs(st.v[0, 0]) < 1e-12 and abs(st.omega[0]).max() < 1e-12


def _hopper_run(orifice_w: float) -> ParticleState:
    st = make_state(2, [1.5, 4.0], 0.5)
    law = GranularLaw(2)
    law.set_all(kn=2e3, gamma_n=60.0, mu=0.5)
    sim = Simulation(st, 2e-3, law)
    sim.add_force(Gravity([0.0, -1.0]))
    sim.add_force(WallForce(Hopper2D(6.0, 45.0, orifice_w, y_bottom=0.0, height=8.0), law, 1))
    sim.run(3500)
    return st


def test_disk_falls_through_a_wide_orifice():
    st = _hopper_run(1.4)
    assert st.x[0, 1] < -2.0


def test_disk_is_held_by_a_narrow_orifice():
    st = _hopper_run(0.8)
    # at rest on both orifice edges: centre sqrt(r^2 - (w/2)^2) above the orifice
    assert st.x[0, 0] == pytest.approx(0.0, abs=1e-3)
    assert st.x[0, 1] == pytest.approx(0.3, abs=2e-3)
    assert np.linalg.norm(st.v[0]) < 1e-3


def test_force_on_an_orifice_rim_and_contact_report():
    """A sphere over the orifice pressed against its rim: F = k delta along x - rim point."""
    st = make_state(3, [0.8, 0.0, 0.3], 0.5)
    law = SoftLaw(2)
    law.set_all(epsilon=1.0)
    law.set_pair(0, 1, epsilon=2.0)
    sim = Simulation(st, 1e-3, law)
    wall = sim.add_force(WallForce([PlateWithHole((0, 0, 0), (0, 0, 1), 1.0)], law, 1))
    sim.compute_forces(update=False)
    d = np.array([-0.2, 0.0, 0.3])
    r = np.linalg.norm(d)
    # soft wall law (seed 003 eq. 4 with sigma = r_m): |F| = eps/r_m (1 - |d|/r_m)
    expected = 2.0 / 0.5 * (1 - r / 0.5) * d / r
    np.testing.assert_allclose(st.force[0], expected, rtol=1e-12)
    (rows,) = wall.contacts(sim.context)
    assert rows.i.tolist() == [0] and rows.j.tolist() == [0] and rows.kind == WALL
    np.testing.assert_allclose(rows.force[0], expected, rtol=1e-12)
    np.testing.assert_allclose(rows.branch[0], d, atol=1e-12)
    saved = sim.contacts()  # the same contact among the simulation's, by id and wall index
    assert saved.of_kind(WALL).i.tolist() == [int(st.id[0])]
    np.testing.assert_allclose(saved.of_kind(WALL).branch[0], d, atol=1e-12)
    assert sim.max_overlap() == pytest.approx(0.5 - r)


def test_grain_grazing_an_orifice_rim_is_deflected_through():
    st = make_state(3, [0.6, 0.0, 1.0], 0.5, v=[[0.0, 0.0, -1.0]])
    law = GranularLaw(2)
    law.set_all(kn=1e4, gamma_n=10.0, mu=0.3)
    sim = Simulation(st, 2e-4, law)
    sim.add_force(Gravity([0, 0, -1.0]))
    sim.add_force(WallForce([PlateWithHole((0, 0, 0), (0, 0, 1), 1.0)], law, 1))
    sim.run(12000)
    assert st.x[0, 2] < -0.5
    assert st.v[0, 0] < -0.05


def test_moving_piston_launches_a_grain():
    """An infinite-mass wall moving at u hits a grain at rest: v = (1 + e) u."""
    st = make_state(3, [0, 0, 0.52], 0.5)
    m = float(st.mass[0])
    law = GranularLaw(2)
    kn, gn = stiffness_and_damping(0.7, 0.01, m)
    law.set_all(kn=kn, gamma_n=gn)
    sim = Simulation(st, 1e-4, law)
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1), velocity=(0, 0, 0.5))], law, 1))
    sim.run(700)
    e = restitution_and_contact_time(kn, gn, m)[0]
    assert st.v[0, 2] == pytest.approx((1 + e) * 0.5, rel=5e-3)


def test_moving_belt_drags_a_sphere_to_two_sevenths_of_its_speed():
    """Friction of a belt moving at u under a sphere at rest conserves the sphere's angular
    momentum about the contact line: it ends rolling at v = 2/7 u."""
    g = 1.0
    st = make_state(3, [0, 0, 0.5], 0.5)
    m = float(st.mass[0])
    law = GranularLaw(2)
    law.set_all(kn=1e4, gamma_n=40.0, mu=0.5)
    st.x[0, 2] = 0.5 - m * g / 1e4
    sim = Simulation(st, 2e-4, law)
    sim.add_force(Gravity([0, 0, -g]))
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1), velocity=(1.0, 0, 0))], law, 1))
    sim.run(5000)
    assert st.v[0, 0] == pytest.approx(2.0 / 7.0, rel=1e-2)
    assert st.omega[0, 1] * 0.5 == pytest.approx(st.v[0, 0] - 1.0, rel=1e-2)


def test_walls_must_fit_the_dimension_and_the_law():
    st = make_state(2, [0, 1], 0.5)
    law = GranularLaw(1)
    law.set_all(kn=1e3)
    sim = Simulation(st, 1e-3, law)
    with pytest.raises(ValueError, match="z = 0 plane"):
        sim.add_force(WallForce([Cone((0, 0, 0), (0, 0, 1), 30)], law, 0))
    sim.forces.clear()
    with pytest.raises(ValueError, match="set_pair"):
        sim.add_force(WallForce([Segment((0, 0), (1, 0))], law, 3))


# ------------------------------------------------------------ geometry against brute force
def _frame(axis):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    return a, e1, np.cross(a, e1)


def _revolution(origin, axis, s, rho):
    """Points ``origin + s a + rho (cos phi e1 + sin phi e2)`` on a grid of phi."""
    a, e1, e2 = _frame(axis)
    phi = np.linspace(0.0, 2 * np.pi, 721)[:, None]
    s, rho = np.broadcast_arrays(np.atleast_1d(s).astype(float), np.atleast_1d(rho).astype(float))
    pts = (np.asarray(origin)[None, None, :] + s[None, :, None] * a
           + rho[None, :, None] * (np.cos(phi)[..., None] * e1 + np.sin(phi)[..., None] * e2))
    return pts.reshape(-1, 3)


def surface_samples(wall) -> np.ndarray:
    """Dense points of the wall's surface near the test points (|x| < 3)."""
    if isinstance(wall, Segment):
        t = np.linspace(0.0, 1.0, 4001)[:, None]
        return np.asarray(wall.p0) + t * np.subtract(wall.p1, wall.p0)
    if isinstance(wall, (Plane, PlateWithHole)):
        a, e1, e2 = _frame(wall.normal)
        u = np.linspace(-6.0, 6.0, 1201)
        uu, vv = np.meshgrid(u, u)
        keep = np.hypot(uu, vv) >= getattr(wall, "hole_radius", 0.0)
        pts = np.asarray(wall.point) + uu[keep, None] * e1 + vv[keep, None] * e2
        if isinstance(wall, PlateWithHole):  # the rim itself, densely
            pts = np.vstack([pts, _revolution(wall.point, wall.normal, 0.0, wall.hole_radius)])
        return pts
    if isinstance(wall, Cylinder):
        lo, hi = (max(v, -5.0) if v < 0 else min(v, 5.0) for v in wall.axial_range)
        s = np.linspace(lo, hi, int((hi - lo) / 0.01) + 1)
        parts = [_revolution(wall.axis_point, wall.axis_direction, s, wall.radius)]
        radius = wall.radius
        origin, axis = wall.axis_point, wall.axis_direction
        ends = [(flag, v) for flag, v in zip((wall.lid_lo, wall.lid_hi), wall.axial_range)]
        radii = (radius, radius)
    else:
        tan = math.tan(math.radians(wall.half_angle_deg))
        lo, hi = wall.axial_range
        hi = min(hi, 7.0)
        s = np.linspace(lo, hi, int((hi - lo) / 0.01) + 1)
        parts = [_revolution(wall.apex, wall.axis, s, s * tan)]
        origin, axis = wall.apex, wall.axis
        ends = [(wall.lid_lo, lo), (wall.lid_hi, hi)]
        radii = (lo * tan, hi * tan)
    for (flag, s_end), r_end in zip(ends, radii):
        if flag:
            rho = np.linspace(0.0, r_end, max(2, int(r_end / 0.01) + 1))
            parts.append(_revolution(origin, axis, s_end, rho))
    return np.vstack(parts)


BRUTE_WALLS = [
    Plane((0.2, -0.1, 0.3), (1, 2, 2)),
    Segment((-1, -0.5), (1.5, 1.0)),
    Segment((-1, -0.5, 0.5), (1.5, 1.0, -0.5)),
    Cylinder((0.1, 0.2, 0), (0, 0, 1), 1.2),
    Cylinder((0, 0, -1), (1, 1, 2), 1.0, inside=False, axial_range=(0.5, 3.0)),
    Cylinder((0, 0, -1), (0, 1, 1), 1.5, axial_range=(0.0, 2.5), lid_lo=True, lid_hi=True),
    Cylinder((0, 0, -1), (0, 0, 1), 1.0, inside=False, axial_range=(0.0, 2.0), lid_hi=True),
    Cone((0, 0, -2), (0, 0, 1), 30, axial_range=(1.0, 4.0)),
    Cone((0, 0, -2), (0, 0, 1), 30),
    Cone((0.3, 0, 2), (0.2, 0, -1), 50, inside=False, axial_range=(0.5, 3.0), lid_lo=True),
    Cone((0, 0, -2), (0, 0, 1), 35, axial_range=(1.0, 3.5), lid_lo=True, lid_hi=True),
    Cone.from_lammps("y", 0.2, -0.1, 2.0, 0.5, -1.5, 1.5, lid_lo=True),
    PlateWithHole((0, 0, 0.2), (0.3, 0, 1), 0.8),
]


@pytest.fixture(scope="module")
def random_points() -> np.ndarray:
    rng = np.random.default_rng(7)
    return rng.uniform(-3.0, 3.0, size=(150, 3))


@pytest.mark.parametrize("wall", BRUTE_WALLS, ids=lambda w: type(w).__name__)
def test_closest_point_against_brute_force(wall, random_points):
    """c lies on the surface and no sampled surface point is closer to x than c."""
    from scipy.spatial import cKDTree

    tree = cKDTree(surface_samples(wall))
    c = np.array([wall.closest_point(x).point for x in random_points])
    nearest, _ = tree.query(random_points)
    assert np.all(np.linalg.norm(random_points - c, axis=1) <= nearest + 1e-9)
    on_surface, _ = tree.query(c)
    assert on_surface.max() < 0.02  # the sampling's resolution


def _inside_closed(wall, x) -> bool:
    """x inside the solid bounded by a wall with both lids."""
    if isinstance(wall, Cylinder):
        a, origin, lo, hi = np.asarray(wall.axis_direction), wall.axis_point, *wall.axial_range
        radius = lambda s: wall.radius  # noqa: E731
    else:
        a, origin, lo, hi = np.asarray(wall.axis), wall.apex, *wall.axial_range
        radius = lambda s: s * math.tan(math.radians(wall.half_angle_deg))  # noqa: E731
    r = np.subtract(x, origin)
    s = r @ a
    return lo < s < hi and np.linalg.norm(r - s * a) < radius(s)


@pytest.mark.parametrize("wall", BRUTE_WALLS, ids=lambda w: type(w).__name__)
def test_normal_is_unit_and_points_to_the_acting_side(wall, random_points):
    closed = getattr(wall, "lid_lo", False) and getattr(wall, "lid_hi", False)
    for x in random_points:
        if isinstance(wall, Segment) and wall.planar():
            x = x * (1, 1, 0)  # 2D
        c, ok, n = wall.closest_point(x)
        d = x - c
        assert np.linalg.norm(n) == pytest.approx(1.0, abs=1e-12)
        if isinstance(wall, Segment):  # n = +-l, towards x; along d inside a 2D segment
            assert abs(n @ wall.left_normal) == pytest.approx(1.0) and n @ d >= 0
            interior = 0 < (c - wall.p0) @ np.subtract(wall.p1, wall.p0) < np.sum(
                np.subtract(wall.p1, wall.p0) ** 2)
            if wall.planar() and interior:
                np.testing.assert_allclose(n, d / np.linalg.norm(d), atol=1e-9)
        else:
            # n is the wall's normal at c: along x - c, to the acting side; only the rim of a
            # closed end, seen from outside, has a normal cone (n: the corner's bisector)
            along = d / np.linalg.norm(d)
            if ok:
                np.testing.assert_allclose(n, along, atol=1e-9)
            else:
                assert n @ along < 0
                if n @ along > -1 + 1e-9:  # a corner: the closest point is on an end circle
                    assert closed or getattr(wall, "lid_lo", False) or wall.lid_hi
        # a point just off c along n is on the acting side
        assert wall.closest_point(c + 1e-6 * n).ok
        if closed:  # a closed body acts on its inside (or outside) only
            assert ok == (_inside_closed(wall, x) == wall.inside)


@pytest.mark.parametrize("wall, x, n", [
    (Plane((0, 0, 1), (0, 0, 2)), (0.3, 0.4, 1), (0, 0, 1)),
    (Segment((0, 0), (2, 0)), (0.5, 0), (0, 1, 0)),  # the left normal
    (Segment((2, 0), (0, 0)), (0.5, 0), (0, -1, 0)),
    (Segment((0, 0), (2, 0)), (0, 0), (0, 1, 0)),  # on an end
    (Cylinder((0, 0, 0), (0, 0, 1), 2.0), (2, 0, 5), (-1, 0, 0)),
    (Cylinder((0, 0, 0), (0, 0, 1), 2.0, inside=False), (0, -2, 5), (0, -1, 0)),
    (TUBE, (0.3, 0.2, 0), (0, 0, 1)),
    (Cylinder((0, 0, 0), (0, 0, 1), 1.0, inside=False, axial_range=(0, 4), lid_hi=True),
     (0.3, 0.2, 4), (0, 0, 1)),
    (Cone((0, 0, 0), (0, 0, 1), 45, axial_range=(1, 3), lid_hi=True), (0.5, 0, 3), (0, 0, -1)),
    (PlateWithHole((0, 0, 0), (0, 0, 1), 1.0), (1.5, 0, 0), (0, 0, 1)),
])
def test_a_centre_on_the_wall_is_in_contact_along_the_normal(wall, x, n):
    c, ok, normal = wall.closest_point(x)
    np.testing.assert_allclose(c, wall.closest_point(x).point)
    assert ok and np.all(c == np.asarray(x + (0,) * (3 - len(x)), float))
    np.testing.assert_allclose(normal, n, atol=1e-15)


def test_lids_need_finite_ends_and_ranges_are_checked():
    with pytest.raises(ValueError, match="lid_hi"):
        Cylinder((0, 0, 0), (0, 0, 1), 1.0, axial_range=(0, math.inf), lid_hi=True)
    with pytest.raises(ValueError, match="lid_hi"):
        Cone((0, 0, 0), (0, 0, 1), 30, lid_hi=True)
    with pytest.raises(ValueError, match="axial_range"):
        Cylinder((0, 0, 0), (0, 0, 1), 1.0, axial_range=(2, 1))
    with pytest.raises(ValueError, match="axial_range"):
        Cone((0, 0, 0), (0, 0, 1), 30, axial_range=(-1, 1))


def test_finite_cylinder_is_a_2d_wall_only_across_the_plane():
    assert Cylinder((0, 0), (0, 0, 1), 1.0).planar()
    assert Cylinder((0, 0, -1), (0, 0, 1), 1.0, axial_range=(0, 2)).planar()
    assert not Cylinder((0, 0, 1), (0, 0, 1), 1.0, axial_range=(0, 2)).planar()
    assert not Cylinder((0, 0, -1), (0, 0, 1), 1.0, axial_range=(0, 2), lid_lo=True).planar()


@pytest.mark.parametrize("radlo, radhi", [(0.5, 2.0), (2.0, 0.5), (0.0, 1.5), (1.5, 0.0)])
def test_cone_from_lammps_matches_the_region(radlo, radhi):
    """The surface passes through the end circles at lo and hi; lids follow lo and hi."""
    cone = Cone.from_lammps("x", 1.0, -2.0, radlo, radhi, -1.0, 3.0, lid_lo=radlo > 0,
                            lid_hi=radhi > 0)
    assert isinstance(cone, Cone)
    for coord, rad in ((-1.0, radlo), (3.0, radhi)):
        for phi in np.linspace(0, 2 * np.pi, 7):
            x = (coord, 1.0 + rad * math.cos(phi), -2.0 + rad * math.sin(phi))
            np.testing.assert_allclose(cone.closest_point(x).point, x, atol=1e-12)
        if rad > 0:  # closed ends: a point just outside the lid, on the axis, is not held
            outside = (coord - 0.1 if coord < 0 else coord + 0.1, 1.0, -2.0)
            c, ok, _ = cone.closest_point(outside)
            np.testing.assert_allclose(c, (coord, 1.0, -2.0), atol=1e-12)
            assert not ok
    # halfway the radius is the mean, the inside is held
    middle = (1.0, 1.0, -2.0 + 0.5 * (radlo + radhi))
    np.testing.assert_allclose(cone.closest_point(middle).point, middle, atol=1e-12)
    assert cone.closest_point((1.0, 1.0, -2.0 + 0.01)).ok


def test_cone_from_lammps_with_equal_radii_is_a_cylinder_and_bad_input_is_refused():
    wall = Cone.from_lammps("z", 1.0, 2.0, 0.5, 0.5, 0.0, 3.0, lid_hi=True)
    assert wall == Cylinder((1, 2, 0), (0, 0, 1), 0.5, axial_range=(0, 3), lid_hi=True)
    with pytest.raises(ValueError, match="dim"):
        Cone.from_lammps("r", 0, 0, 1, 2, 0, 1)
    with pytest.raises(ValueError, match="hi"):
        Cone.from_lammps("z", 0, 0, 1, 2, 1, 1)
    with pytest.raises(ValueError, match="radlo"):
        Cone.from_lammps("z", 0, 0, 0, 0, 0, 1)


# --------------------------------------------------------------------- walls from a config
def _wall_config(dim: int, *walls: dict) -> dict:
    return {"dim": dim, "run": {"steps": 5},
            "box": {"lo": [-10.0] * dim, "hi": [10.0] * dim},
            "particles": [{"fill": "list", "positions": [[0.0, 2.0, 3.0][:dim]], "radius": 0.5}],
            "contact": {"law": "granular", "restitution": 0.8, "contact_time": 0.05},
            "walls": list(walls)}


def test_hopper2d_wall_from_a_config_builds_and_moves():
    from grainflow.config.build import build_simulation
    from grainflow.config.schema import load_config

    config = load_config(_wall_config(2, {"shape": "hopper2d", "W": 6.0, "theta_w_deg": 60.0,
                                          "orifice_w": 1.0, "height": 8.0, "type": 1,
                                          "velocity": [0.0, 0.1]}))
    sim = build_simulation(config)
    walls = sim.walls
    assert len(walls) == 4 and all(isinstance(w, Segment) for w in walls)
    assert all(w.velocity == (0.0, 0.1, 0.0) for w in walls)
    assert walls == tuple(Hopper2D(6.0, 60.0, 1.0, height=8.0, velocity=(0, 0.1)).segments())
    sim.run(5)


def test_cone_and_cylinder_walls_from_a_config():
    from grainflow.config.build import build_simulation, wall_shapes
    from grainflow.config.schema import load_config

    lammps = {"shape": "cone", "axis": "z", "center": [0, 0], "radius_lo": 0.5,
              "radius_hi": 4.0, "lo": 0.0, "hi": 5.0, "lid_lo": True}
    can = {"shape": "cylinder", "axis_point": [0, 0, -1], "radius": 5.0,
           "axial_range": ["0 m", "8 m"], "lid_lo": True, "type": 1}
    config = load_config(_wall_config(3, lammps, can))
    cone, cylinder = (wall_shapes(w)[0] for w in config.walls)
    assert cone == Cone.from_lammps("z", 0, 0, 0.5, 4.0, 0, 5, lid_lo=True)
    assert cylinder == Cylinder((0, 0, -1), (0, 0, 1), 5.0, axial_range=(0, 8), lid_lo=True)
    build_simulation(config).run(5)


@pytest.mark.parametrize("wall, message", [
    ({"shape": "cone", "apex": [0, 0, 0], "axis": "z", "center": [0, 0], "radius_lo": 1,
      "radius_hi": 2, "lo": 0, "hi": 1}, "apex and center, radius_lo, radius_hi, lo, hi mix"),
    ({"shape": "cone", "axis": [0, 0, 1], "radius_lo": 1, "radius_hi": 2, "lo": 0, "hi": 1,
      "center": [0, 0]}, "axis: [0.0, 0.0, 1.0] is not valid with center"),
    ({"shape": "cone", "axis": "z", "center": [0, 0], "radius_lo": 1, "lo": 0, "hi": 1},
     "radius_hi: missing"),
    ({"shape": "cone", "apex": [0, 0, 0], "axis": [0, 0, 1], "half_angle_deg": 30,
      "lid_hi": True}, "walls[0].lid_hi: a lid needs a finite end"),
    ({"shape": "cylinder", "axis_point": [0, 0, 0], "radius": 1, "lid_lo": True},
     "walls[0].lid_lo: a lid needs a finite end"),
    ({"shape": "cylinder", "axis_point": [0, 0, 0], "radius": 1, "axial_range": [2, 1]},
     "walls[0].axial_range: [2.0, 1.0] is not valid"),
])
def test_bad_cone_and_cylinder_walls_are_refused_by_name(wall, message):
    from grainflow.config.schema import ConfigError, load_config

    with pytest.raises(ConfigError, match=re.escape(message)):
        load_config(_wall_config(3, wall))


@pytest.mark.usefixtures("numba_one_thread")
@pytest.mark.parametrize("dim", [2, 3])
def test_visiting_only_particles_near_walls_changes_nothing(dim: int, monkeypatch) -> None:
    """The stepping loop visits the particles within reach + skin of a wall (or holding a
    wall history); a hopper discharge with reinsertion ends bitwise as when it visits all."""
    from grainflow.scenarios.hopper import HopperSection, build_hopper, hopper_updater, prepare
    from grainflow.walls.force import WallForce

    def discharge() -> Simulation:
        shape = dict(n=300, orifice_width=5.0) if dim == 2 else dict(n=200, width=8.0,
                                                                       orifice_width=3.0)
        section = HopperSection(**shape, E_sp=1000.0, E_w=1000.0, lam=math.inf)
        sim = build_hopper(section, dim, seed=1)
        prepare(sim)
        sim.run(15000)
        assert len(hopper_updater(sim).event_times) > 0  # grains were reinserted (relocated)
        return sim

    near = discharge()
    visited = [len(f._visit) for f in near.forces if isinstance(f, WallForce)]
    assert 0 < sum(visited) < near.state.n * len(visited)  # the list does leave grains out
    monkeypatch.setattr(WallForce, "_near",
                        lambda self, ctx: np.arange(ctx.state.n, dtype=np.int64))
    every = discharge()
    assert near.step == every.step
    for name in every.state.arrays:
        assert np.array_equal(near.state.arrays[name], every.state.arrays[name]), name


def _record_over_every_particle(wall: WallForce, sim: Simulation) -> np.ndarray:
    """Slots (``i * n_walls + w``) of every particle-wall force now, visiting every particle."""
    st = sim.state
    out = np.zeros((st.n * wall.n_walls, 6))
    wall._run(sim.context, sim.time, False, np.zeros((st.n, 3)), np.zeros((st.n, 3)), out,
              np.arange(st.n, dtype=np.int64))
    return out


def test_the_contact_record_visits_what_touches_a_wall_and_misses_nothing():
    """contacts() visits only the grains within reach + skin of a wall (or holding a wall
    history), yet lists every force the walls exert: the same rows as a record over every
    grain, for a frictional pile in a can (wall histories) and a soft pile over an orifice."""
    rng = np.random.default_rng(3)
    xs = [(x, y, z) for z in np.arange(0.3, 3.6, 0.32) for x in np.arange(-0.6, 0.7, 0.32)
          for y in np.arange(-0.6, 0.7, 0.32) if x * x + y * y < 0.7**2]
    st = make_state(3, np.asarray(xs) + rng.uniform(-0.01, 0.01, (len(xs), 3)), 0.14)
    law = GranularLaw(2)
    law.set_all(kn=2e3, gamma_n=20.0, kt=1e3, mu=0.5)
    can = Simulation(st, 2e-4, law)
    can.add_force(Gravity([0.3, 0.0, -1.0]))
    plate = Simulation(make_state(3, np.asarray(xs) + rng.uniform(-0.01, 0.01, (len(xs), 3)),
                                  0.14), 2e-4, law)
    plate.add_force(Gravity([0.0, 0.0, -1.0]))
    for sim, walls in ((can, [TUBE]), (plate, [PlateWithHole((0, 0, 0), (0, 0, 1), 0.3),
                                              Cylinder((0, 0, 0), (0, 0, 1), 1.0)])):
        wall = sim.add_force(WallForce(walls, law, 1))
        sim.run(20000)
        (rows,) = wall.contacts(sim.context)
        out = _record_over_every_particle(wall, sim)
        slots = np.nonzero(np.any(out[:, :3] != 0.0, axis=1))[0]
        assert len(slots) >= 10
        assert rows.i.tolist() == (slots // wall.n_walls).tolist()
        assert rows.j.tolist() == (slots % wall.n_walls).tolist()
        assert np.array_equal(rows.force, out[slots, :3])
        assert np.array_equal(rows.branch, out[slots, 3:])
        assert wall._touching(sim.context, sim.time).size < sim.state.n  # not every grain
