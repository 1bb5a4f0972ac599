"""Kinetic friction of soft particles: SPEC M3, seed 003 eq. 6.

A velocity-difference damping between touching particles (not Coulomb friction):

.. math::  \\mathbf F^{\\mu}_m = -\\mu_k \\sum_n (\\mathbf v_m - \\mathbf v_n)
           \\Theta(1 - r_{mn}/\\sigma_{mn})

on the full relative velocity (``kinetic_on = "full"``, the seed's equation) or on its part
perpendicular to the branch vector (``"tangential"``, as in the authors' public code; see
PARAMETERS.md). It relaxes the relative velocity of a pair at the rate ``mu_k / m_eff``,
which the time-step check compares with dt. Walls take part like any partner (set ``mu_k``
of the particle-wall type pair to 0 to exclude them, as seed 003 does).
"""

from __future__ import annotations

import math

from numba import njit

from grainflow.models.submodel import DampingModel, Param


@njit(cache=True, inline="always")
def kinetic_mass_factor(tab, ti, tj, c, meff):
    """Dashpots of other slots are absolute (force per unit velocity)."""
    return 1.0


@njit(cache=True, inline="always")
def kinetic_force(tab, ti, tj, c, md, vnnr, rsqinv, vr1, vr2, vr3, vt1, vt2, vt3):
    """``-mu_k v_rel`` (full) or ``-mu_k v_t`` (tangential)."""
    mu = tab[ti, tj, c]
    if tab[ti, tj, c + 1] > 0.0:
        return 0.0, -mu * vr1, -mu * vr2, -mu * vr3
    return 0.0, -mu * vt1, -mu * vt2, -mu * vt3


class KineticFriction(DampingModel):
    name = "kinetic"
    summary = "F -= mu_k (v_i - v_j) while touching (SPEC M3; seed 003 eq. 6)"
    params = (
        Param("mu_k", "kinetic-friction coefficient (force per unit relative velocity)",
              "damping", default=0.0),
        Param("kinetic_on", "'full' relative velocity (seed 003 eq. 6) or its 'tangential' "
              "part", default="full", choices={"full": 1.0, "tangential": 0.0}),
    )
    mass_factor = kinetic_mass_factor
    force = kinetic_force

    @classmethod
    def relaxation_time(cls, row: dict[str, float], meff: float) -> float:
        """``m_eff / mu_k``."""
        return meff / row["mu_k"] if row["mu_k"] > 0 else math.inf
