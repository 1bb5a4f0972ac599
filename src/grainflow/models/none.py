"""The empty sub-model of the ``damping``, ``tangential`` and ``cohesion`` slots.

A law without a sub-model in one of these slots uses these: they add nothing, keep no
history and compile away (their functions are inlined constants).
"""

from __future__ import annotations

from numba import njit

from grainflow.models.submodel import CohesionModel, DampingModel, TangentialModel


@njit(cache=True, inline="always")
def _unit_mass(tab, ti, tj, c, meff):
    return 1.0


@njit(cache=True, inline="always")
def _no_damping(tab, ti, tj, c, md, vnnr, rsqinv, vr1, vr2, vr3, vt1, vt2, vt3):
    return 0.0, 0.0, 0.0, 0.0


@njit(cache=True, inline="always")
def _no_tangential(tab, ti, tj, c, hist, k, h, md, fn, dx, dy, dz, rsqinv, vtr1, vtr2, vtr3,
                   dt, update):
    return 0.0, 0.0, 0.0


@njit(cache=True, inline="always")
def _nothing_to_release(hist, k, h, update):
    return None


@njit(cache=True, inline="always")
def _no_touch(tab, ti, tj, c, hist, k, h, update):
    return None


@njit(cache=True, inline="always")
def _no_gap_force(tab, ti, tj, c, hist, k, h, rsq, radsum, update):
    return 0.0


class NoDamping(DampingModel):
    name = "none"
    summary = "no dissipation (dashpot mass factor m_d = 1)"
    mass_factor = _unit_mass
    force = _no_damping


class NoTangential(TangentialModel):
    name = "none"
    summary = "frictionless: no tangential force"
    force = _no_tangential
    release = _nothing_to_release


class NoCohesion(CohesionModel):
    name = "none"
    summary = "no attraction"
    touch = _no_touch
    gap_force = _no_gap_force
