"""The simulation object: state plus lists of operations, advanced step by step.

Order of work within one step of :meth:`Simulation.run` (the same for every set-up)::

    1. integrator.pre_force        (VV: half kick + drift; AB2: the whole step)
    2. neighbour list: wrap periodic positions; rebuild if some particle moved > skin/2
       (``list_check = "relative"``: if some pair may have moved skin against each other)
       (every ``sort_every`` builds also re-sort particles in space, history carried along)
    3. forces: the pair interactions over the list (the first sets force and torque; zero
       without any), then every operation in ``forces`` (walls, tethers, gravity, drag ...)
       in the order they were added
    4. integrator.post_force       (VV: second half kick)
    5. step += 1, time += dt
    6. updaters due this step      (insertion, deletion, reinsertion; may change N)
    7. health check every ``check_every`` steps (:meth:`Simulation.check_health`); on
       the other steps where an output is due, the cheap compiled part of it
       (:meth:`Simulation.check_state`), so nothing broken is ever written
    8. observers due this step     (outputs, analyses; read-only access to state/contacts)
    9. the ``"auto"`` thread choice, when its window ends (:mod:`grainflow.engine.threads`)

Steps 1-5 of the steps where nothing of 6-9 is due run in one compiled loop when every
operation offers a compiled step call (:mod:`grainflow.engine.fast_path`); a step whose
list must be rebuilt is finished here. The order of work and the result are the same.

Before the first step forces are evaluated once without advancing contact histories
(LAMMPS's set-up call), unless they are already current (e.g. after a checkpoint load).
Every evaluation outside step 3 (set-up, after an insertion, contact listing, FIRE) is
read-only: no contact history changes, so what observers ask never alters a run.

Each operation receives a narrow context, not this object
(:mod:`grainflow.engine.operations`).
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass
from typing import Any, Callable, Iterable

import numba
import numpy as np

from grainflow.engine.fast_path import FastPath
from grainflow.engine.integrators import VelocityVerlet
from grainflow.engine.neighbor_list import ListGeometry, NeighborList
from grainflow.engine.operations import (Clock, ContactRows, Force, ForceContext, Integrator,
                                         Observer, ObserverContext, TimeScale, Updater,
                                         UpdateContext)
from grainflow.engine.pair import PairInteraction
from grainflow.engine.threads import CpuLoad, Threads, ThreadTuner, check_threads
from grainflow.frame import PAIR, WALL, Contacts, Frame
from grainflow.kernels.health import ARRAY_OF_CODE, HEALTHY, TOO_FAST, scan_state
from grainflow.kernels.pair_loop import max_pair_overlap, max_relative_overlap
from grainflow.models.base import ContactLaw
from grainflow.state import ParticleState, speeds
from grainflow.user_warnings import warn_user


class InstabilityError(RuntimeError):
    """The run went unstable; ``step``, ``particle`` (id) and ``reason`` say where and why."""

    def __init__(self, step: int, particle: int, reason: str) -> None:
        super().__init__(f"unstable at step {step}, particle id {particle}: {reason}")
        self.step = step
        self.particle = particle
        self.reason = reason


class TimeStepError(ValueError):
    """The time step is past the hard stability limit of some interaction."""


@dataclass
class _Scheduled:
    every: int
    action: Callable[[Any], None]
    owner: Any
    checked: bool = True


@dataclass
class _EnergyReference:
    """Mechanical energy at a health check, and how much it may grow from there without a
    source: the elastic energy the contacts then held (bounded) plus a margin."""

    step: int
    energy: float
    allowance: float


#: A step may move a particle at most this fraction of its radius (beyond, grains tunnel
#: through walls and each other between two force evaluations).
MAX_STEP_FRACTION = 0.5
#: Margin of the energy check: the mechanical energy may exceed its value at the reference
#: check by the elastic energy then stored plus this fraction of the kinetic and elastic
#: energy then present (integration error is orders of magnitude smaller; a blow-up grows
#: without bound).
ENERGY_MARGIN = 0.5
#: dt above ``t / WARN_RATIO`` warns, above ``t / REFUSE_RATIO`` refuses, for each kind of
#: time scale: the half period of an oscillation (a contact, a tether), the relaxation time
#: of a velocity (drag, kinetic friction; an explicit step is unstable past 2 tau), and the
#: time a pair at its escape speed crosses a cohesive shell. The last is a matter of accuracy,
#: not of stability, so it only warns: at half of it, the speed below which a head-on pair is
#: captured scatters by 6-7 % with where in a step the contact starts (1-2 % at an eighth,
#: 18-19 % at 1.2 times it; :meth:`~grainflow.models.cohesion_constant.ConstantCohesion.
#: crossing_time`).
WARN_RATIO = {"oscillation": 15.0, "relaxation": 5.0, "crossing": 2.0}
REFUSE_RATIO = {"oscillation": 4.0, "relaxation": 1.0}
#: What a step too close to a time scale of each kind does, for the warning.
TIGHT_EFFECT = {"oscillation": "it is resolved by few steps",
                "relaxation": "it is resolved by few steps",
                "crossing": "the step, not the law, decides which pairs stay bound (widen "
                            "the cohesive shell or shorten the step)"}

#: Runs shorter than this step in Python: the first run of a new set of operations compiles
#: its step loop (and, on one thread, serial twins of the kernels: seconds, once; numba caches
#: them on disk), and even loading them from the cache (0.1-0.3 s) costs what the loop saves
#: in a few thousand small-system steps.
FAST_PATH_MIN_STEPS = 5000
#: Fewer quiet steps than this before the next thing due: a Python step is as quick.
FAST_PATH_MIN_CHUNK = 4


class Simulation:
    """State, pair interactions, operations and the step loop.

    Parameters
    ----------
    state:
        The particles.
    dt:
        Time step.
    law:
        A :class:`~grainflow.models.base.ContactLaw` for every particle pair (the default
        interaction; None: none). More interactions, each owning some type pairs:
        :meth:`add_interaction`.
    skin:
        Verlet skin; default 0.2 of the mean radius.
    list_check:
        When the list is rebuilt: ``"absolute"`` (default), once some particle has moved
        half the skin; ``"relative"``, once some pair may have moved the skin against each
        other (:mod:`grainflow.kernels.list_check`; for streams and jets, which move as a
        whole). Both give bitwise the same forces at every step.
    integrator:
        Default :class:`~grainflow.engine.integrators.VelocityVerlet`.
    allow_unsafe_dt:
        Warn instead of refusing a time step past an interaction's stability limit
        (diagnosis only).
    threads:
        ``"auto"`` (default): the run measures whether one thread or numba's current count
        is faster, now and then, and uses that (:mod:`grainflow.engine.threads`); a count:
        exactly that many. Results are bitwise the same either way.
    """

    def __init__(self, state: ParticleState, dt: float, law: ContactLaw | None = None, *,
                 skin: float | None = None, integrator: Integrator | None = None,
                 sort_every: int = 1, list_check: str = "absolute", check_every: int = 100,
                 max_overlap_fraction: float = 0.5, seed: int | None = None,
                 allow_unsafe_dt: bool = False, threads: Threads = "auto") -> None:
        if not (dt > 0 and np.isfinite(dt)):
            raise ValueError(f"dt: {dt!r} is not valid; expected a positive time step")
        self.state = state
        self.clock = Clock(float(dt))
        if skin is None:
            skin = 0.2 * float(np.mean(state.radius)) if state.n else 0.1
        self.neighbors = NeighborList(skin, sort_every, list_check)
        self.geometry = ListGeometry.from_state(state)
        #: The context forces and integrators receive.
        self.context = ForceContext(state, self.geometry, self.neighbors, self.clock)
        #: The random-number generator of the run (insertion, thinning); in checkpoints.
        self.rng = np.random.default_rng(seed)
        self._update_context = UpdateContext(self.context, self.rng, self)
        #: The read-only view observers receive.
        self.observer_context = ObserverContext(state, self.clock, self)
        self.interactions: list[PairInteraction] = []
        self._owned_types: tuple[int, int] | None = None
        self.forces: list[Force] = []
        self.integrator = integrator or VelocityVerlet()
        self.integrator.setup(self.context)
        self.updaters: list[_Scheduled] = []
        self.observers: list[_Scheduled] = []
        self.check_every = int(check_every)
        if not (max_overlap_fraction > 0 and math.isfinite(max_overlap_fraction)):
            raise ValueError(f"max_overlap_fraction: {max_overlap_fraction!r} is not valid; "
                             "expected a positive finite fraction of the radius")
        self.max_overlap_fraction = float(max_overlap_fraction)
        self.allow_unsafe_dt = bool(allow_unsafe_dt)
        #: Particles farther than this many box lengths outside the box on a non-periodic
        #: axis, moving away, are lost: the run stops (None: never). Box bounds are
        #: otherwise informational.
        self.escape_lengths: float | None = 1.0
        self._energy_ref: _EnergyReference | None = None
        self.forces_current = False
        self.rebuilds = 0
        self.wall_seconds = 0.0
        self.particle_steps = 0
        self.threads = threads
        #: ``(step, threads, seconds per particle-step)`` of every timed window of the
        #: ``"auto"`` thread choice, over all runs (:class:`~grainflow.engine.threads.ThreadTuner`).
        self.thread_log: list[tuple[int, int, float]] = []
        self._fast_path = FastPath()
        self._tuner: ThreadTuner | None = None  # the "auto" choice, kept from run to run
        #: Runs of fewer steps than this step in Python (0: every run uses the compiled step
        #: loop; benchmarks warm it up so). Default :data:`FAST_PATH_MIN_STEPS`.
        self.fast_path_min_steps = FAST_PATH_MIN_STEPS
        if law is not None:
            self.add_interaction(law)

    # ------------------------------------------------------------------- clock
    @property
    def dt(self) -> float:
        return self.clock.dt

    @dt.setter
    def dt(self, value: float) -> None:
        if not (value > 0 and np.isfinite(value)):
            raise ValueError(f"dt: {value!r} is not valid; expected a positive time step")
        self.clock.dt = float(value)

    @property
    def threads(self) -> Threads:
        """``"auto"`` or the fixed thread count of :meth:`run`."""
        return self._threads

    @threads.setter
    def threads(self, value: Threads) -> None:
        self._threads = check_threads(value)

    @property
    def time(self) -> float:
        return self.clock.time

    @time.setter
    def time(self, value: float) -> None:
        self.clock.time = float(value)

    @property
    def step(self) -> int:
        return self.clock.step

    # ----------------------------------------------------------- composition
    def add_interaction(self, law: ContactLaw,
                        types: Iterable[tuple[int, int]] | None = None) -> PairInteraction:
        """Add a pair interaction through ``law`` for the type pairs ``types`` (None: every
        type pair no other interaction owns; at most one such default)."""
        interaction = PairInteraction(law, types)
        mine = interaction.types or frozenset()
        for k, other in enumerate(self.interactions):
            if interaction.types is None and other.types is None:
                raise ValueError("types: the simulation has a default interaction already "
                                 f"({other!r}); name the type pairs the new one owns")
            clash = mine & (other.types or frozenset())
            if clash:
                raise ValueError(f"types: {sorted(clash)} already belong to interaction {k} "
                                 f"({other!r}); each type pair has one interaction")
        self.interactions.append(interaction)
        self._owned_types = None
        self.forces_current = False
        return interaction

    def add_force(self, force: Force) -> Force:
        """Append a force operation (walls, tethers, gravity, drag ...)."""
        force.setup(self.context)
        self.forces.append(force)
        self.forces_current = False
        return force

    def remove_force(self, force: Force) -> None:
        """Take a force operation out (e.g. a lid that opens); its per-particle arrays stay."""
        self.forces.remove(force)
        self.forces_current = False

    def add_updater(self, updater: Updater | Callable[[UpdateContext], None],
                    every: int = 1) -> None:
        """Run ``updater.update(ctx)`` (or ``updater(ctx)``) every ``every`` steps, with an
        :class:`~grainflow.engine.operations.UpdateContext`."""
        if every < 1:
            raise ValueError("every: updaters need an interval >= 1 step")
        action = updater.update if hasattr(updater, "update") else updater
        self.updaters.append(_Scheduled(int(every), action, updater))

    def add_observer(self, observer: Observer, every: int = 1, *, checked: bool = True) -> None:
        """Call ``observer(ctx)`` every ``every`` steps (after the step's updaters), with an
        :class:`~grainflow.engine.operations.ObserverContext`; ``observer.start(ctx)``, if
        defined, runs when each :meth:`run` begins. Before a ``checked`` observer (one that
        writes or analyses the state) runs, :meth:`check_state` makes sure the state is
        whole; ``checked=False`` is for observers that read only counters (progress)."""
        if every < 1:
            raise ValueError("every: observers need an interval >= 1 step")
        self.observers.append(_Scheduled(int(every), observer, observer, checked))

    @property
    def walls(self) -> tuple:
        """Every analytic wall shape, numbered as in saved contacts (``Contacts.j``)."""
        return tuple(w for f in self.forces for w in f.walls)

    # -------------------------------------------------------- particle edits
    def add_particles(self, x: np.ndarray, radius: np.ndarray | float, **kw: Any) -> np.ndarray:
        """Insert particles (see :meth:`ParticleState.add_particles`); forces are refreshed."""
        idx = self.state.add_particles(x, radius, **kw)
        self.forces_current = False
        self._energy_ref = None  # inserted grains bring energy
        return idx

    def remove_particles(self, mask: np.ndarray) -> np.ndarray:
        """Delete particles where ``mask`` is true; contact histories follow."""
        old_to_new = self.state.remove(mask)
        for op in (*self.interactions, *self.forces):
            op.reindex(old_to_new)
        self.forces_current = False
        self._energy_ref = None
        return old_to_new

    def relocate(self, index: np.ndarray, x: np.ndarray, v: np.ndarray | None = None,
                 omega: np.ndarray | None = None) -> None:
        """Move particles (a reinsertion): their pair and wall contact histories and their
        integrator memory (e.g. Adams-Bashforth's previous force) restart."""
        index = np.atleast_1d(np.asarray(index, dtype=np.int64))
        for interaction in self.interactions:
            interaction.forget(index, self.context)
        self.state.relocate(index, x, v, omega)
        self.forces_current = False
        self._energy_ref = None  # a reinsertion brings energy

    # ------------------------------------------------------------- forces
    def _assign_types(self) -> None:
        """Give each interaction its ``use`` matrix over the types present and named."""
        st = self.state
        key = (st.generation, len(self.interactions))
        if key == self._owned_types:
            return
        n = max([int(st.type.max()) + 1 if st.n else 1]
                + [max(max(p) for p in i.types) + 1 for i in self.interactions if i.types])
        claimed = np.zeros((n, n), dtype=bool)
        for i in self.interactions:
            if i.types is not None:
                use = np.zeros((n, n), dtype=bool)
                for a, b in i.types:
                    use[a, b] = use[b, a] = True
                claimed |= use
                i.owns(use, False)
        for i in self.interactions:
            if i.types is None:
                i.owns(~claimed, not claimed.any())
        self._owned_types = key

    def reach(self) -> float:
        """Largest reach beyond touching of the pair interactions and of the force
        operations that read the neighbour list (the list's margin)."""
        reaches = [f.neighbor_reach() for f in self.forces]
        return max([i.law.reach() for i in self.interactions]
                   + [r for r in reaches if r is not None], default=0.0)

    def _lists_pairs(self) -> bool:
        """Whether some operation reads the neighbour list's pairs (a pair interaction, or a
        force whose :meth:`~grainflow.engine.operations.Force.neighbor_reach` is not None)."""
        return bool(self.interactions) or any(f.neighbor_reach() is not None
                                              for f in self.forces)

    def _refresh_list(self) -> None:
        st = self.state
        nl = self.neighbors
        if not nl.needs_build(st, self.geometry):
            return
        nl.wrap(st, self.geometry)
        if not self._lists_pairs():  # lone grains: the wrap and the walls' cadence only
            nl.build_empty(st, self.geometry)
            self.rebuilds += 1
            return
        cells = nl.cell_order(st, self.geometry, self.reach())
        new_to_old = None
        if nl.sort_due() and st.n:
            new_to_old = cells[2]
            old_to_new = np.empty(st.n, dtype=np.int64)
            old_to_new[new_to_old] = np.arange(st.n)
            st.reindex(old_to_new)
            cells = nl.in_new_order(cells)
        nl.build(st, self.geometry, cells)
        for interaction in self.interactions:
            # the pair history follows the re-sort and the rebuild in one pass
            interaction.attach(nl.row_ptr, nl.nbr, new_to_old)
        self.rebuilds += 1

    def compute_forces(self, update: bool = True) -> None:
        """Recompute all forces and torques at the current positions.

        ``update=False`` is a read-only evaluation: no contact history changes.
        """
        st = self.state
        self._assign_types()
        self._refresh_list()
        for k, interaction in enumerate(self.interactions):
            interaction.compute(self.context, update, first=k == 0)
        if not self.interactions:
            st.force[:] = 0.0
            st.torque[:] = 0.0
        for f in self.forces:
            f.compute(self.context, update)
        self.forces_current = True

    # ---------------------------------------------------------------- run
    def run(self, steps: int, *, until: Callable[["Simulation"], bool] | None = None,
            until_every: int = 1) -> None:
        """Advance ``steps`` time steps; stop early when ``until(sim)``, asked every
        ``until_every`` steps, is true.

        Runs of steps with nothing due in between go through one compiled loop
        (:mod:`grainflow.engine.fast_path`) when every operation offers one and the run has
        at least :attr:`fast_path_min_steps` steps; the result is bitwise the same.
        """
        if steps < 0:
            raise ValueError("steps: must be >= 0")
        if until_every < 1:
            raise ValueError(f"until_every: {until_every!r} is not valid; expected >= 1")
        integ = self.integrator
        ctx = self.context
        clock = self.clock
        end = clock.step + steps
        fast = self._fast_path if steps >= self.fast_path_min_steps else None
        self._fast_path.forget()
        before = numba.get_num_threads()
        tuner = None
        # the thread count is set before the set-up evaluation, which then compiles (or
        # loads) the kernels of that count, not of the caller's; the thread tuner's clock
        # starts after it (a first compilation must not count against the count in use)
        if self._threads == "auto":
            tuner = self._tuner
            if tuner is None or tuner.cap != before:
                tuner = self._tuner = ThreadTuner(before, log=self.thread_log,
                                                  idle=CpuLoad().idle_cores)
            count = tuner.count_to_go_on() if tuner.started else tuner.first_count(self.state.n)
            tuner.set_threads(count)
        else:
            numba.set_num_threads(min(self._threads, numba.config.NUMBA_NUM_THREADS))
        t0 = _time.perf_counter()
        try:
            self.check_time_step()
            if not self.forces_current:
                self.compute_forces(update=False)
            self._energy_ref = None  # the state may have been edited between runs
            self.check_state()
            for o in self.observers:
                start = getattr(o.owner, "start", None)
                if start is not None:
                    start(self.observer_context)
            if tuner is not None and tuner.started:
                tuner.resume(clock.step, self.particle_steps)
            elif tuner is not None:
                tuner.begin(clock.step, self.state.n, self.particle_steps, count)
            t0 = _time.perf_counter()  # wall_seconds counts the steps, as before
            while clock.step < end:
                quiet = self._quiet_steps(end, tuner, until, until_every)
                calls = None
                if fast is not None and quiet >= FAST_PATH_MIN_CHUNK:
                    self._assign_types()
                    if self.neighbors.is_current_for(self.state):
                        calls = fast.calls(self)
                        if calls is None:
                            fast = None  # some operation steps only in Python
                if calls is not None:
                    done, clock.time, pending = fast.run(self, quiet, calls)
                    clock.step += done
                    self.particle_steps += self.state.n * done
                    self.forces_current = True
                else:
                    integ.pre_force(ctx)
                    pending = True
                if pending:  # the step's first half is done; the rest here
                    self.compute_forces(update=True)
                    integ.post_force(ctx)
                    clock.step += 1
                    clock.time += clock.dt
                    self.particle_steps += self.state.n
                if self._after_step(tuner, until, until_every):
                    break
        finally:
            self.wall_seconds += _time.perf_counter() - t0
            numba.set_num_threads(before)

    def _quiet_steps(self, end: int, tuner: ThreadTuner | None,
                     until: Callable[["Simulation"], bool] | None, until_every: int) -> int:
        """Steps from now to the next one after which something is due (an updater, an
        observer, a health check, a thread-choice window, ``until``) or the run ends,
        that step included."""
        step = self.clock.step
        due = end
        for every in [s.every for s in self.updaters] + [o.every for o in self.observers]:
            due = min(due, (step // every + 1) * every)
        if self.check_every:
            due = min(due, (step // self.check_every + 1) * self.check_every)
        if tuner is not None:
            due = min(due, max(tuner.next_step, step + 1))
        if until is not None:
            due = min(due, (step // until_every + 1) * until_every)
        return due - step

    def _after_step(self, tuner: ThreadTuner | None,
                    until: Callable[["Simulation"], bool] | None, until_every: int) -> bool:
        """What is due after the step just taken (updaters, checks, observers, the thread
        choice); True when ``until`` says stop."""
        clock = self.clock
        for u in self.updaters:
            if clock.step % u.every == 0:
                u.action(self._update_context)
                if not getattr(u.owner, "keeps_step_calls", False):
                    self._fast_path.forget()
        if not self.forces_current:
            self.compute_forces(update=False)
        if self.check_every and clock.step % self.check_every == 0:
            self.check_health()
        else:
            for o in self.observers:
                if o.checked and clock.step % o.every == 0:
                    self.check_state()
                    break
        for o in self.observers:
            if clock.step % o.every == 0:
                o.action(self.observer_context)
        if tuner is not None and clock.step >= tuner.next_step:
            tuner.tick(clock.step, self.particle_steps)
        return until is not None and clock.step % until_every == 0 and until(self)

    # ------------------------------------------------------------ checks
    def time_scales(self) -> list[TimeScale]:
        """Every time scale the interactions and operations need resolved."""
        self._assign_types()
        return [s for op in (*self.interactions, *self.forces)
                for s in op.time_scales(self.context)]

    def contact_time(self) -> float:
        """Shortest oscillation time (contact, wall contact, tether) present (inf if none)."""
        return min((s.time for s in self.time_scales() if s.kind == "oscillation"),
                   default=math.inf)

    def stable_time_step(self, fraction: float = 0.02) -> float:
        """``fraction`` of the shortest oscillation time, and at most the warning bound of
        every relaxation and crossing time (inf when there is none)."""
        dt = math.inf
        for s in self.time_scales():
            if s.kind == "oscillation":
                dt = min(dt, fraction * s.time)
            else:
                dt = min(dt, s.time / WARN_RATIO[s.kind])
        return dt

    def check_time_step(self) -> None:
        """Refuse (:class:`TimeStepError`) a dt past ``t/4`` of an oscillation time or past a
        relaxation time; warn past ``t/15``, ``tau/5`` or half a crossing time. The message
        names the interaction that limits dt. With ``allow_unsafe_dt`` the refusal is a
        warning."""
        scales = self.time_scales()
        if not scales:
            return
        safe = min(s.time / WARN_RATIO[s.kind] for s in scales)
        stability = [s for s in scales if s.kind in REFUSE_RATIO]
        worst = max(stability, key=lambda s: REFUSE_RATIO[s.kind] / s.time, default=None)
        limit = math.inf if worst is None else worst.time / REFUSE_RATIO[worst.kind]
        if self.dt > limit:
            message = (f"dt: {self.dt:g} exceeds the stability limit {limit:g} set by "
                       f"{worst.source} ({worst.kind} time {worst.time:g}); use dt <= "
                       f"{safe:g}")
            if not self.allow_unsafe_dt:
                raise TimeStepError(message)
            warn_user(message + "; running anyway (allow_unsafe_dt)")
            return
        tight = sorted((s for s in scales if self.dt > s.time / WARN_RATIO[s.kind]),
                       key=lambda s: s.time / WARN_RATIO[s.kind])
        if tight:
            causes = "; ".join(
                f"{s.time / WARN_RATIO[s.kind]:g} ({s.kind} time {s.time:g} of {s.source} / "
                f"{WARN_RATIO[s.kind]:g}): {TIGHT_EFFECT[s.kind]}" for s in tight)
            warn_user(f"dt = {self.dt:g} is larger than {causes}; dt <= {safe:g} is safer")

    def max_overlap(self) -> float:
        """Largest particle-particle or particle-wall overlap now."""
        self._refresh_list()
        st = self.state
        best = float(max_pair_overlap(self.neighbors.row_ptr, self.neighbors.nbr, st.x,
                                      st.radius, self.geometry.length, self.geometry.periodic))
        for f in self.forces:
            best = max(best, f.max_overlap(self.context)[0])
        return best

    def check_state(self) -> None:
        """The cheap part of the health check (one compiled pass, run before every output):
        raise :class:`InstabilityError` on a non-finite position, velocity, angular velocity
        or force, or on a particle moving more than ``MAX_STEP_FRACTION`` of its radius in
        one step."""
        st = self.state
        code, i = scan_state(st.x, st.v, st.omega, st.force, st.radius, st.frozen, self.dt,
                             MAX_STEP_FRACTION)
        if code == HEALTHY:
            return
        if code == TOO_FAST:
            speed = float(speeds(st.v[i:i + 1])[0])  # |v| may overflow when squared
            raise InstabilityError(
                self.step, int(st.id[i]),
                f"it moves {speed * self.dt / st.radius[i]:.3g} radii per step (|v| = "
                f"{speed:.4g}, dt = {self.dt:g}), more than "
                f"{MAX_STEP_FRACTION:g}: at that speed grains pass through walls and each "
                f"other; dt is too large for {self._shortest_scale()}, or the particle was "
                "given an unphysical velocity")
        raise InstabilityError(
            self.step, int(st.id[i]),
            f"non-finite {ARRAY_OF_CODE[code]}; the time step dt = {self.dt:g} is probably "
            f"too large for {self._shortest_scale()}")

    def check_health(self) -> None:
        """Raise :class:`InstabilityError` on a broken state (:meth:`check_state`), a
        particle lost far outside the box, an overlap past ``max_overlap_fraction`` (with
        another particle or a wall), or mechanical energy growing without a source."""
        self.check_state()
        st = self.state
        if not st.n:
            return
        self._check_escape()
        frac, i, what = self._max_overlap_fraction()
        for f in self.forces:
            _, wall_frac, wall_i = f.max_overlap(self.context)
            if wall_frac > frac:
                frac, i, what = wall_frac, wall_i, f"with a wall ({type(f).__name__})"
        if frac > self.max_overlap_fraction:
            raise InstabilityError(
                self.step, int(st.id[i]),
                f"overlap {frac:.3g} of the radius {what} exceeds max_overlap_fraction = "
                f"{self.max_overlap_fraction:g}; particles are too soft for the load or "
                f"dt = {self.dt:g} is too large for {self._shortest_scale()}")
        self._check_energy()

    def _check_escape(self) -> None:
        """Particles farther than ``escape_lengths`` box lengths outside the box on a
        non-periodic axis, and moving away from it, have left every region walls bound
        (LAMMPS's lost atoms)."""
        if self.escape_lengths is None:
            return
        st = self.state
        box = st.box
        for a in range(st.dim):
            if box.periodic[a]:
                continue
            margin = self.escape_lengths * float(box.hi[a] - box.lo[a])
            coord, speed = st.x[:, a], st.v[:, a]
            out = (((coord < box.lo[a] - margin) & (speed < 0))
                   | ((coord > box.hi[a] + margin) & (speed > 0)))
            out &= ~st.frozen
            if out.any():
                i = int(np.argmax(out))
                raise InstabilityError(
                    self.step, int(st.id[i]),
                    f"it left the box: {'xyz'[a]} = {coord[i]:.4g}, box {box.lo[a]:.4g} to "
                    f"{box.hi[a]:.4g} (lost past {self.escape_lengths:g} box length); it "
                    f"tunnelled through a wall (dt = {self.dt:g} too large for "
                    f"{self._shortest_scale()}) or nothing holds it there (add a wall or a "
                    "delete updater)")

    def _field_energy(self) -> float | None:
        """Energy stored in the operations' fields now; None when some operation can supply
        energy the balance does not count (see ``Force.potential_energy``)."""
        total = 0.0
        for op in (*self.interactions, *self.forces):
            e = op.potential_energy(self.context)
            if e is None:
                return None
            total += e
        return total

    def _elastic_energy_bound(self) -> float:
        """An upper bound of the elastic energy pair and wall contacts hold now:
        ``2 sum |F| delta`` (the integral of a force growing with the overlap is at most
        ``|F| delta``; the factor 2 covers tangential springs)."""
        if not self.forces_current:
            self.compute_forces(update=False)
        radius = self.state.radius
        total = 0.0
        for op in (*self.interactions, *self.forces):
            for r in op.contacts(self.context):  # particle indices, not ids
                if r.kind not in (PAIR, WALL):
                    continue
                reach = radius[r.i] + (radius[r.j] if r.kind == PAIR else 0.0)
                overlap = np.maximum(reach - np.linalg.norm(r.branch, axis=1), 0.0)
                total += float(np.sum(np.linalg.norm(r.force, axis=1) * overlap))
        return 2.0 * total

    def _check_energy(self) -> None:
        """Mechanical energy may not grow past its reference (the first check after a
        run starts or the particles were edited) by more than the allowance."""
        field = self._field_energy()
        if field is None:
            self._energy_ref = None
            return
        st = self.state
        kinetic = st.kinetic_energy() + st.rotational_energy()
        energy = kinetic + field
        ref = self._energy_ref
        if ref is None:
            elastic = self._elastic_energy_bound()
            allowance = (elastic + ENERGY_MARGIN * (kinetic + elastic)
                         + 1e-9 * (abs(energy) + kinetic))
            self._energy_ref = _EnergyReference(self.step, energy, allowance)
            return
        if energy - ref.energy <= ref.allowance:
            return
        i = int(np.argmax(st.mass * np.einsum("ij,ij->i", st.v, st.v)))
        raise InstabilityError(
            self.step, int(st.id[i]),
            f"the mechanical energy grew from {ref.energy:.6g} at step {ref.step} to "
            f"{energy:.6g} with no source (no insertion, moving wall or cohesion); this "
            f"particle is the fastest; dt = {self.dt:g} is probably too large for "
            f"{self._shortest_scale()}")

    def _shortest_scale(self) -> str:
        scales = [s for s in self.time_scales() if s.kind in REFUSE_RATIO]
        if not scales:
            return "(no time scale)"
        s = min(scales, key=lambda s: s.time / REFUSE_RATIO[s.kind])
        return f"the {s.kind} time {s.time:g} of {s.source}"

    def _max_overlap_fraction(self) -> tuple[float, int, str]:
        st = self.state
        nl = self.neighbors
        if nl.n_pairs == 0 or not self.interactions:
            return 0.0, 0, "between particles"
        g = self.geometry
        rel, row = max_relative_overlap(nl.row_ptr, nl.nbr, st.x, st.radius, g.length,
                                        g.periodic)
        return float(rel), int(row), "between particles"

    # ----------------------------------------------------------- outputs
    def contacts(self) -> Contacts:
        """Every force between two bodies now: pair contacts, wall contacts (``j``: the
        wall's index in :attr:`walls`), bonds and anchors (copies; read-only)."""
        if not self.forces_current:
            self.compute_forces(update=False)
        rows: list[ContactRows] = []
        wall_offset = 0
        ids = self.state.id
        for op in (*self.interactions, *self.forces):
            for r in op.contacts(self.context):
                if r.kind == WALL:
                    j = r.j + wall_offset
                else:  # particle indices to ids; -1 (an anchor) stays
                    j = np.where(r.j >= 0, ids[np.maximum(r.j, 0)], -1)
                rows.append(ContactRows(ids[r.i], j, r.kind, r.force, r.branch))
            wall_offset += len(op.walls)
        d = self.state.dim
        if not rows:
            e = np.zeros(0, dtype=np.int64)
            return Contacts(e, e.copy(), np.zeros((0, d)), np.zeros((0, d)),
                            np.zeros(0, dtype=np.int8))
        return Contacts(np.concatenate([r.i for r in rows]).astype(np.int64),
                        np.concatenate([r.j for r in rows]).astype(np.int64),
                        np.concatenate([r.force for r in rows])[:, :d],
                        np.concatenate([r.branch for r in rows])[:, :d],
                        np.concatenate([np.full(r.i.size, r.kind, dtype=np.int8)
                                        for r in rows]))

    def frame(self, contacts: bool = False) -> Frame:
        """A copy of the current state as a :class:`Frame`."""
        return self.state.to_frame(self.step, self.time, self.contacts() if contacts else None)

    # -------------------------------------------------------- checkpoints
    def state_dict(self) -> dict[str, Any]:
        """Everything needed to continue this run bitwise identically.

        Particle arrays (including integrator history registered in the state), step, time,
        dt, the neighbour list as built (so re-sorting happens at the same steps), pair and
        operation histories, and the random-number generator state. Values are numpy arrays
        or plain Python scalars/dicts; nested dicts mirror the operations' names.
        """
        nl = self.neighbors
        return {
            "step": self.step, "time": self.time, "dt": self.dt,
            "particle_steps": self.particle_steps, "rebuilds": self.rebuilds,
            "forces_current": self.forces_current,
            "arrays": {k: v.copy() for k, v in self.state.arrays.items()},
            "next_id": self.state._next_id,
            "neighbors": {"row_ptr": nl.row_ptr.copy(), "nbr": nl.nbr.copy(),
                          "col_ptr": nl.col_ptr.copy(), "col_pair": nl.col_pair.copy(),
                          "x_ref": nl._x_ref.copy(), "builds": nl.builds,
                          "cut": nl._cut, "allowance_sq": nl.allowance_sq.copy(),
                          "allowance_by": sorted(nl.allowance_by)},
            "interactions": {str(k): i.state_dict() for k, i in enumerate(self.interactions)},
            "forces": {str(k): f.state_dict() for k, f in enumerate(self.forces)},
            "updaters": {str(k): u.owner.state_dict() for k, u in enumerate(self.updaters)
                         if hasattr(u.owner, "state_dict")},
            "rng": self.rng.bit_generator.state,
        }

    def _restore_relative_check(self, saved: dict[str, Any]) -> None:
        """The relative check's blocks (from the build positions) and allowances. A
        checkpoint of an absolute-check run has none: every particle is then allowed the
        periodic cap, and the walls set theirs again from the current positions
        (:meth:`~grainflow.walls.force.WallForce` takes the motion since the build off)."""
        nl = self.neighbors
        st = self.state
        if "cut" in saved:
            nl._cut = float(saved["cut"])
        else:
            nl._cut = nl.cut_for(st, self.reach()) if self._lists_pairs() else 0.0
        nl.index_blocks(st.dim, self.geometry)
        if "allowance_sq" in saved:
            nl.allowance_sq = np.array(saved["allowance_sq"], dtype=np.float64)
            nl.allowance_by = set(saved["allowance_by"])
        else:
            nl.allowance_sq = np.full(st.n, nl._periodic_cap(self.geometry))
            nl.allowance_by = set()

    def load_state_dict(self, data: dict[str, Any]) -> None:
        """Restore a :meth:`state_dict` into a simulation built with the same operations."""
        st = self.state
        for name, arr in data["arrays"].items():
            if name not in st.arrays:
                st.add_array(name, arr.shape[1:], arr.dtype)
            st.arrays[name] = np.array(arr, dtype=st.arrays[name].dtype)
        st._next_id = int(data["next_id"])
        st.generation += 1
        self.clock.step = int(data["step"])
        self.clock.time = float(data["time"])
        self.dt = float(data["dt"])
        self.particle_steps = int(data.get("particle_steps", 0))
        nl = self.neighbors
        nb = data["neighbors"]
        nl.row_ptr = np.asarray(nb["row_ptr"], dtype=np.int64)
        nl.nbr = np.asarray(nb["nbr"], dtype=np.int64)
        nl.index_columns()  # the transpose is a function of the rows (saved for readers)
        nl._x_ref = np.asarray(nb["x_ref"], dtype=np.float64)
        nl.index_rows(self.geometry)
        nl.builds = int(nb["builds"])
        nl._generation = st.generation
        if nl.relative:
            self._restore_relative_check(nb)
        saved = data.get("interactions", {})
        if len(saved) != len(self.interactions):
            raise ValueError(f"checkpoint: holds {len(saved)} pair interaction(s), the "
                             f"simulation has {len(self.interactions)}")
        for k, interaction in enumerate(self.interactions):
            interaction.load_state_dict(saved[str(k)])
            if interaction.active.shape[0] != nl.n_pairs:
                raise ValueError("checkpoint: pair history does not match the neighbour list")
        for k, f in enumerate(self.forces):
            f.load_state_dict(data["forces"].get(str(k), {}))
        for k, u in enumerate(self.updaters):
            if hasattr(u.owner, "load_state_dict") and str(k) in data["updaters"]:
                u.owner.load_state_dict(data["updaters"][str(k)])
        self.rng.bit_generator.state = data["rng"]
        self.rebuilds = int(data.get("rebuilds", self.rebuilds))
        self._energy_ref = None
        # Forces and per-pair buffers are saved as they were: the next step continues
        # exactly where the saved run was.
        self.forces_current = bool(data["forces_current"])

    def memory_bytes(self) -> dict[str, int]:
        """Bytes held by particle state, neighbour list and contact history."""
        hist = sum(op.nbytes() for op in (*self.interactions, *self.forces))
        return {"state": int(sum(a.nbytes for a in self.state.arrays.values())),
                "neighbors": self.neighbors.nbytes(), "history": int(hist)}
