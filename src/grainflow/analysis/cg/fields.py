"""Coarse-grained continuum fields from saved frames: coordinates x kernel x fields.

For a kernel ``W`` (a bin's indicator over its volume, or a smooth kernel) the fields are
(Goldhirsch, Granular Matter 12, 239 (2010); Weinhart et al. 2012; seed 002 Appendix C)::

    n(r)    = sum_i W(r - r_i)                       number density
    rho(r)  = sum_i m_i W(r - r_i)                   mass density
    phi(r)  = sum_i V_i W(r - r_i)                   packing fraction (V_i: disk area,
                                                     sphere volume; the grain counts where
                                                     its centre is)
    p(r)    = sum_i m_i v_i W(r - r_i)               momentum density; V = p / rho
    sigma_k = sum_i m_i v_i v_i W - rho V V          kinetic stress (seed 002 eq. C.20/C.31:
                                                     sum m u' u' / V with u' = v - V)
    sigma_c = sum_c F_c (x) b_c int_0^1 W(r - r_i + s b_c) ds
                                                     contact stress (eq. C.21; for bins the
                                                     integral is A/V, A the fraction of the
                                                     branch line in the cell, eq. C.29/C.32)
    T_a     = sigma_k,aa / n,  T = tr(sigma_k) / (D n)   granular temperature (thesis Sec. 5.2)
    D_ab    = (d_a V_b + d_b V_a) / 2                strain rate, by finite differences

Stress is compression-positive: a contact ``c`` on grain ``i`` from its partner carries the
force ``F_c`` on ``i`` and the branch vector ``b_c = r_i - r_partner`` (partner: a grain, the
wall's contact point, a tether's anchor; :class:`~grainflow.frame.Contacts`), listed once.
Wall and tether contributions are the terms with the partner a wall or an anchor; they are
kept apart (:meth:`CGFields.contact_stress` with ``kind``). With every contact force and
branch, ``div sigma = rho g`` for grains at rest under gravity; the volume integral of
``sigma_c`` is the virial sum ``sum F (x) b`` exactly for bins.

Time averaging sums each density over the frames of the window and divides by their number;
ratios (velocity, temperature) are taken of the averaged sums, so that ``u'`` is measured
from the window's mean velocity. ``blocks`` consecutive groups of frames give error bars:
each derived field computed per block, its standard error ``std / sqrt(blocks)``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from math import pi
from pathlib import Path

import numpy as np

from grainflow.analysis.cg.coordinates import (Cartesian, Coordinates, Cylindrical, Polar,
                                              frame_about, rotate_rows)
from grainflow.analysis.cg.kernels import Gaussian, Heaviside, Kernel, Lucy
from grainflow.analysis.cg.selection import select_types
from grainflow.frame import CONTACT_KINDS, Frame
from grainflow.kernels import cg_deposit

__all__ = ["FIELDS", "CGFields", "coarse_grain", "combine", "frame_sums", "load_fields",
           "radial_basis", "rows_of", "strain_rate"]


def _grain_volumes(radius: np.ndarray, dim: int) -> np.ndarray:
    return pi * radius**2 if dim == 2 else 4.0 / 3.0 * pi * radius**3


def radial_basis(local: np.ndarray, dim: int) -> np.ndarray:
    """(N, dim, dim): rows e_r, e_theta(, e_z) at local points (e_r along x on the axis)."""
    rho = np.hypot(local[:, 0], local[:, 1])
    safe = np.where(rho > 0, rho, 1.0)
    c = np.where(rho > 0, local[:, 0] / safe, 1.0)
    s = np.where(rho > 0, local[:, 1] / safe, 0.0)
    basis = np.zeros((local.shape[0], dim, dim))
    basis[:, 0, 0], basis[:, 0, 1] = c, s
    basis[:, 1, 0], basis[:, 1, 1] = -s, c
    if dim == 3:
        basis[:, 2, 2] = 1.0
    return basis


def _local_axes(coords: Coordinates, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Positions in the system's local frame, and the radial basis there (None: Cartesian)."""
    local = coords.to_local(x)
    return local, None if isinstance(coords, Cartesian) else radial_basis(local, coords.dim)


def _vectors_in_frame(coords: Coordinates, v: np.ndarray) -> np.ndarray:
    """Vectors turned into the local frame's Cartesian axes (a rotation for cylinders)."""
    if isinstance(coords, Cylindrical):
        return rotate_rows(v, frame_about(coords.axis))
    return v


