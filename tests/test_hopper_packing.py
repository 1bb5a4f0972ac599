"""The authors' dense start of the hopper (``initial_packing = "inflated"``,
grainflow.scenarios.hopper_packing): random positions relaxed by FIRE with radii x 1.2, then
restored."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError
from scipy.spatial import cKDTree

from grainflow.scenarios.hopper import HopperSection, build_hopper, prepare

SMALL = dict(convention="authors", n=400, width=20.0, orifice_width=4.0, lam=0.0)


def _grains(section: HopperSection, dim: int = 2, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    sim = build_hopper(section, dim, seed=seed)
    order = np.argsort(sim.state.arrays["id"])
    return sim.state.positions[order].copy(), sim.state.radius[order].copy()


def _pair_gaps(x: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Surface gaps of the pairs closer than two large diameters, over sigma_ij = r_i + r_j."""
    pairs = cKDTree(x).query_pairs(4.0 * float(r.max()), output_type="ndarray")
    sigma = r[pairs].sum(axis=1)
    return (np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) - sigma) / sigma


def test_inflated_start_is_dense_touches_nothing_and_stays_inside() -> None:
    """Built with the authors' convention, no two grains lie closer than 0.2 sigma_ij (they
    were relaxed at 1.2 r, up to FIRE's residual), none touches a wall, and the pile is ~0.58
    dense; the sequential fill is 0.45 dense with grains nearly touching."""
    section = HopperSection(**SMALL)
    assert section.resolved_options()["initial_packing"] == "inflated"
    x, r = _grains(section)
    gaps = _pair_gaps(x, r)
    assert gaps.min() > 0.19
    half = 0.5 * 20.0
    assert np.all(np.abs(x[:, 0]) + r <= half + 1e-9) and np.all(x[:, 1] - r >= -1e-9)
    # at 1.2 r the packing is near jamming: about four near contacts a grain
    assert 3.0 < 2.0 * np.sum(gaps < 0.21) / r.size < 4.5
    dense = float(np.sum(np.pi * r**2)) / (20.0 * float((x[:, 1] + r).max()))
    assert dense > 0.5

    xs, rs = _grains(HopperSection(**{**SMALL, "initial_packing": "sequential"}))
    loose = float(np.sum(np.pi * rs**2)) / (20.0 * float((xs[:, 1] + rs).max()))
    assert loose < 0.47
    assert _pair_gaps(xs, rs).min() < 0.05


def test_inflated_start_in_3d_touches_nothing() -> None:
    section = HopperSection(convention="authors", n=300, width=10.0, orifice_width=3.0,
                            lam=0.0)
    x, r = _grains(section, dim=3)
    assert _pair_gaps(x, r).min() > 0.19
    assert np.all(np.hypot(x[:, 0], x[:, 1]) + r <= 5.0 + 1e-9)
    assert np.all(x[:, 2] - r >= -1e-9)


def test_inflated_start_is_reproducible_from_the_seed() -> None:
    section = HopperSection(**SMALL)
    a, _ = _grains(section, seed=3)
    b, _ = _grains(section, seed=3)
    c, _ = _grains(section, seed=4)
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)


def test_run_minimize_leaves_the_inflated_start_as_it_is() -> None:
    """``run.minimize`` (FIRE for overlaps) finds nothing to do after the inflated start."""
    sim = build_hopper(HopperSection(**SMALL), 2)
    ids = sim.state.arrays["id"]
    before = sim.state.positions[np.argsort(ids)].copy()
    result = prepare(sim)
    assert result.converged and result.steps == 0
    ids = sim.state.arrays["id"]  # FIRE's first list build may re-sort the grains
    assert np.array_equal(sim.state.positions[np.argsort(ids)], before)


def test_packing_options_are_checked() -> None:
    with pytest.raises(ValidationError, match="fill_fraction.*inflated"):
        HopperSection(fill_fraction=0.65)  # sequential (grainflow's default)
    HopperSection(convention="authors", fill_fraction=0.65)
    with pytest.raises(ValueError, match="hopper.fill_fraction.*inflate"):
        build_hopper(HopperSection(convention="authors", fill_fraction=0.7, n=50), 2)
    with pytest.raises(ValidationError, match="initial_packing"):
        HopperSection(particles="dp_rough", initial_packing="inflated")
    with pytest.raises(ValidationError, match="inflate"):
        HopperSection(convention="authors", inflate=1.0)
    with pytest.raises(ValidationError, match="inflate: applies to initial_packing"):
        HopperSection(inflate=1.3)  # grainflow's sequential fill


def test_a_fire_that_does_not_settle_warns(monkeypatch: pytest.MonkeyPatch) -> None:
    """Cut short, the inflated packing's FIRE says so; what still overlaps is left to
    ``run.minimize``, which removes it."""
    import grainflow.scenarios.hopper_packing as packing

    monkeypatch.setattr(packing, "MAX_FIRE_STEPS", 20)
    with pytest.warns(RuntimeWarning, match="inflated packing's FIRE stopped after 20 steps"):
        sim = build_hopper(HopperSection(**SMALL), 2)
    assert prepare(sim).converged
