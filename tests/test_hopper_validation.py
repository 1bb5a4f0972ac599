"""Validation (slow, ``-m validation``, about 27 minutes on 2 cores; the authors'-path tests
about 11 minutes of it, 7 in two workers): short real 2D Q(w)
series and their Beverloo exponents against seed 003 (issue tolerance +/- 0.15 in 2D).

The drag-limit series run 800 t0: the drag-limited pile settles only after about 300 t0
(MSER cuts at 250-400 t0), so a 500 t0 record leaves ~150 t0 of steady flow and its beta
depends on the realization: two runs that differ only by floating-point rounding (the same
model before and after the engine's sub-model refactor) gave 0.51 and 0.87 +/- 0.16 at
500 t0, and 0.62 +/- 0.06 (bulk rule) / 0.51 +/- 0.04 (column rule) at 800 t0.

- drag limit (lambda -> inf): beta = d - 3/2 = 1/2;
- friction limit (lambda -> 0): beta = d - 1/2 = 3/2. Known discrepancy with the printed
  seed's mu/mu0 = 10 sqrt(10): beta near 2.2-2.5 (docs/hopper_study.md, "Friction limit"),
  xfail(strict). On the authors' path (``convention = "authors"``, mu/mu0 = 8.5 from their
  code, their dense start, docs/hopper_study.md "Second pass") the free fit gives 1.92 +- 0.07
  (1.78 with another seed; 1.84 and 1.69 at the 2D skin before 2026-12-08), still outside
  3/2 +- 0.15 (xfail(strict)): at N = 1600 the soft
  pile drains as a viscous, pressure-driven flow. The paper's own bounded fit (beta <= 1.58,
  k >= 0.5) lands on 1.58, its bound, within the tolerance; and a pile twice as tall
  (N = 3200) gives the seed's 3/2 in a free fit;
- the time step and the reinsertion rule (bulk partner or top of the column) are choices
  where the seed is unreadable: halving dt must leave Q unchanged, and the two reinsertion
  rules should give the same beta within the fits' uncertainties; they do not (by about
  0.2 at 800 t0, both within the tolerance: xfail(strict), its reason gives the numbers).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from grainflow.analysis.hopper import BeverlooFit, fit_beverloo, flow_rate_from_events
from grainflow.scenarios.hopper import HopperSection, build_hopper, hopper_updater, prepare

pytestmark = pytest.mark.validation

WIDTHS = [4.0, 6.0, 8.0, 10.0]


def _flow_rate(w: float, duration: float, dt_scale: float = 1.0, **section) -> tuple[float, float]:
    params = dict(n=1600, orifice_width=w, E_sp=1000.0, E_w=1000.0, lam=math.inf,
                  dt_fraction=0.05 * dt_scale)
    sim = build_hopper(HopperSection(**{**params, **section}), 2, seed=0)
    prepare(sim)
    sim.run(int(math.ceil(duration / sim.dt)))
    up = hopper_updater(sim)
    flow = flow_rate_from_events(up.event_times, up.event_sizes, t_begin=0.0, t_end=sim.time)
    return flow.flow_rate, flow.flow_rate_err


@functools.cache
def _beverloo(duration: float, **section) -> BeverlooFit:
    rates = [_flow_rate(w, duration, **section) for w in WIDTHS]
    return fit_beverloo(WIDTHS, [q for q, _ in rates], Q_err=[e for _, e in rates])


#: Flow time of the drag-limit series (module docstring).
DRAG_LIMIT_T = 800.0


def test_beverloo_exponent_drag_limit_2d() -> None:
    fit = _beverloo(DRAG_LIMIT_T)
    assert abs(fit.beta - 0.5) <= 0.15, fit


@pytest.mark.xfail(strict=True, reason="first pass (printed mu/mu0 = 10 sqrt(10)): beta ~ "
                   "2.2-2.5 in the friction limit against the seed's 3/2; the authors' mu/mu0 = "
                   "8.5 gives 1.84 (docs/hopper_study.md, 'Second pass')")
def test_beverloo_exponent_friction_limit_2d() -> None:
    fit = _beverloo(150.0, lam=0.0)
    assert abs(fit.beta - 1.5) <= 0.15, fit


#: The authors' path: their widths' span (3.0-10.6 sigma_avg, six of their 20) and run length.
AUTHORS_WIDTHS = [3.0, 4.6, 6.2, 7.8, 9.4, 10.6]
AUTHORS_T = 150.0


@functools.cache
def _authors_rates(lam: float, n: int = 1600, seed: int = 0) -> tuple[tuple[float, float], ...]:
    out = []
    for w in AUTHORS_WIDTHS:
        sim = build_hopper(HopperSection(convention="authors", n=n, orifice_width=w, lam=lam),
                           2, seed=seed, max_overlap_fraction=2.0)
        prepare(sim)
        sim.run(int(math.ceil(AUTHORS_T / sim.dt)))
        up = hopper_updater(sim)
        flow = flow_rate_from_events(up.event_times, up.event_sizes, t_begin=0.0, t_end=sim.time)
        out.append((flow.flow_rate, flow.flow_rate_err))
    return tuple(out)


def _authors_fit(lam: float, n: int = 1600, seed: int = 0, **kw) -> BeverlooFit:
    rates = _authors_rates(lam, n, seed)
    return fit_beverloo(AUTHORS_WIDTHS, [q for q, _ in rates], Q_err=[e for _, e in rates], **kw)


def test_authors_path_drag_limit_2d() -> None:
    """The mean exponent of two realizations (seeds 0 and 1), as the study's replicate table
    gives it: at 150 t0 one realization's drag-limit beta moves by about 0.1 from seed to seed
    (0.65 and 0.60 from the authors' dense start, 0.66 and 0.58 at the 2D skin before
    2026-12-08; the fits' own errors are 0.04-0.06), so a single series does not measure it
    to the tolerance."""
    fits = [_authors_fit(math.inf, seed=seed) for seed in (0, 1)]
    assert abs(np.mean([f.beta for f in fits]) - 0.5) <= 0.15, fits


@pytest.mark.xfail(strict=True, reason="the free fit on the authors' path gives beta = 1.92 "
                   "+- 0.07 (1.78 with seed 1; 1.84 and 1.69 at the 2D skin before 2026-12-08) "
                   "against 3/2 +- 0.15: at N = 1600 the soft pile drains as a viscous, "
                   "pressure-driven flow (Q doubles with the pile's height; beta = 2 fits with "
                   "chi2/dof 3.8 against 20 for 3/2); docs/hopper_study.md, 'The friction "
                   "limit'")
def test_authors_path_friction_limit_2d_free_fit() -> None:
    fit = _authors_fit(0.0)
    assert abs(fit.beta - 1.5) <= 0.15, fit


def test_authors_path_friction_limit_2d_paper_fit() -> None:
    """The paper's bounded fit (beta <= 1.58, k >= 0.5): within 3/2 +- 0.15 of the seed, and
    on its upper bound, which is what the free fit's larger exponent pushes it to."""
    fit = _authors_fit(0.0, beta_bounds=(1e-6, 1.58), k_min=0.5)
    assert abs(fit.beta - 1.5) <= 0.15, fit
    assert "beta" in fit.at_bound, fit


def test_authors_path_friction_limit_2d_tall_pile() -> None:
    """With twice the grains (a column twice as tall, which doubles the flow rate at
    lambda = 0) the friction-limited flow leaves the viscous regime: the free fit gives the
    seed's 3/2 (1.46 +- 0.07 in the reduced study), below the N = 1600 exponent."""
    tall = _authors_fit(0.0, n=3200)
    assert abs(tall.beta - 1.5) <= 0.15, tall
    assert _authors_fit(0.0).beta - tall.beta > 0.15
    ratio = np.array([q for q, _ in _authors_rates(0.0, 3200)]) / np.array(
        [q for q, _ in _authors_rates(0.0)])
    assert np.all(ratio > 1.5), ratio


def test_halving_dt_keeps_flow_rate() -> None:
    q1, e1 = _flow_rate(8.0, 500.0)
    q2, e2 = _flow_rate(8.0, 500.0, dt_scale=0.5)
    assert abs(q1 - q2) <= 3.0 * np.hypot(e1, e2), (q1, e1, q2, e2)


@pytest.mark.xfail(strict=True, reason="the rule does move the drag-limit beta at 800 t0: "
                   "bulk 0.64 against column 0.42 (seed 0; bulk seeds 0-2 0.63 +- 0.02, column "
                   "seeds 0-4 0.45 +- 0.04, s.d.) at the 2D skin of 0.4 sigma_avg; at 0.1 seed "
                   "0 gave 0.62 and 0.51. Both rules stay in 1/2 +- 0.15 (docs/hopper_study.md, "
                   "'Reinsertion')")
def test_reinsertion_rule_does_not_change_beta() -> None:
    bulk = _beverloo(DRAG_LIMIT_T)  # the default rule: d + 1 = 3 bulk contacts
    column = _beverloo(DRAG_LIMIT_T, reinsert_bulk_contacts=0)
    assert abs(bulk.beta - column.beta) <= 2.0 * np.hypot(bulk.beta_err, column.beta_err), (
        bulk, column)


def test_a_tall_pile_at_the_friction_limit_runs_from_the_authors_start() -> None:
    """N = 3200 (a pile twice the seed's height) at lambda = 0: from the loose sequential fill
    (packing 0.45) the grains fall onto the pile and compress pairs past twice the small
    radius, and the run stops on the overlap check; from the authors' dense start
    (``initial_packing = "inflated"``) it flows (about 40 s)."""
    from grainflow.engine.simulation import InstabilityError

    def run(packing: str) -> None:
        section = HopperSection(convention="authors", n=3200, orifice_width=10.6, lam=0.0,
                                initial_packing=packing)
        sim = build_hopper(section, 2, seed=0, max_overlap_fraction=2.0)
        prepare(sim)
        sim.run(int(math.ceil(30.0 / sim.dt)))
        assert len(hopper_updater(sim).event_times) > 500

    with pytest.raises(InstabilityError, match="overlap"):
        run("sequential")
    run("inflated")
