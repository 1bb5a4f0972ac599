"""The compiled step loop (:mod:`grainflow.engine.fast_path`) gives bitwise the result of
stepping in Python, for every kind of operation that offers one, and steps in Python when an
operation does not.

Each case runs the same set-up twice, once with the compiled loop switched off
(``fast_path_min_steps`` above the run's length) and once with it on from the first step,
and compares positions, velocities, spins, forces, contact histories and the clock bit for
bit; it also checks that the loop really took most of the steps and that the neighbour list
was rebuilt in between (the loop hands those steps back to Python).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
import pytest

from conftest import build_pile, two_law_disks
from grainflow.engine.forces import Gravity
from grainflow.engine.integrators import AdamsBashforth2
from grainflow.engine.simulation import Simulation
from grainflow.walls.force import WallForce
from grainflow.walls.geometry import Plane

pytestmark = pytest.mark.usefixtures("numba_one_thread")


def _chute() -> Simulation:
    from grainflow.scenarios.chute import chute_cut

    return chute_cut(0.25, 0.25)


def _hopper(dim: int) -> Callable[[], Simulation]:
    def build() -> Simulation:
        from grainflow.scenarios.hopper import HopperSection, build_hopper, prepare

        shape = dict(n=400, orifice_width=6.0) if dim == 2 else dict(n=200, width=8.0,
                                                                      orifice_width=3.0)
        section = HopperSection(**shape, E_sp=1000.0, E_w=1000.0,
                                lam=math.inf if dim == 2 else 1.0)
        sim = build_hopper(section, dim, seed=1)
        prepare(sim)
        sim.add_observer(lambda ctx: ctx.state.kinetic_energy(), 37)  # an event every 37
        return sim
    return build


def _smooth_dp_hopper() -> Simulation:
    """Seven operations: force zeroing (no pair interaction), ring shape, edge contacts, two
    wall sets, gravity and drag."""
    from grainflow.scenarios.hopper import HopperSection, build_hopper, prepare

    section = HopperSection(convention="authors", particles="dp_smooth", n=16, width=8.0,
                            orifice_width=4.0, lam=math.inf, dt_fraction=0.15)
    sim = build_hopper(section, 2, seed=2)
    prepare(sim)
    return sim


def _two_laws_and_a_moving_wall() -> Simulation:
    """A granular law and a soft law on different type pairs, a static floor and a wall
    pushing in from the side at constant speed (time-dependent wall position)."""
    st, granular, soft = two_law_disks(8.0, False, 200)
    sim = Simulation(st, 2e-4, granular)
    sim.add_interaction(soft, types=[(1, 1)])
    sim.add_force(WallForce([Plane((0, 0), (0, 1)), Plane((-6.0, 0), (1, 0), velocity=(2.0, 0))],
                            granular, 2))
    sim.add_force(Gravity([0.0, -10.0]))
    return sim


CASES = {
    "chute cut (pairs, gravity, periodic)": (_chute, 2000),
    "cohesive pile (history, cohesion, re-sorting)": (lambda: build_pile(), 2000),
    "2D hopper (walls, drag, reinsertion, observer)": (_hopper(2), 3000),
    "3D hopper (cylinder, cone, kinetic friction)": (_hopper(3), 1500),
    "two laws and a moving wall": (_two_laws_and_a_moving_wall, 2000),
    "smooth DP hopper (seven operations)": (_smooth_dp_hopper, 3000),
}


def _run(build: Callable[[], Simulation], steps: int, fast: bool, threads: int = 1
         ) -> Simulation:
    sim = build()
    sim.fast_path_min_steps = 0 if fast else 10**12
    sim.threads = threads
    sim.run(steps)
    return sim


def _by_id(sim: Simulation, a: np.ndarray) -> np.ndarray:
    return a[np.argsort(sim.state.id)]


def _assert_same(a: Simulation, b: Simulation) -> None:
    assert a.step == b.step and a.time == b.time
    assert np.array_equal(a.state.id, b.state.id)  # same re-sorting, same order
    for name in ("x", "v", "omega", "force", "torque"):
        assert np.array_equal(getattr(a.state, name), getattr(b.state, name)), name
    for ia, ib in zip(a.interactions, b.interactions):
        assert np.array_equal(ia.history, ib.history)
    for name in a.state.arrays:
        if name.startswith("wall_history_"):
            assert np.array_equal(a.state.arrays[name], b.state.arrays[name]), name


@pytest.mark.parametrize("case", list(CASES))
def test_compiled_steps_are_bitwise_python_steps(case: str) -> None:
    build, steps = CASES[case]
    python = _run(build, steps, False)
    compiled = _run(build, steps, True)
    assert python._fast_path.steps_done == 0
    assert compiled._fast_path.steps_done > steps // 2
    assert compiled.rebuilds > 2  # steps that needed a new list went back to Python
    _assert_same(python, compiled)
    if case == "two laws and a moving wall":
        from grainflow.frame import WALL

        c = compiled.contacts()
        assert np.sum((c.kind == WALL) & (c.j == 1)) >= 3  # the moving wall does push


def _rough_dp_hopper() -> Simulation:
    """Rough deformable rings reinserted whole (:class:`RingReinsertion`)."""
    from grainflow.scenarios.hopper import HopperSection, build_hopper, prepare

    section = HopperSection(convention="authors", particles="dp_rough", n=40, width=8.0,
                            orifice_width=5.0, lam=math.inf, dt_fraction=0.15)
    sim = build_hopper(section, 2, seed=5)
    prepare(sim)
    return sim


@pytest.mark.parametrize("case", ["grains", "rings"])
def test_an_updater_that_edits_in_place_keeps_the_step_calls(monkeypatch, case) -> None:
    """The hopper's reinsertion (every 10 steps) relocates grains, or whole rings, in place:
    the compiled loop collects its step calls again only when the list or the particle set
    changes, with the same result, bit for bit, as collecting them after every action."""
    from grainflow.scenarios.hopper import hopper_updater
    from grainflow.scenarios.hopper_reinsertion import HopperReinsertion
    from grainflow.scenarios.hopper_rings import RingReinsertion

    build, updater, steps = ((_hopper(2), HopperReinsertion, 13000) if case == "grains"
                             else (_rough_dp_hopper, RingReinsertion, 15000))
    kept = _run(build, steps, True)
    assert hopper_updater(kept).reinserted >= 2  # relocations happened
    # (other updaters, such as the rings' lid, still renew them when they act)
    others = sum(steps // u.every for u in kept.updaters
                 if not getattr(u.owner, "keeps_step_calls", False))
    assert kept._fast_path.collections <= kept.rebuilds + others + 2
    monkeypatch.setattr(updater, "keeps_step_calls", False)
    renewed = _run(build, steps, True)
    assert renewed._fast_path.collections >= steps // 10 // 2
    assert kept._fast_path.collections < renewed._fast_path.collections / 2
    _assert_same(kept, renewed)


@pytest.mark.parametrize("threads", [1, 2])
def test_contacts_read_between_compiled_runs_are_those_of_the_last_step(threads: int) -> None:
    """The compiled loop stores each pair's force only on the last step of a run of steps
    (the pair loop's ``keep``); whatever Python reads after it, an observer's contacts or
    the simulation's, must still be the last step's, bitwise as stepping in Python gives."""
    import numba

    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip("numba was started with a single thread")

    def build() -> Simulation:
        sim = _chute()
        seen = sim.seen = []
        sim.add_observer(lambda ctx: seen.append(ctx.contacts()), 23)
        return sim

    python = _run(build, 400, False, threads)
    compiled = _run(build, 400, True, threads)
    assert compiled._fast_path.steps_done > 200
    assert len(python.seen) == len(compiled.seen) == 400 // 23
    for a, b in zip(python.seen + [python.contacts()], compiled.seen + [compiled.contacts()]):
        assert a.i.size > 100
        for name in ("i", "j", "kind", "force", "branch"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_compiled_steps_on_two_threads_are_bitwise_one_thread() -> None:
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba was started with a single thread")
    build, steps = CASES["cohesive pile (history, cohesion, re-sorting)"]
    one = _run(build, steps, True, threads=1)
    two = _run(build, steps, True, threads=2)
    assert two._fast_path.steps_done > steps // 2
    _assert_same(one, two)


def test_an_operation_without_a_compiled_step_steps_in_python() -> None:
    """AB2 has no compiled halves: the run steps in Python, with the same result as ever."""
    sim = build_pile(integrator=AdamsBashforth2())
    sim.fast_path_min_steps = 0
    sim.run(300)
    assert sim._fast_path.steps_done == 0 and sim.step == 300


def test_until_is_asked_every_until_every_steps() -> None:
    sim = build_pile()
    sim.fast_path_min_steps = 0
    asked = []
    sim.run(1000, until=lambda s: asked.append(s.step) or s.step >= 420, until_every=20)
    assert sim.step == 420 and asked == list(range(20, 421, 20))
    assert sim._fast_path.steps_done > 300
    with pytest.raises(ValueError, match="until_every"):
        sim.run(10, until=lambda s: False, until_every=0)


def test_step_calls_compile_no_literal_specialisations() -> None:
    """A constant passed from an adapter (``update=True``) would type as a literal and
    compile the pair or wall kernel a second time, for that constant (seconds each, cold)."""
    from grainflow.kernels.specialize import serial

    sim = _run(_hopper(2), 200, True)
    kernels = [serial(k) for i in sim.interactions for k in i._kernels.values()]
    kernels += [serial(f._kernel) for f in sim.forces if isinstance(f, WallForce)]
    assert len(kernels) >= 2
    for kernel in kernels:
        assert kernel.signatures
        assert not any("Literal" in str(sig) for sig in kernel.signatures), kernel
