"""Kinetic theory of dense granular gases as used by seed 002: Sano, PhD thesis (Kyoto, 2013),
chapter 5, "comparison with the kinetic theory"; Sano & Hayakawa, PRE 86, 041308 (2012).

Pure numpy functions of the volume fraction ``phi``, the restitution coefficient and the
granular temperature; scalars and arrays both work and broadcast. Temperature is in energy
units (k_B = 1), as the thesis's T_g.

* :func:`radial_distribution_contact` -- the contact value chi(phi), thesis eq. (5.3)
  (Carnahan-Starling, continued by a form diverging at random close packing, after Torquato,
  PRE 51, 3170 (1995), the thesis's ref. [103]); disks use Henderson's form continued the same
  way.
* :func:`pressure_ratio`, :func:`pressure` -- the equation of state P/(nT), eq. (5.2), for
  spheres and disks (Garzo & Dufty, PRE 59, 5895 (1999): P/(nT) = 1 + 2^(d-2) (1+e) phi chi).
* :func:`c_star`, :func:`zeta_star`, :func:`nu_eta_star`, :func:`gamma_star`,
  :func:`eta_k_star`, :func:`eta_star`, :func:`shear_viscosity` -- the Garzo-Dufty shear
  viscosity, eqs. (5.5)-(5.11), spheres only.
* :func:`eta_mu_star` -- the viscosity implied by the fit mu* = a I, eq. (5.13);
  :func:`friction_slope`, the converse: the a of a flow with the kinetic-theory viscosity.
* :func:`effective_restitution` -- the restitution coefficient renormalised for slightly
  frictional spheres, eq. (2.55) (Jenkins & Zhang, Phys. Fluids 14, 1228 (2002)).

Only the thesis's three-dimensional transport coefficients are implemented: the d-dimensional
Garzo-Dufty coefficients and the disk form of eq. (2.55) could not be checked against their
papers, so those functions raise NotImplementedError for ``dim=2`` rather than guess.
"""

from __future__ import annotations

import math
from numbers import Real
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike

#: Result type: a numpy float for scalar inputs, an array otherwise.
FloatOrArray = float | np.ndarray

#: Default freezing volume fraction phi_f per dimension. 3D: 0.49 (thesis eq. 5.3). 2D: 0.69,
#: the hard-disk freezing point used by Torquato (1995) for the same piecewise form.
FREEZING_FRACTION = MappingProxyType({2: 0.69, 3: 0.49})

#: Default random-close-packing fraction phi_c, where chi diverges. 3D: 0.64 (thesis eq. 5.3).
#: 2D: 0.82, monodisperse random close packing of disks (Torquato 1995; Berryman, PRA 27,
#: 1053 (1983)). The thesis's 2D runs are bidisperse; pass their jamming fraction instead.
RANDOM_CLOSE_PACKING = MappingProxyType({2: 0.82, 3: 0.64})

_NO_2D_VISCOSITY = (
    "the shear viscosity is implemented for spheres (dim=3) only: the thesis gives the 3D "
    "Garzo-Dufty coefficients (eqs. 5.6-5.11), and their d-dimensional forms (PRE 59, 5895 "
    "(1999)) could not be checked against the paper, so no disk version is guessed"
)


# --------------------------------------------------------------------------------------------
# Argument checks
# --------------------------------------------------------------------------------------------


