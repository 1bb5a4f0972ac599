"""Scattering angle psi0 of the outgoing sheet or cone from the grains' velocities, after seed
002 Sec. 4.1 and Fig. 4.2 (H. Sano, PhD thesis (2013); Sano & Hayakawa, PRE 86, 041308 (2012)):
the direction of the (flux-weighted) mean velocity of the scattered grains crossing the shell
around the target (:mod:`grainflow.analysis.jet`, "The scattering shell")."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.jet._common import (GrainSelection, check_weighting, jackknife,
                                            jackknife_units, shell_samples, unit_sums)
from grainflow.frame import Frame


@dataclass(frozen=True, kw_only=True)
class ScatteringAngle:
    """Scattering angle of the outgoing flow (:func:`scattering_angle`).

    Attributes
    ----------
    psi0 : angle in rad between the direction of travel of the incoming jet and the mean
        (flux-weighted by default) velocity of the scattered grains in the meridional plane;
        pi/2 for a flat sheet, > pi/2 for a backward cone.
    psi0_err : jackknife standard error (see the module notes); NaN when it cannot be formed.
    axial, radial : the weighted means <v . n> and <v . e_rho> whose atan2 is psi0.
    n_grains : grain samples used (a grain counts once per frame it is found in the shell).
    n_frames : frames in the window; blocks : jackknife blocks (1: over grains).
    X : R_tar / R_jet; shell_radius, shell_width : the shell; weighting : "flux" or "count".
    """

    psi0: float
    psi0_err: float
    axial: float
    radial: float
    n_grains: int
    n_frames: int
    blocks: int
    X: float
    shell_radius: float
    shell_width: float
    weighting: str


def scattering_angle(
    frames: Frame | Iterable[Frame],
    *,
    target_radius: float,
    jet_radius: float,
    direction: ArrayLike | None = None,
    centre: ArrayLike | None = None,
    grains: GrainSelection = None,
    window: tuple[float, float] | None = None,
    u0: float = 1.0,
    deflection: float = 0.25,
    shell_factor: float = 1.5,
    shell_offset: float = 3.0,
    shell_width: float = 2.0,
    weighting: str = "flux",
    blocks: int | None = None,
) -> ScatteringAngle:
    """Scattering angle psi0 of a granular jet from particle data (thesis Sec. 4.1, Fig. 4.2).

    psi0 is measured from the incoming jet axis, the direction of travel n (seed 002,
    "psi0 convention" in PARAMETERS.md): eq. (4.3), 1 - cos psi0 = 4 A_cs / (pi D_jet^2), gives
    psi0 -> 0 for a vanishing target (narrow forward cone, psi0 ~ C1 X), pi/2 for a flat sheet
    along the target and > pi/2 for a backward cone (C0 = 1.68 rad for large targets).

    Extraction (the thesis does not say how it measured psi0; this is our definition). Take the
    scattered grains in the shell around the target centre (module notes: outward moving,
    deflected by more than ``deflection`` u0). Split each velocity into its component along
    the direction of travel, b_i = v_i . n, and its component away from the jet axis,
    a_i = v_i . e_rho,i, with e_rho,i the unit vector from the axis to the grain, perpendicular
    to n (2D: +-y; a grain exactly on the axis uses |v_perp|). Then::

        psi0 = atan2( sum_i w_i a_i , sum_i w_i b_i ),

    summed over the scattered grains of all frames of the window. Averaging the meridional
    components (not the velocity vectors, whose radial parts cancel round the axis) keeps
    psi0 in [0, pi]; averaging components rather than per-grain angles keeps thermal noise from
    biasing it.

    Weighting. ``"flux"`` (default): w_i = m_i (v_i . r_hat_i), the grain's outward radial
    velocity times its mass. sum_i w_i v_i / shell_width is then the momentum flux through the
    shell, so psi0 is the direction of the scattered momentum flux, the quantity whose axial
    part j_sc cos psi0 enters the momentum balance (4.2) of Clanet's model that defines psi0;
    every crossing counts once whatever its speed, and slow grains lingering in the shell
    (which a snapshot oversamples in proportion to 1/speed) do not bias it. ``"count"``:
    w_i = m_i, the direction of the mean (mass-weighted) velocity of the grains in the shell.
    The two agree when the outgoing grains share one speed.

    Parameters
    ----------
    frames : saved frames (a list, a generator such as :func:`grainflow.io.h5md.read_frames`,
        or one Frame).
    target_radius, jet_radius : R_tar and R_jet in units of d, > 0.
    direction : direction of travel of the jet; default -z (3D) or -x (2D).
    centre : where the jet axis meets the target surface; default the origin.
    grains : which particles are grains (module notes); default type != TARGET_TYPE.
    window : (t_start, t_end) of the steady state, inclusive; default every frame.
    u0 : speed of the incoming jet.
    deflection : minimum |v - u0 n| / u0 of a scattered grain, >= 0.
    shell_factor, shell_offset, shell_width : the shell R_s <= r < R_s + width with
        R_s = shell_factor * max(R_tar, R_jet) + shell_offset.
    weighting : "flux" or "count" (above).
    blocks : blocks of consecutive frames for the jackknife error; default min(10, frames);
        1 runs the jackknife over the grain samples.
    """
    weighting = check_weighting(weighting)
    s = shell_samples(frames, target_radius=target_radius, jet_radius=jet_radius,
                      direction=direction, centre=centre, grains=grains, window=window, u0=u0,
                      deflection=deflection, shell_factor=shell_factor,
                      shell_offset=shell_offset, shell_width=shell_width)
    n = s.geo.n
    b = s.velocity @ n
    perp = s.position - np.outer(s.position @ n, n)
    rho = np.linalg.norm(perp, axis=1)
    v_perp = s.velocity - np.outer(b, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(rho > 1e-12, np.einsum("ij,ij->i", v_perp, perp) / rho,
                     np.linalg.norm(v_perp, axis=1))
    w = s.mass * (s.outward if weighting == "flux" else 1.0)
    unit, n_units, n_blocks = jackknife_units(s, blocks)
    sums = [np.sum(w * a), np.sum(w * b), np.sum(w)]
    per_unit = [unit_sums(unit, n_units, w * a), unit_sums(unit, n_units, w * b)]
    psi0 = float(np.arctan2(sums[0], sums[1]))
    err = float(jackknife(lambda ya, yb: np.arctan2(ya, yb), sums[:2], per_unit))
    return ScatteringAngle(
        psi0=psi0, psi0_err=err, axial=float(sums[1] / sums[2]),
        radial=float(sums[0] / sums[2]), n_grains=int(w.size), n_frames=s.n_frames,
        blocks=n_blocks, X=float(target_radius) / float(jet_radius),
        shell_radius=s.shell_radius, shell_width=s.shell_width, weighting=weighting,
    )
