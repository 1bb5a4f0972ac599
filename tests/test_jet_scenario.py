"""The jet scenarios (seed 002, Chapter 3): lattice jets, the tethered target, the law."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainflow.config.schema import ConfigError, load_config
from grainflow.config.build import build_simulation
from grainflow.engine.integrators import AdamsBashforth2
from grainflow.engine.tethers import Tethers
from grainflow.insertion.lattice import IDEAL_PACKING
from grainflow.scenarios.jet import TARGET_TYPE, JetSection, jet_sites, target_sites


def _config(dim: int, **jet) -> dict:
    return {"scenario": f"jet{dim}d", "dim": dim, "run": {"duration": 1.0},
            "jet": {"jet_diameter": 4.5, "target_diameter": 9.0, "n": 400, **jet}}


def test_table_4_1_contact_parameters() -> None:
    """(e, t_c) -> (k_n, eta_n) by eqs. 3.4-3.5 reproduces Table 4.1 for all four e."""
    table = {0.75: (4.98e2, 2.88), 0.80: (4.96e2, 2.23), 0.90: (4.94e2, 1.05),
             0.99: (4.93e2, 0.101)}
    for e, (kn, eta) in table.items():
        got = JetSection(restitution=e, contact_time=0.1).contact_parameters()
        assert got[0] == pytest.approx(kn, rel=3e-3)
        assert got[1] == pytest.approx(eta, rel=5e-3)
    # the 2D mu_p = 0.4 set (k_n = 1.99e3, eta_n = 5.75 at t_c = 0.05)
    kn, eta = JetSection(contact_time=0.05).contact_parameters()
    assert (kn, eta) == (pytest.approx(1.99e3, rel=3e-3), pytest.approx(5.75, rel=3e-3))


def test_the_3d_jet_as_built() -> None:
    config = load_config(_config(3, phi_tilde=0.9))
    assert config.run.integrator == "adams_bashforth2"  # the scenario's run default
    sim = build_simulation(config)
    st = sim.state
    grains = st.type != TARGET_TYPE
    assert abs(int(grains.sum()) - 400) <= 10
    assert isinstance(sim.integrator, AdamsBashforth2)
    assert sim.dt == pytest.approx(0.02 * 0.1)
    np.testing.assert_array_equal(st.v[grains], np.tile([0.0, 0.0, -1.0], (grains.sum(), 1)))
    assert np.all(st.mass == 1.0) and np.all(st.radius == 0.5)
    # no two grains overlap (fcc nearest neighbours just touch)
    from scipy.spatial import cKDTree
    pairs = cKDTree(st.x[grains]).query_pairs(1.0 - 1e-9)
    assert not pairs
    # the jet starts gap = 2 above the surface z = 0 and lies within D_jet/2 of the axis
    assert st.x[grains, 2].min() - 0.5 == pytest.approx(2.0)
    assert np.hypot(st.x[grains, 0], st.x[grains, 1]).max() <= 2.25 + 1e-9
    # the target: one layer at z = -1/2 inside D_tar/2, one body, tethered
    wall = st.x[~grains]
    assert np.all(wall[:, 2] == -0.5) and np.hypot(wall[:, 0], wall[:, 1]).max() <= 4.5
    assert len(np.unique(st.body[~grains])) == 1 and st.body[~grains][0] >= 0
    tethers = [f for f in sim.forces if isinstance(f, Tethers)]
    assert len(tethers) == 1
    _, eta_n = JetSection().contact_parameters()
    assert tethers[0].k == 10.0 and tethers[0].eta == pytest.approx(5.0 * eta_n)
    assert len(tethers[0].bond_ids) > 2 * len(wall)  # neighbours of a triangular lattice


def test_thinning_keeps_phi_tilde_of_the_sites() -> None:
    """phi0 = phi_tilde phi_fcc: the kept sites are that fraction of the full lattice."""
    for phi_tilde in (0.3, 0.6, 0.9):
        section = JetSection(jet_diameter=6.0, n=3000, phi_tilde=phi_tilde)
        sites, _, phi_lattice = jet_sites(section, 3, np.random.default_rng(0))
        assert phi_lattice == pytest.approx(IDEAL_PACKING["fcc"])
        sim = build_simulation(load_config(_config(3, jet_diameter=6.0, n=3000,
                                                   phi_tilde=phi_tilde)))
        grains = int((sim.state.type != TARGET_TYPE).sum())
        assert grains / len(sites) == pytest.approx(phi_tilde, abs=1.0 / len(sites))


def test_2d_lattices_and_the_seed_phi_ini() -> None:
    """2D: triangular lattice of spacing 1.1 d; bidisperse 50:50 (0.8 d, d) gives the seed's
    phi_ini = 0.612; monodisperse gives pi/(2 sqrt 3)/1.1^2 = 0.750 (the seed prints 0.780,
    which no spacing-1.1 triangular lattice of d-disks reaches: recorded in docs/jets.md)."""
    rng = np.random.default_rng(1)
    _, r, phi_bi = jet_sites(JetSection(jet_diameter=30.0, n=8000, sizes="bidisperse"), 2, rng)
    assert phi_bi == pytest.approx(0.612, abs=0.01)
    assert np.mean(r < 0.5) == pytest.approx(0.5, abs=0.02)
    _, _, phi_mono = jet_sites(JetSection(jet_diameter=30.0, n=8000), 2, rng)
    assert phi_mono == pytest.approx(math.pi / (2 * math.sqrt(3)) / 1.21)
    sim = build_simulation(load_config(_config(2, sizes="bidisperse", jet_diameter=30.0,
                                               target_diameter=66.0, n=2000)))
    st = sim.state
    grains = st.type != TARGET_TYPE
    assert set(np.unique(st.type[grains])) == {0, 1}
    np.testing.assert_array_equal(st.radius[st.type == 1], 0.5)
    np.testing.assert_array_equal(st.radius[st.type == 0], 0.4)
    assert np.all(st.mass[grains] == 1.0)  # identical mass m (Chapter 3)
    np.testing.assert_array_equal(st.v[grains, :2], np.tile([-1.0, 0.0], (grains.sum(), 1)))
    wall = st.x[~grains]
    assert np.all(wall[:, 0] == -0.5) and len(wall) == 67  # |y| <= 33, spacing d


def test_the_jet_arrives_intact_at_speed_u0_and_phi0() -> None:
    """No spurious pre-collisions: until its front reaches the target (t = gap) every speed
    is still u0 (fcc neighbours touch at exactly d, so round-off overlaps of ~1e-16 d exchange
    forces that change velocities by ~1e-13 u0 and nothing more), and the jet's packing
    fraction in its interior is phi_tilde phi_fcc (binomial scatter of the thinning)."""
    config = _config(3, jet_diameter=8.0, target_diameter=16.0, n=3000, phi_tilde=0.6)
    sim = build_simulation(load_config(config))
    sim.run(int(round(1.9 / sim.dt)))
    st = sim.state
    grains = st.type != TARGET_TYPE
    v = st.v[grains]
    np.testing.assert_allclose(v, np.tile([0.0, 0.0, -1.0], (len(v), 1)), rtol=0, atol=1e-11)
    assert np.abs(st.omega).max() < 1e-11
    x = st.x[grains]
    r = np.hypot(x[:, 0], x[:, 1])
    lo, hi = x[:, 2].min() + 3.0, x[:, 2].max() - 3.0
    inner = (r < 2.5) & (x[:, 2] > lo) & (x[:, 2] < hi)
    volume = math.pi * 2.5**2 * (hi - lo)
    phi = inner.sum() * math.pi / 6.0 / volume
    expected = 0.6 * IDEAL_PACKING["fcc"]
    sites = inner.sum() / 0.6
    assert phi == pytest.approx(expected, abs=4 * expected * math.sqrt(0.4 / 0.6 / sites) + 0.02)
    # the front touches the target's top (z = 0) at t = gap = 2, not before
    sim.run(int(round(0.2 / sim.dt)))
    assert np.any(sim.state.v[sim.state.type != TARGET_TYPE, 2] > -1.0)


def test_a_rectangular_cross_section_for_the_anisotropy_runs() -> None:
    sim = build_simulation(load_config(_config(3, cross_section="rectangle", aspect_ratio=4.0,
                                               cross_section_area=16.0, n=1000)))
    x = sim.state.x[sim.state.type != TARGET_TYPE]
    assert np.abs(x[:, 0]).max() <= 1.0 + 1e-9  # short side 2 along x
    assert np.abs(x[:, 1]).max() <= 4.0 + 1e-9  # long side 8 along y
    assert np.abs(x[:, 1]).max() > 3.0


def test_target_sites() -> None:
    wall = target_sites(JetSection(target_diameter=22.0), 3)
    assert np.hypot(wall[:, 0], wall[:, 1]).max() <= 11.0 + 1e-9
    # area per site of a triangular lattice of spacing 1: sqrt(3)/2
    assert len(wall) == pytest.approx(math.pi * 11.0**2 / (math.sqrt(3) / 2), rel=0.05)


@pytest.mark.parametrize("jet, message", [
    ({"phi_tilde": 1.5}, "jet.phi_tilde"),
    ({"restitution": 0.0}, "jet.restitution"),
    ({"aspect_ratio": 0.5}, "jet.aspect_ratio"),
    ({"sizes": "tri"}, "jet.sizes"),
    ({"n": "20000"}, "jet.n"),
    ({"bogus": 1}, "jet.bogus"),
])
def test_bad_jet_fields_name_the_field(jet: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        load_config(_config(3, **jet))


def test_a_3d_bidisperse_jet_is_refused() -> None:
    with pytest.raises((ConfigError, ValueError), match="jet.sizes"):
        build_simulation(load_config(_config(3, sizes="bidisperse")))


def test_docs_jet_table_lists_every_field() -> None:
    """docs/jets.md's `[jet]` table has one row per field, with its default."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "jets.md").read_text()
    table = text.split("## The `[jet]` table", 1)[1].split("\n## ", 1)[0]
    rows = {line.split("|")[1].strip().strip("`"): line.split("|")[2].strip()
            for line in table.splitlines() if line.startswith("| `")}
    assert set(rows) == set(JetSection.model_fields)
    for name, field in JetSection.model_fields.items():
        assert rows[name] == repr(field.default), name


def test_a_denser_target() -> None:
    """target_spacing = 0.5: four times the wall particles (a smoother surface), bonded to
    their neighbours at that spacing."""
    wide = target_sites(JetSection(target_diameter=22.0), 3)
    dense = target_sites(JetSection(target_diameter=22.0, target_spacing=0.5), 3)
    assert len(dense) == pytest.approx(4 * len(wide), rel=0.05)
    sim = build_simulation(load_config(_config(3, target_spacing=0.5)))
    tethers = [f for f in sim.forces if isinstance(f, Tethers)][0]
    wall = sim.state.type == TARGET_TYPE
    assert len(tethers.bond_ids) > 2 * int(wall.sum())
    assert tethers.l0.max() == pytest.approx(0.5)
