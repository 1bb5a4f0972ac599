"""The jet study's plumbing (seed 002): sweeps, per-run analyses on a real small run, the
report table's verdicts. The study itself runs with ``grainflow study jet`` (docs/jets.md)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from grainflow.studies import jet_study
from grainflow.studies.jet_study import FULL, REDUCED, SEED, _mean_by, _Table, sweep_specs


def test_the_sweeps_of_both_plans_validate_and_cover_the_seed() -> None:
    for plan in (REDUCED, FULL):
        specs = sweep_specs(plan)
        assert set(specs) == {"scatter", "anisotropy", "rheo3d", "rheo2d"}
        assert specs["scatter"].replicates == plan.replicas
        assert specs["rheo3d"].base["jet"]["target_diameter"] == 22.0  # D_tar = 22 d
        assert specs["rheo2d"].base["jet"]["target_diameter"] == pytest.approx(2.2 * 30.0)
        assert specs["rheo2d"].base["jet"]["sizes"] == "bidisperse"
        assert specs["rheo3d"].base["output"]["contacts"] is True
    assert FULL.replicas == 10 and FULL.rheo3d_n == 20_000 and FULL.rheo2d_n == 8000
    assert FULL.rheo3d_window == (50.0, 100.0) and FULL.rheo2d_window == (180.0, 300.0)
    assert 0.615 == pytest.approx((2.05**2 - 1) / (2.05**2 + 1), abs=2e-3)  # eps of l = 2.05


def test_replica_means_and_errors() -> None:
    keys, mean, err = _mean_by([1.0, 1.0, 2.0], [0.5, 0.7, 3.0])
    np.testing.assert_array_equal(keys, [1.0, 2.0])
    np.testing.assert_allclose(mean, [0.6, 3.0])
    assert err[0] == pytest.approx(np.std([0.5, 0.7], ddof=1) / math.sqrt(2))
    assert np.isnan(err[1])


def test_table_verdicts_use_the_seed_uncertainty_or_ten_percent() -> None:
    table = _Table()
    table.add("phi_s", 0.8345, 0.002, 1.0)  # quoted +-0.001
    table.add("phi_s", 0.837, 0.002, 1.0)
    table.add("C0", 1.68 * 1.09, 0.01, 1.0)  # none quoted: 10 %
    table.add("C0", 1.68 * 1.11, 0.01, 1.0)
    table.add("C1", None, None, 1.0)
    verdicts = [row.split("|")[4].strip() for row in table.rows]
    assert verdicts == ["agrees", "misses", "agrees", "misses", "—"]
    assert set(SEED) >= {"C0", "C1", "C2", "v2(eps=0.615), experiment", "phi_s", "alpha_s", "mu_s",
                         "mu_max", "I0", "a (frictional)", "a (frictionless)"}


def test_report_lists_the_2d_fits_under_each_choice() -> None:
    """The report's table of fit choices: one row per choice, the layer (a) row recovers the
    layer's own phi_s, and a fit that cannot be made prints '-'."""
    from grainflow.analysis.jet.rheology import LayerFields

    I = np.geomspace(0.005, 0.12, 16)  # noqa: E741
    mu = 0.01 + 0.5 / (1 + 0.08 / I)

    def layer(lo: float, phi: np.ndarray) -> LayerFields:
        values = {"I": I, "I_dev": I, "I_T": ((0.87 - phi) / 0.5) ** 0.75, "phi": phi,
                  "mu_folded": mu, "shear_fraction": np.where(I < 0.02, 0.1, 0.9)}
        return LayerFields(dim=2, target_radius=1.0, layer=(lo, lo + 5.0),
                           edges=np.linspace(0.0, 1.0, 17), values=values,
                           errors={k: np.full(16, 0.005) for k in values})

    lines = jet_study._fit_choices_lines([layer(0.0, 0.85 - I), layer(5.0, 0.81 - I)])
    rows = [line for line in lines if line.startswith("| ") and "---" not in line][1:]
    assert len(rows) == 6
    inner = next(row for row in rows if row.startswith("| layer (a) alone"))
    assert inner.split("|")[3].strip() == "0.85"
    flat = [layer(0.0, np.full(16, 0.8))]  # no divergence to fit, one layer only
    rows = [line for line in jet_study._fit_choices_lines(flat) if line.startswith("| ")]
    assert not any(row.startswith("| layer (b)") for row in rows)
    assert all(row.split("|")[3].strip() == "-" for row in rows[2:])


