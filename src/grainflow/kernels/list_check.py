"""Compiled kernels for the neighbour list's *relative* validity check.

The usual rule (:func:`~grainflow.kernels.neighbors.max_displacement_sq`) rebuilds the list
once some particle has moved half the skin ``s`` since the last build. It bounds the
relative displacement of every pair by ``s``, which is what the list needs, but it pays for
motion the pairs share: a stream falling at 2 m/s rebuilds every few steps although its
neighbouring grains hardly move against each other.

The relative rule checks the pairs' relative displacements instead. At a build, particles
are grouped by their build position into cubic *blocks* of side ``G`` (a few interaction
cut-offs). Each step, every block gets the box ``[lo_b, hi_b]`` bounding the displacements
``Delta_i = x_i - x_i(build)`` of its particles, and the list is still valid when

1. for every pair of neighbouring blocks ``(a, b)`` (the block itself included),
   ``sum_axes max(hi_a - lo_b, hi_b - lo_a)^2 < s^2``: every pair of particles that may
   touch, listed or not, has moved less than ``s`` against each other. An unlisted pair
   was at least ``r_i + r_j + reach + s`` apart, so it is still out of reach;
2. the displacements of all particles span less than ``G - c`` (``c = 2 r_max + reach``)
   in the same sense: two particles in blocks that are not neighbours were more than ``G``
   apart, so they are still out of reach;
3. every particle has moved less than its own ``allowance`` (infinite unless a force
   relies on absolute positions: static walls visit only the particles that were near
   them, :mod:`grainflow.walls.force`).

Both rules rebuild before the list could miss a pair, so every result is bitwise the same
as with a list rebuilt at every step. The passes have one writer per run or block, and
minima and maxima do not depend on the order they are taken in, so neither does the
answer on the thread count.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

from grainflow.kernels.neighbors import max_displacement_sq
from grainflow.kernels.specialize import serial, specialize


@njit(cache=True, parallel=True)
def block_displacement_bounds(x, x_ref, member, block_ptr, allowance_sq, lo, hi, excess):
    """Per block ``b`` (particles ``member[block_ptr[b]:block_ptr[b + 1]]``): the bounding
    box ``lo[b], hi[b]`` of their displacements since the build, and ``excess[b] = 1`` if
    one has moved at least its allowance (``allowance_sq`` is squared)."""
    for b in prange(block_ptr.shape[0] - 1):
        l0 = l1 = l2 = np.inf
        h0 = h1 = h2 = -np.inf
        over = 0
        for k in range(block_ptr[b], block_ptr[b + 1]):
            i = member[k]
            d0 = x[i, 0] - x_ref[i, 0]
            d1 = x[i, 1] - x_ref[i, 1]
            d2 = x[i, 2] - x_ref[i, 2]
            l0 = min(l0, d0)
            h0 = max(h0, d0)
            l1 = min(l1, d1)
            h1 = max(h1, d1)
            l2 = min(l2, d2)
            h2 = max(h2, d2)
            if d0 * d0 + d1 * d1 + d2 * d2 >= allowance_sq[i]:
                over = 1
        lo[b, 0] = l0
        lo[b, 1] = l1
        lo[b, 2] = l2
        hi[b, 0] = h0
        hi[b, 1] = h1
        hi[b, 2] = h2
        excess[b] = over


@njit(cache=True)
def spread_holds(lo, hi, excess, spread_sq):
    """Conditions 3 and 2: no particle has moved its allowance, and the displacements of
    all particles spread less than ``sqrt(spread_sq)``."""
    g_lo = np.full(3, np.inf)
    g_hi = np.full(3, -np.inf)
    for b in range(lo.shape[0]):
        if excess[b]:
            return False
        for a in range(3):
            g_lo[a] = min(g_lo[a], lo[b, a])
            g_hi[a] = max(g_hi[a], hi[b, a])
    if lo.shape[0] == 0:
        return True
    s = 0.0
    for a in range(3):
        s += (g_hi[a] - g_lo[a]) ** 2
    return s < spread_sq


@njit(cache=True, parallel=True)
def neighbour_blocks_hold(lo, hi, pair_ptr, pair_block, skin_sq, worst):
    """Condition 1: ``worst[u]``, the largest squared relative displacement two particles
    of block ``u`` and of one of its neighbours ``v >= u``
    (``pair_block[pair_ptr[u]:pair_ptr[u + 1]]``) may have; True if all are below
    ``skin_sq``. (A running maximum with conditional expressions: ``max()`` and a flag
    made this loop twice as slow.)"""
    for u in prange(lo.shape[0]):
        w = 0.0
        for k in range(pair_ptr[u], pair_ptr[u + 1]):
            v = pair_block[k]
            s = 0.0
            for a in range(3):
                p = hi[u, a] - lo[v, a]
                q = hi[v, a] - lo[u, a]
                m = p if p > q else q
                s += m * m
            w = s if s > w else w
        worst[u] = w
    for u in range(lo.shape[0]):
        if worst[u] >= skin_sq:
            return False
    return True


def _stale_absolute(args):
    """The usual rule: ``args = (x, x_ref, box_len, periodic, limit)``; True once some
    particle has moved more than ``sqrt(limit)`` (half the skin) since the build.
    Template: ``DISPLACEMENT`` is bound by :func:`stale_kernel`."""
    x, x_ref, box_len, periodic, limit = args
    return DISPLACEMENT(x, x_ref, box_len, periodic) > limit  # noqa: F821 (bound name)


def _stale_relative(args):
    """The relative rule: ``args = (x, x_ref, allowance_sq, member, block_ptr, lo, hi,
    excess, pair_ptr, pair_block, worst, skin_sq, spread_sq)``
    (:meth:`~grainflow.engine.list_blocks.Blocks.arrays`); True once the list may miss a
    pair or a wall contact (module docstring). Template: ``BOUNDS`` and ``NEIGHBOURS``
    are bound by :func:`stale_kernel`."""
    (x, x_ref, allowance_sq, member, block_ptr, lo, hi, excess, pair_ptr, pair_block,
     worst, skin_sq, spread_sq) = args
    BOUNDS(x, x_ref, member, block_ptr, allowance_sq, lo, hi, excess)  # noqa: F821
    if not spread_holds(lo, hi, excess, spread_sq):
        return True
    return not NEIGHBOURS(lo, hi, pair_ptr, pair_block, skin_sq, worst)  # noqa: F821


def stale_kernel(relative: bool, one_thread: bool) -> Any:
    """The compiled check ``stale(args) -> bool`` of either rule, calling the serial twins
    of the parallel passes on one thread (as the rest of the step loop does)."""
    if relative:
        twin = serial if one_thread else (lambda kernel: kernel)
        return specialize(_stale_relative, "stale_relative",
                          {"BOUNDS": twin(block_displacement_bounds),
                           "NEIGHBOURS": twin(neighbour_blocks_hold)})
    displacement = serial(max_displacement_sq) if one_thread else max_displacement_sq
    return specialize(_stale_absolute, "stale_absolute", {"DISPLACEMENT": displacement})