def _check_frame(frame: Frame, coords: Coordinates) -> None:
    if frame.dim != coords.dim:
        raise ValueError(f"coordinates: a {coords.dim}D system cannot coarse-grain the "
                         f"{frame.dim}D frame at step {frame.step}")


def _particle_values(frame: Frame, coords: Coordinates) -> tuple[np.ndarray, np.ndarray]:
    """Local positions (N, dim) and per-grain values (N, 3 + D + D^2): 1, m, V_i, m v, m v v,
    vectors in the system's components."""
    dim = frame.dim
    local, basis = _local_axes(coords, np.asarray(frame.position, dtype=float))
    v = _vectors_in_frame(coords, np.asarray(frame.velocity, dtype=float))
    if basis is not None:
        v = np.einsum("nab,nb->na", basis, v)
    m = np.asarray(frame.mass, dtype=float)
    mvv = (m[:, None, None] * v[:, :, None] * v[:, None, :]).reshape(-1, dim * dim)
    values = np.column_stack([np.ones_like(m), m, _grain_volumes(np.asarray(frame.radius), dim),
                              m[:, None] * v, mvv])
    return local, values


def rows_of(frame: Frame, ids: np.ndarray) -> np.ndarray:
    """The frame's rows of the particles ``ids`` (e.g. a contact listing's ``i``);
    ValueError naming ids the frame does not hold."""
    ids = np.asarray(ids)
    order = np.argsort(frame.id, kind="stable")
    slot = np.searchsorted(frame.id, ids, sorter=order)
    slot = np.clip(slot, 0, frame.n - 1)
    rows = order[slot]
    if frame.n == 0 or np.any(frame.id[rows] != ids):
        missing = np.setdiff1d(ids, frame.id)[:5]
        raise ValueError(f"frame at step {frame.step}: contacts name particle ids "
                         f"{missing.tolist()} that the frame does not hold")
    return rows


def _contact_segments(frame: Frame, coords: Coordinates):
    """Per contact kind present: (start, end) of its branch lines in the local frame (partner
    point -> grain centre) and F (x) b (M, D, D) in the local frame's Cartesian axes."""
    c = frame.contacts
    rows = rows_of(frame, c.i)
    centre = np.asarray(frame.position, dtype=float)[rows]
    branch = np.asarray(c.branch, dtype=float)
    force = np.asarray(c.force, dtype=float)
    end = coords.to_local(centre)
    start = coords.to_local(centre - branch)
    f = _vectors_in_frame(coords, force)
    b = _vectors_in_frame(coords, branch)
    tensor = f[:, :, None] * b[:, None, :]
    out = {}
    for code, name in enumerate(CONTACT_KINDS):
        sel = c.kind == code
        if np.any(sel):
            out[name] = (start[sel], end[sel], tensor[sel])
    return out


def _kernel_grid(coords: Coordinates):
    edges, offsets, counts = coords.packed()
    theta0 = float(coords.edges[1][0]) if isinstance(coords, Polar) else 0.0
    return edges, offsets, counts, theta0


def _bin_particles(coords, local, values, periods, n_cells) -> np.ndarray:
    edges, offsets, counts, theta0 = _kernel_grid(coords)
    cells = cg_deposit.cells_of(coords.system, np.ascontiguousarray(local), edges, offsets,
                                counts, periods, theta0)
    keep = cells >= 0
    out = np.empty((n_cells, values.shape[1]))
    for col in range(values.shape[1]):
        out[:, col] = np.bincount(cells[keep], weights=values[keep, col], minlength=n_cells)
    return out


def _bin_segments(coords, start, end, tensor, periods, n_cells) -> np.ndarray:
    edges, offsets, counts, theta0 = _kernel_grid(coords)
    dim = coords.dim
    out = np.zeros((n_cells, dim, dim))
    cg_deposit.deposit_segments(coords.system, np.ascontiguousarray(start),
                                np.ascontiguousarray(end), np.ascontiguousarray(tensor),
                                not isinstance(coords, Cartesian), edges, offsets, counts,
                                periods, theta0, out)
    return out.reshape(n_cells, dim * dim)


