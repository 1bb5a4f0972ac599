"""Analytic wall shapes (SPEC M4) and the one compiled closest-point kernel.

Every shape is a small frozen dataclass that packs into a numeric row ``(kind,
params[N_PARAMS])``; :func:`closest_point` switches on ``kind`` and returns the point of the
wall closest to a particle centre, a flag saying whether that point may be in contact, and
the wall's unit normal there. The wall force (:mod:`grainflow.walls.force`) then calls the
particle's contact law with ``d = x - c`` (with the normal when ``x`` lies on the wall).

Which side of a wall acts (``ok``):

* :class:`Plane`: the closed half-space the normal points into (``h >= 0``).
* :class:`Segment`: both sides and the end caps (a thin rigid line; in 3D a thin rod).
* :class:`Cylinder` and :class:`Cone`: the side face acts on the inside (``inside=True``) or
  the outside; with a finite ``axial_range`` the optional lids (flat end disks, ``lid_lo``,
  ``lid_hi``) act on the same side (the inside of a closed can when ``inside=True``). The
  rims (end circles) of an open end are thin edges and act from every side, so grains leaving
  through an open end feel its edge; the rim of a closed (lidded) end is a corner of the
  closed body and acts on its acting side only.
* :class:`PlateWithHole`: the plate acts on the side its normal points into, the orifice's
  edge from every side.

A centre exactly on the acting surface is in contact (``ok`` is True there).

Several walls combine by superposition: the forces from all walls add; each (particle, wall)
pair keeps its own contact history; walls of one ``type`` share that type's contact
parameters (``law.table[particle type, wall type]``).

Walls translate with a constant ``velocity``: the shape at time ``t`` is the packed shape
shifted by ``velocity * t``. The kernel works in the wall's rest frame; callers subtract the
shift from the particle position (the branch vector ``x - c`` does not depend on the frame).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar, Iterator, NamedTuple, Sequence

import numpy as np
from numba import njit

PLANE, SEGMENT, CYLINDER, CONE, PLATE_WITH_HOLE = range(5)

#: Length of a packed parameter row.
N_PARAMS = 20


@njit(cache=True)
def _revolution_end(p, row, x0, x1, x2, s, rho, e0, e1, e2, l):
    """:func:`closest_point` of a :class:`Cylinder` or :class:`Cone` where an end may be
    closest (beyond the range, or with lids): the rims and lids, kept out of the common path.
    """
    a0 = p[row, 3]
    a1 = p[row, 4]
    a2 = p[row, 5]
    rad0 = p[row, 6]
    us = p[row, 7]
    ur = p[row, 8]
    llo = p[row, 9]
    lhi = p[row, 10]
    inside = p[row, 11] > 0.0
    lc = min(max(l, llo), lhi)
    cs = lc * us
    cr = rad0 + lc * ur
    where = 0  # 0 side face, 1 rim at l_lo, 2 rim at l_hi, 3 lid at l_lo, 4 lid at l_hi
    if lc != l:
        where = 1 if lc == llo else 2
    best = (s - cs) * (s - cs) + (rho - cr) * (rho - cr)
    for end in range(2):
        if p[row, 12 + end] > 0.0:
            le = llo if end == 0 else lhi
            se = le * us
            re = rad0 + le * ur
            if rho < re and (s - se) * (s - se) < best:
                best = (s - se) * (s - se)
                where = 3 + end
                cs = se
                cr = rho
    c0 = p[row, 0] + cs * a0 + cr * e0
    c1 = p[row, 1] + cs * a1 + cr * e1
    c2 = p[row, 2] + cs * a2 + cr * e2
    if where >= 3:  # a lid: acts towards the inside of the range when inside
        sgn = 1.0 if (where == 3) == inside else -1.0
        return c0, c1, c2, sgn * (s - cs) >= 0.0, sgn * a0, sgn * a1, sgn * a2
    # outward normal of the side (away from the axis): m = -ur a + us e
    m0 = us * e0 - ur * a0
    m1 = us * e1 - ur * a1
    m2 = us * e2 - ur * a2
    if where == 0:
        side = (rho - rad0) * us - s * ur  # > 0 outside the surface
        if inside:
            return c0, c1, c2, side <= 0.0, -m0, -m1, -m2
        return c0, c1, c2, side >= 0.0, m0, m1, m2
    # a rim: an open end acts from every side, a closed one on the acting side only
    ok = not (p[row, 11 + where] > 0.0 and inside)
    d0 = x0 - c0
    d1 = x1 - c1
    d2 = x2 - c2
    dd = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if ok and dd > 0.0:
        return c0, c1, c2, ok, d0 / dd, d1 / dd, d2 / dd
    # into the closed body: the bisector of the corner's two tangent directions (along the
    # side into the range, and along the lid towards the axis; at an apex, the axis)
    if where == 1:
        bs = us + (1.0 if cr == 0.0 else 0.0)
        br = ur - (0.0 if cr == 0.0 else 1.0)
    else:
        bs = -us
        br = -ur - 1.0
    g = 1.0 / math.sqrt(bs * bs + br * br)
    if ok:  # x on an open rim (only by rounding): out of the body
        g = -g
    return c0, c1, c2, ok, g * (bs * a0 + br * e0), g * (bs * a1 + br * e1), g * (
        bs * a2 + br * e2)


@njit(inline="always")
def closest_point(kind, params, row, x0, x1, x2):
    """Closest point ``c`` of wall ``params[row]`` to ``x``, ``ok`` and the normal ``n``.

    Returns ``(c0, c1, c2, ok, n0, n1, n2)``:

    * ``c``: the point of the wall closest to ``x`` (ties: any one of the closest points);
    * ``ok``: True when ``x`` is on the acting side of the wall at ``c``, including exactly
      on the surface (``x == c``); edges that act from every side always give True;
    * ``n``: a unit normal of the wall at ``c`` pointing to the side on which the wall acts.
      On a smooth face (plane, plate, cylinder or cone side, lid) it is the face normal, so
      ``x - c = +|x - c| n`` when ``ok`` and ``-|x - c| n`` when not. On an edge (a rim, the
      orifice's edge, a cone's apex) ``n = (x - c)/|x - c|`` (these have ``ok`` and
      ``x != c``), except on the rim of a closed (lidded) end seen from the non-acting side,
      where ``n`` is the bisector of the corner pointing into the body. On a segment
      (two-sided, end caps included) ``n = +-l``, with ``l`` the segment's left normal (see
      :class:`Segment`), the sign making ``n . (x - c) >= 0``: a centre exactly on a segment
      gets ``n = l``; in 2D ``n`` is along ``x - c`` except at the end caps. The force uses
      ``n`` when ``x - c`` is zero.

    The whole ``(n_walls, N_PARAMS)`` table and a row index are passed rather than the row
    itself: creating an array view per particle-wall pair inside a parallel loop costs more
    than the geometry (see :mod:`grainflow.kernels.pair_loop`). Inlined into the compiled
    callers (``inline="always"``: a call costs more than the geometry); the rare ends of
    tubes and cones are a separate function. From Python, :meth:`Wall.closest_point`.
    """
    p = params
    if kind == PLANE:
        # p = [point(3), unit normal(3)]; c = x - ((x - p).n) n
        n0 = p[row, 3]
        n1 = p[row, 4]
        n2 = p[row, 5]
        h = (x0 - p[row, 0]) * n0 + (x1 - p[row, 1]) * n1 + (x2 - p[row, 2]) * n2
        return x0 - h * n0, x1 - h * n1, x2 - h * n2, h >= 0.0, n0, n1, n2
    if kind == SEGMENT:
        # p = [p0(3), p1 - p0(3), 1/|p1 - p0|^2, left normal(3)];
        # c = p0 + clamp(t, 0, 1) (p1 - p0)
        t = ((x0 - p[row, 0]) * p[row, 3] + (x1 - p[row, 1]) * p[row, 4]
             + (x2 - p[row, 2]) * p[row, 5]) * p[row, 6]
        tc = min(max(t, 0.0), 1.0)
        c0 = p[row, 0] + tc * p[row, 3]
        c1 = p[row, 1] + tc * p[row, 4]
        c2 = p[row, 2] + tc * p[row, 5]
        # n = +-l, towards x (no square root: the force needs n only when x == c)
        sgn = 1.0 if ((x0 - c0) * p[row, 7] + (x1 - c1) * p[row, 8]
                      + (x2 - c2) * p[row, 9]) >= 0.0 else -1.0
        return c0, c1, c2, True, sgn * p[row, 7], sgn * p[row, 8], sgn * p[row, 9]
    if kind == CYLINDER or kind == CONE:
        # A surface of revolution about the axis line P + s a. In the meridian half-plane
        # (s along the axis, rho >= 0 off it) the side is the segment
        # (s, rho) = (0, R0) + l (us, ur), l_lo <= l <= l_hi (us > 0; +-inf for an infinite
        # tube); lids are the disks s = s_end, rho <= rho_end at finite ends.
        # p = [P(3), unit axis a(3), R0, us, ur, l_lo, l_hi, inside, lid_lo, lid_hi,
        #      e_perp(3)]
        r0 = x0 - p[row, 0]
        r1 = x1 - p[row, 1]
        r2 = x2 - p[row, 2]
        a0 = p[row, 3]
        a1 = p[row, 4]
        a2 = p[row, 5]
        s = r0 * a0 + r1 * a1 + r2 * a2
        q0 = r0 - s * a0
        q1 = r1 - s * a1
        q2 = r2 - s * a2
        rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
        if rho > 0.0:
            inv = 1.0 / rho
            e0 = q0 * inv
            e1 = q1 * inv
            e2 = q2 * inv
        else:
            e0 = p[row, 14]
            e1 = p[row, 15]
            e2 = p[row, 16]
        rad0 = p[row, 6]
        us = p[row, 7]
        ur = p[row, 8]
        l = s * us + (rho - rad0) * ur
        if l < p[row, 9] or l > p[row, 10] or p[row, 12] > 0.0 or p[row, 13] > 0.0:
            return _revolution_end(p, row, x0, x1, x2, s, rho, e0, e1, e2, l)
        cs = l * us
        cr = rad0 + l * ur
        # outward normal of the side (away from the axis): m = -ur a + us e
        m0 = us * e0 - ur * a0
        m1 = us * e1 - ur * a1
        m2 = us * e2 - ur * a2
        side = (rho - rad0) * us - s * ur  # > 0 outside the surface
        c0 = p[row, 0] + cs * a0 + cr * e0
        c1 = p[row, 1] + cs * a1 + cr * e1
        c2 = p[row, 2] + cs * a2 + cr * e2
        if p[row, 11] > 0.0:
            return c0, c1, c2, side <= 0.0, -m0, -m1, -m2
        return c0, c1, c2, side >= 0.0, m0, m1, m2
    # PLATE_WITH_HOLE: p = [centre(3), unit normal(3), hole radius, e_perp(3)]
    n0 = p[row, 3]
    n1 = p[row, 4]
    n2 = p[row, 5]
    r0 = x0 - p[row, 0]
    r1 = x1 - p[row, 1]
    r2 = x2 - p[row, 2]
    h = r0 * n0 + r1 * n1 + r2 * n2
    q0 = r0 - h * n0
    q1 = r1 - h * n1
    q2 = r2 - h * n2
    rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    hole = p[row, 6]
    if rho >= hole:
        return x0 - h * n0, x1 - h * n1, x2 - h * n2, h >= 0.0, n0, n1, n2
    if rho > 0.0:
        g = hole / rho
        c0 = p[row, 0] + g * q0
        c1 = p[row, 1] + g * q1
        c2 = p[row, 2] + g * q2
    else:
        c0 = p[row, 0] + hole * p[row, 7]
        c1 = p[row, 1] + hole * p[row, 8]
        c2 = p[row, 2] + hole * p[row, 9]
    d0 = x0 - c0
    d1 = x1 - c1
    d2 = x2 - c2
    dd = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if dd > 0.0:
        return c0, c1, c2, True, d0 / dd, d1 / dd, d2 / dd
    return c0, c1, c2, True, n0, n1, n2


@njit(cache=True)
def _closest_point(kind, params, row, x0, x1, x2):
    """:func:`closest_point` compiled on its own (and cached) for :meth:`Wall.closest_point`."""
    return closest_point(kind, params, row, x0, x1, x2)


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


class ClosestPoint(NamedTuple):
    """What :meth:`Wall.closest_point` returns (see :func:`closest_point`)."""

    point: np.ndarray
    ok: bool
    normal: np.ndarray


@dataclass(frozen=True)
class Wall:
    """Base of the wall shapes: a constant translation ``velocity`` (2 or 3 components).

    Several walls combine by superposition: the forces from all walls add; each (particle,
    wall) pair keeps its own contact history; walls of one ``type`` share that type's contact
    parameters.
    """

    kind: ClassVar[int]
    velocity: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0), kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "velocity", _vec3(self.velocity, "velocity"))

    def pack(self) -> np.ndarray:
        """The ``params[N_PARAMS]`` row read by :func:`closest_point`."""
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

    def closest_point(self, x: Sequence[float], time: float = 0.0) -> ClosestPoint:
        """Closest wall point to ``x`` at ``time``, whether it may be in contact, and the
        wall's unit normal there towards its acting side (the kernel :func:`closest_point`)."""
        shift = np.asarray(self.velocity) * time
        p = np.asarray(_vec3(x, "x")) - shift
        c0, c1, c2, ok, n0, n1, n2 = _closest_point(self.kind, self.pack()[None, :], 0,
                                                    p[0], p[1], p[2])
        return ClosestPoint(np.array([c0, c1, c2]) + shift, bool(ok), np.array([n0, n1, n2]))


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
    """Finite segment ``p0``-``p1`` (2D walls); both sides and the end caps act.

    Its left normal ``l`` is ``z x (p1 - p0)`` normalised: in 2D the direction of ``p1 - p0``
    turned 90 degrees counter-clockwise (for a 3D segment along z, a fixed perpendicular).
    A centre exactly on the segment is pushed along ``l``.
    """

    kind: ClassVar[int] = SEGMENT
    p0: tuple[float, float, float]
    p1: tuple[float, float, float]

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "p0", _vec3(self.p0, "p0"))
        object.__setattr__(self, "p1", _vec3(self.p1, "p1"))
        if self.p0 == self.p1:
            raise ValueError(f"p1: {self.p1!r} equals p0; a segment needs two distinct ends")

    @property
    def left_normal(self) -> tuple[float, float, float]:
        """``z x (p1 - p0)`` normalised (see the class docstring)."""
        e = np.subtract(self.p1, self.p0)
        left = np.array([-e[1], e[0], 0.0])
        norm = float(np.linalg.norm(left))
        if norm == 0.0:
            left, norm = _perpendicular(e / np.linalg.norm(e)), 1.0
        return tuple(float(v) for v in left / norm)  # type: ignore[return-value]

    def _params(self) -> list[float]:
        e = np.subtract(self.p1, self.p0)
        return [*self.p0, *e, 1.0 / float(e @ e), *self.left_normal]

    def _planar(self) -> bool:
        return self.p0[2] == 0.0 and self.p1[2] == 0.0


