"""The composed contact law: one compiled evaluator from the four slots' sub-models.

For a pair with branch vector ``d = x_i - x_j`` (``r = |d|``), relative velocity
``v = v_i - v_j`` and spins ``omega``, the force on i is (SPEC M1-M3; LAMMPS ``pair
granular``'s decomposition)

.. math::

    \\mathbf F_i = \\Big(f^{el}(r) - f^{d}\\Big)\\,\\mathbf d + \\mathbf F_t + \\mathbf e
    \\quad (r < r_i + r_j), \\qquad
    \\mathbf F_i = s\\,\\mathbf d \\quad (r \\ge r_i + r_j)

with ``f^el`` the normal model's elastic force per unit ``r``, ``f^d`` and ``e`` the damping
model's normal dashpot (per unit ``r``) and extra force (kinetic friction), ``F_t`` the
tangential model's force at the contact point, capped with ``|f^el - f^d| r`` as the normal
force, and ``s`` the cohesion model's force across the gap. The torque vector returned is
``c = d x F_t / r`` (torques ``T_i -= r_i c``, ``T_j -= r_j c``; LAMMPS's convention with the
full radius as lever arm). The evaluator's signature is the pair loop's
(:mod:`grainflow.kernels.pair_loop`).

History is written only when ``update`` is true: a read-only evaluation (set-up call,
contact listing, FIRE, recomputation after an insertion) leaves every history value
bitwise as it was.
"""

from __future__ import annotations

import math
from typing import Any

from grainflow.kernels.specialize import specialize
from grainflow.models.submodel import SubModel


def _evaluate(tab, ti, tj, dx, dy, dz, rsq, radi, radj, vr1, vr2, vr3, wi1, wi2, wi3, wj1, wj2,
              wj3, meff, hist, k, dt, update):
    """Force on i and torque vector of one pair (module docstring); bound by
    :func:`composed_evaluator`."""
    radsum = radi + radj
    if rsq >= radsum * radsum:
        tangential_release(hist, k, H_T, update)  # noqa: F821 (bound names)
        s = cohesion_gap_force(tab, ti, tj, C_C, hist, k, H_C, rsq, radsum, update)  # noqa: F821
        return s * dx, s * dy, s * dz, 0.0, 0.0, 0.0

    md = damping_mass_factor(tab, ti, tj, C_D, meff)  # noqa: F821
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

    # normal force per unit r = elastic - dashpot; extra damping force e
    dn, e1, e2, e3 = damping_force(tab, ti, tj, C_D, md, vnnr, rsqinv,  # noqa: F821
                                   vr1, vr2, vr3, vt1, vt2, vt3)
    ccel = normal_force(tab, ti, tj, C_N, r, rinv, radsum, radi, radj) - dn  # noqa: F821

    # tangential relative velocity at the contact point
    vtr1 = vt1 - (dz * wr2 - dy * wr3)
    vtr2 = vt2 - (dx * wr3 - dz * wr1)
    vtr3 = vt3 - (dy * wr1 - dx * wr2)

    cohesion_touch(tab, ti, tj, C_C, hist, k, H_C, update)  # noqa: F821
    fs1, fs2, fs3 = tangential_force(tab, ti, tj, C_T, hist, k, H_T, md,  # noqa: F821
                                     abs(ccel * r), dx, dy, dz, rsqinv, vtr1, vtr2, vtr3,
                                     dt, update)

    fx = dx * ccel + fs1 + e1
    fy = dy * ccel + fs2 + e2
    fz = dz * ccel + fs3 + e3
    c1 = rinv * (dy * fs3 - dz * fs2)
    c2 = rinv * (dz * fs1 - dx * fs3)
    c3 = rinv * (dx * fs2 - dy * fs1)
    return fx, fy, fz, c1, c2, c3


def composed_evaluator(parts: dict[str, type[SubModel]], columns: dict[str, int],
                       history: dict[str, int]) -> Any:
    """The compiled evaluator (``inline='always'``) of one composition.

    ``parts``: slot -> sub-model class; ``columns``/``history``: slot -> first column of
    the sub-model in the law's table / history row.
    """
    normal, damping, tangential, cohesion = (parts[s] for s in
                                             ("normal", "damping", "tangential", "cohesion"))
    bindings = {
        "normal_force": normal.force,
        "damping_mass_factor": damping.mass_factor, "damping_force": damping.force,
        "tangential_force": tangential.force, "tangential_release": tangential.release,
        "cohesion_touch": cohesion.touch, "cohesion_gap_force": cohesion.gap_force,
        "C_N": columns["normal"], "C_D": columns["damping"], "C_T": columns["tangential"],
        "C_C": columns["cohesion"], "H_T": history["tangential"], "H_C": history["cohesion"],
    }
    name = "contact_" + "_".join(parts[s].name for s in parts)
    return specialize(_evaluate, name, bindings, inline="always")
