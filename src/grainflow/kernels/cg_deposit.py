"""Compiled deposition kernels of the coarse-graining library (:mod:`grainflow.analysis.cg`).

Two jobs, both "spread per-item values onto a grid of cells":

* :func:`deposit_smooth_lines`: each line (a branch line's quadrature points, or a single
  grain) carries a row of values and points in *kernel space* (the k <= 3 coordinates the
  kernel acts on); it adds ``sum_p w_p W(|q_cell - q_p|) * values`` to every cell centre
  within the kernel's reach. The sample grid is a tensor product of one-dimensional centre
  arrays, so the cells in reach are a box of indices.
* :func:`deposit_segments`: Heaviside cells and branch lines: each segment from ``a`` to ``b``
  adds ``values * (length fraction of the segment inside the cell)`` to every cell it crosses
  (the A of seed 002 Appendix C, eq. C.29, computed exactly: the segment is cut at every
  cell-boundary crossing and each piece is given to the cell holding its midpoint).

Determinism: the items are cut into a fixed number of chunks (not one per thread), each chunk
sums into its own buffer in item order, and the buffers are added in chunk order, so results
are bitwise the same on any number of threads.

Coordinate-system codes for :func:`deposit_segments` (kinds of cell boundaries):
:data:`CARTESIAN` (planes ``x_a = e``), :data:`CYLINDRICAL` (cylinders ``r = e`` about the
local z axis, planes ``z = e``), :data:`POLAR` (circles ``r = e``, rays ``theta = e``).
Segments arrive in the system's local Cartesian frame (origin on the axis / centre).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

#: Kernel codes for :func:`kernel_weight`.
GAUSSIAN, LUCY = 0, 1
#: Coordinate-system codes for :func:`deposit_segments`.
CARTESIAN, CYLINDRICAL, POLAR = 0, 1, 2
#: Number of chunks (independent of the thread count; see the module docstring).
N_CHUNKS = 16
_MAX_CROSSINGS = 256


@njit(cache=True, inline="always")
def kernel_weight(kind: int, r2: float, width: float, cutoff: float, norm: float) -> float:
    """``W(r)`` at squared distance ``r2`` (0 beyond the cutoff); ``norm`` makes it integrate
    to one in its dimension (computed by the caller).

    Gaussian: ``norm * exp(-r^2 / (2 w^2))`` for ``r <= cutoff``; Lucy:
    ``norm * (1 + 3 r/c)(1 - r/c)^3`` for ``r <= c`` with ``c = cutoff``.
    """
    if r2 > cutoff * cutoff:
        return 0.0
    if kind == GAUSSIAN:
        return norm * math.exp(-0.5 * r2 / (width * width))
    s = math.sqrt(r2) / cutoff
    return norm * (1.0 + 3.0 * s) * (1.0 - s) ** 3


@njit(cache=True, parallel=True)
def deposit_smooth_points(q, values, sample, kind, width, cutoff, norm, out):
    """Like :func:`deposit_smooth` for an explicit list of sample points ``sample`` (P, k)
    (grids that are not tensor products in kernel space, e.g. polar cells); brute force."""
    n = q.shape[0]
    n_values = values.shape[1]
    chunk = (n + N_CHUNKS - 1) // N_CHUNKS
    buffers = np.zeros((N_CHUNKS, sample.shape[0], n_values))
    for c in prange(N_CHUNKS):
        for i in range(c * chunk, min(n, (c + 1) * chunk)):
            for p in range(sample.shape[0]):
                r2 = 0.0
                for a in range(q.shape[1]):
                    r2 += (sample[p, a] - q[i, a]) ** 2
                w = kernel_weight(kind, r2, width, cutoff, norm)
                if w == 0.0:
                    continue
                for v in range(n_values):
                    buffers[c, p, v] += w * values[i, v]
    for c in range(N_CHUNKS):
        out += buffers[c]


@njit(cache=True, inline="always")
def _search(arr, first, n, value, right):
    """``np.searchsorted(arr[first:first + n], value, side)`` without making the slice (a
    view made inside a parallel loop costs an atomic reference count shared by the threads)."""
    lo = 0
    hi = n
    while lo < hi:
        mid = (lo + hi) // 2
        if arr[first + mid] < value or (right and arr[first + mid] == value):
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, inline="always")
def _bin(edges, first, n_edges, value):
    """Bin of ``value`` among ``edges[first:first + n_edges]`` (lower edge inclusive), -1
    outside."""
    if value < edges[first] or value >= edges[first + n_edges - 1]:
        return -1
    return _search(edges, first, n_edges, value, True) - 1


@njit(cache=True)
def _add_plane_crossings(p0, p1, edges, first, n_edges, period, lam, n_lam):
    """Parameters in (0, 1) where ``p0 + t (p1 - p0)`` crosses a plane ``x = e`` (one axis),
    ``e`` in ``edges[first:first + n_edges]``; with ``period`` > 0 the edges repeat."""
    d = p1 - p0
    if d == 0.0:
        return n_lam
    lo = min(p0, p1)
    hi = max(p0, p1)
    shifts = 1 if period <= 0.0 else 3
    for s in range(shifts):
        shift = 0.0 if period <= 0.0 else (s - 1) * period
        for k in range(n_edges):
            x = edges[first + k] + shift
            if lo < x < hi and n_lam < lam.shape[0]:
                lam[n_lam] = (x - p0) / d
                n_lam += 1
    return n_lam


@njit(cache=True)
def _add_circle_crossings(px, py, dx, dy, edges, first, n_edges, lam, n_lam):
    """Parameters in (0, 1) where the 2D line ``p + t d`` crosses a circle ``|x| = r``."""
    a = dx * dx + dy * dy
    if a == 0.0:
        return n_lam
    b = 2.0 * (px * dx + py * dy)
    c0 = px * px + py * py
    for k in range(n_edges):
        r = edges[first + k]
        disc = b * b - 4.0 * a * (c0 - r * r)
        if disc <= 0.0:
            continue
        root = math.sqrt(disc)
        for t in ((-b - root) / (2.0 * a), (-b + root) / (2.0 * a)):
            if 0.0 < t < 1.0 and n_lam < lam.shape[0]:
                lam[n_lam] = t
                n_lam += 1
    return n_lam


@njit(cache=True)
def _add_ray_crossings(px, py, dx, dy, edges, first, n_edges, lam, n_lam):
    """Parameters in (0, 1) where the 2D line ``p + t d`` crosses a ray at angle ``theta``."""
    for k in range(n_edges):
        theta = edges[first + k]
        ux = math.cos(theta)
        uy = math.sin(theta)
        denom = ux * dy - uy * dx
        if denom == 0.0:
            continue
        t = -(ux * py - uy * px) / denom
        if 0.0 < t < 1.0 and ux * (px + t * dx) + uy * (py + t * dy) > 0.0 \
                and n_lam < lam.shape[0]:
            lam[n_lam] = t
            n_lam += 1
    return n_lam


@njit(cache=True)
def cell_at(system, x0, x1, x2, edges, offsets, counts, periods, theta0):
    """Flat cell index (C order over the system's coordinates) of the local point (x0, x1,
    x2), -1 outside the grid. Cartesian: coordinates x, y(, z) with periodic wrapping where
    ``periods[a] > 0``; cylindrical: (r, z); polar: (r, theta) with theta in
    ``[theta0, theta0 + 2 pi)``."""
    n_axes = counts.shape[0]
    if system == CARTESIAN:
        c0, c1, c2 = x0, x1, x2
        if periods[0] > 0.0:
            c0 = edges[offsets[0]] + (x0 - edges[offsets[0]]) % periods[0]
        if periods[1] > 0.0:
            c1 = edges[offsets[1]] + (x1 - edges[offsets[1]]) % periods[1]
        if n_axes > 2 and periods[2] > 0.0:
            c2 = edges[offsets[2]] + (x2 - edges[offsets[2]]) % periods[2]
    elif system == CYLINDRICAL:
        c0 = math.sqrt(x0 * x0 + x1 * x1)
        c1 = x2
        c2 = 0.0
    else:
        c0 = math.sqrt(x0 * x0 + x1 * x1)
        c1 = theta0 + (math.atan2(x1, x0) - theta0) % (2.0 * math.pi)
        c2 = 0.0
    cell = 0
    for a in range(n_axes):
        value = c0 if a == 0 else (c1 if a == 1 else c2)
        b = _bin(edges, offsets[a], counts[a] + 1, value)
        if b < 0:
            return -1
        cell = cell * counts[a] + b
    return cell


@njit(cache=True)
def _crossings(system, m, start, end, edges, offsets, counts, periods, lam):
    """Sorted crossing parameters of segment ``m`` with every cell boundary, framed by 0 and
    1; returns how many entries of ``lam`` are used."""
    lam[0] = 0.0
    n_lam = 1
    if system == CARTESIAN:
        for a in range(counts.shape[0]):
            n_lam = _add_plane_crossings(start[m, a], end[m, a], edges, offsets[a],
                                         counts[a] + 1, periods[a], lam, n_lam)
    else:
        px = start[m, 0]
        py = start[m, 1]
        dx = end[m, 0] - px
        dy = end[m, 1] - py
        n_lam = _add_circle_crossings(px, py, dx, dy, edges, offsets[0], counts[0] + 1, lam,
                                      n_lam)
        if system == CYLINDRICAL:
            n_lam = _add_plane_crossings(start[m, 2], end[m, 2], edges, offsets[1],
                                         counts[1] + 1, 0.0, lam, n_lam)
        else:
            n_lam = _add_ray_crossings(px, py, dx, dy, edges, offsets[1], counts[1] + 1, lam,
                                       n_lam)
    lam[n_lam] = 1.0
    n_lam += 1
    for i in range(2, n_lam - 1):  # insertion sort: a handful of crossings, no temporaries
        value = lam[i]
        j = i - 1
        while lam[j] > value:
            lam[j + 1] = lam[j]
            j -= 1
        lam[j + 1] = value
    return n_lam


@njit(cache=True, parallel=True)
def deposit_segments(system, start, end, values, rotate, edges, offsets, counts, periods,
                     theta0, out):
    """Add ``values[m] * A_cell(m)`` to every cell the segment ``start[m] -> end[m]`` crosses,
    A the fraction of its length inside the cell (seed 002 eq. C.29, exact).

    ``values`` (M, dim, dim) tensors in the local Cartesian frame; with ``rotate`` true each
    piece's tensor is turned into the (r, theta[, z]) basis at the piece's midpoint before it
    is added (cylindrical and polar systems). ``out`` (cells, dim, dim).
    """
    m_total = start.shape[0]
    dim = start.shape[1]
    n_cells = out.shape[0]
    chunk = (m_total + N_CHUNKS - 1) // N_CHUNKS
    buffers = np.zeros((N_CHUNKS, n_cells, dim, dim))
    for c in prange(N_CHUNKS):
        lam = np.empty(_MAX_CROSSINGS)
        mid = np.zeros(3)
        basis = np.zeros((dim, dim))
        rotated = np.zeros((dim, dim))
        for m in range(c * chunk, min(m_total, (c + 1) * chunk)):
            n_lam = _crossings(system, m, start, end, edges, offsets, counts, periods, lam)
            for s in range(n_lam - 1):
                piece = lam[s + 1] - lam[s]
                if piece <= 0.0:
                    continue
                t = 0.5 * (lam[s] + lam[s + 1])
                for a in range(dim):
                    mid[a] = start[m, a] + t * (end[m, a] - start[m, a])
                cell = cell_at(system, mid[0], mid[1], mid[2], edges, offsets, counts,
                               periods, theta0)
                if cell < 0:
                    continue
                if rotate:
                    radial_basis(mid, basis)
                    rotate_tensor(basis, values, m, rotated)
                    for a in range(dim):
                        for b in range(dim):
                            buffers[c, cell, a, b] += piece * rotated[a, b]
                else:
                    for a in range(dim):
                        for b in range(dim):
                            buffers[c, cell, a, b] += piece * values[m, a, b]
    for c in range(N_CHUNKS):
        out += buffers[c]


@njit(cache=True, parallel=True)
def line_points(start, end, tensors, nodes, weights, points, values):
    """Quadrature points of each branch line and their weighted tensors in the (r, theta[, z])
    basis at the point: point ``p`` of line ``m`` is ``start + nodes[p] (end - start)`` with
    the tensor ``weights[p] * tensors[m]`` turned into that basis (cylindrical and polar
    cells). ``points`` (M, P, dim) and ``values`` (M, P, dim * dim) are filled."""
    m_total, dim = start.shape
    n_points = nodes.shape[0]
    for m in prange(m_total):
        basis = np.zeros((dim, dim))
        rotated = np.zeros((dim, dim))
        x = np.zeros(3)
        for p in range(n_points):
            for a in range(dim):
                x[a] = start[m, a] + nodes[p] * (end[m, a] - start[m, a])
                points[m, p, a] = x[a]
            radial_basis(x, basis)
            rotate_tensor(basis, tensors, m, rotated)
            for a in range(dim):
                for b in range(dim):
                    values[m, p, a * dim + b] = weights[p] * rotated[a, b]


@njit(cache=True, inline="always")
def radial_basis(x, basis):
    """Rows e_r, e_theta(, e_z) at the local point ``x`` (about the local z axis / origin).
    On the axis itself e_r is taken along local x."""
    rho = math.sqrt(x[0] * x[0] + x[1] * x[1])
    cx, sy = (x[0] / rho, x[1] / rho) if rho > 0.0 else (1.0, 0.0)
    basis[0, 0] = cx
    basis[0, 1] = sy
    basis[1, 0] = -sy
    basis[1, 1] = cx
    if basis.shape[0] == 3:
        basis[0, 2] = 0.0
        basis[1, 2] = 0.0
        basis[2, 0] = 0.0
        basis[2, 1] = 0.0
        basis[2, 2] = 1.0


@njit(cache=True, inline="always")
def rotate_tensor(basis, tensors, m, out):
    """``out = basis @ tensors[m] @ basis.T``."""
    dim = basis.shape[0]
    for a in range(dim):
        for b in range(dim):
            s = 0.0
            for p in range(dim):
                for q in range(dim):
                    s += basis[a, p] * tensors[m, p, q] * basis[b, q]
            out[a, b] = s


@njit(cache=True, parallel=True)
def cells_of(system, x, edges, offsets, counts, periods, theta0):
    """:func:`cell_at` for every row of ``x`` (N, dim) in the local frame."""
    out = np.empty(x.shape[0], dtype=np.int64)
    dim = x.shape[1]
    for i in prange(x.shape[0]):
        out[i] = cell_at(system, x[i, 0], x[i, 1], x[i, 2] if dim > 2 else 0.0, edges,
                         offsets, counts, periods, theta0)
    return out


@njit(cache=True)
def _line_box(q, m, a, centres, offsets, counts, cutoff):
    """Index range [lo, hi) along axis ``a`` of the cells within ``cutoff`` of line ``m``."""
    lo_q = q[m, 0, a]
    hi_q = q[m, 0, a]
    for p in range(1, q.shape[1]):
        lo_q = min(lo_q, q[m, p, a])
        hi_q = max(hi_q, q[m, p, a])
    return (_search(centres, offsets[a], counts[a], lo_q - cutoff, False),
            _search(centres, offsets[a], counts[a], hi_q + cutoff, True))


@njit(cache=True)
def line_patch_size(q, centres, offsets, counts, cutoff):
    """The most cells any line's patch in :func:`deposit_smooth_lines` covers."""
    most = 1
    for m in range(q.shape[0]):
        cells = 1
        for a in range(q.shape[2]):
            lo, hi = _line_box(q, m, a, centres, offsets, counts, cutoff)
            cells *= max(hi - lo, 0)
        most = max(most, cells)
    return most


