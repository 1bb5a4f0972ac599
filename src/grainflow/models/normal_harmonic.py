"""Soft harmonic repulsion: SPEC M3, seed 003 eq. 4.

.. math::  U = \\frac{\\epsilon}{2}\\left(1 - \\frac{r}{\\sigma_{mn}}\\right)^2
           \\Theta(\\sigma_{mn} - r), \\qquad
           \\mathbf F_m = \\frac{\\epsilon}{\\sigma_{mn}}\\left(1 - \\frac{r}{\\sigma_{mn}}\\right)
           \\hat n

with ``sigma_mn = r_m + r_n`` the mean diameter. Walls use the same expression with the wall
as a partner of radius 0 (``sigma = r_m``, i.e. the seed's ``(eps_w/2)(1 - 2 d_w/sigma_m)^2``).
"""

from __future__ import annotations

from numba import njit

from grainflow.models.submodel import NormalModel, Param


@njit(cache=True, inline="always")
def harmonic_force(tab, ti, tj, c, r, rinv, radsum, radi, radj):
    """``(epsilon / sigma) (1 - r / sigma) / r`` with ``sigma = r_i + r_j``."""
    return tab[ti, tj, c] / radsum * (1.0 - r / radsum) * rinv


class Harmonic(NormalModel):
    name = "harmonic"
    summary = ("U = (epsilon/2)(1 - r/sigma)^2, sigma = r_i + r_j (SPEC M3; seed 003 eq. 4)")
    params = (Param("epsilon", "energy scale of the harmonic repulsion", "energy", lower=0.0,
                    strict=True, group="normal"),)
    force = harmonic_force

    @classmethod
    def stiffness(cls, row: dict[str, float], sigma: float) -> float:
        """``epsilon / sigma^2``."""
        return row["epsilon"] / sigma**2
