"""Figures of the stream analyses (:mod:`grainflow.analysis.stream`), after seed 000
(Waitukaitis et al., PRE 83, 051302 (2011)): the normalised contact number Z/Z_0 and the
network size N against depth (Fig. 6a-b), the axial and transverse velocity deviations against
depth with the free-fall fit (Fig. 5), the droplet aspect-ratio histogram (Fig. 2c), the
separation Delta z(t) of adjacent droplets (forward-tracked with their linear fits, or traced
back to the aperture by their grains: Fig. 3), their separation velocities against their
spacing at the aperture with the free-fall fit, and the phase
diagram over (F_c, e) (Fig. 4).

Each function takes data (the analyses' result objects or arrays) and a path, writes a PNG and
returns the path. Figures are drawn on an Agg canvas without pyplot
(:mod:`grainflow.plotting.figures`). Depths are shown in cm, velocities in cm/s, forces in nN.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
from numpy.typing import ArrayLike

from grainflow.analysis.stream import (REGIMES, AspectHistogram, ContactProfiles, DepthProfile,
                                       DeviationProfiles, DropletSeparation, FreeFallFit,
                                       NormalisedProfile, ProfileValue, SeparationGradient,
                                       ToyModelFit, TracedPair)
from grainflow.frame import Frame
from grainflow.plotting.figures import new_figure, save_figure

__all__ = ["plot_contact_number", "plot_network_size", "plot_velocity_deviations",
           "plot_aspect_histogram", "plot_droplet_separations", "plot_traced_pairs",
           "plot_separation_gradient", "plot_phase_diagram", "plot_stream_side",
           "write_stream_movie", "plot_contact_vs_capture", "plot_toy_model"]

_CM = 100.0
#: Marker of each regime in the phase diagram (anything else: "x").
REGIME_MARKERS = {"spray": "o", "clustering": "s", "droplets": "^", "dripping": "D"}


def _as_list(name: str, value: object, kinds: tuple[type, ...]) -> list:
    items = list(value) if isinstance(value, (list, tuple)) else [value]
    if not items:
        raise ValueError(f"{name}: nothing to plot")
    for item in items:
        if not isinstance(item, kinds):
            allowed = " or ".join(k.__name__ for k in kinds)
            raise ValueError(f"{name}: expected {allowed} (or a list of them), got "
                             f"{type(item).__name__}")
    return items


def _labels(labels: Sequence[str] | None, n: int) -> list[str | None]:
    if labels is None:
        return [None] * n
    out = list(labels)
    if len(out) != n:
        raise ValueError(f"labels: expected {n} labels, one per profile, got {len(out)}")
    return out


def _draw_profile(ax, profile: DepthProfile, label: str | None, color=None, fmt: str = "o-"
                  ) -> None:
    ok = profile.count > 0
    err = np.where(np.isfinite(profile.err), profile.err, 0.0)
    ax.errorbar(profile.centres[ok] * _CM, profile.mean[ok], yerr=err[ok], fmt=fmt, ms=3,
                lw=1, capsize=1.5, color=color, label=label)


def plot_contact_number(
    profiles: NormalisedProfile | Sequence[NormalisedProfile],
    path: str | Path,
    *,
    labels: Sequence[str] | None = None,
) -> Path:
    """Normalised contact number Z/Z_0 against depth (seed Fig. 6a), one curve per profile
    (from :func:`~grainflow.analysis.stream.normalised_contact_number`)."""
    items = _as_list("profiles", profiles, (NormalisedProfile,))
    names = _labels(labels, len(items))
    fig = new_figure(1, width=5.2, height=4.0)
    ax = fig.subplots()
    for item, name in zip(items, names):
        ref = item.reference
        text = name if name is not None else (
            rf"$Z_0$ = {ref.value:.3g} at {ref.depth * 1e3:.3g} mm")
        _draw_profile(ax, item.profile, text)
    ax.axhline(1.0, color="0.7", lw=0.8, ls=":")
    ax.axvline(0.0, color="0.85", lw=0.8)
    ax.set_xlabel("depth below the aperture $z$ [cm]")
    ax.set_ylabel(r"$\langle Z\rangle / \langle Z_0\rangle$")
    ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


def plot_network_size(
    profiles: DepthProfile | ContactProfiles | Sequence[DepthProfile | ContactProfiles],
    path: str | Path,
    *,
    labels: Sequence[str] | None = None,
    saturation: ProfileValue | Sequence[ProfileValue] | None = None,
) -> Path:
    """Network size N against depth on a log scale (seed Fig. 6b), one curve per profile; the
    saturation sizes N_inf (:func:`~grainflow.analysis.stream.saturation_network_size`), if
    given, as points with error bars at their depths."""
    items = [p.network_size if isinstance(p, ContactProfiles) else p
             for p in _as_list("profiles", profiles, (DepthProfile, ContactProfiles))]
    names = _labels(labels, len(items))
    sats = [] if saturation is None else _as_list("saturation", saturation, (ProfileValue,))
    fig = new_figure(1, width=5.2, height=4.0)
    ax = fig.subplots()
    for item, name in zip(items, names):
        _draw_profile(ax, item, name)
    for k, s in enumerate(sats):
        ax.errorbar([s.depth * _CM], [s.value],
                    yerr=[s.err if np.isfinite(s.err) else 0.0], fmt="*", ms=9,
                    color="k", label=r"$N_\infty$" if k == 0 else None)
    ax.set_yscale("log")
    ax.axhline(1.0, color="0.7", lw=0.8, ls=":")
    ax.set_xlabel("depth below the aperture $z$ [cm]")
    ax.set_ylabel(r"network size $N$ [grains]")
    if any(n is not None for n in names) or sats:
        ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


def plot_velocity_deviations(
    deviations: DeviationProfiles,
    path: str | Path,
    *,
    fit: FreeFallFit | None = None,
) -> Path:
    """Axial and transverse mean squared velocity deviations against depth below the aperture,
    log-log (seed Fig. 5b-d), with the free-fall fit (g dz)^2 / (v0^2 + 2 g z) on the axial
    panel. Only bins below the aperture with a positive mean are drawn."""
    if not isinstance(deviations, DeviationProfiles):
        raise ValueError(f"deviations: expected DeviationProfiles, got "
                         f"{type(deviations).__name__}")
    if fit is not None and not isinstance(fit, FreeFallFit):
        raise ValueError(f"fit: expected a FreeFallFit, got {type(fit).__name__}")
    fig = new_figure(2, width=4.4, height=3.8)
    axes = fig.subplots(1, 2)
    for ax, prof, title in ((axes[0], deviations.axial, "axial"),
                            (axes[1], deviations.transverse, "transverse (per component)")):
        ok = (prof.centres > 0) & (prof.count > 0) & (prof.mean > 0)
        if np.any(ok):
            err = np.where(np.isfinite(prof.err), prof.err, 0.0)[ok] * _CM ** 2
            low = np.minimum(err, prof.mean[ok] * _CM ** 2 * 0.999)
            ax.errorbar(prof.centres[ok] * _CM, prof.mean[ok] * _CM ** 2, yerr=(low, err),
                        fmt="o", ms=3, mfc="none", color="k", capsize=1.5, label="simulation")
            ax.set_xscale("log")
            ax.set_yscale("log")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("depth $z$ [cm]")
    if fit is not None:
        lo, hi = fit.depth_range
        z = np.geomspace(max(lo, 1e-6), hi, 200)
        axes[0].plot(z * _CM, np.asarray(fit.predict(z)) * _CM ** 2, "--", color="tab:red",
                     label=(rf"free fall: $\Delta z$ = {fit.dz * 1e6:.3g} $\pm$ "
                            rf"{fit.dz_err * 1e6:.2g} $\mu$m, $v_0$ = {fit.v0 * _CM:.3g} cm/s"))
    axes[0].set_ylabel(r"$\langle \delta v_z^2\rangle$ [cm$^2$/s$^2$]")
    axes[1].set_ylabel(r"$\langle \delta v_t^2\rangle$ [cm$^2$/s$^2$]")
    axes[0].legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


def plot_aspect_histogram(histogram: AspectHistogram, path: str | Path) -> Path:
    """Histogram of droplet aspect ratios (seed Fig. 2c) with the most probable value and the
    fraction between 1 and 3."""
    if not isinstance(histogram, AspectHistogram):
        raise ValueError(f"histogram: expected an AspectHistogram, got "
                         f"{type(histogram).__name__}")
    h = histogram
    fig = new_figure(1, width=5.0, height=3.8)
    ax = fig.subplots()
    ax.stairs(h.counts, h.edges, fill=True, color="tab:blue", alpha=0.6,
              label=f"{h.n} droplets")
    ax.axvspan(1.0, 3.0, color="0.9", zorder=0,
               label=rf"$1 \leq A \leq 3$: {100 * h.fraction_1_3:.0f}%")
    ax.axvline(h.mode, color="tab:red", lw=1.2, label=f"most probable: {h.mode:.2g}")
    ax.set_xlim(h.edges[0], h.edges[-1])
    ax.set_xlabel(r"aspect ratio $A = L / (2W)$")
    ax.set_ylabel("droplets")
    ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


def plot_droplet_separations(
    separations: Sequence[DropletSeparation],
    path: str | Path,
    *,
    max_pairs: int = 12,
) -> Path:
    """Vertical distance Delta z between the centres of mass of adjacent droplets against time,
    with the linear fits whose slopes are the separation velocities (seed Fig. 3). Time is
    t - t0 (t0: the pair's centre at the aperture) when every pair has t0, else t. At most
    ``max_pairs`` pairs are drawn."""
    items = _as_list("separations", list(separations) if not isinstance(
        separations, DropletSeparation) else separations, (DropletSeparation,))
    if max_pairs < 1:
        raise ValueError(f"max_pairs: expected >= 1, got {max_pairs!r}")
    items = items[:max_pairs]
    shift = all(np.isfinite(s.t0) for s in items)
    fig = new_figure(1, width=5.4, height=4.0)
    ax = fig.subplots()
    colors = [f"C{k % 10}" for k in range(len(items))]
    for s, c in zip(items, colors):
        t0 = s.t0 if shift else 0.0
        t = np.asarray(s.times) - t0
        ax.plot(t * 1e3, np.asarray(s.dz) * 1e3, "o", ms=3, color=c)
        line = np.linspace(t.min(), t.max(), 20)
        ax.plot(line * 1e3, s.predict(line + t0) * 1e3, "-", color=c, lw=1,
                label=rf"$\Delta v$ = {s.velocity * _CM:.3g} $\pm$ {s.velocity_err * _CM:.2g}"
                      " cm/s")
    ax.set_xlabel(r"$t - t_0$ [ms]" if shift else "$t$ [ms]")
    ax.set_ylabel(r"$\Delta z$ [mm]")
    ax.legend(fontsize=6, frameon=False)
    return save_figure(fig, path)


def plot_traced_pairs(
    pairs: Sequence[TracedPair],
    path: str | Path,
    *,
    max_pairs: int = 12,
) -> Path:
    """Vertical distance Delta z between the centres of mass of adjacent droplets' grains
    against t - t0, t0 when the pair's centre passes the aperture (seed 000, Sec. III: the
    droplets accelerate apart in the hopper, leave the aperture at Delta v0 and then separate
    at a nearly constant rate), with each pair's initial slope. Pairs without t0 are left
    out; at most ``max_pairs`` are drawn."""
    items = [p for p in _as_list("pairs", list(pairs) if not isinstance(pairs, TracedPair)
                                 else pairs, (TracedPair,)) if np.isfinite(p.t0)]
    if max_pairs < 1:
        raise ValueError(f"max_pairs: expected >= 1, got {max_pairs!r}")
    if not items:
        raise ValueError("pairs: none passes the aperture within the frames (every t0 is NaN)")
    fig = new_figure(1, width=5.4, height=4.0)
    ax = fig.subplots()
    for k, p in enumerate(items[:max_pairs]):
        c = f"C{k % 10}"
        t = np.asarray(p.times) - p.t0
        ax.plot(t * 1e3, np.asarray(p.dz) * 1e3, "-", color=c, lw=1,
                label=rf"$\Delta v_0$ = {p.initial_velocity * _CM:.3g} cm/s")
    ax.axvline(0.0, color="0.5", lw=0.8, ls=":")
    ax.set_xlabel(r"$t - t_0$ [ms] (pair's centre at the aperture at 0)")
    ax.set_ylabel(r"$\Delta z$ [mm]")
    ax.legend(fontsize=6, frameon=False)
    return save_figure(fig, path)


def plot_separation_gradient(
    dz0: ArrayLike,
    dv0: ArrayLike,
    fit: SeparationGradient,
    path: str | Path,
    *,
    grain_diameter: float,
) -> Path:
    """Separation velocity Delta v0 of adjacent droplets against their spacing Delta z0 at the
    aperture (in grain diameters), with the free-fall fit sqrt(V^2 + 2 g Delta z0) - V and
    its slope at the origin, the gradient g d / V (seed 000, Sec. III: the pairs collapse
    onto the free-fall profile)."""
    z = np.asarray(dz0, dtype=float)
    v = np.asarray(dv0, dtype=float)
    if z.ndim != 1 or v.shape != z.shape:
        raise ValueError(f"dv0: expected shape {z.shape} like dz0 (1-D), got {v.shape}")
    if not isinstance(fit, SeparationGradient):
        raise ValueError(f"fit: expected a SeparationGradient, got {type(fit).__name__}")
    if not grain_diameter > 0:
        raise ValueError(f"grain_diameter: expected a positive diameter, got {grain_diameter!r}")
    keep = np.isfinite(z) & (z > 0) & np.isfinite(v)
    if not keep.any():
        raise ValueError("dz0: no pair with a finite, positive spacing to draw")
    fig = new_figure(1, width=5.4, height=4.0)
    ax = fig.subplots()
    ax.plot(z[keep] / grain_diameter, v[keep] * _CM, "o", ms=3,
            label=f"{int(keep.sum())} adjacent pairs")
    line = np.linspace(0.0, float(z[keep].max()), 100)
    ax.plot(line / grain_diameter, np.asarray(fit.predict(line)) * _CM, "-", color="k", lw=1,
            label=rf"free fall, $V$ = {fit.speed * _CM:.3g} $\pm$ {fit.speed_err * _CM:.2g} cm/s")
    ax.plot(line / grain_diameter, fit.gradient * line / grain_diameter * _CM, "--",
            color="0.5", lw=1, label=rf"$g d / V$ = {fit.gradient * _CM:.3g} cm/s per $d$")
    ax.set_xlabel(r"$\Delta z_0 / d$")
    ax.set_ylabel(r"$\Delta v_0$ [cm/s]")
    ax.set_xlim(left=0.0)
    ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


def plot_phase_diagram(
    cohesive_force: ArrayLike,
    restitution: ArrayLike,
    mean_contact_number: ArrayLike,
    regimes: Sequence[str],
    path: str | Path,
) -> Path:
    """Phase diagram over (F_c, e) (seed Fig. 4): one point per stream, F_c on a
    log axis in nN (streams with F_c = 0 drawn at the left edge, labelled 0), coloured by the
    mean contact number <Z> (e.g. at 4 cm) and marked by regime.

    Parameters
    ----------
    cohesive_force : (M,) F_c in newtons, >= 0.
    restitution : (M,) e.
    mean_contact_number : (M,) <Z> (NaN: drawn grey).
    regimes : (M,) regime names ("spray", "clustering", "droplets", "dripping").
    path : output PNG path.
    """
    fc = np.asarray(cohesive_force, dtype=float)
    e = np.asarray(restitution, dtype=float)
    zc = np.asarray(mean_contact_number, dtype=float)
    names = list(regimes)
    if fc.ndim != 1 or fc.size == 0:
        raise ValueError(f"cohesive_force: expected a non-empty 1-D array, got shape {fc.shape}")
    for label, arr in (("restitution", e), ("mean_contact_number", zc)):
        if arr.shape != fc.shape:
            raise ValueError(f"{label}: expected shape {fc.shape} like cohesive_force, got "
                             f"{arr.shape}")
    if len(names) != fc.size:
        raise ValueError(f"regimes: expected {fc.size} names like cohesive_force, got "
                         f"{len(names)}")
    if not np.all(np.isfinite(fc)) or np.any(fc < 0):
        raise ValueError("cohesive_force: values must be finite and >= 0 (newtons)")
    nn = fc * 1e9
    positive = nn[nn > 0]
    zero_at = (positive.min() / 10.0) if positive.size else 0.1
    x = np.where(nn > 0, nn, zero_at)
    finite = np.isfinite(zc)
    vmin, vmax = (float(zc[finite].min()), float(zc[finite].max())) if finite.any() else (0, 1)
    if vmax == vmin:
        vmax = vmin + 1.0
    fig = new_figure(1, width=5.6, height=4.2)
    ax = fig.subplots()
    artist = None
    for regime in list(REGIMES) + sorted(set(names) - set(REGIMES)):
        sel = np.array([n == regime for n in names])
        if not sel.any():
            continue
        marker = REGIME_MARKERS.get(regime, "x")
        ok = sel & finite
        if ok.any():
            artist = ax.scatter(x[ok], e[ok], c=zc[ok], cmap="viridis", vmin=vmin, vmax=vmax,
                                marker=marker, s=45, edgecolors="k", linewidths=0.6,
                                label=regime)
        if (sel & ~finite).any():
            ax.scatter(x[sel & ~finite], e[sel & ~finite], c="0.7", marker=marker, s=45,
                       edgecolors="k", linewidths=0.6, label=None if ok.any() else regime)
    ax.set_xscale("log")
    if np.any(nn == 0):
        ticks = [zero_at] + [t for t in ax.get_xticks() if t > zero_at * 3]
        ax.set_xticks(ticks, ["0"] + [f"{t:g}" for t in ticks[1:]])
        ax.set_xlim(zero_at / 2, x.max() * 2)
    ax.set_xlabel(r"cohesive force $F_c$ [nN]")
    ax.set_ylabel("restitution $e$")
    if artist is not None:
        fig.colorbar(artist, ax=ax, label=r"$\langle Z\rangle$")
    leg = ax.legend(fontsize=7, frameon=False, loc="best")
    for handle in getattr(leg, "legend_handles", []):  # regime markers without colour
        if hasattr(handle, "set_array"):
            handle.set_array(None)
        handle.set_facecolor("white")
    return save_figure(fig, path)


def _draw_stream(fig, frame: Frame, delta: float, depth_range: tuple[float, float],
                 columns: int, vmax: float) -> None:
    """The stream between two depths cut into ``columns`` side-by-side strips (x against
    depth, each strip the next stretch downstream), grains coloured by their network size."""
    from grainflow.analysis.stream import network_sizes

    grains = frame.type == 0
    x = frame.position[grains]
    size = network_sizes(x, frame.radius[grains], delta)
    depth = -x[:, 2]
    lo, hi = depth_range
    step = (hi - lo) / columns
    axes = fig.subplots(1, columns, sharey=False)
    axes = np.atleast_1d(axes)
    half = 3.0  # mm either side of the axis
    # marker area (pt^2) of a grain's diameter on the strip's scale (about 80 pt for 6 mm)
    d_mm = 2e3 * float(np.median(frame.radius[grains])) if grains.any() else 0.2
    area = (80.0 * d_mm / (2 * half)) ** 2
    artist = None
    for k, ax in enumerate(axes):
        a, b = lo + k * step, lo + (k + 1) * step
        sel = (depth >= a) & (depth < b)
        order = np.argsort(x[sel, 1])  # far grains first
        artist = ax.scatter(x[sel, 0][order] * 1e3, depth[sel][order] * 1e3,
                            c=np.log10(size[sel][order]), s=area, cmap="plasma", vmin=0,
                            vmax=np.log10(vmax), linewidths=0)
        ax.set_ylim(b * 1e3, a * 1e3)
        ax.set_xlim(-half, half)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel("x [mm]")
        ax.tick_params(labelsize=6)
    axes[0].set_ylabel("depth below the aperture [mm]")
    if artist is not None:
        fig.colorbar(artist, ax=list(axes), label="log10 network size", shrink=0.8)
    fig.suptitle(f"t = {frame.time * 1e3:.1f} ms, step {frame.step}", fontsize=8)


def _stream_figure(columns: int, depth_range: tuple[float, float]):
    """A figure whose strips (6 mm wide, 1.4 in) keep the stream's true aspect ratio."""
    strip_mm = 1e3 * (depth_range[1] - depth_range[0]) / columns
    return new_figure(columns, width=1.4, height=1.0 + 1.1 * strip_mm / 6.0)