def _smooth(coords, kernel, points, weights, values, periods, n_cells) -> np.ndarray:
    """Deposit lines with a smooth kernel: line ``m`` has local points ``points[m]`` (P, dim)
    with weights ``weights[m]`` sharing the values ``values[m]`` (a grain is a line of one
    point of weight 1). Points outside the averaged extents get weight 0; along periodic axes
    lines are wrapped whole (by their first point) and imaged near the faces; near a
    cylinder's axis (or a full-turn polar grid's centre) lines get a mirror image at -r."""
    m, n_points, dim = points.shape
    weights = weights.copy()
    if isinstance(coords, Cartesian):  # averaged periodic axes: wrap before the extent test
        for a, e in enumerate(coords.edges):
            if e.size == 2 and periods[a] > 0:
                points = points.copy()
                points[..., a] = e[0] + np.mod(points[..., a] - e[0], periods[a])
    q, inside = coords.kernel_space(points.reshape(-1, dim))
    q = q.reshape(m, n_points, -1)
    weights[~inside.reshape(m, n_points)] = 0.0
    if isinstance(coords, Cartesian):
        for axis, a in enumerate(coords.resolved):
            if periods[a] <= 0:
                continue
            lo, period = coords.edges[a][0], periods[a]
            q = q.copy()
            q[..., axis] -= np.floor((q[:, :1, axis] - lo) / period) * period
            near_lo = q[..., axis].min(axis=1) < lo + kernel.reach
            near_hi = q[..., axis].max(axis=1) >= lo + period - kernel.reach
            shift = np.zeros(q.shape[-1])
            shift[axis] = period
            q = np.concatenate([q, q[near_lo] + shift, q[near_hi] - shift])
            weights = np.concatenate([weights, weights[near_lo], weights[near_hi]])
            values = np.concatenate([values, values[near_lo], values[near_hi]])
    if coords.mirrored:
        near = q[..., 0].min(axis=1) < kernel.reach
        mirror = q[near].copy()
        mirror[..., 0] *= -1.0
        q = np.concatenate([q, mirror])
        weights = np.concatenate([weights, weights[near]])
        values = np.concatenate([values, values[near]])
    out = np.zeros((n_cells, values.shape[1]))
    if q.shape[-1] == 0:  # every coordinate averaged: one cell
        out[:] = (weights.sum(axis=1)[:, None] * values).sum(axis=0)
    elif coords.explicit:
        seen = weights.reshape(-1) != 0.0
        flat_values = (weights[..., None] * values[:, None, :]).reshape(-1, values.shape[1])
        cg_deposit.deposit_smooth_points(
            np.ascontiguousarray(q.reshape(-1, q.shape[-1])[seen]),
            np.ascontiguousarray(flat_values[seen]), coords.sample_points(), kernel.code,
            kernel.width, kernel.reach, kernel.norm(q.shape[-1]), out)
    elif q.shape[0] > 0:
        _deposit_lines(coords, kernel, q, weights, values, out)
    return out / coords.smooth_divisor().reshape(n_cells, 1)


def _deposit_lines(coords, kernel, q, weights, values, out) -> None:
    """:func:`cg_deposit.deposit_smooth_lines` on the grid's resolved centres
    (:func:`cg_deposit.deposit_gaussian_points` for one-point lines and the Gaussian)."""
    centres = coords.centres
    flat = np.concatenate(centres)
    offsets = np.cumsum([0] + [c.size for c in centres[:-1]]).astype(np.int64)
    counts = np.array([c.size for c in centres], dtype=np.int64)
    if isinstance(kernel, Gaussian) and q.shape[1] == 1:  # grains, rotated line points
        cg_deposit.deposit_gaussian_points(np.ascontiguousarray(q[:, 0, :]),
                                           np.ascontiguousarray(weights[:, 0]),
                                           np.ascontiguousarray(values), flat, offsets,
                                           counts, kernel.width, kernel.reach,
                                           kernel.norm(q.shape[-1]), out)
        return
    q = np.ascontiguousarray(q)
    patch = cg_deposit.line_patch_size(q, flat, offsets, counts, kernel.reach)
    cg_deposit.deposit_smooth_lines(q, np.ascontiguousarray(weights),
                                    np.ascontiguousarray(values), flat, offsets, counts,
                                    kernel.code, kernel.width, kernel.reach,
                                    kernel.norm(q.shape[-1]), patch, out)


