"""Tethered particle walls (SPEC M5; seed 002, Chapter 3, the paragraph on the wall).

Seed 002 builds the jet's target from "one layer of DEM particles with the same diameter d
and the same mass m, which are connected to each other and with their own initial positions
via the spring and the dashpot with spring constant k_w = 10.0 m u0^2/d^2 and the dashpot
constant eta_w = 5.0 eta_n". Each listed particle i feels

.. math::  \\mathbf F_i = -k_w (\\mathbf x_i - \\mathbf x_i^{anchor}) - \\eta_w \\mathbf v_i

and each bonded pair (i, j), with ``d = x_i - x_j``, ``n = d/|d|``, ``l0`` the initial
distance and ``v_rel = v_i - v_j``:

.. math::  \\mathbf F_i = -\\mathbf F_j
           = -k_w (|\\mathbf d| - l_0)\\,\\hat n - \\eta_w (\\mathbf v_{rel}\\cdot\\hat n)\\,\\hat n .

A tethered particle displaced along a free axis therefore oscillates at
``omega_d = sqrt(k_w/m - (eta_w/2m)^2)`` and decays at the rate ``eta_w/(2m)``.

Wall-wall pairs must interact only through the tethers (seed 002: "the interaction between
a grain and a wall particle is calculated via DEM, while that between wall particles is done
only via the spring"). Give all wall particles one shared ``body`` id >= 0 when adding them,
``sim.add_particles(x, r, mass=m, body=b)``: the neighbour list skips pairs within one body,
so the contact law never sees wall-wall pairs. :class:`Tethers` checks this unless
``allow_wall_contacts=True``.

Anchors and bonds are stored by particle *id* and resolved to indices whenever
``state.generation`` changes, so re-sorting, insertion and deletion are safe; a deleted
particle's tether and bonds are dropped. Displacements use the minimum image on periodic
axes.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

from grainflow.engine.operations import ContactRows, Force, ForceContext, TimeScale
from grainflow.frame import ANCHOR, BOND
from grainflow.kernels.neighbors import minimum_image
from grainflow.state import ParticleState


@njit(cache=True, parallel=True)
def _anchor_forces(idx, anchor, k, eta, x, v, frozen, box_len, periodic, force):
    """``F_i -= k (x_i - anchor) + eta v_i`` for each tethered index (-1: deleted)."""
    for a in prange(idx.shape[0]):
        i = idx[a]
        if i < 0 or frozen[i]:
            continue
        for c in range(3):
            d = minimum_image(x[i, c] - anchor[a, c], box_len[c], periodic[c])
            force[i, c] -= k * d + eta * v[i, c]


@njit(cache=True)
def _bond_forces(pairs, l0, k, eta, x, v, frozen, box_len, periodic, force):
    """Bond springs and dashpots along the bond; serial, as each bond writes to two
    particles (a one-layer target holds few bonds)."""
    for b in range(pairs.shape[0]):
        i = pairs[b, 0]
        j = pairs[b, 1]
        if i < 0 or j < 0:
            continue
        d0 = minimum_image(x[i, 0] - x[j, 0], box_len[0], periodic[0])
        d1 = minimum_image(x[i, 1] - x[j, 1], box_len[1], periodic[1])
        d2 = minimum_image(x[i, 2] - x[j, 2], box_len[2], periodic[2])
        r = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        n0 = d0 / r
        n1 = d1 / r
        n2 = d2 / r
        vn = (v[i, 0] - v[j, 0]) * n0 + (v[i, 1] - v[j, 1]) * n1 + (v[i, 2] - v[j, 2]) * n2
        s = -k * (r - l0[b]) - eta * vn
        if not frozen[i]:
            force[i, 0] += s * n0
            force[i, 1] += s * n1
            force[i, 2] += s * n2
        if not frozen[j]:
            force[j, 0] -= s * n0
            force[j, 1] -= s * n1
            force[j, 2] -= s * n2


def neighbor_bonds(state: ParticleState, ids: np.ndarray, cutoff: float) -> np.ndarray:
    """Pairs (B, 2) of the given particle ids whose centres are closer than ``cutoff``
    (seed 002's wall particles are tied "to each other": use ``cutoff`` a little above the
    lattice spacing)."""
    idx = _indices_of(state, np.asarray(ids, dtype=np.int64), "ids")
    pairs = cKDTree(state.x[idx]).query_pairs(float(cutoff), output_type="ndarray")
    return np.asarray(ids, dtype=np.int64)[pairs.reshape(-1, 2)]


def _indices_of(state: ParticleState, ids: np.ndarray, name: str) -> np.ndarray:
    """Current indices of ``ids``; ValueError naming ``name`` if one does not exist."""
    idx = _resolve(state.id, ids)
    if np.any(idx < 0):
        raise ValueError(f"{name}: particle id(s) {ids[idx < 0][:5].tolist()} do not exist; "
                         "add the particles before attaching the tethers")
    return idx


def _resolve(all_ids: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Index of each id in ``all_ids`` (-1 where absent)."""
    if all_ids.size == 0:
        return np.full(ids.shape, -1, dtype=np.int64)
    order = np.argsort(all_ids, kind="stable")
    idx = order[np.minimum(np.searchsorted(all_ids, ids, sorter=order), all_ids.size - 1)]
    return np.where(all_ids[idx] == ids, idx, -1).astype(np.int64)


