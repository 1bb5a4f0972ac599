"""Compiled kernels for the neighbour search: sparse cell lists into a half Verlet list.

Cells are hashed, not stored densely: each particle gets integer cell coordinates, the
coordinates are linearised into one int64 key, particles are sorted by key and only occupied
cells exist (a sorted array of unique keys). A neighbour cell is found by binary search in
that array, so memory and time grow with the number of particles, never with the empty
volume of the domain (a falling stream 1000 diameters tall costs what its grains cost).

The Verlet list is a *half* list in CSR form: row ``i`` holds the partners ``j > i`` with
centre distance below ``radius_i + radius_j + reach + skin``, sorted ascending. Pairs of two
frozen particles and pairs inside one body (``body >= 0``) are excluded. The transpose
(``col_ptr``, ``col_pair``) lists for each particle the pair slots where it is the second
member, so per-pair forces can be gathered per particle in a fixed order: results are then
bitwise independent of the number of threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True)
def minimum_image(d: float, length: float, periodic: bool) -> float:
    """Displacement component folded into [-L/2, L/2] on a periodic axis.

    ``d - L rint(d / L)``, evaluated only when ``|d| > L/2`` (otherwise ``rint`` gives 0 and
    ``d`` is returned unchanged): the division is skipped for almost every pair.
    """
    if periodic and abs(d) > 0.5 * length:
        return d - length * np.rint(d / length)
    return d


@njit(cache=True, inline="always")
def _separation(d0: float, d1: float, d2: float, wrap: bool, box_len, periodic
                ) -> tuple[float, float, float]:
    """A separation's components, folded by :func:`minimum_image` when ``wrap`` (some axis
    is periodic); unchanged otherwise."""
    if wrap:
        return (minimum_image(d0, box_len[0], periodic[0]),
                minimum_image(d1, box_len[1], periodic[1]),
                minimum_image(d2, box_len[2], periodic[2]))
    return d0, d1, d2


@njit(cache=True, parallel=True)
def wrap_periodic(x, image, lo, length, periodic):
    """Fold positions on periodic axes into ``[lo, lo + L)``: ``x -= s L`` and
    ``image += s`` with ``s = floor((x - lo) / L)``, only where ``s`` is not zero (one
    compiled pass; numpy's whole-column form took half a millisecond on 32k grains)."""
    for i in prange(x.shape[0]):
        for a in range(3):
            if periodic[a]:
                s = np.floor((x[i, a] - lo[a]) / length[a])
                if s != 0.0:
                    x[i, a] -= s * length[a]
                    image[i, a] += np.int64(s)


@njit(cache=True, parallel=True)
def cell_coordinates(x, lo, cell_size, ncell, periodic):
    """Integer cell coordinates (N, 3); periodic axes are folded into [0, ncell)."""
    n = x.shape[0]
    c = np.empty((n, 3), dtype=np.int64)
    for i in prange(n):
        for a in range(3):
            ca = np.int64(np.floor((x[i, a] - lo[a]) / cell_size[a]))
            if periodic[a]:
                ca = ca % ncell[a]
            c[i, a] = ca
    return c


@njit(cache=True)
def coordinate_bounds(c):
    """Smallest and largest cell coordinate along each axis of ``c`` (N >= 1, 3): one pass,
    where numpy's ``min(axis=0)`` and ``max(axis=0)`` take a millisecond on 32k rows."""
    lo = c[0].copy()
    hi = c[0].copy()
    for i in range(1, c.shape[0]):
        for a in range(3):
            lo[a] = min(lo[a], c[i, a])
            hi[a] = max(hi[a], c[i, a])
    return lo, hi


@njit(cache=True, parallel=True)
def linear_keys(c, cmin, extent):
    """Linearise cell coordinates into int64 keys (row-major over x, y, z)."""
    n = c.shape[0]
    keys = np.empty(n, dtype=np.int64)
    for i in prange(n):
        keys[i] = ((c[i, 0] - cmin[0]) * extent[1] + (c[i, 1] - cmin[1])) * extent[2] + (
            c[i, 2] - cmin[2])
    return keys


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


@njit(cache=True)
def _slot(key, bits):
    """Multiplicative (Fibonacci) hash of a cell key into ``bits`` bits."""
    return np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(64 - bits))