def _smooth_contacts(coords, kernel, start, end, tensor, periods, n_cells) -> np.ndarray:
    """Branch lines with a smooth kernel, by Gauss-Legendre points. On a Cartesian grid a
    line's tensor is the same at all its points (one line of ``line_points`` points); in
    cylindrical and polar cells it turns with the azimuth, so each point is a line of its own
    with its rotated tensor (:func:`cg_deposit.line_points`)."""
    nodes, gl_weights = np.polynomial.legendre.leggauss(kernel.line_points)
    s, w = 0.5 * (nodes + 1.0), 0.5 * gl_weights
    m, dim = start.shape
    if isinstance(coords, Cartesian):
        points = start[:, None, :] + s[None, :, None] * (end - start)[:, None, :]
        weights = np.broadcast_to(w, points.shape[:2])
        return _smooth(coords, kernel, points, weights, tensor.reshape(m, -1), periods,
                       n_cells)
    points = np.empty((m, s.size, dim))
    values = np.empty((m, s.size, dim * dim))
    cg_deposit.line_points(np.ascontiguousarray(start), np.ascontiguousarray(end),
                           np.ascontiguousarray(tensor), s, w, points, values)
    return _smooth(coords, kernel, points.reshape(-1, 1, dim), np.ones((m * s.size, 1)),
                   values.reshape(-1, dim * dim), periods, n_cells)


def frame_sums(frame: Frame, coordinates: Coordinates, kernel: Kernel, *,
               contacts: bool = True) -> dict[str, np.ndarray]:
    """Kernel-weighted sums of one frame, per cell (densities: divided by the cell's volume).

    Keys: ``number``, ``mass``, ``volume`` (cells,), ``momentum`` (cells, D), ``mvv``
    (cells, D, D), and ``contact_<kind>`` (cells, D, D) for every contact kind in
    :data:`~grainflow.frame.CONTACT_KINDS` (zeros where the frame has none of that kind).
    Components are those of ``coordinates``. With ``contacts`` true a frame without a contact
    listing is an error (its stress would silently be kinetic only).
    """
    _check_frame(frame, coordinates)
    dim = frame.dim
    n_cells = int(np.prod(coordinates.shape, dtype=np.int64))
    periods = coordinates.periods(frame.box)
    local, values = _particle_values(frame, coordinates)
    if kernel.smooth:
        per_grain = _smooth(coordinates, kernel, local[:, None, :], np.ones((frame.n, 1)),
                            values, periods, n_cells)
    else:
        per_grain = _bin_particles(coordinates, local, values, periods, n_cells)
        per_grain /= coordinates.cell_volumes().reshape(n_cells, 1)
    out = {"number": per_grain[:, 0], "mass": per_grain[:, 1], "volume": per_grain[:, 2],
           "momentum": per_grain[:, 3:3 + dim],
           "mvv": per_grain[:, 3 + dim:].reshape(n_cells, dim, dim)}
    for name in CONTACT_KINDS:
        out[f"contact_{name}"] = np.zeros((n_cells, dim, dim))
    if contacts:
        if frame.contacts is None:
            raise ValueError(f"frame at step {frame.step} carries no contact listing, so its "
                             "contact stress is unknown: write contacts with the trajectory "
                             "([output] contacts = true), or pass contacts=False for the "
                             "kinetic fields only")
        for name, (start, end, tensor) in _contact_segments(frame, coordinates).items():
            if kernel.smooth:
                sums = _smooth_contacts(coordinates, kernel, start, end, tensor, periods,
                                        n_cells)
            else:
                sums = _bin_segments(coordinates, start, end, tensor, periods, n_cells)
                sums /= coordinates.cell_volumes().reshape(n_cells, 1)
            out[f"contact_{name}"] = sums.reshape(n_cells, dim, dim)
    return out


