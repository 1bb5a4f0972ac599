"""Viscous normal dashpot: SPEC M1, LAMMPS ``gran/hooke`` (``damping mass_velocity`` /
``velocity`` of ``pair granular``).

.. math::  \\mathbf F^{d}_n = -m_d \\gamma_n v_n \\hat n

with ``m_d = m_eff`` in the ``"mass"`` convention (LAMMPS, seed 000) or ``m_d = 1`` in the
``"absolute"`` convention (seed 002: ``F_n = -k_n u_n - eta_n du_n/dt``). ``m_d`` also
multiplies the tangential dashpot of the law. With a Hooke spring the pair is a damped
oscillator ``m_eff u'' + m_d gamma_n u' + k_n u = 0``
(:func:`grainflow.models.granular.restitution_and_contact_time`).
"""

from __future__ import annotations

from numba import njit

from grainflow.models.submodel import DampingModel, Param


@njit(cache=True, inline="always")
def viscous_mass_factor(tab, ti, tj, c, meff):
    """``m_eff`` in the mass convention, 1 in the absolute one."""
    return meff if tab[ti, tj, c + 1] > 0.0 else 1.0


@njit(cache=True, inline="always")
def viscous_force(tab, ti, tj, c, md, vnnr, rsqinv, vr1, vr2, vr3, vt1, vt2, vt3):
    """Normal dashpot ``m_d gamma_n (v . d) / r^2`` (per unit ``r``, along ``d``)."""
    return md * tab[ti, tj, c] * vnnr * rsqinv, 0.0, 0.0, 0.0


class Viscous(DampingModel):
    name = "viscous"
    summary = "F_n -= m_d gamma_n v_n; m_d = meff ('mass') or 1 ('absolute') (SPEC M1)"
    params = (
        Param("gamma_n", "normal damping: per unit effective mass with damping = 'mass' "
              "(1/s), absolute with 'absolute' (kg/s)", None, default=0.0, group="normal"),
        Param("damping", "convention of every dashpot of the law: 'mass' (m_d = meff, "
              "LAMMPS / seed 000) or 'absolute' (m_d = 1, seed 002)", default="mass",
              choices={"mass": 1.0, "absolute": 0.0}),
    )
    mass_factor = viscous_mass_factor
    force = viscous_force

    @classmethod
    def normal_rate(cls, row: dict[str, float], meff: float) -> float:
        md = meff if row["damping"] > 0 else 1.0
        return md * row["gamma_n"] / (2.0 * meff)