@njit(cache=True)
def cell_hash(cell_keys):
    """Open-addressing hash table of the occupied cells: slot -> cell index (-1 empty).

    Its size is the next power of two above twice the number of occupied cells, so
    memory stays proportional to the particles, never to the volume.
    """
    nc = cell_keys.shape[0]
    bits = 4
    while (1 << bits) < 2 * nc:
        bits += 1
    mask = (1 << bits) - 1
    slots = np.full(1 << bits, -1, dtype=np.int64)
    for c in range(nc):
        h = _slot(cell_keys[c], bits)
        while slots[h] != -1:
            h = (h + 1) & mask
        slots[h] = c
    return slots, bits


@njit(cache=True)
def _lookup(slots, bits, cell_keys, key):
    """Cell index of ``key`` or -1."""
    mask = (1 << bits) - 1
    h = _slot(key, bits)
    while True:
        c = slots[h]
        if c == -1:
            return -1
        if cell_keys[c] == key:
            return c
        h = (h + 1) & mask


#: The cells are looked up in a dense array over the occupied cells' bounding box (instead
#: of a hash table) when the box holds at most this many cells per occupied cell.
DENSE_CELLS_PER_OCCUPIED = 8


@njit(cache=True)
def dense_cell_index(cell_keys, n_keys):
    """``at[key]`` = index of the occupied cell with that key, -1 for an empty one."""
    at = np.full(n_keys, -1, dtype=np.int64)
    for c in range(cell_keys.shape[0]):
        at[cell_keys[c]] = c
    return at


@njit(cache=True, parallel=True)
def cell_neighbor_table(cell_coords, cell_keys, offsets, cmin, extent, periodic, ncell,
                        dense_limit=DENSE_CELLS_PER_OCCUPIED):
    """For each occupied cell, the indices of its occupied neighbour cells (-1: empty).

    ``cell_coords`` (C, 3) are the integer coordinates of the occupied cells; ``offsets``
    (Q, 3) the stencil (27 cells in 3D, 9 in 2D, fewer on short periodic axes).

    Where the bounding box of the occupied cells holds at most ``dense_limit`` (default
    :data:`DENSE_CELLS_PER_OCCUPIED`) cells per occupied one (a packing, a flowing pile) a
    cell is found by indexing a dense array over the box: about 4x faster than the hash
    table used otherwise (a dilute stream, a jet), whose memory stays proportional to the
    occupied cells. With the hash, consecutive stencil entries along the last axis usually
    have consecutive keys: then the cell after the previous entry's cell is the only
    candidate (``cell_keys`` is sorted), so the hash is consulted about once per run of
    three instead of once per entry.
    """
    nc = cell_keys.shape[0]
    n_keys = extent[0] * extent[1] * extent[2]
    dense = n_keys <= dense_limit * nc
    if dense:
        at = dense_cell_index(cell_keys, n_keys)
        slots, bits = np.full(1, -1, dtype=np.int64), 0
    else:
        at = np.full(1, -1, dtype=np.int64)
        slots, bits = cell_hash(cell_keys)
    nq = offsets.shape[0]
    table = np.empty((nc, nq), dtype=np.int64)
    for c in prange(nc):
        prev_key = np.int64(-2)
        prev_cell = -1
        for q in range(nq):
            key = np.int64(0)
            inside = True
            for a in range(3):
                ca = cell_coords[c, a] + offsets[q, a]
                if periodic[a]:
                    if ca < 0:
                        ca += ncell[a]
                    elif ca >= ncell[a]:
                        ca -= ncell[a]
                ca -= cmin[a]
                if ca < 0 or ca >= extent[a]:
                    inside = False
                key = key * extent[a] + ca
            if not inside:
                found = -1
            elif dense:
                found = at[key]
            elif key == prev_key + 1 and prev_cell >= 0:
                nxt = prev_cell + 1
                found = nxt if nxt < nc and cell_keys[nxt] == key else -1
            else:
                found = _lookup(slots, bits, cell_keys, key)
            table[c, q] = found
            prev_key = key if inside else np.int64(-2)
            prev_cell = found
    return table


