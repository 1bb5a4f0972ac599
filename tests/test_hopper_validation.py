"""Validation (slow, ``-m validation``): a short real 2D Q(w) in the lambda -> inf limit and its
Beverloo exponent against seed 003 (beta = d - 3/2 = 1/2, issue tolerance +/- 0.15)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainflow.analysis.hopper import fit_beverloo, flow_rate_from_events
from grainflow.scenarios.hopper import HopperSection, build_hopper, hopper_updater, prepare

pytestmark = pytest.mark.validation


def _flow_rate(w: float, duration: float, dt_scale: float = 1.0) -> tuple[float, float]:
    section = HopperSection(n=1600, orifice_width=w, E_sp=1000.0, E_w=1000.0, lam=math.inf,
                            dt_fraction=0.05 * dt_scale)
    sim = build_hopper(section, 2, seed=0)
    prepare(sim)
    sim.run(int(math.ceil(duration / sim.dt)))
    up = hopper_updater(sim)
    flow = flow_rate_from_events(up.event_times, up.event_sizes, t_begin=0.0, t_end=sim.time)
    return flow.flow_rate, flow.flow_rate_err


def test_beverloo_exponent_drag_limit_2d() -> None:
    widths = [4.0, 6.0, 8.0, 10.0]
    rates = [_flow_rate(w, 300.0) for w in widths]
    fit = fit_beverloo(widths, [q for q, _ in rates], Q_err=[e for _, e in rates])
    assert abs(fit.beta - 0.5) <= 0.15, (fit, rates)


def test_halving_dt_keeps_flow_rate() -> None:
    q1, e1 = _flow_rate(8.0, 300.0)
    q2, e2 = _flow_rate(8.0, 300.0, dt_scale=0.5)
    assert abs(q1 - q2) <= 3.0 * np.hypot(e1, e2), (q1, e1, q2, e2)
