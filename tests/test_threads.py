"""The ``threads = "auto"`` choice (:mod:`grainflow.engine.threads`): what it chooses under a
given cost model (a fake clock), that switching threads mid-run changes no bit of a result,
and how ``threads`` is given and refused (Simulation, config, command line)."""

from __future__ import annotations

import functools

import numba
import numpy as np
import pytest

from grainflow.engine import simulation as simulation_module
from grainflow.engine.threads import SERIAL_BELOW, ThreadTuner, check_threads


class FakeMachine:
    """A run whose cost per particle-step depends on the thread count and on time."""

    def __init__(self, cost):
        self.now = 0.0
        self.cost = cost  # cost(threads, now) -> seconds per particle-step
        self.threads = None

    def clock(self) -> float:
        return self.now

    def set_threads(self, threads: int) -> None:
        self.threads = threads

    def run(self, tuner: ThreadTuner, n: int, seconds: float) -> dict[int, int]:
        """Step until ``seconds`` of fake time have passed; steps done per thread count."""
        done = 0
        step = 0
        tuner.begin(step, n, done)
        steps_on: dict[int, int] = {}
        while self.now < seconds:
            self.now += self.cost(self.threads, self.now) * n
            step += 1
            done += n
            steps_on[self.threads] = steps_on.get(self.threads, 0) + 1
            if step >= tuner.next_step:
                tuner.tick(step, done)
        return steps_on


def tuner_on(machine: FakeMachine) -> ThreadTuner:
    return ThreadTuner(2, clock=machine.clock, set_threads=machine.set_threads)


def share(steps_on: dict[int, int], threads: int) -> float:
    return steps_on.get(threads, 0) / sum(steps_on.values())


@pytest.mark.parametrize("n", [1600, 32000])
def test_auto_keeps_the_faster_count_and_probes_little(n: int) -> None:
    # idle machine, large system: two threads 1.8x faster
    fast2 = FakeMachine(lambda t, now: 1e-7 / (1.8 if t == 2 else 1.0))
    steps = fast2.run(tuner_on(fast2), n, 120.0)
    assert share(steps, 2) > 0.95
    # loaded machine: two threads 5x slower than one
    slow2 = FakeMachine(lambda t, now: 1e-7 * (5.0 if t == 2 else 1.0))
    steps = slow2.run(tuner_on(slow2), n, 120.0)
    assert share(steps, 1) > 0.95


def test_auto_starts_serial_below_the_threshold_and_finds_the_faster_count() -> None:
    machine = FakeMachine(lambda t, now: 1e-7 / (1.8 if t == 2 else 1.0))
    tuner = tuner_on(machine)
    tuner.begin(0, SERIAL_BELOW - 1, 0)
    assert machine.threads == 1
    tuner.begin(0, SERIAL_BELOW, 0)
    assert machine.threads == 2
    machine.run(tuner, 1600, 1.0)  # small, but two threads are faster here: found in 1 s
    assert machine.threads == 2


def test_auto_follows_a_change_of_load() -> None:
    # two threads win until another process starts at t = 60 s; then one thread wins
    machine = FakeMachine(lambda t, now: 1e-7 * ((1 / 1.8 if t == 2 else 1.0) if now < 60.0
                                                 else (5.0 if t == 2 else 1.0)))
    tuner = tuner_on(machine)
    machine.run(tuner, 32000, 120.0)
    switched = next(step for step, threads, _ in tuner.log
                    if threads == 1 and machine_time(tuner, step) > 60.0)
    assert machine.threads == 1
    # the switch came within seconds of the change, not after the longest wait (64 s)
    assert machine_time(tuner, switched) < 63.0


def machine_time(tuner: ThreadTuner, step: int) -> float:
    """Fake time at the end of the window that ended at ``step`` (sum of window costs)."""
    total = 0.0
    previous = 0
    for s, _, cost in tuner.log:
        total += cost * 32000 * (s - previous)
        previous = s
        if s == step:
            return total
    raise KeyError(step)


def test_a_cap_of_one_never_switches() -> None:
    machine = FakeMachine(lambda t, now: 1e-7)
    tuner = ThreadTuner(1, clock=machine.clock, set_threads=machine.set_threads)
    steps = machine.run(tuner, 32000, 10.0)
    assert set(steps) == {1}


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_switching_threads_mid_run_changes_no_bit(monkeypatch) -> None:
    """A chute cut run with the auto choice probing every few steps against the same run
    on one fixed thread: positions, velocities and spins bitwise equal."""
    from grainflow.scenarios.chute import chute_cut

    fixed = chute_cut(0.25, 0.25)
    fixed.threads = 1
    fixed.run(300)

    eager = functools.partial(ThreadTuner, window_s=1e-9, probe_s=1e-9, base_wait_s=0.0,
                              max_wait_s=0.0)
    monkeypatch.setattr(simulation_module, "ThreadTuner", eager)
    auto = chute_cut(0.25, 0.25)
    before = numba.get_num_threads()
    auto.run(300)
    assert numba.get_num_threads() == before  # restored
    assert {threads for _, threads, _ in auto.thread_log} == {1, 2}
    assert np.array_equal(auto.state.x, fixed.state.x)
    assert np.array_equal(auto.state.v, fixed.state.v)
    assert np.array_equal(auto.state.omega, fixed.state.omega)