def _axial_range(value: Sequence[float], lowest: float, what: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"axial_range: {value!r} is not valid; expected two numbers "
                         f"(s_min, s_max) {what}") from None
    if not (lowest <= lo < hi) or math.isnan(hi) or lo == math.inf:
        low = "-inf" if lowest == -math.inf else f"{lowest:g}"
        raise ValueError(f"axial_range: {value!r} is not valid; expected {low} <= s_min < "
                         f"s_max {what}")
    return lo, hi


def _check_lids(wall: "Cylinder | Cone") -> None:
    for name, end in (("lid_lo", 0), ("lid_hi", 1)):
        if getattr(wall, name) and not math.isfinite(wall.axial_range[end]):
            raise ValueError(f"{name}: a lid needs a finite end; axial_range[{end}] is "
                             f"{wall.axial_range[end]!r}")


def _flag(value: bool) -> float:
    return 1.0 if value else 0.0


@dataclass(frozen=True)
class Cylinder(Wall):
    """Cylinder of ``radius`` around the line ``axis_point + s axis_direction``.

    ``inside=True``: a tube holding the grains inside; ``False``: a post, grains outside.
    ``axial_range = (s_min, s_max)`` (``s`` measured from ``axis_point`` along
    ``axis_direction``) makes it finite; the default is infinite. ``lid_lo`` / ``lid_hi``
    close the finite ends at ``s_min`` / ``s_max`` with flat disks acting on the same side as
    the tube (a closed can with ``inside=True``, a solid post otherwise); the rim of an open
    end acts from every side. With the axis along z (infinite, or a range across z = 0, and
    no lids) this is a circular wall in 2D.
    """

    kind: ClassVar[int] = CYLINDER
    axis_point: tuple[float, float, float]
    axis_direction: tuple[float, float, float]
    radius: float
    inside: bool = True
    axial_range: tuple[float, float] = (-math.inf, math.inf)
    lid_lo: bool = False
    lid_hi: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "axis_point", _vec3(self.axis_point, "axis_point"))
        object.__setattr__(self, "axis_direction", _unit(self.axis_direction, "axis_direction"))
        if not (self.radius > 0 and math.isfinite(self.radius)):
            raise ValueError(f"radius: {self.radius!r} is not valid; expected a positive number")
        object.__setattr__(self, "axial_range", _axial_range(
            self.axial_range, -math.inf, "(distances from axis_point along axis_direction)"))
        _check_lids(self)

    def _params(self) -> list[float]:
        lo, hi = self.axial_range
        return [*self.axis_point, *self.axis_direction, float(self.radius), 1.0, 0.0, lo, hi,
                _flag(self.inside), _flag(self.lid_lo), _flag(self.lid_hi),
                *_perpendicular(self.axis_direction)]

    def _planar(self) -> bool:
        a = self.axis_direction
        if a[0] != 0.0 or a[1] != 0.0 or self.lid_lo or self.lid_hi:
            return False
        s0 = -self.axis_point[2] * a[2]  # where the axis crosses z = 0
        return self.axial_range[0] < s0 < self.axial_range[1]


