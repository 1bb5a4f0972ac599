"""How many threads the kernels use during a run: a fixed count, or ``"auto"``, measured.

Forces are bitwise identical for any thread count (:mod:`grainflow.kernels.pair_loop`), so
the count may change at any step without changing a result: it is a matter of speed only.
Which count is fastest depends on the system size *and on what else the machine runs*: on
2 idle cores two threads give 1.8x on 32,000 grains and about 1x on 1,600, but with one
CPU-bound process beside the run every parallel region waits for a descheduled thread, and
two threads run 2x (32,000 grains) to 30x (1,600 grains) *slower* than one (BENCHMARKS.md,
"Shared machine"). No setting chosen before the run is right in both cases, so ``"auto"``
measures:

- it chooses between one thread and ``cap`` threads (numba's count when the run starts:
  ``NUMBA_NUM_THREADS`` or :func:`numba.set_num_threads`, so a cap of 1 turns it off);
- it starts with one thread below :data:`SERIAL_BELOW` particles (idle, two threads gain
  little there; loaded, they are tens of times slower) and with ``cap`` above (the idle
  case, where a wrong start costs most; loaded, the first trial comes after 0.1 s);
- it times the run in windows of about :attr:`ThreadTuner.window_s` seconds; after the
  first full window, and then now and then, it runs a *trial* of the other count in short
  windows: first :attr:`ThreadTuner.probe_min_steps` steps, not judged (the threads wake
  up), then at least :data:`TRIAL_WINDOWS` windows of :attr:`ThreadTuner.probe_s` at the
  pace of the count in use, until they add up to :attr:`ThreadTuner.trial_s` at that pace.
  The judged windows together costing more than twice :attr:`ThreadTuner.abort` times the
  count in use after the first, or :attr:`ThreadTuner.abort` times after the second, end
  the trial at once (on a loaded machine two threads can be 50x slower, so a trial must
  stay short; one short window can hold a list rebuild, several times a step); otherwise the other count is
  adopted if the trial's particle-steps cost less, all windows together, than the median
  of the last three full windows, by more than :attr:`ThreadTuner.margin` (together: one
  short window may hold a list rebuild, or be lucky);
- a trial that loses doubles the time to the next one (from :attr:`ThreadTuner.base_wait_s`
  up to :attr:`ThreadTuner.max_wait_s`), so trials cost a few per cent of the run at most;
- when the median of the last three windows costs more than :attr:`ThreadTuner.change`
  times the cost at the last decision (another process started, say), the next trial comes
  within :attr:`ThreadTuner.change_wait_s` seconds (not at once: on a loaded machine short
  windows are noisy, and every trial of a count that loses costs time).

- where the machine says how busy its cores are (Linux: ``/proc/stat``, read by
  :class:`CpuLoad`), a run that would start on ``cap`` threads starts on one when other
  processes leave fewer than ``cap`` cores idle (sampled for :data:`START_SAMPLE_S` before
  the first step), and a trial of ``cap`` threads waits while the window just ended left
  fewer than ``cap - 1`` cores idle beside the run's own thread: under load those trials
  were most of what ``"auto"`` lost against one thread in short runs.

The simulation keeps its tuner from run to run (a loop of short runs does not start over
on one thread each time) and restores numba's thread count when each run ends.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Literal, Optional, Union

import numba

Threads = Union[int, Literal["auto"]]

#: Below this many particles ``"auto"`` starts on one thread.
SERIAL_BELOW = 4000

#: Judged windows a trial runs at least (after one that wakes the threads up).
TRIAL_WINDOWS = 3

#: Seconds over which the machine's idle cores are sampled before a run's first step
#: (``/proc/stat`` counts in 10 ms ticks: over 50 ms on 2 cores, a tenth of a core).
START_SAMPLE_S = 0.05

#: Cores a count must find idle, below the count itself: half a core of other work beside
#: the run is tolerated.
IDLE_SLACK = 0.5


class CpuLoad:
    """Idle cores of the whole machine between two readings of ``/proc/stat`` (Linux; the
    first ``cpu`` line: idle and iowait against all time, over every ``cpuN`` line's core;
    time stolen by a hypervisor counts as busy). :meth:`idle_cores` is None where the file
    cannot be read."""

    def __init__(self, path: str = "/proc/stat") -> None:
        self._path = Path(path)
        self._last = self._read()

    def _read(self) -> tuple[float, float, int] | None:
        """(all time, idle time, cores) so far, or None."""
        try:
            lines = self._path.read_text().splitlines()
            fields = [float(v) for v in lines[0].split()[1:9]]
            cores = sum(1 for line in lines if line.startswith("cpu") and line[3:4].isdigit())
        except (OSError, IndexError, ValueError):
            return None
        if len(fields) < 5 or cores < 1:
            return None
        return sum(fields), fields[3] + fields[4], cores

    def idle_cores(self, wait: float = 0.0) -> float | None:
        """Cores idle on average since the previous call (or since this object was made),
        after sleeping ``wait`` seconds; None if unknown."""
        if wait > 0.0:
            self._last = self._read()
            time.sleep(wait)
        now, last = self._read(), self._last
        self._last = now
        if now is None or last is None or now[0] <= last[0]:
            return None
        return (now[1] - last[1]) / (now[0] - last[0]) * now[2]


def check_threads(threads: object) -> Threads:
    """``threads`` as given, if it is ``"auto"`` or a count from 1 to numba's maximum."""
    if threads == "auto":
        return "auto"
    available = numba.config.NUMBA_NUM_THREADS
    if isinstance(threads, bool) or not isinstance(threads, int) or not 1 <= threads <= available:
        raise ValueError(f"threads: {threads!r} is not valid; expected 'auto' or a count from 1 "
                         f"to {available} (NUMBA_NUM_THREADS)")
    return threads