@njit(cache=True, parallel=True)
def positions_in_order(x, radius, order):
    """Positions and radii of the particles in the cells' sorted ``order``: the scans read
    a cell's candidates from one contiguous slice of these, not at scattered indices. The
    list is the same."""
    n = order.shape[0]
    x_sorted = np.empty((n, 3))
    r_sorted = np.empty(n)
    for s in prange(n):
        j = order[s]
        x_sorted[s, 0] = x[j, 0]
        x_sorted[s, 1] = x[j, 1]
        x_sorted[s, 2] = x[j, 2]
        r_sorted[s] = radius[j]
    return x_sorted, r_sorted


@njit(cache=True, inline="always")
def _scan(i, x, radius, x_sorted, r_sorted, frozen, body, cell_of, table, cell_start, order,
          box_len, periodic, wrap, margin, out, offset, capacity, in_cell_order):
    """Count the partners j > i of i, storing the first ``capacity`` at ``out[offset:]``.

    The candidates are read from ``x_sorted``, ``r_sorted`` (:func:`positions_in_order`) at
    their sorted positions; ``wrap``: some axis is periodic (else no minimum image is taken).
    With ``in_cell_order`` (particle indices sorted by cell), cells before i's own cell hold
    only lower indices and are skipped.
    """
    count = 0
    c = cell_of[i]
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    ri = radius[i] + margin
    fi = frozen[i]
    bi = body[i]
    for q in range(table.shape[1]):
        cj = table[c, q]
        if cj < 0 or (in_cell_order and cj < c):
            continue
        for s in range(cell_start[cj], cell_start[cj + 1]):
            j = order[s]
            if j <= i:
                continue
            if fi and frozen[j]:
                continue
            if bi >= 0 and body[j] == bi:
                continue
            d0, d1, d2 = _separation(xi0 - x_sorted[s, 0], xi1 - x_sorted[s, 1],
                                     xi2 - x_sorted[s, 2], wrap, box_len, periodic)
            cut = ri + r_sorted[s]
            if d0 * d0 + d1 * d1 + d2 * d2 < cut * cut:
                if count < capacity:
                    out[offset + count] = j
                count += 1
    return count


@njit(cache=True)
def insertion_sort(a, lo, hi):
    """Sort ``a[lo:hi]`` in place (short, nearly sorted runs: list rows, stencils)."""
    for p in range(lo + 1, hi):
        v = a[p]
        q = p - 1
        while q >= lo and a[q] > v:
            a[q + 1] = a[q]
            q -= 1
        a[q + 1] = v


@njit(cache=True, parallel=True)
def _fill_rows(x, radius, x_sorted, r_sorted, frozen, body, cell_of, table, cell_start, order,
               box_len, periodic, wrap, margin, capacity, scratch, counts, in_cell_order):
    """Scan every particle once into a fixed-capacity scratch row; report overflow."""
    n = x.shape[0]
    overflow = 0
    for i in prange(n):
        c = _scan(i, x, radius, x_sorted, r_sorted, frozen, body, cell_of, table, cell_start,
                  order, box_len, periodic, wrap, margin, scratch, i * capacity, capacity,
                  in_cell_order)
        counts[i + 1] = c
        if c > capacity:
            overflow += 1
    return overflow


@njit(cache=True, parallel=True)
def _compact_rows(scratch, capacity, row_ptr, nbr):
    n = row_ptr.shape[0] - 1
    for i in prange(n):
        base = i * capacity
        start = row_ptr[i]
        m = row_ptr[i + 1] - start
        for q in range(m):
            nbr[start + q] = scratch[base + q]
        insertion_sort(nbr, start, start + m)


def build_half_list(x, radius, frozen, body, cell_of, table, cell_start, order, box_len,
                    periodic, margin, capacity=16, in_cell_order=False):
    """Half Verlet list (row_ptr, nbr) with rows sorted ascending; and the row capacity used.

    ``cell_of[i]`` is the occupied-cell index of particle i, ``table`` the cell stencil from
    :func:`cell_neighbor_table`, ``order`` the particles sorted by cell and ``cell_start``
    the start of each cell in ``order``. ``margin`` = interaction reach + skin. Pairs of two
    frozen particles and pairs within one body are left out. ``in_cell_order``: the
    particles are indexed in cell order (just re-sorted), which halves the scan. Each particle is scanned once
    into a scratch row of ``capacity`` slots; rows that overflow trigger one re-scan with
    the capacity the overflow showed was needed (reported, never silently truncated).
    """
    n = x.shape[0]
    x_sorted, r_sorted = positions_in_order(x, radius, order)
    wrap = bool(periodic.any())
    while True:
        counts = np.zeros(n + 1, dtype=np.int64)
        scratch = np.empty(max(n * capacity, 1), dtype=np.int64)
        overflow = _fill_rows(x, radius, x_sorted, r_sorted, frozen, body, cell_of, table,
                              cell_start, order, box_len, periodic, wrap, margin, capacity,
                              scratch, counts, in_cell_order)
        if overflow == 0:
            break
        capacity = int(counts.max()) + 4
    row_ptr = np.cumsum(counts)
    nbr = np.empty(row_ptr[n], dtype=np.int64)
    _compact_rows(scratch, capacity, row_ptr, nbr)
    return row_ptr, nbr, capacity