@dataclass(frozen=True)
class CGFields:
    """Time-averaged coarse-grained fields on a grid, with block error bars.

    Fields have the grid's :attr:`shape` (``coordinates.shape``) followed by their component
    axes (D for vectors, (D, D) for tensors), components in ``coordinates.components``. NaN
    where no grain was seen (velocity, temperature, strain rate next to such cells); the
    kinetic stress is zero there, so the stress of a cell that only branch lines cross is
    their contact stress. ``errors(name)`` gives the standard error
    of any field over the ``blocks`` groups of frames (NaN with one block).
    """

    coordinates: Coordinates
    kernel: Kernel
    n_frames: int
    time: tuple[float, float]
    block_sums: dict[str, np.ndarray] = field(repr=False)
    block_frames: np.ndarray = field(repr=False)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.coordinates.shape

    @property
    def dim(self) -> int:
        return self.coordinates.dim

    @property
    def blocks(self) -> int:
        return int(self.block_frames.size)

    def _pooled(self) -> dict[str, np.ndarray]:
        return {k: v.sum(axis=0) / self.n_frames for k, v in self.block_sums.items()}

    def _block(self, b: int) -> dict[str, np.ndarray]:
        return {k: v[b] / self.block_frames[b] for k, v in self.block_sums.items()}

    def field(self, name: str) -> np.ndarray:
        """A field by name (see :data:`FIELDS`)."""
        return _derived(name, self._pooled(), self.coordinates)

    def errors(self, name: str) -> np.ndarray:
        """Standard error of a field from its spread over blocks (NaN with one block)."""
        if self.blocks < 2:
            return np.full_like(self.field(name), np.nan)
        values = np.stack([_derived(name, self._block(b), self.coordinates)
                           for b in range(self.blocks)])
        return np.nanstd(values, axis=0, ddof=1) / np.sqrt(self.blocks)

    # named access, so that the fields read like the physics
    number_density = property(lambda self: self.field("number_density"))
    mass_density = property(lambda self: self.field("mass_density"))
    packing_fraction = property(lambda self: self.field("packing_fraction"))
    momentum = property(lambda self: self.field("momentum"))
    velocity = property(lambda self: self.field("velocity"))
    kinetic_stress = property(lambda self: self.field("kinetic_stress"))
    stress = property(lambda self: self.field("stress"))
    pressure = property(lambda self: self.field("pressure"))
    temperature = property(lambda self: self.field("temperature"))
    temperature_components = property(lambda self: self.field("temperature_components"))
    strain_rate = property(lambda self: self.field("strain_rate"))

    def contact_stress(self, kind: str | None = None) -> np.ndarray:
        """Contact stress of all contacts, or of one kind (``"pair"``, ``"wall"``, ``"bond"``,
        ``"anchor"``: the wall and tether contributions)."""
        return self.field("contact_stress" if kind is None else f"contact_stress_{kind}")

    def save(self, path: str | Path) -> Path:
        """Write the block sums and the grid to a ``.npz`` file (:func:`load_fields`)."""
        path = Path(path)
        c = self.coordinates
        meta = {"system": type(c).__name__, "kernel": type(self.kernel).__name__}
        extra = {}
        if isinstance(c, Cylindrical):
            extra = {"origin": c.origin, "axis": c.axis}
        elif isinstance(c, Polar):
            extra = {"centre": c.centre}
        kernel_params = {k: getattr(self.kernel, k) for k in ("width", "cutoff", "line_points")
                         if k in getattr(type(self.kernel), "__dataclass_fields__", {})}
        np.savez_compressed(
            path, **{f"sum_{k}": v for k, v in self.block_sums.items()},
            **{f"edges_{a}": e for a, e in enumerate(c.edges)}, **extra,
            block_frames=self.block_frames, time=np.asarray(self.time),
            meta=np.asarray([meta["system"], meta["kernel"]]),
            kernel_params=np.asarray([kernel_params.get(k, np.nan)
                                      for k in ("width", "cutoff", "line_points")]))
        return path


#: Names accepted by :meth:`CGFields.field`.
FIELDS = ("number_density", "mass_density", "packing_fraction", "momentum", "velocity",
          "kinetic_stress", "contact_stress", "stress", "pressure", "temperature",
          "temperature_components", "strain_rate",
          *(f"contact_stress_{k}" for k in CONTACT_KINDS))


def _derived(name: str, s: dict[str, np.ndarray], coords: Coordinates) -> np.ndarray:
    shape = coords.shape
    dim = coords.dim
    if name not in FIELDS:
        raise ValueError(f"field: unknown name {name!r}; choose one of {', '.join(FIELDS)}")
    with np.errstate(invalid="ignore", divide="ignore"):
        if name == "number_density":
            out = s["number"]
        elif name == "mass_density":
            out = s["mass"]
        elif name == "packing_fraction":
            out = s["volume"]
        elif name == "momentum":
            out = s["momentum"]
        elif name == "velocity":
            out = s["momentum"] / s["mass"][:, None]
        elif name == "kinetic_stress":  # sum m v v - p p / rho; zero where no grain is
            mass = np.where(s["mass"] > 0, s["mass"], np.inf)[:, None, None]
            out = s["mvv"] - s["momentum"][:, :, None] * s["momentum"][:, None, :] / mass
        elif name.startswith("contact_stress_"):
            out = s[f"contact_{name.removeprefix('contact_stress_')}"]
        elif name == "contact_stress":
            out = sum(s[f"contact_{k}"] for k in CONTACT_KINDS)
        elif name == "stress":
            out = (_derived("kinetic_stress", s, coords).reshape(-1, dim, dim)
                   + _derived("contact_stress", s, coords).reshape(-1, dim, dim))
        elif name == "pressure":
            out = np.trace(_derived("stress", s, coords).reshape(-1, dim, dim), axis1=1,
                           axis2=2) / dim
        elif name == "temperature_components":
            k = _derived("kinetic_stress", s, coords).reshape(-1, dim, dim)
            out = np.diagonal(k, axis1=1, axis2=2) / s["number"][:, None]
        elif name == "temperature":
            out = _derived("temperature_components", s, coords).reshape(-1, dim).mean(axis=1)
        else:  # strain_rate
            return strain_rate(_derived("velocity", s, coords), coords)
    tail = out.shape[1:] if out.ndim > 1 else ()
    return np.asarray(out).reshape(shape + tail)