def plot_stream_side(frame: Frame, path: str | Path, delta: float, *,
                     depth_range: tuple[float, float] = (0.0, 0.06), columns: int = 4,
                     vmax: float = 2000.0) -> Path:
    """A side view of the stream (seed Fig. 1, without the co-moving frame): the stretch
    ``depth_range`` (m) cut into ``columns`` strips, grains coloured by network size
    (A5, contact reach ``delta``), so clusters and droplets show as colour."""
    if not (depth_range[1] > depth_range[0]):
        raise ValueError(f"depth_range: {depth_range!r}; expected (shallow, deep) in metres")
    if columns < 1:
        raise ValueError(f"columns: {columns!r}; expected >= 1")
    fig = _stream_figure(columns, depth_range)
    _draw_stream(fig, frame, delta, depth_range, columns, vmax)
    return save_figure(fig, path)


def write_stream_movie(frames: Sequence[Frame], path: str | Path, delta: float, *,
                       depth_range: tuple[float, float] = (0.0, 0.06), columns: int = 4,
                       vmax: float = 2000.0, frame_ms: int = 120) -> Path:
    """A movie of :func:`plot_stream_side` over ``frames`` (``frame_ms`` per picture): an
    animated GIF for a ``.gif`` path, H.264 for ``.mp4``, through the project's one movie
    writer (:func:`grainflow.plotting.movie.open_movie`); returns the path."""
    from grainflow.plotting.movie import open_movie

    frames = list(frames)
    if not frames:
        raise ValueError("frames: nothing to animate")
    with open_movie(path, fps=1000.0 / frame_ms) as movie:
        for frame in frames:
            fig = _stream_figure(columns, depth_range)
            _draw_stream(fig, frame, delta, depth_range, columns, vmax)
            fig.canvas.draw()
            movie.append(np.asarray(fig.canvas.buffer_rgba())[..., :3])
    return movie.path