def test_threads_are_checked() -> None:
    assert check_threads("auto") == "auto"
    assert check_threads(1) == 1
    for bad in (0, -1, True, 2.0, "two", numba.config.NUMBA_NUM_THREADS + 1):
        with pytest.raises(ValueError, match="threads: .* expected 'auto' or a count"):
            check_threads(bad)
    from grainflow.scenarios.chute import chute_cut

    sim = chute_cut(0.25, 0.25)
    assert sim.threads == "auto"
    with pytest.raises(ValueError, match="threads"):
        sim.threads = 0


def test_the_choice_carries_over_from_run_to_run() -> None:
    """A loop of short runs goes on with the count chosen so far, not from one thread."""
    machine = FakeMachine(lambda t, now: 1e-7 / (1.8 if t == 2 else 1.0))
    tuner = tuner_on(machine)
    machine.run(tuner, 32000, 5.0)
    assert machine.threads == 2
    tuner.resume(10**6, 0)
    assert machine.threads == 2
    # a trial under way when a run ends is dropped: the count in use stays
    tuner._trial = 2
    tuner._other, tuner.threads = 2, 1
    tuner.resume(10**6, 0)
    assert machine.threads == 2 and not tuner._trial


def test_a_simulation_keeps_its_tuner() -> None:
    from grainflow.scenarios.chute import chute_cut

    sim = chute_cut(0.25, 0.16)
    sim.run(20)
    tuner = sim._tuner
    sim.run(20)
    assert sim._tuner is tuner and sim.thread_log[-1][0] <= 40


def test_cpu_load_reads_idle_cores_from_proc_stat(tmp_path) -> None:
    """Idle cores between two readings: (idle + iowait) / all time x cores; None when the
    file cannot be read or time did not advance."""
    from grainflow.engine.threads import CpuLoad

    stat = tmp_path / "stat"

    def write(user: int, idle: int, iowait: int) -> None:
        stat.write_text(f"cpu  {user} 0 0 {idle} {iowait} 0 0 0 0 0\n"
                        "cpu0 0 0 0 0 0 0 0 0 0 0\ncpu1 0 0 0 0 0 0 0 0 0 0\nintr 1 2\n")

    write(1000, 1000, 0)
    load = CpuLoad(str(stat))
    write(1150, 1040, 10)  # 200 ticks: 50 idle -> a quarter of 2 cores idle
    assert load.idle_cores() == pytest.approx(0.5)
    assert load.idle_cores() is None  # no time passed since
    assert CpuLoad(str(tmp_path / "missing")).idle_cores() is None
    assert CpuLoad().idle_cores(0.01) is None or 0.0 <= CpuLoad().idle_cores(0.01) <= 1e4


def test_auto_starts_and_stays_on_one_thread_while_the_machine_is_busy() -> None:
    """With the machine's cores busy (another process), a large run starts on one thread and
    tries two only once a core is idle again; an idle machine starts on two."""
    busy_until = 60.0
    machine = FakeMachine(lambda t, now: 1e-7 * ((5.0 if t == 2 else 1.0) if now < busy_until
                                                 else (1 / 1.8 if t == 2 else 1.0)))

    def idle(wait: float) -> float:
        # beside the run's own thread: no idle core while the other process runs
        return 0.05 if machine.now < busy_until else 1.0

    tuner = ThreadTuner(2, clock=machine.clock, set_threads=machine.set_threads, idle=idle)
    tuner.begin(0, 32000, 0)
    assert machine.threads == 1
    steps = machine.run(tuner, 32000, 120.0)
    two = [step for step, threads, _ in tuner.log if threads == 2]
    assert two and machine_time(tuner, two[0]) > busy_until  # no trial while busy
    assert machine.threads == 2 and share(steps, 2) > 0.4
    idle_machine = ThreadTuner(2, clock=machine.clock, set_threads=machine.set_threads,
                               idle=lambda wait: 1.9)
    idle_machine.begin(0, 32000, 0)
    assert machine.threads == 2
    unknown = ThreadTuner(2, clock=machine.clock, set_threads=machine.set_threads,
                          idle=lambda wait: None)
    unknown.begin(0, 32000, 0)
    assert machine.threads == 2  # unknown: as before


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_a_run_samples_the_idle_cores_once_before_its_first_step(monkeypatch) -> None:
    """The starting count is chosen once: the run sets it before its set-up evaluation and
    the tuner's first window starts on it, without sampling the machine a second time."""
    from grainflow.engine.threads import START_SAMPLE_S, CpuLoad
    from grainflow.scenarios.chute import chute_cut

    waits: list[float] = []
    monkeypatch.setattr(CpuLoad, "idle_cores",
                        lambda self, wait=0.0: waits.append(wait) or 2.0)
    sim = chute_cut(0.5, 0.5)  # 8,000 grains: a run that may start on two threads
    sim.run(2)
    assert waits.count(START_SAMPLE_S) == 1
