"""The contacts next to the target, ring by ring: how many, how they are oriented, how many
slide (docs/jets.md, "3D mu* = a I": why grain friction raises the slope a).

On the seed's 3D mesh (:func:`~grainflow.analysis.jet.rheology.layer_fields_3d`: rings
k dr < r < (k+1) dr, dr = R_tar / n_r, in the layer 0 < z < Delta z above the target's
surface), over the frames of a window, for the grain-grain contacts whose contact point
x_c = x_i - b / 2 (b = x_i - x_j, the branch vector) lies in a ring:

* the coordination number Z = 2 N_c / N_g, N_g the grains whose centres lie in the ring's
  cell (both averaged over the frames);
* the fabric tensor F = <n n> (n = b / |b|, Oda 1982) in cylindrical components at the
  contact point, and its normal-force-weighted form F_f = sum f_n |b| n n / sum f_n |b|
  (f_n = F . n > 0 in compression: F is the force on i, along b when the pair is pushed
  apart). The normal forces' part of the contact stress (eq. 5.1, compression positive) is
  sigma_n = (1/V) sum f_n |b| n n, so the -sigma_rz / P they carry is
  mu*_n = -3 F_f,rz / tr F_f: the rz anisotropy of the weighted fabric;
* the sliding fraction: the share of contacts at the Coulomb cap, |F_t| >= (1 - tol) mu |f_n|
  (F_t = F - f_n n; the seed's tangential law caps |F_t| at mu_p |F_n|).

Pure functions of saved frames (their contact listing); no simulation is touched.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from grainflow.analysis.cg.fields import radial_basis, rows_of
from grainflow.analysis.jet.rheology import GRAIN_TYPES
from grainflow.frame import PAIR, Frame

__all__ = ["RingFabric", "pool_fabrics", "ring_fabric_3d"]

#: Relative tolerance of "at the Coulomb cap".
SLIDING_TOLERANCE = 1e-3


@dataclass(frozen=True)
class RingFabric:
    """Per ring (centre ``r`` in units of R_tar): ``coordination`` Z, ``fabric`` and
    ``force_fabric`` (n_r, 3, 3) in (r, theta, z) components, ``sliding`` (the fraction of
    the ring's contacts at the Coulomb cap; nan without friction), ``normal_force`` (mean
    f_n); and what they were taken over: ``contacts`` and ``grains`` counted over all
    frames, ``force_weight`` (sum of f_n |b|) and ``frames``."""

    r: np.ndarray
    coordination: np.ndarray
    fabric: np.ndarray
    force_fabric: np.ndarray
    sliding: np.ndarray
    normal_force: np.ndarray
    contacts: np.ndarray
    grains: np.ndarray
    force_weight: np.ndarray
    frames: int

    @property
    def shear_anisotropy(self) -> np.ndarray:
        """F_rz of the contact normals."""
        return self.fabric[:, 0, 2]

    @property
    def normal_force_mu(self) -> np.ndarray:
        """mu*_n = -3 F_f,rz / tr F_f: the -sigma_rz / P of the contacts' normal forces."""
        return -3.0 * self.force_fabric[:, 0, 2] / np.trace(self.force_fabric, axis1=1, axis2=2)