def test_report_lists_the_3d_slope_under_each_choice() -> None:
    """mu* = 0.24 I against I and 0.06 I_dev (I_dev = 4 I): the rows give both slopes, the
    median shear fraction, and the inner-ring cut drops the ring at r/R_tar = 0.1."""
    from grainflow.analysis.jet.rheology import LayerFields

    I = np.array([0.01, 0.02, 0.04, 0.07, 0.1])  # noqa: E741
    values = {"I": I, "I_dev": 4 * I, "mu_folded": 0.24 * I,
              "shear_fraction": np.array([0.1, 0.2, 0.3, 0.4, 0.5])}
    layer = LayerFields(dim=3, target_radius=11.0, layer=(0.0, 5.0),
                        edges=np.linspace(0.0, 11.0, 6), values=values,
                        errors={k: np.full(5, 0.001) for k in values})
    lines = jet_study._fit_choices_3d_lines([layer], "frictional")
    assert "seed: 0.24" in lines[1] and "shear fraction |D_rz| / D_dev is 0.30" in lines[1]
    rows = {line.split("|")[1].strip(): line.split("|")[2:4] for line in lines
            if line.startswith("| ") and "---" not in line}
    assert float(rows["every ring, weighted (the table)"][1]) == pytest.approx(0.24)
    assert float(rows["I_dev in place of I"][1]) == pytest.approx(0.06)
    assert int(rows["rings r/R_tar >= 0.2"][0]) == 4


@pytest.fixture(scope="module")
def small_jet_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from grainflow.runner import run_config

    rundir = tmp_path_factory.mktemp("jet") / "run"
    config = {"scenario": "jet3d", "dim": 3, "run": {"duration": 20.0},
              "output": {"thermo_every": 1000, "frames_every": 500, "contacts": True,
                         "checkpoint_every": 0, "snapshot": False},
              "jet": {"jet_diameter": 4.5, "target_diameter": 11.25, "n": 400,
                      "cross_section": "rectangle", "aspect_ratio": 2.05,
                      "cross_section_area": 16.0}}
    run_config(config, rundir, progress="none")
    return rundir


def test_per_run_analyses_on_a_real_run(small_jet_run: Path) -> None:
    """A 400-grain jet onto a target 2.5 times wider: the flow leaves as a sheet
    (psi0 near pi/2 or beyond), and the anisotropy analysis reports the eccentricity."""
    summary = jet_study.scattering_summary(small_jet_run)
    assert summary["X"] == pytest.approx(2.5)
    assert summary["scattered"] > 50
    assert 1.2 < summary["psi0"] < 2.0
    assert 0 < summary["psi0_err"] < 0.2
    aniso = jet_study.anisotropy_summary(small_jet_run)
    assert aniso["eps"] == pytest.approx(0.6155, abs=1e-3)
    assert abs(aniso["v2"]) < 0.5 and aniso["v2_err"] > 0


def test_the_contact_fabric_of_a_real_run_and_its_report_table(small_jet_run: Path) -> None:
    """On a real run's contact listing: each ring's fabric has unit trace, the sliding
    fraction lies in [0, 1] (the scenario's grains are frictional), and the report table has one
    row per ring carrying the layer's mu*."""
    from grainflow.analysis.jet.fabric import ring_fabric_3d
    from grainflow.analysis.jet.rheology import layer_fields_3d

    frames, config = jet_study._run_frames(small_jet_run)
    radius = 0.5 * config["jet"]["target_diameter"]
    mu = config["jet"]["mu_p"]
    fab = ring_fabric_3d(frames, radius, mu)
    touched = fab.contacts > 0
    assert touched.sum() >= 2
    np.testing.assert_allclose(np.trace(fab.fabric[touched], axis1=1, axis2=2), 1.0)
    assert np.all((fab.sliding[touched] >= 0) & (fab.sliding[touched] <= 1))
    assert np.all(fab.coordination[touched] > 0)
    layer = layer_fields_3d(frames, radius)
    lines = jet_study._fabric_lines("frictional", {0.5: fab}, {0.5: layer})
    rows = [line for line in lines if line.startswith("| 0.5 |")]
    assert len(rows) == 5
    assert rows[0].split("|")[6].strip() == f"{layer.values['mu'][0]:+.3f}"


def test_with_target_spacing_changes_only_the_base_jets_target():
    from grainflow.studies.jet_study import REDUCED, sweep_specs, with_target_spacing

    spec = sweep_specs(REDUCED)["rheo3d"]
    assert with_target_spacing(spec, None) is spec
    smooth = with_target_spacing(spec, 0.5).model_dump()
    assert smooth["base"]["jet"]["target_spacing"] == 0.5
    smooth["base"]["jet"].pop("target_spacing")
    plain = spec.model_dump()
    plain["base"]["jet"].pop("target_spacing", None)
    assert smooth == plain
