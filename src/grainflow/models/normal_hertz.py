"""Hertzian normal force between elastic spheres (LAMMPS ``pair granular`` ``hertz``).

.. math::  \\mathbf F^{el}_n = k_n \\sqrt{R\\,\\delta}\\;\\delta\\,\\hat n,
           \\qquad R = \\frac{r_i r_j}{r_i + r_j}

(``R = r_i`` against a wall), i.e. Hertz's ``F = (4/3) E^* sqrt(R) delta^{3/2}`` with
``k_n = 4 E^*/3`` (Johnson, *Contact Mechanics*, eq. 4.22; LAMMPS manual, ``pair_style
granular``, "hertz"). Without damping a head-on collision at speed ``v`` reaches the
overlap ``delta_max = (5 m_eff v^2 / (4 k_n sqrt(R)))^(2/5)`` (energy: ``m_eff v^2 / 2 =
(2/5) k_n sqrt(R) delta_max^(5/2)``) and lasts ``t_c = 2 (delta_max / v) int_0^1 dx /
sqrt(1 - x^(5/2)) = 2.9432 delta_max / v`` (Johnson eq. 11.24; ``tests/test_hertz.py``).

For the time-step check the stiffness ``dF/d delta = 1.5 k_n sqrt(R delta)`` is taken at
``delta`` = 1 % of the contact distance (:data:`REFERENCE_OVERLAP`), a typical overlap of
dense flows; a Hertzian contact has no contact time independent of the impact speed.
"""

from __future__ import annotations

import math

from numba import njit

from grainflow.models.submodel import NormalModel, Param

#: Overlap, as a fraction of the contact distance, at which the stiffness is evaluated for
#: the time-step check.
REFERENCE_OVERLAP = 0.01


@njit(cache=True, inline="always")
def hertz_force(tab, ti, tj, c, r, rinv, radsum, radi, radj):
    """``k_n sqrt(R delta) delta / r``."""
    delta = radsum - r
    reff = radi * radj / radsum if radj > 0.0 else radi
    return tab[ti, tj, c] * math.sqrt(reff * delta) * delta * rinv


class Hertz(NormalModel):
    name = "hertz"
    summary = "F_n = kn sqrt(R delta) delta, kn = 4E*/3 (Hertz; LAMMPS pair granular hertz)"
    params = (Param("kn", "Hertz stiffness 4 E*/3 (force per length^2)", "pressure",
                    lower=0.0, strict=True, group="normal"),)
    force = hertz_force

    @classmethod
    def stiffness(cls, row: dict[str, float], sigma: float) -> float:
        """``1.5 k_n sqrt(R delta)`` at ``delta = REFERENCE_OVERLAP sigma``, ``R = sigma/4``
        (equal spheres)."""
        return 1.5 * row["kn"] * math.sqrt(0.25 * sigma * REFERENCE_OVERLAP * sigma)
