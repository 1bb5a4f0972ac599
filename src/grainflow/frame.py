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


#: ``Contacts.kind`` codes: what the partner ``j`` of a contact is.
PAIR, WALL, BOND, ANCHOR = 0, 1, 2, 3
#: Names of the ``kind`` codes, in code order.
CONTACT_KINDS = ("pair", "wall", "bond", "anchor")


@dataclass(frozen=True)
class Contacts:
    """Every force between two bodies in one frame, with its branch vector.

    ``i``: (M,) particle ids (not indices); ``kind``: (M,) int8 code saying what the partner
    is (:data:`PAIR`, :data:`WALL`, :data:`BOND`, :data:`ANCHOR`); ``j``: (M,) the partner:
    a particle id for pair contacts and bonds (tethers between particles), the wall's index
    for wall contacts (walls numbered in the order the simulation's wall operations list
    them, see :meth:`grainflow.engine.simulation.Simulation.walls`), -1 for a tether to a
    fixed anchor point; ``force``: (M, dim) force on ``i`` from ``j``; ``branch``: (M, dim)
    vector from the partner to the centre of ``i``: from the centre of ``j`` (minimum image)
    for pairs and bonds, from the wall's contact point for walls, from the anchor point for
    anchors. The contact stress of a region of volume V is ``sum force (x) branch / V`` over
    its pairs and bonds (each counted once, as listed) plus the wall and anchor terms.
    ``kind`` may be omitted (None): every row is then a particle pair.
    """

    i: np.ndarray
    j: np.ndarray
    force: np.ndarray
    branch: np.ndarray
    kind: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.kind is None:
            object.__setattr__(self, "kind", np.zeros(np.shape(self.i)[0], dtype=np.int8))

    def of_kind(self, kind: int) -> "Contacts":
        """The rows of one kind (e.g. ``contacts.of_kind(PAIR)``)."""
        return self.select(self.kind == kind)

    def select(self, rows: np.ndarray) -> "Contacts":
        """The rows where the boolean mask ``rows`` is true (or the rows of an index array)."""
        return Contacts(self.i[rows], self.j[rows], self.force[rows], self.branch[rows],
                        self.kind[rows])


@dataclass(frozen=True)
class Frame:
    """Per-particle state at one step. All arrays are copies owned by the frame.

    ``ring_vertex`` (N,) int32: each particle's place in its deformable ring
    (:mod:`grainflow.rings`; -1 = in no ring), counter-clockwise, the ring being its
    ``body``. None when the state registered no rings (and in frames read back from a
    trajectory in which no particle of the frame is in a ring).
    """

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
    ring_vertex: np.ndarray | None = None  # (N,) int32, -1 outside rings; None: no rings
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def dim(self) -> int:
        return self.box.dim

    @property
    def n(self) -> int:
        return int(self.id.shape[0])