def _as_array(name: str, value: ArrayLike) -> np.ndarray:
    """``value`` as a finite float array, or ValueError naming ``name``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number or an array of numbers, got {value!r}"
                         ) from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be finite, got {value!r}")
    return arr


def _non_negative(name: str, value: ArrayLike) -> np.ndarray:
    arr = _as_array(name, value)
    if np.any(arr < 0):
        raise ValueError(f"{name}: must be >= 0, got {value!r}")
    return arr


def _positive(name: str, value: ArrayLike) -> np.ndarray:
    arr = _as_array(name, value)
    if np.any(arr <= 0):
        raise ValueError(f"{name}: must be > 0, got {value!r}")
    return arr


def _restitution(value: ArrayLike) -> np.ndarray:
    arr = _as_array("restitution", value)
    if np.any((arr < 0) | (arr > 1)):
        raise ValueError(f"restitution: must lie in [0, 1], got {value!r}")
    return arr


def _dim(dim: int) -> int:
    if isinstance(dim, bool) or dim not in (2, 3):
        raise ValueError(f"dim: must be 2 (disks) or 3 (spheres), got {dim!r}")
    return int(dim)


def _spheres_only(dim: int) -> None:
    if _dim(dim) == 2:
        raise NotImplementedError(_NO_2D_VISCOSITY)


def _packing_limits(dim: int, phi_f: float | None, phi_c: float | None) -> tuple[float, float]:
    """(phi_f, phi_c), defaults by dimension, checked 0 < phi_f < phi_c < 1."""
    phi_f = FREEZING_FRACTION[dim] if phi_f is None else phi_f
    phi_c = RANDOM_CLOSE_PACKING[dim] if phi_c is None else phi_c
    for name, value in (("phi_f", phi_f), ("phi_c", phi_c)):
        if isinstance(value, bool) or not (isinstance(value, Real) and 0 < value < 1):
            raise ValueError(f"{name}: must be a number in (0, 1), got {value!r}")
    if phi_f >= phi_c:
        raise ValueError(f"phi_f: must be below phi_c = {phi_c!r}, got {phi_f!r}")
    return float(phi_f), float(phi_c)


def _volume_fraction(value: ArrayLike) -> np.ndarray:
    arr = _as_array("phi", value)
    if np.any((arr < 0) | (arr >= 1)):
        raise ValueError(f"phi: a packing fraction must lie in [0, 1); got {value!r}")
    return arr


def _out(arr: np.ndarray) -> FloatOrArray:
    """A numpy float for a 0-d result, the array otherwise."""
    return arr[()]


# --------------------------------------------------------------------------------------------
# Contact value and equation of state
# --------------------------------------------------------------------------------------------


def _dilute_branch(phi: np.ndarray | float, dim: int) -> np.ndarray | float:
    """Carnahan-Starling (spheres) or Henderson (disks) contact value."""
    if dim == 3:
        return (1 - phi / 2) / (1 - phi) ** 3
    return (1 - 7 * phi / 16) / (1 - phi) ** 2


def _chi(phi: ArrayLike, dim: int, phi_f: float | None, phi_c: float | None) -> np.ndarray:
    phi_f, phi_c = _packing_limits(dim, phi_f, phi_c)
    phi = _volume_fraction(phi)
    with np.errstate(divide="ignore"):
        dense = _dilute_branch(phi_f, dim) * (phi_c - phi_f) / (phi_c - phi)
    chi = np.where(phi < phi_f, _dilute_branch(phi, dim), dense)
    return np.where(phi < phi_c, chi, np.nan)


def radial_distribution_contact(phi: ArrayLike, dim: int = 3, phi_f: float | None = None,
                                phi_c: float | None = None) -> FloatOrArray:
    """Pair distribution at contact, chi(phi); thesis eq. (5.3) for spheres.

    Spheres (dim=3), eq. (5.3) with the thesis's ref. [103] (Torquato, PRE 51, 3170 (1995))::

        chi = (1 - phi/2) / (1 - phi)^3                                   0 <= phi < phi_f
        chi = (1 - phi_f/2)(phi_c - phi_f) / ((1 - phi_f)^3 (phi_c - phi))  phi_f <= phi < phi_c

    i.e. Carnahan-Starling up to freezing, then a form that diverges at random close packing and
    is continuous at phi_f. Disks (dim=2) use Henderson's form (Mol. Phys. 30, 971 (1975))
    continued the same way::

        chi = (1 - 7 phi/16) / (1 - phi)^2                                0 <= phi < phi_f
        chi = chi_H(phi_f) (phi_c - phi_f) / (phi_c - phi)                phi_f <= phi < phi_c

    ``phi_f`` and ``phi_c`` default to :data:`FREEZING_FRACTION` and
    :data:`RANDOM_CLOSE_PACKING` of the dimension: 0.49 and 0.64 for spheres (thesis), 0.69
    and 0.82 for disks (Torquato 1995: hard-disk freezing and random close packing).

    NaN for ``phi_c <= phi < 1``, where chi has diverged (a measured field may hold cells packed
    beyond random close packing: they get no value instead of stopping the whole map);
    ValueError for ``phi`` outside [0, 1). Every function below built on chi inherits the NaN.
    """
    return _out(_chi(phi, _dim(dim), phi_f, phi_c))


def pressure_ratio(phi: ArrayLike, restitution: ArrayLike, dim: int = 3,
                   phi_f: float | None = None, phi_c: float | None = None) -> FloatOrArray:
    """Equation of state P/(n T) of the inelastic Enskog gas; thesis eq. (5.2) for spheres.

    Garzo & Dufty, PRE 59, 5895 (1999), in d dimensions::

        P / (n T) = 1 + 2^(d-2) (1 + e) phi chi(phi)

    i.e. 1 + 2 phi (1 + e) chi for spheres (eq. 5.2) and 1 + (1 + e) phi chi for disks; at
    e = 1 these are the hard-sphere (1 + 4 phi chi) and hard-disk (1 + 2 phi chi) virial
    pressures. chi is :func:`radial_distribution_contact` with the same ``dim``, ``phi_f`` and
    ``phi_c``.
    """
    dim = _dim(dim)
    chi = _chi(phi, dim, phi_f, phi_c)
    e = _restitution(restitution)
    return _out(1 + 2.0 ** (dim - 2) * (1 + e) * np.asarray(phi, dtype=float) * chi)


def pressure(number_density: ArrayLike, temperature: ArrayLike, phi: ArrayLike,
             restitution: ArrayLike, dim: int = 3, phi_f: float | None = None,
             phi_c: float | None = None) -> FloatOrArray:
    """Pressure P = n T (P/(n T)), with the ratio of :func:`pressure_ratio` (eq. 5.2).

    ``number_density`` n is grains per unit volume (area in 2D) and ``temperature`` T the
    granular temperature in energy units; the thesis's P = sum_a sigma_aa / 3.
    """
    n = _non_negative("number_density", number_density)
    temp = _non_negative("temperature", temperature)
    return _out(n * temp * pressure_ratio(phi, restitution, dim, phi_f, phi_c))


# --------------------------------------------------------------------------------------------
# Shear viscosity (Garzo & Dufty 1999, spheres)
# --------------------------------------------------------------------------------------------


def _c_star(e: np.ndarray) -> np.ndarray:
    return 32 * (1 - e) * (1 - 2 * e**2) / (81 - 17 * e + 30 * e**2 * (1 - e))


def c_star(restitution: ArrayLike, dim: int = 3) -> FloatOrArray:
    """Fourth cumulant of the homogeneous cooling state, thesis eq. (5.11) (Garzo-Dufty)::

        c* = 32 (1 - e)(1 - 2 e^2) / (81 - 17 e + 30 e^2 (1 - e))

    Zero for elastic grains (e = 1). Spheres only (``dim=2`` raises NotImplementedError).
    """
    _spheres_only(dim)
    return _out(_c_star(_restitution(restitution)))


def _zeta_star(chi: np.ndarray, e: np.ndarray) -> np.ndarray:
    return 5 / 12 * chi * (1 - e**2) * (1 + 3 * _c_star(e) / 32)


def _nu_eta_star(chi: np.ndarray, e: np.ndarray) -> np.ndarray:
    return chi * (1 - (1 - e) ** 2 / 4) * (1 - _c_star(e) / 64)


def _gamma_star(phi: np.ndarray, chi: np.ndarray, e: np.ndarray) -> np.ndarray:
    return 128 / (5 * math.pi) * phi**2 * chi * (1 + e) * (1 - _c_star(e) / 32)


def _eta_k_star(phi: np.ndarray, chi: np.ndarray, e: np.ndarray) -> np.ndarray:
    numerator = 1 - 2 * (1 + e) * (1 - 3 * e) * phi * chi / 5
    return numerator / (_nu_eta_star(chi, e) - _zeta_star(chi, e) / 2)


def _eta_star(phi: np.ndarray, chi: np.ndarray, e: np.ndarray) -> np.ndarray:
    kinetic = _eta_k_star(phi, chi, e) * (1 + 4 * phi * chi * (1 + e) / 5)
    return kinetic + 3 * _gamma_star(phi, chi, e) / 5


def _sphere_state(phi: ArrayLike, restitution: ArrayLike, dim: int, phi_f: float | None,
                  phi_c: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checked (phi, chi(phi), e) for the 3D transport coefficients."""
    _spheres_only(dim)
    chi = _chi(phi, 3, phi_f, phi_c)
    return np.asarray(phi, dtype=float), chi, _restitution(restitution)