def plot_contact_vs_capture(capture_velocity: ArrayLike, mean_contact_number: ArrayLike,
                            restitution: ArrayLike, path: str | Path) -> Path:
    """Mean contact number against the binary capture velocity v_c = (2/e) sqrt(F_c delta/m),
    one series per restitution (seed Fig. 8b: plotted against v_c rather than F_c, streams of
    different e come together). Cohesionless streams (v_c = 0) are left out of the log axis."""
    vc = np.asarray(capture_velocity, dtype=float)
    z = np.asarray(mean_contact_number, dtype=float)
    e = np.asarray(restitution, dtype=float)
    if vc.ndim != 1 or vc.shape != z.shape or vc.shape != e.shape:
        raise ValueError("capture_velocity, mean_contact_number, restitution: expected 1-D "
                         f"arrays of one length, got {vc.shape}, {z.shape}, {e.shape}")
    fig = new_figure(1)
    ax = fig.subplots()
    for value in sorted(set(e.tolist()), reverse=True):
        sel = (e == value) & (vc > 0) & np.isfinite(z)
        order = np.argsort(vc[sel])
        ax.plot(vc[sel][order] * 1e3, z[sel][order], "o-", ms=4, label=f"e = {value:g}")
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xticks([t for t in (0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50, 100)
                   if np.any(vc > 0) and 0.5 * vc[vc > 0].min() * 1e3 <= t
                   <= 2 * vc.max() * 1e3])
    ax.set_xlabel(r"capture velocity $v_c$ [mm/s]")
    ax.set_ylabel(r"$\langle Z\rangle$")
    ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