def strain_rate(velocity: np.ndarray, coords: Coordinates,
                across: Mapping[int, np.ndarray] | None = None) -> np.ndarray:
    """D_ab = (d_a V_b + d_b V_a)/2 of a velocity field on the grid (shape + (D,)), by second-
    order finite differences (``numpy.gradient``) along resolved coordinates. Along an averaged
    coordinate ``c`` the derivative is ``across[c]`` (dV/dx_c in that coordinate's units, the
    field's shape + (D,); :func:`slab_gradient` measures it from the two halves of a thin
    slab) and zero where none is given (a homogeneous direction). Cylindrical (r, theta, z)
    and polar (r, theta) components carry the curvature terms of an axisymmetric (theta-averaged) field::

        D_thth = V_r / r,  D_rth = (dV_th/dr - V_th / r) / 2            (+ (1/r) dV_r/dth / 2,
                                                                          D_thth += (1/r) dV_th/dth
                                                                          when theta is resolved)
    """
    dim = coords.dim
    resolved = coords.resolved
    centres = coords.centres
    grad = np.zeros(velocity.shape + (dim,))  # grad[..., b, a] = d_a V_b in coordinates

    across = {} if across is None else dict(across)
    for coord, gradient in across.items():
        if coord in resolved or not 0 <= coord < len(coords.edges):
            raise ValueError(f"across: keys are averaged coordinates of the grid "
                             f"({[c for c in range(len(coords.edges)) if c not in resolved]}), "
                             f"got {coord}")
        if np.shape(gradient) != velocity.shape:
            raise ValueError(f"across[{coord}]: dV/dx of shape {velocity.shape}, got "
                             f"{np.shape(gradient)}")

    def d(values: np.ndarray, coord: int, component: int) -> np.ndarray:
        if coord in across:
            return np.asarray(across[coord], dtype=float)[..., component]
        if coord not in resolved:
            return np.zeros_like(values)
        axis = resolved.index(coord)
        if values.shape[axis] < 2:
            return np.zeros_like(values)
        return np.gradient(values, centres[axis], axis=axis, edge_order=1 if
                           values.shape[axis] < 3 else 2)

    if isinstance(coords, Cartesian):
        for b in range(dim):
            for a in range(dim):
                grad[..., b, a] = d(velocity[..., b], a, b)
        return 0.5 * (grad + np.swapaxes(grad, -1, -2))
    r = _radius_field(coords)
    v_r, v_t = velocity[..., 0], velocity[..., 1]
    out = np.zeros(velocity.shape + (dim,))
    with np.errstate(invalid="ignore", divide="ignore"):
        out[..., 0, 0] = d(v_r, 0, 0)
        out[..., 1, 1] = v_r / r
        out[..., 0, 1] = 0.5 * (d(v_t, 0, 1) - v_t / r)
        if isinstance(coords, Polar):
            out[..., 1, 1] += d(v_t, 1, 1) / r
            out[..., 0, 1] += 0.5 * d(v_r, 1, 0) / r
        else:
            v_z = velocity[..., 2]
            out[..., 2, 2] = d(v_z, 1, 2)
            out[..., 0, 2] = 0.5 * (d(v_r, 1, 0) + d(v_z, 0, 2))
            out[..., 1, 2] = 0.5 * d(v_t, 1, 1)
    out[..., 1, 0] = out[..., 0, 1]
    if dim == 3:
        out[..., 2, 0] = out[..., 0, 2]
        out[..., 2, 1] = out[..., 1, 2]
    return out


