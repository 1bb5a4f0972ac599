"""A saved snapshot of a simulation: the unit that outputs write and analyses read.

Analyses in :mod:`grainflow.analysis` are pure functions of :class:`Frame` objects (or of
arrays taken from them), never of a live :class:`~grainflow.engine.simulation.Simulation`;
this keeps coarse-graining and post-processing outside the engine, as MercuryCG does.

Array shapes use ``dim`` = 2 (disks) or 3 (spheres). Angular velocity is stored with 3
components in both cases; in 2D only the z component is non-zero.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Box:
    """Simulation box: ``lo``/``hi`` (dim,) bounds and which axes are periodic.

    Bounds on a non-periodic axis are informational (the bounding region of the set-up);
    particles may leave them, and the neighbour search does not rely on them.
    """

    lo: np.ndarray
    hi: np.ndarray
    periodic: tuple[bool, ...]

    @property
    def dim(self) -> int:
        return len(self.periodic)

    @property
    def lengths(self) -> np.ndarray:
        return np.asarray(self.hi, dtype=float) - np.asarray(self.lo, dtype=float)


@dataclass(frozen=True)
class Contacts:
    """Pair contacts of one frame.

    ``i``, ``j``: (M,) particle ids (not indices); ``force``: (M, dim) force on ``i`` from
    ``j``; ``branch``: (M, dim) vector from the centre of ``j`` to the centre of ``i``
    (minimum image), so the contact stress is ``sum force (x) branch / V``.
    """

    i: np.ndarray
    j: np.ndarray
    force: np.ndarray
    branch: np.ndarray


@dataclass(frozen=True)
class Frame:
    """Per-particle state at one step. All arrays are copies owned by the frame."""

    step: int
    time: float
    box: Box
    id: np.ndarray  # (N,) int64, stable particle ids
    type: np.ndarray  # (N,) int32
    body: np.ndarray  # (N,) int64, -1 for free particles
    radius: np.ndarray  # (N,)
    mass: np.ndarray  # (N,)
    position: np.ndarray  # (N, dim)
    velocity: np.ndarray  # (N, dim)
    omega: np.ndarray  # (N, 3)
    contacts: Contacts | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def dim(self) -> int:
        return self.box.dim

    @property
    def n(self) -> int:
        return int(self.id.shape[0])
