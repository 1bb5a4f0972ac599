"""The simulation object: state plus a list of operations, advanced step by step.

Order of work within one step of :meth:`Simulation.run` (the same for every set-up)::

    1. integrator.pre_force        (VV: half kick + drift; AB2: the whole step)
    2. neighbour list: wrap periodic positions; rebuild if some particle moved > skin/2
       (every ``sort_every`` builds also re-sort particles in space, history carried along)
    3. forces: pair law over the list (it sets force and torque; zero without a law), then
       every operation in ``forces``
       (walls, tethers, gravity, drag ...) in the order they were added
    4. integrator.post_force       (VV: second half kick)
    5. step += 1, time += dt
    6. updaters due this step      (insertion, deletion, reinsertion; may change N)
    7. observers due this step     (outputs, analyses; read-only access to state/contacts)
    8. health check every ``check_every`` steps (NaN/inf, overlap > max_overlap_fraction r)

Before the first step forces are evaluated once without advancing contact histories
(LAMMPS's set-up call), unless they are already current (e.g. after a checkpoint load).
"""

from __future__ import annotations

import time as _time
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Protocol

import numpy as np

from grainflow.engine.forces import Force, PairForce
from grainflow.engine.integrators import Integrator, VelocityVerlet
from grainflow.engine.neighbor_list import ListGeometry, NeighborList
from grainflow.frame import Contacts, Frame
from grainflow.kernels.pair_loop import max_pair_overlap, max_relative_overlap
from grainflow.models.base import ContactLaw
from grainflow.state import ParticleState


class InstabilityError(RuntimeError):
    """The run went unstable; ``step``, ``particle`` (id) and ``reason`` say where and why."""

    def __init__(self, step: int, particle: int, reason: str) -> None:
        super().__init__(f"unstable at step {step}, particle id {particle}: {reason}")
        self.step = step
        self.particle = particle
        self.reason = reason


class TimeStepError(ValueError):
    """The time step is past the hard stability limit."""


class Updater(Protocol):
    """An operation that may insert/delete particles: ``update(sim)``."""

    def update(self, sim: "Simulation") -> None: ...


@dataclass
class _Scheduled:
    every: int
    action: Callable[["Simulation"], None]
    owner: Any


#: dt above ``contact_time / WARN_RATIO`` warns, above ``contact_time / REFUSE_RATIO`` refuses.
WARN_RATIO = 15.0
REFUSE_RATIO = 4.0


