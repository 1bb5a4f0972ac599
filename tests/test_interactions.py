"""Several pair interactions in one simulation, each owning some type pairs; the contact
law's sub-model registry; saved contacts of every kind (pairs, walls, bonds, anchors)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import two_law_disks
from grainflow.engine.forces import Gravity
from grainflow.engine.simulation import Simulation
from grainflow.engine.tethers import Tethers, neighbor_bonds
from grainflow.frame import ANCHOR, BOND, PAIR, WALL, Box
from grainflow.io.thermo import ThermoLog
from grainflow.models.base import ContactLaw
from grainflow.models.granular import GranularLaw
from grainflow.models.registry import PRESETS, SUBMODELS, submodel
from grainflow.models.soft import SoftLaw
from grainflow.models.submodel import SLOTS
from grainflow.state import ParticleState
from grainflow.walls import Plane, WallForce

pytestmark = pytest.mark.usefixtures("numba_one_thread")


def _three_pairs() -> ParticleState:
    """Pairs (0,0), (1,1) and (0,1) types, each overlapping by 0.1, far from each other."""
    st = ParticleState(3, Box(np.full(3, -20.0), np.full(3, 20.0), (False,) * 3))
    x = [[0, 0, 0], [0.9, 0, 0], [5, 0, 0], [5.9, 0, 0], [10, 0, 0], [10.9, 0, 0]]
    st.add_particles(np.array(x, float), 0.5, mass=1.0, type=np.array([0, 0, 1, 1, 0, 1]))
    return st


def _laws() -> tuple[GranularLaw, SoftLaw]:
    granular = GranularLaw(2)
    granular.set_all(kn=1e3)
    soft = SoftLaw(2)
    soft.set_all(epsilon=50.0)
    return granular, soft


def test_each_type_pair_uses_its_own_law() -> None:
    st = _three_pairs()
    granular, soft = _laws()
    sim = Simulation(st, 1e-4)
    sim.add_interaction(granular, types=[(0, 0), (0, 1)])
    sim.add_interaction(soft, types=[(1, 1)])
    sim.compute_forces(update=False)
    assert st.force[0, 0] == pytest.approx(-1e3 * 0.1)  # Hooke: kn overlap
    assert st.force[2, 0] == pytest.approx(-50.0 * (1 - 0.9))  # eps/sigma (1 - r/sigma), sigma 1
    assert st.force[4, 0] == pytest.approx(-1e3 * 0.1)
    np.testing.assert_allclose(st.force.sum(axis=0), 0.0, atol=1e-12)
    kinds = sim.contacts()
    assert kinds.i.size == 3 and np.all(kinds.kind == PAIR)


def test_a_default_interaction_takes_the_unclaimed_pairs() -> None:
    st = _three_pairs()
    granular, soft = _laws()
    sim = Simulation(st, 1e-4, granular)  # default
    sim.add_interaction(soft, types=[(1, 1)])
    sim.compute_forces(update=False)
    assert st.force[0, 0] == pytest.approx(-100.0)
    assert st.force[2, 0] == pytest.approx(-5.0)
    assert st.force[4, 0] == pytest.approx(-100.0)
    with pytest.raises(ValueError, match=r"\[\(1, 1\)\] already belong to interaction 1"):
        sim.add_interaction(GranularLaw(2), types=[(1, 1)])
    with pytest.raises(ValueError, match="default interaction already"):
        sim.add_interaction(GranularLaw(2))


def test_unowned_type_pairs_do_not_interact() -> None:
    st = _three_pairs()
    soft = SoftLaw(2)
    soft.set_all(epsilon=50.0)
    sim = Simulation(st, 1e-4)
    sim.add_interaction(soft, types=[(1, 1)])
    sim.compute_forces(update=False)
    assert np.all(st.force[[0, 1, 4, 5]] == 0.0) and st.force[2, 0] == pytest.approx(-5.0)


def _mixed_run(threads: int) -> Simulation:
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        st, granular, soft = two_law_disks(6.0, True, 120)
        sim = Simulation(st, 2e-4, granular, threads=min(threads, numba.config.NUMBA_NUM_THREADS))
        sim.add_interaction(soft, types=[(1, 1)])
        sim.add_force(WallForce([Plane((0, 0), (0, 1))], granular, 2))
        sim.add_force(Gravity([0.0, -10.0]))
        sim.run(1500)
        return sim
    finally:
        numba.set_num_threads(before)


def test_two_interactions_are_bitwise_identical_on_any_thread_count() -> None:
    one, two = _mixed_run(1), _mixed_run(2)
    for name in ("x", "v", "omega"):
        assert np.array_equal(one.state.arrays[name], two.state.arrays[name])
    assert np.array_equal(one.interactions[0].history, two.interactions[0].history)


def test_two_interactions_survive_a_checkpoint() -> None:
    sim = _mixed_run(1)
    data = sim.state_dict()
    assert set(data["interactions"]) == {"0", "1"}
    clone = _mixed_run(1)
    clone.load_state_dict(data)
    sim.run(50)
    clone.run(50)
    assert np.array_equal(sim.state.x, clone.state.x)


# ------------------------------------------------------------------------ the registry
def test_every_registry_row_resolves_and_names_its_class() -> None:
    for slot, name in SUBMODELS:
        cls = submodel(slot, name)
        assert cls.slot == slot and cls.name == name and cls.summary
        assert len(cls.history_flip) == cls.history_size
        for p in cls.params:
            assert p.description
    for preset in PRESETS.values():
        assert set(ContactLaw(law=preset.name).models) == set(SLOTS)


def test_parameter_names_are_unique_across_slots() -> None:
    owner: dict[str, str] = {}
    for slot, name in SUBMODELS:
        for p in submodel(slot, name).params:
            assert owner.setdefault(p.name, slot) == slot, p.name


def test_composed_law_reports_what_it_is() -> None:
    law = ContactLaw(normal="hertz", tangential="history")
    assert law.name == "hertz/none/history/none"
    assert law.param_names == ("kn", "kt", "gamma_t", "mu")
    with pytest.raises(ValueError, match="kt: missing; give the tangential stiffness"):
        law.set_all(kn=1e6)
    with pytest.raises(ValueError, match="epsilon: not a parameter of the contact law"):
        law.set_all(kn=1e6, kt=1e3, epsilon=1.0)
    with pytest.raises(ValueError, match="normal: 'spring' is not valid; use one of"):
        ContactLaw(normal="spring")
    with pytest.raises(ValueError, match="normal: missing"):
        ContactLaw(damping="viscous")


# ----------------------------------------------------------------- contacts of all kinds
def test_saved_contacts_hold_walls_bonds_and_anchors() -> None:
    st = ParticleState(3, Box(np.full(3, -20.0), np.full(3, 20.0), (False,) * 3))
    st.add_particles([[0.0, 0.0, 0.45], [3.0, 0.0, 0.48]], 0.5, density=1.0)  # on the floor
    wall_ids = st.add_particles([[10.0, 0.0, 2.0], [11.0, 0.0, 2.0], [12.0, 0.0, 2.0]], 0.5,
                                density=1.0, type=2, body=0)
    law = GranularLaw(3)
    law.set_all(kn=1e4)
    sim = Simulation(st, 1e-4, law)
    sim.add_force(WallForce([Plane((0, 0, 10), (0, 0, -1))], law, 1))  # ceiling: wall 0
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))], law, 1))  # floor: wall 1
    tethers = Tethers(st.id[wall_ids], k=50.0,
                      bonds=neighbor_bonds(st, st.id[wall_ids], 1.5))
    sim.add_force(tethers)
    sim.add_force(Gravity([0.0, 0.0, -1.0]))
    st.x[wall_ids[0], 2] += 0.1  # stretch the first tethered particle
    c = sim.contacts()
    walls = c.of_kind(WALL)
    assert walls.i.tolist() == [0, 1] and walls.j.tolist() == [1, 1]  # the floor is wall 1
    np.testing.assert_allclose(walls.branch, [[0, 0, 0.45], [0, 0, 0.48]], atol=1e-12)
    np.testing.assert_allclose(walls.force[:, 2], [1e4 * 0.05, 1e4 * 0.02], rtol=1e-12)
    anchors = c.of_kind(ANCHOR)
    assert sorted(anchors.i.tolist()) == st.id[wall_ids].tolist() and np.all(anchors.j == -1)
    bonds = c.of_kind(BOND)
    assert sorted(zip(bonds.i.tolist(), bonds.j.tolist())) == [(2, 3), (3, 4)]
    # the rows add up to the tether forces the engine applies
    sim.forces = [tethers]
    sim.interactions = []
    sim.compute_forces(update=False)
    total = np.zeros((st.n, 3))
    for rows in (anchors, bonds):
        np.add.at(total, rows.i, rows.force)
    np.add.at(total, bonds.j, -bonds.force)
    np.testing.assert_allclose(total[wall_ids], st.force[wall_ids], atol=1e-12)
    np.testing.assert_allclose(anchors.branch[anchors.i == 2], [[0, 0, 0.1]], atol=1e-12)


def test_wall_contacts_balance_the_weight_of_a_settled_layer() -> None:
    st = ParticleState(3, Box(np.array([-3.0, -3.0, -1.0]), np.array([3.0, 3.0, 9.0]),
                              (True, True, False)))
    g = np.stack(np.meshgrid(np.arange(-2.5, 3, 1.0), np.arange(-2.5, 3, 1.0)), -1)
    st.add_particles(np.c_[g.reshape(-1, 2), np.full(36, 0.6)], 0.5, density=1.0)
    law = GranularLaw(2)
    law.set_all(kn=1e4, gamma_n=150.0, mu=0.5)  # e = 0.6: settles in a few contact times
    sim = Simulation(st, 2e-4, law)
    sim.add_force(WallForce([Plane((0, 0, 0), (0, 0, 1))], law, 1))
    sim.add_force(Gravity([0.0, 0.0, -9.81]))
    sim.run(5000)
    c = sim.contacts()
    weight = float(st.mass.sum()) * 9.81
    assert c.of_kind(WALL).force[:, 2].sum() == pytest.approx(weight, rel=1e-6)


# ----------------------------------------------------------------------- thermo from Python
def test_thermo_observer_logs_the_initial_state_once(tmp_path) -> None:
    st = ParticleState(3, Box(np.full(3, -5.0), np.full(3, 5.0), (False,) * 3))
    st.add_particles([[0.0, 0.0, 1.0]], 0.5, density=1.0)
    sim = Simulation(st, 1e-3)
    sim.add_force(Gravity([0.0, 0.0, -1.0]))
    log = ThermoLog(tmp_path / "thermo.csv")
    sim.add_observer(log, every=5)
    sim.run(10)
    sim.run(5)
    log.close()
    rows = (tmp_path / "thermo.csv").read_text().splitlines()
    assert [int(r.split(",")[0]) for r in rows[1:]] == [0, 5, 10, 15]
