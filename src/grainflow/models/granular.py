"""M1 linear spring-dashpot with tangential history, plus M2 hysteretic constant-force cohesion.

Normal force (SPEC M1; LAMMPS ``gran/hooke/history``; seed 000 and seed 002 eq. 2.x):

.. math::  \\mathbf F_n = (k_n \\delta - m_d \\gamma_n v_n)\\,\\hat n,
           \\qquad \\delta = r_i + r_j - |\\mathbf d|,\\; \\hat n = \\mathbf d/|\\mathbf d|

with ``m_d = meff`` in the ``"mass"`` damping convention (LAMMPS, seed 000) or ``m_d = 1`` in
the ``"absolute"`` convention (seed 002: ``F_n = -k_n u_n - eta_n du_n/dt``).

Tangential force: a spring ``u_t`` accumulates the tangential relative velocity at the contact
point (including ``omega x r``) over the contact's life, is projected into the current tangent
plane every step, and ``F_t = -k_t u_t - m_d gamma_t v_t`` is capped at ``mu |F_n|``; when the
cap is hit the spring is reset to the value that gives the capped force (Coulomb sliding).
Torques use the full radius as lever arm. The arithmetic follows LAMMPS's
``pair gran/hooke/history`` statement by statement so that the chute benchmark reproduces
LAMMPS's log.

Cohesion (SPEC M2, seed 000 "Model"): once a pair has touched, a constant attractive force
``F_c`` acts along ``-n`` while the surface gap ``s = |d| - r_i - r_j`` satisfies
``0 <= s < delta_c``; it vanishes beyond ``delta_c``, where the pair forgets that it touched,
and never acts on grains approaching for the first time. Separating a touching pair thus
costs exactly ``W = F_c delta_c`` (the seed's statement). We read the seed as cohesion acting
in the gap only (not during overlap); then a head-on pair of equal masses ``m`` is captured
when its incoming speed is below ``v_c = (2/e) sqrt(F_c delta_c / m)`` (PARAMETERS.md).

History row: ``(u_tx, u_ty, u_tz, touched)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from grainflow.models.base import ContactLaw, require

#: Parameter columns of the table.
KN, KT, GAMMA_N, GAMMA_T, MU, FC, DELTA_C, MASS_DAMPING = range(8)


@njit(cache=True, inline="always")  # inlined into the pair loop (kernels.pair_loop)
def granular_evaluate(tab, ti, tj, dx, dy, dz, rsq, radi, radj, vr1, vr2, vr3, wi1, wi2, wi3, wj1, wj2,
                      wj3, meff, hist, k, dt, update):
    """Force on i and torque vector for one pair (see module docstring)."""
    radsum = radi + radj
    if rsq >= radsum * radsum:
        hist[k, 0] = 0.0
        hist[k, 1] = 0.0
        hist[k, 2] = 0.0
        fc = tab[ti, tj, FC]
        if fc > 0.0 and hist[k, 3] > 0.0:
            r = math.sqrt(rsq)
            if r - radsum < tab[ti, tj, DELTA_C]:
                s = -fc / r
                return s * dx, s * dy, s * dz, 0.0, 0.0, 0.0
            if update:
                hist[k, 3] = 0.0
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0

    kn = tab[ti, tj, KN]
    kt = tab[ti, tj, KT]
    md = meff if tab[ti, tj, MASS_DAMPING] > 0.0 else 1.0
    gamman = tab[ti, tj, GAMMA_N]
    gammat = tab[ti, tj, GAMMA_T]
    r = math.sqrt(rsq)
    rinv = 1.0 / r
    rsqinv = 1.0 / rsq

    # relative translational velocity: normal and tangential parts
    vnnr = vr1 * dx + vr2 * dy + vr3 * dz
    vn1 = dx * vnnr * rsqinv
    vn2 = dy * vnnr * rsqinv
    vn3 = dz * vnnr * rsqinv
    vt1 = vr1 - vn1
    vt2 = vr2 - vn2
    vt3 = vr3 - vn3

    # relative rotational velocity
    wr1 = (radi * wi1 + radj * wj1) * rinv
    wr2 = (radi * wi2 + radj * wj2) * rinv
    wr3 = (radi * wi3 + radj * wj3) * rinv

    # normal force = Hookean contact + normal velocity damping
    damp = md * gamman * vnnr * rsqinv
    ccel = kn * (radsum - r) * rinv - damp

    # tangential relative velocity at the contact point
    vtr1 = vt1 - (dz * wr2 - dy * wr3)
    vtr2 = vt2 - (dx * wr3 - dz * wr1)
    vtr3 = vt3 - (dy * wr1 - dx * wr2)

    # tangential spring: accumulate, then rotate into the tangent plane
    if update:
        hist[k, 0] += vtr1 * dt
        hist[k, 1] += vtr2 * dt
        hist[k, 2] += vtr3 * dt
        if tab[ti, tj, FC] > 0.0:
            hist[k, 3] = 1.0
    shrmag = math.sqrt(hist[k, 0] ** 2 + hist[k, 1] ** 2 + hist[k, 2] ** 2)
    rsht = (hist[k, 0] * dx + hist[k, 1] * dy + hist[k, 2] * dz) * rsqinv
    if update:
        hist[k, 0] -= rsht * dx
        hist[k, 1] -= rsht * dy
        hist[k, 2] -= rsht * dz

    # tangential force = spring + tangential damping, capped by Coulomb
    fs1 = -(kt * hist[k, 0] + md * gammat * vtr1)
    fs2 = -(kt * hist[k, 1] + md * gammat * vtr2)
    fs3 = -(kt * hist[k, 2] + md * gammat * vtr3)
    fs = math.sqrt(fs1 * fs1 + fs2 * fs2 + fs3 * fs3)
    fn = tab[ti, tj, MU] * abs(ccel * r)
    if fs > fn:
        if shrmag != 0.0 and kt > 0.0:
            scale = fn / fs
            g = md * gammat / kt
            hist[k, 0] = scale * (hist[k, 0] + g * vtr1) - g * vtr1
            hist[k, 1] = scale * (hist[k, 1] + g * vtr2) - g * vtr2
            hist[k, 2] = scale * (hist[k, 2] + g * vtr3) - g * vtr3
            fs1 *= scale
            fs2 *= scale
            fs3 *= scale
        else:
            fs1 = 0.0
            fs2 = 0.0
            fs3 = 0.0

    fx = dx * ccel + fs1
    fy = dy * ccel + fs2
    fz = dz * ccel + fs3
    c1 = rinv * (dy * fs3 - dz * fs2)
    c2 = rinv * (dz * fs1 - dx * fs3)
    c3 = rinv * (dx * fs2 - dy * fs1)
    return fx, fy, fz, c1, c2, c3


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

    name = "granular"
    param_names = ("kn", "kt", "gamma_n", "gamma_t", "mu", "cohesion_force", "cohesion_range",
                   "mass_damping")
    history_size = 4
    history_flip = (-1.0, -1.0, -1.0, 1.0)

    @property
    def evaluator(self) -> Any:
        return granular_evaluate

    def _row(self, *, kn: float, kt: float | None = None, gamma_n: float = 0.0,
             gamma_t: float | None = None, mu: float = 0.0, cohesion_force: float = 0.0,
             cohesion_range: float = 0.0, damping: str = "mass") -> np.ndarray:
        require(kn, "kn", kn > 0, "a positive normal stiffness")
        kt = 2.0 / 7.0 * kn if kt is None else kt
        gamma_t = 0.5 * gamma_n if gamma_t is None else gamma_t
        require(kt, "kt", kt >= 0, "a non-negative tangential stiffness")
        require(gamma_n, "gamma_n", gamma_n >= 0, "a non-negative damping")
        require(gamma_t, "gamma_t", gamma_t >= 0, "a non-negative damping")
        require(mu, "mu", mu >= 0, "a non-negative friction coefficient")
        require(cohesion_force, "cohesion_force", cohesion_force >= 0, "F_c >= 0")
        require(cohesion_range, "cohesion_range", cohesion_range >= 0, "delta_c >= 0")
        if cohesion_force > 0 and cohesion_range <= 0:
            raise ValueError("cohesion_range: must be > 0 when cohesion_force > 0 "
                             "(the shell delta_c in which the force acts)")
        if damping not in ("mass", "absolute"):
            raise ValueError(f"damping: {damping!r} is not valid; use 'mass' or 'absolute'")
        return np.array([kn, kt, gamma_n, gamma_t, mu, cohesion_force, cohesion_range,
                         1.0 if damping == "mass" else 0.0])

    def reach(self) -> float:
        return float(self.table[:, :, DELTA_C].max())

    def contact_time(self, type_i: int, type_j: int, meff: float, sigma: float) -> float:
        p = self.table[type_i, type_j]
        damping = "mass" if p[MASS_DAMPING] > 0 else "absolute"
        return restitution_and_contact_time(p[KN], p[GAMMA_N], meff, damping)[1]


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
    require(restitution, "restitution", 0 < restitution <= 1, "0 < e <= 1")
    require(contact_time, "contact_time", contact_time > 0, "a positive contact time")
    b = -math.log(restitution) / contact_time
    kn = meff * (math.pi**2 / contact_time**2 + b * b)
    md = meff if damping == "mass" else 1.0
    return kn, 2.0 * meff * b / md
