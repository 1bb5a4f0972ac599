"""Reproduction of seed 000's cohesive-stream study (Waitukaitis et al., PRE 83, 051302
(2011)) through the sweep engine.

One sweep ``phase`` over the restitution e and the cohesive force F_c (the seed's phase
diagram; e in {1.0, 0.88, 0.73, 0.61, 0.40}, F_c from 1 to 2000 nN in the full version), and
one sweep ``shell`` that changes the NF shell thickness delta at a fixed binding energy
W = F_c delta (the seed's capture velocity depends on W only). Each run is a ``stream``
scenario (:mod:`grainflow.scenarios.stream`); :func:`stream_summary` analyses its saved
frames over the window in which the stream reaches ``stream_depth`` and stores the per-run
profiles in ``stream_analysis.npz`` beside the frames; :func:`reproduce` runs what is not yet
done (finished points are never recomputed) and writes ``report.md`` with the figures and the
table of the seed's numbers. The binary capture velocity v_c = (2/e) sqrt(F_c delta/m) is
measured by bisection on two-grain collisions with the scenario's own contact law
(:func:`measured_capture_velocity`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grainflow.studies.points import run_sweeps

#: The seed's numbers (PARAMETERS.md, seed 000); the issue's acceptance is 30 %. Bounds are
#: given as (value, "max") where the seed states one ("saturates below ~30 grains").
SEED: dict[str, tuple[float, str]] = {
    "v0 at the aperture (cm/s)": (10.0, "~"),
    "v0 read as the superficial speed Q V/(phi_b A) (cm/s)": (10.0, "~"),
    "N_inf, clustering (F_c < 100 nN)": (30.0, "max"),
    "peak network size, droplets": (1100.0, "~"),
    "most probable aspect ratio": (2.0, "~"),
    "separation gradient g d/V fitted to the droplet pairs (cm/s)": (1.4, "~"),
    "clustering / droplet crossover F_c (nN)": (100.0, "~"),
}
#: Acceptance band of the issue: the seed's figures are read by eye.
TOLERANCE = 0.30


@dataclass(frozen=True)
class StreamPlan:
    """Sizes of the study; ``reductions`` lists how it departs from the seed."""

    restitution: tuple[float, ...]
    cohesion_nN: tuple[float, ...]
    stream: dict[str, Any]
    duration: float
    frames_every: int
    shell: tuple[tuple[float, float], ...] = ()   # (F_c nN, delta nm) at e = shell_e
    shell_e: float = 0.40
    #: s; frames before it are not saved (the opening's transient). It lies 0.1 s after the
    #: aperture opens, before the steady window, so that the droplets found in the window can
    #: be traced back to the aperture (_tracked_separations)
    frames_from: float = 0.0
    reductions: tuple[str, ...] = field(default=())


FULL = StreamPlan(
    restitution=(1.0, 0.88, 0.73, 0.61, 0.40),
    cohesion_nN=(0.0, 1.0, 10.0, 30.0, 100.0, 300.0, 400.0, 1000.0, 1100.0, 2000.0),
    stream={"hopper_diameter": "7.5 mm", "fill_height": "6 mm", "contact_time": "50 us",
            "open_time": "0.08 s", "stream_depth": "22 cm"},
    duration=0.45, frames_every=1000, frames_from=0.18,
    shell=((2000.0, 50.0), (500.0, 200.0)), shell_e=0.40)
REDUCED = StreamPlan(
    restitution=(0.88, 0.40),
    cohesion_nN=(0.0, 30.0, 300.0, 1000.0),
    stream={"hopper_diameter": "5 mm", "fill_height": "3 mm", "contact_time": "100 us",
            "open_time": "0.05 s", "stream_depth": "22 cm"},
    duration=0.36, frames_every=500, frames_from=0.15,
    shell=((500.0, 200.0),), shell_e=0.40,
    reductions=(
        "e in {0.88, 0.40} and F_c in {0, 30, 300, 1000} nN (seed: 5 x ~10 points)",
        "the shell sweep at one thickness, 200 nm (full: 50 and 200 nm)",
        "hopper D_h = 5 mm, H = 3 mm (about 8,400 grains; full: 7.5 mm, 6 mm, 38,000)",
        "the stream is followed to 22 cm as in the seed, but over a window of 0.1 s "
        "(t = 0.26-0.36 s); droplets deeper than 20 cm count, none excluded (seed: the 1000 "
        "farthest)",
        "t_c = 100 us (full: 50 us); frames every 1 ms from t = 0.15 s"))


def _base(plan: StreamPlan) -> dict[str, Any]:
    from grainflow.scenarios.stream import StreamSection

    dt = 0.02 * StreamSection(**plan.stream).contact_time
    output = {"thermo_every": 5000, "frames_every": plan.frames_every,
              "checkpoint_every": int(round(0.05 / dt)), "snapshot": False}
    if plan.frames_from > 0:
        output["frames_from"] = plan.frames_from
    return {"scenario": "stream", "dim": 3,
            "run": {"duration": plan.duration, "seed": 0},
            "output": output,
            "stream": {**plan.stream, "restitution": 0.88, "cohesion_force": "0 nN",
                       "cohesion_range": "100 nm"}}


def sweep_specs(plan: StreamPlan) -> dict[str, Any]:
    """The study's sweeps (name -> validated :class:`~grainflow.sweep.SweepSpec`)."""
    from grainflow.sweep import parse_sweep

    analyses = ["grainflow.studies.stream_study:stream_summary"]
    raw = {"phase": {"base": _base(plan), "overrides": {
        "stream.restitution": list(plan.restitution),
        "stream.cohesion_force": [f"{f:g} nN" for f in plan.cohesion_nN]}}}
    if plan.shell:
        shell_base = _base(plan)
        shell_base["stream"]["restitution"] = plan.shell_e
        raw["shell"] = {"base": shell_base,
                        "overrides": {"stream.cohesion_force": [f"{f:g} nN"
                                                                for f, _ in plan.shell],
                                      "stream.cohesion_range": [f"{d:g} nm"
                                                                for _, d in plan.shell]},
                        "mode": "zip"}
    return {name: parse_sweep({"name": name, "mode": spec.pop("mode", "grid"), **spec,
                               "analyses": analyses}) for name, spec in raw.items()}


