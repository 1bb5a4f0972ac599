"""Grain-size distributions for insertion: monodisperse, bidisperse, uniform.

Each distribution is a frozen dataclass with ``radii(n, rng) -> (n,)`` (drawn with the
caller's numpy Generator, so runs are reproducible) and ``max_radius``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def particle_volume(radius: np.ndarray | float, dim: int) -> np.ndarray:
    """Disk area ``pi r^2`` (2D) or sphere volume ``4/3 pi r^3`` (3D)."""
    r = np.asarray(radius, dtype=float)
    return np.pi * r**2 if dim == 2 else 4.0 / 3.0 * np.pi * r**3


def _positive(value: float, name: str) -> None:
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"{name}: {value!r} is not valid; expected a positive diameter")


@dataclass(frozen=True)
class Monodisperse:
    """All grains of one ``diameter``."""

    diameter: float

    def __post_init__(self) -> None:
        _positive(self.diameter, "diameter")

    @property
    def max_radius(self) -> float:
        return 0.5 * self.diameter

    def radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return np.full(n, 0.5 * self.diameter)


@dataclass(frozen=True)
class Bidisperse:
    """50:50 mixture of ``small_diameter`` and ``ratio * small_diameter`` grains (seed 003:
    ratio 1.4), in random order; an odd count gets its extra grain's size at random."""

    small_diameter: float
    ratio: float = 1.4

    def __post_init__(self) -> None:
        _positive(self.small_diameter, "small_diameter")
        if not (self.ratio >= 1 and math.isfinite(self.ratio)):
            raise ValueError(f"ratio: {self.ratio!r} is not valid; expected large/small >= 1")

    @property
    def max_radius(self) -> float:
        return 0.5 * self.small_diameter * self.ratio

    def radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        n_large = n // 2 + (int(rng.random() < 0.5) if n % 2 else 0)
        r = np.full(n, 0.5 * self.small_diameter)
        r[:n_large] *= self.ratio
        return rng.permutation(r)


@dataclass(frozen=True)
class UniformDiameter:
    """Diameters uniformly distributed in ``[d_min, d_max]``."""

    d_min: float
    d_max: float

    def __post_init__(self) -> None:
        _positive(self.d_min, "d_min")
        if not (self.d_max >= self.d_min and math.isfinite(self.d_max)):
            raise ValueError(f"d_max: {self.d_max!r} is not valid; expected >= d_min")

    @property
    def max_radius(self) -> float:
        return 0.5 * self.d_max

    def radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return 0.5 * rng.uniform(self.d_min, self.d_max, n)


SizeDistribution = Monodisperse | Bidisperse | UniformDiameter
