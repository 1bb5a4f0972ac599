"""Shape forces of 2D deformable rings (SPEC M6; seed 003 eq. 8 in the normalisation of the
authors' code, docs/dp.md): compiled kernels.

For a ring of vertices ``r_0 .. r_{N-1}`` (counter-clockwise), edges ``l_i = r_{i+1} - r_i``
and bends ``b_i = l_i - l_{i-1} = r_{i+1} - 2 r_i + r_{i-1}`` (indices mod N), preferred
area ``a0`` and edge ``l0``:

.. math::

    U = \\frac{k_a}{2 a_0}(a - a_0)^2 + \\frac{k_l N}{2}\\sum_i (|l_i| - l_0)^2
        + \\frac{k_b a_0^2}{2 \\pi N l_0^4}\\sum_i |b_i|^2,
    \\qquad a = \\tfrac12 \\sum_i (x_i y_{i+1} - x_{i+1} y_i),

and the force on vertex ``j``:

.. math::

    F_j = -\\frac{k_a}{a_0}(a - a_0)\\,\\tfrac12 (y_{j+1} - y_{j-1},\\; x_{j-1} - x_{j+1})
          - k_l N \\left[(|l_{j-1}| - l_0)\\hat l_{j-1} - (|l_j| - l_0)\\hat l_j\\right]
          - \\frac{k_b a_0^2}{\\pi N l_0^4}(b_{j-1} - 2 b_j + b_{j+1}).

Each ring is one iteration of a parallel loop and writes only its own vertices, always in the
same order: forces are bitwise the same for any thread count. Edge vectors take the minimum
image on periodic axes, so a ring may straddle a periodic boundary.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from grainflow.kernels.neighbors import minimum_image


@njit(cache=True, inline="always")
def _edge(x, i, j, box_len, periodic):
    """Minimum-image vector ``x_j - x_i`` (2D)."""
    return (minimum_image(x[j, 0] - x[i, 0], box_len[0], periodic[0]),
            minimum_image(x[j, 1] - x[i, 1], box_len[1], periodic[1]))


@njit(cache=True, inline="always")
def _bending(kb, a0, l0, n):
    """The bending coefficient ``k_b a0^2 / (pi N l0^4)``."""
    return kb * a0 * a0 / (np.pi * n * l0**4)


@njit(cache=True)
def _ring_edges(x, ring, box_len, periodic, ex, ey):
    """Edge vectors of one ring into ``ex``, ``ey``; returns the ring's area, computed from
    the positions relative to vertex 0 rebuilt from the edges (translation invariant)."""
    n = ring.shape[0]
    for s in range(n):
        # unsigned vertex indices: numba wraps a negative signed index at every access
        nxt = s + 1 if s + 1 < n else 0
        ex[s], ey[s] = _edge(x, np.uint64(ring[s]), np.uint64(ring[nxt]), box_len, periodic)
    area = 0.0
    px = 0.0
    py = 0.0
    for s in range(n):
        qx = px + ex[s]
        qy = py + ey[s]
        area += px * qy - qx * py
        px = qx
        py = qy
    return 0.5 * area


@njit(cache=True, parallel=True)
def shape_forces(index, a0, l0, ka, kl, kb, x, frozen, box_len, periodic, force):
    """Add the shape force of every ring ``index[r]`` (vertex indices in ring order) with
    preferred area ``a0[r]`` and edge length ``l0[r]`` to ``force``. One pass over a ring's
    edges stores each edge, its spring coefficient ``k_l N (|l| - l0)/|l|`` (one square root
    and one division per edge) and the area (as :func:`_ring_edges` sums it); a second adds
    the forces vertex by vertex. The first pass repeats :func:`_ring_edges` inline: calling it
    from this parallel loop made the kernel 2.7x slower (0.48 against 0.18 ms for 1600 rings
    on one thread), though the forces are bitwise the same."""
    n_rings, n = index.shape
    spring = kl * n
    for r in prange(n_rings):
        ring = index[r]
        ex = np.empty(n)
        ey = np.empty(n)
        coef = np.empty(n)
        area = 0.0
        px = 0.0
        py = 0.0
        for s in range(n):
            # unsigned vertex indices: numba wraps a negative signed index at every access
            nxt = s + 1 if s + 1 < n else 0
            lx, ly = _edge(x, np.uint64(ring[s]), np.uint64(ring[nxt]), box_len, periodic)
            ex[s] = lx
            ey[s] = ly
            qx = px + lx
            qy = py + ly
            area += px * qy - qx * py
            px = qx
            py = qy
            length = np.sqrt(lx ** 2 + ly ** 2)
            coef[s] = spring * (length - l0[r]) / length
        da = ka / a0[r] * (0.5 * area - a0[r])
        bend = _bending(kb, a0[r], l0[r], n)
        for s in range(n):
            p = s - 1 if s > 0 else n - 1  # previous edge / vertex
            q = s + 1 if s + 1 < n else 0  # next edge / vertex
            # area: d a / d r_s = (1/2)(y_{s+1} - y_{s-1}, x_{s-1} - x_{s+1})
            fx = -da * 0.5 * (ey[p] + ey[s])
            fy = da * 0.5 * (ex[p] + ex[s])
            # perimeter springs of edges s-1 (ends at s) and s (starts at s)
            fx += -coef[p] * ex[p] + coef[s] * ex[s]
            fy += -coef[p] * ey[p] + coef[s] * ey[s]
            # bending: b_k = l_k - l_{k-1}; F_s = -c (b_{s-1} - 2 b_s + b_{s+1})
            pp = p - 1 if p > 0 else n - 1
            bx = (ex[p] - ex[pp]) - 2.0 * (ex[s] - ex[p]) + (ex[q] - ex[s])
            by = (ey[p] - ey[pp]) - 2.0 * (ey[s] - ey[p]) + (ey[q] - ey[s])
            fx -= bend * bx
            fy -= bend * by
            i = np.uint64(ring[s])
            if not frozen[i]:
                force[i, 0] += fx
                force[i, 1] += fy


@njit(cache=True)
def shape_energy(index, a0, l0, ka, kl, kb, x, box_len, periodic):
    """Total shape energy ``U`` of the rings (the equation of the module docstring)."""
    n_rings, n = index.shape
    ex = np.empty(n)
    ey = np.empty(n)
    total = 0.0
    for r in range(n_rings):
        area = _ring_edges(x, index[r], box_len, periodic, ex, ey)
        u_l = 0.0
        u_b = 0.0
        for s in range(n):
            p = (s - 1) % n
            u_l += (np.sqrt(ex[s] ** 2 + ey[s] ** 2) - l0[r]) ** 2
            u_b += (ex[s] - ex[p]) ** 2 + (ey[s] - ey[p]) ** 2
        total += (0.5 * ka / a0[r] * (area - a0[r]) ** 2 + 0.5 * kl * n * u_l
                  + 0.5 * _bending(kb, a0[r], l0[r], n) * u_b)
    return total


@njit(cache=True)
def ring_areas(index, x, box_len, periodic):
    """Area of every ring (R,)."""
    n_rings, n = index.shape
    ex = np.empty(n)
    ey = np.empty(n)
    out = np.empty(n_rings)
    for r in range(n_rings):
        out[r] = _ring_edges(x, index[r], box_len, periodic, ex, ey)
    return out


@njit(cache=True)
def ring_centres(index, x, v, radius):
    """Per ring: centroid (mean of its vertices), mean vertex velocity, and outer radius (the
    largest vertex distance from the centroid plus the largest vertex contact radius), in one
    pass; positions are taken as they are (no periodic images: for hopper rings)."""
    n_rings, n = index.shape
    centre = np.zeros((n_rings, 3))
    velocity = np.zeros((n_rings, 3))
    outer = np.zeros(n_rings)
    for r in range(n_rings):
        for s in range(n):
            i = index[r, s]
            for c in range(3):
                centre[r, c] += x[i, c]
                velocity[r, c] += v[i, c]
        for c in range(3):
            centre[r, c] /= n
            velocity[r, c] /= n
        spread = 0.0
        contact = 0.0
        for s in range(n):
            i = index[r, s]
            d2 = 0.0
            for c in range(3):
                d2 += (x[i, c] - centre[r, c]) ** 2
            spread = max(spread, d2)
            contact = max(contact, radius[i])
        outer[r] = np.sqrt(spread) + contact
    return centre, velocity, outer
