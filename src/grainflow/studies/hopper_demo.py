"""``grainflow demo``: a small 2D hopper discharge (seed 003), its flow rate and two plots.

It runs the scenario (:mod:`grainflow.scenarios.hopper`) directly, without a run directory,
and draws with :mod:`grainflow.plotting`, so it lives above both.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from grainflow.progress import make_progress
from grainflow.scenarios.hopper import (
    EVENTS,
    HopperSection,
    build_hopper,
    hopper_segments,
    hopper_updater,
    prepare,
)
from grainflow.scenarios.hopper_reinsertion import write_events

if TYPE_CHECKING:
    from grainflow.analysis.hopper import FlowRate
    from grainflow.engine.threads import Threads

__all__ = ["demo"]


def demo(out_dir: str | Path | None = None, *, n: int = 1600, orifice_width: float = 10.0,
         duration: float = 600.0, E_sp: float = 1000.0, E_w: float = 1000.0, seed: int = 0,
         quiet: bool = False, threads: "Threads" = "auto", progress: str = "auto",
         movie_frames: int = 100) -> "FlowRate":
    """A 2D hopper discharge in the lambda -> inf limit; about a minute on 2 cores.

    ``n`` grains, a wide orifice (w = 10 sigma_avg), ``duration`` t0 of flow (the drag-limited
    pile turns over slowly: the rate settles only after about 300 t0, a transient that the
    analysis detects and discards), E_sp = E_w = 1000 (moderately stiff grains; walls no
    stiffer than the grains, so that the wall contact time does not shorten dt, see
    :meth:`~grainflow.engine.simulation.Simulation.stable_time_step`). Prints Q with its error bar in
    Q0 = sigma_avg^2/t0, writes ``snapshot.png``, ``flow_rate.png``, ``events.csv`` and
    ``movie.mp4`` (``movie_frames`` pictures spread over the run, grains coloured by speed,
    :func:`~grainflow.plotting.movie.write_movie`; 0: no movie) into ``out_dir`` (default
    ``./grainflow-demo``) and returns the
    :class:`~grainflow.analysis.hopper.FlowRate`. ``threads``: see
    :mod:`grainflow.engine.threads`; ``progress``: a bar with the time left on a terminal,
    a line every 10 s otherwise (:func:`~grainflow.progress.make_progress`; ``quiet``:
    none).
    """
    import time

    from grainflow.analysis.hopper import flow_rate_from_events
    from grainflow.plotting.hopper_plots import plot_flow_rate_timeseries
    from grainflow.plotting.movie import write_movie
    from grainflow.plotting.snapshot import snapshot

    out = Path(out_dir if out_dir is not None else "grainflow-demo")
    out.mkdir(parents=True, exist_ok=True)
    section = HopperSection(n=n, orifice_width=orifice_width, E_sp=E_sp, E_w=E_w,
                            lam=math.inf)
    start = time.perf_counter()
    sim = build_hopper(section, 2, seed=seed)
    sim.threads = threads
    prepare(sim)
    steps = int(math.ceil(duration / sim.dt))
    if not quiet:
        print(f"grainflow demo: 2D hopper, N = {sim.state.n}, w = {orifice_width:g} sigma_avg, "
              f"lambda -> inf, E_sp = {E_sp:g}, dt = {sim.dt:.4g} t0, {steps} steps")
    display = make_progress("none" if quiet else progress)
    t_run, particle_steps = time.perf_counter(), sim.particle_steps

    def rate(s) -> float:
        """Particle-steps per second so far."""
        return (s.particle_steps - particle_steps) / max(time.perf_counter() - t_run, 1e-9)

    sim.add_observer(lambda s: display.update(s.step, s.state.n, rate(s)), 100, checked=False)
    frames = []
    if movie_frames > 0:
        sim.add_observer(lambda s: frames.append(s.frame()), max(1, steps // movie_frames))
    with display:
        display.start(steps)
        sim.run(steps)
    seconds = time.perf_counter() - t_run
    speed = rate(sim)
    updater = hopper_updater(sim)
    write_events(out / EVENTS, updater.event_times, updater.event_ids, updater.event_sizes)
    flow = flow_rate_from_events(updater.event_times, updater.event_sizes, t_begin=0.0,
                                 t_end=sim.time)
    plot_flow_rate_timeseries(flow, out / "flow_rate.png")
    walls = hopper_segments(sim)
    snapshot(sim.frame(), out / "snapshot.png", walls=walls)
    if frames:
        write_movie(frames, out / "movie.mp4", walls=walls, fps=15.0,
                    progress="none" if quiet else progress)
    if not quiet:
        print(f"Q = {flow.flow_rate:.4g} +/- {flow.flow_rate_err:.2g} Q0 "
              f"(dN/dt = {flow.number_rate:.4g} +/- {flow.number_rate_err:.2g} per t0, "
              f"{flow.n_events} events after t = {flow.t_start:.3g} t0)")
        print(f"{steps} steps in {seconds:.1f} s: {steps / seconds:.4g} steps/s, "
              f"{speed:.3g} particle-steps/s "
              f"({_threads_used(sim)}); {time.perf_counter() - start:.1f} s in all; "
              f"outputs in {out}")
    return flow


def _threads_used(sim) -> str:
    """Which thread count the run used for most of its steps (the auto choice's log)."""
    if sim.threads != "auto":
        return f"{sim.threads} thread(s)"
    steps: dict[int, int] = {}
    previous = 0
    for step, threads, _ in sim.thread_log:
        steps[threads] = steps.get(threads, 0) + step - previous
        previous = step
    if not steps:
        return "threads auto"
    most = max(steps, key=steps.get)
    return (f"threads auto: {most} for {100.0 * steps[most] / previous:.0f} % of the steps")
