"""The stream study (seed 000): its sweeps, its verdicts, and its per-run analysis on a saved
run."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from conftest import TINY_STREAM, one_thread
from grainflow.studies import stream_study
from grainflow.studies.stream_study import FULL, REDUCED, SEED, sweep_specs


def test_the_sweeps_of_both_plans_validate_and_cover_the_seed() -> None:
    full = sweep_specs(FULL)
    assert len(full["phase"].points()) == 5 * len(FULL.cohesion_nN)
    forces = {p.overrides["stream.cohesion_force"] for p in full["phase"].points()}
    assert {"1 nN", "100 nN", "2000 nN"} <= forces
    assert {p.overrides["stream.restitution"] for p in full["phase"].points()} == {
        1.0, 0.88, 0.73, 0.61, 0.40}
    reduced = sweep_specs(REDUCED)
    assert len(reduced["phase"].points()) == 8
    # the shell sweeps keep W = F_c delta at its base value (1000 nN x 100 nm)
    assert len(full["shell"].points()) == 2 and len(reduced["shell"].points()) == 1
    for p in [*full["shell"].points(), *reduced["shell"].points()]:
        f = float(p.overrides["stream.cohesion_force"].split()[0])
        d = float(p.overrides["stream.cohesion_range"].split()[0])
        assert f * d == pytest.approx(1000 * 100)


def test_verdicts_use_thirty_percent_and_bounds() -> None:
    assert stream_study._verdict("v0 at the aperture (cm/s)", 12.9, 0.1)[1] == "agrees"
    assert stream_study._verdict("v0 at the aperture (cm/s)", 13.1, 0.1)[1] == "misses"
    assert stream_study._verdict("N_inf, clustering (F_c < 100 nN)", 5.0, None)[1] == "agrees"
    assert stream_study._verdict("N_inf, clustering (F_c < 100 nN)", 40.0, None)[1] == "misses"
    assert stream_study._verdict("most probable aspect ratio", None, None) == ("not measured",
                                                                               "—")
    assert set(SEED) >= {"peak network size, droplets", "separation gradient g d/V fitted to the droplet pairs (cm/s)"}


def test_per_run_analysis_of_a_cohesionless_stream(tiny_stream_run: Path) -> None:
    """A cohesionless stream is a spray: one network per grain deep down, no droplets, a
    steady outflow, and the saved profiles are there for the report."""
    summary = stream_study.stream_summary(tiny_stream_run)
    assert summary["frames"] >= 10
    assert 0.05 < summary["v0"] < 0.5
    assert 0.4 < summary["phi_bulk"] < 0.7  # a rained, settled bed
    # the outflow spread over the whole aperture at the bulk's packing is slower than the
    # grains, which cross it dilated (docs/streams.md, "v0 by every reading")
    assert 0.0 < summary["v0_superficial"] < summary["v0"]
    assert summary["outflow"] > 0 and summary["outflow_cv"] < 0.5
    assert summary["droplets"] == 0
    assert summary["N_inf"] < 2.0
    assert stream_study.REGIME_NAMES[int(summary["regime"])] == "spray"
    assert 0 < summary["dz"] < 0.01
    saved = np.load(tiny_stream_run / "stream_analysis.npz")
    assert saved["network"].shape == saved["network_depth"].shape


def test_a_blocked_aperture_is_named_as_such(tmp_path: Path) -> None:
    """Grains held over the aperture by F_c = 49 weights (a bridge; the 3 mm aperture of the
    reduced hopper blocked so at 5000 nN) leave no stream: the analysis says why and what to
    change, instead of failing on an empty profile."""
    from grainflow.runner import run_config

    rundir = tmp_path / "run"
    config = {"scenario": "stream", "dim": 3, "run": {"duration": 0.11, "seed": 3},
              "output": {"thermo_every": 5000, "frames_every": 250, "checkpoint_every": 0,
                         "snapshot": False},
              "stream": {**TINY_STREAM, "cohesion_force": "5000 nN",
                         "cohesion_range": "400 nm"}}
    with one_thread():
        run_config(config, rundir, progress="none")
    with pytest.raises(ValueError, match=r"the aperture is blocked: no grain fell .* 5000 nN "
                                         r"is 48.7 times a grain's weight .* Lower "
                                         r"stream.cohesion_force"):
        stream_study.stream_summary(rundir)


def test_measured_capture_velocity_matches_the_analytic_form() -> None:
    measured, analytic = stream_study.measured_capture_velocity(0.40, 100.0, iterations=7)
    assert measured == pytest.approx(analytic, rel=0.02)


@pytest.mark.filterwarnings("ignore:dt = .*crossing time")
@pytest.mark.parametrize("e", [0.88, 0.40])
def test_a_coarse_step_makes_the_capture_depend_on_where_in_a_step_a_contact_starts(e) -> None:
    """At F_c delta = 1e-13 J and dt = 2 us, a 100 nm shell (u_e dt / delta = 0.12) captures
    within 3 % of (2/e) sqrt(F_c delta / m) wherever in a step the contact starts; a 10 nm
    shell (1.24, past the time-step check's warning at 0.5) scatters by more than 10 % over
    the same starts, whatever e (what the warning stands on: ConstantCohesion.crossing_time)."""
    def ratios(delta_nm: float) -> np.ndarray:
        out = []
        for phase in (0.125, 0.375, 0.625, 0.875):
            measured, analytic = stream_study.measured_capture_velocity(
                e, 1e5 / delta_nm, delta_nm, iterations=9, contact_time="100 us",
                dt_fraction=0.02, start_phase=phase)
            out.append(measured / analytic)
        return np.array(out)
    resolved, coarse = ratios(100.0), ratios(10.0)
    assert np.all(np.abs(resolved - 1.0) < 0.03)
    assert coarse.std() > 0.10 and coarse.std() > 4 * resolved.std()


def test_crossover_brackets_per_restitution() -> None:
    e = np.array([0.4, 0.4, 0.4, 0.4, 0.88, 0.88, 0.61])
    fc = np.array([0.0, 30.0, 300.0, 1000.0, 30.0, 1000.0, 100.0])
    regime = ["spray", "clustering", "droplets", "droplets", "clustering", "droplets",
              "clustering"]
    assert stream_study._crossovers(e, fc, regime) == {0.4: (30.0, 300.0), 0.88: (30.0, 1000.0)}


def test_crossover_brackets_in_capture_velocity_overlap_where_one_v_c_fits_both() -> None:
    from grainflow.models.cohesion_constant import capture_velocity

    m, delta = 1.047e-8, 100e-9
    # v_c scales as sqrt(F_c)/e: 100 nN at e = 0.4 is the same v_c as 484 nN at e = 0.88
    same = capture_velocity(100e-9, delta, m, 0.4)
    assert capture_velocity(484e-9, delta, m, 0.88) == pytest.approx(same)
    speeds, common = stream_study.crossover_capture_velocities(
        {0.4: (30.0, 100.0), 0.88: (300.0, 500.0)}, delta, m)
    assert speeds[0.4] == pytest.approx((capture_velocity(30e-9, delta, m, 0.4), same))
    assert common == pytest.approx((capture_velocity(300e-9, delta, m, 0.88), same))
    _, apart = stream_study.crossover_capture_velocities(
        {0.4: (30.0, 100.0), 0.88: (1000.0, 2000.0)}, delta, m)
    assert apart is None
    assert stream_study.crossover_capture_velocities({}, delta, m) == ({}, None)


def _traced(dz0: float, dv0: float) -> Any:
    from grainflow.analysis.stream import TracedPair

    times = np.array([0.0, 1e-3, 2e-3])
    return TracedPair(upper_ids=np.arange(30), lower_ids=np.arange(30, 60), identified_at=0.3,
                      times=times, dz=dz0 + dv0 * times, centre_depth=0.1 * times - 1e-4,
                      t0=1e-3, dz0=dz0, initial_velocity=dv0, initial_velocity_err=1e-4,
                      final_velocity=dv0, final_velocity_err=1e-4, n_grains_mean=80.0,
                      predicted_velocity=dv0)


def test_toy_model_section_fits_sigma_and_draws_it(tmp_path: Path) -> None:
    from grainflow.analysis.stream import ApertureLength
    from grainflow.studies.stream_study import _toy_model_section

    sigma = 2.0  # N/m^2
    forces_nN = np.array([300.0, 1000.0, 2000.0])
    sep = _traced(3e-4, 0.014)
    lengths = {k: (ApertureLength(math.sqrt(f * 1e-9 / sigma), 2e-5, 3), [sep, sep])
               for k, f in enumerate(forces_nN)}
    text = "\n".join(_toy_model_section(lengths, np.full(3, 0.4), forces_nN, 200e-6,
                                        tmp_path, {0.4: (30.0, 300.0)}))
    assert "Sigma = 2e+03" in text and "F* = Sigma d^2 = 80 nN" in text
    assert "30-300 nN at e = 0.4" in text and "| 0.4 | 1000 | 3 |" in text
    assert "| 1.4 ± 0 |" in text  # the pairs' initial separation velocity, cm/s
    assert (tmp_path / "toy_model.png").stat().st_size > 0
    one = _toy_model_section({0: lengths[0]}, np.full(3, 0.4), forces_nN, 200e-6,
                             tmp_path / "x", {})
    assert any("not made" in line for line in one)


def test_separation_gradient_section_pools_the_streams_and_draws_the_fit(tmp_path: Path) -> None:
    """The report's gradient pools every droplet stream's traced pairs (the seed's pairs
    collapse whatever F_c) and compares g d / V with g d / v0 from the streams' own
    speeds."""
    from grainflow.analysis.stream import GRAVITY
    from grainflow.studies.stream_study import _separation_gradient_section

    speed, d = 0.15, 200e-6

    def pair(dz0: float) -> Any:
        return _traced(dz0, math.sqrt(speed ** 2 + 2 * GRAVITY * dz0) - speed)

    lengths = {0: (None, [pair(1e-3), pair(2e-3)]), 2: (None, [pair(4e-3)])}
    summaries = [{"v0": 0.16, "v0_superficial": 0.11}, {}, {"v0": 0.16, "v0_superficial": 0.11}]
    fit, lines = _separation_gradient_section(lengths, d, summaries, tmp_path)
    assert fit.pairs == 3 and fit.speed == pytest.approx(speed, rel=1e-6)
    text = "\n".join(lines)
    assert f"g d / V = {100 * GRAVITY * d / speed:.3g}" in text and "of 2 streams" in text
    assert f"g d / v0 = {100 * GRAVITY * d / 0.16:.3g} cm/s" in text
    assert (tmp_path / "separation_gradient.png").stat().st_size > 0
    assert _separation_gradient_section({0: (None, [pair(1e-3)])}, d, summaries,
                                        tmp_path) == (None, [])