def zeta_star(phi: ArrayLike, restitution: ArrayLike, dim: int = 3,
              phi_f: float | None = None, phi_c: float | None = None) -> FloatOrArray:
    """Reduced cooling rate, thesis eq. (5.10)::

        zeta* = (5/12) chi (1 - e^2)(1 + 3 c*/32)

    Zero for e = 1. Spheres only.
    """
    phi, chi, e = _sphere_state(phi, restitution, dim, phi_f, phi_c)
    return _out(_zeta_star(chi, e))


def nu_eta_star(phi: ArrayLike, restitution: ArrayLike, dim: int = 3,
                phi_f: float | None = None, phi_c: float | None = None) -> FloatOrArray:
    """Reduced collision frequency of the shear viscosity, thesis eq. (5.9)::

        nu_eta* = chi [1 - (1 - e)^2 / 4] [1 - c*/64]

    Spheres only.
    """
    phi, chi, e = _sphere_state(phi, restitution, dim, phi_f, phi_c)
    return _out(_nu_eta_star(chi, e))


def gamma_star(phi: ArrayLike, restitution: ArrayLike, dim: int = 3,
               phi_f: float | None = None, phi_c: float | None = None) -> FloatOrArray:
    """Reduced bulk viscosity, thesis eq. (5.8)::

        gamma* = 128/(5 pi) phi^2 chi (1 + e)(1 - c*/32)

    Spheres only.
    """
    phi, chi, e = _sphere_state(phi, restitution, dim, phi_f, phi_c)
    return _out(_gamma_star(phi, chi, e))