#: A cell grid is stored densely (every cell of the occupied box, with a ghost layer) when it
#: holds at most this many cells per particle; otherwise the occupied cells are hashed.
DENSE_GRID_CELLS_PER_PARTICLE = 4


@njit(cache=True)
def counting_sort(keys, n_keys):
    """Stable order of ``keys`` (each in ``[0, n_keys)``) and where each key starts in it.

    Returns ``order`` (N,), the particle indices sorted by key, ties in index order (what a
    stable ``argsort`` gives), and ``start`` (n_keys + 1,): the particles of key ``c`` are
    ``order[start[c]:start[c + 1]]``. O(N + n_keys), against O(N log N) for a sort."""
    n = keys.shape[0]
    start = np.zeros(n_keys + 1, dtype=np.int64)
    for i in range(n):
        start[keys[i] + 1] += 1
    for c in range(n_keys):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[fill[keys[i]]] = i
        fill[keys[i]] += 1
    return order, start


@njit(cache=True)
def ghost_cell_ranges(start, extent, periodic):
    """Each cell's slice ``[first, end)`` of the key-sorted particles, ghosts included.

    The grid of ``extent`` cells carries a layer of ghost cells on every axis with
    ``extent > 1``. On an open axis they hold no particle (the counting sort left them
    empty, in place). On a periodic one each ghost names the particles of the cell it is
    the periodic image of (the first real cell for the ghost after the last, the last for
    the ghost before the first; its other coordinates unchanged). A cell's neighbours are
    then at fixed key offsets, with no bounds test and no wrap, and a pair across a periodic
    boundary is found through the ghost (its branch vector needs the minimum image)."""
    first = start[:-1].copy()
    end = start[1:].copy()
    g = np.empty(3, dtype=np.int64)
    for c0 in range(extent[0]):
        for c1 in range(extent[1]):
            for c2 in range(extent[2]):
                g[0] = c0
                g[1] = c1
                g[2] = c2
                ghost = False
                for a in range(3):
                    if periodic[a] and extent[a] > 1:
                        if g[a] == 0:
                            g[a] = extent[a] - 2
                            ghost = True
                        elif g[a] == extent[a] - 1:
                            g[a] = 1
                            ghost = True
                if ghost:
                    src = (g[0] * extent[1] + g[1]) * extent[2] + g[2]
                    key = (c0 * extent[1] + c1) * extent[2] + c2
                    first[key] = start[src]
                    end[key] = start[src + 1]
    return first, end


