"""SPEC validation: a grain launched sliding on a frictional wall decelerates at mu g while it
slips, then rolls without slip at v0 / (1 + I/(m r^2)): 5/7 v0 (sphere), 2/3 v0 (disk).

The friction force acts at the contact point, so the angular momentum about the contact
line, ``m v r + I omega``, is conserved; rolling sets in at ``t_s = v0 (1 - v_f/v0)/(mu g)``.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainflow.engine.forces import Gravity
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.models.granular import GranularLaw
from grainflow.state import ParticleState
from grainflow.walls import Plane, WallForce

G, MU, V0, R = 1.0, 0.5, 1.0, 0.5


#: one grain or a few gain nothing from threads (see conftest.numba_one_thread)
pytestmark = pytest.mark.usefixtures("numba_one_thread")


@pytest.mark.parametrize("dim, final_ratio", [(3, 5.0 / 7.0), (2, 2.0 / 3.0)])
def test_slip_then_roll(dim, final_ratio):
    kn = 1e5
    up = np.zeros(3)
    up[dim - 1] = 1.0
    st = ParticleState(dim, Box(np.full(dim, -10.0), np.full(dim, 10.0), (False,) * dim))
    st.add_particles(np.zeros((1, dim)), R, density=1.0)
    m = float(st.mass[0])
    st.x[0] = (R - m * G / kn) * up  # resting at the equilibrium overlap
    st.v[0, 0] = V0
    law = GranularLaw(2)
    law.set_all(kn=kn, gamma_n=50.0, mu=MU)
    sim = Simulation(st, 1e-4, law)
    sim.add_force(Gravity(-G * up[:dim]))
    sim.add_force(WallForce([Plane(np.zeros(3), up)], law, 1))
    times, speeds, slips = [], [], []

    def record(s: Simulation) -> None:
        times.append(s.time)
        speeds.append(st.v[0, 0])
        slips.append((st.v[0] + np.cross(st.omega[0], -R * up))[0])

    sim.add_observer(record, every=10)
    t_slip = V0 * (1.0 - final_ratio) / (MU * G)
    sim.run(int(1.6 * t_slip / sim.dt))
    t = np.array(times)
    v = np.array(speeds)
    window = (t > 0.1 * t_slip) & (t < 0.9 * t_slip)
    deceleration = -np.polyfit(t[window], v[window], 1)[0]
    assert deceleration == pytest.approx(MU * G, rel=1e-2)
    rolling = t > 1.3 * t_slip
    assert np.mean(v[rolling]) == pytest.approx(final_ratio * V0, rel=1e-2)
    assert np.max(np.abs(np.array(slips)[rolling])) < 1e-3 * V0
