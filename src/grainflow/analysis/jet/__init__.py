"""Analyses of granular jets hitting a target after seed 002 (H. Sano, PhD thesis (2013);
Sano & Hayakawa, PRE 86, 041308 (2012)): pure functions of saved frames
(:class:`~grainflow.frame.Frame`, e.g. from :func:`grainflow.io.h5md.read_frames`) and of
coarse-grained fields.

* :mod:`~grainflow.analysis.jet.scattering` (Sec. 4.1): the scattering angle psi0 from the
  velocities of the grains crossing a shell around the target;
* :mod:`~grainflow.analysis.jet.force_balance` (Sec. 4.1.1, eq. 4.3): psi0 from the momentum
  balance on the target, the thesis's own definition;
* :mod:`~grainflow.analysis.jet.psi0_fit` (Fig. 4.2): the interpolation function psi0(X) and
  its fit;
* :mod:`~grainflow.analysis.jet.anisotropy` (Sec. 4.2, Fig. 4.3): the azimuthal flux dN/dphi
  of rectangular jets and its harmonics v_n;
* :mod:`~grainflow.analysis.jet.dead_zone` (Sec. 6.1.1): the frozen region next to the target;
* :mod:`~grainflow.analysis.jet.rheology` (chapters 5 and 6): stress, temperature, packing
  fraction and strain rate in the seed's layers and meshes, the kinetic-theory check, mu*(I),
  the jamming-type fits and flatness.

The names of the first five are importable from this package.

Geometry of the jet scenarios (fixed conventions; the functions take them as arguments with
these defaults)
-----------------------------------------------------------------------------------------------
* Units: d (the largest grain diameter) = 1, m = 1, u0 = 1 (the jet speed).
* 3D: the jet travels along ``direction`` = -z at speed u0, its axis the z axis (x = y = 0).
  The target is one layer of wall particles of type :data:`TARGET_TYPE` = 2 with centres at
  z = -0.5 inside a disk of radius R_tar, so its surface lies near z = 0; ``centre`` = (0, 0, 0)
  is where the axis meets the target surface.
* 2D: the jet travels along -x, its axis is y = 0; the target is a line of wall particles
  (type 2) at x = -0.5 for |y| <= R_tar; ``centre`` = (0, 0).
* Grains have types 0 and 1; the default ``grains`` selection is every particle whose type is
  not :data:`TARGET_TYPE`. ``grains`` may also be a sequence of types or a callable
  ``frame -> (N,) bool mask``.
* X = D_tar / D_jet = R_tar / R_jet (thesis Sec. 4.1). Positions are taken as they are (the
  jet scenarios are not periodic; no minimum image is applied).

Frames are read once, in order; ``window = (t0, t1)`` keeps those with t0 <= time <= t1 (the
thesis averages over t u0/d = 50-100 in 3D, 180-300 in 2D). A single Frame is accepted too.

The scattering shell
--------------------
The outgoing flow is observed where it crosses a shell around ``centre``: a spherical (3D) or
circular (2D) shell R_s <= |r - centre| < R_s + ``shell_width`` with

    R_s = shell_factor * max(R_tar, R_jet) + shell_offset      (defaults 1.5 and 3 d; width 2 d),

so it lies outside the target and the incoming jet, where the sheet or cone has formed. The
jet scenarios delete grains beyond ``removal_radius`` (default max(R_tar, R_jet) + 15 d): keep
R_s + shell_width inside it (true with the defaults while max(R_tar, R_jet) < 20 d). A grain
in the shell counts as *scattered* when

* it moves outward, w_i = v_i . r_hat_i > 0 (the incoming jet crosses the upstream half of the
  shell moving inward and is excluded), and
* its velocity differs from the incoming one by more than ``deflection`` u0,
  |v_i - u0 n| > deflection u0 (default 0.25), so that jet grains passing undeflected beside a
  small target (X < 1) do not count. A cone at the thesis's smallest angle psi0 ~ C2 = 0.55
  rad has |v - u0 n| >= 2 u0 sin(psi0/2) ~ 0.54 u0 even without loss of speed.

The force balance
-----------------
:func:`force_balance_angle` is a second definition of psi0, the one of Clanet's model that
eq. (4.3) states, 1 - cos psi0 = F_wall / J_in, from the force of the grains on the target
(frames saved with contacts) and the momentum flux of the incoming jet; it uses no shell.

Errors are delete-one jackknife estimates over ``blocks`` consecutive groups of frames (for a
plain mean this is the usual std/sqrt(blocks) of the block means; for the ratios used here it
also copes with blocks that hold few grains). With one block (e.g. a single frame) the jackknife
runs over the individual grain samples instead, which treats grains as independent and
underestimates the error of a correlated flow.

Fits (:func:`fit_psi0`) use :func:`scipy.optimize.least_squares`; standard errors are the square
roots of the covariance diagonal, (J^T J)^-1 from the Jacobian J of the weighted residuals:
absolute when ``psi0_err`` is given, scaled by the residual variance chi^2/dof when not.
"""

from grainflow.analysis.jet._common import TARGET_TYPE, GrainSelection
from grainflow.analysis.jet.anisotropy import (JET_AREA, SEED_V2, Anisotropy, AzimuthalFlux,
                                               anisotropy_v2, aspect_ratio, azimuthal_flux,
                                               eccentricity, rectangle_sides)
from grainflow.analysis.jet.dead_zone import DeadZone, dead_zone
from grainflow.analysis.jet.force_balance import ForceBalanceAngle, force_balance_angle
from grainflow.analysis.jet.psi0_fit import SEED_PSI0_FIT, Psi0Fit, fit_psi0, psi0_interpolation
from grainflow.analysis.jet.scattering import ScatteringAngle, scattering_angle

__all__ = [
    "TARGET_TYPE", "SEED_PSI0_FIT", "SEED_V2", "JET_AREA", "GrainSelection",
    "ScatteringAngle", "scattering_angle", "ForceBalanceAngle", "force_balance_angle",
    "psi0_interpolation", "Psi0Fit", "fit_psi0",
    "AzimuthalFlux", "azimuthal_flux", "Anisotropy", "anisotropy_v2",
    "eccentricity", "aspect_ratio", "rectangle_sides",
    "DeadZone", "dead_zone",
]
