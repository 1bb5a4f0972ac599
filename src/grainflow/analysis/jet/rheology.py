"""Rheology of a granular jet's flow next to its target (seed 002: H. Sano, PhD thesis (2013),
chapter 5 (3D) and chapter 6 (2D); Sano & Hayakawa, PRE 86, 041308 (2012)).

Pure functions of saved frames (:class:`~grainflow.frame.Frame`) and of coarse-grained fields
(:mod:`grainflow.analysis.cg`); the engine is never touched.

Geometry (fixed by :mod:`grainflow.scenarios.jet`; units d = largest diameter, m, u0):

* 3D: the jet travels along -z about the z axis; the target is one layer of wall particles
  (type :data:`TARGET_TYPE`) centred at z = -d/2 in the disk r <= R_tar, its surface at z ~ 0.
  The seed's mesh (Sec. 5, Fig. 5.2) is the cylinder r < R_tar, 0 < z < Delta z = 5 d cut into
  the rings k Delta r < r < (k+1) Delta r, Delta r = R_tar / 5, k = 0..4.
* 2D: the jet travels along -x about y = 0; the target is a line of wall particles at
  x = -d/2, |y| <= R_tar. The seed's meshes (Sec. 6, Fig. 6.2) are the cells
  k Delta y < y < (k+1) Delta y, Delta y = R_tar / 5, k = -5..4, in the layers (a) 0 < x <= 5 d
  and (b) 5 d < x <= 10 d.

In each cell (Heaviside bins, the seed's cell averages, Appendix C):

* stress, eq. (5.1) / (6.1): sigma_ab = (1/V) sum_i m u_ia u_ib + (1/V) sum_c F_a b_b (A/V),
  compression positive, in cylindrical components (r, theta, z) in 3D and (x, y) in 2D; the
  pressure P = tr(sigma) / D (Sec. 5.3.1; 2D: (sigma_xx + sigma_yy)/2, Sec. 6.1.3);
* packing fraction phi, number density n, T_g = sum_i m u_i^2 / (D N) (Secs. 5.2, 6.1.1) and
  T_alpha = sum_i m u_ia^2 / N (caption of Fig. 5.6);
* the strain rate by the seed's own half-cell scheme (:func:`layer_fields_3d`,
  :func:`layer_fields_2d`): D_rz = (d v_r/dz + d v_z/dr)/2 (eq. 5.4's definition, Sec. 5.3.3)
  and D_xy = (d v_y/dx + d v_x/dy)/2 (Sec. 6.1.3);
* mu* = -sigma_rz / P (Sec. 5.3.3) or -sigma_xy / P (Sec. 6.1.4), I = |D_rz| sqrt(m/(P d))
  (3D, Sec. 5.3.3 made dimensionless, see :mod:`grainflow.analysis.rheology`),
  I_s = |D_xy| sqrt(m / P) and I_T = sqrt(T_g / (P d^2)) (2D, Sec. 6.1.3).

Wall particles are the wall, not the flow: they are left out of n, phi, the mean velocity and
the kinetic stress, while their contacts with grains enter the contact stress, whose branch
lines cross the layer (:func:`grainflow.analysis.cg.select_types`).

Errors are standard errors over blocks of frames (``blocks``) and, after :func:`pool`, over
replicas (the seed's ten configurations; their spread is ``LayerFields.spread``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from math import pi
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.checks import frozen as _frozen
from grainflow.analysis.cg import (CGFields, Cartesian, Cylindrical, Heaviside, coarse_grain_grids,
                                   combine, select_types)
from grainflow.analysis.jet._common import TARGET_TYPE, check_window
from grainflow.analysis.kinetic_theory import (RANDOM_CLOSE_PACKING, friction_slope,
                                               pressure_ratio, shear_viscosity)
from grainflow.analysis.rheology import (DivergenceFit, MuLinearFit, MuOfIFit, MuPowerLawFit,
                                         effective_friction, fit_divergence, fit_mu_linear,
                                         fit_mu_of_I, fit_mu_power_law, flatness,
                                         inertial_number, temperature_number)
from grainflow.frame import Frame

__all__ = ["GRAIN_TYPES", "TARGET_TYPE", "FitChoice2D", "KineticTheoryCheck", "LayerFields",
           "ViscosityCheck", "viscosity_check",
           "fit_choices_2d", "fit_choices_3d", "fit_divergence_2d", "fit_friction_2d",
           "fit_friction_3d", "kinetic_theory_check",
           "VALUE_NAMES", "layer_flatness", "layer_fluctuations", "layer_fields_2d",
           "layer_fields_3d", "pool", "rheology_points"]

#: Particle types of the grains (2D bidisperse jets: 0 small, 1 large).
GRAIN_TYPES = (0, 1)

_KERNEL = Heaviside()


# --------------------------------------------------------------------------------------------
# Meshes
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Mesh:
    """One layer's three grids: the seed's mesh, its two half layers along the jet axis, and
    the cells shifted by half a cell across it (the half-cell strain-rate scheme)."""

    dim: int
    target_radius: float
    layer: tuple[float, float]
    edges: np.ndarray  # mesh edges along r (3D) or y (2D)

    @property
    def spacing(self) -> float:
        return float(self.edges[1] - self.edges[0])

    @property
    def shifted_edges(self) -> np.ndarray:
        """Edges of the shifted cells centred on the mesh edges: 3D ``0, dr/2, 3dr/2, ...,
        (n + 1/2) dr`` (the first cell, 0 < r < dr/2, stands for r = 0); 2D ``edges[0] - dy/2,
        ..., edges[-1] + dy/2``."""
        h = 0.5 * self.spacing
        inner = self.edges + h
        first = [0.0] if self.dim == 3 else [self.edges[0] - h]
        return np.concatenate([first, inner])

    def grids(self):
        lo, hi = self.layer
        mid = 0.5 * (lo + hi)
        if self.dim == 3:
            return (Cylindrical(self.edges, [lo, hi]), Cylindrical(self.edges, [lo, mid, hi]),
                    Cylindrical(self.shifted_edges, [lo, hi]))
        return (Cartesian([[lo, hi], self.edges]), Cartesian([[lo, mid, hi], self.edges]),
                Cartesian([[lo, hi], self.shifted_edges]))


def _positive_number(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a positive number, got {value!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name}: expected a positive finite number, got {value!r}")
    return v


def _count(name: str, value: int, *, even: bool = False) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1 or (
            even and value % 2):
        kind = "a positive even integer" if even else "a positive integer"
        raise ValueError(f"{name}: expected {kind}, got {value!r}")
    return int(value)


def _layer_bounds(name: str, layer) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in layer)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected (lo, hi) along the jet axis, got {layer!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ValueError(f"{name}: expected finite (lo, hi) with lo < hi, got {layer!r}")
    return lo, hi


def _mesh_3d(target_radius: float, layer: float, n_r: int) -> _Mesh:
    radius = _positive_number("target_radius", target_radius)
    height = _positive_number("layer", layer)
    n_r = _count("n_r", n_r)
    return _Mesh(3, radius, (0.0, height), np.linspace(0.0, radius, n_r + 1))


def _mesh_2d(target_radius: float, layer, n_y: int) -> _Mesh:
    radius = _positive_number("target_radius", target_radius)
    n_y = _count("n_y", n_y, even=True)
    return _Mesh(2, radius, _layer_bounds("layers", layer), np.linspace(-radius, radius, n_y + 1))


# --------------------------------------------------------------------------------------------
# Accumulating the frames (one pass; frames may be a generator)
# --------------------------------------------------------------------------------------------


def _accumulate(frames: Iterable[Frame], grids: Sequence, contacts: Sequence[bool],
                window, blocks: int, grains: Sequence[int]) -> list[CGFields]:
    """:func:`grainflow.analysis.cg.coarse_grain_grids` of the grains of every frame in the
    window (the target's particles removed, :func:`~grainflow.analysis.cg.select_types`), on several grids in one
    pass."""
    if not isinstance(blocks, (int, np.integer)) or isinstance(blocks, bool) or blocks < 1:
        raise ValueError(f"blocks: a positive integer, got {blocks!r}")
    check_window(window)
    return coarse_grain_grids(frames, list(grids), _KERNEL, window=window, blocks=int(blocks),
                              contacts=list(contacts), types=grains)


def _block(fields: CGFields, b: int) -> CGFields:
    """Block ``b`` of ``fields`` as fields of its own."""
    frames = fields.block_frames[b:b + 1]
    return CGFields(coordinates=fields.coordinates, kernel=fields.kernel,
                    n_frames=int(round(float(frames[0]))), time=fields.time,
                    block_sums={k: v[b:b + 1] for k, v in fields.block_sums.items()},
                    block_frames=frames)


# --------------------------------------------------------------------------------------------
# Per-cell values
# --------------------------------------------------------------------------------------------


def _values(mesh: _Mesh, main: CGFields, half: CGFields, shifted: CGFields, diameter: float,
            mass: float) -> dict[str, np.ndarray]:
    """Every per-cell quantity of one layer from its three grids' fields."""
    dim = mesh.dim
    # (shear axes of sigma, axis of the jet, component along the wall)
    shear, axial, along = ((0, 2), 2, 0) if dim == 3 else ((0, 1), 0, 1)
    lo, hi = mesh.layer
    half_height = 0.5 * (hi - lo)
    with np.errstate(invalid="ignore", divide="ignore"):
        sigma = main.stress
        P = main.pressure
        n = main.number_density
        T_g = main.temperature
        T_alpha = main.temperature_components
        v_half = half.velocity  # 3D (n_r, 2, 3): (r cell, half layer); 2D (2, n_y, 2)
        v_shift = shifted.velocity  # (n + 1, dim)
        if dim == 3:
            grad_wall = (v_half[:, 1, along] - v_half[:, 0, along]) / half_height
        else:
            grad_wall = (v_half[1, :, along] - v_half[0, :, along]) / half_height
        grad_axis = np.diff(v_shift[:, axial]) / mesh.spacing
        D = 0.5 * (grad_wall + grad_axis)
        diag = np.diagonal(sigma, axis1=-2, axis2=-1)
        normal = (_normal_strain_rates_2d(mesh, half_height, v_half, v_shift, D) if dim == 2
                  else _normal_strain_rates_3d(mesh, half_height, main.velocity, v_half, v_shift,
                                               D))
        normal["I_dev"] = inertial_number(normal["D_dev"], P, diameter, mass, dim)
        values = {
            "phi": main.packing_fraction,
            "n": n,
            "velocity": main.velocity,
            "T_g": T_g,
            "T_alpha": T_alpha,
            "sigma": sigma,
            "P": P,
            ("dvr_dz" if dim == 3 else "dvy_dx"): grad_wall,
            ("dvz_dr" if dim == 3 else "dvx_dy"): grad_axis,
            "D": D,
            "mu": effective_friction(sigma, shear),
            "mu_folded": effective_friction(sigma, shear, strain_rate=D),
            "I": inertial_number(D, P, diameter, mass, dim),
            "I_T": temperature_number(np.where(T_g < 0, 0.0, T_g), P, diameter, dim),  # round-off
            "shear_ratio": np.abs(sigma[:, shear[0], shear[1]] / sigma[:, axial, axial]),
            "P_over_nT": P / (n * T_g),
            "P_alpha_over_nT_alpha": diag / (n[:, None] * T_alpha),
        }
        values.update(normal)
    return values


def _normal_strain_rates_2d(mesh: _Mesh, half_height: float, v_half: np.ndarray,
                            v_shift: np.ndarray, D_xy: np.ndarray) -> dict[str, np.ndarray]:
    """The 2D cells' normal strain rates by the same half-cell differences as D_xy:
    dv_x/dx from the two half layers, dv_y/dy from the shifted cells. Beside D_xy they give the
    extension rate D_ext = (dv_x/dx - dv_y/dy)/2, the deviatoric magnitude
    D_dev = sqrt(D_xy^2 + D_ext^2) (half the difference of the principal strain rates), the
    shear fraction |D_xy| / D_dev (0 for a pure extension along x and y, 1 for a pure shear in
    those axes); :func:`_values` adds I_dev = D_dev sqrt(m / P), the inertial number of the
    whole deviatoric rate. The seed's I_s uses D_xy alone (Sec. 6.1.3); these show where that
    misses the flow: on the stagnation line the flow is an extension and D_xy ~ 0."""
    dvx_dx = (v_half[1, :, 0] - v_half[0, :, 0]) / half_height
    dvy_dy = np.diff(v_shift[:, 1]) / mesh.spacing
    extension = 0.5 * (dvx_dx - dvy_dy)
    deviatoric = np.hypot(D_xy, extension)
    return {"dvx_dx": dvx_dx, "dvy_dy": dvy_dy, "D_ext": extension, "D_dev": deviatoric,
            "shear_fraction": np.abs(D_xy) / deviatoric}


def _normal_strain_rates_3d(mesh: _Mesh, half_height: float, velocity: np.ndarray,
                            v_half: np.ndarray, v_shift: np.ndarray,
                            D_rz: np.ndarray) -> dict[str, np.ndarray]:
    """The 3D rings' normal strain rates by the half-cell differences of D_rz: dv_z/dz from
    the two half layers, dv_r/dr from the shifted rings (the first, 0 < r < dr/2, standing for
    r = 0, as for dv_z/dr), and the hoop rate v_r/r at the ring's centre. With them the
    deviatoric magnitude D_dev = sqrt(D':D'/2) = sqrt((D'_rr^2 + D'_tt^2 + D'_zz^2)/2 + D_rz^2)
    (D' = D - tr(D)/3; for the 2D cells the same definition gives sqrt(D_xy^2 + D_ext^2)) and
    the shear fraction |D_rz| / D_dev. Next to the target the flow is mostly a compression
    along z and an extension in r: the seed's D_rz (Sec. 5.3.3) is a part of the rate."""
    centres = 0.5 * (mesh.edges[1:] + mesh.edges[:-1])
    dvz_dz = (v_half[:, 1, 2] - v_half[:, 0, 2]) / half_height
    dvr_dr = np.diff(v_shift[:, 0]) / mesh.spacing
    hoop = velocity[:, 0] / centres
    trace = (dvr_dr + hoop + dvz_dz) / 3.0
    deviatoric = np.sqrt(0.5 * ((dvr_dr - trace) ** 2 + (hoop - trace) ** 2
                                + (dvz_dz - trace) ** 2) + D_rz**2)
    return {"dvr_dr": dvr_dr, "vr_over_r": hoop, "dvz_dz": dvz_dz, "D_dev": deviatoric,
            "shear_fraction": np.abs(D_rz) / deviatoric}


#: Names of the per-cell values of :class:`LayerFields` (2D has dvy_dx, dvx_dy instead of
#: dvr_dz, dvz_dr, and dvx_dx, dvy_dy, D_ext for 3D's dvr_dr, vr_over_r, dvz_dz).
VALUE_NAMES = ("phi", "n", "velocity", "T_g", "T_alpha", "sigma", "P", "dvr_dz", "dvz_dr",
               "dvy_dx", "dvx_dy", "D", "mu", "mu_folded", "I", "I_T", "shear_ratio",
               "P_over_nT", "P_alpha_over_nT_alpha", "dvr_dr", "vr_over_r", "dvz_dz",
               "dvx_dx", "dvy_dy", "D_ext", "D_dev", "shear_fraction", "I_dev")


@dataclass(frozen=True)
class LayerFields:
    """Per-cell fields of one layer next to the target, with standard errors.

    Attributes
    ----------
    dim : 3 (cylindrical rings about the jet axis) or 2 (cells in y).
    target_radius : R_tar.
    layer : (lo, hi) of the layer along the jet axis (3D: z in (0, Delta z); 2D: x).
    edges : (n + 1,) mesh edges along r (3D) or y (2D).
    values : per-cell arrays by name (leading axis the n cells):

        ``phi`` packing fraction; ``n`` number density; ``velocity`` (n, D) mean velocity;
        ``T_g`` sum m u^2 / (D N); ``T_alpha`` (n, D) sum m u_a^2 / N; ``sigma`` (n, D, D)
        stress (eq. 5.1 / 6.1, components (r, theta, z) or (x, y)); ``P`` = tr sigma / D;
        ``dvr_dz``, ``dvz_dr`` (3D) or ``dvy_dx``, ``dvx_dy`` (2D): the half-cell gradients;
        ``D`` = D_rz or D_xy, their half sum; ``mu`` = -sigma_rz / P or -sigma_xy / P (the
        seed's mu*); ``mu_folded`` = mu* sgn(D) (positive where the shear stress opposes the
        deformation: in 2D D_xy changes sign with y, and the seed's mu* vs |I_s| plots fold
        the two halves); ``I`` = |D| sqrt(m / (P d^(D-2))) (3D I, 2D I_s); ``I_T`` =
        sqrt(T_g / (P d^D)); ``shear_ratio`` = |sigma_rz / sigma_zz| (3D) or |sigma_xy /
        sigma_xx| (2D; shear over the normal stress on the target); ``P_over_nT`` =
        P / (n T_g); ``P_alpha_over_nT_alpha`` (n, D) = sigma_aa / (n T_a) (Fig. 5.6);
        the normal rates by the same half-cell scheme, 3D ``dvr_dr``, ``vr_over_r``,
        ``dvz_dz``, 2D ``dvx_dx``, ``dvy_dy`` and ``D_ext`` = (dvx_dx - dvy_dy)/2;
        ``D_dev`` = sqrt(D':D'/2) the deviatoric magnitude, ``shear_fraction`` = |D| / D_dev
        and ``I_dev`` = D_dev sqrt(m / (P d^(D-2))) (:func:`_normal_strain_rates_3d`,
        :func:`_normal_strain_rates_2d`).

    errors : standard errors of the same names over the blocks (NaN with one block).
    blocks : number of blocks (replicas x blocks after :func:`pool`).
    diameter, mass : d and m used in I and I_T.
    sources : the three coarse-grained fields (mesh, half layers, shifted cells), kept so that
        :func:`pool` can pool replicas; None for tables built by hand.
    """

    dim: int
    target_radius: float
    layer: tuple[float, float]
    edges: np.ndarray
    values: Mapping[str, np.ndarray]
    errors: Mapping[str, np.ndarray]
    blocks: int = 1
    diameter: float = 1.0
    mass: float = 1.0
    sources: tuple[CGFields, CGFields, CGFields] | None = field(default=None, repr=False)

    @property
    def centres(self) -> np.ndarray:
        """Cell centres along r (3D) or y (2D)."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    @property
    def scaled_centres(self) -> np.ndarray:
        """Cell centres divided by R_tar (the abscissa of Figs. 5.3, 5.4, 6.3, 6.4)."""
        return self.centres / self.target_radius

    @property
    def volumes(self) -> np.ndarray:
        """Cell volumes: pi (r_{k+1}^2 - r_k^2) Delta z (3D), Delta y Delta x areas (2D)."""
        height = self.layer[1] - self.layer[0]
        if self.dim == 3:
            return pi * np.diff(self.edges**2) * height
        return np.diff(self.edges) * height

    @property
    def components(self) -> tuple[str, ...]:
        return ("r", "theta", "z") if self.dim == 3 else ("x", "y")

    def value(self, name: str) -> np.ndarray:
        if name not in self.values:
            raise ValueError(f"name: unknown value {name!r}; choose one of "
                             f"{', '.join(self.values)}")
        return self.values[name]

    def error(self, name: str) -> np.ndarray:
        """Standard error of a value over the blocks (NaN with one block)."""
        value = self.value(name)
        return self.errors[name] if name in self.errors else np.full_like(value, np.nan)

    def spread(self, name: str) -> np.ndarray:
        """Standard deviation of a value over the blocks (replicas after :func:`pool`)."""
        return self.error(name) * np.sqrt(self.blocks)

    phi = property(lambda self: self.values["phi"])
    n = property(lambda self: self.values["n"])
    velocity = property(lambda self: self.values["velocity"])
    T_g = property(lambda self: self.values["T_g"])
    T_alpha = property(lambda self: self.values["T_alpha"])
    sigma = property(lambda self: self.values["sigma"])
    P = property(lambda self: self.values["P"])
    D = property(lambda self: self.values["D"])
    mu = property(lambda self: self.values["mu"])
    mu_folded = property(lambda self: self.values["mu_folded"])
    I = property(lambda self: self.values["I"])  # noqa: E741
    I_T = property(lambda self: self.values["I_T"])
    shear_ratio = property(lambda self: self.values["shear_ratio"])


def _build(mesh: _Mesh, sources: Sequence[CGFields], diameter: float,
           mass: float) -> LayerFields:
    main, half, shifted = sources
    values = _values(mesh, main, half, shifted, diameter, mass)
    blocks = main.blocks
    if blocks < 2:
        errors = {k: np.full_like(v, np.nan) for k, v in values.items()}
    else:
        per_block = [_values(mesh, _block(main, b), _block(half, b), _block(shifted, b),
                             diameter, mass) for b in range(blocks)]
        errors = {}
        for k in values:
            stack = np.stack([pb[k] for pb in per_block])
            finite = np.sum(np.isfinite(stack), axis=0)
            with np.errstate(invalid="ignore", divide="ignore"):
                mean = np.nansum(np.where(np.isfinite(stack), stack, 0.0), axis=0) / finite
                dev = np.where(np.isfinite(stack), stack - mean, 0.0)
                var = np.sum(dev**2, axis=0) / (finite - 1)
            errors[k] = np.where(finite >= 2, np.sqrt(var) / np.sqrt(blocks), np.nan)
    return LayerFields(dim=mesh.dim, target_radius=mesh.target_radius, layer=mesh.layer,
                       edges=_frozen(mesh.edges),
                       values=MappingProxyType({k: _frozen(v) for k, v in values.items()}),
                       errors=MappingProxyType({k: _frozen(v) for k, v in errors.items()}),
                       blocks=blocks, diameter=diameter, mass=mass, sources=tuple(sources))


def layer_fields_3d(frames: Iterable[Frame], target_radius: float, *, layer: float = 5.0,
                    n_r: int = 5, window: tuple[float, float] | None = None, blocks: int = 1,
                    grains: Sequence[int] = GRAIN_TYPES, diameter: float = 1.0,
                    mass: float = 1.0) -> LayerFields:
    """The seed's 3D mesh next to the target (Sec. 5, Fig. 5.2): rings
    k dr < r < (k+1) dr, dr = R_tar / n_r, in the layer 0 < z < ``layer`` (Delta z = 5 d).

    Fields (Heaviside cell averages over the frames in ``window``): the stress of eq. (5.1) in
    cylindrical components (each grain's velocity and each piece of a branch line turned into
    (r, theta, z) where it lies, the seed's "calculate sigma in Cartesian coordinates and
    transform it"), P = sum_a sigma_aa / 3 (Sec. 5.3.1), T_g and T_alpha (Sec. 5.2, Fig. 5.6),
    mu* = -sigma_rz / P and I = |D_rz| sqrt(m / (P d)) (Sec. 5.3.3; the printed
    D_rz sqrt(P / (m d)) is upside down).

    Strain rate D_rz = (dv_r/dz + dv_z/dr)/2 by the seed's half-cell scheme (Sec. 5.3.3, "On
    the assumption of the zero yield stress"):

    * dv_r/dz (r, Delta z/2) = (v_r(r, 3 Delta z/4) - v_r(r, Delta z/4)) / (Delta z/2), the
      means of the ring in the half layers 0 < z < Delta z/2 and Delta z/2 < z < Delta z;
    * dv_z/dr (r) = (v_z(r + dr/2) - v_z(r - dr/2)) / dr, the means over the whole layer of the
      rings shifted by half a cell, 0 < r < dr/2 (standing for r = 0), dr/2 < r < 3 dr/2, ...,
      (n_r - 1/2) dr < r < (n_r + 1/2) dr (which reaches half a cell beyond R_tar).

    Both differences are exact for a velocity linear in z (r) when the grains' mean position in
    each half (shifted) cell is its nominal centre; the first shifted ring is assigned r = 0.

    Parameters
    ----------
    frames : frames (list or generator, read once) of a 3D jet, with their contact listing.
    target_radius : R_tar (the seed: 11 d).
    layer : Delta z, the layer's height above the target surface z = 0.
    n_r : number of rings (the seed: 5).
    window : (t_start, t_end) inclusive; None: every frame.
    blocks : consecutive groups of frames for the standard errors.
    grains : particle types that are grains; other types (the target, :data:`TARGET_TYPE`)
        count only through their contacts with grains (:func:`~grainflow.analysis.cg.select_types`).
    diameter, mass : d and m in I and I_T (units: 1).
    """
    mesh = _mesh_3d(target_radius, layer, n_r)
    d, m = _positive_number("diameter", diameter), _positive_number("mass", mass)
    sources = _accumulate(frames, mesh.grids(), (True, False, False), window, blocks, grains)
    return _build(mesh, sources, d, m)


def layer_fields_2d(frames: Iterable[Frame], target_radius: float, *,
                    layers: Sequence[tuple[float, float]] = ((0.0, 5.0), (5.0, 10.0)),
                    n_y: int = 10, window: tuple[float, float] | None = None, blocks: int = 1,
                    grains: Sequence[int] = GRAIN_TYPES, diameter: float = 1.0,
                    mass: float = 1.0) -> tuple[LayerFields, ...]:
    """The seed's 2D meshes next to the target (Sec. 6, Fig. 6.2): cells k dy < y < (k+1) dy,
    dy = 2 R_tar / n_y (R_tar / 5 for the seed's n_y = 10, k = -5..4), in each layer of
    ``layers`` along x ((a) 0 < x <= 5 d, (b) 5 d < x <= 10 d). One :class:`LayerFields` per
    layer, in the order given.

    Stress of eq. (6.1) in (x, y) components, P = (sigma_xx + sigma_yy)/2, T_g (Sec. 6.1.1),
    I_T = sqrt(T_g / (P d^2)), I_s = |D_xy| sqrt(m / P) (value ``I``) and mu* = -sigma_xy / P
    (Secs. 6.1.3-6.1.4). Strain rate D_xy = (dv_y/dx + dv_x/dy)/2 by the seed's half-cell
    scheme (Sec. 6.1.3): dv_y/dx from the means in the two halves of the layer (x in
    (lo, mid) and (mid, hi)), dv_x/dy = (v_x(y + dy/2) - v_x(y - dy/2)) / dy from the cells
    shifted by half a cell, -11 dy/2 < y < -9 dy/2, ..., 9 dy/2 < y < 11 dy/2, over the layer.

    Cells include their lower edge (x = lo counts, x = hi does not): the seed's 0 < x <= 5 d
    differs only on a set of measure zero.

    Parameters are those of :func:`layer_fields_3d`; ``n_y`` must be even (cells symmetric
    about the axis y = 0).
    """
    if isinstance(layers, (str, bytes)) or len(layers) < 1:
        raise ValueError(f"layers: expected a sequence of (lo, hi), got {layers!r}")
    meshes = [_mesh_2d(target_radius, lay, n_y) for lay in layers]
    d, m = _positive_number("diameter", diameter), _positive_number("mass", mass)
    grids = [g for mesh in meshes for g in mesh.grids()]
    sources = _accumulate(frames, grids, (True, False, False) * len(meshes), window, blocks,
                          grains)
    return tuple(_build(mesh, sources[3 * k:3 * k + 3], d, m) for k, mesh in enumerate(meshes))


def _mesh_of(layer: LayerFields) -> _Mesh:
    return _Mesh(layer.dim, layer.target_radius, layer.layer, np.asarray(layer.edges))


def pool(layers: Sequence[LayerFields]) -> LayerFields:
    """Pool replicas of the same layer (the seed averages ten initial configurations,
    Secs. 5 and 6): the coarse-grained sums are pooled (:func:`grainflow.analysis.cg.combine`)
    and every value recomputed; every block of every replica becomes a block, so the errors
    measure the spread over replicas (one block per replica: the errors are the standard error
    of the replica mean, ``spread`` the replicas' standard deviation).

    For 2D, pool each layer separately: ``[pool(ls) for ls in zip(*replicas)]``.
    """
    layers = list(layers)
    if not layers:
        raise ValueError("layers: give at least one LayerFields")
    first = layers[0]
    for lay in layers:
        if lay.sources is None:
            raise ValueError("layers: pooling needs the coarse-grained fields (sources); "
                             "LayerFields built by hand cannot be pooled")
        same = (lay.dim == first.dim and lay.target_radius == first.target_radius
                and lay.layer == first.layer and np.array_equal(lay.edges, first.edges)
                and lay.diameter == first.diameter and lay.mass == first.mass)
        if not same:
            raise ValueError("layers: replicas must share the mesh (dim, target radius, layer, "
                             "edges) and d, m")
    sources = [combine(*(lay.sources[k] for lay in layers)) for k in range(3)]
    return _build(_mesh_of(first), sources, first.diameter, first.mass)


# --------------------------------------------------------------------------------------------
# Kinetic theory (Sec. 5.3.1-5.3.2)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class KineticTheoryCheck:
    """Measured equation of state against Garzo-Dufty, eq. (5.2).

    Attributes
    ----------
    phi : (n,) packing fraction per cell.
    measured, measured_err : P / (n T_g) and its standard error.
    theory : 1 + 2^(D-2) (1 + e) phi chi(phi) (eq. 5.2 in 3D: 1 + 2 phi (1+e) chi; chi of
        eq. 5.3); NaN where phi >= phi_c (chi diverges) or phi is not finite.
    components : the stress components (r, theta, z) or (x, y).
    measured_components, measured_components_err : (n, D) P_a / (n T_a) with P_a = sigma_aa
        (Sec. 5.3.2, Fig. 5.6: the per-direction equations of state P_a = n T_a (1 + ...)).
    restitution, dim, phi_f, phi_c : what the theory used (None: the defaults of
        :func:`~grainflow.analysis.kinetic_theory.radial_distribution_contact`).
    """

    phi: np.ndarray
    measured: np.ndarray
    measured_err: np.ndarray
    theory: np.ndarray
    components: tuple[str, ...]
    measured_components: np.ndarray
    measured_components_err: np.ndarray
    restitution: float
    dim: int
    phi_f: float | None = None
    phi_c: float | None = None

    def curve(self, phi: ArrayLike) -> np.ndarray:
        """The theory at ``phi`` (NaN where phi >= phi_c)."""
        return _theory(np.asarray(phi, dtype=float), self.restitution, self.dim, self.phi_f,
                       self.phi_c)


def _theory(phi: np.ndarray, e: float, dim: int, phi_f, phi_c) -> np.ndarray:
    limit = RANDOM_CLOSE_PACKING[dim] if phi_c is None else phi_c
    ok = np.isfinite(phi) & (phi >= 0) & (phi < limit)
    out = np.full(phi.shape, np.nan)
    if np.any(ok):
        out[ok] = pressure_ratio(phi[ok], e, dim, phi_f, phi_c)
    return out


def kinetic_theory_check(layer: LayerFields, restitution: float, dim: int | None = None, *,
                         phi_f: float | None = None,
                         phi_c: float | None = None) -> KineticTheoryCheck:
    """P / (n T_g) measured per cell against the Garzo-Dufty equation of state, eq. (5.2)
    (3D: 1 + 2 phi (1 + e) chi, chi of eq. 5.3 with phi_f = 0.49, phi_c = 0.64), and the
    per-direction ratios sigma_aa / (n T_a) of Sec. 5.3.2 (Fig. 5.6).

    ``restitution``: e, or for frictional grains the effective e of eq. (2.55)
    (:func:`~grainflow.analysis.kinetic_theory.effective_restitution`; 0.616 for e = 0.75,
    mu_p = 0.2). ``dim`` defaults to the layer's; in 2D the disk form 1 + (1 + e) phi chi with
    the library's 2D defaults of phi_f, phi_c (pass the bidisperse packing's own phi_c).
    """
    dim = layer.dim if dim is None else dim
    if dim not in (2, 3):
        raise ValueError(f"dim: must be 2 or 3, got {dim!r}")
    phi = np.asarray(layer.phi, dtype=float)
    return KineticTheoryCheck(
        phi=phi, measured=layer.values["P_over_nT"], measured_err=layer.errors["P_over_nT"],
        theory=_frozen(_theory(phi, float(restitution), dim, phi_f, phi_c)),
        components=layer.components,
        measured_components=layer.values["P_alpha_over_nT_alpha"],
        measured_components_err=layer.errors["P_alpha_over_nT_alpha"],
        restitution=float(restitution), dim=dim, phi_f=phi_f, phi_c=phi_c)


@dataclass(frozen=True)
class ViscosityCheck:
    """Measured shear viscosity of a 3D layer against Garzo-Dufty, eqs. (5.4)-(5.12).

    Attributes (per ring; NaN where phi is not in (0, phi_c) or D_rz = 0)
    ----------
    r : ring centres / R_tar.
    phi, D : packing fraction and strain rate D_rz.
    eta : the measured viscosity -sigma_rz / D_rz (eq. 5.12: sigma_rz = -eta D_rz).
    eta_kin : eq. (5.5) at the ring's phi and T_g (d, m of the layer).
    ratio : eta / eta_kin (the thesis's Fig. 5.9 finds it close to 1 for r/R_tar > 0.2).
    slope : the ring's mu* / I (= eta / sqrt(P m / d)).
    slope_kin : :func:`~grainflow.analysis.kinetic_theory.friction_slope`, the mu* / I a ring
        with the kinetic theory's viscosity and pressure would have.
    restitution : e used (frictional grains: the renormalised e of eq. 2.55).
    """

    r: np.ndarray
    phi: np.ndarray
    D: np.ndarray
    eta: np.ndarray
    eta_kin: np.ndarray
    ratio: np.ndarray
    slope: np.ndarray
    slope_kin: np.ndarray
    restitution: float


def viscosity_check(layer: LayerFields, restitution: float) -> ViscosityCheck:
    """The 3D layer's shear viscosity eta = -sigma_rz / D_rz ring by ring against the
    kinetic theory's eta_kin(phi, T_g) (eq. 5.5; Fig. 5.9 of the thesis), and the ring's
    mu*/I against the slope a flow with that viscosity would give (Sec. 5.3.3: under
    I = D_rz sqrt(m / (P d)), mu*/I = eta / sqrt(P m / d)). ``restitution``: e, or the
    effective e of eq. (2.55) for frictional grains."""
    if layer.dim != 3:
        raise ValueError("layer: the kinetic-theory viscosity is for spheres; give a 3D "
                         "layer (layer_fields_3d)")
    v = layer.values
    phi = np.asarray(v["phi"], dtype=float)
    D = np.asarray(v["D"], dtype=float)
    ok = np.isfinite(phi) & (phi > 0) & (phi < RANDOM_CLOSE_PACKING[3]) & np.isfinite(v["T_g"])
    eta_kin = np.full(phi.shape, np.nan)
    slope_kin = np.full(phi.shape, np.nan)
    e = float(restitution)
    if np.any(ok):
        eta_kin[ok] = shear_viscosity(phi[ok], np.maximum(v["T_g"][ok], 0.0), e,
                                      layer.diameter, layer.mass)
        slope_kin[ok] = friction_slope(phi[ok], e)
    with np.errstate(invalid="ignore", divide="ignore"):
        eta = np.where(D != 0, -np.asarray(v["sigma"])[:, 0, 2] / D, np.nan)
        slope = np.where(np.asarray(v["I"]) > 0, v["mu"] / v["I"], np.nan)
        return ViscosityCheck(r=_frozen(layer.scaled_centres), phi=_frozen(phi), D=_frozen(D),
                              eta=_frozen(eta), eta_kin=_frozen(eta_kin),
                              ratio=_frozen(eta / eta_kin), slope=_frozen(slope),
                              slope_kin=_frozen(slope_kin), restitution=e)


# --------------------------------------------------------------------------------------------
# Fits (Sec. 5.3.3, Fig. 5.7; Secs. 6.1.3-6.1.4, Figs. 6.5, 6.7)
# --------------------------------------------------------------------------------------------


def rheology_points(layers: LayerFields | Sequence[LayerFields], x: str, y: str, *,
                    weighted: bool = True, select=None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The cells of several layers (replicas, phi_0 values, layers (a) and (b)) as fit data.

    Returns (x, y, sigma): the values ``x`` and ``y`` of every cell where both are finite and
    x > 0, concatenated over ``layers``; sigma the standard errors of y when ``weighted`` and
    every one of them is finite and > 0, else None (unweighted fit, errors from the residual).
    ``select(layer) -> bool mask`` picks cells (e.g. ``lambda l: l.scaled_centres > 0.2``).
    """
    if isinstance(layers, LayerFields):
        layers = [layers]
    xs, ys, es = [], [], []
    for lay in layers:
        xv, yv = np.asarray(lay.value(x)), np.asarray(lay.value(y))
        if xv.ndim != 1 or yv.ndim != 1:
            raise ValueError(f"x, y: need per-cell scalars, got {x!r} {xv.shape} and {y!r} "
                             f"{yv.shape}")
        ok = np.isfinite(xv) & np.isfinite(yv) & (xv > 0)
        if select is not None:
            ok &= np.asarray(select(lay), dtype=bool)
        xs.append(xv[ok])
        ys.append(yv[ok])
        es.append(np.asarray(lay.error(y))[ok])
    xa, ya, ea = np.concatenate(xs), np.concatenate(ys), np.concatenate(es)
    sigma = ea if weighted and ea.size and np.all(np.isfinite(ea) & (ea > 0)) else None
    return xa, ya, sigma


def _radial_range(r_range):
    if r_range is None:
        return None
    lo, hi = r_range
    return lambda lay: (lay.scaled_centres >= lo) & (lay.scaled_centres <= hi)


def fit_friction_3d(layers: LayerFields | Sequence[LayerFields], *, weighted: bool = True,
                    r_range: tuple[float, float] | None = None,
                    number: str = "I") -> MuLinearFit:
    """mu* = a I through the origin (zero yield stress, Sec. 5.3.3, Fig. 5.7; the seed:
    a = 0.240 frictional, 0.223 frictionless), by
    :func:`~grainflow.analysis.rheology.fit_mu_linear` on the cells' (I, mu*) with
    mu* folded by the sign of D_rz. ``r_range``: (lo, hi) of r / R_tar to keep (the seed notes
    the cell at r / R_tar = 0.1 deviates, an effect of the axis). ``number="I_dev"`` fits
    against the inertial number of the whole deviatoric rate instead (not the seed's; see
    :func:`fit_choices_3d`)."""
    if number not in ("I", "I_dev"):
        raise ValueError(f"number: 'I' or 'I_dev', got {number!r}")
    x, y, sigma = rheology_points(layers, number, "mu_folded", weighted=weighted,
                                  select=_radial_range(r_range))
    return fit_mu_linear(x, y, sigma)


def _fit_or_none(fit, *args, **kwargs):
    try:
        return fit(*args, **kwargs)
    except ValueError:
        return None


def fit_choices_3d(layers: Sequence[LayerFields]) -> list[tuple[str, int, MuLinearFit | None]]:
    """(label, rings, fit) of mu* = a I (Sec. 5.3.3) under the choices the seed leaves open:
    every ring weighted by its errors (the study's table), unweighted, the rings
    r / R_tar >= 0.2 (the seed notes the centre ring deviates), and I_dev, the inertial
    number of the whole deviatoric rate, in place of I (next to the target the flow is
    mostly a compression along z and an extension in r; D_rz is a part of it). A fit that
    cannot be made is None."""
    layers = list(layers)
    if not layers or any(lay.dim != 3 for lay in layers):
        raise ValueError("layers: give 3D LayerFields (layer_fields_3d)")
    choices = (("every ring, weighted (the table)", {}),
               ("every ring, unweighted", {"weighted": False}),
               ("rings r/R_tar >= 0.2", {"r_range": (0.2, np.inf)}),
               ("I_dev in place of I", {"number": "I_dev"}))
    rows = []
    for label, options in choices:
        cells = rheology_points(layers, options.get("number", "I"), "mu_folded",
                                select=_radial_range(options.get("r_range")))[0].size
        rows.append((label, cells, _fit_or_none(fit_friction_3d, layers, **options)))
    return rows


def fit_divergence_2d(layers: LayerFields | Sequence[LayerFields], number: str = "I", *,
                      weighted: bool = True, select=None) -> DivergenceFit:
    """phi = phi_c - a I^(2/alpha), eq. (6.3) with ``number="I"`` (I_s; the seed: phi_s = 0.834,
    a_s = 3.94, alpha_s = 1.36) or eq. (6.2) with ``number="I_T"`` (phi_T = 0.858,
    a_T = 0.980, alpha_T = 1.15), by :func:`~grainflow.analysis.rheology.fit_divergence`
    (Levenberg-Marquardt, Sec. 6.1.3) over the cells of ``layers`` ((a) and (b) together, as
    Fig. 6.5). ``number="I_dev"`` puts the whole deviatoric rate in place of D_xy (not the
    seed's; see :func:`fit_choices_2d`); ``select`` picks cells as in :func:`rheology_points`."""
    if number not in ("I", "I_T", "I_dev"):
        raise ValueError(f"number: 'I' (I_s), 'I_T' or 'I_dev', got {number!r}")
    x, y, sigma = rheology_points(layers, number, "phi", weighted=weighted, select=select)
    return fit_divergence(x, y, sigma)


def fit_friction_2d(layers: LayerFields | Sequence[LayerFields], law: str = "mu_of_I", *,
                    mu_s: float | None = 0.0, weighted: bool = True, number: str = "I",
                    select=None) -> MuOfIFit | MuPowerLawFit:
    """mu*(I_s) over the cells of ``layers`` (Sec. 6.1.4, Fig. 6.7), mu* folded by the sign of
    D_xy (the cells y < 0 mirror those y > 0).

    ``law="mu_of_I"``: mu* = mu_s + (mu_max - mu_s)/(1 + I0/I_s), eq. (2.57) (eq. 6.9 as
    printed is a typo; the seed: mu_s = 0.0153, mu_max = 0.521, I0 = 0.082).
    ``law="power_law"``: mu* = mu_s + b I_s^beta, eq. (6.10), with ``mu_s`` fixed (the seed:
    0, giving b = 1.18, beta = 0.592) or fitted (None).
    ``number="I_dev"`` fits against the inertial number of the whole deviatoric rate instead
    of I_s; ``select`` picks cells as in :func:`rheology_points`.
    """
    if law not in ("mu_of_I", "power_law"):
        raise ValueError(f"law: 'mu_of_I' or 'power_law', got {law!r}")
    if number not in ("I", "I_dev"):
        raise ValueError(f"number: 'I' (I_s) or 'I_dev', got {number!r}")
    x, y, sigma = rheology_points(layers, number, "mu_folded", weighted=weighted, select=select)
    if law == "mu_of_I":
        return fit_mu_of_I(x, y, sigma)
    return fit_mu_power_law(x, y, sigma, mu_s)


@dataclass(frozen=True)
class FitChoice2D:
    """The 2D fits of eqs. (6.2), (6.3) and (2.57) under one choice of cells, weights or
    strain rate (:func:`fit_choices_2d`); a fit that fails is None."""

    label: str
    cells: int
    I_s: DivergenceFit | None
    I_T: DivergenceFit | None
    friction: MuOfIFit | None


def fit_choices_2d(layers: Sequence[LayerFields], *, min_shear_fraction: float = 0.5
                   ) -> list[FitChoice2D]:
    """The 2D fits (phi_s, phi_T, mu(I)) under the choices the seed leaves open, to show how far
    each moves them (Sec. 6.1.3 says only "Levenberg-Marquardt"):

    1. every cell of every layer, weighted by the cells' errors (the study's table);
    2. the same unweighted;
    3. the layer nearest the target alone ((a), 0 < x <= 5 d), and 4. the others ((b));
    5. only cells whose deformation is mostly shear in the x, y axes (``shear_fraction`` >=
       ``min_shear_fraction``: on the stagnation line the flow is an extension and D_xy ~ 0);
    6. I_dev (the whole deviatoric rate) in place of I_s, every cell.

    The I_T fit does not use the strain rate: it changes only with the cells and weights.
    ``layers``: 2D :class:`LayerFields` (layers (a) and (b), any number of phi_0 and pooled
    replicas)."""
    layers = list(layers)
    if not layers or any(lay.dim != 2 for lay in layers):
        raise ValueError("layers: give 2D LayerFields (layer_fields_2d)")
    nearest = min(lay.layer[0] for lay in layers)
    inner = [lay for lay in layers if lay.layer[0] == nearest]
    outer = [lay for lay in layers if lay.layer[0] != nearest]

    def sheared(lay: LayerFields) -> np.ndarray:
        return np.asarray(lay.values["shear_fraction"]) >= min_shear_fraction

    choices = (("every cell, weighted (the table)", layers, {}, "I"),
               ("every cell, unweighted", layers, {"weighted": False}, "I"),
               ("layer (a) alone", inner, {}, "I"),
               ("layer (b) alone", outer, {}, "I"),
               (f"cells with shear fraction >= {min_shear_fraction:g}", layers,
                {"select": sheared}, "I"),
               ("I_dev in place of I_s", layers, {}, "I_dev"))
    rows = []
    for label, group, options, number in choices:
        if not group:
            continue
        cells = rheology_points(group, number, "phi", select=options.get("select"))[0].size
        rows.append(FitChoice2D(
            label, cells,
            _fit_or_none(fit_divergence_2d, group, number, **options),
            _fit_or_none(fit_divergence_2d, group, "I_T", **options),
            _fit_or_none(fit_friction_2d, group, "mu_of_I", number=number, **options)))
    return rows


# --------------------------------------------------------------------------------------------
# Velocity distributions in the layer (Sec. 5.3.3, Fig. 5.8, Table 5.1)
# --------------------------------------------------------------------------------------------


def _cells_and_components(frame: Frame, mesh: _Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Cell index of each grain (-1 outside the mesh) and its velocity components ((r, theta,
    z) in 3D, (x, y) in 2D)."""
    x = np.asarray(frame.position, dtype=float)
    v = np.asarray(frame.velocity, dtype=float)
    lo, hi = mesh.layer
    if mesh.dim == 3:
        r = np.hypot(x[:, 0], x[:, 1])
        safe = np.where(r > 0, r, 1.0)
        c, s = np.where(r > 0, x[:, 0] / safe, 1.0), np.where(r > 0, x[:, 1] / safe, 0.0)
        comps = np.column_stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1], v[:, 2]])
        across, along = r, x[:, 2]
    else:
        comps = v.copy()
        across, along = x[:, 1], x[:, 0]
    e = mesh.edges
    cell = np.searchsorted(e, across, side="right") - 1
    inside = (across >= e[0]) & (across < e[-1]) & (along >= lo) & (along < hi)
    return np.where(inside, cell, -1), comps


def layer_fluctuations(frames: Iterable[Frame], target_radius: float, *, dim: int = 3,
                       layer: float | tuple[float, float] | None = None,
                       n_cells: int | None = None, cells: ArrayLike | None = None,
                       window: tuple[float, float] | None = None,
                       grains: Sequence[int] = GRAIN_TYPES, scaled: bool = True
                       ) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Velocity fluctuations of the grains in the layer's cells, pooled (Sec. 5.3.3, Fig. 5.8).

    u = v - V_cell, V_cell the cell's mass-weighted mean over the window (as the kinetic
    stress); with ``scaled`` each component is divided by the cell's sqrt(<u_a^2>) =
    sqrt(T_a / m), so that cells of different temperature pool into one distribution
    c_a = u_a / v_a0 of unit variance (:func:`~grainflow.analysis.rheology.velocity_distribution`
    explains why v_a0 = sqrt(T_a/m), not the printed sqrt(2 T_a / m)).

    Parameters
    ----------
    dim : 3 (mesh of :func:`layer_fields_3d`; ``layer`` the height, default 5) or 2 (mesh of
        :func:`layer_fields_2d`; ``layer`` (lo, hi), default (0, 5)).
    n_cells : number of rings (3D, default 5) or of y cells (2D, default 10).
    cells : indices of the cells to pool (default all).

    Returns
    -------
    (u (N, D), masses (N,), components): components (r, theta, z) in 3D, (x, y) in 2D.
    """
    if dim == 3:
        mesh = _mesh_3d(target_radius, 5.0 if layer is None else layer,
                        5 if n_cells is None else n_cells)
    elif dim == 2:
        mesh = _mesh_2d(target_radius, (0.0, 5.0) if layer is None else layer,
                        10 if n_cells is None else n_cells)
    else:
        raise ValueError(f"dim: must be 2 or 3, got {dim!r}")
    check_window(window)
    n = mesh.edges.size - 1
    chosen = np.arange(n) if cells is None else np.asarray(cells, dtype=int).ravel()
    if chosen.size == 0 or np.any((chosen < 0) | (chosen >= n)):
        raise ValueError(f"cells: indices in [0, {n}), got {cells!r}")
    cell_list, comp_list, mass_list = [], [], []
    for frame in frames:
        if window is not None and not window[0] <= frame.time <= window[1]:
            continue
        if frame.dim != dim:
            raise ValueError(f"dim: {dim}D mesh, but the frame at step {frame.step} is "
                             f"{frame.dim}D")
        grain = select_types(frame, grains)
        cell, comps = _cells_and_components(grain, mesh)
        keep = np.isin(cell, chosen)
        cell_list.append(cell[keep])
        comp_list.append(comps[keep])
        mass_list.append(np.asarray(grain.mass, dtype=float)[keep])
    if not cell_list:
        raise ValueError("frames: no frame lies in the window" if window is not None
                         else "frames: no frames given")
    cell = np.concatenate(cell_list)
    comps = np.concatenate(comp_list) if comp_list else np.zeros((0, dim))
    mass = np.concatenate(mass_list)
    u = np.zeros_like(comps)
    for k in np.unique(cell):
        rows = cell == k
        mean = np.average(comps[rows], axis=0, weights=mass[rows])
        u[rows] = comps[rows] - mean
        if scaled:
            std = np.sqrt(np.average(u[rows] ** 2, axis=0, weights=mass[rows]))
            u[rows] = u[rows] / np.where(std > 0, std, np.nan)
    good = np.all(np.isfinite(u), axis=1)
    components = ("r", "theta", "z") if dim == 3 else ("x", "y")
    return u[good], mass[good], components


def layer_flatness(frames: Iterable[Frame], target_radius: float, **kwargs) -> dict[str, float]:
    """Flatness <u^4>/<u^2>^2 per component of the layer's pooled fluctuations (Table 5.1:
    2.87 / 2.86 / 3.41 (z / r / theta) frictionless and 2.70 / 2.98 / 3.71 frictional at
    phi0/phi_fcc = 0.90; Gaussian 3, exponential 6), by
    :func:`~grainflow.analysis.rheology.flatness` on :func:`layer_fluctuations` (same keyword
    arguments). Returns {component: flatness}."""
    u, masses, components = layer_fluctuations(frames, target_radius, **kwargs)
    values = np.atleast_1d(flatness(u, masses))
    return {name: float(v) for name, v in zip(components, values)}