@njit(cache=True, parallel=True)
def deposit_smooth_lines(q, weights, values, centres, offsets, counts, kind, width, cutoff,
                         norm, patch_size, out):
    """Add ``sum_p weights[m, p] W(q_cell - q[m, p]) * values[m]`` into ``out`` (cells,
    n_values), C order over the k axes; ``centres`` holds the k sorted centre arrays
    concatenated, axis a being ``centres[offsets[a]:offsets[a] + counts[a]]``.

    Line ``m`` has points ``q[m, p]`` (kernel space) with quadrature weights
    ``weights[m, p]`` (0 for a point to leave out) sharing the values ``values[m]`` (a grain
    is a line of one point of weight 1). The kernel weights of a line's points are summed on a
    patch of cells first and the values added once per cell, a factor of about the number of
    points per line fewer operations than depositing each point with its own copy of the
    values. For the Gaussian the per-axis factors ``exp(-d_a^2 / 2 w^2)`` are computed once
    per cell row (the kernel separates inside its spherical cutoff). ``patch_size`` must be
    :func:`line_patch_size` (an exception inside the parallel loop would make numba run it
    serially, so the bound is found beforehand)."""
    m_total, n_points, k = q.shape
    n_values = values.shape[1]
    n_cells = out.shape[0]
    chunk = (m_total + N_CHUNKS - 1) // N_CHUNKS
    buffers = np.zeros((N_CHUNKS, n_cells, n_values))
    for c in prange(N_CHUNKS):
        patch = np.zeros(patch_size)
        lo_idx = np.zeros(3, dtype=np.int64)
        hi_idx = np.ones(3, dtype=np.int64)
        size = np.ones(3, dtype=np.int64)
        stride = np.zeros(3, dtype=np.int64)
        dist = np.zeros((3, counts.max()))
        factor = np.ones((3, counts.max()))
        for m in range(c * chunk, min(m_total, (c + 1) * chunk)):
            empty = False
            for a in range(k):
                lo_idx[a], hi_idx[a] = _line_box(q, m, a, centres, offsets, counts, cutoff)
                size[a] = hi_idx[a] - lo_idx[a]
                if size[a] <= 0:
                    empty = True
            if empty:
                continue
            cells = size[0] * size[1] * size[2]  # <= patch_size (line_patch_size)
            for j in range(cells):
                patch[j] = 0.0
            for p in range(n_points):
                wp = weights[m, p]
                if wp == 0.0:
                    continue
                for a in range(k):
                    for j in range(size[a]):
                        d = centres[offsets[a] + lo_idx[a] + j] - q[m, p, a]
                        dist[a, j] = d * d
                        if kind == GAUSSIAN:
                            factor[a, j] = math.exp(-0.5 * d * d / (width * width))
                for j0 in range(size[0]):
                    for j1 in range(size[1]):
                        for j2 in range(size[2]):
                            r2 = dist[0, j0] + dist[1, j1] + dist[2, j2]
                            if r2 > cutoff * cutoff:
                                continue
                            if kind == GAUSSIAN:
                                w = norm * factor[0, j0] * factor[1, j1] * factor[2, j2]
                            else:
                                w = kernel_weight(kind, r2, width, cutoff, norm)
                            patch[(j0 * size[1] + j1) * size[2] + j2] += wp * w
            s = 1
            for a in range(k - 1, -1, -1):
                stride[a] = s
                s *= counts[a]
            for j0 in range(size[0]):
                for j1 in range(size[1]):
                    for j2 in range(size[2]):
                        w = patch[(j0 * size[1] + j1) * size[2] + j2]
                        if w == 0.0:
                            continue
                        cell = ((lo_idx[0] + j0) * stride[0] + (lo_idx[1] + j1) * stride[1]
                                + (lo_idx[2] + j2) * stride[2])
                        for v in range(n_values):
                            buffers[c, cell, v] += w * values[m, v]
    for c in range(N_CHUNKS):
        out += buffers[c]



