"""Energy and momentum conservation of an elastic, frictionless granular gas (SPEC M1, M7).

With ``gamma_n = gamma_t = 0`` and ``mu = 0`` the linear contact law is conservative:
``U = sum_pairs kn delta^2 / 2`` over overlapping pairs. Velocity Verlet must then keep
``E = K + K_rot + U`` constant up to its bounded O(dt^2) error, with no drift, in a fully
periodic box where grains collide thousands of times. The elastic energy is computed here
from the positions with a k-d tree, independently of the engine's neighbour list, so a pair
missed by the list (or a list that was not rebuilt in time) shows up as an energy jump.

Time step: ``t_c/100``. At ``t_c/50`` the 3D gas drifted by about 1.2e-4 of E in 1e5 steps
(the linear spring's kink at first touch costs VV an O(dt^2) error per collision), too close
to the 1e-4 bound; at ``t_c/100`` the largest deviation was about 2e-5.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import overlaps, random_nonoverlapping
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.models.granular import GranularLaw, restitution_and_contact_time
from grainflow.state import ParticleState

pytestmark = pytest.mark.usefixtures("numba_one_thread")

KN = 1.0e4


def _gas(dim: int, n: int, phi: float, seed: int) -> tuple[Simulation, np.ndarray]:
    rng = np.random.default_rng(seed)
    radii = rng.uniform(0.4, 0.6, n)  # polydisperse: unequal masses and radii
    vol = np.sum(np.pi * radii**2) if dim == 2 else np.sum(4.0 / 3.0 * np.pi * radii**3)
    length = (vol / phi) ** (1.0 / dim)
    box = Box(lo=np.zeros(dim), hi=np.full(dim, length), periodic=(True,) * dim)
    st = ParticleState(dim, box)
    x = random_nonoverlapping(dim, radii, length, rng)
    v = rng.standard_normal((n, dim))
    st.add_particles(x, radii, density=1.0, v=v)
    st.v[:] -= st.momentum() / st.mass.sum()  # zero total momentum
    law = GranularLaw()
    law.set_all(kn=KN, gamma_n=0.0, gamma_t=0.0, mu=0.0)
    sim = Simulation(st, 1.0, law)
    sim.dt = sim.contact_time() / 100.0
    assert restitution_and_contact_time(KN, 0.0, 0.5)[0] == 1.0
    return sim, np.full(dim, length)


def _energy(sim: Simulation, lengths: np.ndarray) -> tuple[float, float]:
    st = sim.state
    d = st.dim
    ov = overlaps(st.x[:, :d].copy(), st.radius, lengths)
    elastic = 0.5 * KN * float(np.sum(ov**2))
    return st.kinetic_energy() + st.rotational_energy() + elastic, elastic


def _check_gas(dim: int, n: int, phi: float, steps: int, every: int, seed: int) -> None:
    sim, lengths = _gas(dim, n, phi, seed)
    st = sim.state
    e0, _ = _energy(sim, lengths)
    p0 = st.momentum().copy()
    p_scale = float(np.sum(st.mass * np.linalg.norm(st.v, axis=1)))
    samples = []

    def watch(s: Simulation) -> None:
        samples.append(_energy(s, lengths) + (s.state.momentum().copy(),))

    sim.add_observer(watch, every=every)
    sim.run(steps)
    energies = np.array([e for e, _, _ in samples])
    elastic = np.array([u for _, u, _ in samples])
    drift = np.abs(energies / e0 - 1.0)
    # the check means something: grains were overlapping at the sampled instants and the
    # list was rebuilt many times over the run
    assert elastic.max() > 1e-4 * e0
    assert sim.rebuilds > 50
    assert drift.max() < 1e-4, f"relative energy error up to {drift.max():.3g}"
    for *_, p in samples:
        assert np.abs(p - p0).max() < 1e-10 * p_scale
    # elastic gas with mu = 0: no spin is ever created
    assert np.abs(st.omega).max() == 0.0


@pytest.mark.slow
def test_elastic_gas_3d_energy_and_momentum():
    """1000 spheres, packing fraction 0.2, 1e5 steps (~30 s on one core)."""
    _check_gas(3, 1000, 0.2, steps=100_000, every=5_000, seed=11)


def test_elastic_gas_2d_energy_and_momentum():
    """1000 disks, packing fraction 0.3, 1e4 steps."""
    _check_gas(2, 1000, 0.3, steps=10_000, every=1_000, seed=12)
