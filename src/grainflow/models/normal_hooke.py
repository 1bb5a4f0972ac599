"""Linear (Hookean) normal spring: SPEC M1, LAMMPS ``gran/hooke``.

.. math::  \\mathbf F^{el}_n = k_n \\delta\\,\\hat n, \\qquad \\delta = r_i + r_j - |\\mathbf d|

(seed 000 "Model"; seed 002 eq. 2.4 with ``k_n``). With the ``viscous`` damping model the
pair may instead be given by its normal restitution ``e`` and contact time ``t_c``
(:func:`grainflow.models.granular.stiffness_and_damping`, seed 002 eqs. 2.6-2.7).
"""

from __future__ import annotations

from typing import Any

from numba import njit

from grainflow.models.submodel import NormalModel, Param


@njit(cache=True, inline="always")
def hooke_force(tab, ti, tj, c, r, rinv, radsum, radi, radj):
    """``k_n (r_i + r_j - r) / r``."""
    return tab[ti, tj, c] * (radsum - r) * rinv


class Hooke(NormalModel):
    name = "hooke"
    summary = "F_n = kn delta (SPEC M1; LAMMPS gran/hooke)"
    params = (
        Param("kn", "normal stiffness", "stiffness", lower=0.0, strict=True, group="normal"),
        Param("restitution", "normal restitution e, with contact_time instead of kn and "
              "gamma_n (needs damping 'viscous' unless e = 1)", None, lower=0.0, strict=True,
              upper=1.0, group="normal", column=False),
        Param("contact_time", "binary contact time t_c, with restitution", "time", lower=0.0,
              strict=True, group="normal", column=False),
    )
    force = hooke_force

    @classmethod
    def resolve(cls, params: dict[str, Any], meff: float) -> dict[str, Any]:
        """``(restitution, contact_time)`` -> ``(kn, gamma_n)`` for the pair's ``meff``."""
        from grainflow.models.granular import stiffness_and_damping

        given = [k for k in ("restitution", "contact_time") if k in params]
        if not given:
            return params
        if "kn" in params or len(given) == 1:
            raise ValueError("kn/restitution/contact_time: give either kn (and gamma_n) or "
                             "both restitution and contact_time")
        if "gamma_n" in params:
            raise ValueError("gamma_n: goes with kn; with restitution and contact_time the "
                             "damping follows from them")
        out = dict(params)
        e, tc = out.pop("restitution"), out.pop("contact_time")
        out["kn"], gamma_n = stiffness_and_damping(e, tc, meff, out.get("damping", "mass"))
        if gamma_n > 0:
            out["gamma_n"] = gamma_n
        return out

    @classmethod
    def stiffness(cls, row: dict[str, float], sigma: float) -> float:
        return row["kn"]