# ------------------------------------------------------------------- per-run analysis
#: Depth (m) at which the seed's phase diagram reads the mean contact number.
PHASE_DEPTH = 0.04
#: Where N_inf is read and below which droplets count: the seed's 20 cm; a stream followed
#: less deep (the reduced study) uses its deepest bin for N_inf and its lower half for droplets.
SATURATION_DEPTH = 0.20


def _section(config: dict[str, Any]) -> Any:
    from grainflow.scenarios.stream import StreamSection

    return StreamSection(**config["stream"])


def _window_frames(rundir: Path, *, before: bool = False) -> tuple[list[Any], Any]:
    """The run's frames from :func:`_steady_start` on (``before``: every saved frame, the
    earlier ones first), and its ``[stream]`` section."""
    import tomllib

    from grainflow.io.h5md import read_frames

    section = _section(tomllib.loads((rundir / "config.toml").read_text()))
    start = -math.inf if before else _steady_start(section)
    frames = [f for f in read_frames(rundir / "frames.h5") if f.time >= start - 1e-12]
    return frames, section


def _steady_start(s: Any) -> float:
    """When the stream of section ``s`` has reached ``stream_depth``: the opening time plus
    the free-fall time from the aperture at 10 cm/s, plus 10 ms."""
    from grainflow.scenarios.stream import GRAVITY

    v0 = 0.10
    fall = (math.sqrt(v0 * v0 + 2 * GRAVITY * s.stream_depth) - v0) / GRAVITY
    return s.open_time + fall + 0.01


