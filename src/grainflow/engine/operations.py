"""The typed operation interface: what a force, integrator, updater or observer is, and the
narrow view of the simulation each one receives.

A :class:`~grainflow.engine.simulation.Simulation` holds the state and lists of operations
(HOOMD-blue's design). Each kind of operation gets a *context*, not the simulation:

================  =====================  ================================================
operation         method(s)              context: what it may read and do
================  =====================  ================================================
:class:`Force`    ``compute(ctx, upd)``  :class:`ForceContext`: state, box geometry,
                                         neighbour list, clock (dt, time, step)
:class:`Integrator` ``pre_force(ctx)``,  :class:`ForceContext`
                  ``post_force(ctx)``
:class:`Updater`  ``update(ctx)``        :class:`UpdateContext`: the above plus the run's
                                         random generator and particle edits (add,
                                         remove, relocate)
:class:`Observer` ``__call__(ctx)``      :class:`ObserverContext`: read-only queries
                                         (frame, contacts, overlaps, counters)
================  =====================  ================================================

This module imports nothing from the simulation, so operations never import it either.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Protocol

import numpy as np

from grainflow.frame import Contacts, Frame
from grainflow.state import ParticleState

if TYPE_CHECKING:
    from grainflow.engine.fast_path import StepCall
    from grainflow.engine.neighbor_list import ListGeometry, NeighborList


@dataclass
class Clock:
    """Time step, simulated time and step count of a run."""

    dt: float
    time: float = 0.0
    step: int = 0


class _Clocked:
    """Read access to a context's :class:`Clock`."""

    __slots__ = ()
    clock: Clock

    @property
    def dt(self) -> float:
        return self.clock.dt

    @property
    def time(self) -> float:
        return self.clock.time

    @property
    def step(self) -> int:
        return self.clock.step


class ForceContext(_Clocked):
    """What forces and integrators see: the particles, the box, the neighbour list, the
    clock. Forces add into ``state.force`` and ``state.torque``."""

    __slots__ = ("state", "geometry", "neighbors", "clock")

    def __init__(self, state: ParticleState, geometry: "ListGeometry",
                 neighbors: "NeighborList", clock: Clock) -> None:
        self.state = state
        self.geometry = geometry
        self.neighbors = neighbors
        self.clock = clock


class ParticleEditor(Protocol):
    """The particle edits an updater may make (implemented by the simulation)."""

    def add_particles(self, x: np.ndarray, radius: np.ndarray | float,
                      **kw: Any) -> np.ndarray: ...

    def remove_particles(self, mask: np.ndarray) -> np.ndarray: ...

    def relocate(self, index: np.ndarray, x: np.ndarray, v: np.ndarray | None = None,
                 omega: np.ndarray | None = None) -> None: ...


class UpdateContext(ForceContext):
    """What updaters see: a :class:`ForceContext` plus the run's random generator and the
    particle edits :meth:`add_particles`, :meth:`remove_particles` and :meth:`relocate`
    (which keep contact histories, integrator memories and forces consistent)."""

    __slots__ = ("rng", "_editor")

    def __init__(self, base: ForceContext, rng: np.random.Generator,
                 editor: ParticleEditor) -> None:
        super().__init__(base.state, base.geometry, base.neighbors, base.clock)
        self.rng = rng
        self._editor = editor

    def add_particles(self, x: np.ndarray, radius: np.ndarray | float, **kw: Any) -> np.ndarray:
        """Insert particles (:meth:`~grainflow.state.ParticleState.add_particles`)."""
        return self._editor.add_particles(x, radius, **kw)

    def remove_particles(self, mask: np.ndarray) -> np.ndarray:
        """Delete particles where ``mask`` is true; returns the old-to-new index map."""
        return self._editor.remove_particles(mask)

    def relocate(self, index: np.ndarray, x: np.ndarray, v: np.ndarray | None = None,
                 omega: np.ndarray | None = None) -> None:
        """Move particles (reinsertion): their contact and integrator histories restart."""
        self._editor.relocate(index, x, v, omega)


class ObserverQueries(Protocol):
    """The read-only queries an observer may make (implemented by the simulation)."""

    rebuilds: int
    particle_steps: int

    def frame(self, contacts: bool = False) -> Frame: ...

    def contacts(self) -> Contacts: ...

    def max_overlap(self) -> float: ...


class ObserverContext(_Clocked):
    """What observers see: the clock, the particles (to read, not to change) and read-only
    queries. Nothing reached from here advances a contact history."""

    __slots__ = ("state", "clock", "_queries")

    def __init__(self, state: ParticleState, clock: Clock, queries: ObserverQueries) -> None:
        self.state = state
        self.clock = clock
        self._queries = queries

    @property
    def rebuilds(self) -> int:
        """Neighbour-list builds so far."""
        return self._queries.rebuilds

    @property
    def particle_steps(self) -> int:
        """Sum over steps of the particle count (the speed measure)."""
        return self._queries.particle_steps

    def frame(self, contacts: bool = False) -> Frame:
        """A copy of the current state (with its contacts if asked)."""
        return self._queries.frame(contacts)

    def contacts(self) -> Contacts:
        """Every force between two bodies now (:class:`~grainflow.frame.Contacts`)."""
        return self._queries.contacts()

    def max_overlap(self) -> float:
        """Largest particle-particle or particle-wall overlap now."""
        return self._queries.max_overlap()


