"""Choosing which particles are the flow: a frame restricted to particle types.

Walls made of particles (a jet's tethered target, a rough base) are not part of the flow:
their mass and velocities must stay out of the densities, the mean velocity and the kinetic
stress, while their contacts with grains are forces on the flow and belong in its contact
stress (seed 002 Sec. 5.3.1: the stress of the grains in a layer includes the target's push).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from grainflow.frame import BOND, PAIR, Contacts, Frame

__all__ = ["select_types"]


def select_types(frame: Frame, types: Sequence[int]) -> Frame:
    """The frame restricted to the particles whose type is in ``types``, with every contact
    that acts on one of them.

    The coarse-graining places a branch line from the position of its particle ``i`` (the
    line runs from ``r_i - b`` to ``r_i``), so ``i`` must stay in the frame. A pair or bond
    row whose ``i`` is dropped and whose ``j`` is kept is therefore written from the kept
    side: ``i <-> j``, ``F -> -F`` (Newton's third law), ``b -> -b``, which is the same
    segment and the same tensor ``F (x) b``. Rows between two dropped particles and wall or
    anchor rows of dropped particles are the dropped body's internal forces and are left out.
    The frame itself is returned when nothing is dropped.
    """
    types = np.asarray(types)
    if types.ndim != 1 or types.size == 0:
        raise ValueError(f"types: a non-empty list of particle types, got {types!r}")
    keep = np.isin(np.asarray(frame.type), types)
    if keep.all():
        return frame
    kept_ids = np.asarray(frame.id)[keep]
    contacts = frame.contacts
    if contacts is not None:
        c = contacts
        pair_like = (c.kind == PAIR) | (c.kind == BOND)
        i_kept = np.isin(c.i, kept_ids)
        flip = ~i_kept & pair_like & np.isin(c.j, kept_ids)
        rows = i_kept | flip
        sign = np.where(flip, -1.0, 1.0)[:, None]
        contacts = Contacts(i=np.where(flip, c.j, c.i)[rows], j=np.where(flip, c.i, c.j)[rows],
                            force=(sign * np.asarray(c.force, dtype=float))[rows],
                            branch=(sign * np.asarray(c.branch, dtype=float))[rows],
                            kind=np.asarray(c.kind)[rows])
    n = frame.n
    extra = {k: (np.asarray(v)[keep] if np.ndim(v) and np.shape(v)[0] == n else v)
             for k, v in frame.extra.items()}
    return Frame(step=frame.step, time=frame.time, box=frame.box, id=frame.id[keep],
                 type=frame.type[keep], body=frame.body[keep], radius=frame.radius[keep],
                 mass=frame.mass[keep], position=frame.position[keep],
                 velocity=frame.velocity[keep], omega=frame.omega[keep], contacts=contacts,
                 ring_vertex=None if frame.ring_vertex is None else frame.ring_vertex[keep],
                 extra=extra)