def stream_summary(rundir: str | Path) -> dict[str, float]:
    """Sweep analysis of one run over its steady window: the aperture speed v0, the outflow
    and its steadiness, the contact number at 4 cm (the phase diagram's depth), the network
    size profile (peak and deepest value), the free-fall fit of the axial velocity
    deviations, the droplets, the regime; the profiles go to ``stream_analysis.npz``."""
    from grainflow.analysis.stream import (aperture_speed, classify_regime, contact_profiles,
                                           find_droplets, fit_free_fall_profile,
                                           outflow_steadiness, profile_value_at, stream_grains,
                                           superficial_speed, velocity_deviation_profile)

    rundir = Path(rundir)
    frames, s = _window_frames(rundir)
    if len(frames) < 3:
        raise ValueError(f"{rundir}: fewer than 3 frames in the steady window; run longer")
    depth_range = (0.0, s.stream_depth)
    flow = outflow_steadiness(frames)
    if flow.mean_rate == 0:
        _blocked(rundir, s, frames)
    speed = aperture_speed(frames)
    superficial = superficial_speed(frames, flow.mean_rate,
                                    aperture_diameter=s.aperture_diameter,
                                    hopper_diameter=s.hopper_diameter,
                                    fill_height=s.fill_height)
    stream = [stream_grains(f) for f in frames]
    # the seed's 5 mm network bins; at least 10 bins over a shorter stream (the classifier's
    # peak and asymptote need them)
    profiles = contact_profiles(stream, s.cohesion_range, depth_range=depth_range,
                                network_bin=min(5e-3, 0.1 * s.stream_depth))
    deviations = velocity_deviation_profile(stream, depth_range=depth_range)
    fit = fit_free_fall_profile(deviations.axial, speed.v0, weighting="relative",
                                depth_range=(1e-3, s.stream_depth - 2e-3))
    z = profiles.contact_number
    z4 = profile_value_at(z, min(PHASE_DEPTH, float(z.centres[z.count > 0].max())))
    net = profiles.network_size
    below = (net.centres > 0) & (net.count > 0)
    deepest = net.centres[below].max() if below.any() else float("nan")
    n_inf = profile_value_at(net, min(SATURATION_DEPTH, float(deepest)))
    droplet_depth = (SATURATION_DEPTH if s.stream_depth > SATURATION_DEPTH
                     else 0.5 * s.stream_depth)
    droplets = [d for f in stream[::max(1, len(stream) // 10)]
                for d in find_droplets(f, s.cohesion_range, min_depth=droplet_depth)]
    regime = classify_regime(net, droplet_count=len(droplets), outflow_cv=flow.cv)
    np.savez(rundir / "stream_analysis.npz",
             contact_depth=profiles.contact_number.centres,
             contact=profiles.contact_number.mean, contact_err=profiles.contact_number.err,
             contact_count=profiles.contact_number.count,
             network_depth=net.centres, network=net.mean, network_err=net.err,
             network_count=net.count,
             deviation_depth=deviations.axial.centres, axial=deviations.axial.mean,
             axial_err=deviations.axial.err, transverse=deviations.transverse.mean,
             transverse_err=deviations.transverse.err, deviation_count=deviations.axial.count,
             aspect=np.array([d.aspect_ratio for d in droplets]),
             droplet_size=np.array([d.ids.size for d in droplets]))
    peak = net.mean[below].max() if below.any() else float("nan")
    return {"v0": speed.v0, "v0_err": speed.err, "v0_superficial": superficial.speed,
            "phi_bulk": superficial.phi_b, "outflow": flow.mean_rate,
            "outflow_cv": flow.cv, "Z_4cm": z4.value, "Z_4cm_err": z4.err,
            "Z_depth": z4.depth,
            "N_inf": n_inf.value, "N_inf_err": n_inf.err, "N_inf_depth": n_inf.depth,
            "N_peak": float(peak), "dz": fit.dz, "dz_err": fit.dz_err,
            "droplets": float(len(droplets)),
            "regime": float(REGIME_NAMES.index(regime.regime))
            if regime.regime in REGIME_NAMES else -1.0,
            "frames": float(len(frames))}


def _blocked(rundir: Path, s: Any, frames: list[Any]) -> None:
    """Raise the reason a run has no stream to analyse: no grain fell through the aperture
    in the whole window (a cohesive bridge holds over it)."""
    from grainflow.scenarios.stream import GRAVITY, grain_mass

    weight = grain_mass(s) * GRAVITY
    if s.cohesion_force > 0:
        why = (f"A bridge of cohesive grains holds over it: F_c = {1e9 * s.cohesion_force:.4g} "
               f"nN is {s.cohesion_force / weight:.3g} times a grain's weight (the seed's "
               "streams of 200 um glass grains flow up to 2000 nN, about 20 weights). "
               "Lower stream.cohesion_force or widen stream.aperture_diameter")
    else:
        why = ("Without cohesion a jam needs an aperture of a few grains: check "
               "stream.aperture_diameter against stream.grain_diameter, and stream.open_time "
               "against the run's duration")
    raise ValueError(
        f"{rundir}: the aperture is blocked: no grain fell one diameter below it between "
        f"t = {frames[0].time:.3g} and {frames[-1].time:.3g} s, so there is no stream to "
        f"analyse. {why}")


# --------------------------------------------------------------------- binary capture
def measured_capture_velocity(restitution: float, cohesion_nN: float, delta_nm: float = 100.0,
                              *, iterations: int = 10, contact_time: str | None = None,
                              dt_fraction: float = 1 / 500,
                              start_phase: float = 0.37) -> tuple[float, float]:
    """(measured, analytic) capture velocity of two of the study's grains: bisection on
    head-on collisions with the scenario's contact law (captured = the pair never leaves the
    shell: it turns back inside it), at a step ``dt_fraction`` of the contact time (the
    section's default unless ``contact_time``). ``start_phase``: the fraction of a step by
    which the pair, starting a whole number of steps apart, misses touching at a step's end
    (the capture at a coarse step depends on it)."""
    from grainflow.engine.simulation import Simulation
    from grainflow.frame import Box
    from grainflow.models.cohesion_constant import capture_velocity
    from grainflow.models.granular import GranularLaw
    from grainflow.scenarios.stream import StreamSection, grain_mass
    from grainflow.state import ParticleState

    timing = {} if contact_time is None else {"contact_time": contact_time}
    s = StreamSection(restitution=restitution, cohesion_force=cohesion_nN * 1e-9,
                      cohesion_range=delta_nm * 1e-9, **timing)
    m = grain_mass(s)
    r = 0.5 * s.grain_diameter
    kn, gamma_n = s.contact_parameters()
    law = GranularLaw()
    law.set_all(kn=kn, kt=kn, gamma_n=gamma_n, gamma_t=gamma_n, mu=s.mu, damping="mass",
                cohesion_force=s.cohesion_force, cohesion_range=s.cohesion_range)
    dt = s.contact_time * dt_fraction

    def captured(v: float) -> bool:
        """True if, after its first contact, the pair turns back towards each other inside
        the shell; False once it leaves the shell receding."""
        st = ParticleState(3, Box(lo=np.full(3, -1e-2), hi=np.full(3, 1e-2),
                                  periodic=(False,) * 3))
        gap = (4.0 + start_phase) * v * dt
        st.add_particles(np.array([[-r - gap / 2, 0, 0], [r + gap / 2, 0, 0]]), r, mass=m,
                         v=np.array([[v / 2, 0, 0], [-v / 2, 0, 0]]))
        sim = Simulation(st, dt, law, skin=0.05 * r)
        seen = {"touched": False, "outcome": None}

        def watch(q: Simulation) -> None:
            branch = q.state.x[1] - q.state.x[0]
            g = float(np.linalg.norm(branch)) - 2 * r
            approaching = float(np.dot(q.state.v[1] - q.state.v[0], branch)) < 0
            if g < 0:
                seen["touched"] = True
            elif seen["touched"]:
                if g >= s.cohesion_range and not approaching:
                    seen["outcome"] = False
                elif approaching:
                    seen["outcome"] = True
        sim.add_observer(watch)
        sim.run(round(50 / dt_fraction), until=lambda q: seen["outcome"] is not None)
        if seen["outcome"] is None:
            raise RuntimeError(f"capture test at {v:g} m/s: neither captured nor escaped")
        return bool(seen["outcome"])

    vc = capture_velocity(s.cohesion_force, s.cohesion_range, m, s.restitution)
    lo, hi = 0.5 * vc, 1.5 * vc
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if captured(mid) else (lo, mid)
    return 0.5 * (lo + hi), vc


# ----------------------------------------------------------------------------- collection
def _force_nN(value: Any) -> float:
    from grainflow.units import parse_quantity

    return parse_quantity(value, "force") * 1e9


REGIME_NAMES = ("spray", "clustering", "droplets", "dripping")


def regime_name(summary: dict[str, float]) -> str:
    """The regime of a :func:`stream_summary` (which stores its index in REGIME_NAMES, or -1
    for one the classifier did not name): its name, or "unclassified"."""
    code = summary["regime"]
    return REGIME_NAMES[int(code)] if 0 <= code < len(REGIME_NAMES) else "unclassified"


def _profile(npz: Any, name: str, depth: str) -> Any:
    """A :class:`~grainflow.analysis.stream.DepthProfile` back from a run's
    ``stream_analysis.npz`` (means, errors and sample counts as :func:`stream_summary` saved
    them; the per-bin frame counts are not saved, so the sample counts stand in for them and
    ``n_frames`` is 1: the report only draws these profiles and reads values off them)."""
    from grainflow.analysis.stream import DepthProfile

    centres = np.asarray(npz[depth])
    width = float(centres[1] - centres[0]) if centres.size > 1 else 1e-3
    edges = np.concatenate([centres - width / 2, [centres[-1] + width / 2]])
    count = np.asarray(npz[f"{depth.split('_')[0]}_count"])
    return DepthProfile(quantity=name, bin_width=width, edges=edges, centres=centres,
                        mean=np.asarray(npz[name]), err=np.asarray(npz[f"{name}_err"]),
                        count=count, frames_with_data=count, n_frames=1)


def _crossovers(e: np.ndarray, fc: np.ndarray, regime: list[str]
                ) -> dict[float, tuple[float, float]]:
    """Per restitution, (the largest F_c > 0 below the first droplet-forming one, that first
    F_c) in nN, where the sweep brackets the clustering-to-droplet crossover."""
    out: dict[float, tuple[float, float]] = {}
    for value in sorted(set(e.tolist())):
        at = [(fc[i], regime[i]) for i in range(len(fc)) if e[i] == value and fc[i] > 0]
        first = min((f for f, r in at if r == "droplets"), default=None)
        below = [f for f, r in at if first is not None and f < first and r != "droplets"]
        if first is not None and below:
            out[value] = (float(max(below)), float(first))
    return out


def crossover_capture_velocities(brackets: dict[float, tuple[float, float]], delta: float,
                                 mass: float) -> tuple[dict[float, tuple[float, float]],
                                                       tuple[float, float] | None]:
    """The crossover brackets of :func:`_crossovers` (nN, per restitution) as brackets of
    the capture velocity v_c = (2/e) sqrt(F_c delta/m) (m/s), and where they all overlap
    (None if they do not). The seed finds the contact number governed mostly by v_c (its
    Fig. 7, eq. 3): if one v_c sets the crossover, the brackets of different e overlap."""
    from grainflow.models.cohesion_constant import capture_velocity

    speeds = {e: (capture_velocity(lo * 1e-9, delta, mass, e),
                  capture_velocity(hi * 1e-9, delta, mass, e))
              for e, (lo, hi) in brackets.items()}
    if not speeds:
        return speeds, None
    low = max(lo for lo, _ in speeds.values())
    high = min(hi for _, hi in speeds.values())
    return speeds, ((low, high) if low < high else None)


def _verdict(name: str, value: float | None, err: float | None) -> tuple[str, str]:
    seed, kind = SEED[name]
    if value is None or not np.isfinite(value):
        return "not measured", "—"
    ours = f"{value:.3g}" + (f" ± {err:.2g}" if err is not None and np.isfinite(err) else "")
    if kind == "max":
        return ours, "agrees" if value <= seed * (1 + TOLERANCE) else "misses"
    return ours, "agrees" if abs(value - seed) <= TOLERANCE * abs(seed) else "misses"


#: Droplets are paired in the window's frames 10 ms apart, from its last frame back, and only
#: those deeper than 5 cm (the seed's fully formed droplets lie below 20 cm; a pair found
#: there left the aperture 0.19 s before, so only the window's last frames could give one:
#: docs/streams.md gives the answer at 3 and 8 cm).
TRACE_EVERY = 0.01
TRACE_MIN_DEPTH = 0.05


def traced_pairs_in(frames: list[Any], delta: float, v0: float, *, first: int = 0,
                    min_depth: float = TRACE_MIN_DEPTH) -> list[Any]:
    """The adjacent droplets (>= 30 grains) found in ``frames[first:]`` every
    ``TRACE_EVERY`` from the last frame back, deeper than ``min_depth``, and traced back to
    the aperture through all of ``frames`` (the seed's method,
    :func:`~grainflow.analysis.stream.trace_droplet_pairs`); only the pairs whose crossing
    of the aperture lies in the frames."""
    from grainflow.analysis.stream import trace_droplet_pairs

    step = max(1, int(round(TRACE_EVERY / float(np.median(np.diff([f.time for f in frames]))))))
    pairs = trace_droplet_pairs(frames, delta, identify=range(len(frames) - 1, first - 1, -step),
                                min_depth=min_depth, v0=v0)
    return [p for p in pairs if np.isfinite(p.initial_velocity)]


def _tracked_separations(rundir: Path, delta: float, v0: float) -> tuple[list[Any], list[Any]]:
    """The run's window frames (grains below the aperture) and its adjacent droplets, found
    in the window and traced back to the aperture through every saved frame
    (:func:`traced_pairs_in`)."""
    from grainflow.analysis.stream import stream_grains

    frames, section = _window_frames(rundir, before=True)
    first = next(k for k, f in enumerate(frames) if f.time >= _steady_start(section) - 1e-12)
    return ([stream_grains(f) for f in frames[first:]],
            traced_pairs_in(frames, delta, v0, first=first))


def _toy_model_section(lengths: dict[int, tuple[Any, list[Any]]], e: np.ndarray,
                       fc: np.ndarray, grain_diameter: float, out: Path,
                       brackets: dict[float, tuple[float, float]]) -> list[str]:
    """The report's toy-model part (seed 000, Sec. IV, Fig. 5): per droplet-forming stream
    the length L0 at the aperture and the separation velocities; the fit
    L0 = (F_c / Sigma)^(1/2) over the streams with at least two tracked pairs; the force
    F* = Sigma d^2 against the crossover the sweep brackets."""
    from grainflow.analysis.stream import fit_toy_model
    from grainflow.plotting.stream_plots import plot_toy_model

    if not lengths:
        return []
    lines = ["Droplet length at the aperture (the toy model's L0: the separation of adjacent "
             "droplets' grains when the pair's centre passes the aperture):", "",
             "| e | F_c (nN) | adjacent pairs | L0 (mm) | initial separation velocity (cm/s) | "
             "free-fall prediction (cm/s) |", "|---|---|---|---|---|---|"]
    for i, (length, seps) in lengths.items():
        v = np.array([q.initial_velocity for q in seps])
        pred = np.array([q.predicted_velocity for q in seps])
        speed = (f"{100 * v.mean():.3g} ± {100 * v.std() / math.sqrt(v.size):.2g}"
                 if v.size else "—")
        predicted = f"{100 * np.nanmean(pred):.3g}" if np.isfinite(pred).any() else "—"
        mm = (f"{1e3 * length.mean:.3g} ± {1e3 * length.err:.2g}"
              if length.pairs > 1 else "—")
        lines.append(f"| {e[i]:g} | {fc[i]:g} | {length.pairs} | {mm} | {speed} | "
                     f"{predicted} |")
    lines.append("")
    usable = [i for i, (length, _) in lengths.items() if length.pairs > 1]
    if len(usable) < 2:
        return lines + ["Fewer than two streams with two or more tracked pairs: the fit "
                        "L0 = (F_c/Sigma)^(1/2) is not made.", ""]
    force = fc[usable] * 1e-9
    l0 = np.array([lengths[i][0].mean for i in usable])
    err = np.array([lengths[i][0].err for i in usable])
    fit = fit_toy_model(force, l0, err, grain_diameter=grain_diameter)
    plot_toy_model(force, l0, err, e[usable], out / "toy_model.png", fit)
    bracket = ", ".join(f"{lo:g}-{hi:g} nN at e = {k:g}" for k, (lo, hi) in
                        sorted(brackets.items())) or "not bracketed by this sweep"
    return lines + ["![L0 against F_c with the toy model](toy_model.png)", "",
                    f"Fit of L0 = (F_c/Sigma)^(1/2) over {fit.points} streams: Sigma = "
                    f"{1e3 * fit.sigma:.3g} ± {1e3 * fit.sigma_err:.2g} nN/mm^2 "
                    f"(chi^2/dof {fit.chi2_dof:.2g}; the seed's value is lost). L0 would "
                    f"equal d at F* = Sigma d^2 = {1e9 * fit.crossover_force:.3g} nN; the seed "
                    "finds F* close to the clustering-to-droplet crossover, which this sweep "
                    f"brackets at {bracket}.", ""]


def _separation_gradient_section(lengths: dict[int, tuple[Any, list[Any]]],
                                 grain_diameter: float, summaries: list[dict[str, float]],
                                 out: Path) -> tuple[Any, list[str]]:
    """The seed's separation gradient (its 1.4 cm/s against g d / v0 = 1.7 predicted):
    the free-fall fit of every tracked pair's separation velocity against its spacing at the
    aperture, pooled over the droplet-forming streams (the seed's pairs collapse onto one
    curve whatever F_c), with the figure; (None, []) with fewer than two pairs."""
    from grainflow.analysis.stream import GRAVITY, fit_separation_gradient
    from grainflow.plotting.stream_plots import plot_separation_gradient

    pairs = [q for _, seps in lengths.values() for q in seps]
    dz0 = np.array([q.dz0 for q in pairs])
    dv0 = np.array([q.initial_velocity for q in pairs])
    try:
        fit = fit_separation_gradient(dz0, dv0, grain_diameter=grain_diameter)
    except ValueError:
        return None, []
    plot_separation_gradient(dz0, dv0, fit, out / "separation_gradient.png",
                             grain_diameter=grain_diameter)
    g_d = GRAVITY * grain_diameter
    v0 = np.array([summaries[i]["v0"] for i in lengths])
    sup = np.array([summaries[i].get("v0_superficial", np.nan) for i in lengths])
    return fit, [
        "![separation velocity against spacing at the aperture](separation_gradient.png)", "",
        f"Separation gradient (seed Sec. III: \"the fit yields 1.4 cm/s, reasonably close to "
        f"the value 1.7 cm/s predicted from just the free-fall velocity profile\", i.e. g d / "
        f"v0): Delta v0 = sqrt(V^2 + 2 g Delta z0) - V fitted to {fit.pairs} pairs of "
        f"{len(lengths)} streams gives V = {100 * fit.speed:.3g} ± {100 * fit.speed_err:.2g} "
        f"cm/s and g d / V = {100 * fit.gradient:.3g} ± {100 * fit.gradient_err:.2g} cm/s "
        f"(rms residual {100 * fit.rms_residual:.2g} cm/s). Predicted from the streams' own "
        f"aperture speed: g d / v0 = {100 * g_d / v0.mean():.3g} cm/s with the grains' speed "
        f"v0 = {100 * v0.mean():.3g} cm/s, {100 * g_d / np.nanmean(sup):.3g} cm/s with the "
        f"superficial speed {100 * np.nanmean(sup):.3g} cm/s.", ""]


def reproduce(out_dir: str | Path, *, reduced: bool = True, scheduler: str | None = None,
              n_workers: int | None = None, progress: str = "auto") -> Path:
    """Run (or continue) the stream study into ``out_dir`` and write ``out_dir/report.md``."""
    from grainflow.analysis.stream import (aperture_length, aspect_ratio_histogram,
                                           normalised_contact_number)
    from grainflow.analysis.stream.fluctuations import fit_free_fall_profile
    from grainflow.models.cohesion_constant import capture_velocity
    from grainflow.plotting.stream_plots import (plot_aspect_histogram, plot_contact_number,
                                                 plot_contact_vs_capture,
                                                 plot_network_size, plot_traced_pairs,
                                                 plot_phase_diagram, plot_stream_side,
                                                 plot_velocity_deviations, write_stream_movie)
    from grainflow.scenarios.stream import GRAVITY, StreamSection, grain_mass
    from grainflow.units import parse_quantity

    plan = REDUCED if reduced else FULL
    out = Path(out_dir)
    # its runs are large (8,000-28,000 grains) and two threads run one 1.8-2x faster: a
    # run that one worker finds alone at the end takes the idle core (docs/streams.md)
    points = run_sweeps(sweep_specs(plan), out, scheduler=scheduler, n_workers=n_workers,
                        progress=progress, worker_threads=os.cpu_count() or 1)
    ph = points["phase"]
    lines = [f"# Cohesive granular streams (seed 000) — {'reduced' if reduced else 'full'} "
             "version", ""]
    if plan.reductions:
        lines += ["Reductions relative to the seed:", ""] + [f"- {r}" for r in plan.reductions]
        lines.append("")
    lines += ["Every quantity is defined in docs/streams.md; depths are below the aperture.", ""]

    e = np.array([float(p["stream.restitution"]) for p in ph.params])
    fc = np.array([_force_nN(p["stream.cohesion_force"]) for p in ph.params])
    summ = ph.summaries
    regime = [regime_name(s) for s in summ]
    order = np.lexsort((fc, -e))
    base = StreamSection(**plan.stream)
    m = grain_mass(base)

    # per-run table
    lines += ["| e | F_c (nN) | v_c (mm/s) | v0 (cm/s) | outflow (grains/ms) | <Z> at 4 cm "
              "| N peak | N_inf (depth) | droplets | regime |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for i in order:
        s = summ[i]
        vc = capture_velocity(fc[i] * 1e-9, base.cohesion_range, m, e[i]) * 1e3
        lines.append(f"| {e[i]:g} | {fc[i]:g} | {vc:.3g} | {100 * s['v0']:.3g} | "
                     f"{s['outflow'] / 1e3:.3g} | {s['Z_4cm']:.3g} ± {s['Z_4cm_err']:.1g} | "
                     f"{s['N_peak']:.3g} | {s['N_inf']:.3g} ({100 * s['N_inf_depth']:.3g} cm) "
                     f"| {s['droplets']:.0f} | {regime[i]} |")
    lines.append("")

    flow = np.array([s["outflow"] for s in summ])
    beverloo = (0.58 * 0.6 * base.density * math.sqrt(GRAVITY)
                * (base.aperture_diameter - 1.5 * base.grain_diameter) ** 2.5 / m)
    if flow.size:
        lines += [f"Outflow {flow.mean() / 1e3:.3g} grains/ms (range {flow.min() / 1e3:.3g}-"
                  f"{flow.max() / 1e3:.3g}); Beverloo's law with the usual C = 0.58, k = 1.5 "
                  f"and a bulk density 0.6 rho gives {beverloo / 1e3:.3g} grains/ms through this "
                  "aperture. v0 is the mean axial speed of the grains in the first diameter "
                  "below the aperture; the seed does not define its v0, and the seed table "
                  "also reads it as the superficial speed Q V_grain/(phi_b A), the outflow "
                  "spread over the aperture at the hopper's bulk packing phi_b.", ""]
    if len(fc):
        plot_phase_diagram(fc * 1e-9, e, [s["Z_4cm"] for s in summ], regime,
                           out / "phase_diagram.png")
        vcs = [capture_velocity(f * 1e-9, base.cohesion_range, m, x) for f, x in zip(fc, e)]
        plot_contact_vs_capture(vcs, [s["Z_4cm"] for s in summ], e, out / "capture.png")
        lines += ["![phase diagram](phase_diagram.png)",
                  "![<Z> against the capture velocity](capture.png)"]

    # profiles per e
    npz = {i: np.load(rd / "stream_analysis.npz") for i, rd in enumerate(ph.rundirs)
           if (rd / "stream_analysis.npz").exists()}
    for e_value in sorted(set(e.tolist()), reverse=True):
        sel = [i for i in order if e[i] == e_value and i in npz]
        if not sel:
            continue
        labels = [f"F_c = {fc[i]:g} nN" for i in sel]
        contact = [normalised_contact_number(_profile(npz[i], "contact", "contact_depth"),
                                             reference_depth=0.5e-3) for i in sel]
        network = [_profile(npz[i], "network", "network_depth") for i in sel]
        plot_contact_number(contact, out / f"contact_e{e_value:g}.png", labels=labels)
        plot_network_size(network, out / f"network_e{e_value:g}.png", labels=labels)
        lines += [f"![Z/Z0, e = {e_value:g}](contact_e{e_value:g}.png)",
                  f"![network size, e = {e_value:g}](network_e{e_value:g}.png)"]
    cohesionless = [i for i in order if fc[i] == 0 and i in npz]
    if cohesionless:
        i = cohesionless[0]
        from grainflow.analysis.stream import DeviationProfiles
        axial = _profile(npz[i], "axial", "deviation_depth")
        transverse = _profile(npz[i], "transverse", "deviation_depth")
        fit = fit_free_fall_profile(axial, summ[i]["v0"], weighting="relative",
                                    depth_range=(1e-3, base.stream_depth - 2e-3))
        plot_velocity_deviations(DeviationProfiles(axial=axial, transverse=transverse,
                                                   total=axial, radius=1.5 * base.grain_diameter),
                                 out / "deviations.png", fit=fit)
        lines += [f"![velocity deviations, e = {e[i]:g}, F_c = 0](deviations.png)", "",
                  f"Free-fall fit of the axial deviations (e = {e[i]:g}, F_c = 0): dz = "
                  f"{fit.dz * 1e6:.3g} ± {fit.dz_err * 1e6:.2g} um with v0 = "
                  f"{100 * summ[i]['v0']:.3g} cm/s.", ""]

    # droplets: aspect ratios pooled over the runs that formed droplets
    aspects = np.concatenate([npz[i]["aspect"] for i in npz]) if npz else np.array([])
    hist = aspect_ratio_histogram(aspects) if aspects.size >= 5 else None
    if hist is not None:
        plot_aspect_histogram(hist, out / "aspect.png")
        lines.append("![aspect ratios](aspect.png)")
    # separation velocity: the most cohesive stream at the lowest e, its pairs traced back;
    # the toy model's length at the aperture: every stream that formed droplets
    strongest = max(order, key=lambda i: (fc[i], -e[i])) if len(order) else None
    separation = None
    lengths: dict[int, tuple[Any, list[Any]]] = {}
    for i in order:
        if fc[i] > 0 and (regime[i] == "droplets" or i == strongest):
            frames, seps = _tracked_separations(ph.rundirs[i], base.cohesion_range,
                                                summ[i]["v0"])
            lengths[i] = (aperture_length(seps), seps)
            if i != strongest:
                continue
            if seps:
                plot_traced_pairs(seps, out / "separations.png")
                lines.append("![droplet separations](separations.png)")
                v = np.array([q.initial_velocity for q in seps])
                v_final = np.array([q.final_velocity for q in seps])
                pred = np.array([q.predicted_velocity for q in seps])
                separation = (float(np.mean(v)), float(np.std(v) / math.sqrt(len(v))),
                              float(np.nanmean(pred)) if np.isfinite(pred).any()
                              else float("nan"), len(seps), float(np.nanmean(v_final)))
            plot_stream_side(frames[-1], out / "stream.png", base.cohesion_range,
                             depth_range=(0.0, base.stream_depth))
            write_stream_movie(frames[::2], out / "stream.gif", base.cohesion_range,
                               depth_range=(0.0, base.stream_depth))
            lines += [f"![stream at e = {e[i]:g}, F_c = {fc[i]:g} nN](stream.png)",
                      "", f"Movie: [stream.gif](stream.gif) (e = {e[i]:g}, "
                      f"F_c = {fc[i]:g} nN).", ""]
    brackets = _crossovers(e, fc, regime)
    lines += _toy_model_section(lengths, e, fc, base.grain_diameter, out, brackets)
    gradient, gradient_lines = _separation_gradient_section(lengths, base.grain_diameter,
                                                            summ, out)
    lines += gradient_lines

    # binary capture
    measured, analytic = measured_capture_velocity(0.40, 100.0, base.cohesion_range * 1e9)
    lines += ["", "Binary capture (two 200 um glass grains, e = 0.40, F_c = 100 nN, "
              f"delta = {base.cohesion_range * 1e9:g} nm): bisection on head-on collisions "
              f"gives v_c = {measured * 1e3:.4g} mm/s; (2/e) sqrt(F_c delta/m) = "
              f"{analytic * 1e3:.4g} mm/s ({100 * (measured / analytic - 1):+.2f} %).", ""]

    # seed table
    table: list[str] = []

    def add(name: str, value: float | None, err: float | None, cost: float) -> None:
        ours, verdict = _verdict(name, value, err)
        seed, kind = SEED[name]
        quoted = ("< " if kind == "max" else "~") + f"{seed:g}"
        table.append(f"| {name} | {quoted} | {ours} | {verdict} | {cost:.0f} |")

    v0 = np.array([s["v0"] for s in summ])
    add("v0 at the aperture (cm/s)", 100 * float(np.mean(v0)) if v0.size else None,
        100 * float(np.std(v0)) if v0.size else None, ph.cpu)
    u = np.array([s["v0_superficial"] for s in summ if "v0_superficial" in s])
    add("v0 read as the superficial speed Q V/(phi_b A) (cm/s)",
        100 * float(np.mean(u)) if u.size else None,
        100 * float(np.std(u)) if u.size else None, ph.cpu)
    clustering = [i for i in range(len(fc)) if 0 < fc[i] < 100 and regime[i] == "clustering"]
    add("N_inf, clustering (F_c < 100 nN)",
        max(summ[i]["N_inf"] for i in clustering) if clustering else None, None, ph.cpu)
    drops = [i for i in range(len(fc)) if regime[i] == "droplets"]
    add("peak network size, droplets", max(summ[i]["N_peak"] for i in drops) if drops else None,
        None, ph.cpu)
    add("most probable aspect ratio", hist.mode if hist is not None else None, None, ph.cpu)
    add("separation gradient g d/V fitted to the droplet pairs (cm/s)",
        100 * gradient.gradient if gradient else None,
        100 * gradient.gradient_err if gradient else None, ph.cpu)
    crossover = np.array([math.sqrt(lo * hi) for lo, hi in brackets.values()])
    add("clustering / droplet crossover F_c (nN)",
        float(np.exp(np.mean(np.log(crossover)))) if crossover.size else None,
        None, ph.cpu)
    lines += ["| quantity | seed | ours | within 30 % | run cost (s of run time, whole "
              "sweep; a lone last run may use two threads) |",
              "|---|---|---|---|---|", *table, ""]
    if brackets:
        lines += ["Crossover from clustering to droplets (geometric mean of the last F_c "
                  "without and the first with droplets, per e; the table gives their "
                  "geometric mean): " + ", ".join(f"e = {k:g}: {lo:g}-{hi:g} nN"
                                                  for k, (lo, hi) in sorted(brackets.items())),
                  ""]
        speeds, common = crossover_capture_velocities(brackets, base.cohesion_range, m)
        overlap = (f"they overlap in {1e3 * common[0]:.3g}-{1e3 * common[1]:.3g} mm/s, so one "
                   "capture velocity can set the crossover at every e of the sweep"
                   if common is not None else "they do not overlap: no single capture "
                   "velocity sets the crossover at every e of the sweep")
        lines += ["The same brackets in the capture velocity v_c = (2/e) sqrt(F_c delta/m): "
                  + ", ".join(f"e = {k:g}: {1e3 * lo:.3g}-{1e3 * hi:.3g} mm/s"
                              for k, (lo, hi) in sorted(speeds.items()))
                  + f"; {overlap} (the seed: the contact number depends mostly on v_c).", ""]
    if separation:
        lines += [f"Droplet separation in the most cohesive stream: {separation[3]} adjacent "
                  "pairs traced back to the aperture by their grains, initial separation "
                  f"velocity Delta v0 = {100 * separation[0]:.3g} ± {100 * separation[1]:.2g} "
                  f"cm/s, final {100 * separation[4]:.3g} cm/s (the seed: \"essentially "
                  f"identical\"), against {100 * separation[2]:.3g} cm/s from free fall at "
                  "their own spacing (the seed gives no mean: its 1.4 cm/s is the gradient in "
                  "the table).", ""]
    sh = points.get("shell")
    if sh is not None and sh.summaries:
        lines += ["Shell thickness at fixed W = F_c delta (e = "
                  f"{plan.shell_e:g}; the base value is delta = 100 nm):", "",
                  "| F_c (nN) | delta (nm) | <Z> at 4 cm | N peak | N_inf | regime |",
                  "|---|---|---|---|---|---|"]
        for p, s in zip(sh.params, sh.summaries):
            name = regime_name(s)
            delta = parse_quantity(p["stream.cohesion_range"], "length") * 1e9
            lines.append(f"| {_force_nN(p['stream.cohesion_force']):g} | {delta:g} | "
                         f"{s['Z_4cm']:.3g} | {s['N_peak']:.3g} | {s['N_inf']:.3g} | {name} |")
        lines.append("")
    total = sum(p.cpu for p in points.values())
    lines += [f"Total run time of the points: {total:.0f} s "
              f"({sum(len(p.rundirs) for p in points.values())} runs).", ""]
    report = out / "report.md"
    report.write_text("\n".join(lines) + "\n")
    return report