def _room_for(count: int, idle: float | None, own: float) -> bool:
    """Whether ``count`` threads would find their cores: ``idle`` cores (None: unknown, then
    yes) plus the ``own`` ones the run holds now, at least ``count - IDLE_SLACK``."""
    return idle is None or idle + own >= count - IDLE_SLACK


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
    probe_s: float = 0.002
    probe_min_steps: int = 3
    base_wait_s: float = 0.5
    max_wait_s: float = 64.0
    trial_s: float = 0.05
    abort: float = 4.0
    margin: float = 0.05
    change: float = 2.0
    change_wait_s: float = 2.0
    clock: Callable[[], float] = time.perf_counter
    set_threads: Callable[[int], None] = numba.set_num_threads
    #: ``idle(wait)``: cores idle machine-wide since its previous call, after sleeping
    #: ``wait`` seconds (:meth:`CpuLoad.idle_cores`), or None; no function: never asked.
    idle: Optional[Callable[[float], Optional[float]]] = None
    log: list[tuple[int, int, float]] = field(default_factory=list)
    next_step: int = 0

    @property
    def started(self) -> bool:
        """Whether :meth:`begin` was called (a later run then calls :meth:`resume`)."""
        return hasattr(self, "_recent")

    def first_count(self, n_particles: int) -> int:
        """The count a run of ``n_particles`` starts on: one thread below
        :data:`SERIAL_BELOW` particles, all of them from there unless other processes leave
        fewer than ``cap`` cores idle (sampled for :data:`START_SAMPLE_S`)."""
        if n_particles < SERIAL_BELOW or self.cap == 1:
            return 1
        idle = self.idle(START_SAMPLE_S) if self.idle is not None else None
        return self.cap if _room_for(self.cap, idle, 0.0) else 1

    def count_to_go_on(self) -> int:
        """The count :meth:`resume` goes on with: the one in use, not a trial's."""
        return self._other if self._trial else self.threads

    def begin(self, step: int, n_particles: int, particle_steps: int,
              threads: int | None = None) -> None:
        """Set the starting count (``threads``, when the caller already chose it with
        :meth:`first_count`) and open the first window at ``step``."""
        self.threads = self.first_count(n_particles) if threads is None else threads
        self.set_threads(self.threads)
        self._recent: list[float] = []  # costs of the last full windows of the count in use
        self._settled_cost = float("inf")  # its typical cost when it was last chosen
        self._pace = 0.0  # seconds per step of the count in use
        self._trial = 0  # trial windows still to run (0: no trial under way)
        self._trial_time = 0.0  # seconds, particle-steps and steps of its judged windows
        self._trial_done = 0
        self._trial_steps_done = 0
        self._trial_pace = 0.0  # seconds per step of the count in use when it began
        self._reference = float("inf")  # what the trial must beat
        self._other = self.threads
        self._wait = 0.0  # the first trial comes after the first full window
        self._since_probe = 0.0
        self._open(step, particle_steps, 1)

    def resume(self, step: int, particle_steps: int) -> None:
        """Go on in a new run with the count chosen so far (a trial under way is dropped)."""
        self.threads = self.count_to_go_on()
        self._trial = 0
        self.set_threads(self.threads)
        self._open(step, particle_steps, self._steps_for(self.window_s))

    def tick(self, step: int, particle_steps: int) -> None:
        """Close the window ending at ``step`` (``particle_steps``: the run's running total)
        and decide the count and length of the next one."""
        now = self.clock()
        elapsed = now - self._t0
        done = particle_steps - self._ps0
        steps = max(step - self._step0, 1)
        cost = elapsed / done if done > 0 else float("inf")
        self.log.append((step, self.threads, cost))
        if self._trial:  # a window of the other count
            self._trial -= 1
            if self._trial < TRIAL_WINDOWS:  # judged (the first one wakes the threads up)
                self._trial_time += elapsed
                self._trial_done += done
                self._trial_steps_done += steps
                so_far = self._trial_time / max(self._trial_done, 1) / self._reference
                if so_far > 2.0 * self.abort or (self._trial < TRIAL_WINDOWS - 1
                                                 and so_far > self.abort):
                    self._trial = 0  # far worse: stop at once
                elif self._trial_steps_done * self._trial_pace < self.trial_s:
                    self._trial = max(self._trial, 1)  # not enough seen yet: go on
            if self._trial:
                self._open(step, particle_steps, self._trial_steps(), now)
                return
            verdict = self._trial_time / self._trial_done if self._trial_done else float("inf")
            if verdict < (1.0 - self.margin) * self._reference:  # adopted
                self._settled_cost = verdict
                self._recent = []
                self._pace = elapsed / steps
                self._wait = self.base_wait_s
                self._since_probe = 0.0
                self._open(step, particle_steps, self._steps_for(self.window_s), now)
                return
            self._switch(self._other)
            self._settled_cost = self._reference  # the count in use is still the best
            self._wait = min(max(2.0 * self._wait, self.base_wait_s), self.max_wait_s)
            self._since_probe = 0.0
            self._open(step, particle_steps, self._steps_for(self.window_s), now)
            return
        self._pace = elapsed / steps
        if elapsed >= 0.5 * self.window_s:  # a full window
            # cores idle beside the run's one thread over this window (asked only then)
            idle = (self.idle(0.0) if self.idle is not None and self.threads == 1
                    and self.cap > 1 else None)
            self._recent = (self._recent + [cost])[-3:]
            self._since_probe += elapsed
            if self._settled_cost == float("inf"):
                self._settled_cost = cost
            if len(self._recent) == 3 and self._typical() > self.change * self._settled_cost:
                self._wait = min(self._wait, self.change_wait_s)  # conditions changed
            # (a trial of cap threads waits, window by window, while the machine is busy)
            if (self.cap > 1 and self._since_probe >= self._wait
                    and (self.threads != 1 or _room_for(self.cap, idle, 1.0))):
                self._reference = self._typical()
                self._trial = TRIAL_WINDOWS + 1
                self._trial_time = 0.0
                self._trial_done = 0
                self._trial_steps_done = 0
                self._trial_pace = self._pace
                self._other = self.threads
                self._switch(1 if self.threads != 1 else self.cap)
                self._open(step, particle_steps, self._trial_steps(), now)
                return
        self._open(step, particle_steps, min(self._steps_for(self.window_s), 10 * steps), now)

    def _trial_steps(self) -> int:
        """Steps of the next trial window: :attr:`probe_min_steps` for the first (it wakes
        the threads up), then :attr:`probe_s` at the pace of the count being left (the one
        known to be good), so that a much slower trial stays short."""
        if self._trial > TRIAL_WINDOWS:
            return self.probe_min_steps
        return max(self._steps_for(self.probe_s), self.probe_min_steps)

    def _typical(self) -> float:
        """The median of the last full windows of the count in use."""
        recent = sorted(self._recent)
        return recent[len(recent) // 2] if recent else float("inf")

    def _switch(self, threads: int) -> None:
        self.threads = threads
        self.set_threads(threads)

    def _steps_for(self, seconds: float) -> int:
        """Steps that take about ``seconds`` at the pace of the count in use."""
        return max(1, int(seconds / self._pace)) if self._pace > 0 else 1

    def _open(self, step: int, particle_steps: int, steps: int,
              now: float | None = None) -> None:
        self._t0 = self.clock() if now is None else now
        self._step0 = step
        self._ps0 = particle_steps
        self.next_step = step + steps
