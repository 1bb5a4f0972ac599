"""Runs of time steps without Python in between: one compiled loop over the operations.

Between two *events* (an updater, observer, health check or thread-choice window due, the
end of the run) and as long as the neighbour list holds, a step is always the same calls:
the integrator's first half, the list's displacement check, every force operation's
update, the integrator's second half, the clock. Done from Python, each call costs a few
microseconds of dispatch, which on the seeds' system sizes (1,600 to 20,000 grains) is as
much as the arithmetic. :class:`FastPath` instead runs those calls for ``k`` steps in one
compiled function, :func:`_run_steps`, specialised (:mod:`grainflow.kernels.specialize`) for
the simulation's integrator and operations, each contributing a :class:`StepCall`: an
adapter compiled for it, doing exactly what its Python ``compute(ctx, update=True)`` does at
clock time ``time``, and the arrays and numbers it takes. A force operation's adapter is
``adapter(args, time, dt, last)``: ``last`` is true on the last step of the run, after
which Python reads the state, so an operation may skip records only Python reads (the pair
loop's per-pair forces) on the other steps. The integrator's halves are
``adapter(args, time, dt)``. Between two steps of a run the integrator's second half and the
next step's first half are one call (for velocity Verlet one pass over the particles
instead of two, adding the same terms in the same order). The same kernels run in the same
order on the same arrays, so a run is bitwise the same either way (tests/test_fast_path.py).

The loop stops early, returning control to Python, after the first half of a step after
which the list may miss a pair (:mod:`grainflow.kernels.list_check`: some particle has moved
more than half the skin, or under the relative check some pair the skin against each other):
that step is finished in Python, where the list is rebuilt. An operation without a step call (or more than :data:`SLOTS` of them) means
the simulation steps in Python, as before.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numba
from numba import njit

from grainflow.kernels.list_check import stale_kernel
from grainflow.kernels.specialize import serial, specialize

#: Force operations (pair interactions first) one compiled loop can hold: the smooth DP
#: hopper has seven (force zeroing, shape, edges, two wall sets, gravity, drag).
SLOTS = 8


class StepCall(NamedTuple):
    """A compiled adapter (``(args, time, dt, last)`` for a force operation, ``(args, time,
    dt)`` for an integrator half) and the ``args`` tuple it is given."""

    adapter: Any
    args: tuple


@njit(cache=True)
def nothing(args, time, dt, last):
    """An empty slot."""


#: Whether the step calls being collected are for one thread (set by :class:`FastPath`
#: around the collection, read by :func:`kernel_for`: numba.get_num_threads costs microseconds).
_serial = {"now": False}
_ADAPTERS: dict[tuple, Any] = {}


def kernel_for(kernel: Any) -> Any:
    """The version of a parallel kernel an adapter calls at the thread count the step calls
    are collected for: the kernel itself, or on one thread its serial twin
    (:func:`~grainflow.kernels.specialize.serial`), which skips opening a parallel region."""
    return serial(kernel) if _serial["now"] else kernel


@njit(cache=True)
def _zero_forces(args, time, dt, last):
    """Set force and torque to zero (what the first pair interaction's ``FIRST`` does)."""
    args[0][:] = 0.0
    args[1][:] = 0.0


def zero_forces_call(state: Any) -> StepCall:
    """The step call that zeroes forces and torques in a simulation without pair
    interactions (Python's :meth:`~grainflow.engine.simulation.Simulation.compute_forces`
    does the same)."""
    return StepCall(_zero_forces, (state.force, state.torque))


def step_call(template: Any, name: str, args: tuple, *, serial_twins: bool = True,
              **kernels: Any) -> StepCall:
    """A :class:`StepCall` whose adapter is ``template`` with the names in ``kernels`` bound
    to those kernels (:func:`kernel_for` each: serial twins on one thread, unless
    ``serial_twins`` is False: some kernels compile to much slower code without numba's
    parallel transformation, which e.g. hoists allocations out of loops; measure first)."""
    twins = serial_twins and _serial["now"]
    key = (template, twins, *sorted((k, id(v)) for k, v in kernels.items()))
    adapter = _ADAPTERS.get(key)
    if adapter is None:
        bound = {k: kernel_for(v) if twins else v for k, v in kernels.items()}
        label = name + "_" + "_".join(getattr(v, "py_func", v).__name__
                                      for v in bound.values())
        adapter = _ADAPTERS[key] = specialize(template, label, bound)
    return StepCall(adapter, args)


def _run_steps(k, time, dt, check_args, pre_args, post_args,
               joined_args, a0, a1, a2, a3, a4, a5, a6, a7):
    """Up to ``k`` steps from clock time ``time``: ``(steps done, new time, pending)``.

    ``pending``: the last step's first half is done but the list may miss a pair
    (``STALE(check_args)``); the caller finishes that step (not counted in
    the steps done), rebuilding the list and computing every force in Python. Otherwise the
    force operations are told which step is the ``k``-th, the last. Between two steps of
    the run the second half of one and the first half of the next are one call,
    ``JOINED`` (:meth:`~grainflow.engine.operations.Integrator.step_calls`). Template:
    ``PRE``, ``POST``, ``JOINED``, ``OP0`` ... ``OP7`` and ``STALE``
    (:func:`~grainflow.kernels.list_check.stale_kernel`) are bound by :class:`FastPath`.
    """
    if k == 0:
        return 0, time, False
    PRE(pre_args, time, dt)  # noqa: F821 (bound names)
    for s in range(k):
        if STALE(check_args):  # noqa: F821
            return s, time, True
        last = s == k - 1
        OP0(a0, time, dt, last)  # noqa: F821
        OP1(a1, time, dt, last)  # noqa: F821
        OP2(a2, time, dt, last)  # noqa: F821
        OP3(a3, time, dt, last)  # noqa: F821
        OP4(a4, time, dt, last)  # noqa: F821
        OP5(a5, time, dt, last)  # noqa: F821
        OP6(a6, time, dt, last)  # noqa: F821
        OP7(a7, time, dt, last)  # noqa: F821
        if last:
            POST(post_args, time, dt)  # noqa: F821
        else:
            JOINED(joined_args, time, dt)  # noqa: F821
        time = time + dt
    return k, time, False


class FastPath:
    """The compiled step loop of one simulation's current set of operations."""

    def __init__(self) -> None:
        self._loops: dict[tuple, Any] = {}
        self._calls: tuple | None = None
        self._calls_key: tuple | None = None
        self._serial = False  # the step calls were collected for one thread
        #: Steps taken in the compiled loop so far (for tests and profiles).
        self.steps_done = 0
        #: Times the step calls were collected (for tests and profiles).
        self.collections = 0

    def forget(self) -> None:
        """Drop the step calls: something an operation reads may have been replaced (a run
        starts, an updater acted that does not say it
        :attr:`~grainflow.engine.operations.Updater.keeps_step_calls`)."""
        self._calls_key = None

    def calls(self, sim: Any
              ) -> tuple[StepCall, StepCall, StepCall, list[StepCall]] | None:
        """The integrator's two halves, the two joined, and every force's step call, or
        None when some
        operation has none (then the simulation steps in Python). Kept while the list,
        the particle set and the thread count stay (and until :meth:`forget`)."""
        threads = numba.get_num_threads()
        key = (sim.neighbors.builds, sim.state.generation, sim.state.n, threads)
        if key != self._calls_key:
            _serial["now"] = self._serial = threads == 1
            self._calls = self._collect(sim)
            self._calls_key = key
            self.collections += 1
        return self._calls

    def _collect(self, sim: Any
                 ) -> tuple[StepCall, StepCall, StepCall, list[StepCall]] | None:
        ctx = sim.context
        halves = sim.integrator.step_calls(ctx)
        zeroing = [] if sim.interactions else [zero_forces_call(sim.state)]
        if halves is None or len(zeroing) + len(sim.interactions) + len(sim.forces) > SLOTS:
            return None
        ops = zeroing + [interaction.step_call(ctx, first=k == 0)
                         for k, interaction in enumerate(sim.interactions)]
        for force in sim.forces:
            call = force.step_call(ctx)
            if call is None:
                return None
            ops.append(call)
        return halves[0], halves[1], halves[2], ops

    def run(self, sim: Any, k: int,
            calls: tuple[StepCall, StepCall, StepCall, list[StepCall]]
            ) -> tuple[int, float, bool]:
        """Up to ``k`` steps (see :func:`_run_steps`); the caller advances the clock."""
        pre, post, joined, ops = calls
        ops = ops + [StepCall(nothing, ())] * (SLOTS - len(ops))
        nl = sim.neighbors
        stale = stale_kernel(nl.relative, self._serial)
        key = (pre.adapter, post.adapter, joined.adapter, stale,
               *(op.adapter for op in ops))
        loop = self._loops.get(key)
        if loop is None:
            bindings = {"PRE": pre.adapter, "POST": post.adapter, "JOINED": joined.adapter,
                        "STALE": stale}
            bindings.update({f"OP{i}": op.adapter for i, op in enumerate(ops)})
            loop = self._loops[key] = specialize(_run_steps, "run_steps", bindings)
        done, time, pending = loop(k, sim.clock.time, sim.clock.dt,
                                   nl.check_args(sim.state, sim.geometry),
                                   pre.args, post.args, joined.args,
                                   *(op.args for op in ops))
        self.steps_done += done
        return done, time, pending