@dataclass(frozen=True)
class Cone(Wall):
    """Finite cone (3D hoppers): apex, axis (pointing to where it widens), half angle.

    The surface is the set of points at axial distance ``s`` from ``apex`` and radial distance
    ``s tan(half_angle)``, for ``axial_range[0] <= s <= axial_range[1]``. A conical hopper
    with an orifice of radius ``r_o`` at height ``z_o`` has ``apex = (0, 0, z_o - r_o /
    tan(half_angle))``, ``axis = (0, 0, 1)`` and ``axial_range = (r_o / tan(half_angle), H)``.
    ``inside=True``: grains inside the cone. ``lid_lo`` / ``lid_hi`` close the ends at
    ``s_min`` / ``s_max`` with flat disks acting on the same side as the cone; the rim of an
    open end acts from every side (a lid at the apex, ``s_min = 0``, only closes the apex).
    :meth:`from_lammps` builds a cone from LAMMPS's ``region cone`` arguments.
    """

    kind: ClassVar[int] = CONE
    apex: tuple[float, float, float]
    axis: tuple[float, float, float]
    half_angle_deg: float
    inside: bool = True
    axial_range: tuple[float, float] = (0.0, math.inf)
    lid_lo: bool = False
    lid_hi: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "apex", _vec3(self.apex, "apex"))
        object.__setattr__(self, "axis", _unit(self.axis, "axis"))
        if not 0.0 < self.half_angle_deg < 90.0:
            raise ValueError(f"half_angle_deg: {self.half_angle_deg!r} is not valid; expected "
                             "0 < half angle < 90 degrees")
        object.__setattr__(self, "axial_range", _axial_range(
            self.axial_range, 0.0, "(distances from the apex along the axis)"))
        _check_lids(self)

    @classmethod
    def from_lammps(cls, dim: str, c1: float, c2: float, radlo: float, radhi: float,
                    lo: float, hi: float, *, inside: bool = True, lid_lo: bool = False,
                    lid_hi: bool = False,
                    velocity: Sequence[float] = (0.0, 0.0, 0.0)) -> "Cone | Cylinder":
        """The cone of LAMMPS's ``region ID cone dim c1 c2 radlo radhi lo hi``.

        ``dim`` (``"x"``, ``"y"``, ``"z"``) is the axis, ``c1, c2`` the axis' coordinates
        in the other two dimensions in increasing order (y, z for x; x, z for y; x, y for z),
        ``radlo`` / ``radhi`` the radii at the coordinates ``lo`` < ``hi`` along ``dim``.
        Either radius may be 0 (an apex) and ``radlo > radhi`` is a cone widening towards
        ``lo``; ``radlo == radhi`` is a cylinder and returns a :class:`Cylinder`.
        ``lid_lo`` / ``lid_hi`` close the ends at ``lo`` / ``hi``. Unlike a LAMMPS region,
        whose ends are closed unless ``open 1`` / ``open 2`` is given, ends are open unless
        a lid is asked for (as for :class:`Cone`); ``side in`` is ``inside=True``.
        """
        if dim not in ("x", "y", "z"):
            raise ValueError(f"dim: {dim!r} is not valid; expected 'x', 'y' or 'z'")
        values = {"c1": c1, "c2": c2, "radlo": radlo, "radhi": radhi, "lo": lo, "hi": hi}
        for name, v in values.items():
            if not math.isfinite(float(v)):
                raise ValueError(f"{name}: {v!r} is not valid; expected a finite number")
        if not lo < hi:
            raise ValueError(f"hi: {hi!r} is not valid; expected hi > lo = {lo!r}")
        if radlo < 0 or radhi < 0 or radlo == radhi == 0:
            raise ValueError(f"radlo, radhi: {radlo!r}, {radhi!r} are not valid; expected "
                             "radii >= 0, not both 0")
        k = "xyz".index(dim)
        others = [i for i in range(3) if i != k]
        unit = [0.0, 0.0, 0.0]
        unit[k] = 1.0

        def on_axis(coord: float) -> tuple[float, float, float]:
            point = [0.0, 0.0, 0.0]
            point[others[0]], point[others[1]], point[k] = float(c1), float(c2), float(coord)
            return tuple(point)  # type: ignore[return-value]

        if radlo == radhi:
            return Cylinder(on_axis(lo), tuple(unit), float(radlo), inside,
                            axial_range=(0.0, float(hi - lo)), lid_lo=lid_lo, lid_hi=lid_hi,
                            velocity=velocity)
        tan_a = abs(radhi - radlo) / (hi - lo)
        half = math.degrees(math.atan(tan_a))
        if radhi > radlo:  # widens towards hi: the axis points along +dim
            return cls(on_axis(lo - radlo / tan_a), tuple(unit), half, inside,
                       axial_range=(radlo / tan_a, radhi / tan_a), lid_lo=lid_lo,
                       lid_hi=lid_hi, velocity=velocity)
        down = tuple(-u if u else 0.0 for u in unit)  # widens towards lo: axis along -dim
        return cls(on_axis(hi + radhi / tan_a), down, half, inside,  # type: ignore[arg-type]
                   axial_range=(radhi / tan_a, radlo / tan_a), lid_lo=lid_hi, lid_hi=lid_lo,
                   velocity=velocity)

    def _params(self) -> list[float]:
        a = math.radians(self.half_angle_deg)
        ca = math.cos(a)
        lo, hi = self.axial_range
        return [*self.apex, *self.axis, 0.0, ca, math.sin(a), lo / ca, hi / ca,
                _flag(self.inside), _flag(self.lid_lo), _flag(self.lid_hi),
                *_perpendicular(self.axis)]


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
    works. The segments are oriented so that their left normals (:class:`Segment`) point
    into the hopper, and all move with the hopper's ``velocity``.
    """

    W: float
    theta_w_deg: float
    orifice_w: float
    y_bottom: float = 0.0
    height: float = 1.0
    x_center: float = 0.0
    velocity: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0), kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "velocity", _vec3(self.velocity, "velocity"))
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
        """Left bottom, right bottom, left side, right side walls (left normals inwards)."""
        xc, yb = self.x_center, self.y_bottom
        half_w, half_W = 0.5 * self.orifice_w, 0.5 * self.W
        corner = yb + self.rise
        top = yb + self.height
        v = self.velocity
        return [Segment((xc - half_W, corner), (xc - half_w, yb), velocity=v),
                Segment((xc + half_w, yb), (xc + half_W, corner), velocity=v),
                Segment((xc - half_W, top), (xc - half_W, corner), velocity=v),
                Segment((xc + half_W, corner), (xc + half_W, top), velocity=v)]

    def __iter__(self) -> Iterator[Segment]:
        return iter(self.segments())
