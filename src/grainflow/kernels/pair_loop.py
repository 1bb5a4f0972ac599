"""The one pair loop every contact law runs through, and the deterministic force gather.

A contact law is a compiled *evaluator* (see :mod:`grainflow.models.base`) with the
signature::

    evaluate(table, type_i, type_j, dx, dy, dz, rsq, rad_i, rad_j, vrx, vry, vrz,
             wix, wiy, wiz, wjx, wjy, wjz, meff, hist, k, dt, update)
        -> (fx, fy, fz, cx, cy, cz)

``table[type_i, type_j, :]`` holds the law's parameters for the type pair (the whole table
is passed, not a row: creating an array view per pair costs more than the whole contact
computation), ``d = x_i - x_j`` the branch vector
(minimum image), ``vr = v_i - v_j``, ``w`` the angular velocities, ``meff`` the effective
mass (``m_i m_j / (m_i + m_j)``, or the mobile partner's mass when the other is frozen or a
wall), ``hist[k]`` the pair's history row. The evaluator returns the force on ``i`` and the
vector ``c`` such that the torques are ``T_i -= rad_i c`` and ``T_j -= rad_j c`` (for a
tangential force ``F_t``: ``c = d x F_t / |d|``, LAMMPS's convention with the full radius as
lever arm). Walls call the same evaluator with ``rad_j = 0`` and ``d`` the vector from the
wall's closest point, so one law serves pairs and walls alike.

Several pair interactions may share one neighbour list, each with its own law and the type
pairs it owns (``use[type_i, type_j]``); pairs of other types are skipped. The first
interaction of a step *sets* each particle's force to the sum over its own row (this
replaces zeroing), later ones add to it; each stores its pairs' results per pair;
the ``j`` sides are then added per particle in a fixed order (the column order of the list's
transpose: ascending ``i``), so forces are bitwise identical for any number of threads.

The rows are cut into one contiguous chunk per thread. A particle whose whole column lies
in one chunk (most of them) gets its ``j`` sides summed directly by that chunk's thread into
``col_sum`` while the rows are evaluated, in exactly the column order; only the particles
whose column straddles a chunk boundary are gathered afterwards from the stored per-pair
results. Both ways add the same terms in the same order, starting from zero, so the split
(which depends on the thread count) does not change a bit of the result.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from grainflow.kernels.neighbors import minimum_image
from grainflow.kernels.specialize import specialize

#: ``active[k]`` codes: the law was not evaluated for pair slot ``k`` at the last call and its
#: history is zero; it was evaluated (``fc_pair[k]`` is valid); it was not, but its history
#: may still be non-zero (a read-only call found it out of reach and left the history
#: alone; the next updating call clears it).
INACTIVE, ACTIVE, STALE = 0, 1, 2


@njit(cache=True)
def chunk_start(t, n, n_chunks):
    """First row of chunk ``t`` when ``n`` rows are cut into ``n_chunks`` contiguous chunks."""
    return (t * n) // n_chunks


@njit(cache=True)
def spans_chunks(first, last, starts):
    """True if rows ``first <= last`` lie in different chunks (a chunk starts in (first, last]).

    ``starts``: the first row of every chunk after the first, ascending.
    """
    for b in starts:
        if b > first:
            return b <= last
    return False


def pair_kernel(evaluate, all_types: bool = True, first: bool = True):
    """:func:`_evaluate_pairs` compiled for one law's evaluator, bound as a global so that
    an evaluator declared ``inline='always'`` is inlined into the loop (about 15 % of the
    loop's time on the chute; :mod:`grainflow.kernels.specialize`). ``all_types`` and
    ``first`` are compile-time constants too: testing them per pair costs 3 % on the chute."""
    name = "evaluate_pairs_" + evaluate.py_func.__name__
    return specialize(_evaluate_pairs, name, {"evaluate": evaluate, "ALL_TYPES": bool(all_types),
                                              "FIRST": bool(first)}, parallel=True)


def _evaluate_pairs(params, reach, use, x, v, omega, radius, mass, ptype, frozen, row_ptr, nbr,
                    pair_col, col_span, n_chunks, hist, fc_pair, active, active_col, col_sum,
                    box_len, periodic, dt, update, keep, force, torque, row_wraps):
    """Evaluate the law for every listed pair of its types; set or add each row's sum.

    Template compiled by :func:`pair_kernel`, which binds the globals ``evaluate``,
    ``ALL_TYPES`` and ``FIRST``.

    Pairs whose type pair is not ``use``d (unless ``ALL_TYPES``) are skipped. For every
    other pair within ``r_i + r_j + reach`` the law is evaluated, ``active[k] = ACTIVE``,
    ``fc_pair[k] = (f, c)`` (npairs, 6) is written where ``keep`` or where the gather needs
    it (the column of ``j`` straddles two chunks), and the force and torque of particle
    ``i`` (the row owner) are *set* (``FIRST``) to ``F_i = 0 + sum_k f_k`` and
    ``T_i = 0 - r_i sum_k c_k`` (exactly what zeroing and then adding gives), or else
    incremented by the same sums. Rows are processed in ``n_chunks``
    contiguous chunks, one thread each; when the column of ``j`` (rows
    ``col_span[j, 0]`` to ``col_span[j, 1]``) lies inside the chunk, ``(f, c)`` is also added
    to ``col_sum[j]`` (no other thread touches it). :func:`gather_pair_forces` applies the
    ``j`` sides afterwards.

    Farther pairs are not passed to the law: by contract a law exerts no force there and
    keeps no memory, so an updating call (``update``) zeroes the history of those that were
    evaluated before and sets ``active[k] = INACTIVE``; a read-only call writes no history
    and marks them ``STALE`` instead. Their ``fc_pair`` row is left stale and must not be
    read. Most listed
    pairs are of this kind, and touching one byte for them instead of 80 saves most of the
    memory traffic of the loop. ``active_col[pair_col[k]]`` mirrors ``active[k]`` in column
    order (written only when a pair changes state) for the gather.

    ``row_wraps[i]`` false says that no pair of row ``i`` reaches across a periodic
    boundary (:func:`~grainflow.kernels.neighbors.rows_crossing_periodic`): the branch
    vector is then the plain difference, and the minimum image (about 2 ns a listed pair,
    a tenth of the loop) is skipped.

    ``keep`` false skips the per-pair store the gather does not read: ``fc_pair`` is then
    incomplete until the next call with ``keep``. The compiled step loop keeps only on the
    last step of a run of steps, so the listing of contacts Python reads is always whole,
    and saves a scattered 48-byte store per contact on the other steps (on the chute,
    medians of five alternated runs: 1 % of a step on one thread, 12 % on two).
    """
    n = row_ptr.shape[0] - 1
    for t in prange(n_chunks):
        lo = chunk_start(t, n, n_chunks)
        hi = chunk_start(t + 1, n, n_chunks)
        # unsigned indices: numba wraps a negative signed index around at every access (a
        # compare and a select each); unsigned ones skip it (7 % of this loop on the chute)
        for i in range(np.uint64(lo), np.uint64(hi)):
            xi0 = x[i, 0]
            xi1 = x[i, 1]
            xi2 = x[i, 2]
            ti = ptype[i]
            ri = radius[i]
            mi = mass[i]
            f0 = 0.0
            f1 = 0.0
            f2 = 0.0
            c0 = 0.0
            c1 = 0.0
            c2 = 0.0
            wraps = row_wraps[i]
            for k in range(np.uint64(row_ptr[i]), np.uint64(row_ptr[i + 1])):
                j = np.uint64(nbr[k])
                if not ALL_TYPES and not use[ti, ptype[j]]:  # noqa: F821 (bound)
                    continue
                dx = xi0 - x[j, 0]
                dy = xi1 - x[j, 1]
                dz = xi2 - x[j, 2]
                if wraps:
                    dx = minimum_image(dx, box_len[0], periodic[0])
                    dy = minimum_image(dy, box_len[1], periodic[1])
                    dz = minimum_image(dz, box_len[2], periodic[2])
                rsq = dx * dx + dy * dy + dz * dz
                cut = ri + radius[j] + reach
                if rsq >= cut * cut:
                    if active[k] != INACTIVE:
                        if update:
                            for h in range(hist.shape[1]):
                                hist[k, h] = 0.0
                            active[k] = INACTIVE
                        else:
                            active[k] = STALE
                        active_col[pair_col[k]] = 0
                    continue
                if active[k] != ACTIVE:
                    active[k] = ACTIVE
                    active_col[pair_col[k]] = 1
                mj = mass[j]
                if frozen[i]:
                    meff = mj
                elif frozen[j]:
                    meff = mi
                else:
                    meff = mi * mj / (mi + mj)
                fx, fy, fz, cx, cy, cz = evaluate(  # noqa: F821 (bound by pair_kernel)
                    params, ti, ptype[j], dx, dy, dz, rsq, ri, radius[j],
                    v[i, 0] - v[j, 0], v[i, 1] - v[j, 1], v[i, 2] - v[j, 2],
                    omega[i, 0], omega[i, 1], omega[i, 2], omega[j, 0], omega[j, 1],
                    omega[j, 2], meff, hist, k, dt, update)
                inside = col_span[j, 0] >= lo and col_span[j, 1] < hi
                if keep or not inside:
                    fc_pair[k, 0] = fx
                    fc_pair[k, 1] = fy
                    fc_pair[k, 2] = fz
                    fc_pair[k, 3] = cx
                    fc_pair[k, 4] = cy
                    fc_pair[k, 5] = cz
                if inside:
                    col_sum[j, 0] += fx
                    col_sum[j, 1] += fy
                    col_sum[j, 2] += fz
                    col_sum[j, 3] += cx
                    col_sum[j, 4] += cy
                    col_sum[j, 5] += cz
                f0 += fx
                f1 += fy
                f2 += fz
                c0 += cx
                c1 += cy
                c2 += cz
            if FIRST:  # noqa: F821 (bound by pair_kernel)
                force[i, 0] = 0.0 + f0
                force[i, 1] = 0.0 + f1
                force[i, 2] = 0.0 + f2
                torque[i, 0] = 0.0 - ri * c0
                torque[i, 1] = 0.0 - ri * c1
                torque[i, 2] = 0.0 - ri * c2
            else:
                force[i, 0] += f0
                force[i, 1] += f1
                force[i, 2] += f2
                torque[i, 0] -= ri * c0
                torque[i, 1] -= ri * c1
                torque[i, 2] -= ri * c2


@njit(cache=True, parallel=True)
def gather_pair_forces(col_ptr, col_pair, col_span, n_chunks, fc_pair, active_col, col_sum,
                       radius, force, torque):
    """Add the j-side of every active pair to the particles, in a fixed order (deterministic).

    ``F_j -= s_f``, ``T_j -= r_j s_c`` with ``(s_f, s_c) = 0 + sum_q (f, c)_{k(q)}`` over the
    active column entries ``q`` of ``j`` in order (``k(q) = col_pair[q]``, active where
    ``active_col[q]``). The sum is ``col_sum[j]`` when :func:`evaluate_pairs` built it (the
    column lies in one of its ``n_chunks`` chunks; ``col_sum[j]`` is then reset to zero for
    the next call), else it is summed here from ``fc_pair``.
    """
    n = col_ptr.shape[0] - 1
    starts = np.empty(n_chunks - 1, dtype=np.int64)
    for t in range(1, n_chunks):
        starts[t - 1] = chunk_start(t, n, n_chunks)
    for j in prange(n):
        first = col_span[j, 0]
        last = col_span[j, 1]
        if first > last:
            continue
        if not spans_chunks(first, last, starts):
            f0 = col_sum[j, 0]
            f1 = col_sum[j, 1]
            f2 = col_sum[j, 2]
            c0 = col_sum[j, 3]
            c1 = col_sum[j, 4]
            c2 = col_sum[j, 5]
            for h in range(6):
                col_sum[j, h] = 0.0
        else:
            f0 = 0.0
            f1 = 0.0
            f2 = 0.0
            c0 = 0.0
            c1 = 0.0
            c2 = 0.0
            for q in range(col_ptr[j], col_ptr[j + 1]):
                if not active_col[q]:
                    continue
                k = col_pair[q]
                f0 += fc_pair[k, 0]
                f1 += fc_pair[k, 1]
                f2 += fc_pair[k, 2]
                c0 += fc_pair[k, 3]
                c1 += fc_pair[k, 4]
                c2 += fc_pair[k, 5]
        force[j, 0] -= f0
        force[j, 1] -= f1
        force[j, 2] -= f2
        r = radius[j]
        torque[j, 0] -= r * c0
        torque[j, 1] -= r * c1
        torque[j, 2] -= r * c2


@njit(cache=True)
def active_pairs(row_ptr, nbr, f_pair, active):
    """Pair slots evaluated at the last call (``ACTIVE``) with a non-zero force (first three
    columns of ``f_pair``): (i, j, slot)."""
    n = row_ptr.shape[0] - 1
    m = 0
    for k in range(nbr.shape[0]):
        if active[k] == ACTIVE and (f_pair[k, 0] != 0.0 or f_pair[k, 1] != 0.0 or f_pair[k, 2] != 0.0):
            m += 1
    pi = np.empty(m, dtype=np.int64)
    pj = np.empty(m, dtype=np.int64)
    slot = np.empty(m, dtype=np.int64)
    m = 0
    for i in range(n):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            if active[k] == ACTIVE and (f_pair[k, 0] != 0.0 or f_pair[k, 1] != 0.0 or f_pair[k, 2] != 0.0):
                pi[m] = i
                pj[m] = nbr[k]
                slot[m] = k
                m += 1
    return pi, pj, slot


@njit(cache=True, parallel=True)
def max_pair_overlap(row_ptr, nbr, x, radius, box_len, periodic):
    """Largest overlap ``r_i + r_j - |d|`` over listed pairs (0 if none overlap)."""
    best = 0.0
    for i in prange(row_ptr.shape[0] - 1):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            j = nbr[k]
            rsq = 0.0
            for a in range(3):
                d = minimum_image(x[i, a] - x[j, a], box_len[a], periodic[a])
                rsq += d * d
            best = max(best, radius[i] + radius[j] - np.sqrt(rsq))
    return best


@njit(cache=True)
def max_relative_overlap(row_ptr, nbr, x, radius, box_len, periodic):
    """Largest ``(r_i + r_j - |d|) / min(r_i, r_j)`` over listed pairs and its row ``i``.

    The first such pair in list order wins ties; ``(0.0, 0)`` for an empty list.
    """
    best = -np.inf
    row = 0
    for i in range(row_ptr.shape[0] - 1):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            j = nbr[k]
            rsq = 0.0
            for a in range(3):
                d = minimum_image(x[i, a] - x[j, a], box_len[a], periodic[a])
                rsq += d * d
            rel = (radius[i] + radius[j] - np.sqrt(rsq)) / min(radius[i], radius[j])
            if rel > best:
                best = rel
                row = i
    if best == -np.inf:
        return 0.0, 0
    return best, row