def _radius_field(coords: Cylindrical | Polar) -> np.ndarray:
    r_edges = coords.edges[0]
    r = 0.5 * (r_edges[1:] + r_edges[:-1])
    if r_edges.size == 2:
        return np.full(coords.shape, r[0])
    shape = [1] * len(coords.shape)
    shape[0] = r.size
    return np.broadcast_to(r.reshape(shape), coords.shape)


def _with_edges(coords: Coordinates, coord: int, edges: Sequence[float]) -> Coordinates:
    """The same grid with coordinate ``coord``'s bin edges replaced."""
    all_edges = [edges if c == coord else e for c, e in enumerate(coords.edges)]
    if isinstance(coords, Cylindrical):
        return Cylindrical(*all_edges, origin=coords.origin, axis=coords.axis)
    if isinstance(coords, Polar):
        return Polar(*all_edges, centre=coords.centre)
    return Cartesian(all_edges)


def slab_gradient(frames: Iterable[Frame], coordinates: Coordinates, coordinate: int,
                  kernel: Kernel | None = None, *, window: tuple[float, float] | None = None,
                  types: Sequence[int] | None = None) -> np.ndarray:
    """dV/dx_c across a slab the grid averages over: the mean velocities of its two halves
    along coordinate ``c`` (``coordinate``, an averaged one), differenced over their centres'
    spacing, half the slab's thickness. This is seed 002's half-layer scheme for dv_r/dz in a
    layer of one cell (Sec. 5.3.3, "On the strain rate"); pass the result to
    :func:`strain_rate` as ``across={c: gradient}``. Each half is coarse-grained with
    ``kernel`` like the slab itself, in one pass over the frames; shape ``coordinates.shape +
    (D,)``, in the grid's components, NaN where either half saw no grain."""
    edges = coordinates.edges
    if not 0 <= coordinate < len(edges) or coordinate in coordinates.resolved:
        averaged = [c for c in range(len(edges)) if c not in coordinates.resolved]
        raise ValueError(f"coordinate: one of the grid's averaged coordinates {averaged} (a "
                         f"slab one bin thick), got {coordinate!r}")
    lo, hi = edges[coordinate]
    mid = 0.5 * (lo + hi)
    lower, upper = coarse_grain_grids(
        frames, [_with_edges(coordinates, coordinate, [lo, mid]),
                 _with_edges(coordinates, coordinate, [mid, hi])],
        kernel, window=window, contacts=False, types=types)
    return (upper.velocity - lower.velocity) / (mid - lo)


def coarse_grain(frames: Iterable[Frame], coordinates: Coordinates, kernel: Kernel | None = None,
                 *, window: tuple[float, float] | None = None, blocks: int = 1,
                 contacts: bool = True, types: Sequence[int] | None = None) -> CGFields:
    """Time-averaged fields of the frames whose time lies in ``window`` (all when None).

    Parameters
    ----------
    frames : saved frames (a list, or a generator such as :func:`grainflow.io.h5md.read_frames`
        or :func:`grainflow.io.lammps_local.frames_from_lammps`); read once, in order.
    coordinates : :class:`Cartesian`, :class:`Cylindrical` or :class:`Polar` grid.
    kernel : :class:`Heaviside` (default), :class:`Gaussian` or :class:`Lucy`.
    window : (t_start, t_end), inclusive.
    blocks : number of consecutive groups of frames for error bars (>= 1; at most the
        number of frames).
    contacts : include the contact stress (frames must carry their contact listing).
    types : the particle types that are the flow (all when None); the others (walls made of
        particles) are left out of the densities, velocity and kinetic stress, while their
        contacts with the flow stay in its contact stress (:func:`select_types`).
    """
    return coarse_grain_grids(frames, [coordinates], kernel, window=window, blocks=blocks,
                              contacts=contacts, types=types)[0]


