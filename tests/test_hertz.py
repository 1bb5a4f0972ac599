"""The Hertz normal model, added through the sub-model registry (one file + one row), against
Hertz's analytic elastic collision: maximum overlap, contact time, restitution 1."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from conftest import two_grains
from grainflow.models.base import ContactLaw

pytestmark = pytest.mark.usefixtures("numba_one_thread")


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("radii", [(0.5, 0.5), (0.5, 0.3)])
def test_hertz_collision_matches_the_analytic_solution(dim, radii) -> None:
    law = ContactLaw(normal="hertz")
    kn, v = 1.0e5, 0.8
    law.set_all(kn=kn)
    sim = two_grains(dim, law, dt=2e-6, v_rel=v, gap=0.01, radii=radii)
    st = sim.state
    m0, m1 = st.mass
    meff = m0 * m1 / (m0 + m1)
    reff = radii[0] * radii[1] / sum(radii)
    delta_max = (5.0 * meff * v**2 / (4.0 * kn * np.sqrt(reff))) ** 0.4
    shape = quad(lambda x: 1.0 / np.sqrt(1.0 - x**2.5), 0.0, 1.0)[0]
    tc = 2.0 * shape * delta_max / v
    assert shape == pytest.approx(1.4716, abs=1e-4)

    overlaps, touching = [], []
    sim.add_observer(lambda ctx: overlaps.append(
        sum(radii) - np.linalg.norm(ctx.state.x[0] - ctx.state.x[1])))
    sim.run(int(1.5 * tc / sim.dt) + int(0.01 / v / sim.dt))
    overlaps = np.array(overlaps)
    touching = overlaps > 0
    assert overlaps.max() == pytest.approx(delta_max, rel=1e-4)
    assert touching.sum() * sim.dt == pytest.approx(tc, rel=2e-3)
    v_out = np.linalg.norm(st.v[0] - st.v[1])
    assert v_out == pytest.approx(v, rel=1e-8)  # elastic: e = 1


def test_hertz_force_against_a_wall_uses_the_particle_radius() -> None:
    from grainflow.frame import Box
    from grainflow.state import ParticleState
    from grainflow.engine.simulation import Simulation
    from grainflow.walls import Plane, WallForce

    st = ParticleState(3, Box(np.full(3, -5.0), np.full(3, 5.0), (False,) * 3))
    st.add_particles([[0.0, 0.0, 0.49]], 0.5, density=1.0)
    law = ContactLaw(2, normal="hertz")
    law.set_all(kn=1e6)
    sim = Simulation(st, 1e-6, law)
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))], law, 1))
    sim.compute_forces(update=False)
    assert st.force[0, 2] == pytest.approx(1e6 * np.sqrt(0.5 * 0.01) * 0.01, rel=1e-12)