def _cylindrical(vectors: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``vectors`` (M, 3) in (r, theta, z) components at the points ``at`` (M, 3), about the
    z axis (:func:`~grainflow.analysis.cg.fields.radial_basis`)."""
    return np.einsum("mij,mj->mi", radial_basis(at, 3), vectors)


def ring_fabric_3d(frames: Iterable[Frame], target_radius: float, mu: float, *,
                   layer: float = 5.0, n_r: int = 5,
                   window: tuple[float, float] | None = None,
                   grains: Sequence[int] = GRAIN_TYPES) -> RingFabric:
    """Coordination, fabric, force-weighted fabric and sliding fraction of the grain-grain
    contacts in each ring of the 3D layer (module docstring), over the frames of ``window``
    (inclusive; None: all). ``mu``: the grains' friction coefficient (0: no sliding count).
    """
    if not target_radius > 0 or not layer > 0 or n_r < 1:
        raise ValueError("target_radius and layer must be positive and n_r >= 1; got "
                         f"{target_radius!r}, {layer!r}, {n_r!r}")
    dr = target_radius / n_r
    count = np.zeros(n_r)
    grains_in = np.zeros(n_r)
    fabric = np.zeros((n_r, 3, 3))
    weighted = np.zeros((n_r, 3, 3))
    weight = np.zeros(n_r)
    at_cap = np.zeros(n_r)
    force_sum = np.zeros(n_r)
    used = 0
    for frame in frames:
        if window is not None and not window[0] <= frame.time <= window[1]:
            continue
        if frame.contacts is None:
            raise ValueError(f"frame at t = {frame.time:g} has no contact listing; write "
                             "frames with contacts")
        used += 1
        x = np.asarray(frame.position, dtype=float)
        is_grain = np.isin(frame.type, grains)
        rho = np.hypot(x[:, 0], x[:, 1])
        inside = is_grain & (x[:, 2] > 0) & (x[:, 2] < layer) & (rho < target_radius)
        grains_in += np.bincount((rho[inside] // dr).astype(int), minlength=n_r)[:n_r]
        c = frame.contacts
        pair = np.asarray(c.kind) == PAIR
        ii = rows_of(frame, np.asarray(c.i)[pair])
        jj = rows_of(frame, np.asarray(c.j)[pair])
        both = is_grain[ii] & is_grain[jj]
        ii = ii[both]
        b = np.asarray(c.branch, dtype=float)[pair][both]
        f = np.asarray(c.force, dtype=float)[pair][both]
        point = x[ii] - 0.5 * b
        rp = np.hypot(point[:, 0], point[:, 1])
        keep = (point[:, 2] > 0) & (point[:, 2] < layer) & (rp < target_radius)
        ring = (rp[keep] // dr).astype(int)
        b, f, point = b[keep], f[keep], point[keep]
        length = np.linalg.norm(b, axis=1)
        n = _cylindrical(b / length[:, None], point)
        fc = _cylindrical(f, point)
        fn = np.sum(fc * n, axis=1)  # > 0: the pair is pushed apart (compression)
        ft = np.linalg.norm(fc - fn[:, None] * n, axis=1)
        nn = n[:, :, None] * n[:, None, :]
        w = np.abs(fn) * length
        for k in range(n_r):
            sel = ring == k
            count[k] += sel.sum()
            fabric[k] += nn[sel].sum(axis=0)
            weighted[k] += (w[sel][:, None, None] * nn[sel]).sum(axis=0)
            weight[k] += w[sel].sum()
            force_sum[k] += np.abs(fn[sel]).sum()
            if mu > 0:
                at_cap[k] += np.count_nonzero(ft[sel] >= (1.0 - SLIDING_TOLERANCE) * mu
                                              * np.abs(fn[sel]))
    if used == 0:
        raise ValueError(f"no frame in the window {window!r}")
    with np.errstate(invalid="ignore", divide="ignore"):
        return RingFabric(
            r=(np.arange(n_r) + 0.5) / n_r, coordination=2.0 * count / grains_in,
            fabric=fabric / count[:, None, None], force_fabric=weighted / weight[:, None, None],
            sliding=at_cap / count if mu > 0 else np.full(n_r, np.nan),
            normal_force=force_sum / count, contacts=count.astype(np.int64),
            grains=grains_in.astype(np.int64), force_weight=weight, frames=used)


def _weighted(values: Sequence[np.ndarray], weights: Sequence[np.ndarray]) -> np.ndarray:
    """sum_k w_k v_k / sum_k w_k per ring (rings where a run has no weight skipped)."""
    v = np.array(values, dtype=float)
    w = np.array(weights, dtype=float).reshape((len(weights), -1) + (1,) * (v.ndim - 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sum(np.where(w > 0, v * w, 0.0), axis=0) / w.sum(axis=0)


def pool_fabrics(fabrics: Sequence[RingFabric]) -> RingFabric:
    """Several runs' :class:`RingFabric` (replicas) as one, as if their frames had been
    counted together: Z from the summed contacts and grains, the fabric, sliding fraction
    and mean force weighted by the contacts, the force fabric by the force weights."""
    if not fabrics:
        raise ValueError("pool_fabrics: no fabric given")
    contacts = [f.contacts for f in fabrics]
    count = np.sum(contacts, axis=0)
    grains = np.sum([f.grains for f in fabrics], axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        coordination = 2.0 * count / grains
    return RingFabric(
        r=fabrics[0].r, coordination=coordination,
        fabric=_weighted([f.fabric for f in fabrics], contacts),
        force_fabric=_weighted([f.force_fabric for f in fabrics],
                               [f.force_weight for f in fabrics]),
        sliding=_weighted([f.sliding for f in fabrics], contacts),
        normal_force=_weighted([f.normal_force for f in fabrics], contacts),
        contacts=count, grains=grains,
        force_weight=np.sum([f.force_weight for f in fabrics], axis=0),
        frames=sum(f.frames for f in fabrics))