@njit(cache=True, parallel=True)
def deposit_gaussian_points(q, weights, values, centres, offsets, counts, width, cutoff, norm,
                            out):
    """:func:`deposit_smooth_lines` for lines of one point and the Gaussian kernel: adds
    ``weights[m] W(|q_cell - q[m]|) * values[m]`` into ``out`` (cells, n_values).

    The Gaussian separates, ``W = norm * prod_a exp(-d_a^2 / 2 w^2)``, so a point's values
    times the factors along the last (contiguous) axis form one row of ``n_last * n_values``
    numbers, computed once; every cell row in reach then adds that row times the product of
    the other axes' factors as one contiguous multiply-add, cut to the cells inside the
    spherical cutoff (the same ``r^2 > cutoff^2`` test, summed in the same axis order, as
    :func:`deposit_smooth_lines`, so exactly the same cells). Grains on every grid and the
    rotated branch-line points of cylindrical and polar cells are such lines."""
    m_total, k = q.shape
    n_values = values.shape[1]
    n_cells = out.shape[0]
    last = k - 1
    cut2 = cutoff * cutoff
    stride = np.zeros(3, dtype=np.int64)
    s = 1
    for a in range(k - 1, -1, -1):
        stride[a] = s
        s *= counts[a]
    widest = counts.max()
    chunk = (m_total + N_CHUNKS - 1) // N_CHUNKS
    buffers = np.zeros((N_CHUNKS, n_cells * n_values))
    for c in prange(N_CHUNKS):
        buffer = buffers[c]
        lo_idx = np.zeros(3, dtype=np.int64)
        size = np.ones(3, dtype=np.int64)
        dist = np.zeros((3, widest))
        factor = np.ones((3, widest))
        row = np.zeros(widest * n_values)
        for m in range(c * chunk, min(m_total, (c + 1) * chunk)):
            wp = weights[m]
            if wp == 0.0:
                continue
            empty = False
            for a in range(k):
                lo_idx[a] = _search(centres, offsets[a], counts[a], q[m, a] - cutoff, False)
                size[a] = _search(centres, offsets[a], counts[a], q[m, a] + cutoff,
                                  True) - lo_idx[a]
                if size[a] <= 0:
                    empty = True
            if empty:
                continue
            for a in range(k):
                for j in range(size[a]):
                    d = centres[offsets[a] + lo_idx[a] + j] - q[m, a]
                    dist[a, j] = d * d
                    factor[a, j] = math.exp(-0.5 * d * d / (width * width))
            for j in range(size[last]):
                f = wp * norm * factor[last, j]
                for v in range(n_values):
                    row[j * n_values + v] = f * values[m, v]
            n_outer = 1
            for a in range(last):
                n_outer *= size[a]
            for o in range(n_outer):
                # the cell row's outer indices (C order) and its part of r^2, summed in
                # deposit_smooth_lines' order: (d0 + d1) + d_last
                outer_d2 = 0.0
                outer_f = 1.0
                cell = lo_idx[last] * stride[last]
                if k == 2:
                    outer_d2 = dist[0, o]
                    outer_f = factor[0, o]
                    cell += (lo_idx[0] + o) * stride[0]
                elif k == 3:
                    j0 = o // size[1]
                    j1 = o - j0 * size[1]
                    outer_d2 = dist[0, j0] + dist[1, j1]
                    outer_f = factor[0, j0] * factor[1, j1]
                    cell += (lo_idx[0] + j0) * stride[0] + (lo_idx[1] + j1) * stride[1]
                first = 0
                while first < size[last] and outer_d2 + dist[last, first] > cut2:
                    first += 1
                end = size[last]
                while end > first and outer_d2 + dist[last, end - 1] > cut2:
                    end -= 1
                # unsigned indices: numba wraps a negative signed index at every access,
                # which keeps this multiply-add from being vectorized
                base = np.uint64(cell * n_values)
                for t in range(np.uint64(first * n_values), np.uint64(end * n_values)):
                    buffer[base + t] += outer_f * row[t]
    for c in range(N_CHUNKS):
        out += buffers[c].reshape(n_cells, n_values)