@dataclass(frozen=True)
class TimeScale:
    """A time an explicit step must resolve: an ``"oscillation"`` (half period of a contact
    or spring; dt must stay well below it), a ``"relaxation"`` (decay time of a velocity
    by a dissipative force; dt must stay below it) or a ``"crossing"`` (time a pair leaving
    contact at its escape speed takes to cross a cohesive shell; past it the step, not the
    law, decides which pairs stay bound, though nothing goes unstable). ``source`` names
    the interaction."""

    time: float
    kind: str
    source: str


@dataclass(frozen=True)
class ContactRows:
    """Forces between two bodies that one operation exerts now, in the simulation's
    indices: particle index ``i``, partner ``j`` (particle index for pairs and bonds, the
    operation's own wall index for walls, -1 for anchors), ``kind`` (``frame.PAIR`` ...),
    force on ``i`` (M, 3) and branch vector from the partner to ``i`` (M, 3)."""

    i: np.ndarray
    j: np.ndarray
    kind: int
    force: np.ndarray
    branch: np.ndarray


class Force(ABC):
    """A force operation: adds into ``state.force``/``state.torque`` every step.

    ``update`` is False during read-only evaluations (set-up, contact listing, FIRE), when
    no history may change (LAMMPS's set-up call; lammps#1631). Operations that remember
    something between steps implement :meth:`state_dict`/:meth:`load_state_dict` for
    checkpoints; those with contacts or stability limits report them.
    """

    #: Analytic wall shapes this operation owns (numbered in the simulation's wall list).
    walls: tuple = ()

    def setup(self, ctx: ForceContext) -> None:
        """Called once when the operation is added to a simulation."""

    @abstractmethod
    def compute(self, ctx: ForceContext, update: bool) -> None:
        """Add this operation's forces at the current positions."""

    def step_call(self, ctx: ForceContext) -> "StepCall | None":
        """``compute(ctx, update=True)`` as a compiled call ``adapter(args, time, dt, last)``
        for runs of steps without Python (:mod:`grainflow.engine.fast_path`), valid until the
        particle set or the neighbour list changes; None (the default): the simulation steps
        in Python."""
        return None

    def neighbor_reach(self) -> float | None:
        """How far beyond touching (``r_i + r_j``) this operation needs the neighbour list
        to list pairs; None (the default) for an operation that does not read the pairs."""
        return None

    def time_scales(self, ctx: ForceContext) -> list[TimeScale]:
        """The times this operation's forces need resolved (for the time-step check)."""
        return []

    def contacts(self, ctx: ForceContext) -> list[ContactRows]:
        """Its forces between two bodies now, without changing any history."""
        return []

    def max_overlap(self, ctx: ForceContext) -> tuple[float, float, int]:
        """Largest overlap it sees now: absolute, relative to the particle's radius, and the
        particle index of the latter (``(0, 0, -1)`` if none)."""
        return 0.0, 0.0, -1

    def potential_energy(self, ctx: ForceContext) -> float | None:
        """Energy stored in its conservative field now (gravity: ``-sum m g.x``; a spring:
        ``k s^2 / 2``), 0 for a purely dissipative force, or None when it can supply energy
        the health check's energy balance cannot count (a moving wall, cohesion). Elastic
        energy of contacts is not counted here: the check bounds it from the contact list.
        """
        return None

    def reindex(self, old_to_new: np.ndarray) -> None:
        """Particles were deleted (``old_to_new[i] = -1``) or permuted."""

    def state_dict(self) -> dict[str, Any]:
        return {}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        pass

    def nbytes(self) -> int:
        return 0


class Integrator(ABC):
    """An integrator: the two halves of a time step around the force evaluation."""

    name = "integrator"

    def setup(self, ctx: ForceContext) -> None:
        """Register per-particle memory (``state.add_array(..., reset_on_move=True)``)."""

    @abstractmethod
    def pre_force(self, ctx: ForceContext) -> None:
        """Before forces are evaluated at the new positions."""

    def post_force(self, ctx: ForceContext) -> None:
        """After the forces of the step are known."""

    def step_calls(self, ctx: ForceContext) -> "tuple[StepCall, StepCall, StepCall] | None":
        """``pre_force``, ``post_force``, and ``post_force`` followed by the next step's
        ``pre_force`` as one call (e.g. one pass over the particles instead of two, bitwise
        the same as the two), as compiled calls (see :meth:`Force.step_call`); None (the
        default): the simulation steps in Python."""
        return None


class Updater(ABC):
    """An operation that may insert, delete or move particles, every ``every`` steps."""

    #: True for an updater that changes the simulation only through the context's particle
    #: edits and in place (e.g. :meth:`UpdateContext.relocate`): it replaces no array and no
    #: parameter an operation holds, so the compiled step loop keeps its step calls after
    #: it acts (an insertion or deletion still renews them: it changes the particle set).
    #: False (the default, and for plain functions) makes the loop collect them again.
    keeps_step_calls: bool = False

    @abstractmethod
    def update(self, ctx: UpdateContext) -> None:
        """Act on the system (after the step's integration)."""


#: An observer: ``observer(ctx)`` every ``every`` steps; an optional ``start(ctx)`` method
#: runs when a run begins (e.g. to log the initial state).
Observer = Callable[[ObserverContext], None]
