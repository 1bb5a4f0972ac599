"""Continuous hopper flow by reinsertion (SPEC M8), as in seed 003 (Cheng et al., Soft Matter
18, 8071 (2022), Sec. 2.1 and 2.4).

The seed's wording: "particles that exit the hopper orifice are placed back into the left side
of the hopper [gravity points left to right, so: on top of the pile] in contact with one of
the bulk particles with the same velocity as the particle it is touching. A particle is
considered outside of the hopper (and does not contribute to the flow rate) when it first
exits the orifice. However, particles are put back into the hopper only after they fall at
least two particle diameters past the orifice." Sec. 2.1 adds that they are "replaced ... near
the leftmost flowing particles and given the same speed as neighboring particles".

Our reading, implemented by :class:`HopperReinsertion` (every ``every`` steps):

1. *Crossing event.* A grain whose height ``h = x . up`` is below the orifice plane
   ``h_o`` and that is not flagged yet records an event ``(time, id, size)`` and is flagged
   (per-particle array ``hopper_out``). A flagged grain that bounces back above the plane is
   not counted again; the flag is cleared only by reinsertion. ``size`` is the nominal grain
   area pi sigma^2/4 (2D) or volume pi sigma^3/6 (3D), so Q = sum(size)/time.
2. *Reinsertion.* A flagged grain with ``h < h_o - 2 sigma_i`` (two of its own diameters below
   the plane) is moved on top of the pile: a lateral position is drawn uniformly in the
   hopper's cross-section (inset by the grain's radius from the side walls); among the grains
   above the orifice plane whose lateral distance ``l_j`` is below ``r_i + r_j`` (the column
   the new grain would fall through), the one with the highest contact height
   ``h_j + sqrt((r_i + r_j)^2 - l_j^2)`` is the partner: the grain is placed there, touching
   it (centre distance exactly ``r_i + r_j``) and above every other grain of the column, so
   it overlaps no grain, and takes the partner's velocity. If the column is empty, another
   lateral position is drawn (``max_attempts`` times).

Events are kept in the updater (checkpointed through ``state_dict``) and written by
:func:`write_events` or read from a run's checkpoint by
:func:`grainflow.studies.hopper_results.read_events`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from grainflow.engine.operations import ForceContext, Updater, UpdateContext


#: Name of the per-particle flag "crossed the orifice, not yet reinserted".
OUT_FLAG = "hopper_out"
#: Surface gap, as a fraction of the smaller diameter, within which two grains count as
#: neighbours for ``bulk_contacts`` (touching, or about to touch).
NEAR_GAP = 0.1
#: Columns of ``events.csv``.
EVENT_COLUMNS = ("time", "id", "size")


def grain_size(radius: np.ndarray, dim: int) -> np.ndarray:
    """Nominal area (2D, pi r^2) or volume (3D, 4/3 pi r^3) of grains of ``radius``."""
    r = np.asarray(radius, dtype=float)
    return np.pi * r**2 if dim == 2 else 4.0 / 3.0 * np.pi * r**3


class HopperReinsertion(Updater):
    """Record orifice crossings and reinsert grains on top of the pile (see module docstring).

    Parameters
    ----------
    dim : 2 or 3; gravity is -y (2D) or -z (3D), so ``up`` is the last axis.
    orifice_height : height h_o of the orifice plane.
    centre : lateral centre of the hopper (x in 2D, (x, y) in 3D).
    width : side-wall separation W (2D) or cylinder diameter (3D).
    depth : reinsert once ``h < h_o - depth * 2 r`` (seed: 2 diameters).
    bulk_contacts : a partner must touch or nearly touch (gap < ``NEAR_GAP`` diameters) at
        least this many grains: one of the seed's "bulk particles", not a grain still raining
        onto the pile; 0 lets any grain of the column be the partner.
    max_attempts : lateral positions tried per grain before giving up.
    """

    def __init__(self, dim: int, orifice_height: float, centre: np.ndarray | float,
                 width: float, *, depth: float = 2.0, bulk_contacts: int = 0,
                 max_attempts: int = 1000) -> None:
        if dim not in (2, 3):
            raise ValueError(f"dim: {dim!r}; expected 2 or 3")
        if not width > 0:
            raise ValueError(f"width: {width!r}; expected a positive wall separation")
        if not depth > 0:
            raise ValueError(f"depth: {depth!r}; expected a positive number of diameters")
        self.dim = dim
        self.axis = dim - 1
        self.orifice_height = float(orifice_height)
        self.centre = np.atleast_1d(np.asarray(centre, dtype=float)).reshape(dim - 1)
        self.half_width = 0.5 * float(width)
        self.depth = float(depth)
        if bulk_contacts < 0:
            raise ValueError(f"bulk_contacts: {bulk_contacts!r}; expected a count >= 0")
        self.bulk_contacts = int(bulk_contacts)
        self.max_attempts = int(max_attempts)
        self._times: list[float] = []
        self._ids: list[int] = []
        self._sizes: list[float] = []
        self.reinserted = 0

    # ------------------------------------------------------------------ events
    @property
    def event_times(self) -> np.ndarray:
        return np.asarray(self._times, dtype=float)

    @property
    def event_ids(self) -> np.ndarray:
        return np.asarray(self._ids, dtype=np.int64)

    @property
    def event_sizes(self) -> np.ndarray:
        return np.asarray(self._sizes, dtype=float)

    @property
    def n_events(self) -> int:
        return len(self._times)

    # ------------------------------------------------------------------ update
    def setup_state(self, ctx: ForceContext) -> None:
        """Register the per-particle flag (call before a checkpoint is loaded)."""
        ctx.state.add_array(OUT_FLAG, (), np.int8, 0)

    def update(self, ctx: UpdateContext) -> None:
        st = ctx.state
        if OUT_FLAG not in st.arrays:
            self.setup_state(ctx)
        out = st.arrays[OUT_FLAG]
        h = st.x[:, self.axis]
        crossed = np.flatnonzero((out == 0) & (h < self.orifice_height))
        if crossed.size:
            out[crossed] = 1
            self._times.extend([ctx.time] * crossed.size)
            self._ids.extend(st.id[crossed].tolist())
            self._sizes.extend(grain_size(st.radius[crossed], self.dim).tolist())
        due = np.flatnonzero((out == 1) & (h < self.orifice_height - self.depth * 2.0 * st.radius))
        if due.size:
            contacts = self._contact_numbers(ctx)
        for i in due:
            self._reinsert(ctx, int(i), contacts)
            out[i] = 0
        if due.size:
            self.reinserted += int(due.size)

    def _contact_numbers(self, ctx: UpdateContext) -> np.ndarray:
        """Per grain, the number of grains it touches or nearly touches (surface gap below
        ``NEAR_GAP`` of the smaller diameter); zeros unless ``bulk_contacts`` asks for them."""
        from scipy.spatial import cKDTree

        st = ctx.state
        if self.bulk_contacts == 0 or st.n < 2:
            return np.zeros(st.n, dtype=np.int64)
        pairs = cKDTree(st.x).query_pairs(2.0 * float(st.radius.max()) * (1.0 + NEAR_GAP),
                                          output_type="ndarray")
        i, j = pairs[:, 0], pairs[:, 1]
        gap = np.linalg.norm(st.x[i] - st.x[j], axis=1) - (st.radius[i] + st.radius[j])
        near = gap < NEAR_GAP * 2.0 * np.minimum(st.radius[i], st.radius[j])
        return np.bincount(np.concatenate([i[near], j[near]]), minlength=st.n)

    def _reinsert(self, ctx: UpdateContext, i: int, contacts: np.ndarray) -> None:
        """Place grain ``i`` on the pile: on a bulk partner if ``bulk_contacts`` asks and one
        is free above, else on the highest grain of a column (module docstring, step 2)."""
        st = ctx.state
        r = float(st.radius[i])
        span = self.half_width - r
        if span <= 0:
            raise ValueError(f"hopper reinsertion: grain radius {r:g} does not fit in the "
                             f"hopper (half width {self.half_width:g})")
        pile = st.x[:, self.axis] > self.orifice_height
        pile[i] = False
        if not pile.any():
            raise RuntimeError("hopper reinsertion: no grain left above the orifice to place "
                               f"grain id {int(st.id[i])} on")
        bulk = pile & (contacts >= self.bulk_contacts)
        if self.bulk_contacts and self._place(ctx, i, span, bulk, check_overlaps=True):
            return
        if not self._place(ctx, i, span, pile, check_overlaps=False):
            raise RuntimeError(f"hopper reinsertion: no column with grains found for grain id "
                               f"{int(st.id[i])} in {self.max_attempts} lateral positions")

    def _place(self, ctx: UpdateContext, i: int, span: float, pool: np.ndarray, *,
               check_overlaps: bool) -> bool:
        """Try ``max_attempts`` lateral positions: touch the grain of ``pool`` with the highest
        contact height in that column and take its velocity. With ``check_overlaps`` a
        position that overlaps any other grain is refused; for a pool of all grains the
        column's highest grain is above every other, so there is nothing to check."""
        st = ctx.state
        ax = self.axis
        lat = [a for a in range(self.dim) if a != ax]
        r = float(st.radius[i])
        idx = np.flatnonzero(pool)
        lateral = st.x[np.ix_(idx, lat)]
        reach = r + st.radius[idx]
        for _ in range(self.max_attempts if idx.size else 0):
            p = self._lateral_sample(ctx.rng, span)
            l2 = np.sum((lateral - p) ** 2, axis=1)
            column = np.flatnonzero(l2 < reach**2)
            if column.size == 0:
                continue
            heights = st.x[idx[column], ax] + np.sqrt(reach[column] ** 2 - l2[column])
            k = int(np.argmax(heights))
            j = idx[column[k]]
            target = np.zeros(st.x.shape[1])
            target[lat] = p
            target[ax] = heights[k]
            if check_overlaps and self._overlaps(st, target, r, i, j):
                continue  # a grain still raining onto the bulk partner is in the way
            ctx.relocate(i, target, v=st.v[j], omega=np.zeros((1, 3)))
            return True
        return False

    def _overlaps(self, st: Any, target: np.ndarray, r: float, i: int, partner: int) -> bool:
        """Whether grain ``i`` (radius ``r``) at ``target`` would overlap any grain but its
        partner (which it touches by construction). Only grains within ``r + r_max`` of the
        target along the vertical axis, widened by a relative 1e-9, can (a superset of the
        overlapping ones, so the answer is exactly that of testing every grain); the
        distance is computed for those alone."""
        ax = self.axis
        reach = (r + float(st.radius.max())) * (1.0 + 1e-9)
        near = np.flatnonzero(np.abs(st.x[:, ax] - target[ax]) <= reach)
        near = near[(near != i) & (near != partner)]
        gap = np.linalg.norm(st.x[near] - target, axis=1) - (r + st.radius[near])
        return bool(np.any(gap < 0.0))

    def _lateral_sample(self, rng: np.random.Generator, span: float) -> np.ndarray:
        """Uniform point of the cross-section inset by the grain radius."""
        if self.dim == 2:
            return self.centre + rng.uniform(-span, span, 1)
        rho = span * np.sqrt(rng.random())
        phi = 2.0 * np.pi * rng.random()
        return self.centre + rho * np.array([np.cos(phi), np.sin(phi)])

    # ------------------------------------------------------------- checkpoints
    def state_dict(self) -> dict[str, Any]:
        return {"event_times": self.event_times, "event_ids": self.event_ids,
                "event_sizes": self.event_sizes, "reinserted": self.reinserted}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self._times = [float(t) for t in np.asarray(data.get("event_times", []), dtype=float)]
        self._ids = [int(k) for k in np.asarray(data.get("event_ids", []), dtype=np.int64)]
        self._sizes = [float(s) for s in np.asarray(data.get("event_sizes", []), dtype=float)]
        self.reinserted = int(data.get("reinserted", 0))


def write_events(path: str | Path, times: np.ndarray, ids: np.ndarray,
                 sizes: np.ndarray) -> Path:
    """Write crossing events as CSV with header ``time,id,size``."""
    path = Path(path)
    table = np.column_stack([np.asarray(times, float), np.asarray(ids, float),
                             np.asarray(sizes, float)])
    np.savetxt(path, table, delimiter=",", header=",".join(EVENT_COLUMNS), comments="",
               fmt=["%.10g", "%d", "%.10g"])
    return path


def read_events_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(times, ids, sizes)`` from a file written by :func:`write_events`."""
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.size == 0:
        return np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros(0)
    return data[:, 0], data[:, 1].astype(np.int64), data[:, 2]
