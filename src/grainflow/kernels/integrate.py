"""Compiled time-stepping kernels (SPEC M7). Frozen particles are never moved.

Velocity Verlet ("modified velocity Verlet" of seeds 000/003; LAMMPS ``fix nve/sphere``)::

    v += dt/2 F/m ; omega += dt/2 T/I ; x += dt v      (first half, before forces)
    v += dt/2 F/m ; omega += dt/2 T/I                  (second half, after forces)

Second-order Adams-Bashforth for velocities with trapezoidal positions (seed 002, Appendix
B.2, eqs. B.21-B.24)::

    v(t+dt) = v(t) + dt/(2m) (3 F(t) - F(t-dt))
    omega(t+dt) = omega(t) + dt/(2I) (3 T(t) - T(t-dt))
    x(t+dt) = x(t) + dt/2 (v(t+dt) + v(t))
"""

from __future__ import annotations

from numba import njit, prange


@njit(cache=True, parallel=True)
def verlet_first_half(x, v, omega, force, torque, mass, inertia, frozen, dt):
    """Half kick of velocities and spins, then a full drift of positions."""
    h = 0.5 * dt
    for i in prange(x.shape[0]):
        if frozen[i]:
            continue
        a = h / mass[i]
        b = h / inertia[i]
        for c in range(3):
            v[i, c] += a * force[i, c]
            omega[i, c] += b * torque[i, c]
            x[i, c] += dt * v[i, c]


@njit(cache=True, parallel=True)
def verlet_second_half(v, omega, force, torque, mass, inertia, frozen, dt):
    """Half kick of velocities and spins with the new forces."""
    h = 0.5 * dt
    for i in prange(v.shape[0]):
        if frozen[i]:
            continue
        a = h / mass[i]
        b = h / inertia[i]
        for c in range(3):
            v[i, c] += a * force[i, c]
            omega[i, c] += b * torque[i, c]


@njit(cache=True, parallel=True)
def verlet_second_then_first_half(x, v, omega, force, torque, mass, inertia, frozen, dt):
    """One step's second half, then the next step's first half, in one pass over the
    particles: both half kicks use the same forces (nothing changes them in between), and
    each is added on its own, so the result is bitwise that of the two passes."""
    h = 0.5 * dt
    for i in prange(x.shape[0]):
        if frozen[i]:
            continue
        a = h / mass[i]
        b = h / inertia[i]
        for c in range(3):
            v[i, c] += a * force[i, c]
            omega[i, c] += b * torque[i, c]
            v[i, c] += a * force[i, c]
            omega[i, c] += b * torque[i, c]
            x[i, c] += dt * v[i, c]


@njit(cache=True, parallel=True)
def adams_bashforth2_step(x, v, omega, force, torque, force_prev, torque_prev, mass, inertia,
                          frozen, dt):
    """One AB2 step (eqs. B.21-B.23); stores the current force as the next step's previous."""
    h = 0.5 * dt
    for i in prange(x.shape[0]):
        if frozen[i]:
            continue
        a = h / mass[i]
        b = h / inertia[i]
        for c in range(3):
            v_old = v[i, c]
            v[i, c] = v_old + a * (3.0 * force[i, c] - force_prev[i, c])
            omega[i, c] += b * (3.0 * torque[i, c] - torque_prev[i, c])
            x[i, c] += h * (v[i, c] + v_old)
            force_prev[i, c] = force[i, c]
            torque_prev[i, c] = torque[i, c]
