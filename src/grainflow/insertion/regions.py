"""Regions for insertion and deletion: boxes, cylinders, disks and half-spaces.

Each region is a small frozen dataclass with ``dim``, a vectorised ``contains(x, margin)``
(true where a centre lies inside and at least ``margin`` from the boundary, so a grain of
radius ``margin`` fits entirely), ``volume`` (area in 2D; ``inf`` if unbounded) and
``bounds()`` (its bounding box; ValueError if unbounded). ``x`` may be (N, dim) or (N, 3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np


class Region(Protocol):
    """What insertion and deletion need from a region."""

    dim: int

    def contains(self, x: np.ndarray, margin: float = 0.0) -> np.ndarray: ...

    @property
    def volume(self) -> float: ...

    def bounds(self) -> tuple[np.ndarray, np.ndarray]: ...


def _points(x: np.ndarray, dim: int) -> np.ndarray:
    x = np.atleast_2d(np.asarray(x, dtype=float))
    if x.shape[1] < dim:
        raise ValueError(f"x: expected (N, {dim}) or (N, 3) positions, got {x.shape}")
    return x[:, :dim]


def _finite_bounds(lo: np.ndarray, hi: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError(f"{name}: the region is unbounded; give finite limits for filling")
    return lo, hi


@dataclass(frozen=True)
class BoxRegion:
    """Axis-aligned box ``lo <= x <= hi`` (2 or 3 components; infinite limits allowed)."""

    lo: tuple[float, ...]
    hi: tuple[float, ...]

    def __post_init__(self) -> None:
        lo = tuple(float(v) for v in self.lo)
        hi = tuple(float(v) for v in self.hi)
        if len(lo) not in (2, 3) or len(hi) != len(lo):
            raise ValueError(f"hi: {self.hi!r} / lo: {self.lo!r} need 2 or 3 components each")
        if not all(a < b for a, b in zip(lo, hi)):
            raise ValueError(f"hi: {self.hi!r} must exceed lo {self.lo!r} on every axis")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)

    @property
    def dim(self) -> int:
        return len(self.lo)

    def contains(self, x: np.ndarray, margin: float = 0.0) -> np.ndarray:
        p = _points(x, self.dim)
        lo = np.asarray(self.lo) + margin
        hi = np.asarray(self.hi) - margin
        return np.all((p >= lo) & (p <= hi), axis=1)

    @property
    def volume(self) -> float:
        return float(np.prod(np.subtract(self.hi, self.lo)))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return _finite_bounds(np.asarray(self.lo), np.asarray(self.hi), "BoxRegion")


@dataclass(frozen=True)
class CylinderRegion:
    """3D cylinder of ``radius`` along coordinate ``axis`` (0, 1, 2 = x, y, z) between
    ``lo`` and ``hi`` on that axis; ``center`` is the axis position in the two other
    coordinates, in increasing axis order ((x, y) for a z cylinder)."""

    center: tuple[float, float]
    radius: float
    lo: float = -math.inf
    hi: float = math.inf
    axis: int = 2

    def __post_init__(self) -> None:
        c = tuple(float(v) for v in self.center)
        if len(c) != 2:
            raise ValueError(f"center: {self.center!r} needs the 2 coordinates off the axis")
        if not self.radius > 0:
            raise ValueError(f"radius: {self.radius!r} is not valid; expected > 0")
        if not self.lo < self.hi:
            raise ValueError(f"hi: {self.hi!r} must exceed lo {self.lo!r}")
        if self.axis not in (0, 1, 2):
            raise ValueError(f"axis: {self.axis!r} is not valid; use 0, 1 or 2 (x, y, z)")
        object.__setattr__(self, "center", c)

    dim = 3

    @property
    def _off(self) -> list[int]:
        return [a for a in range(3) if a != self.axis]

    def contains(self, x: np.ndarray, margin: float = 0.0) -> np.ndarray:
        p = _points(x, 3)
        off = self._off
        rsq = (p[:, off[0]] - self.center[0]) ** 2 + (p[:, off[1]] - self.center[1]) ** 2
        s = p[:, self.axis]
        r = self.radius - margin
        return (rsq <= r * r) & (r >= 0) & (s >= self.lo + margin) & (s <= self.hi - margin)

    @property
    def volume(self) -> float:
        return math.pi * self.radius**2 * (self.hi - self.lo)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.empty(3)
        hi = np.empty(3)
        for a, c in zip(self._off, self.center):
            lo[a], hi[a] = c - self.radius, c + self.radius
        lo[self.axis], hi[self.axis] = self.lo, self.hi
        return _finite_bounds(lo, hi, "CylinderRegion")


@dataclass(frozen=True)
class DiskRegion:
    """2D disk of ``radius`` around ``center``."""

    center: tuple[float, float]
    radius: float

    def __post_init__(self) -> None:
        c = tuple(float(v) for v in self.center)
        if len(c) != 2:
            raise ValueError(f"center: {self.center!r} needs 2 components (a 2D disk)")
        if not self.radius > 0:
            raise ValueError(f"radius: {self.radius!r} is not valid; expected > 0")
        object.__setattr__(self, "center", c)

    dim = 2

    def contains(self, x: np.ndarray, margin: float = 0.0) -> np.ndarray:
        p = _points(x, 2)
        r = self.radius - margin
        return (np.sum((p - np.asarray(self.center)) ** 2, axis=1) <= r * r) & (r >= 0)

    @property
    def volume(self) -> float:
        return math.pi * self.radius**2

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        c = np.asarray(self.center)
        return c - self.radius, c + self.radius


@dataclass(frozen=True)
class HalfSpace:
    """The half-space ``(x - point) . normal >= 0`` (2 or 3 components); e.g. "above the
    plane z = z0" is ``HalfSpace((0, 0, z0), (0, 0, 1))``."""

    point: tuple[float, ...]
    normal: tuple[float, ...]

    def __post_init__(self) -> None:
        p = np.asarray(self.point, dtype=float)
        n = np.asarray(self.normal, dtype=float)
        if p.size not in (2, 3) or n.size != p.size:
            raise ValueError(f"normal: {self.normal!r} / point: {self.point!r} need 2 or 3 "
                             "components each")
        norm = float(np.linalg.norm(n))
        if norm == 0.0:
            raise ValueError("normal: has zero length; give the direction pointing inside")
        object.__setattr__(self, "point", tuple(p.tolist()))
        object.__setattr__(self, "normal", tuple((n / norm).tolist()))

    @property
    def dim(self) -> int:
        return len(self.point)

    def contains(self, x: np.ndarray, margin: float = 0.0) -> np.ndarray:
        p = _points(x, self.dim)
        return (p - np.asarray(self.point)) @ np.asarray(self.normal) >= margin

    @property
    def volume(self) -> float:
        return math.inf

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        raise ValueError("HalfSpace: the region is unbounded; fill a BoxRegion instead")


def region_dim_check(region: Region, dim: int, name: str = "region") -> None:
    """ValueError if ``region`` is for another dimension than the simulation's."""
    if region.dim != dim:
        raise ValueError(f"{name}: a {region.dim}D region in a {dim}D simulation; give "
                         f"{dim} components")