def coarse_grain_grids(frames: Iterable[Frame], grids: Sequence[Coordinates],
                       kernel: Kernel | None = None, *,
                       window: tuple[float, float] | None = None, blocks: int = 1,
                       contacts: bool | Sequence[bool] = True,
                       types: Sequence[int] | None = None) -> list[CGFields]:
    """:func:`coarse_grain` on several grids in one pass over the frames (a generator is
    read once): one :class:`CGFields` per grid, with the same window, blocks and types.
    ``contacts``: one flag for all grids, or one per grid."""
    kernel = Heaviside() if kernel is None else kernel
    if not isinstance(kernel, (Heaviside, Gaussian, Lucy)):
        raise ValueError(f"kernel: expected Heaviside(), Gaussian(width) or Lucy(cutoff), "
                         f"got {kernel!r}")
    for coordinates in grids:
        if not isinstance(coordinates, (Cartesian, Cylindrical, Polar)):
            raise ValueError(f"coordinates: expected Cartesian, Cylindrical or Polar, got "
                             f"{coordinates!r}")
    flags = [contacts] * len(grids) if isinstance(contacts, bool) else list(contacts)
    if len(flags) != len(grids):
        raise ValueError(f"contacts: one flag or one per grid ({len(grids)}), got {contacts!r}")
    if not isinstance(blocks, int) or blocks < 1:
        raise ValueError(f"blocks: a positive integer, got {blocks!r}")
    if window is not None and not (len(window) == 2 and window[0] <= window[1]):
        raise ValueError(f"window: (t_start, t_end) with t_start <= t_end, got {window!r}")
    per_frame: list[list[dict[str, np.ndarray]]] = [[] for _ in grids]
    times: list[float] = []
    for frame in frames:
        if window is not None and not window[0] <= frame.time <= window[1]:
            continue
        if types is not None:
            frame = select_types(frame, types)
        for store, coordinates, with_contacts in zip(per_frame, grids, flags):
            store.append(frame_sums(frame, coordinates, kernel, contacts=with_contacts))
        times.append(float(frame.time))
    if not times:
        raise ValueError("frames: no frame lies in the window" if window is not None
                         else "frames: no frames given")
    if blocks > len(times):
        raise ValueError(f"blocks: {blocks} blocks need at least as many frames; the window "
                         f"holds {len(times)}")
    bounds = np.linspace(0, len(times), blocks + 1).round().astype(int)
    out = []
    for coordinates, store in zip(grids, per_frame):
        block_sums = {k: np.stack([sum(f[k] for f in store[a:b])
                                   for a, b in zip(bounds[:-1], bounds[1:])])
                      for k in store[0]}
        out.append(CGFields(coordinates=coordinates, kernel=kernel, n_frames=len(times),
                            time=(times[0], times[-1]), block_sums=block_sums,
                            block_frames=np.diff(bounds).astype(float)))
    return out


def combine(*fields: CGFields) -> CGFields:
    """Pool replicas (e.g. the seed's ten configurations) on the same grid: every block of
    every replica becomes a block of the result, so errors measure the replica spread."""
    if not fields:
        raise ValueError("fields: give at least one CGFields")
    first = fields[0]
    for f in fields[1:]:
        same = (type(f.coordinates) is type(first.coordinates)
                and all(np.array_equal(a, b) for a, b in zip(f.coordinates.edges,
                                                            first.coordinates.edges)))
        if not same or f.kernel != first.kernel:
            raise ValueError("fields: replicas must share coordinates and kernel")
    return CGFields(coordinates=first.coordinates, kernel=first.kernel,
                    n_frames=sum(f.n_frames for f in fields),
                    time=(min(f.time[0] for f in fields), max(f.time[1] for f in fields)),
                    block_sums={k: np.concatenate([f.block_sums[k] for f in fields])
                                for k in first.block_sums},
                    block_frames=np.concatenate([f.block_frames for f in fields]))


def load_fields(path: str | Path) -> CGFields:
    """Read fields written by :meth:`CGFields.save`."""
    with np.load(Path(path), allow_pickle=False) as data:
        system, kernel_name = (str(x) for x in data["meta"])
        edges = [data[f"edges_{a}"] for a in range(3) if f"edges_{a}" in data]
        if system == "Cartesian":
            coords: Coordinates = Cartesian(edges)
        elif system == "Cylindrical":
            coords = Cylindrical(edges[0], edges[1], origin=data["origin"], axis=data["axis"])
        elif system == "Polar":
            coords = Polar(edges[0], edges[1], centre=data["centre"])
        else:
            raise ValueError(f"{path}: unknown coordinate system {system!r}")
        width, cutoff, line_points = (float(x) for x in data["kernel_params"])
        kernel: Kernel
        if kernel_name == "Gaussian":
            kernel = Gaussian(width, cutoff, int(line_points))
        elif kernel_name == "Lucy":
            kernel = Lucy(cutoff, int(line_points))
        else:
            kernel = Heaviside()
        sums = {k.removeprefix("sum_"): data[k] for k in data.files if k.startswith("sum_")}
        block_frames = data["block_frames"]
        time = tuple(float(t) for t in data["time"])
    return CGFields(coordinates=coords, kernel=kernel, n_frames=int(block_frames.sum()),
                    time=time, block_sums=sums, block_frames=block_frames)