def eta_k_star(phi: ArrayLike, restitution: ArrayLike, dim: int = 3,
               phi_f: float | None = None, phi_c: float | None = None) -> FloatOrArray:
    """Kinetic part of the reduced shear viscosity, thesis eq. (5.7)::

        eta_k* = [1 - 2 (1 + e)(1 - 3e) phi chi / 5] / (nu_eta* - zeta*/2)

    Spheres only.
    """
    phi, chi, e = _sphere_state(phi, restitution, dim, phi_f, phi_c)
    return _out(_eta_k_star(phi, chi, e))


def eta_star(phi: ArrayLike, restitution: ArrayLike, dim: int = 3,
             phi_f: float | None = None, phi_c: float | None = None) -> FloatOrArray:
    """Reduced shear viscosity eta*(phi), thesis eq. (5.6) (Garzo & Dufty 1999)::

        eta* = eta_k* [1 + 4 phi chi (1 + e) / 5] + 3 gamma* / 5

    with eta_k*, gamma* of eqs. (5.7)-(5.8). eta* -> 1 for a dilute elastic gas. Spheres only.
    """
    phi, chi, e = _sphere_state(phi, restitution, dim, phi_f, phi_c)
    return _out(_eta_star(phi, chi, e))


def shear_viscosity(phi: ArrayLike, temperature: ArrayLike, restitution: ArrayLike,
                    diameter: ArrayLike, mass: ArrayLike, dim: int = 3,
                    phi_f: float | None = None, phi_c: float | None = None) -> FloatOrArray:
    """Kinetic-theory shear viscosity eta_kin(phi, T), thesis eq. (5.5)::

        eta_kin = 5 / (16 d^2) sqrt(m T / pi) eta*(phi)

    with grain diameter d, mass m, granular temperature T (energy units) and eta* of
    :func:`eta_star`; the constitutive law is sigma_rz = -eta_kin D_rz, eq. (5.4). Spheres only.
    """
    phi, chi, e = _sphere_state(phi, restitution, dim, phi_f, phi_c)
    temp = _non_negative("temperature", temperature)
    d = _positive("diameter", diameter)
    m = _positive("mass", mass)
    return _out(5 / (16 * d**2) * np.sqrt(m * temp / math.pi) * _eta_star(phi, chi, e))


