"""The droplet-length toy model of seed 000 (Sec. IV, Fig. 5; PARAMETERS.md "Toy model").

A slice of stream of length ``L0`` leaving the aperture carries, in its centre-of-mass frame,
the kinetic energy of the free-fall velocity gradient ``gamma = dv/dz``: for a cylinder of
diameter ``D`` at packing fraction ``phi0`` and grain density ``rho``,
``K_i = int_{-L0/2}^{L0/2} (1/2) rho phi0 (pi D^2 / 4) (gamma z)^2 dz
= (pi / 96) rho phi0 D^2 gamma^2 L0^3`` [INF]. The slice becomes one droplet when cohesion
and dissipation can take that energy away; the seed argues that the bonds' energy, the
work of the neighbouring droplets and the losses all scale as ``F_c L0`` to first order,
so ``K_i ~ kappa F_c L0`` and

    L0 = (F_c / Sigma)^(1/2),

with ``Sigma`` a stress (the seed's fit value is lost: "? nN/mm^2", NF). ``L0`` is measured
as the separation of adjacent droplets at the aperture: measured on the droplets' grains when
the pair passes it (:attr:`~grainflow.analysis.stream.traced_pairs.TracedPair.dz0`, the
seed's method), or their forward-tracked line carried back to it
(:attr:`~grainflow.analysis.stream.droplets.DropletSeparation.dz0`), and the model predicts
it equals the grain size d at ``F* = Sigma d^2``, which the seed finds close to the
clustering-to-droplet crossover.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.checks import finite, paired_arrays, positive
from grainflow.analysis.stream.droplets import DropletSeparation
from grainflow.analysis.stream.traced_pairs import TracedPair


def gradient_kinetic_energy(length: ArrayLike, *, density: float, packing_fraction: float,
                            diameter: float, shear_rate: float) -> np.ndarray | float:
    """K_i = (pi/96) rho phi0 D^2 gamma^2 L0^3: the kinetic energy, in its centre-of-mass
    frame, of a stream slice of length L0 with the velocity gradient gamma (module
    docstring; SI units)."""
    out = (math.pi / 96.0) * positive("density", density) \
        * positive("packing_fraction", packing_fraction) * positive("diameter", diameter) ** 2 \
        * finite("shear_rate", shear_rate) ** 2 * np.asarray(length, dtype=float) ** 3
    return float(out) if out.ndim == 0 else out


@dataclass(frozen=True)
class ApertureLength:
    """The droplet length scale at the aperture of one stream: the mean separation of
    adjacent droplets at the aperture (``dz0``), its standard error over the pairs, and how
    many pairs gave it."""

    mean: float
    err: float
    pairs: int


def aperture_length(separations: Sequence[TracedPair | DropletSeparation]) -> ApertureLength:
    """:class:`ApertureLength` from :func:`~grainflow.analysis.stream.trace_droplet_pairs` or
    :func:`~grainflow.analysis.stream.droplet_separations` (pairs without a finite, positive
    ``dz0`` are left out: a traced pair that passed the aperture before the first frame, a
    forward-tracked one without v0 or whose line crosses zero before the aperture)."""
    dz0 = np.array([s.dz0 for s in separations], dtype=float)
    dz0 = dz0[np.isfinite(dz0) & (dz0 > 0)]
    if dz0.size == 0:
        return ApertureLength(float("nan"), float("nan"), 0)
    err = float(np.std(dz0, ddof=1) / math.sqrt(dz0.size)) if dz0.size > 1 else float("nan")
    return ApertureLength(float(dz0.mean()), err, int(dz0.size))


@dataclass(frozen=True)
class ToyModelFit:
    """L0 = (F_c / Sigma)^(1/2) fitted to measured lengths: ``sigma`` (N/m^2) and its
    standard error, the force ``F*`` (N) at which L0 equals ``grain_diameter``, and the
    reduced chi-square (NaN without errors or with one point)."""

    sigma: float
    sigma_err: float
    crossover_force: float
    grain_diameter: float
    chi2_dof: float
    points: int

    def length(self, cohesion_force: ArrayLike) -> np.ndarray:
        """The model's L0 (m) at the forces ``cohesion_force`` (N)."""
        return np.sqrt(np.asarray(cohesion_force, dtype=float) / self.sigma)


def fit_toy_model(cohesion_force: ArrayLike, length: ArrayLike,
                  length_err: ArrayLike | None = None, *,
                  grain_diameter: float) -> ToyModelFit:
    """Fit L0 = p sqrt(F_c), p = Sigma^(-1/2), by (weighted) least squares: linear in p, so
    ``p = sum(w L0 sqrt(F)) / sum(w F)``, ``w = 1/err^2``. The error of p: from
    ``length_err``, inflated by sqrt(chi^2/dof) when that exceeds 1; without errors, from
    the scatter about the line (NaN for one point)."""
    f, lengths = paired_arrays("cohesion_force", cohesion_force, "length", length)
    if f.size == 0 or not np.all(np.isfinite(f) & (f > 0)):
        raise ValueError("cohesion_force: expected at least one positive finite force (N)")
    if not np.all(np.isfinite(lengths) & (lengths > 0)):
        raise ValueError("length: expected positive finite lengths (m)")
    positive("grain_diameter", grain_diameter)
    errs = None
    w = np.ones_like(f)
    if length_err is not None:
        errs = paired_arrays("cohesion_force", f, "length_err", length_err)[1]
        if not np.all(np.isfinite(errs) & (errs > 0)):
            raise ValueError("length_err: expected positive finite errors (m), one per length")
        w = 1.0 / errs ** 2
    root = np.sqrt(f)
    p = float(np.sum(w * lengths * root) / np.sum(w * f))
    dof = f.size - 1
    misfit = float(np.sum(w * (lengths - p * root) ** 2)) / dof if dof > 0 else float("nan")
    if errs is None:  # the scatter about the line
        p_err = math.sqrt(misfit / float(np.sum(f))) if dof > 0 else float("nan")
        chi2 = float("nan")
    else:  # the given errors, inflated by sqrt(chi^2/dof) when the line fits worse
        chi2 = misfit
        p_err = math.sqrt(1.0 / float(np.sum(w * f))) * (math.sqrt(max(1.0, chi2))
                                                         if dof > 0 else 1.0)
    sigma = 1.0 / p ** 2
    sigma_err = 2.0 * sigma * p_err / p if math.isfinite(p_err) else float("nan")
    return ToyModelFit(sigma=sigma, sigma_err=sigma_err,
                       crossover_force=sigma * grain_diameter ** 2,
                       grain_diameter=float(grain_diameter), chi2_dof=chi2,
                       points=int(f.size))
