"""Coordinate systems of the coarse-graining grid: where the cells are and which components
tensors are given in.

* :class:`Cartesian`: an axis-aligned grid in 2D or 3D, bin edges per axis. An axis with one
  bin is *averaged over* (slabs: ``Cartesian([x_lo, x_hi], y_edges)`` gives profiles in y).
  Components x, y(, z).
* :class:`Cylindrical`: 3D, r-z cells about an axis (every cell a full ring: fields are
  averaged over the azimuth). Components (r, theta, z), the thesis's choice for the 3D jet
  (seed 002 Sec. 5.1: stresses computed in Cartesian and turned into cylindrical ones).
* :class:`Polar`: 2D, r-theta cells about a centre; one theta bin spanning 2 pi averages over
  the azimuth. Components (r, theta).

Each system maps positions to its *local frame*: origin on the axis (centre), local z along
the axis; the kernels of :mod:`grainflow.kernels.cg_deposit` work there.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from math import pi

import numpy as np
from numpy.typing import ArrayLike

from grainflow.frame import Box
from grainflow.kernels import cg_deposit

__all__ = ["Cartesian", "Coordinates", "Cylindrical", "Polar"]


def _edges(name: str, values: ArrayLike) -> np.ndarray:
    arr = np.asarray(values, dtype=float).ravel()
    if arr.size < 2 or not np.all(np.isfinite(arr)) or np.any(np.diff(arr) <= 0):
        raise ValueError(f"{name}: bin edges must be >= 2 finite, strictly increasing numbers, "
                         f"got {values!r}")
    arr.setflags(write=False)
    return arr


def _centres(edges: np.ndarray) -> np.ndarray:
    return 0.5 * (edges[1:] + edges[:-1])


def _unit(name: str, vector: ArrayLike, dim: int) -> np.ndarray:
    v = np.asarray(vector, dtype=float)
    norm = float(np.linalg.norm(v)) if v.shape == (dim,) else 0.0
    if not (norm > 0 and np.isfinite(norm)):
        raise ValueError(f"{name}: expected a non-zero vector of {dim} components, got {vector!r}")
    return v / norm


def frame_about(axis: np.ndarray) -> np.ndarray:
    """Rows (e1, e2, axis): a right-handed orthonormal frame with local z along ``axis``."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e1 = np.cross(helper, axis)
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(axis, e1), axis])


