"""Hysteretic constant-force cohesion: SPEC M2, seed 000 "Model".

Once a pair has touched, a constant attractive force ``F_c`` acts along ``-n`` while the
surface gap ``s = |d| - r_i - r_j`` satisfies ``0 <= s < delta_c``; it vanishes beyond
``delta_c``, where the pair forgets that it touched, and never acts on grains approaching
for the first time. Separating a touching pair thus costs exactly ``W = F_c delta_c`` (the
seed's statement). We read the seed as cohesion acting in the gap only (not during
overlap); then a head-on pair of equal masses ``m`` is captured when its incoming speed is
below ``v_c = (2/e) sqrt(F_c delta_c / m)`` (PARAMETERS.md). The law's reach is
``delta_c``. History: one flag, "touched".
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainflow.models.submodel import CohesionModel, Param


@njit(cache=True, inline="always")
def constant_touch(tab, ti, tj, c, hist, k, h, update):
    """Remember that the pair touched (only when cohesion is on for the type pair)."""
    if update and tab[ti, tj, c] > 0.0:
        hist[k, h] = 1.0


@njit(cache=True, inline="always")
def constant_gap_force(tab, ti, tj, c, hist, k, h, rsq, radsum, update):
    """``-F_c / r`` (force ``-F_c n``) in the shell after touching; forget beyond it."""
    fc = tab[ti, tj, c]
    if fc > 0.0 and hist[k, h] > 0.0:
        r = math.sqrt(rsq)
        if r - radsum < tab[ti, tj, c + 1]:
            return -fc / r
        if update:
            hist[k, h] = 0.0
    return 0.0


class ConstantCohesion(CohesionModel):
    name = "constant"
    summary = "F = -F_c n in the gap 0 <= s < delta_c after touching (SPEC M2; seed 000)"
    params = (
        Param("cohesion_force", "F_c; 0 disables cohesion", "force", default=0.0),
        Param("cohesion_range", "delta_c, the shell in which F_c acts", "length", default=0.0),
    )
    history_size = 1
    history_flip = (1.0,)
    touch = constant_touch
    gap_force = constant_gap_force

    @classmethod
    def check_row(cls, row: dict[str, float]) -> None:
        if row["cohesion_force"] > 0 and not row["cohesion_range"] > 0:
            raise ValueError("cohesion_range: must be > 0 when cohesion_force > 0 (the shell "
                             "delta_c in which the force acts)")

    @classmethod
    def reach(cls, cols: np.ndarray) -> float:
        return float(cols[..., 1].max()) if cols.size else 0.0

    @classmethod
    def crossing_time(cls, row: dict[str, float], meff: float) -> float:
        """``delta_c / u_e``, with ``u_e`` the :func:`escape_speed`. The error of a capture
        grows with ``u_e dt / delta_c`` whatever the restitution: head-on pairs of the
        seed-000 grains whose contact starts at eight points of a step are captured below
        speeds that scatter by 1-2 % of the analytic at 0.12 and by 18-19 % at 1.24, at
        e = 0.88 and 0.40 alike, while the mean stays within 3 %
        (``scripts/stream_shell_resolution.py``, docs/streams.md)."""
        fc, delta = row["cohesion_force"], row["cohesion_range"]
        if fc <= 0.0:
            return math.inf
        return delta / escape_speed(fc, delta, meff)


def escape_speed(cohesion_force: float, cohesion_range: float, meff: float) -> float:
    """``u_e = sqrt(2 F_c delta_c / m_eff)``: the slowest relative speed at which a pair of
    effective mass ``m_eff`` that leaves contact gets out of the shell (its kinetic energy
    pays ``W = F_c delta_c``)."""
    return math.sqrt(2.0 * cohesion_force * cohesion_range / meff)


def capture_velocity(cohesion_force: float, cohesion_range: float, mass: float,
                     restitution: float) -> float:
    """``v_c = (2/e) sqrt(F_c delta_c / m)``: the head-on approach speed below which two
    grains of mass ``m`` stay bound (PARAMETERS.md, seed 000's capture velocity).

    The pair (m_eff = m/2) leaves contact at ``e v`` and escapes the shell only at ``e v``
    above the :func:`escape_speed`: ``m_eff (e v)^2 / 2 = W`` at the threshold.
    """
    return escape_speed(cohesion_force, cohesion_range, 0.5 * mass) / restitution


def effective_restitution(speed: float | np.ndarray, cohesion_force: float,
                          cohesion_range: float, mass: float,
                          restitution: float) -> float | np.ndarray:
    """``e_eff = e sqrt(1 - v_c^2/v^2)`` for a head-on approach at ``speed`` above the
    capture velocity (:func:`capture_velocity`), 0 below it (PARAMETERS.md, seed 000)."""
    vc = capture_velocity(cohesion_force, cohesion_range, mass, restitution)
    v = np.asarray(speed, dtype=float)
    ratio = np.divide(vc * vc, v * v, out=np.full(v.shape, np.inf), where=v > 0)
    out = restitution * np.sqrt(np.clip(1.0 - ratio, 0.0, None))
    return float(out) if out.ndim == 0 else out
