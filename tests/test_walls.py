"""Analytic walls (SPEC M4): closest points, restitution, hoppers, orifice rims, moving walls."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainflow.engine.forces import Gravity
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
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
]


@pytest.mark.parametrize("wall, x, expected, ok", CASES)
def test_closest_point(wall, x, expected, ok):
    c, inside_ok = wall.closest_point(x)
    np.testing.assert_allclose(c, expected, atol=1e-12)
    assert inside_ok is ok


def test_closest_point_on_axis_of_hole_and_of_moving_wall():
    c, ok = PlateWithHole((0, 0, 0), (0, 0, 1), 1.0).closest_point((0, 0, 1))
    assert ok and abs(np.linalg.norm(c) - 1.0) < 1e-12 and c[2] == 0.0
    c, ok = Plane((0, 0, 0), (0, 0, 1), velocity=(0, 0, 2)).closest_point((1, 1, 3), time=0.5)
    np.testing.assert_allclose(c, (1, 1, 1))
    assert ok


@pytest.mark.parametrize("theta, rise", [(90.0, 0.0), (45.0, 4.0), (60.0, 4.0 / math.sqrt(3))])
def test_hopper2d_segments(theta, rise):
    hopper = Hopper2D(W=10.0, theta_w_deg=theta, orifice_w=2.0, y_bottom=1.0, height=20.0)
    left_bottom, right_bottom, left_side, right_side = hopper
    assert left_bottom.p0 == (-1.0, 1.0, 0.0) and right_bottom.p0 == (1.0, 1.0, 0.0)
    np.testing.assert_allclose(left_bottom.p1, (-5.0, 1.0 + rise, 0.0), atol=1e-12)
    np.testing.assert_allclose(right_side.p0, (5.0, 1.0 + rise, 0.0), atol=1e-12)
    assert left_side.p1 == (-5.0, 21.0, 0.0)
    # the bottom wall makes the angle theta_w with the side wall (the direction of gravity)
    e = np.subtract(left_bottom.p1, left_bottom.p0)
    angle = math.degrees(math.acos(e[1] / np.linalg.norm(e)))
    assert angle == pytest.approx(theta)


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
    pi, wi, f, branch = wall.contacts(sim)
    assert pi.tolist() == [0] and wi.tolist() == [0]
    np.testing.assert_allclose(f[0], expected, rtol=1e-12)
    np.testing.assert_allclose(branch[0], d, atol=1e-12)
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