class Tethers(Force):
    """Springs ``k`` and dashpots ``eta`` tying particles to anchors and to each other (M5).

    Parameters
    ----------
    ids:
        Particle ids (``state.id``) of the tethered particles, e.g. ``state.id[idx]`` for
        the indices returned by ``sim.add_particles``.
    k, eta:
        Spring constant ``k_w`` and dashpot constant ``eta_w`` (seed 002: ``k_w = 10 m
        u0^2/d^2``, ``eta_w = 5 eta_n``); the same for anchors and bonds.
    anchors:
        (M, dim) anchor points; default: the particles' positions when the force is added.
    bonds:
        (B, 2) pairs of ids tied by springs of rest length equal to their distance when the
        force is added (see :func:`neighbor_bonds`); default none.
    allow_wall_contacts:
        Skip the check that all tethered particles share one ``body`` id >= 0 (which keeps
        wall-wall pairs out of the contact law, as M5 requires).
    """

    def __init__(self, ids: np.ndarray, k: float, eta: float = 0.0, *,
                 anchors: np.ndarray | None = None, bonds: np.ndarray | None = None,
                 allow_wall_contacts: bool = False) -> None:
        self.ids = np.asarray(ids, dtype=np.int64).ravel()
        if self.ids.size == 0:
            raise ValueError("ids: no particles given; list the ids of the wall particles")
        if np.unique(self.ids).size != self.ids.size:
            raise ValueError("ids: an id is listed twice; each particle has one anchor")
        if not (k >= 0 and np.isfinite(k)):
            raise ValueError(f"k: {k!r} is not valid; expected a non-negative spring constant")
        if not (eta >= 0 and np.isfinite(eta)):
            raise ValueError(f"eta: {eta!r} is not valid; expected a non-negative dashpot "
                             "constant")
        self.k = float(k)
        self.eta = float(eta)
        self.anchor = None if anchors is None else np.asarray(anchors, dtype=float)
        self.bond_ids = (np.zeros((0, 2), dtype=np.int64) if bonds is None
                         else np.asarray(bonds, dtype=np.int64).reshape(-1, 2))
        if np.any(~np.isin(self.bond_ids, self.ids)):
            raise ValueError("bonds: every bonded id must also be listed in ids")
        self.allow_wall_contacts = allow_wall_contacts
        self.l0 = np.zeros(0)
        self._generation = -1
        self._idx = np.zeros(0, dtype=np.int64)
        self._pairs = np.zeros((0, 2), dtype=np.int64)

    def setup(self, ctx: ForceContext) -> None:
        """Fix anchors (default: current positions) and rest lengths; check bodies."""
        st = ctx.state
        idx = _indices_of(st, self.ids, "ids")
        if self.anchor is None:
            self.anchor = st.x[idx].copy()
        else:
            a = self.anchor
            if a.ndim != 2 or a.shape[0] != idx.size or a.shape[1] not in (st.dim, 3):
                raise ValueError(f"anchors: expected shape ({idx.size}, {st.dim}), got {a.shape}")
            full = np.zeros((idx.size, 3))
            full[:, : a.shape[1]] = a
            self.anchor = full
        pairs = _indices_of(st, self.bond_ids.ravel(), "bonds").reshape(-1, 2)
        self.l0 = np.linalg.norm(ctx.geometry.branch(st.x[pairs[:, 0]], st.x[pairs[:, 1]]), axis=1)
        if np.any(self.l0 == 0.0):
            raise ValueError("bonds: a bonded pair sits at one point; bond distinct particles")
        body = st.body[idx]
        if not self.allow_wall_contacts and idx.size > 1 and (
                body[0] < 0 or np.any(body != body[0])):
            raise ValueError(
                "ids: tethered wall particles must share one body id >= 0 so that wall-wall "
                "pairs interact only through the tethers (M5); add them with "
                "sim.add_particles(..., body=b), or pass allow_wall_contacts=True")

    def _refresh_indices(self, st: ParticleState) -> None:
        if st.generation == self._generation:
            return
        self._idx = _resolve(st.id, self.ids)
        self._pairs = _resolve(st.id, self.bond_ids.ravel()).reshape(-1, 2)
        self._generation = st.generation

    def compute(self, ctx: ForceContext, update: bool) -> None:
        st = ctx.state
        self._refresh_indices(st)
        g = ctx.geometry
        _anchor_forces(self._idx, self.anchor, self.k, self.eta, st.x, st.v, st.frozen,
                       g.length, g.periodic, st.force)
        if self._pairs.shape[0]:
            _bond_forces(self._pairs, self.l0, self.k, self.eta, st.x, st.v, st.frozen,
                         g.length, g.periodic, st.force)

    def contacts(self, ctx: ForceContext) -> list[ContactRows]:
        """Anchor springs (partner -1, branch from the anchor to the particle) and bonds
        (branch from j to i), with the force each exerts on its particle i."""
        st = ctx.state
        self._refresh_indices(st)
        a = self._idx[self._idx >= 0]
        anchor = self.anchor[self._idx >= 0]
        d = ctx.geometry.branch(st.x[a], anchor)
        f = -self.k * d - self.eta * st.v[a]
        f[st.frozen[a]] = 0.0
        rows = [ContactRows(a, np.full(a.size, -1), ANCHOR, f, d)]
        pairs = self._pairs[np.all(self._pairs >= 0, axis=1)]
        if pairs.size:
            i, j = pairs[:, 0], pairs[:, 1]
            d = ctx.geometry.branch(st.x[i], st.x[j])
            r = np.linalg.norm(d, axis=1)
            n = d / r[:, None]
            vn = np.einsum("ij,ij->i", st.v[i] - st.v[j], n)
            l0 = self.l0[np.all(self._pairs >= 0, axis=1)]
            rows.append(ContactRows(i, j, BOND, (-self.k * (r - l0) - self.eta * vn)[:, None] * n,
                                    d))
        return rows

    def potential_energy(self, ctx: ForceContext) -> float:
        """Spring energy ``k s^2 / 2`` of every anchor (``s = |x - anchor|``) and every bond
        (``s = |x_i - x_j| - l0``); anchors do not move, so tethers supply no energy."""
        st = ctx.state
        self._refresh_indices(st)
        held = self._idx >= 0
        a = self._idx[held]
        s2 = float(np.sum(ctx.geometry.branch(st.x[a], self.anchor[held]) ** 2))
        whole = np.all(self._pairs >= 0, axis=1)
        pairs = self._pairs[whole]
        if pairs.size:
            r = np.linalg.norm(ctx.geometry.branch(st.x[pairs[:, 0]], st.x[pairs[:, 1]]),
                               axis=1)
            s2 += float(np.sum((r - self.l0[whole]) ** 2))
        return 0.5 * self.k * s2

    def time_scales(self, ctx: ForceContext) -> list[TimeScale]:
        """Half period ``pi / sqrt(k lambda)`` and relaxation time ``1 / (eta lambda)`` of the
        fastest mode of the tethered particles, ``lambda`` the largest eigenvalue of
        ``M^(-1/2) L M^(-1/2)``: ``L`` the linearised coupling of the anchors (identity) and
        bonds (``(e_i - e_j)(e_i - e_j)^T (x) n n^T``), the same for springs and dashpots.
        (Gershgorin's bound ``(1 + 2 z) / m`` for ``z`` bonds overestimates it about twice
        on a triangular target, which made seed 002's dt look unsafe.)"""
        st = ctx.state
        self._refresh_indices(st)
        idx = self._idx[self._idx >= 0]
        idx = idx[~st.frozen[idx]]
        if idx.size == 0 or self.k == 0 and self.eta == 0:
            return []
        lam = self._largest_mode(ctx, idx)
        out = []
        if self.k > 0:
            out.append(TimeScale(np.pi / np.sqrt(self.k * lam), "oscillation",
                                 f"tethers (k = {self.k:g})"))
        if self.eta > 0:
            out.append(TimeScale(1.0 / (self.eta * lam), "relaxation",
                                 f"tethers (eta = {self.eta:g})"))
        return out

    def _largest_mode(self, ctx: ForceContext, idx: np.ndarray) -> float:
        """Largest eigenvalue of ``M^(-1/2) L M^(-1/2)`` (see :meth:`time_scales`) over the
        free tethered particles ``idx``; frozen bond partners act as anchors."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.linalg import ArpackError, eigsh

        st = ctx.state
        dim = st.dim
        slot = np.full(st.n, -1)
        slot[idx] = np.arange(idx.size)
        rows: list[np.ndarray] = [np.arange(idx.size * dim)]
        cols: list[np.ndarray] = [np.arange(idx.size * dim)]
        vals: list[np.ndarray] = [np.ones(idx.size * dim)]
        pairs = self._pairs[np.all(self._pairs >= 0, axis=1)]
        if pairs.size:
            d = ctx.geometry.branch(st.x[pairs[:, 0]], st.x[pairs[:, 1]])[:, :dim]
            nn = np.einsum("ba,bc->bac", d, d) / np.einsum("ba,ba->b", d, d)[:, None, None]
            a, c = np.meshgrid(np.arange(dim), np.arange(dim), indexing="ij")
            for p, q, sign in ((0, 0, 1.0), (1, 1, 1.0), (0, 1, -1.0), (1, 0, -1.0)):
                sp, sq = slot[pairs[:, p]], slot[pairs[:, q]]
                keep = (sp >= 0) & (sq >= 0)
                rows.append((sp[keep, None, None] * dim + a).ravel())
                cols.append((sq[keep, None, None] * dim + c).ravel())
                vals.append((sign * nn[keep]).ravel())
        scale = np.repeat(1.0 / np.sqrt(st.mass[idx]), dim)
        rows_a, cols_a = np.concatenate(rows), np.concatenate(cols)
        matrix = coo_matrix((np.concatenate(vals) * scale[rows_a] * scale[cols_a],
                             (rows_a, cols_a)), shape=(idx.size * dim,) * 2).tocsr()
        if matrix.shape[0] <= 64:
            return float(np.linalg.eigvalsh(matrix.toarray())[-1])
        try:
            return float(eigsh(matrix, k=1, which="LA", return_eigenvectors=False,
                               tol=1e-6)[0])
        except ArpackError:  # not converged: Gershgorin's bound, always safe
            return float(np.abs(matrix).sum(axis=1).max())

    def state_dict(self) -> dict[str, Any]:
        return {"ids": self.ids.copy(), "anchor": self.anchor.copy(),
                "bond_ids": self.bond_ids.copy(), "l0": self.l0.copy()}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        self.ids = np.asarray(data["ids"], dtype=np.int64)
        self.anchor = np.asarray(data["anchor"], dtype=np.float64).reshape(-1, 3)
        self.bond_ids = np.asarray(data["bond_ids"], dtype=np.int64).reshape(-1, 2)
        self.l0 = np.asarray(data["l0"], dtype=np.float64)
        self._generation = -1