def rotate_rows(v: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """``v @ frame.T`` for (N, 3) rows and a 3 x 3 frame, without BLAS: a threaded BLAS call
    beside numba's idle OpenMP threads on a 2-core machine made the whole coarse-graining
    slower on 2 threads than on 1 (benchmarks/cg.py, 3D cylindrical grid)."""
    return np.einsum("nj,ij->ni", v, frame)


@dataclass(frozen=True)
class _Grid:
    """What every system shares: its bin edges per coordinate and the compiled-kernel codes."""

    edges: tuple[np.ndarray, ...]
    system: int = field(init=False, repr=False)

    @property
    def counts(self) -> np.ndarray:
        return np.array([e.size - 1 for e in self.edges], dtype=np.int64)

    @property
    def resolved(self) -> tuple[int, ...]:
        """Coordinates with more than one bin (the field's axes)."""
        return tuple(a for a, e in enumerate(self.edges) if e.size > 2)

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of a scalar field: the bin counts of the resolved coordinates."""
        return tuple(self.edges[a].size - 1 for a in self.resolved)

    @property
    def centres(self) -> tuple[np.ndarray, ...]:
        """Cell centres along each resolved coordinate."""
        return tuple(_centres(self.edges[a]) for a in self.resolved)

    def packed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Edges concatenated, offsets, bin counts (the compiled kernels' form)."""
        offsets = np.cumsum([0] + [e.size for e in self.edges[:-1]]).astype(np.int64)
        return np.concatenate(self.edges), offsets, self.counts


@dataclass(frozen=True)
class Cartesian(_Grid):
    """Axis-aligned grid: ``edges[a]`` the bin edges along axis a (2 or 3 axes).

    ``Cartesian.uniform(lo, hi, bins)`` builds equal bins; an axis with one bin is averaged.
    Periodic axes of the frames' box are wrapped when the grid spans the box along them.
    """

    def __init__(self, edges: Sequence[ArrayLike]) -> None:
        if len(edges) not in (2, 3):
            raise ValueError(f"edges: one array of bin edges per axis (2 or 3), got {len(edges)}")
        object.__setattr__(self, "edges", tuple(_edges(f"edges[{a}]", e)
                                                for a, e in enumerate(edges)))
        object.__setattr__(self, "system", cg_deposit.CARTESIAN)

    @classmethod
    def uniform(cls, lo: ArrayLike, hi: ArrayLike, bins: Sequence[int]) -> "Cartesian":
        lo_, hi_ = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        if lo_.shape != hi_.shape or lo_.shape != (len(bins),):
            raise ValueError("lo, hi, bins: need one value per axis each")
        if any(int(b) != b or b < 1 for b in bins):
            raise ValueError(f"bins: positive integers, got {bins!r}")
        return cls([np.linspace(a, b, int(n) + 1) for a, b, n in zip(lo_, hi_, bins)])

    @property
    def dim(self) -> int:
        return len(self.edges)

    @property
    def components(self) -> tuple[str, ...]:
        return ("x", "y", "z")[: self.dim]

    mirrored = False
    explicit = False

    def to_local(self, x: np.ndarray) -> np.ndarray:
        return x

    def cell_volumes(self) -> np.ndarray:
        """Cell volumes (areas in 2D), shape :attr:`shape`."""
        widths = [np.diff(e) for e in self.edges]
        vol = widths[0]
        for w in widths[1:]:
            vol = np.multiply.outer(vol, w)
        return vol.reshape(self.shape)

    def periods(self, box: Box | None) -> np.ndarray:
        """Box length along each periodic axis the grid spans exactly, else 0."""
        out = np.zeros(self.dim)
        if box is None:
            return out
        for a in range(self.dim):
            lo, hi = float(box.lo[a]), float(box.hi[a])
            e = self.edges[a]
            span = hi - lo
            if box.periodic[a] and abs(e[0] - lo) <= 1e-9 * span and abs(e[-1] - hi) <= 1e-9 * span:
                out[a] = span
        return out

    # smooth kernels: k-dimensional kernel in the resolved axes, Heaviside in the others
    def kernel_space(self, local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(points in kernel space, mask of points inside the averaged extents)."""
        inside = np.ones(local.shape[0], dtype=bool)
        for a, e in enumerate(self.edges):
            if e.size == 2:
                inside &= (local[:, a] >= e[0]) & (local[:, a] < e[1])
        return local[:, list(self.resolved)], inside

    def smooth_divisor(self) -> np.ndarray:
        """Measure of the averaged directions at each cell (the kernel's missing factor)."""
        extent = 1.0
        for e in self.edges:
            if e.size == 2:
                extent *= e[1] - e[0]
        return np.full(self.shape, extent)


@dataclass(frozen=True)
class Cylindrical(_Grid):
    """r-z cells about the axis through ``origin`` along ``axis`` (3D; full rings)."""

    origin: np.ndarray = field(default=None)
    axis: np.ndarray = field(default=None)

    def __init__(self, r_edges: ArrayLike, z_edges: ArrayLike, *,
                 origin: ArrayLike = (0.0, 0.0, 0.0), axis: ArrayLike = (0.0, 0.0, 1.0)) -> None:
        r = _edges("r_edges", r_edges)
        if r[0] < 0:
            raise ValueError(f"r_edges: radii must be >= 0, got first edge {r[0]}")
        o = np.asarray(origin, dtype=float)
        if o.shape != (3,) or not np.all(np.isfinite(o)):
            raise ValueError(f"origin: expected 3 finite components, got {origin!r}")
        object.__setattr__(self, "edges", (r, _edges("z_edges", z_edges)))
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "axis", _unit("axis", axis, 3))
        object.__setattr__(self, "system", cg_deposit.CYLINDRICAL)

    dim = 3
    components = ("r", "theta", "z")
    explicit = False

    def to_local(self, x: np.ndarray) -> np.ndarray:
        return rotate_rows(x - self.origin, frame_about(self.axis))

    def cell_volumes(self) -> np.ndarray:
        r, z = self.edges
        return np.multiply.outer(pi * np.diff(r**2), np.diff(z)).reshape(self.shape)

    def periods(self, box: Box | None) -> np.ndarray:
        return np.zeros(2)

    def kernel_space(self, local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = np.column_stack([np.hypot(local[:, 0], local[:, 1]), local[:, 2]])
        inside = np.ones(local.shape[0], dtype=bool)
        for a, e in enumerate(self.edges):
            if e.size == 2:
                inside &= (q[:, a] >= e[0]) & (q[:, a] < e[1])
        return q[:, list(self.resolved)], inside

    @property
    def mirrored(self) -> bool:
        """Whether kernels in r get a mirror image at -r (so no weight is lost at the axis)."""
        return self.edges[0].size > 2

    def smooth_divisor(self) -> np.ndarray:
        """``2 pi r`` (r resolved) or the annulus area (r averaged), times the averaged z
        extent: the volume element the kernel in (r, z) does not carry."""
        r, z = self.edges
        radial = 2.0 * pi * _centres(r) if r.size > 2 else np.array([pi * (r[1]**2 - r[0]**2)])
        axial = np.ones(z.size - 1) if z.size > 2 else np.array([z[1] - z[0]])
        return np.multiply.outer(radial, axial).reshape(self.shape)


@dataclass(frozen=True)
class Polar(_Grid):
    """r-theta cells about ``centre`` (2D); theta edges within one turn, theta0 = first edge.

    ``Polar(r_edges)`` (theta edges default ``[0, 2 pi]``) averages over the azimuth.
    """

    centre: np.ndarray = field(default=None)

    def __init__(self, r_edges: ArrayLike, theta_edges: ArrayLike = (0.0, 2.0 * pi), *,
                 centre: ArrayLike = (0.0, 0.0)) -> None:
        r = _edges("r_edges", r_edges)
        if r[0] < 0:
            raise ValueError(f"r_edges: radii must be >= 0, got first edge {r[0]}")
        t = _edges("theta_edges", theta_edges)
        if t[-1] - t[0] > 2.0 * pi * (1 + 1e-12):
            raise ValueError(f"theta_edges: must span at most one turn (2 pi), got "
                             f"{t[-1] - t[0]}")
        c = np.asarray(centre, dtype=float)
        if c.shape != (2,) or not np.all(np.isfinite(c)):
            raise ValueError(f"centre: expected 2 finite components, got {centre!r}")
        object.__setattr__(self, "edges", (r, t))
        object.__setattr__(self, "centre", c)
        object.__setattr__(self, "system", cg_deposit.POLAR)

    dim = 2
    components = ("r", "theta")

    @property
    def full_turn(self) -> bool:
        t = self.edges[1]
        return t.size == 2 and abs(t[1] - t[0] - 2.0 * pi) < 1e-9

    def to_local(self, x: np.ndarray) -> np.ndarray:
        return x - self.centre

    def cell_volumes(self) -> np.ndarray:
        r, t = self.edges
        return np.multiply.outer(0.5 * np.diff(r**2), np.diff(t)).reshape(self.shape)

    def periods(self, box: Box | None) -> np.ndarray:
        return np.zeros(2)

    @property
    def explicit(self) -> bool:
        """Theta resolved: smooth kernels act in the plane at the cells' centre points."""
        return self.edges[1].size > 2

    @property
    def mirrored(self) -> bool:
        return self.full_turn and self.edges[0].size > 2

    def theta(self, local: np.ndarray) -> np.ndarray:
        """Azimuth of local points in ``[theta0, theta0 + 2 pi)``."""
        t0 = self.edges[1][0]
        return t0 + np.mod(np.arctan2(local[:, 1], local[:, 0]) - t0, 2.0 * pi)

    def kernel_space(self, local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        inside = np.ones(local.shape[0], dtype=bool)
        if self.explicit:
            return local, inside
        r_edges, t_edges = self.edges
        r = np.hypot(local[:, 0], local[:, 1])
        if not self.full_turn:
            t = self.theta(local)
            inside &= (t >= t_edges[0]) & (t < t_edges[1])
        if r_edges.size == 2:
            inside &= (r >= r_edges[0]) & (r < r_edges[1])
            return np.zeros((local.shape[0], 0)), inside
        return r[:, None], inside

    def smooth_divisor(self) -> np.ndarray:
        if self.explicit:
            return np.ones(self.shape)
        r, t = self.edges
        sector = t[1] - t[0]
        if r.size > 2:
            return sector * _centres(r)
        return np.array(0.5 * sector * (r[1]**2 - r[0]**2))

    def sample_points(self) -> np.ndarray:
        """Cell centres as local Cartesian points (P, 2), C order over (r, theta)."""
        r_c, t_c = _centres(self.edges[0]), _centres(self.edges[1])
        rr, tt = np.meshgrid(r_c, t_c, indexing="ij")
        return np.column_stack([(rr * np.cos(tt)).ravel(), (rr * np.sin(tt)).ravel()])


Coordinates = Cartesian | Cylindrical | Polar
