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

The loop adds each pair's force to its row owner ``i`` and stores it per pair;
:func:`gather_pair_forces` then adds the ``j`` sides per particle in a fixed order, so
forces are bitwise identical for any number of threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from grainflow.kernels.neighbors import minimum_image


@njit(cache=True, parallel=True)
def evaluate_pairs(evaluate, params, reach, x, v, omega, radius, mass, ptype, frozen, row_ptr,
                   nbr, hist, fc_pair, active, box_len, periodic, dt, update, force, torque):
    """Evaluate the law for every listed pair.

    For every pair within ``r_i + r_j + reach`` the law is evaluated, ``fc_pair[k] = (f, c)``
    (npairs, 6) is written, ``active[k] = 1``, and the force and torque are added to
    particle ``i`` (the row owner; one thread per row, so no races). The ``j`` side is added
    afterwards by :func:`gather_pair_forces`.

    Farther pairs are not passed to the law: by contract a law exerts no force there and
    keeps no memory, so their history is zeroed (if they were evaluated before) and
    ``active[k] = 0``; their ``fc_pair`` row is left stale and must not be read. Most listed
    pairs are of this kind, and touching one byte for them instead of 80 saves most of the
    memory traffic of the loop.
    """
    n = row_ptr.shape[0] - 1
    for i in prange(n):
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
        for k in range(row_ptr[i], row_ptr[i + 1]):
            j = nbr[k]
            dx = minimum_image(xi0 - x[j, 0], box_len[0], periodic[0])
            dy = minimum_image(xi1 - x[j, 1], box_len[1], periodic[1])
            dz = minimum_image(xi2 - x[j, 2], box_len[2], periodic[2])
            rsq = dx * dx + dy * dy + dz * dz
            cut = ri + radius[j] + reach
            if rsq >= cut * cut:
                if active[k]:
                    for h in range(hist.shape[1]):
                        hist[k, h] = 0.0
                    active[k] = 0
                continue
            active[k] = 1
            mj = mass[j]
            if frozen[i]:
                meff = mj
            elif frozen[j]:
                meff = mi
            else:
                meff = mi * mj / (mi + mj)
            fx, fy, fz, cx, cy, cz = evaluate(
                params, ti, ptype[j], dx, dy, dz, rsq, ri, radius[j],
                v[i, 0] - v[j, 0], v[i, 1] - v[j, 1], v[i, 2] - v[j, 2],
                omega[i, 0], omega[i, 1], omega[i, 2], omega[j, 0], omega[j, 1], omega[j, 2],
                meff, hist, k, dt, update)
            fc_pair[k, 0] = fx
            fc_pair[k, 1] = fy
            fc_pair[k, 2] = fz
            fc_pair[k, 3] = cx
            fc_pair[k, 4] = cy
            fc_pair[k, 5] = cz
            f0 += fx
            f1 += fy
            f2 += fz
            c0 += cx
            c1 += cy
            c2 += cz
        force[i, 0] += f0
        force[i, 1] += f1
        force[i, 2] += f2
        torque[i, 0] -= ri * c0
        torque[i, 1] -= ri * c1
        torque[i, 2] -= ri * c2


@njit(cache=True, parallel=True)
def gather_pair_forces(col_ptr, col_pair, fc_pair, active, radius, force, torque):
    """Add the j-side of every active pair to the particles, in a fixed order (deterministic)."""
    n = col_ptr.shape[0] - 1
    for i in prange(n):
        if col_ptr[i] == col_ptr[i + 1]:
            continue
        f0 = 0.0
        f1 = 0.0
        f2 = 0.0
        c0 = 0.0
        c1 = 0.0
        c2 = 0.0
        for q in range(col_ptr[i], col_ptr[i + 1]):
            k = col_pair[q]
            if not active[k]:
                continue
            f0 += fc_pair[k, 0]
            f1 += fc_pair[k, 1]
            f2 += fc_pair[k, 2]
            c0 += fc_pair[k, 3]
            c1 += fc_pair[k, 4]
            c2 += fc_pair[k, 5]
        force[i, 0] -= f0
        force[i, 1] -= f1
        force[i, 2] -= f2
        r = radius[i]
        torque[i, 0] -= r * c0
        torque[i, 1] -= r * c1
        torque[i, 2] -= r * c2


@njit(cache=True)
def active_pairs(row_ptr, nbr, f_pair, active):
    """Active pair slots with a non-zero force (first three columns of ``f_pair``): (i, j, slot)."""
    n = row_ptr.shape[0] - 1
    m = 0
    for k in range(nbr.shape[0]):
        if active[k] and (f_pair[k, 0] != 0.0 or f_pair[k, 1] != 0.0 or f_pair[k, 2] != 0.0):
            m += 1
    pi = np.empty(m, dtype=np.int64)
    pj = np.empty(m, dtype=np.int64)
    slot = np.empty(m, dtype=np.int64)
    m = 0
    for i in range(n):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            if active[k] and (f_pair[k, 0] != 0.0 or f_pair[k, 1] != 0.0 or f_pair[k, 2] != 0.0):
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
