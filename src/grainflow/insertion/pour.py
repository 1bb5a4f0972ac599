"""Insertion and deletion updaters (SPEC M8): pouring, deleting, replenishing.

Each is an :class:`~grainflow.engine.operations.Updater` for
:meth:`Simulation.add_updater` (``update(ctx)`` runs every ``every`` steps, after the step's
integration) with ``state_dict()`` / ``load_state_dict()`` for its counters, so checkpoints
resume them exactly. New grains are placed without overlap with the grains present
(:func:`random_fill`, with the run's ``ctx.rng``) and added through ``ctx.add_particles``;
deletions go through ``ctx.remove_particles``, so contact histories and every registered
per-particle array (wall histories included) follow.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from grainflow.engine.operations import Updater, UpdateContext
from grainflow.insertion.random_fill import random_fill
from grainflow.insertion.regions import Region, region_dim_check
from grainflow.insertion.sizes import SizeDistribution
from grainflow.user_warnings import warn_user


class _Inserter(Updater):
    """What the inserting updaters share: grain sizes, density, velocity and type."""

    def __init__(self, region: Region, sizes: SizeDistribution, density: float,
                 velocity: Sequence[float] | None, type: int, max_attempts: int) -> None:
        if not density > 0:
            raise ValueError(f"density: {density!r} is not valid; expected a positive density")
        self.region = region
        self.sizes = sizes
        self.density = float(density)
        self.velocity = np.zeros(region.dim) if velocity is None else np.asarray(
            velocity, dtype=float)
        if self.velocity.shape != (region.dim,):
            raise ValueError(f"velocity: expected {region.dim} components (the region's "
                             f"dimension), got {self.velocity.shape}")
        self.type = int(type)
        self.max_attempts = int(max_attempts)

    def _insert(self, ctx: UpdateContext, n: int) -> int:
        """Place up to ``n`` grains in the region without overlap; return how many."""
        st = ctx.state
        region_dim_check(self.region, st.dim)
        x, r = random_fill(self.region, n, self.sizes, ctx.rng, existing_x=st.x,
                           existing_radius=st.radius, max_attempts=self.max_attempts,
                           partial=True)
        if r.size:
            ctx.add_particles(x, r, density=self.density,
                              v=np.broadcast_to(self.velocity, x.shape), type=self.type)
        return int(r.size)


def _type_mask(ptype: np.ndarray, types: Sequence[int] | None) -> np.ndarray:
    return np.ones(ptype.shape, dtype=bool) if types is None else np.isin(ptype, types)


class Pour(_Inserter):
    """Rain grains into ``region``: each call adds ``per_insertion`` grains.

    With ``sim.add_updater(pour, every=N)`` the rate is ``per_insertion / (N dt)`` grains per
    unit time. Grains that do not fit (the region is still crowded by the previous batch)
    are owed and tried again at the next call; pouring stops after ``total`` grains.
    ``velocity``: initial velocity of the poured grains (e.g. downwards).
    """

    def __init__(self, region: Region, sizes: SizeDistribution, per_insertion: int, *,
                 density: float, velocity: Sequence[float] | None = None, type: int = 0,
                 total: int | None = None, max_attempts: int = 200) -> None:
        super().__init__(region, sizes, density, velocity, type, max_attempts)
        if per_insertion < 1:
            raise ValueError(f"per_insertion: {per_insertion!r} is not valid; expected >= 1")
        if total is not None and total < 0:
            raise ValueError(f"total: {total!r} is not valid; expected >= 0 or None")
        self.per_insertion = int(per_insertion)
        self.total = total
        self.inserted = 0
        self.owed = 0

    @property
    def done(self) -> bool:
        return self.total is not None and self.inserted >= self.total

    def update(self, ctx: UpdateContext) -> None:
        self.owed += self.per_insertion
        if self.total is not None:
            self.owed = min(self.owed, self.total - self.inserted)
        if self.owed > 0:
            added = self._insert(ctx, self.owed)
            self.inserted += added
            self.owed -= added

    def state_dict(self) -> dict[str, Any]:
        return {"inserted": self.inserted, "owed": self.owed}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self.inserted = int(data["inserted"])
        self.owed = int(data["owed"])


class DeleteRegion(Updater):
    """Remove grains whose centre is outside ``region`` (``outside=True``: grains that left
    the region of interest, e.g. fell below ``HalfSpace((0, 0, z0), (0, 0, 1))``) or inside
    it (``outside=False``: a sink). ``types`` restricts it to some particle types; frozen
    particles are never removed. ``removed`` counts the deleted grains."""

    #: It only removes particles (which renews the compiled step loop's calls anyway).
    keeps_step_calls = True

    def __init__(self, region: Region, *, outside: bool = True,
                 types: Sequence[int] | None = None) -> None:
        self.region = region
        self.outside = bool(outside)
        self.types = None if types is None else list(types)
        self.removed = 0

    def update(self, ctx: UpdateContext) -> None:
        st = ctx.state
        region_dim_check(self.region, st.dim)
        inside = self.region.contains(st.x)
        mask = (~inside if self.outside else inside) & _type_mask(st.type, self.types)
        mask &= ~st.frozen
        k = int(mask.sum())
        if k:
            ctx.remove_particles(mask)
            self.removed += k

    def state_dict(self) -> dict[str, Any]:
        return {"removed": self.removed}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self.removed = int(data["removed"])


class ReplenishTo(_Inserter):
    """Keep ``target`` grains in ``count_region`` by adding the missing ones in
    ``insert_region`` (at the top of the pile).

    Seed 000 keeps the hopper's fill height constant by adding grains at the top; at fixed
    grain count N_h in the hopper the fill height is constant too (PARAMETERS.md, seed 000),
    so the count is the controlled quantity. ``types`` restricts the count to some particle
    types. Grains that do not fit in ``insert_region`` are added at a later call; when the
    count stays more than ``shortfall_warning`` (a fraction of ``target``) short after a call,
    the region cannot keep up with the outflow, and a warning says so once (None: never).
    """

    def __init__(self, count_region: Region, target: int, insert_region: Region,
                 sizes: SizeDistribution, *, density: float,
                 velocity: Sequence[float] | None = None, type: int = 0,
                 types: Sequence[int] | None = None, max_attempts: int = 200,
                 shortfall_warning: float | None = None) -> None:
        super().__init__(insert_region, sizes, density, velocity, type, max_attempts)
        if count_region.dim != insert_region.dim:
            raise ValueError("insert_region: its dimension differs from count_region's")
        if target < 0:
            raise ValueError(f"target: {target!r} is not valid; expected a count >= 0")
        self.count_region = count_region
        self.target = int(target)
        self.types = None if types is None else list(types)
        self.inserted = 0
        self.shortfall_warning = shortfall_warning
        self._warned = False

    def count(self, ctx: UpdateContext) -> int:
        """Grains now in ``count_region``."""
        st = ctx.state
        return int(np.sum(self.count_region.contains(st.x) & _type_mask(st.type, self.types)))

    def update(self, ctx: UpdateContext) -> None:
        missing = self.target - self.count(ctx)
        if missing > 0:
            added = self._insert(ctx, missing)
            self.inserted += added
            short = missing - added
            if (self.shortfall_warning is not None and not self._warned
                    and short > self.shortfall_warning * self.target):
                self._warned = True
                warn_user(
                    f"refill: {short} of the {self.target} grains kept in the count region are "
                    "missing and do not fit in the insertion region; it empties too slowly for "
                    "the outflow (give the added grains a downward velocity or a larger "
                    "region)", RuntimeWarning)

    def state_dict(self) -> dict[str, Any]:
        return {"inserted": self.inserted}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self.inserted = int(data["inserted"])