def plot_toy_model(cohesive_force: ArrayLike, length: ArrayLike, length_err: ArrayLike,
                   restitution: ArrayLike, path: str | Path,
                   fit: ToyModelFit | None = None) -> Path:
    """The droplet length scale at the aperture L0 against F_c, one series per restitution,
    with the toy model's L0 = (F_c / Sigma)^(1/2) and the grain size (seed Fig. 5)."""
    f = np.asarray(cohesive_force, dtype=float)
    lengths = np.asarray(length, dtype=float)
    errs = np.asarray(length_err, dtype=float)
    e = np.asarray(restitution, dtype=float)
    if not (f.ndim == 1 and f.shape == lengths.shape == errs.shape == e.shape):
        raise ValueError("cohesive_force, length, length_err, restitution: expected 1-D "
                         "arrays of one length")
    fig = new_figure(1)
    ax = fig.subplots()
    for value in sorted(set(e.tolist()), reverse=True):
        sel = e == value
        ax.errorbar(f[sel] * 1e9, lengths[sel] * 1e3, yerr=np.nan_to_num(errs[sel]) * 1e3,
                    fmt="o", ms=4, capsize=2, label=f"e = {value:g}")
    if fit is not None:
        line = np.geomspace(0.5 * f.min(), 2.0 * f.max(), 50) if f.size else np.array([])
        ax.plot(line * 1e9, fit.length(line) * 1e3, "k-", lw=1,
                label=rf"$(F_c/\Sigma)^{{1/2}}$, $\Sigma$ = {fit.sigma * 1e3:.3g} nN/mm$^2$")
        ax.axhline(fit.grain_diameter * 1e3, color="0.6", ls=":", lw=1, label="$d$")
    ax.set_xscale("log")
    ax.set_yscale("log")
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(r"$F_c$ [nN]")
    ax.set_ylabel(r"$L_0$ at the aperture [mm]")
    ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)
