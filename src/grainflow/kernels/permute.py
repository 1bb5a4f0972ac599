"""Parallel row gather used to re-order particle arrays (re-sorting, deletion)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def _take_rows_2d(src, order, dst):
    for q in prange(order.shape[0]):
        s = order[q]
        for c in range(src.shape[1]):
            dst[q, c] = src[s, c]


@njit(cache=True, parallel=True)
def _take_rows_1d(src, order, dst):
    for q in prange(order.shape[0]):
        dst[q] = src[order[q]]


def take_rows(src: np.ndarray, order: np.ndarray) -> np.ndarray:
    """``src[order]`` as a new contiguous array, gathered in parallel for 1-D/2-D arrays."""
    if src.ndim > 2 or src.dtype == np.bool_:
        return np.ascontiguousarray(src[order])
    dst = np.empty((order.shape[0], *src.shape[1:]), dtype=src.dtype)
    if src.ndim == 1:
        _take_rows_1d(src, order, dst)
    else:
        _take_rows_2d(np.ascontiguousarray(src), order, dst)
    return dst
