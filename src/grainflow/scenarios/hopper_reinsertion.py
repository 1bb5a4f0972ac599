"""Continuous hopper flow by reinsertion (SPEC M8), as in seed 003 (Cheng et al., Soft Matter
18, 8071 (2022), Sec. 2.1 and 2.4).

The seed's wording: "particles that exit the hopper orifice are placed back into the left side
of the hopper [gravity points left to right, so: on top of the pile] in contact with one of
the bulk particles with the same velocity as the particle it is touching. A particle is
considered outside of the hopper (and does not contribute to the flow rate) when it first
exits the orifice. However, particles are put back into the hopper only after they fall at
least two particle diameters past the orifice." Sec. 2.1 adds that they are "replaced ... near
the leftmost flowing particles and given the same speed as neighboring particles".

:class:`HopperReinsertion` (every ``every`` steps) implements two readings, chosen by its
options ``count_at`` (when an event is recorded) and ``placement`` (where the grain goes).
Heights are ``h = x . up`` (``up`` is the last axis: gravity is -y in 2D, -z in 3D), ``h_o``
is the orifice plane; a grain is *due* for reinsertion when ``h < h_o - depth * sigma_i``
(``depth`` of its own diameters below the plane; seed: 2).

Today's reading (defaults ``count_at="orifice"``, ``placement="pile"``):

1. *Crossing event.* A grain with ``h < h_o`` that is not flagged yet records an event
   ``(time, id, size)`` and is flagged (per-particle array ``hopper_out``). A flagged grain
   that bounces back above the plane is not counted again; the flag is cleared only by
   reinsertion. ``size`` is the nominal grain area pi sigma^2/4 (2D) or volume pi sigma^3/6
   (3D), so Q = sum(size)/time.
2. *Reinsertion.* A flagged, due grain is moved on top of the pile: a lateral position is
   drawn uniformly in the hopper's cross-section (inset by the grain's radius from the side
   walls); among the grains above the orifice plane whose lateral distance ``l_j`` is below
   ``r_i + r_j`` (the column the new grain would fall through), the one with the highest
   contact height ``h_j + sqrt((r_i + r_j)^2 - l_j^2)`` is the partner: the grain is placed
   there, touching it (centre distance exactly ``r_i + r_j``) and above every other grain of
   the column, so it overlaps no grain, and takes the partner's velocity. If the column is
   empty, another lateral position is drawn (``max_attempts`` times). With ``bulk_contacts``
   the partner must first be a "bulk" grain (see :class:`HopperReinsertion`).

The authors' code (``count_at="reinsertion"``, ``placement="lanes"``), read from their
public code:

1. *Event at reinsertion.* A grain below the plane is flagged (``hopper_out``, so that it is
   reinserted once) but nothing is recorded yet; the event ``(time, id, size)`` is recorded
   when the grain is due and moved back (the authors count a grain ~2.5 of its own
   diameters past the orifice and move it at that moment; ``depth`` sets this distance).
   A grain that dips below the plane and comes back up is therefore never counted for that
   dip.
2. *Lanes.* ``lanes`` fixed lateral positions are used in turn (a counter, checkpointed).
   With ``span`` = half width (radius in 3D) minus the largest grain radius and
   ``s = 2 span / lanes``: in 2D the lanes sit at ``centre +- (j + 1/2) s``,
   ``j = 0 .. lanes/2 - 1``, taken centre-out alternating sides (``+s/2, -s/2, +3s/2,
   -3s/2, ...``); for odd ``lanes`` one lane is at the centre and comes first, the others at
   ``centre +- k s``. In 3D the lanes are the points ``rho_k = span sqrt((k + 1/2)/lanes)``,
   ``phi_k = k * golden angle`` of a sunflower (Fermat/Vogel) spiral filling the disk of
   radius ``span``, in order of increasing radius (a single lane is at the centre). This 3D
   layout is our choice: the authors' 3D lane layout is not known.
3. *Height.* On its lane the grain is placed ``lift`` above the centre of the highest pile
   grain (above the orifice plane) whose lateral distance to the lane is below
   ``lane_reach``. A lane with no such grain, or where the grain would lie past a wall
   (``inside``: in an inclined hopper an outer lane may reach past a sloped wall), is passed
   over for the next one in the order; the counter still moves by one per grain. If every lane is empty, the grain goes ``lift`` above the highest grain
   of the whole pile, on the lane it started from.
   The authors place it at exactly ``lift``; we raise it only where that would overlap a
   grain (e.g. a large grain over a large grain, since ``lift = sigma_s < r_i + r_j``): the
   grain is raised to the lowest height at which it clears, by a relative 1e-9, every grain
   it overlapped, repeatedly until it overlaps none.
4. *Velocity.* The grain takes that highest grain's velocity component along gravity, plus
   a lateral velocity of magnitude ``kick * |v_up|`` in a random direction (2D: a random
   sign; 3D: a random azimuth), drawn from the run's generator; its angular velocity is
   zero.

Events are kept in the updater (checkpointed through ``state_dict``) and written by
:func:`write_events` or read from a run's checkpoint by
:func:`grainflow.studies.hopper_results.read_events`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import numpy as np

from grainflow.engine.operations import ForceContext, Updater, UpdateContext
from grainflow.kernels.placement import column_landings, crossings


#: Name of the per-particle flag "crossed the orifice, not yet reinserted".
OUT_FLAG = "hopper_out"
#: Surface gap, as a fraction of the smaller diameter, within which two grains count as
#: neighbours for ``bulk_contacts`` (touching, or about to touch).
NEAR_GAP = 0.1
#: Columns of ``events.csv``.
EVENT_COLUMNS = ("time", "id", "size")
#: Choices of ``count_at`` and ``placement`` (the first is the default: today's reading).
COUNT_AT = ("orifice", "reinsertion")
PLACEMENTS = ("pile", "lanes")
#: Defaults of the lane rule, in units of sigma_avg = 1.2 sigma_s (seed 003): ``lift`` is one
#: small diameter sigma_s = 1/1.2, ``lane_reach`` 1.5 small diameters.
LANE_LIFT = 1.0 / 1.2
LANE_REACH = 1.5 / 1.2
#: Relative margin by which a raised lane grain clears the grains it would overlap.
CLEAR_MARGIN = 1e-9
#: Sizes of the successive batches in which :meth:`HopperReinsertion._place` evaluates its
#: lateral attempts (the last repeats): small first, since most placements on a pool of
#: every pile grain succeed at once, larger when a placement keeps failing.
PLACE_BATCHES = (2, 8, 32, 128)
#: Azimuth step of the 3D sunflower (Vogel) spiral of lanes.
GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


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
    depth : reinsert once ``h < h_o - depth * 2 r`` (seed: 2 diameters; the authors' code
        about 2.5).
    bulk_contacts : (``placement="pile"``) a partner must touch or nearly touch (gap <
        ``NEAR_GAP`` diameters) at least this many grains: one of the seed's "bulk
        particles", not a grain still raining onto the pile; 0 lets any grain of the column
        be the partner. Ignored by ``placement="lanes"``.
    max_attempts : (``placement="pile"``) lateral positions tried per grain before giving up.
    count_at : ``"orifice"`` (default) records an event when a grain first crosses the
        orifice plane; ``"reinsertion"`` (the authors' code) when it is moved back.
    placement : ``"pile"`` (default): random lateral position, on a partner of its column;
        ``"lanes"`` (the authors' code): fixed lanes used in turn (module docstring).
    lanes : (``"lanes"``) number of lateral lane positions (authors: 28).
    lift : (``"lanes"``) height of the new grain's centre above the lane's highest grain,
        before any raise to clear overlaps; default one small diameter, ``LANE_LIFT`` =
        1/1.2 in sigma_avg units (pass it in other units).
    lane_reach : (``"lanes"``) lateral distance below which a grain belongs to a lane;
        default 1.5 small diameters, ``LANE_REACH`` = 1.25 in sigma_avg units.
    kick : (``"lanes"``) lateral speed of the new grain, as a fraction of its speed along
        gravity, in a random direction.

    ``lane_counter`` is the number of lane placements so far (grain ``k`` takes lane
    ``k % lanes``); it is checkpointed with the events.
    """

    #: It only relocates grains, in place: the compiled step loop keeps its step calls.
    keeps_step_calls = True

    def __init__(self, dim: int, orifice_height: float, centre: np.ndarray | float,
                 width: float, *, depth: float = 2.0, bulk_contacts: int = 0,
                 max_attempts: int = 1000, count_at: str = "orifice",
                 placement: str = "pile", lanes: int = 28, lift: float = LANE_LIFT,
                 lane_reach: float = LANE_REACH, kick: float = 0.1,
                 inside: Callable[[np.ndarray, float], bool] | None = None) -> None:
        if dim not in (2, 3):
            raise ValueError(f"dim: {dim!r}; expected 2 or 3")
        if not width > 0:
            raise ValueError(f"width: {width!r}; expected a positive wall separation")
        if not depth > 0:
            raise ValueError(f"depth: {depth!r}; expected a positive number of diameters")
        self.dim = dim
        self.axis = dim - 1
        #: Whether a grain of radius r at x lies clear of the walls (None: every lateral
        #: position above the pile does, as with vertical walls). Inclined hoppers pass it:
        #: there a lane or a column may reach past a sloped wall.
        self.inside = inside
        self.orifice_height = float(orifice_height)
        self.centre = np.atleast_1d(np.asarray(centre, dtype=float)).reshape(dim - 1)
        self.half_width = 0.5 * float(width)
        self.depth = float(depth)
        if bulk_contacts < 0:
            raise ValueError(f"bulk_contacts: {bulk_contacts!r}; expected a count >= 0")
        self.bulk_contacts = int(bulk_contacts)
        self.max_attempts = int(max_attempts)
        if count_at not in COUNT_AT:
            raise ValueError(f"count_at: {count_at!r}; expected one of "
                             f"{', '.join(map(repr, COUNT_AT))}")
        if placement not in PLACEMENTS:
            raise ValueError(f"placement: {placement!r}; expected one of "
                             f"{', '.join(map(repr, PLACEMENTS))}")
        if isinstance(lanes, bool) or not isinstance(lanes, (int, np.integer)) or lanes < 1:
            raise ValueError(f"lanes: {lanes!r}; expected an integer >= 1")
        if not np.isfinite(lift) or not lift > 0:
            raise ValueError(f"lift: {lift!r}; expected a positive finite height")
        if not np.isfinite(lane_reach) or not lane_reach > 0:
            raise ValueError(f"lane_reach: {lane_reach!r}; expected a positive finite distance")
        if not np.isfinite(kick) or not kick >= 0:
            raise ValueError(f"kick: {kick!r}; expected a finite fraction >= 0")
        self.count_at = count_at
        self.placement = placement
        self.lanes = int(lanes)
        self.lift = float(lift)
        self.lane_reach = float(lane_reach)
        self.kick = float(kick)
        self.lane_counter = 0
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
        crossed, due = crossings(out, st.x, self.axis, self.orifice_height, self.depth * 2.0,
                                 st.radius)
        if crossed.size:
            out[crossed] = 1
            if self.count_at == "orifice":
                self._record(ctx, crossed)
        if due.size and self.count_at == "reinsertion":
            self._record(ctx, due)
        if due.size and self.placement == "pile":
            contacts = self._contact_numbers(ctx)
        for i in due:
            if self.placement == "pile":
                self._reinsert(ctx, int(i), contacts)
            else:
                self._reinsert_on_lane(ctx, int(i))
            out[i] = 0
        if due.size:
            self.reinserted += int(due.size)

    def _record(self, ctx: UpdateContext, index: np.ndarray) -> None:
        """Record an event ``(time, id, size)`` for each grain of ``index``."""
        st = ctx.state
        self._times.extend([ctx.time] * index.size)
        self._ids.extend(st.id[index].tolist())
        sizes = (st.event_size(index) if hasattr(st, "event_size")  # rings: their area
                 else grain_size(st.radius[index], self.dim))
        self._sizes.extend(np.asarray(sizes).tolist())

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
        column's highest grain is above every other, so there is nothing to check.

        The attempts are evaluated in batches (:data:`PLACE_BATCHES`) by a compiled kernel
        (:func:`~grainflow.kernels.placement.column_landings`), but decided one after the
        other as if drawn singly: the first attempt of a batch that succeeds wins, and the
        random generator is then left exactly where single draws up to that attempt would
        leave it, so the run is bitwise the same as with one attempt at a time. (A bulk
        partner is usually buried under grains still settling on the pile: in the demo
        hopper a placement takes ~170 attempts, which one by one in numpy cost ~35 % of a
        steady-state step.)"""
        st = ctx.state
        ax = self.axis
        lat = np.array([a for a in range(self.dim) if a != ax], dtype=np.int64)
        r = float(st.radius[i])
        idx = np.flatnonzero(pool)
        left = self.max_attempts if idx.size else 0
        batches = iter(PLACE_BATCHES)
        size = next(batches)
        while left > 0:
            k = min(size, left)
            size = next(batches, size)
            left -= k
            saved = ctx.rng.bit_generator.state
            p = self._lateral_samples(ctx.rng, span, k)
            partners, heights, blocked = column_landings(
                p, idx, lat, ax, st.x, st.radius, i, r, check_overlaps, self.inside is None)
            for q in np.flatnonzero(partners >= 0):
                target = np.zeros(st.x.shape[1])
                target[lat] = p[q]
                target[ax] = heights[q]
                if self.inside is not None and not self.inside(target, r):
                    continue  # past a sloped wall
                if blocked[q]:
                    continue  # a grain still raining onto the bulk partner is in the way
                ctx.rng.bit_generator.state = saved
                self._lateral_samples(ctx.rng, span, int(q) + 1)  # the draws used
                j = int(partners[q])
                ctx.relocate(i, target, v=st.v[j], omega=np.zeros((1, 3)))
                return True
        return False

    # ------------------------------------------------------------------- lanes
    def lane_positions(self, span: float) -> np.ndarray:
        """The ``lanes`` lateral positions, shape ``(lanes, dim - 1)``, in the order they are
        used, for a half width ``span`` (module docstring, the authors' code, step 2)."""
        n = self.lanes
        if self.dim == 2:
            s = 2.0 * span / n
            if n % 2:
                k = np.arange(1, n // 2 + 1, dtype=float)
                offsets = np.concatenate([[0.0], np.column_stack([k * s, -k * s]).ravel()])
            else:
                k = np.arange(n // 2, dtype=float) + 0.5
                offsets = np.column_stack([k * s, -k * s]).ravel()
            return self.centre + offsets[:, None]
        if n == 1:
            return self.centre[None, :].copy()
        k = np.arange(n, dtype=float)
        rho = span * np.sqrt((k + 0.5) / n)
        phi = k * GOLDEN_ANGLE
        return self.centre + rho[:, None] * np.column_stack([np.cos(phi), np.sin(phi)])

    def _reinsert_on_lane(self, ctx: UpdateContext, i: int) -> None:
        """Place grain ``i`` on the next lane, ``lift`` above the lane's highest grain (raised
        only to clear overlaps), with that grain's velocity along gravity plus a random
        lateral kick (module docstring, the authors' code, steps 2 to 4)."""
        st = ctx.state
        ax = self.axis
        lat = [a for a in range(self.dim) if a != ax]
        span = self.half_width - float(st.radius.max())
        if span <= 0:
            raise ValueError(f"hopper reinsertion: largest grain radius "
                             f"{float(st.radius.max()):g} does not fit in the hopper (half "
                             f"width {self.half_width:g})")
        pile = st.x[:, ax] > self.orifice_height
        pile[i] = False
        if not pile.any():
            raise RuntimeError("hopper reinsertion: no grain left above the orifice to place "
                               f"grain id {int(st.id[i])} on")
        lanes = self.lane_positions(span)
        idx = np.flatnonzero(pile)
        lateral = st.x[np.ix_(idx, lat)]
        start = self.lane_counter % self.lanes
        self.lane_counter += 1
        r = float(st.radius[i])
        target = np.zeros(st.x.shape[1])
        for k in range(self.lanes + 1):  # an empty lane, or one past a wall, is passed over
            if k < self.lanes:
                lane = lanes[(start + k) % self.lanes]
                column = idx[np.sum((lateral - lane) ** 2, axis=1) < self.lane_reach**2]
                if column.size == 0:
                    continue
            else:  # no lane will do: the lane it started from, on the top of the whole pile
                lane, column = lanes[start], idx
            j = int(column[np.argmax(st.x[column, ax])])
            target[lat] = lane
            target[ax] = self._clear_height(st, target, r, i, float(st.x[j, ax]) + self.lift)
            if self.inside is None or self.inside(target, r) or k == self.lanes:
                break
        v_up = float(st.v[j, ax])
        v = np.zeros(3)
        v[ax] = v_up
        speed = self.kick * abs(v_up)
        if self.dim == 2:
            v[0] = speed if ctx.rng.random() < 0.5 else -speed
        else:
            phi = 2.0 * np.pi * ctx.rng.random()
            v[lat] = speed * np.array([np.cos(phi), np.sin(phi)])
        ctx.relocate(i, target, v=v, omega=np.zeros((1, 3)))

    def _clear_height(self, st: Any, target: np.ndarray, r: float, i: int,
                      height: float) -> float:
        """The lowest height from ``height`` up at which grain ``i`` (radius ``r``) at the
        lateral position of ``target`` overlaps no other grain: while it overlaps some, it is
        raised to clear each of those by a relative ``CLEAR_MARGIN``. A grain once cleared
        from above stays cleared as the height grows, so this ends within ``n`` rounds."""
        ax = self.axis
        lat = [a for a in range(self.dim) if a != ax]
        others = np.flatnonzero(np.arange(st.n) != i)
        l2 = np.sum((st.x[np.ix_(others, lat)] - target[lat]) ** 2, axis=1)
        contact = r + st.radius[others]
        near = l2 < contact**2  # only these can overlap at any height
        l2, contact, h = l2[near], contact[near], st.x[others[near], ax]
        clear = (contact * (1.0 + CLEAR_MARGIN)) ** 2
        for _ in range(h.size + 1):
            overlap = (h - height) ** 2 + l2 < contact**2
            if not overlap.any():
                return height
            height = max(height, float(np.max(h[overlap] + np.sqrt(clear[overlap] - l2[overlap]))))
        raise RuntimeError("hopper reinsertion: could not clear the overlaps of a lane grain")

    def _lateral_samples(self, rng: np.random.Generator, span: float, k: int) -> np.ndarray:
        """``k`` uniform points of the cross-section inset by the grain radius, shape
        ``(k, dim - 1)``: the same draws, in the same order, as ``k`` single points (2D: one
        uniform number each; 3D: a radius, then an azimuth)."""
        if self.dim == 2:
            return self.centre + rng.uniform(-span, span, k)[:, None]
        u = rng.random(2 * k).reshape(k, 2)
        rho = span * np.sqrt(u[:, 0])
        phi = 2.0 * np.pi * u[:, 1]
        # cosine and sine one value at a time, as single draws took them: numpy may evaluate
        # them differently (SIMD) over an array
        unit = np.array([[np.cos(a), np.sin(a)] for a in phi]).reshape(k, 2)
        return self.centre + rho[:, None] * unit

    # ------------------------------------------------------------- checkpoints
    def state_dict(self) -> dict[str, Any]:
        return {"event_times": self.event_times, "event_ids": self.event_ids,
                "event_sizes": self.event_sizes, "reinserted": self.reinserted,
                "lane_counter": self.lane_counter}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self._times = [float(t) for t in np.asarray(data.get("event_times", []), dtype=float)]
        self._ids = [int(k) for k in np.asarray(data.get("event_ids", []), dtype=np.int64)]
        self._sizes = [float(s) for s in np.asarray(data.get("event_sizes", []), dtype=float)]
        self.reinserted = int(data.get("reinserted", 0))
        self.lane_counter = int(data.get("lane_counter", 0))  # absent before lanes existed


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
