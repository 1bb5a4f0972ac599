"""Compiled parts of the hopper reinsertion (SPEC M8; seed 003, Sec. 2.4;
:class:`grainflow.scenarios.hopper_reinsertion.HopperReinsertion`): which grains a check
acts on, and where a reinserted grain lands on the pile."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def column_landings(samples, pool, lateral_axes, up, x, radius, i, r, check_overlaps,
                    stop_at_first):
    """For each lateral attempt ``samples[q]`` (in the ``lateral_axes`` of ``x``): the grain
    of ``pool`` (indices, ascending) with the highest contact height in that column,
    ``h_j + sqrt((r + r_j)^2 - l_j^2)`` over the pool grains at lateral distance
    ``l_j < r + r_j`` (the first such grain on ties), and whether grain ``i`` of radius ``r``
    placed there, touching it, would overlap any other grain (``check_overlaps``).

    Returns ``(partner, height, blocked)`` per attempt; ``partner[q] = -1`` where the column
    holds no pool grain (or, with ``stop_at_first``, for every attempt after the first that
    lands unblocked, which are not evaluated). The arithmetic is that of the array form
    (squares summed over the lateral axes in order, the centre distance as the square root
    of the three squared differences summed in order), so the answers are bitwise those of
    numpy on the same attempts.
    """
    k = samples.shape[0]
    partner = np.full(k, -1, dtype=np.int64)
    height = np.zeros(k)
    blocked = np.zeros(k, dtype=np.bool_)
    target = np.zeros(3)
    for q in range(k):
        best = -np.inf
        best_j = -1
        for m in range(pool.shape[0]):
            j = pool[m]
            l2 = 0.0
            for c in range(lateral_axes.shape[0]):
                d = x[j, lateral_axes[c]] - samples[q, c]
                l2 += d * d
            reach = r + radius[j]
            reach_sq = reach * reach
            if l2 < reach_sq:
                h = x[j, up] + np.sqrt(reach_sq - l2)
                if h > best:
                    best = h
                    best_j = j
        if best_j < 0:
            continue
        partner[q] = best_j
        height[q] = best
        if check_overlaps:
            target[:] = 0.0
            for c in range(lateral_axes.shape[0]):
                target[lateral_axes[c]] = samples[q, c]
            target[up] = best
            for j in range(x.shape[0]):
                if j == i or j == best_j:
                    continue
                d0 = x[j, 0] - target[0]
                d1 = x[j, 1] - target[1]
                d2 = x[j, 2] - target[2]
                if np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) - (r + radius[j]) < 0.0:
                    blocked[q] = True
                    break
        if stop_at_first and not blocked[q]:
            break
    return partner, height, blocked


@njit(cache=True)
def crossings(flag, x, up, orifice_height, depth_diameters, radius):
    """The grains a reinsertion check acts on, as ascending index arrays ``(crossed, due)``:
    ``crossed``, not flagged yet (``flag == 0``) and below the orifice plane
    ``orifice_height`` along axis ``up``; ``due``, flagged or just crossed, and below
    ``orifice_height - depth_diameters * r_i`` (``depth_diameters`` = 2 x the depth in
    diameters). One pass, no temporary arrays: most checks (every 10 steps in the seed's
    hoppers) find nothing."""
    n = x.shape[0]
    crossed = np.empty(n, dtype=np.int64)
    due = np.empty(n, dtype=np.int64)
    n_crossed = 0
    n_due = 0
    for i in range(n):
        h = x[i, up]
        out = flag[i] == 1
        if flag[i] == 0 and h < orifice_height:
            crossed[n_crossed] = i
            n_crossed += 1
            out = True
        if out and h < orifice_height - depth_diameters * radius[i]:
            due[n_due] = i
            n_due += 1
    return crossed[:n_crossed].copy(), due[:n_due].copy()
