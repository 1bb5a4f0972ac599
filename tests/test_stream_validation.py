"""Validation (slow, ``-m validation``, about 8 minutes on 2 cores): the seed-000 stream at its
aperture (d = 200 um, D = 3 mm) in the reduced study's hopper (D_h = 5 mm, H = 3 mm), without
cohesion, followed to 2 cm.

- The outflow follows Beverloo's law, Q = C rho_b sqrt(g) (D - k d)^(5/2), with the usual
  C = 0.58, k = 1.5 and rho_b = 0.6 rho, within 10 %.
- Below the aperture, the mean axial speed follows free fall, v(z) = sqrt(v0^2 + 2 g z),
  within 3 %.
- A cohesionless stream is a spray: its network size tends to 1.
- The contact time (k_n is NF in the seed) does not change the outflow or v0: t_c = 50 us and
  100 us agree within 5 %.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from grainflow.analysis.stream import (aperture_speed, contact_profiles, outflow_steadiness,
                                       stream_grains)
from grainflow.scenarios.stream import GRAVITY, StreamSection, grain_mass

pytestmark = pytest.mark.validation

STREAM = dict(hopper_diameter="5 mm", fill_height="3 mm", restitution=0.88,
              open_time="0.05 s", stream_depth="2 cm")


@functools.lru_cache(maxsize=None)
def _run(contact_time: str, tmp: str) -> tuple[list, StreamSection]:
    from pathlib import Path

    from grainflow.io.h5md import read_frames
    from grainflow.runner import run_config

    rundir = Path(tmp) / contact_time.replace(" ", "")
    config = {"scenario": "stream", "dim": 3, "run": {"duration": 0.13, "seed": 1},
              "output": {"thermo_every": 5000, "frames_every": int(round(1e-3 / (
                  0.02 * StreamSection(contact_time=contact_time).contact_time))),
                  "frames_from": 0.1, "checkpoint_every": 0, "snapshot": False},
              "stream": {**STREAM, "contact_time": contact_time}}
    run_config(config, rundir, progress="none")
    return list(read_frames(rundir / "frames.h5")), StreamSection(**config["stream"])


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> str:
    return str(tmp_path_factory.mktemp("stream_validation"))


def _beverloo(s: StreamSection) -> float:
    """Grains per second through the aperture (C = 0.58, k = 1.5, rho_b = 0.6 rho)."""
    rate = 0.58 * 0.6 * s.density * math.sqrt(GRAVITY) * (
        s.aperture_diameter - 1.5 * s.grain_diameter) ** 2.5
    return rate / grain_mass(s)


def test_outflow_follows_beverloo_and_the_stream_falls_freely(tmp: str) -> None:
    frames, s = _run("100 us", tmp)
    flow = outflow_steadiness(frames)
    assert flow.mean_rate == pytest.approx(_beverloo(s), rel=0.10)
    assert flow.cv < 0.2
    v0 = aperture_speed(frames).v0
    depth = np.concatenate([-f.position[f.position[:, 2] < 0, 2] for f in frames])
    vz = np.concatenate([-f.velocity[f.position[:, 2] < 0, 2] for f in frames])
    for z in (0.003, 0.006, 0.010, 0.014, 0.018):
        band = np.abs(depth - z) < 0.5e-3
        assert band.sum() > 200
        assert vz[band].mean() == pytest.approx(math.sqrt(v0**2 + 2 * GRAVITY * z), rel=0.03)
    net = contact_profiles([stream_grains(f) for f in frames], s.cohesion_range,
                           depth_range=(0.0, s.stream_depth), network_bin=2e-3).network_size
    deep = (net.centres > 0.01) & (net.count > 0)
    assert np.all(net.mean[deep] < 1.1)


def test_contact_time_does_not_change_the_flow(tmp: str) -> None:
    coarse, _ = _run("100 us", tmp)
    fine, _ = _run("50 us", tmp)
    assert outflow_steadiness(fine).mean_rate == pytest.approx(
        outflow_steadiness(coarse).mean_rate, rel=0.05)
    assert aperture_speed(fine).v0 == pytest.approx(aperture_speed(coarse).v0, rel=0.05)
