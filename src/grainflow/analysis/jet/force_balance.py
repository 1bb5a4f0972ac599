"""Scattering angle psi0 from the momentum balance on the target, the definition of Clanet's
model that seed 002 states in Sec. 4.1.1, eq. (4.3): 1 - cos psi0 = F_wall / J_in, with F_wall the
grains' force on the target along the jet and J_in the incoming jet's momentum flux."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from grainflow.analysis.checks import each_frame
from grainflow.analysis.checks import non_negative as _non_negative
from grainflow.analysis.checks import positive as _positive
from grainflow.analysis.jet._common import (GrainSelection, JetGeometry, block_count, block_of,
                                            check_dim, check_window, grain_mask, in_window,
                                            jackknife, jet_geometry, target_mask, unit_sums)
from grainflow.frame import ANCHOR, PAIR, Frame


#: Fraction of the jet's undisturbed extent kept (the middle) by ``line_density="initial"``.
_INITIAL_MIDDLE = 0.6
#: Smallest share of the first frame's grains that must move at u0 n (``"initial"``).
_INITIAL_UNDISTURBED = 0.95
#: At most this many equal sub-slabs, each at least _SUBSLAB_LENGTH long, give the error of
#: the initial line density (shorter ones would measure the lattice's layering).
_INITIAL_SUBSLABS = 10
_SUBSLAB_LENGTH = 10.0


@dataclass(frozen=True, kw_only=True)
class ForceBalanceAngle:
    """Scattering angle from the momentum balance on the target (:func:`force_balance_angle`).

    Attributes
    ----------
    psi0 : arccos(1 - F_wall / J_in) in rad, eq. (4.3); pi/2 when the target absorbs the
        incoming momentum flux J_in, > pi/2 when it receives more (backward cone).
    psi0_err : jackknife standard error over blocks of frames (the error of J_in is not
        included unless J_in comes from the window); NaN when it cannot be formed.
    ratio, ratio_err : F_wall / J_in = 1 - cos psi0 = 4 A_cs / (pi D_jet^2), the total cross
        section A_cs = F_wall / j_in of eq. (4.3) over the jet's cross-section, and its error.
    F_wall, F_wall_err : force of the grains on the target along the direction of travel n,
        averaged over the frames used, and its jackknife error.
    J_in, J_in_err : momentum flux of the incoming jet lambda m u0^2 (mass flow rate times u0)
        and its standard error (0 for a given line density; NaN for an initial jet too short
        for two sub-slabs).
    lambda_ : grains per unit length of the undisturbed jet.
    n_frames : frames whose force entered the mean; n_skipped : frames of the window left out
        (``line_density="window"``: upstream slab not filled by the jet).
    blocks : jackknife blocks (1: over single frames).
    force : "contacts" or "anchors"; line_density : "initial", "window" or "given".
    """

    psi0: float
    psi0_err: float
    ratio: float
    ratio_err: float
    F_wall: float
    F_wall_err: float
    J_in: float
    J_in_err: float
    lambda_: float
    n_frames: int
    n_skipped: int
    blocks: int
    force: str
    line_density: str


def _where(frame: Frame) -> str:
    return f"the frame at step {frame.step} (t = {frame.time:g})"


def _wall_force(frame: Frame, geo: JetGeometry, grains: GrainSelection, target: GrainSelection,
                force: str) -> float:
    """F_wall . n of one frame: force of the grains on the target (or minus the anchors')."""
    c = frame.contacts
    if c is None:
        raise ValueError(f"frames: {_where(frame)} holds no contacts; save them with the run "
                         "(output.contacts = true) to measure the force on the target")
    t_mask = target_mask(frame, target)
    if not t_mask.any():
        raise ValueError(f"target: {_where(frame)} holds no target particle (check the target "
                         "selection)")
    ids = np.asarray(frame.id)
    t_ids = ids[t_mask]
    f = np.asarray(c.force, dtype=float).reshape(-1, geo.dim)
    kind = np.asarray(c.kind)
    on_target = np.isin(c.i, t_ids)
    if force == "anchors":
        rows = (kind == ANCHOR) & on_target
        if not rows.any():
            raise ValueError(f"force: 'anchors' needs tether rows (kind ANCHOR) on the target; "
                             f"{_where(frame)} has none: use force='contacts'")
        return float(-(f[rows].sum(axis=0) @ geo.n))
    g_ids = ids[grain_mask(frame, grains) & ~t_mask]
    pair = kind == PAIR
    from_grain = pair & on_target & np.isin(c.j, g_ids)  # force on target i from grain j
    on_grain = pair & np.isin(c.i, g_ids) & np.isin(c.j, t_ids)  # on grain i from target j
    return float((f[from_grain].sum(axis=0) - f[on_grain].sum(axis=0)) @ geo.n)


def _jet_grains(frame: Frame, geo: JetGeometry, grains: GrainSelection, u0: float,
                undisturbed: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Of the grains: height h = (x - centre) . (-n) above the target surface, distance from
    the jet axis, mass, and the undisturbed flag |v - u0 n| <= undisturbed u0."""
    mask = grain_mask(frame, grains)
    x = np.asarray(frame.position, dtype=float)[mask] - geo.centre
    v = np.asarray(frame.velocity, dtype=float)[mask]
    still = np.linalg.norm(v - u0 * geo.n, axis=1) <= undisturbed * u0
    h = -(x @ geo.n)
    lateral = np.linalg.norm(x + np.outer(h, geo.n), axis=1)
    return h, lateral, np.asarray(frame.mass, dtype=float)[mask], still


def _initial_line_density(frame: Frame, geo: JetGeometry, grains: GrainSelection, u0: float,
                          undisturbed: float) -> tuple[float, float, float]:
    """(lambda, mass per length, its error) of the undisturbed jet in the first frame."""
    h, _, m, still = _jet_grains(frame, geo, grains, u0, undisturbed)
    if h.size == 0:
        raise ValueError(f"line_density: 'initial' found no grains in the first frame given "
                         f"({_where(frame)}); check the grains selection")
    share = float(still.mean())
    if share < _INITIAL_UNDISTURBED:
        raise ValueError(
            f"line_density: 'initial' measures the jet in the first frame given, which must "
            f"show the undisturbed jet (t = 0 of the jet scenarios); in {_where(frame)} only "
            f"{share:.1%} of the grains move at u0 n (within {undisturbed:g} u0). Pass the "
            "frames from t = 0, a number, or line_density='window'")
    hj, mj = h[still & (h > 0)], m[still & (h > 0)]
    if hj.size == 0:
        raise ValueError(f"line_density: no undisturbed grain upstream of the target in "
                         f"{_where(frame)}; check direction and centre")
    lo, hi = float(hj.min()), float(hj.max())
    trim = 0.5 * (1.0 - _INITIAL_MIDDLE) * (hi - lo)
    a, b = lo + trim, hi - trim
    inside = (hj >= a) & (hj < b)
    if b <= a or inside.sum() < 10:
        raise ValueError(f"line_density: the undisturbed jet in {_where(frame)} is too short "
                         f"to measure ({inside.sum()} grains in its middle "
                         f"{_INITIAL_MIDDLE:.0%}); pass a number")
    length = b - a
    k = min(_INITIAL_SUBSLABS, int(length // _SUBSLAB_LENGTH))
    err = float("nan")
    if k >= 2:
        sub = np.clip(((hj[inside] - a) / (length / k)).astype(int), 0, k - 1)
        per_sub = np.bincount(sub, weights=mj[inside], minlength=k) / (length / k)
        err = float(np.std(per_sub, ddof=1) / np.sqrt(k))
    return float(inside.sum()) / length, float(mj[inside].sum()) / length, err


def _psi0_of(ratio: np.ndarray) -> np.ndarray:
    return np.arccos(np.clip(1.0 - ratio, -1.0, 1.0))


def force_balance_angle(
    frames: Frame | Iterable[Frame],
    *,
    force: str = "contacts",
    line_density: str | float = "initial",
    direction: ArrayLike | None = None,
    centre: ArrayLike | None = None,
    grains: GrainSelection = None,
    target: GrainSelection = None,
    window: tuple[float, float] | None = None,
    upstream: tuple[float, float] = (10.0, 20.0),
    u0: float = 1.0,
    undisturbed: float = 0.05,
    blocks: int | None = None,
) -> ForceBalanceAngle:
    """Scattering angle psi0 defined by the momentum balance of Clanet's model (thesis
    Sec. 4.1.1, eqs. 4.1-4.3), from the force of the grains on the target.

    With the incoming momentum flux J_in = (pi D_jet^2 / 4) j_in, the scattered one
    J_sc = pi D_tar h(D_tar/2) j_sc and F_wall the force the grains exert on the target along
    the jet's direction of travel n, conservation of the flux (4.1) and the momentum balance
    along n (4.2) read::

        J_sc - J_in = 0,        J_sc cos psi0 - J_in = -F_wall,

    so that (4.3)::

        1 - cos psi0 = F_wall / J_in = 4 A_cs / (pi D_jet^2),   A_cs = F_wall / j_in.

    Here J_in = lambda m u0^2 (mass flow rate lambda m u0 times u0; lambda = grains per unit
    length of the undisturbed jet; masses are summed, so mixed masses are fine) and
    psi0 = arccos(1 - <F_wall> / J_in). This is the angle eq. (4.3) defines; the direction of
    the outgoing velocities (:func:`scattering_angle`) need not agree with it, since
    inelastic grains do not conserve the momentum flux (4.1).

    Force (``force``). ``"contacts"`` (default): per frame, the sum over the particle-pair
    contacts (kind PAIR of :class:`~grainflow.frame.Contacts`) between a target particle and
    a grain of the force on the target particle, projected on n (rows may list either
    particle first; for those listed on the grain, Newton's third law). Contacts between two
    target particles, tethers (BOND, ANCHOR) and wall contacts do not count. It is the force
    the grains exert, whatever holds the target. ``"anchors"``: minus the tether forces
    holding the target to its anchor points (ANCHOR rows on target particles), projected on
    n. In a steady state it equals the contact force on average (the bonds between target
    particles cancel in pairs), with the target's oscillations as extra noise; it needs a
    tethered target. Every frame in the window must hold contacts (``output.contacts``).

    Line density (``line_density``).

    * ``"initial"`` (default): measured in the first frame of ``frames``, whether or not it
      lies in the window. That frame must show the undisturbed jet (t = 0 of the jet
      scenarios, where every grain moves at u0 n): at least 95 % of its grains must move
      within ``undisturbed`` u0 of u0 n, else a ValueError. lambda = the undisturbed grains
      upstream of the target (h > 0, below) in the middle 60 % of their extent along n
      (trimming the lattice's ragged front and tail), over that length; J_in_err is the
      scatter of up to 10 equal sub-slabs of at least 10 d. The jet is uniform by
      construction (a lattice thinned at random), so this is lambda at every time, measured
      on many grains and untouched by the flow at the target or by the passage of the jet's
      tail. (The thinned lattice's lambda is not quite the continuum phi_tilde sqrt(2) A_jet
      of the 3D fcc jet: 20.27-20.41 over four seeds, +-0.06 each, against 20.24 for
      20,000 grains with D_jet = 4.5 d.)
    * ``"window"``: per frame of the window, the undisturbed grains (velocity within
      ``undisturbed`` u0 of u0 n) at heights ``upstream[0] <= h < upstream[1]`` above the
      target surface, h = (x - centre) . (-n); lambda = count / (upstream[1] - upstream[0]),
      averaged over the frames. A frame enters (its force too) only while the undisturbed
      jet fills the slab: some undisturbed grain at h >= upstream[1] (the jet's tail has not
      entered the slab), some grain at h < upstream[0] (its front has passed it), and no
      disturbed grain in the slab within 1 d of the jet's lateral extent there (the flow at
      the target does not reach it; in a small 3D run at X = 2.5 it reaches ~8 d above the
      target, hence the default slab 10-20 d; 2D, with its dead zone, may need more). Late
      in a run the tail empties the slab. Frames left out are counted in ``n_skipped``.
    * A number: lambda in grains per unit length, with m the mean grain mass of the first
      frame.

    ``"initial"`` is the default as the more robust: the window's slab holds fewer grains (a
    larger error), needs the jet to outlast the window by the slab's height (short runs
    fail) and a slab clear of the flow at the target, whose reach depends on X, the
    dimension and the packing.

    Errors are delete-one jackknife estimates over ``blocks`` consecutive groups of the frames
    used (module notes; with one block, over single frames), of F_wall, of the ratio and of
    psi0 itself. With ``"initial"`` or a number J_in is a constant of the jet and its error
    (J_in_err) is not included: it is small for a long jet (0.3 % for 20,000 grains), where
    the force fluctuates far more; with ``"window"`` the jackknife covers lambda too.

    Parameters
    ----------
    frames : saved frames with contacts (a list, a generator such as
        :func:`grainflow.io.h5md.read_frames`, or one Frame), read once, in order.
    force : "contacts" or "anchors" (above).
    line_density : "initial", "window" or lambda > 0 in grains per unit length (above).
    direction : direction of travel of the jet n; default -z (3D) or -x (2D).
    centre : where the jet axis meets the target surface; default the origin.
    grains : which particles are grains (module notes); default type != TARGET_TYPE.
    target : which particles make the target, like ``grains``; default type == TARGET_TYPE.
        A particle in both selections counts as target.
    window : (t_start, t_end) of the steady state, inclusive; default every frame.
    upstream : (h_lo, h_hi), 0 <= h_lo < h_hi, the slab of ``line_density="window"``.
    u0 : speed of the incoming jet, > 0.
    undisturbed : largest |v - u0 n| / u0 of an undisturbed jet grain, >= 0.
    blocks : blocks of consecutive frames for the jackknife; default min(10, frames).

    Raises ValueError when F_wall / J_in lies outside [0, 2], where eq. (4.3) has no angle
    (a wrong ``direction`` flips the sign of F_wall).
    """
    if force not in ("contacts", "anchors"):
        raise ValueError(f"force: 'contacts' or 'anchors', got {force!r}")
    given: float | None = None
    if isinstance(line_density, str):
        if line_density not in ("initial", "window"):
            raise ValueError(f"line_density: 'initial', 'window' or a positive number, got "
                             f"{line_density!r}")
        mode = line_density
    else:
        given = _positive("line_density", line_density)
        mode = "given"
    u0 = _positive("u0", u0)
    undisturbed = _non_negative("undisturbed", undisturbed)
    try:
        h_lo, h_hi = (float(x) for x in upstream)
    except (TypeError, ValueError):
        raise ValueError(f"upstream: (h_lo, h_hi) heights above the target, got "
                         f"{upstream!r}") from None
    if not (np.isfinite(h_lo) and np.isfinite(h_hi) and 0 <= h_lo < h_hi):
        raise ValueError(f"upstream: (h_lo, h_hi) with 0 <= h_lo < h_hi, got {upstream!r}")
    check_window(window)
    geo: JetGeometry | None = None
    first: tuple[float, float, float] | None = None  # (lambda, mass per length, error)
    mean_mass = float("nan")
    walls: list[float] = []
    masses: list[float] = []  # mass per unit length in the slab ("window")
    counts: list[int] = []
    n_in_window = 0
    for frame in each_frame(frames):
        if geo is None:
            geo = jet_geometry(frame.dim, direction, centre)
            if mode == "initial":
                first = _initial_line_density(frame, geo, grains, u0, undisturbed)
            elif mode == "given":
                picked = grain_mask(frame, grains)
                if not picked.any():
                    raise ValueError(f"grains: {_where(frame)} holds no grains to take the "
                                     "grain mass m of J_in = lambda m u0^2 from")
                mean_mass = float(np.mean(np.asarray(frame.mass)[picked]))
        check_dim(frame, geo)
        if not in_window(frame, window):
            continue
        n_in_window += 1
        if mode == "window":
            h, lateral, m, still = _jet_grains(frame, geo, grains, u0, undisturbed)
            in_slab = (h >= h_lo) & (h < h_hi)
            slab = still & in_slab
            filled = (bool(slab.any()) and bool(np.any(still & (h >= h_hi)))
                      and bool(np.any(h < h_lo)))
            if not filled:
                continue
            reach = float(lateral[slab].max()) + 1.0  # the jet's half-width, plus d
            if np.any(~still & in_slab & (lateral <= reach)):
                continue  # the disturbance near the target reaches the slab
            counts.append(int(slab.sum()))
            masses.append(float(m[slab].sum()) / (h_hi - h_lo))
        walls.append(_wall_force(frame, geo, grains, target, force))
    if geo is None:
        raise ValueError("frames: no frames given")
    if n_in_window == 0:
        raise ValueError("frames: no frame lies in the window")
    if not walls:
        raise ValueError(
            f"line_density: no frame of the window has the undisturbed jet filling the upstream "
            f"slab {h_lo:g} <= h < {h_hi:g} (undisturbed grains beyond it, the front past it, "
            "no disturbed grain in it); the jet's tail may have passed or the flow at the "
            "target reach the slab: use line_density='initial', move the window or upstream")
    F = np.asarray(walls)
    n_frames = F.size
    n_blocks = block_count(blocks, n_frames)
    index = np.arange(n_frames)
    unit = index if n_blocks == 1 else block_of(index, n_frames, n_blocks)
    n_units = n_frames if n_blocks == 1 else n_blocks
    ones = np.ones(n_frames)
    totals_F = [F.sum(), float(n_frames)]
    per_F = [unit_sums(unit, n_units, F), unit_sums(unit, n_units, ones)]
    F_mean = float(F.mean())
    F_err = float(jackknife(lambda s, n: s / n, totals_F, per_F))
    if mode == "window":
        mu = np.asarray(masses)
        lam = float(np.mean(counts)) / (h_hi - h_lo)
        J_in = float(mu.mean()) * u0**2
        totals = [F.sum(), mu.sum()]
        per = [per_F[0], unit_sums(unit, n_units, mu)]

        def ratio_of(sf, sm):
            return sf / (sm * u0**2)

        J_err = float(jackknife(lambda sm, n: sm / n * u0**2, [mu.sum(), float(n_frames)],
                                [per[1], per_F[1]]))
    else:
        if mode == "initial":
            assert first is not None
            lam, mass_per_length, mass_err = first
            J_in, J_err = mass_per_length * u0**2, mass_err * u0**2
        else:
            assert given is not None
            lam, J_in, J_err = given, given * mean_mass * u0**2, 0.0
        totals, per = totals_F, per_F

        def ratio_of(sf, n):
            return sf / n / J_in

    ratio = F_mean / J_in
    if not (np.isfinite(ratio) and 0.0 <= ratio <= 2.0):
        raise ValueError(
            f"F_wall / J_in = {ratio:.4g} (F_wall = {F_mean:.4g}, J_in = {J_in:.4g}) lies outside "
            "[0, 2], where 1 - cos psi0 = F_wall / J_in (eq. 4.3) has no angle; check direction "
            "(the jet's direction of travel), u0, the window and the line density")
    return ForceBalanceAngle(
        psi0=float(np.arccos(1.0 - ratio)),
        psi0_err=float(jackknife(lambda *s: _psi0_of(ratio_of(*s)), totals, per)),
        ratio=float(ratio), ratio_err=float(jackknife(ratio_of, totals, per)),
        F_wall=F_mean, F_wall_err=F_err,
        J_in=float(J_in), J_in_err=float(J_err), lambda_=float(lam), n_frames=int(n_frames),
        n_skipped=int(n_in_window - n_frames), blocks=n_blocks, force=force,
        line_density=mode,
    )