@njit(cache=True, inline="always")
def _scan_grid(i, x, radius, x_sorted, r_sorted, frozen, body, key, first, end, deltas, order,
               box_len, periodic, wrap, margin, out, used, width, in_cell_order):
    """:func:`_scan` on a dense grid with ghosts (:func:`ghost_cell_ranges`): the cells of
    the stencil are at the key offsets ``deltas``. The partners are appended to ``out``
    from ``used`` on, as long as it has room (``width``); their count is returned. With
    ``in_cell_order`` the particles at sorted positions ``s`` are the indices ``s``
    themselves: only ``j > i`` is read. The exclusions are tested after the distance, which
    rejects most candidates.

    Three cells at consecutive keys (neighbours along the last axis) whose particle slices
    follow one another (no ghost among them, or ghosts that hold nothing) are read as one
    slice: the same candidates in the same order, with a third of the cell visits. At about
    one particle per cell the visits cost as much as the candidates (on the chute a build
    8.1 -> 6.5 ms on one thread).

    Inlined into the row loop (``inline="always"``): called once per particle with twenty
    arguments, the call cost about as much as the scan of a small system. With the
    candidates read from :func:`positions_in_order` and the minimum image taken only in a
    periodic box, the scan of the hopper study's 1,600 disks fell from 0.28 to 0.18 ms and
    of its 6,400 spheres from 2.2-2.4 to 1.7-2.0 ms (one thread, AMD EPYC, 2026-12-07)."""
    count = 0
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    ri = radius[i] + margin
    fi = frozen[i]
    bi = body[i]
    nq = deltas.shape[0]
    q = 0
    while q < nq:
        c = key + deltas[q]
        s0 = first[c]
        s1 = end[c]
        if (q + 2 < nq and deltas[q + 2] == deltas[q] + 2 and s1 == first[c + 1]
                and end[c + 1] == first[c + 2]):
            s1 = end[c + 2]
            q += 3
        else:
            q += 1
        if in_cell_order and s0 <= i:
            s0 = i + 1
        for s in range(s0, s1):
            j = s if in_cell_order else order[s]
            if not in_cell_order and j <= i:
                continue
            d0, d1, d2 = _separation(xi0 - x_sorted[s, 0], xi1 - x_sorted[s, 1],
                                     xi2 - x_sorted[s, 2], wrap, box_len, periodic)
            cut = ri + r_sorted[s]
            if d0 * d0 + d1 * d1 + d2 * d2 < cut * cut:
                if fi and frozen[j]:
                    continue
                if bi >= 0 and body[j] == bi:
                    continue
                if used + count < width:
                    out[used + count] = j
                count += 1
    return count


