"""Hysteretic constant-force cohesion (SPEC M2, seed 000).

Once a pair has touched, a constant attraction ``F_c`` acts while the surface gap is in
``[0, delta_c)``; it is absent on first approach and forgotten once the gap exceeds
``delta_c``. A head-on pair of equal masses ``m`` (meff = m/2) leaves contact with relative
speed ``e v`` and must pay ``W = F_c delta_c`` to escape, so it is captured when
``meff (e v)^2 / 2 < F_c delta_c``, i.e. below ``v_c = (2/e) sqrt(F_c delta_c / m)``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import approach_speed, gap_of, two_grains
from grainflow.engine.simulation import Simulation
from grainflow.models.granular import GranularLaw, stiffness_and_damping

pytestmark = pytest.mark.usefixtures("numba_one_thread")

E = 0.75
TC = 0.01
FC = 10.0
DELTA_C = 1.0e-3
M = 1.0
DT = TC / 500
SKIN = 0.1  # >> delta_c: the pair stays in the neighbour list throughout


def _law() -> GranularLaw:
    kn, gamma_n = stiffness_and_damping(E, TC, 0.5 * M, "mass")
    law = GranularLaw()
    law.set_all(kn=kn, gamma_n=gamma_n, mu=0.5, cohesion_force=FC, cohesion_range=DELTA_C)
    return law


def v_capture() -> float:
    return 2.0 / E * math.sqrt(FC * DELTA_C / M)


def _pair(dim: int, v_rel: float, gap: float = 4.37 * DT) -> Simulation:
    return two_grains(dim, _law(), dt=DT, v_rel=v_rel, gap=gap, masses=(M, M), skin=SKIN)


def captured(dim: int, v_rel: float) -> bool:
    """Launch a pair at ``v_rel``: True if it turns back inside the shell after its first
    contact (captured), False if it leaves the shell receding (escaped)."""
    sim = _pair(dim, v_rel)
    rec = {"touched": False, "left_contact": False, "outcome": None}

    def watch(s: Simulation) -> None:
        g = gap_of(s)
        u = approach_speed(s)
        if g < 0:
            rec["touched"] = True
        elif rec["touched"]:
            rec["left_contact"] = True
            if g >= DELTA_C and u < 0:
                rec["outcome"] = False
            elif u > 0:  # approaching again without having left the shell
                rec["outcome"] = True

    sim.add_observer(watch)
    sim.run(50_000, until=lambda s: rec["outcome"] is not None)
    assert rec["outcome"] is not None, "neither captured nor escaped"
    assert sim.neighbors.n_pairs == 1
    return rec["outcome"]


@pytest.mark.parametrize("dim", [2, 3])
def test_capture_velocity_by_bisection(dim):
    vc = v_capture()
    lo, hi = 0.5 * vc, 1.5 * vc
    assert captured(dim, lo) is True
    assert captured(dim, hi) is False
    for _ in range(9):
        mid = 0.5 * (lo + hi)
        if captured(dim, mid):
            lo = mid
        else:
            hi = mid
    threshold = 0.5 * (lo + hi)
    assert threshold == pytest.approx(vc, rel=0.02), (threshold, vc)


def test_escape_speed_matches_energy_balance():
    """Above v_c the pair escapes with the speed left after paying W = F_c delta_c:
    meff v_out^2 / 2 = meff (e v)^2 / 2 - F_c delta_c."""
    v = 2.0 * v_capture()
    sim = _pair(3, v)
    sim.run(5000, until=lambda s: gap_of(s) > 2 * DELTA_C)
    assert gap_of(sim) > 2 * DELTA_C
    v_out = -approach_speed(sim)
    expected = math.sqrt((E * v) ** 2 - 2 * FC * DELTA_C / (0.5 * M))
    assert v_out == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize("dim", [2, 3])
def test_no_force_on_first_approach(dim):
    """Approaching grains inside the shell (0 < s < delta_c) before their first touch feel
    exactly nothing; after a touch, the same gap gives exactly F_c."""
    sim = _pair(dim, v_rel=0.05, gap=0.9 * DELTA_C)
    st = sim.state
    seen = []

    def watch(s: Simulation) -> None:
        g = gap_of(s)
        if g > 0 and not any(gg < 0 for gg, _ in seen):
            seen.append((g, s.state.force.copy()))
        else:
            seen.append((g, None))

    sim.compute_forces(update=False)
    assert sim.neighbors.n_pairs == 1
    assert np.all(st.force == 0.0)
    sim.add_observer(watch)
    sim.run(2000, until=lambda s: gap_of(s) < 0)
    before_touch = [f for g, f in seen if f is not None]
    assert len(before_touch) > 10  # many steps inside the shell before touching
    for f in before_touch:
        assert np.all(f == 0.0)
    assert gap_of(sim) < 0
    # now touched: pull the pair back into the shell by hand (same history) and look
    i, j = np.argsort(st.id)
    st.v[:] = 0.0
    st.x[j, 0] = st.x[i, 0] + st.radius[i] + st.radius[j] + 0.5 * DELTA_C
    sim.compute_forces(update=False)
    assert st.force[i, 0] == pytest.approx(FC, rel=1e-12)   # i pulled towards +x (to j)
    assert st.force[j, 0] == pytest.approx(-FC, rel=1e-12)
    # beyond the shell: no force even though the pair has touched
    st.x[j, 0] = st.x[i, 0] + st.radius[i] + st.radius[j] + 1.01 * DELTA_C
    sim.compute_forces(update=False)
    assert np.all(st.force == 0.0)


@pytest.mark.parametrize("dim", [2, 3])
def test_pair_forgets_after_leaving_shell(dim):
    """A pair that touched and separated beyond delta_c feels no force when it comes back
    into the shell from outside: the "touched" state is forgotten by the law (the pair stays
    in the neighbour list the whole time, so the list is not what forgets)."""
    sim = _pair(dim, v_rel=2.0 * v_capture())
    st = sim.state
    sim.run(5000, until=lambda s: gap_of(s) > 1.5 * DELTA_C)
    assert gap_of(sim) > 1.5 * DELTA_C and approach_speed(sim) < 0
    assert sim.neighbors.n_pairs == 1
    assert np.all(sim.interactions[0].history[:, 3] == 0.0)
    # turn around and come back
    st.v[:] *= -1.0
    forces = []
    sim.add_observer(lambda s: forces.append((gap_of(s), s.state.force.copy())))
    sim.run(5000, until=lambda s: gap_of(s) < 0)
    assert sim.neighbors.n_pairs == 1
    inside = [f for g, f in forces if 0 < g < DELTA_C]
    assert len(inside) > 5
    for f in inside:
        assert np.all(f == 0.0)


def test_cohesion_validation_messages():
    law = GranularLaw()
    with pytest.raises(ValueError, match="cohesion_range"):
        law.set_all(kn=1.0, cohesion_force=1.0)
    with pytest.raises(ValueError, match="cohesion_force"):
        law.set_all(kn=1.0, cohesion_force=-1.0, cohesion_range=0.1)
    law.set_all(kn=1.0, cohesion_force=1.0, cohesion_range=0.25)
    assert law.reach() == 0.25
