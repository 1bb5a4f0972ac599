"""Particle state: structure-of-arrays storage for 2D disks and 3D spheres.

Every per-particle quantity is a numpy array whose first axis is the particle index, held in
one registry (:attr:`ParticleState.arrays`). Anything that must follow a particle when
particles are re-sorted, inserted or deleted (integrator history, scenario flags, observer
accumulators) is registered there with :meth:`ParticleState.add_array`, so a single
:meth:`ParticleState.reindex` keeps all of it consistent.

Vectors are stored with three components in both 2D and 3D. In 2D the z components of
position, velocity and force stay exactly zero and only the z component of the angular
velocity and torque is used (one rotational degree of freedom); the contact kernels are
written for 3D and reduce exactly to the 2D equations when z = 0. :attr:`positions` and
friends return ``(N, dim)`` views for users.

Moments of inertia: solid sphere ``I = 2/5 m r^2`` (3D), solid disk ``I = 1/2 m r^2`` (2D).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainflow.frame import Box, Frame
from grainflow.kernels.permute import take_rows
from grainflow.rings import RING_VERTEX

#: Fraction ``I / (m r^2)`` for the particle shape of each dimension.
INERTIA_FACTOR = {2: 0.5, 3: 0.4}

_CORE_FIELDS: dict[str, tuple[tuple[int, ...], type]] = {
    "x": ((3,), np.float64),
    "v": ((3,), np.float64),
    "omega": ((3,), np.float64),
    "force": ((3,), np.float64),
    "torque": ((3,), np.float64),
    "radius": ((), np.float64),
    "mass": ((), np.float64),
    "inertia": ((), np.float64),
    "type": ((), np.int32),
    "body": ((), np.int64),
    "frozen": ((), np.bool_),
    "id": ((), np.int64),
    "image": ((3,), np.int64),
}


class _Arrays(dict):
    """The registry of per-particle arrays, mirrored into its owner's attributes so that
    ``state.x`` is a plain attribute lookup (the engine reads dozens per step; a
    ``__getattr__`` fallback cost ~8 % of a small system's step)."""

    def __init__(self, owner: "ParticleState", items: dict[str, np.ndarray]) -> None:
        super().__init__()
        self._owner = owner
        for name, value in items.items():
            self[name] = value

    def __setitem__(self, name: str, value: np.ndarray) -> None:
        if name not in self and name in self._owner.__dict__:
            raise ValueError(f"state array {name!r}: the name is taken by an attribute of "
                             "the state; choose another")
        super().__setitem__(name, value)
        self._owner.__dict__[name] = value

    def __delitem__(self, name: str) -> None:
        super().__delitem__(name)
        self._owner.__dict__.pop(name, None)

    def pop(self, name: str, *default: object) -> object:
        self._owner.__dict__.pop(name, None)
        return super().pop(name, *default)

    def update(self, *args: object, **kw: np.ndarray) -> None:
        for name, value in dict(*args, **kw).items():
            self[name] = value

    def setdefault(self, name: str, value: np.ndarray) -> np.ndarray:  # type: ignore[override]
        if name not in self:
            self[name] = value
        return self[name]


def speeds(v: np.ndarray) -> np.ndarray:
    """(N,) ``|v|`` of (N, d) velocities, without overflow for huge ones (each row is
    scaled by its largest component before squaring); inf where a component is not finite."""
    v = np.asarray(v, dtype=float)
    with np.errstate(all="ignore"):
        scale = np.abs(v).max(axis=1) if len(v) else np.zeros(0)
        unit = v / np.where(scale > 0, scale, 1.0)[:, None]
        speed = scale * np.sqrt(np.einsum("ij,ij->i", unit, unit))
    return np.where(np.isfinite(v).all(axis=1), speed, np.inf)


@dataclass
class _Extra:
    shape: tuple[int, ...]
    dtype: type
    fill: float
    reset_on_move: bool


class ParticleState:
    """Positions, velocities, spins, sizes and labels of all particles.

    Parameters
    ----------
    dim:
        2 (disks in the xy plane) or 3 (spheres).
    box:
        The simulation :class:`~grainflow.frame.Box`; periodic axes wrap positions.
    """

    def __init__(self, dim: int, box: Box) -> None:
        if dim not in (2, 3):
            raise ValueError(f"dim: {dim!r} is not supported; use 2 (disks) or 3 (spheres)")
        if box.dim != dim:
            raise ValueError(f"box: has {box.dim} axes but dim = {dim}; give one bound per axis")
        self.dim = dim
        self.box = box
        self.arrays: dict[str, np.ndarray] = _Arrays(self, {
            name: np.zeros((0, *shape), dtype=dt) for name, (shape, dt) in _CORE_FIELDS.items()
        })
        self._extras: dict[str, _Extra] = {}
        self._next_id = 0
        #: Incremented whenever particle indices change (insert, delete, re-sort).
        self.generation = 0

    # ------------------------------------------------------------------ access
    def __len__(self) -> int:
        return int(self.arrays["x"].shape[0])

    @property
    def n(self) -> int:
        return len(self)

    @property
    def positions(self) -> np.ndarray:
        """(N, dim) view of the positions."""
        return self.arrays["x"][:, : self.dim]

    @property
    def velocities(self) -> np.ndarray:
        """(N, dim) view of the velocities."""
        return self.arrays["v"][:, : self.dim]

    @property
    def spins(self) -> np.ndarray:
        """Angular velocity: (N,) view of omega_z in 2D, (N, 3) view in 3D."""
        om = self.arrays["omega"]
        return om[:, 2] if self.dim == 2 else om

    # --------------------------------------------------------------- extras
    def add_array(self, name: str, shape: tuple[int, ...] = (), dtype: type = np.float64,
                  fill: float = 0.0, *, reset_on_move: bool = False) -> np.ndarray:
        """Register a per-particle array that follows particles through re-indexing.

        New particles get ``fill``. ``reset_on_move``: the array is a memory of the
        particle's recent motion (integrator history, wall-contact history), so
        :meth:`relocate` refills it with ``fill`` too.
        """
        if name in _CORE_FIELDS:
            raise ValueError(f"array name {name!r} is a core field; choose another name")
        if name in self.arrays:
            existing = self._extras[name]
            if existing.shape != tuple(shape) or np.dtype(existing.dtype) != np.dtype(dtype):
                raise ValueError(f"array {name!r} already registered with another shape/dtype")
            return self.arrays[name]
        self._extras[name] = _Extra(tuple(shape), dtype, fill, reset_on_move)
        self.arrays[name] = np.full((self.n, *shape), fill, dtype=dtype)
        return self.arrays[name]

    # ------------------------------------------------------------ mutation
    def add_particles(self, x: np.ndarray, radius: np.ndarray | float, *,
                      density: float | np.ndarray | None = None,
                      mass: np.ndarray | float | None = None,
                      v: np.ndarray | None = None, omega: np.ndarray | None = None,
                      type: np.ndarray | int = 0, body: np.ndarray | int = -1,
                      frozen: np.ndarray | bool = False,
                      ids: np.ndarray | None = None) -> np.ndarray:
        """Append particles; return their indices.

        Give either ``density`` (mass from the disk area in 2D, i.e. mass per unit
        thickness, or the sphere volume in 3D) or ``mass``.
        ``x`` and ``v`` may be (M, dim) or (M, 3).
        """
        x = np.atleast_2d(np.asarray(x, dtype=float))
        m = x.shape[0]
        r = np.broadcast_to(np.asarray(radius, dtype=float), (m,)).copy()
        if np.any(~np.isfinite(r)) or np.any(r <= 0):
            raise ValueError("radius: every radius must be a positive finite number")
        if (density is None) == (mass is None):
            raise ValueError("add_particles: give exactly one of density= or mass=")
        if mass is None:
            rho = np.broadcast_to(np.asarray(density, dtype=float), (m,))
            if np.any(rho <= 0):
                raise ValueError("density: must be positive")
            mass_arr = rho * (np.pi * r**2 if self.dim == 2 else 4.0 / 3.0 * np.pi * r**3)
        else:
            mass_arr = np.broadcast_to(np.asarray(mass, dtype=float), (m,)).copy()
            if np.any(mass_arr <= 0):
                raise ValueError("mass: must be positive")
        new = {
            "x": _to3(x, m, "x"),
            "v": _to3(v, m, "v") if v is not None else np.zeros((m, 3)),
            "omega": _omega3(omega, m, self.dim),
            "force": np.zeros((m, 3)),
            "torque": np.zeros((m, 3)),
            "radius": r,
            "mass": mass_arr,
            "inertia": INERTIA_FACTOR[self.dim] * mass_arr * r**2,
            "type": np.broadcast_to(np.asarray(type, dtype=np.int32), (m,)).copy(),
            "body": np.broadcast_to(np.asarray(body, dtype=np.int64), (m,)).copy(),
            "frozen": np.broadcast_to(np.asarray(frozen, dtype=bool), (m,)).copy(),
            "image": np.zeros((m, 3), dtype=np.int64),
        }
        if np.any(new["type"] < 0):
            raise ValueError("type: particle types must be >= 0")
        if ids is None:
            new["id"] = np.arange(self._next_id, self._next_id + m, dtype=np.int64)
        else:
            new["id"] = np.asarray(ids, dtype=np.int64).reshape(m)
        if self.dim == 2:
            new["x"][:, 2] = 0.0
            new["v"][:, 2] = 0.0
        if m:
            self._next_id = max(self._next_id, int(new["id"].max()) + 1)
        start = self.n
        for name, arr in self.arrays.items():
            if name in new:
                add = new[name]
            else:
                ex = self._extras[name]
                add = np.full((m, *ex.shape), ex.fill, dtype=ex.dtype)
            self.arrays[name] = np.concatenate([arr, add.astype(arr.dtype, copy=False)])
        self.generation += 1
        return np.arange(start, start + m)

    def relocate(self, index: np.ndarray, x: np.ndarray, v: np.ndarray | None = None,
                 omega: np.ndarray | None = None) -> None:
        """Move particles ``index`` to ``x`` (and set ``v``/``omega`` if given), as a
        reinsertion does: every array registered with ``reset_on_move`` forgets their past
        (an Adams-Bashforth force history, wall-contact springs). Pair-contact histories
        live outside the state: use :meth:`grainflow.engine.simulation.Simulation.relocate`,
        which clears those too.
        """
        index = np.atleast_1d(np.asarray(index, dtype=np.int64))
        m = index.shape[0]
        self.arrays["x"][index] = _to3(np.reshape(x, (m, -1)), m, "x")
        if v is not None:
            self.arrays["v"][index] = _to3(np.reshape(v, (m, -1)), m, "v")
        if omega is not None:
            self.arrays["omega"][index] = _omega3(omega, m, self.dim)
        if self.dim == 2:
            self.arrays["x"][index, 2] = 0.0
            self.arrays["v"][index, 2] = 0.0
        for name, extra in self._extras.items():
            if extra.reset_on_move:
                self.arrays[name][index] = extra.fill

    def reindex(self, old_to_new: np.ndarray) -> None:
        """Permute and/or delete particles: ``old_to_new[i]`` is the new index, -1 drops it."""
        keep = old_to_new >= 0
        n_new = int(keep.sum())
        order = np.empty(n_new, dtype=np.int64)
        order[old_to_new[keep]] = np.nonzero(keep)[0]
        for name, arr in self.arrays.items():
            self.arrays[name] = take_rows(arr, order)
        self.generation += 1

    def remove(self, mask: np.ndarray) -> np.ndarray:
        """Delete the particles where ``mask`` is true; return the old-to-new index map."""
        mask = np.asarray(mask, dtype=bool)
        old_to_new = np.full(self.n, -1, dtype=np.int64)
        old_to_new[~mask] = np.arange(int((~mask).sum()))
        self.reindex(old_to_new)
        return old_to_new

    # --------------------------------------------------------------- output
    def to_frame(self, step: int, time: float, contacts=None) -> Frame:
        """Copy the state into a :class:`~grainflow.frame.Frame` (with ``ring_vertex`` when
        the state registered it, :mod:`grainflow.rings`)."""
        d = self.dim
        a = self.arrays
        ring_vertex = a[RING_VERTEX].copy() if RING_VERTEX in a else None
        return Frame(step=step, time=time, box=self.box, id=a["id"].copy(), type=a["type"].copy(),
                     body=a["body"].copy(), radius=a["radius"].copy(), mass=a["mass"].copy(),
                     position=a["x"][:, :d].copy(), velocity=a["v"][:, :d].copy(),
                     omega=a["omega"].copy(), contacts=contacts, ring_vertex=ring_vertex)

    def kinetic_energy(self) -> float:
        """Translational kinetic energy sum 1/2 m v^2."""
        return 0.5 * float(np.sum(self.mass * np.einsum("ij,ij->i", self.v, self.v)))

    def rotational_energy(self) -> float:
        """Rotational kinetic energy sum 1/2 I omega^2."""
        return 0.5 * float(np.sum(self.inertia * np.einsum("ij,ij->i", self.omega, self.omega)))

    def momentum(self) -> np.ndarray:
        """Total linear momentum (3,)."""
        return np.einsum("i,ij->j", self.mass, self.v)


def _to3(a: np.ndarray | None, m: int, name: str) -> np.ndarray:
    a = np.atleast_2d(np.asarray(a, dtype=float))
    if a.shape[0] != m or a.shape[1] not in (2, 3):
        raise ValueError(f"{name}: expected shape ({m}, 2) or ({m}, 3), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: contains NaN or infinity")
    out = np.zeros((m, 3))
    out[:, : a.shape[1]] = a
    return out


def _omega3(omega: np.ndarray | None, m: int, dim: int) -> np.ndarray:
    out = np.zeros((m, 3))
    if omega is None:
        return out
    om = np.asarray(omega, dtype=float)
    if dim == 2 and om.ndim == 1:
        out[:, 2] = om
    else:
        out[:] = om.reshape(m, 3)
        if dim == 2:
            out[:, :2] = 0.0
    return out
