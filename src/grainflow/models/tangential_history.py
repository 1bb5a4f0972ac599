"""Tangential spring with history and Coulomb cap: SPEC M1, LAMMPS ``gran/hooke/history``.

A spring ``u_t`` accumulates the tangential relative velocity at the contact point
(including ``omega x r``) over the contact's life and is projected into the current tangent
plane every step; the force

.. math::  \\mathbf F_t = -k_t \\mathbf u_t - m_d \\gamma_t \\mathbf v_t,
           \\qquad |\\mathbf F_t| \\le \\mu |\\mathbf F_n|

is capped by Coulomb's law: when the cap is hit the force is scaled onto it and the spring
is reset to the value that gives the capped force (sliding). This holds for every
combination of ``k_t`` and ``gamma_t`` (with ``k_t = 0`` the capped force is a dashpot's).
The arithmetic follows LAMMPS's ``pair gran/hooke/history`` statement by statement, so the
chute benchmark reproduces LAMMPS's log; unlike LAMMPS (lammps#1631), the spring is written
only when the history advances (``update``), never by a read-only evaluation.
"""

from __future__ import annotations

import math

from numba import njit

from grainflow.models.submodel import Param, TangentialModel


def _default_kt(row: dict[str, float]) -> float:
    """2/7 kn (LAMMPS's default, with normal = 'hooke')"""
    if row.get("normal") != "hooke":
        raise ValueError(f"kt: missing; give the tangential stiffness (the default 2/7 kn "
                         f"holds for normal = 'hooke', not {row.get('normal')!r})")
    return 2.0 / 7.0 * row["kn"]


def _default_gamma_t(row: dict[str, float]) -> float:
    """gamma_n / 2 (LAMMPS's default)"""
    return 0.5 * row.get("gamma_n", 0.0)


@njit(cache=True, inline="always")
def history_force(tab, ti, tj, c, hist, k, h, md, fn, dx, dy, dz, rsqinv, vtr1, vtr2, vtr3,
                  dt, update):
    """Spring + dashpot capped at ``mu fn``; the spring is stored only when ``update``."""
    kt = tab[ti, tj, c]
    gammat = tab[ti, tj, c + 1]
    s1 = hist[k, h]
    s2 = hist[k, h + 1]
    s3 = hist[k, h + 2]
    if update:  # accumulate, then rotate into the tangent plane
        s1 += vtr1 * dt
        s2 += vtr2 * dt
        s3 += vtr3 * dt
        rsht = (s1 * dx + s2 * dy + s3 * dz) * rsqinv
        s1 -= rsht * dx
        s2 -= rsht * dy
        s3 -= rsht * dz
    fs1 = -(kt * s1 + md * gammat * vtr1)
    fs2 = -(kt * s2 + md * gammat * vtr2)
    fs3 = -(kt * s3 + md * gammat * vtr3)
    fs = math.sqrt(fs1 * fs1 + fs2 * fs2 + fs3 * fs3)
    cap = tab[ti, tj, c + 2] * fn
    if fs > cap:
        scale = cap / fs
        if kt > 0.0:
            g = md * gammat / kt
            s1 = scale * (s1 + g * vtr1) - g * vtr1
            s2 = scale * (s2 + g * vtr2) - g * vtr2
            s3 = scale * (s3 + g * vtr3) - g * vtr3
        fs1 *= scale
        fs2 *= scale
        fs3 *= scale
    if update:
        hist[k, h] = s1
        hist[k, h + 1] = s2
        hist[k, h + 2] = s3
    return fs1, fs2, fs3


@njit(cache=True, inline="always")
def history_release(hist, k, h, update):
    """The surfaces separated: the spring is forgotten."""
    if update:
        hist[k, h] = 0.0
        hist[k, h + 1] = 0.0
        hist[k, h + 2] = 0.0


class TangentialHistory(TangentialModel):
    name = "history"
    summary = ("F_t = -kt u_t - m_d gamma_t v_t, |F_t| <= mu |F_n| "
               "(SPEC M1; LAMMPS gran/hooke/history)")
    params = (
        Param("kt", "tangential stiffness", "stiffness", default=_default_kt),
        Param("gamma_t", "tangential damping (same convention as gamma_n)", None,
              default=_default_gamma_t),
        Param("mu", "Coulomb friction coefficient", None, default=0.0),
    )
    history_size = 3
    history_flip = (-1.0, -1.0, -1.0)
    force = history_force
    release = history_release
