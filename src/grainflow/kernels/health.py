"""One compiled pass over the particle arrays that finds the first sign of a broken state.

:func:`scan_state` runs before anything is written (thermo rows, frames, checkpoints) and at
every health check, so it must cost little: one serial pass that stops at the first bad
particle. It reports, in this order of precedence for one particle:

* a non-finite position, velocity, angular velocity or force;
* a step that moves the particle more than ``max_step_fraction`` of its radius
  (``|v| dt > f r``): at that speed a grain passes through walls and other grains between
  two force evaluations (tunnelling), whatever the contact law.
"""

from __future__ import annotations

import math

from numba import njit

#: Codes :func:`scan_state` returns, and what each means.
HEALTHY, BAD_X, BAD_V, BAD_OMEGA, BAD_FORCE, TOO_FAST = 0, 1, 2, 3, 4, 5
ARRAY_OF_CODE = {BAD_X: "x", BAD_V: "v", BAD_OMEGA: "omega", BAD_FORCE: "force"}


@njit(cache=True)
def scan_state(x, v, omega, force, radius, frozen, dt, max_step_fraction):
    """First particle whose state is broken: ``(code, index)``, ``code`` one of
    :data:`HEALTHY` ... :data:`TOO_FAST` (index -1 when healthy). Frozen particles are
    checked for finiteness only."""
    n = x.shape[0]
    for i in range(n):
        for a in range(3):
            if not math.isfinite(x[i, a]):
                return BAD_X, i
            if not math.isfinite(v[i, a]):
                return BAD_V, i
            if not math.isfinite(omega[i, a]):
                return BAD_OMEGA, i
            if not math.isfinite(force[i, a]):
                return BAD_FORCE, i
        if frozen[i]:
            continue
        speed2 = v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2]
        reach = max_step_fraction * radius[i]
        if speed2 * dt * dt > reach * reach:
            return TOO_FAST, i
    return HEALTHY, -1
