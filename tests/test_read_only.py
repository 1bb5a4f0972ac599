"""Read-only evaluations never change a contact history (LAMMPS paid for this in lammps#1631).

Every path that evaluates forces without advancing the run — ``sim.contacts()``,
``sim.frame(contacts=True)``, the set-up call at the start of ``run``, the recomputation
after an insertion or deletion, FIRE — must leave every history value (pair springs,
cohesion flags, wall springs) bitwise as it was. Tested on a sliding frictional pair held
at its Coulomb cap (the case where the old rescale wrote the spring) and on the LAMMPS chute;
and a run whose observers ask for frames and contacts every step ends bitwise equal to the
same run without them.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainflow.engine.forces import Gravity
from grainflow.engine.minimize import minimize_fire
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.io.thermo import ThermoLog
from grainflow.models.granular import GranularLaw
from grainflow.state import ParticleState
from grainflow.walls import Plane, WallForce


def history_by_ids(sim: Simulation) -> dict:
    """Every history value keyed by what it belongs to: (interaction, id_i, id_j) for pairs
    (oriented id_i < id_j), (array name, id) for per-particle arrays (wall springs)."""
    out = {}
    ids = sim.state.id
    nl = sim.neighbors
    for k, inter in enumerate(sim.interactions):
        assert inter.history.shape[0] == nl.n_pairs
        for i in range(sim.state.n):
            for slot in range(nl.row_ptr[i], nl.row_ptr[i + 1]):
                a, b = int(ids[i]), int(ids[nl.nbr[slot]])
                h = inter.history[slot].copy()
                if a > b:
                    a, b, h = b, a, h * inter.law.flip
                out[(k, a, b)] = h
    for name, arr in sim.state.arrays.items():
        if name.startswith("wall_history_"):
            for i, row in zip(ids, arr):
                out[(name, int(i))] = row.copy()
    return out


def assert_unchanged(before: dict, after: dict) -> None:
    """Every entry present in both is bitwise equal; none appears with a non-zero value."""
    for key, value in after.items():
        if key in before:
            assert np.array_equal(before[key].view(np.uint64), value.view(np.uint64)), key
        else:
            assert not np.any(value != 0.0), key


def sliding_pair(kt_factor: float = 2.0 / 7.0) -> Simulation:
    """Two spheres pressed together (gravity along -z) and sheared past each other fast
    enough that friction sits at its Coulomb cap; one of them also slides on a floor."""
    box = Box(np.full(3, -10.0), np.full(3, 10.0), (False,) * 3)
    st = ParticleState(3, box)
    st.add_particles([[0.0, 0.0, 0.5], [0.2, 0.0, 1.45]], 0.5, density=1.0,
                     v=[[-0.5, 0.0, 0.0], [2.0, 0.3, 0.0]])
    law = GranularLaw(2)
    law.set_all(kn=1e4, kt=kt_factor * 1e4, gamma_n=5.0, mu=0.05, cohesion_force=0.5,
                cohesion_range=0.05)
    sim = Simulation(st, 1e-4, law, skin=0.1)
    sim.add_force(Gravity([0.0, 0.0, -5.0]))
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))], law, 1))
    sim.run(30)
    return sim


def _paths():
    """Each read-only path as a function of the simulation."""
    def contacts(sim):
        sim.forces_current = False
        sim.contacts()

    def frame(sim):
        sim.forces_current = False
        sim.frame(contacts=True)

    def setup_call(sim):
        sim.forces_current = False
        sim.run(0)

    def explicit(sim):
        sim.compute_forces(update=False)

    def insertion(sim):
        sim.add_particles([[8.0, 8.0, 8.0]], 0.5, density=1.0)
        sim.run(0)

    def deletion(sim):
        sim.add_particles([[8.0, 8.0, 8.0]], 0.5, density=1.0)
        sim.remove_particles(sim.state.x[:, 0] > 7.0)
        sim.contacts()

    def fire(sim):
        minimize_fire(sim, max_steps=3, overlap_tol=0.0)

    return {"contacts": contacts, "frame": frame, "setup_call": setup_call,
            "compute_forces(update=False)": explicit, "insertion": insertion,
            "deletion": deletion, "fire": fire}


PATHS = _paths()


@pytest.mark.usefixtures("numba_one_thread")
@pytest.mark.parametrize("path", sorted(PATHS))
def test_sliding_pair_history_unchanged_by_read_only_paths(path: str) -> None:
    sim = sliding_pair()
    before = history_by_ids(sim)
    # the pair slides at its Coulomb cap and both springs, the cohesion flag and the wall
    # spring are non-zero: the values an evaluation could change
    pair = before[(0, 0, 1)]
    assert np.all(pair[:2] != 0.0) and pair[3] == 1.0
    assert np.any(before[("wall_history_0", 0)] != 0.0)
    f = sim.contacts().force
    assert np.linalg.norm(f[0]) > 0
    PATHS[path](sim)
    assert_unchanged(before, history_by_ids(sim))


@pytest.mark.usefixtures("numba_one_thread")
def test_sliding_pair_is_at_the_coulomb_cap() -> None:
    """The case the read-only test needs: |F_t| = mu |F_n| exactly."""
    sim = sliding_pair()
    c = sim.contacts().of_kind(0)
    n = c.branch[0] / np.linalg.norm(c.branch[0])
    fn = c.force[0] @ n
    ft = np.linalg.norm(c.force[0] - fn * n)
    assert ft == pytest.approx(0.05 * abs(fn), rel=1e-12)


@pytest.mark.usefixtures("numba_one_thread")
def test_chute_history_unchanged_by_read_only_paths() -> None:
    from grainflow.scenarios.chute import chute_cut

    sim = chute_cut(0.5, 0.5)
    sim.run(20)
    before = history_by_ids(sim)
    assert sum(np.any(h != 0) for h in before.values()) > 1000
    for path in ("contacts", "frame", "setup_call", "compute_forces(update=False)", "fire"):
        PATHS[path](sim)
        assert_unchanged(before, history_by_ids(sim))


def _pile(observed: bool, tmp_path) -> Simulation:
    sim = sliding_pair()
    rng = np.random.default_rng(2)
    x = np.c_[rng.uniform(-2, 2, (30, 2)), 3.0 + 1.1 * np.arange(30)]
    sim.add_particles(x, 0.45, density=1.0)
    if observed:
        frames = []
        sim.add_observer(lambda ctx: frames.append(ctx.frame(contacts=True)), every=1)
        sim.add_observer(lambda ctx: (ctx.contacts(), ctx.max_overlap()), every=1)
        sim.add_observer(ThermoLog(tmp_path / "thermo.csv"), every=1)
    sim.run(400)
    return sim


@pytest.mark.usefixtures("numba_one_thread")
def test_frames_every_step_leave_the_run_bitwise_unchanged(tmp_path) -> None:
    plain = _pile(False, tmp_path)
    observed = _pile(True, tmp_path)
    for name in ("x", "v", "omega", "id"):
        assert np.array_equal(plain.state.arrays[name], observed.state.arrays[name]), name
    assert_unchanged(history_by_ids(plain), history_by_ids(observed))
    assert history_by_ids(plain).keys() == history_by_ids(observed).keys()
