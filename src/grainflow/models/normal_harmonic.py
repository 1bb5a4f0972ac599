"""Soft harmonic repulsion: SPEC M3, seed 003 eq. 4.

.. math::  U = \\frac{\\epsilon}{2}\\left(1 - \\frac{r}{\\sigma_{mn}}\\right)^2
           \\Theta(\\sigma_{mn} - r), \\qquad
           \\mathbf F_m = \\frac{\\epsilon}{\\sigma_{mn}}\\left(1 - \\frac{r}{\\sigma_{mn}}\\right)
           \\hat n

with ``sigma_mn = r_m + r_n`` the mean diameter. Walls use the same expression with the wall
as a partner of radius 0 (``sigma = r_m``, i.e. the seed's ``(eps_w/2)(1 - 2 d_w/sigma_m)^2``).

``epsilon_scales`` chooses how the energy scale depends on the pair:

* ``"constant"``: one ``epsilon`` for every pair of the type pair (seed 003 eq. 4 as printed);
* ``"diameter"``: ``epsilon_mn = epsilon * sigma_mn``, so that the force
  ``epsilon (1 - r/sigma_mn)`` has one scale for every size. This is the authors' public code
  (pair force ``spK (1 - r/sigma_mn)``; docs/hopper_study.md, "Second pass"); ``epsilon`` is then a force, and in units of sigma_avg it is
  the energy scale of a pair of mean diameter sigma_avg. For a wall partner
  ``sigma = r_m``: ``epsilon_w,m = epsilon r_m``.

So ``epsilon``'s dimension follows ``epsilon_scales`` (``Param.dimension_by``): a config
table with units writes an energy (``"2 J"``) with ``"constant"`` and a force (``"2 nN"``)
with ``"diameter"``, and the other is refused.
"""

from __future__ import annotations

from numba import njit

from grainflow.models.submodel import NormalModel, Param


@njit(cache=True, inline="always")
def harmonic_force(tab, ti, tj, c, r, rinv, radsum, radi, radj):
    """``(epsilon_mn / sigma) (1 - r / sigma) / r`` with ``sigma = r_i + r_j`` and
    ``epsilon_mn = epsilon`` or ``epsilon * sigma`` (module docstring)."""
    if tab[ti, tj, c + 1] > 0.0:
        return tab[ti, tj, c] * (1.0 - r / radsum) * rinv
    return tab[ti, tj, c] / radsum * (1.0 - r / radsum) * rinv


class Harmonic(NormalModel):
    name = "harmonic"
    summary = ("U = (epsilon/2)(1 - r/sigma)^2, sigma = r_i + r_j (SPEC M3; seed 003 eq. 4)")
    params = (Param("epsilon", "energy scale of the harmonic repulsion (with "
                    "epsilon_scales = 'diameter': per unit sigma_mn, a force)",
                    dimension_by=("epsilon_scales", {"constant": "energy",
                                                     "diameter": "force"}),
                    lower=0.0, strict=True, group="normal"),
              Param("epsilon_scales", "'constant': one epsilon per type pair (seed 003 eq. 4); "
                    "'diameter': epsilon_mn = epsilon * sigma_mn, the authors' code (force "
                    "epsilon (1 - r/sigma_mn) for every size)", default="constant",
                    choices={"constant": 0.0, "diameter": 1.0}))
    force = harmonic_force

    @classmethod
    def stiffness(cls, row: dict[str, float], sigma: float) -> float:
        """``epsilon_mn / sigma^2`` (``epsilon_mn = epsilon sigma`` for ``"diameter"``)."""
        scale = sigma if row["epsilon_scales"] > 0.0 else 1.0
        return row["epsilon"] * scale / sigma**2
