"""The ``granular`` law (SPEC M1 + M2) and the (restitution, contact time) conversions.

:class:`GranularLaw` is the preset ``hooke`` normal spring + ``viscous`` dashpot + tangential
``history`` with Coulomb cap + ``constant`` hysteretic cohesion
(:mod:`grainflow.models.normal_hooke`, :mod:`~grainflow.models.damping_viscous`,
:mod:`~grainflow.models.tangential_history`, :mod:`~grainflow.models.cohesion_constant`,
composed by :mod:`grainflow.models.compose`). History row: ``(u_tx, u_ty, u_tz, touched)``.
"""

from __future__ import annotations

import math

from grainflow.models.base import ContactLaw
from grainflow.models.submodel import Param

__all__ = ["GranularLaw", "restitution_and_contact_time", "stiffness_and_damping"]


class GranularLaw(ContactLaw):
    """Linear spring-dashpot + tangential history + Coulomb (M1), optional cohesion (M2).

    Parameters per type pair (``set_all`` / ``set_pair``):

    ``kn`` normal stiffness; ``kt`` tangential stiffness (default ``2/7 kn``, LAMMPS's
    default); ``gamma_n`` normal damping (per unit effective mass in the ``"mass"``
    convention, an absolute coefficient in ``"absolute"``); ``gamma_t`` tangential damping
    (default ``gamma_n / 2``); ``mu`` Coulomb friction; ``cohesion_force`` F_c and
    ``cohesion_range`` delta_c (M2; zero disables cohesion); ``damping`` either ``"mass"``
    (``m_d = meff``, LAMMPS / seed 000) or ``"absolute"`` (``m_d = 1``, seed 002).
    """

    def __init__(self, n_types: int = 1) -> None:
        super().__init__(n_types, law="granular")


def restitution_and_contact_time(kn: float, gamma_n: float, meff: float,
                                 damping: str = "mass") -> tuple[float, float]:
    """Normal restitution ``e`` and contact time ``t_c`` of a linear spring-dashpot.

    The overlap obeys ``meff u'' + m_d gamma_n u' + kn u = 0`` (damped oscillator), so with
    ``b = m_d gamma_n / (2 meff)``:

    ``t_c = pi / sqrt(kn/meff - b^2)``, ``e = exp(-b t_c)``.

    Conventions: ``damping="mass"`` has ``m_d = meff`` (LAMMPS gran/hooke; seed 000:
    ``t_c = pi/sqrt(2k_n/m - gamma_n^2/4)``, ``e = exp(-gamma_n t_c/2)`` for equal masses m);
    ``damping="absolute"`` has ``m_d = 1`` (seed 002 with equal masses m:
    ``t_c = pi/sqrt(2k_n/m - eta_n^2/m^2)``, ``e = exp(-eta_n t_c/m)``; with m = 1 this is
    the thesis's ``t_c = pi/sqrt(2k_n - eta_n^2)``, ``e = exp(-eta_n t_c)``).
    """
    md = meff if damping == "mass" else 1.0
    b = md * gamma_n / (2.0 * meff)
    w2 = kn / meff - b * b
    if w2 <= 0:
        raise ValueError("gamma_n: overdamped contact (no rebound); lower the damping")
    tc = math.pi / math.sqrt(w2)
    return math.exp(-b * tc), tc


def stiffness_and_damping(restitution: float, contact_time: float, meff: float,
                          damping: str = "mass") -> tuple[float, float]:
    """Inverse of :func:`restitution_and_contact_time`: ``(kn, gamma_n)`` from ``(e, t_c)``.

    ``b = -ln(e)/t_c``, ``kn = meff (pi^2/t_c^2 + b^2)``, ``gamma_n = 2 meff b / m_d``.
    """
    Param("restitution", "0 < e <= 1", lower=0.0, strict=True, upper=1.0).check(restitution)
    Param("contact_time", "a positive contact time", lower=0.0, strict=True).check(contact_time)
    b = -math.log(restitution) / contact_time
    kn = meff * (math.pi**2 / contact_time**2 + b * b)
    md = meff if damping == "mass" else 1.0
    return kn, 2.0 * meff * b / md