def eta_mu_star(phi: ArrayLike, a: ArrayLike, restitution: ArrayLike,
                phi_f: float | None = None, phi_c: float | None = None) -> FloatOrArray:
    """Reduced shear viscosity implied by the friction law mu* = a I, thesis eq. (5.13)::

        eta_mu* = (16 a / 5) sqrt(6 phi (1 + 2 phi (1 + e) chi))

    Spheres. From mu* = -sigma_rz/P = a I with I = D_rz sqrt(m / (P d)), n = 6 phi/(pi d^3)
    and P of eq. (5.2), divided by eta_0 = 5/(16 d^2) sqrt(m T/pi) of eq. (5.5); the thesis fits
    a = 0.240 (frictional) and 0.223 (frictionless). (The thesis text prints I as
    D_rz sqrt(P/(m d)) and eta_0 as 5 sqrt(pi m T)/(16 d^2); eq. (5.13) as printed follows from
    the forms above.)
    """
    slope = _non_negative("a", a)
    ratio = pressure_ratio(phi, restitution, 3, phi_f, phi_c)
    return _out(16 * slope / 5 * np.sqrt(6 * np.asarray(phi, dtype=float) * ratio))


def friction_slope(phi: ArrayLike, restitution: ArrayLike, phi_f: float | None = None,
                   phi_c: float | None = None) -> FloatOrArray:
    """Slope a of mu* = a I (thesis Sec. 5.3.3) of a flow whose shear viscosity and pressure
    are the kinetic theory's, eqs. (5.5) and (5.2)::

        a_KT(phi) = 5 eta*(phi) / (16 sqrt(6 phi (1 + 2 phi (1 + e) chi)))

    Spheres. With sigma_rz = -eta D_rz (eq. 5.12) and I = D_rz sqrt(m / (P d)),
    mu* / I = eta / sqrt(P m / d); eta_kin = 5/(16 d^2) sqrt(m T/pi) eta* and
    P = n T (P/(n T)), n = 6 phi/(pi d^3), make it independent of T, m and d. The converse of
    :func:`eta_mu_star` (``eta_mu_star(phi, friction_slope(phi, e), e) == eta_star(phi, e)``).
    Its lowest value is 0.35 at e = 0.75 and 0.34 at e = 0.616, near phi = 0.2; it grows
    without bound toward phi_c and toward phi = 0. The thesis's a = 0.223 (e = 0.75) and
    0.240 (e_bar = 0.616) lie below it at every phi, i.e. a viscosity below kinetic theory's
    (its Fig. 5.10).
    """
    phi_arr, chi, e = _sphere_state(phi, restitution, 3, phi_f, phi_c)
    ratio = pressure_ratio(phi_arr, e, 3, phi_f, phi_c)
    return _out(5 * _eta_star(phi_arr, chi, e) / (16 * np.sqrt(6 * phi_arr * ratio)))


# --------------------------------------------------------------------------------------------
# Slightly frictional grains
# --------------------------------------------------------------------------------------------


def effective_restitution(restitution: ArrayLike, mu_p: ArrayLike, dim: int = 3
                          ) -> FloatOrArray:
    """Effective restitution coefficient of slightly frictional spheres, thesis eq. (2.55)::

        e_bar = e - (pi/2) mu_p + (9/2) mu_p^2 + O(mu_p^3)

    (Jenkins & Zhang, Phys. Fluids 14, 1228 (2002)), with e the normal restitution coefficient
    and mu_p the Coulomb friction coefficient; the thesis uses e_bar = 0.616 for e = 0.75,
    mu_p = 0.2. The expansion holds for small mu_p: a result outside [0, 1] raises ValueError.

    Spheres only: the disk form (Yoon & Jenkins 2005; tested by Saitoh & Hayakawa) could not be
    checked against its paper, so ``dim=2`` raises NotImplementedError.
    """
    if _dim(dim) == 2:
        raise NotImplementedError(
            "effective_restitution: eq. (2.55) is the Jenkins-Zhang result for spheres; the "
            "disk form (Yoon & Jenkins 2005) could not be checked against the paper, so no "
            "2D version is guessed")
    e = _restitution(restitution)
    mu = _non_negative("mu_p", mu_p)
    e_bar = e - math.pi / 2 * mu + 4.5 * mu**2
    if np.any((e_bar < 0) | (e_bar > 1)):
        raise ValueError(f"mu_p: the small-friction expansion (2.55) gives e_bar outside [0, 1] "
                         f"for mu_p={mu_p!r}, restitution={restitution!r}")
    return _out(e_bar)
