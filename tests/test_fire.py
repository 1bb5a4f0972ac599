"""FIRE energy minimisation (SPEC M7; seed 003's initialisation with gravity off).

A random fill of soft bidisperse particles (50:50, diameter ratio 1.4) below jamming has
zero-energy states; FIRE must reach one: every overlap below 1e-6 of the mean diameter.
The overlaps are re-measured here with a k-d tree, independently of the engine's list.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import bidisperse_radii, overlaps
from grainflow.engine.minimize import minimize_fire
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.models.soft import SoftLaw
from grainflow.state import ParticleState

pytestmark = pytest.mark.usefixtures("numba_one_thread")


def _fill(dim: int, n: int, phi: float, seed: int, mu: float = 0.0):
    rng = np.random.default_rng(seed)
    radii = bidisperse_radii(n, rng, small=0.5 / 1.2)  # sigma_avg = 1
    vol = np.sum(np.pi * radii**2) if dim == 2 else np.sum(4.0 / 3.0 * np.pi * radii**3)
    length = (vol / phi) ** (1.0 / dim)
    box = Box(lo=np.zeros(dim), hi=np.full(dim, length), periodic=(True,) * dim)
    st = ParticleState(dim, box)
    st.add_particles(rng.uniform(0.0, length, (n, dim)), radii, mass=1.0,
                     v=rng.standard_normal((n, dim)))
    law = SoftLaw()
    law.set_all(epsilon=1.0, mu_k=mu)
    sim = Simulation(st, 1.0, law)
    sim.dt = sim.contact_time() / 50.0
    return sim, np.full(dim, length)


@pytest.mark.parametrize("dim, n, phi, mu", [
    (2, 300, 0.6, 0.0), (3, 400, 0.45, 0.0),
    (2, 300, 0.8, 0.0), (3, 400, 0.6, 0.0),      # closer to jamming
    (2, 300, 0.6, 0.5), (3, 400, 0.45, 0.5),     # SP kinetic friction on, as in seed 003
])
def test_fire_removes_overlaps(dim, n, phi, mu):
    sim, lengths = _fill(dim, n, phi, seed=dim * 10 + int(phi * 10), mu=mu)
    st = sim.state
    mean_d = 2.0 * float(np.mean(st.radius))
    before = overlaps(st.x[:, :dim].copy(), st.radius, lengths)
    assert before.max() > 0.3 * mean_d  # a genuinely overlapping start
    dt0 = sim.dt
    ids = st.id.copy()
    res = minimize_fire(sim, max_steps=5_000)  # ~100-500 steps needed
    assert res.converged, res
    assert res.max_overlap < 1e-6 * mean_d
    after = overlaps(st.x[:, :dim].copy(), st.radius, lengths)
    assert after.max(initial=0.0) < 1e-6 * mean_d
    assert sim.max_overlap() < 1e-6 * mean_d
    # no particle lost, time step and clock untouched, motion stopped
    assert np.array_equal(np.sort(st.id), np.sort(ids))
    assert sim.dt == dt0 and sim.step == 0 and sim.time == 0.0
    assert np.all(st.v == 0.0) and np.all(st.omega == 0.0)
    assert np.all(np.isfinite(st.x))


def test_fire_reports_non_convergence():
    """Above jamming (2D, phi = 0.95) overlaps cannot all vanish: the result must say so."""
    sim, lengths = _fill(2, 100, 0.95, seed=5)
    res = minimize_fire(sim, max_steps=300)
    assert not res.converged
    assert res.steps == 300
    assert res.max_overlap > 1e-6
    assert res.max_overlap == pytest.approx(sim.max_overlap(), rel=1e-12)
