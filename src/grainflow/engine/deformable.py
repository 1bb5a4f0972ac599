"""The shape energy of 2D deformable particles (SPEC M6; seed 003 eq. 8) as a force
operation.

Each ring of vertex particles (:mod:`grainflow.rings`) has the energy

.. math::

    U_m = \\frac{k_a}{2 a_{m,0}}(a_m - a_{m,0})^2
          + \\frac{k_l N_v}{2}\\sum_{i=1}^{N_v}(l_{m,i} - l_{m,0})^2
          + \\frac{k_b a_{m,0}^2}{2 \\pi N_v l_{m,0}^4}
            \\sum_{i=1}^{N_v} |\\vec l_{m,i} - \\vec l_{m,i-1}|^2 ,

seed 003 eq. 8 in the normalisation of the authors' code (docs/dp.md): the area term divided
by ``a0`` and the bending term with ``a0^2/pi`` and the ``l0^4`` denominator the seed copy
lost. All three stiffnesses are then energies per area and every term of ``U_m`` scales as
``a0`` at a given strain, so small and large rings of a mixture are equally deformable; the
``1/N_v`` and ``N_v`` factors make ``U_m`` independent of ``N_v`` (the seed's remark).
Forces and their derivation: :mod:`grainflow.kernels.dp_shape`.

A ring's preferred area ``a0`` is its area when this operation first sees it (rings are
built as regular polygons of area ``a0`` by :func:`grainflow.insertion.dp_bodies.add_rings`)
unless given, and ``l0 = sqrt(4 a0 tan(pi/N_v)/N_v)``, the edge of the regular polygon.
Both are kept per ring (by body id) in checkpoints.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from grainflow.engine.fast_path import StepCall, step_call
from grainflow.engine.operations import Force, ForceContext, TimeScale
from grainflow.kernels.dp_shape import ring_areas, shape_energy, shape_forces
from grainflow.rings import rest_length, state_ring_table


def _shape_step(a, time, dt, last):
    """:meth:`ShapeForce.compute` in the compiled step loop (``KERNEL`` bound)."""
    KERNEL(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10])  # noqa: F821


class ShapeForce(Force):
    """Area, perimeter and bending forces of every deformable ring (seed 003 eq. 8).

    Parameters
    ----------
    k_a, k_l, k_b:
        Area, perimeter-spring and bending stiffnesses (each an energy per area). In seed
        units (``sigma_avg = g = rho = 1``) they are the dimensionless ``K_a``, ``K_l``,
        ``K_b`` of docs/dp.md.
    n_vertices:
        Vertices per ring (seed 003: 16); every ring must have this many.
    a0:
        Preferred areas by body id (a mapping); rings not listed take their area when first
        seen.
    """

    def __init__(self, k_a: float, k_l: float, k_b: float, *, n_vertices: int = 16,
                 a0: Mapping[int, float] | None = None) -> None:
        for name, value in (("k_a", k_a), ("k_l", k_l), ("k_b", k_b)):
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: {value!r} is not valid; expected a non-negative "
                                 "stiffness")
        if not (isinstance(n_vertices, (int, np.integer)) and n_vertices >= 3):
            raise ValueError(f"n_vertices: {n_vertices!r} is not valid; expected an "
                             "integer >= 3")
        self.k_a, self.k_l, self.k_b = float(k_a), float(k_l), float(k_b)
        self.n_vertices = int(n_vertices)
        self._given = {int(b): float(v) for b, v in (a0 or {}).items()}
        if any(not (v > 0 and np.isfinite(v)) for v in self._given.values()):
            raise ValueError("a0: every preferred area must be a positive finite number")
        #: Body ids of the rings known so far (ascending) and their a0 (l0 follows from a0).
        self.ring_body = np.zeros(0, dtype=np.int64)
        self.a0 = np.zeros(0)
        self._generation = -1
        self._index = np.zeros((0, self.n_vertices), dtype=np.int64)
        self._body_now = np.zeros(0, dtype=np.int64)
        self._a0_now = np.zeros(0)
        self._l0_now = np.zeros(0)

    # ----------------------------------------------------------------- rings
    def setup(self, ctx: ForceContext) -> None:
        self._refresh(ctx)

    def _refresh(self, ctx: ForceContext) -> None:
        """Ring table and per-ring a0, l0 for the current particle order."""
        st = ctx.state
        if st.generation == self._generation:
            return
        body, index = state_ring_table(st, self.n_vertices)
        new = ~np.isin(body, self.ring_body)
        if new.any():
            measured = ring_areas(index[new], st.x, ctx.geometry.length, ctx.geometry.periodic)
            if np.any(measured <= 0):
                bad = body[new][measured <= 0][:5].tolist()
                raise ValueError(f"rings {bad}: area <= 0 (vertices clockwise or folded); "
                                 "build rings with add_rings")
            given = np.array([self._given.get(int(b), np.nan) for b in body[new]])
            a0_new = np.where(np.isnan(given), measured, given)
            order = np.argsort(np.concatenate([self.ring_body, body[new]]), kind="stable")
            self.ring_body = np.concatenate([self.ring_body, body[new]])[order]
            self.a0 = np.concatenate([self.a0, a0_new])[order]
        self._index = index
        self._body_now = body
        self._a0_now = np.ascontiguousarray(self.a0[np.searchsorted(self.ring_body, body)])
        self._l0_now = np.asarray(rest_length(self._a0_now, self.n_vertices), dtype=float)
        self._generation = st.generation

    def _args(self, ctx: ForceContext) -> tuple:
        self._refresh(ctx)
        st = ctx.state
        g = ctx.geometry
        return (self._index, self._a0_now, self._l0_now, self.k_a, self.k_l, self.k_b, st.x,
                st.frozen, g.length, g.periodic, st.force)

    # ----------------------------------------------------------------- forces
    def compute(self, ctx: ForceContext, update: bool) -> None:
        shape_forces(*self._args(ctx))

    def step_call(self, ctx: ForceContext) -> StepCall:
        # the parallel kernel on one thread too: its serial twin runs 2.2x slower (numba's
        # parallel transformation hoists the per-ring scratch arrays out of the loop)
        return step_call(_shape_step, "dp_shape", self._args(ctx), serial_twins=False,
                         KERNEL=shape_forces)

    def potential_energy(self, ctx: ForceContext) -> float:
        """The shape energy ``sum_m U_m`` (conservative)."""
        a = self._args(ctx)
        return float(shape_energy(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[8], a[9]))

    def areas(self, ctx: ForceContext) -> tuple[np.ndarray, np.ndarray]:
        """``(ring_body, area)`` of every ring now."""
        self._refresh(ctx)
        return (self._body_now.copy(),
                ring_areas(self._index, ctx.state.x, ctx.geometry.length,
                           ctx.geometry.periodic))

    def time_scales(self, ctx: ForceContext) -> list[TimeScale]:
        """Half periods ``pi/omega`` of the stiffest mode of each term for the lightest
        vertex: perimeter springs ``omega^2 = 4 k_l N_v / m``, area breathing
        ``omega^2 = (k_a/a0) N_v l0^2 / m`` (each vertex moves by ``|grad a| ~ l0``), bending
        ``omega^2 = 16 k_b a0^2 / (pi N_v l0^4 m)`` (16: the largest eigenvalue of the
        squared second difference)."""
        self._refresh(ctx)
        if self._index.shape[0] == 0:
            return []
        st = ctx.state
        m = float(st.mass[self._index.ravel()].min())
        n = self.n_vertices
        a0, l0 = self._a0_now, self._l0_now
        out = []
        for k, what in ((4.0 * self.k_l * n, f"perimeter springs (k_l = {self.k_l:g})"),
                        (float(np.max(self.k_a / a0 * n * l0**2)),
                         f"ring area (k_a = {self.k_a:g})"),
                        (float(np.max(16.0 * self.k_b * a0**2 / (np.pi * n * l0**4))),
                         f"bending (k_b = {self.k_b:g})")):
            if k > 0:
                out.append(TimeScale(float(np.pi * np.sqrt(m / k)), "oscillation", what))
        return out

    # ----------------------------------------------------------------- checkpoints
    def state_dict(self) -> dict[str, Any]:
        return {"ring_body": self.ring_body.copy(), "a0": self.a0.copy()}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self.ring_body = np.asarray(data["ring_body"], dtype=np.int64)
        self.a0 = np.asarray(data["a0"], dtype=np.float64)
        self._generation = -1

    def nbytes(self) -> int:
        return int(sum(a.nbytes for a in (self._index, self.ring_body, self.a0, self._body_now,
                                          self._a0_now, self._l0_now)))
