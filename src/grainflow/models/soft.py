"""M3 soft particles (seed 003, "SP" model): harmonic repulsion and kinetic friction.

Pair energy (seed 003 eq. 4), with ``sigma_mn = r_m + r_n`` the mean diameter:

.. math::  U = \\frac{\\epsilon}{2}\\left(1 - \\frac{r}{\\sigma_{mn}}\\right)^2
           \\Theta(\\sigma_{mn} - r),
           \\qquad \\mathbf F_m = \\frac{\\epsilon}{\\sigma_{mn}}
           \\left(1 - \\frac{r}{\\sigma_{mn}}\\right)\\hat n .

Walls use the same expression with the wall as a partner of radius 0 (``sigma = r_m``,
i.e. the seed's ``(eps_w/2)(1 - 2 d_w/sigma_m)^2``).

"Kinetic friction" between touching particles (seed 003 eq. 6; velocity-difference damping,
not Coulomb friction):

.. math::  \\mathbf F^{\\mu}_m = -\\mu \\sum_n (\\mathbf v_m - \\mathbf v_n)
           \\Theta(1 - r_{mn}/\\sigma_{mn}).

The viscous drag ``-zeta v`` of the background fluid is a one-body force
(:class:`grainflow.engine.forces.Drag`). No torques: SP particles do not rotate.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from grainflow.models.base import ContactLaw, require

EPSILON, MU_KINETIC = range(2)


@njit(cache=True)
def soft_evaluate(tab, ti, tj, dx, dy, dz, rsq, radi, radj, vr1, vr2, vr3, wi1, wi2, wi3, wj1, wj2, wj3,
                  meff, hist, k, dt, update):
    """Harmonic repulsion + kinetic friction on i (see module docstring)."""
    sigma = radi + radj
    if rsq >= sigma * sigma:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    r = math.sqrt(rsq)
    s = tab[ti, tj, EPSILON] / sigma * (1.0 - r / sigma) / r
    mu = tab[ti, tj, MU_KINETIC]
    return (s * dx - mu * vr1, s * dy - mu * vr2, s * dz - mu * vr3, 0.0, 0.0, 0.0)


class SoftLaw(ContactLaw):
    """Soft harmonic particles with kinetic friction (M3).

    Parameters per type pair: ``epsilon`` (energy scale of the harmonic repulsion) and
    ``mu`` (kinetic-friction coefficient, force per unit relative velocity).
    """

    name = "soft"
    param_names = ("epsilon", "mu")
    history_size = 0
    history_flip = ()

    @property
    def evaluator(self) -> Any:
        return soft_evaluate

    def _row(self, *, epsilon: float, mu: float = 0.0) -> np.ndarray:
        require(epsilon, "epsilon", epsilon > 0, "a positive energy scale")
        require(mu, "mu", mu >= 0, "a non-negative kinetic-friction coefficient")
        return np.array([epsilon, mu])

    def contact_time(self, type_i: int, type_j: int, meff: float, sigma: float) -> float:
        """Half period of the harmonic contact, ``pi sqrt(meff sigma^2 / epsilon)``."""
        eps = self.table[type_i, type_j, EPSILON]
        return math.pi * math.sqrt(meff * sigma**2 / eps)