class Simulation:
    """State, pair law, operations and the step loop.

    Parameters
    ----------
    state:
        The particles.
    dt:
        Time step.
    law:
        The particle-particle :class:`~grainflow.models.base.ContactLaw` (None: no pair forces).
    skin:
        Verlet skin; default 0.1 of the mean diameter.
    integrator:
        Default :class:`VelocityVerlet`.
    """

    def __init__(self, state: ParticleState, dt: float, law: ContactLaw | None = None, *,
                 skin: float | None = None, integrator: Integrator | None = None,
                 sort_every: int = 1, check_every: int = 100,
                 max_overlap_fraction: float = 0.5, seed: int | None = None) -> None:
        if not (dt > 0 and np.isfinite(dt)):
            raise ValueError(f"dt: {dt!r} is not valid; expected a positive time step")
        self.state = state
        self.dt = float(dt)
        self.step = 0
        self.time = 0.0
        if skin is None:
            skin = 0.2 * float(np.mean(state.radius)) if state.n else 0.1
        self.neighbors = NeighborList(skin, sort_every)
        self.geometry = ListGeometry.from_state(state)
        self.pair = PairForce(law) if law is not None else None
        self.forces: list[Force] = []
        self.integrator = integrator or VelocityVerlet()
        self.integrator.setup(self)
        self.updaters: list[_Scheduled] = []
        self.observers: list[_Scheduled] = []
        self.check_every = int(check_every)
        self.max_overlap_fraction = float(max_overlap_fraction)
        self.forces_current = False
        #: The run's random-number generator (insertion, thinning); saved in checkpoints.
        self.rng = np.random.default_rng(seed)
        self.rebuilds = 0
        self.wall_seconds = 0.0
        self.particle_steps = 0

    # ----------------------------------------------------------- composition
    def add_force(self, force: Force) -> Force:
        """Append a force operation (walls, tethers, gravity, drag ...)."""
        self.forces.append(force)
        setup = getattr(force, "setup", None)
        if setup is not None:
            setup(self)
        self.forces_current = False
        return force

    def add_updater(self, updater: Updater | Callable[["Simulation"], None],
                    every: int = 1) -> None:
        """Run ``updater.update(sim)`` (or ``updater(sim)``) every ``every`` steps."""
        action = updater.update if hasattr(updater, "update") else updater
        self.updaters.append(_Scheduled(int(every), action, updater))

    def add_observer(self, observer: Callable[["Simulation"], None], every: int = 1) -> None:
        """Call ``observer(sim)`` every ``every`` steps (after the step's updaters)."""
        if every < 1:
            raise ValueError("every: observers need an interval >= 1 step")
        self.observers.append(_Scheduled(int(every), observer, observer))

    # -------------------------------------------------------- particle edits
    def add_particles(self, x: np.ndarray, radius: np.ndarray | float, **kw: Any) -> np.ndarray:
        """Insert particles (see :meth:`ParticleState.add_particles`); forces are refreshed."""
        idx = self.state.add_particles(x, radius, **kw)
        if self.pair is not None:
            self.pair.law.ensure_types(int(self.state.type.max()) + 1)
        self.forces_current = False
        return idx

    def remove_particles(self, mask: np.ndarray) -> np.ndarray:
        """Delete particles where ``mask`` is true; contact histories follow."""
        old_to_new = self.state.remove(mask)
        if self.pair is not None:
            self.pair.reindex(old_to_new)
        self.forces_current = False
        return old_to_new

    # ------------------------------------------------------------- forces
    def _refresh_list(self) -> None:
        st = self.state
        nl = self.neighbors
        if not nl.needs_build(st, self.geometry):
            return
        reach = self.pair.law.reach() if self.pair is not None else 0.0
        nl.wrap(st, self.geometry)
        cells = nl.cell_order(st, self.geometry, reach)
        new_to_old = None
        if nl.sort_due() and st.n:
            new_to_old = cells[2]
            old_to_new = np.empty(st.n, dtype=np.int64)
            old_to_new[new_to_old] = np.arange(st.n)
            st.reindex(old_to_new)
            cells = nl.in_new_order(cells)
        nl.build(st, self.geometry, cells)
        if self.pair is not None:
            # the pair history follows the re-sort and the rebuild in one pass
            self.pair.attach(nl.row_ptr, nl.nbr, new_to_old)
        self.rebuilds += 1

    def compute_forces(self, update: bool = True) -> None:
        """Zero and recompute all forces and torques at the current positions."""
        st = self.state
        self._refresh_list()
        if self.pair is not None:
            self.pair.compute(self, update)  # sets (not adds) force and torque
        else:
            st.force[:] = 0.0
            st.torque[:] = 0.0
        for f in self.forces:
            f.compute(self, update)
        self.forces_current = True

    # ---------------------------------------------------------------- run
    def run(self, steps: int, *, until: Callable[["Simulation"], bool] | None = None) -> None:
        """Advance ``steps`` time steps (stop early when ``until(sim)`` becomes true)."""
        if steps < 0:
            raise ValueError("steps: must be >= 0")
        self.check_time_step()
        if not self.forces_current:
            self.compute_forces(update=False)
        integ = self.integrator
        t0 = _time.perf_counter()
        for _ in range(steps):
            integ.pre_force(self)
            self.compute_forces(update=True)
            integ.post_force(self)
            self.step += 1
            self.time += self.dt
            self.particle_steps += self.state.n
            for u in self.updaters:
                if self.step % u.every == 0:
                    u.action(self)
            if not self.forces_current:
                self.compute_forces(update=False)
            if self.check_every and self.step % self.check_every == 0:
                self.check_health()
            for o in self.observers:
                if self.step % o.every == 0:
                    o.action(self)
            if until is not None and until(self):
                break
        self.wall_seconds += _time.perf_counter() - t0

    # ------------------------------------------------------------ checks
    def contact_time(self) -> float:
        """Shortest binary contact time over the type pairs present (inf without a law)."""
        if self.pair is None or self.state.n == 0:
            return float("inf")
        st = self.state
        law = self.pair.law
        best = float("inf")
        types = np.unique(st.type)
        for a in types:
            ma = float(st.mass[st.type == a].min())
            ra = float(st.radius[st.type == a].min())
            for b in types[types >= a]:
                mb = float(st.mass[st.type == b].min())
                rb = float(st.radius[st.type == b].min())
                best = min(best, law.contact_time(int(a), int(b), ma * mb / (ma + mb), ra + rb))
        return best

    def check_time_step(self) -> None:
        """Warn if ``dt > t_c/15``; refuse (TimeStepError) if ``dt > t_c/4``."""
        tc = self.contact_time()
        if not np.isfinite(tc):
            return
        if self.dt > tc / REFUSE_RATIO:
            raise TimeStepError(
                f"dt: {self.dt:g} exceeds the hard limit t_c/{REFUSE_RATIO:g} = "
                f"{tc / REFUSE_RATIO:g} (contact time t_c = {tc:g}); use dt <= {tc / 50:g} "
                f"(t_c/50, seed 002's choice)")
        if self.dt > tc / WARN_RATIO:
            warnings.warn(f"dt = {self.dt:g} is larger than t_c/{WARN_RATIO:g} = "
                          f"{tc / WARN_RATIO:g}: contacts are resolved by few steps; "
                          f"t_c/50 = {tc / 50:g} is safer", stacklevel=2)

    def max_overlap(self) -> float:
        """Largest particle-particle or particle-wall overlap now."""
        self._refresh_list()
        st = self.state
        best = float(max_pair_overlap(self.neighbors.row_ptr, self.neighbors.nbr, st.x,
                                      st.radius, self.geometry.length, self.geometry.periodic))
        for f in self.forces:
            wall_overlap = getattr(f, "max_overlap", None)
            if wall_overlap is not None:
                best = max(best, float(wall_overlap(self)))
        return best

    def check_health(self) -> None:
        """Raise :class:`InstabilityError` on non-finite state or excessive overlap."""
        st = self.state
        for name in ("x", "v", "omega"):
            if np.isfinite(st.arrays[name]).all():
                continue
            bad = ~np.isfinite(st.arrays[name]).all(axis=1)
            if bad.any():
                i = int(np.argmax(bad))
                raise InstabilityError(
                    self.step, int(st.id[i]),
                    f"non-finite {name}; the time step dt = {self.dt:g} is probably too large "
                    f"for the contact time t_c = {self.contact_time():g}")
        if st.n and self.pair is not None:
            frac = self._max_overlap_fraction()
            if frac[0] > self.max_overlap_fraction:
                raise InstabilityError(
                    self.step, int(st.id[frac[1]]),
                    f"overlap {frac[0]:.3g} of the radius exceeds max_overlap_fraction = "
                    f"{self.max_overlap_fraction:g}; particles are too soft for the load or "
                    f"dt = {self.dt:g} is too large for t_c = {self.contact_time():g}")

    def _max_overlap_fraction(self) -> tuple[float, int]:
        st = self.state
        nl = self.neighbors
        if nl.n_pairs == 0:
            return 0.0, 0
        g = self.geometry
        rel, row = max_relative_overlap(nl.row_ptr, nl.nbr, st.x, st.radius, g.length,
                                        g.periodic)
        return float(rel), int(row)

    # ----------------------------------------------------------- outputs
    def contacts(self) -> Contacts:
        """Current interacting pairs (ids, force on i, branch vector), copies."""
        d = self.state.dim
        if self.pair is None:
            e = np.zeros(0, dtype=np.int64)
            return Contacts(e, e.copy(), np.zeros((0, d)), np.zeros((0, d)))
        if not self.forces_current:
            self.compute_forces(update=False)
        pi, pj, f, b = self.pair.contacts(self)
        ids = self.state.id
        return Contacts(ids[pi], ids[pj], f[:, :d], b[:, :d])

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
        data: dict[str, Any] = {
            "step": self.step, "time": self.time, "dt": self.dt,
            "particle_steps": self.particle_steps,
            "forces_current": self.forces_current,
            "arrays": {k: v.copy() for k, v in self.state.arrays.items()},
            "next_id": self.state._next_id,
            "neighbors": {"row_ptr": nl.row_ptr.copy(), "nbr": nl.nbr.copy(),
                          "col_ptr": nl.col_ptr.copy(), "col_pair": nl.col_pair.copy(),
                          "x_ref": nl._x_ref.copy(), "builds": nl.builds},
            "pair": self.pair.state_dict() if self.pair is not None else {},
            "forces": {str(k): f.state_dict() for k, f in enumerate(self.forces)},
            "updaters": {str(k): u.owner.state_dict() for k, u in enumerate(self.updaters)
                         if hasattr(u.owner, "state_dict")},
            "rng": self.rng.bit_generator.state,
        }
        return data

    def load_state_dict(self, data: dict[str, Any]) -> None:
        """Restore a :meth:`state_dict` into a simulation built with the same operations."""
        st = self.state
        arrays = data["arrays"]
        for name, arr in arrays.items():
            if name not in st.arrays:
                st.add_array(name, arr.shape[1:], arr.dtype)
            st.arrays[name] = np.array(arr, dtype=st.arrays[name].dtype)
        st._next_id = int(data["next_id"])
        st.generation += 1
        self.step = int(data["step"])
        self.time = float(data["time"])
        self.dt = float(data["dt"])
        self.particle_steps = int(data.get("particle_steps", 0))
        nl = self.neighbors
        nb = data["neighbors"]
        nl.row_ptr = np.asarray(nb["row_ptr"], dtype=np.int64)
        nl.nbr = np.asarray(nb["nbr"], dtype=np.int64)
        nl.index_columns()  # the transpose is a function of the rows (saved for readers)
        nl._x_ref = np.asarray(nb["x_ref"], dtype=np.float64)
        nl.builds = int(nb["builds"])
        nl._generation = st.generation
        if self.pair is not None:
            self.pair.load_state_dict(data["pair"])
            if self.pair.active.shape[0] != nl.n_pairs:
                raise ValueError("checkpoint: pair history does not match the neighbour list")
        for k, f in enumerate(self.forces):
            f.load_state_dict(data["forces"].get(str(k), {}))
        for k, u in enumerate(self.updaters):
            if hasattr(u.owner, "load_state_dict") and str(k) in data["updaters"]:
                u.owner.load_state_dict(data["updaters"][str(k)])
        self.rng.bit_generator.state = data["rng"]
        # Forces and per-pair buffers are saved as they were: the next step continues
        # exactly where the saved run was.
        self.forces_current = bool(data["forces_current"])

    def memory_bytes(self) -> dict[str, int]:
        """Bytes held by particle state, neighbour list and contact history."""
        hist = self.pair.nbytes() if self.pair is not None else 0
        hist += sum(f.nbytes() for f in self.forces)
        return {"state": int(sum(a.nbytes for a in self.state.arrays.values())),
                "neighbors": self.neighbors.nbytes(), "history": int(hist)}
