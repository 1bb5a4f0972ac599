"""Whole-ring crossing events and reinsertion for hopper flows of deformable particles.

:class:`~grainflow.scenarios.hopper_reinsertion.HopperReinsertion` works on grains: their
positions, velocities, radii and ids, a per-grain flag, and a ``relocate``. For deformable
particles (SPEC M6) a grain is a ring of vertices, so :class:`RingReinsertion` hands it a
view in which each ring is one grain:

* position: the ring's centroid (the mean of its vertices, which have equal masses);
* velocity: the mean vertex velocity (the ring's centre-of-mass velocity);
* radius: the ring's outer radius now, the largest vertex distance from the centroid plus
  the vertex's contact radius, so placements clear every vertex of the other rings (and a
  ring is due for reinsertion when its centroid is ``depth`` outer diameters below the
  orifice);
* id: the ring's body id; an event's size is the ring's preferred area ``a0``
  (``pi sigma^2/4`` of its effective diameter), so Q is an area rate as for SP grains;
* relocation translates every vertex of the ring by the same vector (its shape is kept) and
  gives them all the new velocity.

The rule (when a grain counts, where it goes) is exactly the SP one; only the grain is the
ring. The per-grain flag is kept on every vertex of the ring, so it survives re-sorting and
checkpoints like any per-particle array.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainflow.engine.operations import ForceContext, UpdateContext, Updater
from grainflow.kernels.dp_shape import ring_centres
from grainflow.rings import state_ring_table
from grainflow.scenarios.hopper_reinsertion import OUT_FLAG, HopperReinsertion


class _RingGrains:
    """The rings of a state seen as grains (the attributes HopperReinsertion reads);
    ``area0`` maps a ring's body id to its counted size."""

    def __init__(self, state: Any, n_vertices: int, area0: dict[int, float]) -> None:
        self.body, self.index = state_ring_table(state, n_vertices)
        self.x, self.v, self.radius = ring_centres(self.index, state.x, state.v, state.radius)
        self.id = self.body
        self.n = int(self.body.size)
        self.area0 = np.array([area0[int(b)] for b in self.body])
        self.arrays = {OUT_FLAG: state.arrays[OUT_FLAG][self.index[:, 0]].copy()}

    def event_size(self, index: np.ndarray) -> np.ndarray:
        """Area counted for rings ``index``: their preferred area."""
        return self.area0[index]


class _RingContext:
    """An :class:`UpdateContext` in which the grains are rings (see the module docstring)."""

    def __init__(self, ctx: UpdateContext, grains: _RingGrains) -> None:
        self._ctx = ctx
        self.state = grains
        self.rng = ctx.rng
        self.time = ctx.time

    def relocate(self, i: int | np.ndarray, x: np.ndarray, v: np.ndarray | None = None,
                 omega: np.ndarray | None = None) -> None:
        """Translate ring ``i`` so that its centroid is at ``x``; every vertex takes ``v``."""
        g = self.state
        i = int(np.atleast_1d(i)[0])
        target = np.zeros(3)
        target[: np.size(x)] = np.ravel(x)
        vertices = self._ctx.state.x[g.index[i]]
        new_x = vertices - g.x[i] + target
        new_v = None
        if v is not None:
            new_v = np.zeros((g.index.shape[1], 3))
            new_v[:, : np.size(v)] = np.ravel(v)
        self._ctx.relocate(g.index[i], new_x, v=new_v,
                           omega=np.zeros((g.index.shape[1], 3)))
        g.x[i] = target
        if new_v is not None:
            g.v[i] = new_v[0]


class RingReinsertion(Updater):
    """:class:`HopperReinsertion` applied to whole rings (module docstring).

    ``inner`` holds the rule, the events and the lane counter; ``area0`` maps a ring's body
    id to its preferred area (the counted size).
    """

    #: It only moves whole rings, in place: the compiled step loop keeps its step calls.
    keeps_step_calls = True

    def __init__(self, inner: HopperReinsertion, n_vertices: int,
                 area0: dict[int, float]) -> None:
        self.inner = inner
        self.n_vertices = int(n_vertices)
        self.area0 = dict(area0)

    def setup_state(self, ctx: ForceContext) -> None:
        self.inner.setup_state(ctx)

    def update(self, ctx: UpdateContext) -> None:
        st = ctx.state
        if OUT_FLAG not in st.arrays:
            self.setup_state(ctx)
        grains = _RingGrains(st, self.n_vertices, self.area0)
        self.inner.update(_RingContext(ctx, grains))
        flags = st.arrays[OUT_FLAG]
        flags[grains.index] = grains.arrays[OUT_FLAG][:, None]

    def state_dict(self) -> dict[str, Any]:
        return self.inner.state_dict()

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self.inner.load_state_dict(data)