@njit(cache=True, parallel=True)
def _fill_chunks_grid(x, radius, x_sorted, r_sorted, frozen, body, keys, first, end, deltas,
                      order, box_len, periodic, wrap, margin, buffers, counts, in_cell_order):
    """Scan the rows in one contiguous chunk per buffer row, appending each chunk's rows
    one after the other (sorted ascending) to its buffer: written in sequence, not into a
    fixed-capacity slot per particle. Returns the slots each chunk needed (more than the
    buffer's width: scan again with a wider one)."""
    n = x.shape[0]
    n_chunks = buffers.shape[0]
    width = buffers.shape[1]
    need = np.zeros(n_chunks, dtype=np.int64)
    for t in prange(n_chunks):
        out = buffers[t]
        used = 0
        for i in range((t * n) // n_chunks, ((t + 1) * n) // n_chunks):
            c = _scan_grid(i, x, radius, x_sorted, r_sorted, frozen, body, keys[i], first, end,
                           deltas, order, box_len, periodic, wrap, margin, out, used, width,
                           in_cell_order)
            counts[i + 1] = c
            if used + c <= width:
                insertion_sort(out, used, used + c)
            used += c
        need[t] = used
    return need


@njit(cache=True)
def _join_chunks(buffers, need, total):
    """The chunks' rows one after the other: the list's ``nbr``."""
    nbr = np.empty(total, dtype=np.int64)
    at = 0
    for t in range(buffers.shape[0]):
        nbr[at:at + need[t]] = buffers[t, :need[t]]
        at += need[t]
    return nbr


def build_half_list_grid(x, radius, frozen, body, keys, first, end, deltas, order, box_len,
                         periodic, margin, capacity=16, in_cell_order=False, n_chunks=1):
    """:func:`build_half_list` on a dense grid with ghosts: ``keys`` (N,) each particle's
    cell, ``first``/``end`` every cell's slice of the key-sorted ``order``
    (:func:`ghost_cell_ranges`), ``deltas`` the stencil's key offsets. The rows are scanned
    in ``n_chunks`` contiguous chunks (one per thread) into buffers of ``capacity`` slots
    per row on average; a chunk that needs more is scanned again with what it needed.
    The list does not depend on ``n_chunks``."""
    n = x.shape[0]
    n_chunks = max(1, min(n_chunks, n))
    x_sorted, r_sorted = positions_in_order(x, radius, order)
    wrap = bool(periodic.any())
    while True:
        counts = np.zeros(n + 1, dtype=np.int64)
        width = max((n // n_chunks + 1) * capacity, 1)
        buffers = np.empty((n_chunks, width), dtype=np.int64)
        need = _fill_chunks_grid(x, radius, x_sorted, r_sorted, frozen, body, keys, first, end,
                                 deltas, order, box_len, periodic, wrap, margin, buffers, counts,
                                 in_cell_order)
        if need.max(initial=0) <= width:
            break
        capacity = int(need.max()) // (n // n_chunks + 1) + 2
    row_ptr = np.cumsum(counts)
    return row_ptr, _join_chunks(buffers, need, int(row_ptr[n])), capacity


@njit(cache=True)
def transpose_index(row_ptr, nbr, n):
    """For each particle, the pair slots where it is the second member (counting sort).

    Returns ``col_ptr`` (N+1,) and ``col_pair`` (P,): the slots of particle j's column are
    ``col_pair[col_ptr[j]:col_ptr[j + 1]]``, ascending; the inverse ``pair_col`` (P,), the
    column position of each slot (``col_pair[pair_col[k]] == k``); and ``col_span`` (N, 2),
    the first and last row in particle j's column (``n, -1`` for an empty column).
    """
    col_ptr = np.zeros(n + 1, dtype=np.int64)
    for k in range(nbr.shape[0]):
        col_ptr[nbr[k] + 1] += 1
    for i in range(n):
        col_ptr[i + 1] += col_ptr[i]
    fill = col_ptr[:-1].copy()
    col_pair = np.empty(nbr.shape[0], dtype=np.int64)
    pair_col = np.empty(nbr.shape[0], dtype=np.int64)
    col_span = np.empty((n, 2), dtype=np.int64)
    col_span[:, 0] = n
    col_span[:, 1] = -1
    for i in range(n):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            j = nbr[k]
            col_pair[fill[j]] = k
            pair_col[k] = fill[j]
            fill[j] += 1
            col_span[j, 0] = min(col_span[j, 0], i)
            col_span[j, 1] = i
    return col_ptr, col_pair, pair_col, col_span


@njit(cache=True, parallel=True)
def carry_history(old_ptr, old_nbr, old_hist, new_ptr, new_nbr, new_hist):
    """Copy per-pair history from an old list to a new one, matching (i, j) by merge.

    Both lists are in the same particle indexing with rows sorted ascending. Pairs absent
    from the old list start with zero history.
    """
    n = new_ptr.shape[0] - 1
    width = new_hist.shape[1]
    for i in prange(n):
        a = old_ptr[i] if i < old_ptr.shape[0] - 1 else 0
        a_end = old_ptr[i + 1] if i < old_ptr.shape[0] - 1 else 0
        for k in range(new_ptr[i], new_ptr[i + 1]):
            j = new_nbr[k]
            while a < a_end and old_nbr[a] < j:
                a += 1
            if a < a_end and old_nbr[a] == j:
                for h in range(width):
                    new_hist[k, h] = old_hist[a, h]
            else:
                for h in range(width):
                    new_hist[k, h] = 0.0


@njit(cache=True, parallel=True)
def carry_history_permuted(old_ptr, old_nbr, old_hist, new_to_old, flip, new_ptr, new_nbr,
                           new_hist, active):
    """Carry per-pair history across a re-sort of the particles and a list rebuild at once.

    The old list (rows sorted ascending, ``i < j``) is in the old particle indexing, the new
    one in the new indexing, ``new_to_old[a]`` the old index of new particle ``a``. The old
    pair ``(p, q)`` is the new pair ``(a, b) = (old_to_new[p], old_to_new[q])``, found in
    new row ``min(a, b)``; when ``a > b`` the components with ``flip = -1`` change sign (as
    in :func:`reindex_pairs`). Every other new pair, and every old pair with an all-zero
    history, starts with zero history. ``active[k]`` is set to 1 where the carried history
    is non-zero, else 0.

    The histories are scattered from the old pairs that hold one (those in contact: an
    eighth of the chute's pairs) instead of gathered by a search for every new pair: on the
    chute 1.8 -> 0.5 ms a build on one thread. Each new slot is written by at most one old
    pair (the re-sort is a permutation), so the result does not depend on the threads.
    """
    n = new_ptr.shape[0] - 1
    n_old = old_ptr.shape[0] - 1
    width = new_hist.shape[1]
    old_to_new = np.full(n_old, -1, dtype=np.int64)
    for a in range(n):
        if new_to_old[a] < n_old:
            old_to_new[new_to_old[a]] = a
    for k in prange(new_nbr.shape[0]):
        active[k] = 0
        for h in range(width):
            new_hist[k, h] = 0.0
    for p in prange(n_old):
        for s in range(old_ptr[p], old_ptr[p + 1]):
            nonzero = False
            for h in range(width):
                if old_hist[s, h] != 0.0:
                    nonzero = True
            if not nonzero:
                continue
            a = old_to_new[p]
            b = old_to_new[old_nbr[s]]
            if a < 0 or b < 0:
                continue
            lo = min(a, b)
            hi = max(a, b)
            for k in range(new_ptr[lo], new_ptr[lo + 1]):
                if new_nbr[k] >= hi:
                    if new_nbr[k] == hi:
                        for h in range(width):
                            new_hist[k, h] = (old_hist[s, h] if a < b
                                              else flip[h] * old_hist[s, h])
                        active[k] = 1
                    break


@njit(cache=True)
def reindex_pairs(row_ptr, nbr, hist, old_to_new, flip):
    """Re-express stored pairs after particles were permuted or deleted.

    Returns a list (row_ptr, nbr, hist) in the new indexing with rows sorted ascending and
    i < j; history components with ``flip = -1`` change sign when i and j swap roles (vector
    quantities defined along the branch vector x_i - x_j). Only pairs with some non-zero
    history are kept: the rest carries no information.
    """
    n_old = row_ptr.shape[0] - 1
    width = hist.shape[1]
    n_new = 0
    for i in range(old_to_new.shape[0]):
        if old_to_new[i] + 1 > n_new:
            n_new = old_to_new[i] + 1
    m = 0
    for i in range(n_old):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            if old_to_new[i] < 0 or old_to_new[nbr[k]] < 0:
                continue
            for h in range(width):
                if hist[k, h] != 0.0:
                    m += 1
                    break
    pi = np.empty(m, dtype=np.int64)
    pj = np.empty(m, dtype=np.int64)
    ph = np.empty((m, width))
    m = 0
    for i in range(n_old):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            a = old_to_new[i]
            b = old_to_new[nbr[k]]
            if a < 0 or b < 0:
                continue
            nonzero = False
            for h in range(width):
                if hist[k, h] != 0.0:
                    nonzero = True
            if not nonzero:
                continue
            if a < b:
                pi[m] = a
                pj[m] = b
                for h in range(width):
                    ph[m, h] = hist[k, h]
            else:
                pi[m] = b
                pj[m] = a
                for h in range(width):
                    ph[m, h] = flip[h] * hist[k, h]
            m += 1
    order = np.argsort(pi * (n_new + 1) + pj)
    new_ptr = np.zeros(n_new + 1, dtype=np.int64)
    for q in range(m):
        new_ptr[pi[q] + 1] += 1
    for i in range(n_new):
        new_ptr[i + 1] += new_ptr[i]
    new_nbr = np.empty(m, dtype=np.int64)
    new_hist = np.empty((m, width))
    for q in range(m):
        s = order[q]
        new_nbr[q] = pj[s]
        for h in range(width):
            new_hist[q, h] = ph[s, h]
    return new_ptr, new_nbr, new_hist


@njit(cache=True, parallel=True)
def rows_crossing_periodic(row_ptr, nbr, x, box_len, periodic):
    """Per row ``i``: 1 if some listed pair ``(i, j)`` has ``|x_i - x_j| > L/2`` along a
    periodic axis (it reaches across the boundary, so its branch vector needs the minimum
    image), else 0.

    Valid until the next build: positions are folded into the box only at a build, and
    between two builds no listed pair moves more than the skin against each other (under
    either check, :mod:`grainflow.kernels.list_check`), so a pair's raw difference stays
    near 0 (a pair inside the box) or near ``L`` (across it)."""
    n = row_ptr.shape[0] - 1
    out = np.zeros(n, dtype=np.uint8)
    for i in prange(n):
        for k in range(row_ptr[i], row_ptr[i + 1]):
            j = nbr[k]
            for a in range(3):
                if periodic[a] and abs(x[i, a] - x[j, a]) > 0.5 * box_len[a]:
                    out[i] = 1
    return out


@njit(cache=True, parallel=True)
def max_displacement_sq(x, x_ref, box_len, periodic):
    """Largest squared displacement since the last list build (minimum image)."""
    best = 0.0
    for i in prange(x.shape[0]):
        s = 0.0
        for a in range(3):
            d = minimum_image(x[i, a] - x_ref[i, a], box_len[a], periodic[a])
            s += d * d
        best = max(best, s)
    return best
