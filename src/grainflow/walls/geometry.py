"""Analytic wall shapes (SPEC M4) and the one compiled closest-point kernel.

Every shape is a small frozen dataclass that packs into a numeric row ``(kind, params[16])``;
:func:`closest_point` switches on ``kind`` and returns the point of the wall closest to a
particle centre plus a flag saying whether that point may be in contact. The wall force
(:mod:`grainflow.walls.force`) then calls the particle's contact law with ``d = x - c``.

Which side of a wall acts (``inside_ok``):

* :class:`Plane`: only the half-space the normal points into.
* :class:`Segment`: both sides and the end caps (a thin rigid line; in 3D a thin rod).
* :class:`Cylinder`: the inside of the tube (``inside=True``) or the outside of a post.
* :class:`Cone` and :class:`PlateWithHole`: their faces act on one side only (inside of the
  cone / the side the plate's normal points into); their rims (the cone's end circles, the
  orifice's edge) are thin edges and act from every side, so grains leaving through an
  orifice feel its edge.

Walls translate with a constant ``velocity``: the shape at time ``t`` is the packed shape
shifted by ``velocity * t``. The kernel works in the wall's rest frame; callers subtract the
shift from the particle position (the branch vector ``x - c`` does not depend on the frame).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar, Iterator, Sequence

import numpy as np
from numba import njit

PLANE, SEGMENT, CYLINDER, CONE, PLATE_WITH_HOLE = range(5)

#: Length of a packed parameter row.
N_PARAMS = 16


@njit(cache=True)
def closest_point(kind, params, row, x0, x1, x2):
    """Closest point ``(c0, c1, c2)`` of wall ``params[row]`` to ``x`` and ``inside_ok``.

    The whole ``(n_walls, 16)`` table and a row index are passed rather than the row itself:
    creating an array view per particle-wall pair inside a parallel loop costs more than the
    geometry (see :mod:`grainflow.kernels.pair_loop`).
    """
    p = params
    if kind == PLANE:
        # p = [point(3), unit normal(3)]; c = x - ((x - p).n) n
        h = (x0 - p[row, 0]) * p[row, 3] + (x1 - p[row, 1]) * p[row, 4] + (x2 - p[row, 2]) * p[row, 5]
        return x0 - h * p[row, 3], x1 - h * p[row, 4], x2 - h * p[row, 5], h > 0.0
    if kind == SEGMENT:
        # p = [p0(3), p1 - p0(3), 1/|p1 - p0|^2]; c = p0 + clamp(t, 0, 1) (p1 - p0)
        t = ((x0 - p[row, 0]) * p[row, 3] + (x1 - p[row, 1]) * p[row, 4]
             + (x2 - p[row, 2]) * p[row, 5]) * p[row, 6]
        t = min(max(t, 0.0), 1.0)
        return p[row, 0] + t * p[row, 3], p[row, 1] + t * p[row, 4], p[row, 2] + t * p[row, 5], True
    if kind == CYLINDER:
        # p = [axis point(3), unit axis(3), R, inside]
        r0 = x0 - p[row, 0]
        r1 = x1 - p[row, 1]
        r2 = x2 - p[row, 2]
        s = r0 * p[row, 3] + r1 * p[row, 4] + r2 * p[row, 5]
        q0 = r0 - s * p[row, 3]
        q1 = r1 - s * p[row, 4]
        q2 = r2 - s * p[row, 5]
        rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
        if rho == 0.0:
            return x0, x1, x2, False
        g = 1.0 - p[row, 6] / rho
        ok = rho < p[row, 6] if p[row, 7] > 0.0 else rho > p[row, 6]
        return x0 - g * q0, x1 - g * q1, x2 - g * q2, ok
    if kind == CONE:
        # p = [apex(3), unit axis(3), cos a, sin a, inside, l_min, l_max, e_perp(3)]
        # In the meridian half-plane (s along the axis, rho >= 0 off it) the surface is the
        # segment l (cos a, sin a), l_min <= l <= l_max, l the distance from the apex.
        r0 = x0 - p[row, 0]
        r1 = x1 - p[row, 1]
        r2 = x2 - p[row, 2]
        s = r0 * p[row, 3] + r1 * p[row, 4] + r2 * p[row, 5]
        q0 = r0 - s * p[row, 3]
        q1 = r1 - s * p[row, 4]
        q2 = r2 - s * p[row, 5]
        rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
        if rho > 0.0:
            e0 = q0 / rho
            e1 = q1 / rho
            e2 = q2 / rho
        else:
            e0 = p[row, 11]
            e1 = p[row, 12]
            e2 = p[row, 13]
        ca = p[row, 6]
        sa = p[row, 7]
        l = s * ca + rho * sa
        lc = min(max(l, p[row, 9]), p[row, 10])
        side = rho * ca - s * sa  # > 0 outside the cone
        if lc != l:
            ok = True
        elif p[row, 8] > 0.0:
            ok = side < 0.0
        else:
            ok = side > 0.0
        a = lc * ca
        b = lc * sa
        return (p[row, 0] + a * p[row, 3] + b * e0, p[row, 1] + a * p[row, 4] + b * e1,
                p[row, 2] + a * p[row, 5] + b * e2, ok)
    # PLATE_WITH_HOLE: p = [centre(3), unit normal(3), hole radius, e_perp(3)]
    r0 = x0 - p[row, 0]
    r1 = x1 - p[row, 1]
    r2 = x2 - p[row, 2]
    h = r0 * p[row, 3] + r1 * p[row, 4] + r2 * p[row, 5]
    q0 = r0 - h * p[row, 3]
    q1 = r1 - h * p[row, 4]
    q2 = r2 - h * p[row, 5]
    rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    hole = p[row, 6]
    if rho >= hole:
        return x0 - h * p[row, 3], x1 - h * p[row, 4], x2 - h * p[row, 5], h > 0.0
    if rho > 0.0:
        g = hole / rho
        return p[row, 0] + g * q0, p[row, 1] + g * q1, p[row, 2] + g * q2, True
    return (p[row, 0] + hole * p[row, 7], p[row, 1] + hole * p[row, 8],
            p[row, 2] + hole * p[row, 9], True)


def _vec3(value: Sequence[float], name: str) -> tuple[float, float, float]:
    a = np.asarray(value, dtype=float).ravel()
    if a.size not in (2, 3) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: {value!r} is not valid; give 2 or 3 finite components")
    return (float(a[0]), float(a[1]), float(a[2]) if a.size == 3 else 0.0)


def _unit(value: Sequence[float], name: str) -> tuple[float, float, float]:
    a = np.asarray(_vec3(value, name))
    norm = float(np.linalg.norm(a))
    if norm == 0.0:
        raise ValueError(f"{name}: {value!r} has zero length; give a non-zero direction")
    return tuple(float(c) for c in a / norm)  # type: ignore[return-value]


def _perpendicular(u: Sequence[float]) -> np.ndarray:
    """Some unit vector perpendicular to the unit vector ``u``."""
    u = np.asarray(u)
    helper = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e = np.cross(u, helper)
    return e / np.linalg.norm(e)


@dataclass(frozen=True)
class Wall:
    """Base of the wall shapes: a constant translation ``velocity`` (2 or 3 components)."""

    kind: ClassVar[int]
    velocity: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0), kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "velocity", _vec3(self.velocity, "velocity"))

    def pack(self) -> np.ndarray:
        """The ``params[16]`` row read by :func:`closest_point`."""
        row = np.zeros(N_PARAMS)
        values = self._params()
        row[: len(values)] = values
        return row

    def _params(self) -> list[float]:  # pragma: no cover
        raise NotImplementedError

    def planar(self) -> bool:
        """True when the wall is a valid 2D wall: it acts in the z = 0 plane only."""
        return self.velocity[2] == 0.0 and self._planar()

    def _planar(self) -> bool:
        return False

    def closest_point(self, x: Sequence[float], time: float = 0.0) -> tuple[np.ndarray, bool]:
        """Closest wall point to ``x`` at ``time`` and whether it may be in contact."""
        shift = np.asarray(self.velocity) * time
        p = np.asarray(_vec3(x, "x")) - shift
        c0, c1, c2, ok = closest_point(self.kind, self.pack()[None, :], 0, p[0], p[1], p[2])
        return np.array([c0, c1, c2]) + shift, bool(ok)


@dataclass(frozen=True)
class Plane(Wall):
    """Infinite plane through ``point``; contact on the side ``normal`` points to."""

    kind: ClassVar[int] = PLANE
    point: tuple[float, float, float]
    normal: tuple[float, float, float]

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "point", _vec3(self.point, "point"))
        object.__setattr__(self, "normal", _unit(self.normal, "normal"))

    def _params(self) -> list[float]:
        return [*self.point, *self.normal]

    def _planar(self) -> bool:
        return self.normal[2] == 0.0


@dataclass(frozen=True)
class Segment(Wall):
    """Finite segment ``p0``-``p1`` (2D walls); both sides and the end caps act."""

    kind: ClassVar[int] = SEGMENT
    p0: tuple[float, float, float]
    p1: tuple[float, float, float]

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "p0", _vec3(self.p0, "p0"))
        object.__setattr__(self, "p1", _vec3(self.p1, "p1"))
        if self.p0 == self.p1:
            raise ValueError(f"p1: {self.p1!r} equals p0; a segment needs two distinct ends")

    def _params(self) -> list[float]:
        e = np.subtract(self.p1, self.p0)
        return [*self.p0, *e, 1.0 / float(e @ e)]

    def _planar(self) -> bool:
        return self.p0[2] == 0.0 and self.p1[2] == 0.0


@dataclass(frozen=True)
class Cylinder(Wall):
    """Infinite cylinder of ``radius`` around the line ``axis_point + s axis_direction``.

    ``inside=True``: a tube holding the grains inside; ``False``: a post, grains outside.
    With the axis along z this is a circular wall in 2D.
    """

    kind: ClassVar[int] = CYLINDER
    axis_point: tuple[float, float, float]
    axis_direction: tuple[float, float, float]
    radius: float
    inside: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "axis_point", _vec3(self.axis_point, "axis_point"))
        object.__setattr__(self, "axis_direction", _unit(self.axis_direction, "axis_direction"))
        if not (self.radius > 0 and math.isfinite(self.radius)):
            raise ValueError(f"radius: {self.radius!r} is not valid; expected a positive number")

    def _params(self) -> list[float]:
        return [*self.axis_point, *self.axis_direction, float(self.radius),
                1.0 if self.inside else 0.0]

    def _planar(self) -> bool:
        return self.axis_direction[0] == 0.0 and self.axis_direction[1] == 0.0


@dataclass(frozen=True)
class Cone(Wall):
    """Finite cone (3D hoppers): apex, axis (pointing to where it widens), half angle.

    The surface is the set of points at axial distance ``s`` from ``apex`` and radial distance
    ``s tan(half_angle)``, for ``axial_range[0] <= s <= axial_range[1]``. A conical hopper
    with an orifice of radius ``r_o`` at height ``z_o`` has ``apex = (0, 0, z_o - r_o /
    tan(half_angle))``, ``axis = (0, 0, 1)`` and ``axial_range = (r_o / tan(half_angle), H)``.
    ``inside=True``: grains inside the cone; the end circles act from every side.
    """

    kind: ClassVar[int] = CONE
    apex: tuple[float, float, float]
    axis: tuple[float, float, float]
    half_angle_deg: float
    inside: bool = True
    axial_range: tuple[float, float] = (0.0, math.inf)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "apex", _vec3(self.apex, "apex"))
        object.__setattr__(self, "axis", _unit(self.axis, "axis"))
        if not 0.0 < self.half_angle_deg < 90.0:
            raise ValueError(f"half_angle_deg: {self.half_angle_deg!r} is not valid; expected "
                             "0 < half angle < 90 degrees")
        lo, hi = (float(v) for v in self.axial_range)
        if not (0.0 <= lo < hi) or math.isnan(hi):
            raise ValueError(f"axial_range: {self.axial_range!r} is not valid; expected "
                             "0 <= s_min < s_max (distances from the apex along the axis)")
        object.__setattr__(self, "axial_range", (lo, hi))

    def _params(self) -> list[float]:
        a = math.radians(self.half_angle_deg)
        ca = math.cos(a)
        lo, hi = self.axial_range
        return [*self.apex, *self.axis, ca, math.sin(a), 1.0 if self.inside else 0.0,
                lo / ca, hi / ca, *_perpendicular(self.axis)]


@dataclass(frozen=True)
class PlateWithHole(Wall):
    """Infinite flat plate through ``point`` with a circular orifice of ``hole_radius``
    centred on ``point``; the plate acts on the side ``normal`` points to, the orifice's edge
    from every side."""

    kind: ClassVar[int] = PLATE_WITH_HOLE
    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    hole_radius: float

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "point", _vec3(self.point, "point"))
        object.__setattr__(self, "normal", _unit(self.normal, "normal"))
        if not (self.hole_radius > 0 and math.isfinite(self.hole_radius)):
            raise ValueError(f"hole_radius: {self.hole_radius!r} is not valid; expected a "
                             "positive number (use a Plane for a closed base)")

    def _params(self) -> list[float]:
        return [*self.point, *self.normal, float(self.hole_radius), *_perpendicular(self.normal)]


@dataclass(frozen=True)
class Hopper2D:
    """The 2D hopper of seed 003 (Sec. 2.1, Fig. 1a) as :class:`Segment` walls; gravity -y.

    Two vertical side walls ``W`` apart (centred on ``x_center``) run down to a bottom made
    of two straight walls that meet the side walls at the angle ``theta_w`` and leave a
    centred orifice of width ``orifice_w`` at height ``y_bottom``; the side walls end at
    ``y_bottom + height``.

    Angle convention (our reading of seed 003): ``theta_w`` is the angle between the slanted
    bottom walls and the side walls, i.e. the direction of gravity. The seed's walls "connect
    to the right wall at an angle theta_w", ``theta_w = 90`` deg is the flat base, and a
    decreasing ``theta_w`` makes "the hopper walls become more aligned with the direction of
    gravity" (Sec. 3). Each bottom wall therefore rises ``(W - w) / (2 tan theta_w)`` from
    the orifice edge to the side wall (0 for 90 deg, ``(W - w)/2`` for 45 deg); the angle
    from the horizontal is ``90 - theta_w``.

    Iterating over a hopper yields its segments, so ``WallForce(Hopper2D(...), law, 1)``
    works.
    """

    W: float
    theta_w_deg: float
    orifice_w: float
    y_bottom: float = 0.0
    height: float = 1.0
    x_center: float = 0.0

    def __post_init__(self) -> None:
        if not (self.W > 0 and math.isfinite(self.W)):
            raise ValueError(f"W: {self.W!r} is not valid; expected a positive wall separation")
        if not 0.0 < self.orifice_w < self.W:
            raise ValueError(f"orifice_w: {self.orifice_w!r} is not valid; expected "
                             f"0 < w < W = {self.W:g}")
        if not 0.0 < self.theta_w_deg <= 90.0:
            raise ValueError(f"theta_w_deg: {self.theta_w_deg!r} is not valid; expected "
                             "0 < theta_w <= 90 (90 = flat bottom)")
        if not self.height > self.rise:
            raise ValueError(f"height: {self.height!r} is not valid; the side walls must reach "
                             f"above the slanted bottom, i.e. height > {self.rise:g}")

    @property
    def rise(self) -> float:
        """Height of the slanted bottom walls, ``(W - w) / (2 tan theta_w)``."""
        if self.theta_w_deg == 90.0:
            return 0.0
        return 0.5 * (self.W - self.orifice_w) / math.tan(math.radians(self.theta_w_deg))

    def segments(self) -> list[Segment]:
        """Left bottom, right bottom, left side, right side walls."""
        xc, yb = self.x_center, self.y_bottom
        half_w, half_W = 0.5 * self.orifice_w, 0.5 * self.W
        corner = yb + self.rise
        top = yb + self.height
        return [Segment((xc - half_w, yb), (xc - half_W, corner)),
                Segment((xc + half_w, yb), (xc + half_W, corner)),
                Segment((xc - half_W, corner), (xc - half_W, top)),
                Segment((xc + half_W, corner), (xc + half_W, top))]

    def __iter__(self) -> Iterator[Segment]:
        return iter(self.segments())
