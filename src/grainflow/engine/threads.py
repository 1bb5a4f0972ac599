"""How many threads the kernels use during a run: a fixed count, or ``"auto"``, measured.

Forces are bitwise identical for any thread count (:mod:`grainflow.kernels.pair_loop`), so
the count may change at any step without changing a result: it is a matter of speed only.
Which count is fastest depends on the system size *and on what else the machine runs*: on
2 idle cores two threads give 1.8x on 32,000 grains and about 1x on 1,600, but with one
CPU-bound process beside the run, every parallel region waits for a descheduled thread and
two threads run 2x (32,000 grains) to 5x (1,600 grains) *slower* than one (BENCHMARKS.md,
"Shared machine"). No setting chosen before the run is right in both cases, so ``"auto"``
measures:

- it chooses between one thread and ``cap`` threads (numba's count when the run starts:
  ``NUMBA_NUM_THREADS`` or :func:`numba.set_num_threads`, so a cap of 1 turns it off);
- it starts with one thread below :data:`SERIAL_BELOW` particles, with ``cap`` above;
- it times the run in windows of about :attr:`ThreadTuner.window_s` seconds, and now and
  then runs one window with the other count (a *probe*); it keeps whichever cost less per
  particle-step than the window just before, by more than :attr:`ThreadTuner.margin`;
- a probe that loses doubles the time to the next one (up to :attr:`ThreadTuner.max_wait_s`),
  so a probe costs at most a few per cent of the run;
- a window that costs more than :attr:`ThreadTuner.change` times the cost at the last decision
  (another process started, say) probes at once.

The simulation restores the thread count in force before the run when the run ends.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Literal, Union

import numba

#: Below this many particles ``"auto"`` starts with one thread (idle, two threads gain at
#: most a few per cent there; loaded, one thread is several times faster).
SERIAL_BELOW = 4000

Threads = Union[int, Literal["auto"]]


def check_threads(threads: object) -> Threads:
    """``threads`` as given, if it is ``"auto"`` or a count from 1 to numba's maximum."""
    if threads == "auto":
        return "auto"
    available = numba.config.NUMBA_NUM_THREADS
    if isinstance(threads, bool) or not isinstance(threads, int) or not 1 <= threads <= available:
        raise ValueError(f"threads: {threads!r} is not valid; expected 'auto' or a count from 1 "
                         f"to {available} (NUMBA_NUM_THREADS)")
    return threads


@dataclass
class ThreadTuner:
    """Chooses the thread count of one run by timing it (module docstring).

    Call :meth:`begin` before the first step and :meth:`tick` whenever the step counter
    reaches :attr:`next_step`; the caller restores the thread count afterwards. ``clock`` and
    ``set_threads`` are injectable for tests. :attr:`log` records every window: ``(step,
    threads, seconds per particle-step of the window that ended there)``.
    """

    cap: int
    window_s: float = 0.1
    first_wait_s: float = 0.5
    max_wait_s: float = 64.0
    margin: float = 0.05
    change: float = 1.5
    clock: Callable[[], float] = time.perf_counter
    set_threads: Callable[[int], None] = numba.set_num_threads
    log: list[tuple[int, int, float]] = field(default_factory=list)
    next_step: int = 0

    def begin(self, step: int, n_particles: int, particle_steps: int) -> None:
        """Set the starting count and open the first window at ``step``."""
        self.threads = 1 if n_particles < SERIAL_BELOW or self.cap == 1 else self.cap
        self.set_threads(self.threads)
        self._incumbent_cost = float("inf")
        self._settled_cost = float("inf")
        self._probing = False
        self._wait = self.first_wait_s
        self._since_probe = 0.0
        self._open(step, particle_steps, steps=1)

    def tick(self, step: int, particle_steps: int) -> None:
        """Close the window ending at ``step`` (``particle_steps``: the run's running total)
        and decide the count for the next one."""
        now = self.clock()
        elapsed = now - self._t0
        done = particle_steps - self._ps0
        steps = max(step - self._step0, 1)
        cost = elapsed / done if done > 0 else float("inf")
        self.log.append((step, self.threads, cost))
        # steps in the next window: about window_s at the pace just measured
        per_step = elapsed / steps
        next_steps = max(1, min(int(self.window_s / per_step) if per_step > 0 else 1000,
                                10 * steps))
        if self.cap == 1:
            self._open(step, particle_steps, next_steps, now)
            return
        if self._probing:
            self._probing = False
            if cost < (1.0 - self.margin) * self._incumbent_cost:
                self._settled_cost = cost  # the probe won: keep its count
                self._wait = self.first_wait_s
            else:
                self._settled_cost = self._incumbent_cost
                self.threads = self._other
                self.set_threads(self.threads)
                self._wait = min(2.0 * self._wait, self.max_wait_s)
            self._since_probe = 0.0
        else:
            self._incumbent_cost = cost
            self._since_probe += elapsed
            if cost > self.change * self._settled_cost:
                self._wait = self.first_wait_s
                self._since_probe = self._wait
            if self._since_probe >= self._wait:
                self._probing = True
                self._other = self.threads
                self.threads = 1 if self.threads != 1 else self.cap
                self.set_threads(self.threads)
        self._open(step, particle_steps, next_steps, now)

    def _open(self, step: int, particle_steps: int, steps: int, now: float | None = None) -> None:
        self._t0 = self.clock() if now is None else now
        self._step0 = step
        self._ps0 = particle_steps
        self.next_step = step + steps
