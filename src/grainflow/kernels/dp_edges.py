"""Smooth contacts between 2D deformable rings (SPEC M6; seed 003 Appendix A, eq. 9, 12):
compiled kernels.

Every ring is a closed polygon of vertex particles (:mod:`grainflow.rings`); ``nxt[i]`` and
``prv[i]`` are the next and previous vertex of particle ``i`` in its ring (-1 for a particle
in no ring). A vertex ``p`` of one ring meets edge ``(a, b = nxt[a])`` of another, with
``z = prv[a]`` the start of the previous edge, ``e = r_b - r_a`` and

.. math::  t = \\frac{(\\mathbf r_p - \\mathbf r_a)\\cdot\\mathbf e}{|\\mathbf e|^2}.

Seed 003 Appendix A: "if P between r_i and r_i+1 then the normal distance, otherwise
|r_i - r_j|". Our precise reading (:func:`edge_term`):

* ``0 <= t <= 1`` (*strip*): ``d`` is the perpendicular distance from ``p`` to the line
  ``ab``, the closest point ``q = r_a + t e``;
* ``t < 0`` and ``p`` also beyond the end of the previous edge ``(z, a)``
  (``t_prev = (r_p - r_z).(r_a - r_z)/|r_a - r_z|^2 > 1``, which is
  ``(r_p - r_a).(r_a - r_z) > 0``): ``p`` is in the outer wedge of the corner ``a``
  (*end cap*), ``d = |r_p - r_a|``, ``q = r_a`` (``t`` is then taken as 0);
* otherwise this (vertex, edge) pair has no term.

Near a convex corner every outside point so gets exactly one term, and the energy is
continuous across the strip/wedge boundaries (at ``t = 0`` the perpendicular distance is
``|r_p - r_a|``, at ``t_prev = 1`` the distance to the previous edge's line is too). At a
reflex (concave) corner the two edges' strips overlap outside the ring, and a point there
gets two terms, one per edge; each ends at its strip's end, where its distance is
``|r_p - r_a|``, so there the energy steps by ``(epsilon/2)(1 - |r_p - r_a|/sigma)^2``
(rings with bending rigidity keep their corners convex in ordinary collisions).

With ``sigma = r_p + r_a`` (the sum of the half-thicknesses: the radii of ``p`` and of the
edge's start vertex) each term with ``d < sigma`` has the harmonic energy of the project's
SP model (seed 003 eq. 9)

.. math::  U = \\frac{\\epsilon}{2}\\left(1 - \\frac{d}{\\sigma}\\right)^2,
           \\qquad \\mathbf F_p = \\frac{\\epsilon}{\\sigma}\\left(1 - \\frac{d}{\\sigma}
           \\right)\\hat n, \\quad \\hat n = \\frac{\\mathbf r_p - \\mathbf q}{d},

and the reaction ``-F_p`` is split by lever arm, ``-(1 - t) F_p`` on ``a`` and ``-t F_p``
on ``b`` (all on ``a`` at an end cap): since ``q`` minimises the distance, ``d`` has the
gradients ``n``, ``-(1 - t) n``, ``-t n`` in ``r_p``, ``r_a``, ``r_b``, so these are exactly
``-grad U``. A term with ``d = 0`` (``p`` on the edge's line) has no direction and no force.

Kinetic friction (seed 003 eq. 12, the edge's velocity interpolated at the contact point):
``v_q = (1 - t) v_a + t v_b`` and ``F_mu = -mu_k (v_p - v_q)`` on ``p``, or only the part of
``v_p - v_q`` perpendicular to ``n`` (``tangential``, the authors' production setting); its
reaction is split by lever arm too.

Candidates come from the half Verlet list: for a listed pair ``(i, j)`` of vertices of two
rings both terms are evaluated, term 0 (``p = j``, edge starting at ``i``) and term 1
(``p = i``, edge starting at ``j``). Every (vertex, edge) pair within reach is evaluated
exactly once, through the listed pair of the vertex and the edge's start.

Four passes, each parallel and each writing only what one iteration owns:

1. :func:`ring_edge_vectors` (over particles) stores every ring edge ``r_b - r_a`` once and
   returns the longest, for the reach check;
2. :func:`edge_pair_terms` (over the list's rows) writes each term's force on ``p`` and its
   ``t`` into the pair's slot, ``slot[k] = (f0x, f0y, t0, f1x, f1y, t1)``, and sums the row's
   own shares in list order into ``shares[i, 0:4]``: ``P``, the force on ``i``, and ``Q``,
   what the edge starting at ``i`` passes to ``nxt[i]``;
3. :func:`column_shares` (over particles) sums the same two shares of the slots in each
   particle's column (in the transpose's ascending order) into ``shares[m, 4:8]``;
4. :func:`add_edge_forces` (over particles) adds to each particle its row's and column's
   ``P`` and its previous vertex's row's and column's ``Q``, in that order.

Every sum has one writer and an order that does not depend on the thread count, so forces
are bitwise the same for any number of threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from grainflow.kernels.neighbors import minimum_image

#: ``kind`` of a (vertex, edge) term: no term, perpendicular (strip), end cap (wedge).
NONE, STRIP, CAP = 0, 1, 2


@njit(cache=True, inline="always")
def _vec(x, i, j, box_len, periodic):
    """Minimum-image vector ``r_j - r_i`` (2D)."""
    return (minimum_image(x[j, 0] - x[i, 0], box_len[0], periodic[0]),
            minimum_image(x[j, 1] - x[i, 1], box_len[1], periodic[1]))


@njit(cache=True, parallel=True)
def ring_edge_vectors(nxt, x, box_len, periodic, edges):
    """Pass 1: ``edges[i] = r_{nxt[i]} - r_i`` (minimum image) for every ring vertex ``i``,
    the edge starting at ``i``; zeros for particles in no ring. Returns the squared length
    of the longest edge (for the reach check). Each particle writes only its own row."""
    n = nxt.shape[0]
    longest = 0.0
    for row in prange(n):
        i = np.uint64(row)  # unsigned indices, as in edge_pair_terms
        if nxt[i] < 0:
            edges[i, 0] = 0.0
            edges[i, 1] = 0.0
            continue
        ex, ey = _vec(x, i, np.uint64(nxt[i]), box_len, periodic)
        edges[i, 0] = ex
        edges[i, 1] = ey
        longest = max(longest, ex * ex + ey * ey)
    return longest


@njit(cache=True, inline="always")
def edge_term(wx, wy, edges, a, z):
    """Closest point of vertex ``p`` on edge ``(a, b)`` by the module's rule, from
    ``(wx, wy) = r_p - r_a`` and the edge vectors (``edges[a] = r_b - r_a``, ``edges[z] =
    r_a - r_z`` for ``z`` the start of the previous edge): ``(kind, t, rx, ry)`` with
    ``(rx, ry) = r_p - q``."""
    ex = edges[a, 0]
    ey = edges[a, 1]
    t = (wx * ex + wy * ey) / (ex * ex + ey * ey)
    if t > 1.0:
        return NONE, 0.0, 0.0, 0.0
    if t >= 0.0:
        return STRIP, t, wx - t * ex, wy - t * ey
    if wx * edges[z, 0] + wy * edges[z, 1] > 0.0:  # t_prev > 1: the outer wedge of corner a
        return CAP, 0.0, wx, wy
    return NONE, 0.0, 0.0, 0.0


@njit(cache=True, inline="always")
def term_force(eps, mu, tangential, v, radius, edges, p, a, b, z, wx, wy):
    """One (vertex ``p``, edge ``(a, b)``) term, ``(wx, wy) = r_p - r_a``:
    ``(kind, t, d, sigma, rx, ry, fx, fy)`` with the force ``(fx, fy)`` on ``p`` (harmonic
    repulsion and kinetic friction); ``kind = NONE`` where there is no contact (``d >= sigma``
    or ``d = 0`` too)."""
    kind, t, rx, ry = edge_term(wx, wy, edges, a, z)
    sigma = radius[p] + radius[a]
    d2 = rx * rx + ry * ry
    if kind == NONE or d2 >= sigma * sigma or d2 == 0.0:
        return NONE, 0.0, 0.0, sigma, 0.0, 0.0, 0.0, 0.0
    d = np.sqrt(d2)
    c = eps / sigma * (1.0 - d / sigma) / d
    fx = c * rx
    fy = c * ry
    if mu > 0.0:
        dvx = v[p, 0] - (1.0 - t) * v[a, 0] - t * v[b, 0]
        dvy = v[p, 1] - (1.0 - t) * v[a, 1] - t * v[b, 1]
        if tangential:
            vn = (dvx * rx + dvy * ry) / d2
            dvx -= vn * rx
            dvy -= vn * ry
        fx -= mu * dvx
        fy -= mu * dvy
    return kind, t, d, sigma, rx, ry, fx, fy


@njit(cache=True, inline="always")
def _segment_distance2(wx, wy, ex, ey):
    """Squared distance from ``r_a + w`` to the segment ``[r_a, r_a + e]``, with ``t`` clamped
    to [0, 1] by min and max (no branch): the ``d^2`` :func:`edge_term` gives in the strip and
    at an end cap, computed the same way, and a lower bound of it elsewhere."""
    t = min(max((wx * ex + wy * ey) / (ex * ex + ey * ey), 0.0), 1.0)
    rx = wx - t * ex
    ry = wy - t * ey
    return rx * rx + ry * ry


@njit(cache=True, inline="always")
def _near_either(wx, wy, sigma, edges, i, j):
    """Whether vertex ``j`` (at ``r_i + w``) is within ``sigma`` of the segment of the edge
    starting at ``i`` or ``i`` of the edge starting at ``j``: necessary for either term of
    the pair to touch. Most listed pairs fail it; answering it without the rule's branches
    keeps the branch predictor right on them (the full rule runs only for the few that
    pass)."""
    near0 = _segment_distance2(wx, wy, edges[i, 0], edges[i, 1]) < sigma * sigma
    near1 = _segment_distance2(-wx, -wy, edges[j, 0], edges[j, 1]) < sigma * sigma
    return near0 | near1


@njit(cache=True, parallel=True)
def edge_pair_terms(eps, mu, tangential, nxt, prv, x, v, radius, row_ptr, nbr, box_len,
                    periodic, edges, slot, shares):
    """Pass 2: both terms of every listed pair ``k = (i, j)`` into
    ``slot[k] = (f0x, f0y, t0, f1x, f1y, t1)`` (term 0: ``p = j`` on the edge starting at
    ``i``; term 1: ``p = i`` on the edge starting at ``j``); zeros where there is no term
    (pairs with a particle in no ring included). The row's own shares are summed on the way,
    in list order: ``shares[i, 0:4] = (P_x, P_y, Q_x, Q_y)`` with ``P`` the force on ``i``
    (``+F`` of term 1 as ``p``, ``-(1 - t0) F`` of term 0 as ``a``) and ``Q`` the force
    on ``nxt[i]`` (``-t0 F`` of term 0 as ``b``). Each row writes only its own slots and its
    own ``shares``. ``edges``: :func:`ring_edge_vectors` of this configuration; both terms
    share the branch ``r_j - r_i``."""
    n = row_ptr.shape[0] - 1
    for row in prange(n):
        # unsigned indices: numba wraps a negative signed index at every access (a compare
        # and a select each); unsigned ones skip it
        i = np.uint64(row)
        in_ring = nxt[i] >= 0
        px = 0.0
        py = 0.0
        qx = 0.0
        qy = 0.0
        for k in range(np.uint64(row_ptr[i]), np.uint64(row_ptr[i + 1])):
            j = np.uint64(nbr[k])
            f0x = 0.0
            f0y = 0.0
            t0 = 0.0
            f1x = 0.0
            f1y = 0.0
            t1 = 0.0
            if in_ring and nxt[j] >= 0:
                wx, wy = _vec(x, i, j, box_len, periodic)  # r_j - r_i; -w is r_i - r_j exactly
                if _near_either(wx, wy, radius[i] + radius[j], edges, i, j):
                    kind, t, d, sigma, rx, ry, fx, fy = term_force(
                        eps, mu, tangential, v, radius, edges, j, i, np.uint64(nxt[i]),
                        np.uint64(prv[i]), wx, wy)
                    if kind != NONE:
                        f0x = fx
                        f0y = fy
                        t0 = t
                    kind, t, d, sigma, rx, ry, fx, fy = term_force(
                        eps, mu, tangential, v, radius, edges, i, j, np.uint64(nxt[j]),
                        np.uint64(prv[j]), -wx, -wy)
                    if kind != NONE:
                        f1x = fx
                        f1y = fy
                        t1 = t
            slot[k, 0] = f0x
            slot[k, 1] = f0y
            slot[k, 2] = t0
            slot[k, 3] = f1x
            slot[k, 4] = f1y
            slot[k, 5] = t1
            w = 1.0 - t0
            px += f1x - w * f0x
            py += f1y - w * f0y
            qx -= t0 * f0x
            qy -= t0 * f0y
        shares[i, 0] = px
        shares[i, 1] = py
        shares[i, 2] = qx
        shares[i, 3] = qy


@njit(cache=True, parallel=True)
def column_shares(nxt, col_ptr, col_pair, slot, shares):
    """Pass 3: for every ring vertex ``m``, the shares of the slots in its column (pairs
    ``(i, m)``, in the transpose's ascending order) into ``shares[m, 4:8] = (P_x, P_y, Q_x,
    Q_y)``: ``P`` the force on ``m`` (``+F`` of term 0 as ``p``, ``-(1 - t1) F`` of term 1
    as ``a``), ``Q`` the force on ``nxt[m]`` (``-t1 F`` of term 1 as ``b``). One loop over
    the column serves both; each vertex writes only its own row."""
    n = col_ptr.shape[0] - 1
    for row in prange(n):
        m = np.uint64(row)  # unsigned indices, as in edge_pair_terms
        if nxt[m] < 0:
            continue
        px = 0.0
        py = 0.0
        qx = 0.0
        qy = 0.0
        for q in range(np.uint64(col_ptr[m]), np.uint64(col_ptr[m + 1])):
            k = np.uint64(col_pair[q])
            t1 = slot[k, 5]
            w = 1.0 - t1
            px += slot[k, 0] - w * slot[k, 3]
            py += slot[k, 1] - w * slot[k, 4]
            qx -= t1 * slot[k, 3]
            qy -= t1 * slot[k, 4]
        shares[m, 4] = px
        shares[m, 5] = py
        shares[m, 6] = qx
        shares[m, 7] = qy


@njit(cache=True, parallel=True)
def add_edge_forces(nxt, prv, frozen, shares, force):
    """Pass 4: add to every ring vertex ``m`` (unless frozen), in this fixed order, the
    ``P`` of its row and of its column and the ``Q`` of the row and of the column of
    ``prv[m]`` (what the edge ending at ``m`` passes on)."""
    n = nxt.shape[0]
    for row in prange(n):
        m = np.uint64(row)  # unsigned indices, as in edge_pair_terms
        if nxt[m] < 0 or frozen[m]:
            continue
        z = np.uint64(prv[m])
        force[m, 0] += ((shares[m, 0] + shares[m, 4]) + shares[z, 2]) + shares[z, 6]
        force[m, 1] += ((shares[m, 1] + shares[m, 5]) + shares[z, 3]) + shares[z, 7]


@njit(cache=True)
def edge_contact_list(eps, mu, tangential, nxt, prv, x, v, radius, row_ptr, nbr, box_len,
                      periodic, edges):
    """Every term in contact now, in list order (term 0 before term 1 of each pair):
    ``(p, a, b, kind, t, d, sigma, force on p (M, 3), branch r_p - q (M, 3))``, the same
    terms as :func:`edge_pair_terms` (``edges``: :func:`ring_edge_vectors` of this
    configuration). Read-only (analyses, energies, contact listings)."""
    n = row_ptr.shape[0] - 1
    cap = 2 * nbr.shape[0]
    ip = np.empty(cap, dtype=np.int64)
    ia = np.empty(cap, dtype=np.int64)
    kinds = np.empty(cap, dtype=np.int8)
    out = np.empty((cap, 3))  # t, d, sigma
    f = np.zeros((cap, 3))
    br = np.zeros((cap, 3))
    m = 0
    for i in range(n):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            j = nbr[k]
            if nxt[i] < 0 or nxt[j] < 0:
                continue
            wx, wy = _vec(x, i, j, box_len, periodic)
            for s in range(2):
                p, a = (j, i) if s == 0 else (i, j)
                sign = 1.0 if s == 0 else -1.0
                kind, t, d, sigma, rx, ry, fx, fy = term_force(
                    eps, mu, tangential, v, radius, edges, p, a, nxt[a], prv[a], sign * wx,
                    sign * wy)
                if kind == NONE:
                    continue
                ip[m] = p
                ia[m] = a
                kinds[m] = kind
                out[m, 0] = t
                out[m, 1] = d
                out[m, 2] = sigma
                f[m, 0] = fx
                f[m, 1] = fy
                br[m, 0] = rx
                br[m, 1] = ry
                m += 1
    ib = np.empty(m, dtype=np.int64)
    for c in range(m):
        ib[c] = nxt[ia[c]]
    return (ip[:m].copy(), ia[:m].copy(), ib, kinds[:m].copy(), out[:m, 0].copy(),
            out[:m, 1].copy(), out[:m, 2].copy(), f[:m].copy(), br[:m].copy())
