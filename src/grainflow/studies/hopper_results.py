"""Results of hopper runs (seed 003) read back from their run directories.

:func:`flow_summary` is the sweep analysis of the hopper study (``analyses =
["grainflow.studies.hopper_results:flow_summary"]``); :func:`read_events` gives a run's
orifice-crossing events; :func:`collect_series` gathers a finished sweep's flow rates into
Q(w) series for the studies' fits. Both read files the runner and the demo write (``events.csv``,
``checkpoint.npz``, ``config.toml``, ``summary.json``, ``frames.h5``), so they live here,
above the scenario (:mod:`grainflow.scenarios.hopper`), which never reads run directories.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from grainflow.scenarios.hopper import DIAMETER_RATIO, EVENTS, SIGMA_SMALL
from grainflow.scenarios.hopper_reinsertion import grain_size, read_events_csv

if TYPE_CHECKING:
    from grainflow.analysis.hopper import FlowRate, SigmoidFit

__all__ = ["Series", "collect_series", "flow_summary", "fmt", "fmt_lambda_c", "read_events"]


@dataclass
class Series:
    """Flow rates of one set of swept parameters at several orifice widths."""

    w: list[float] = field(default_factory=list)
    Q: list[float] = field(default_factory=list)
    Q_err: list[float] = field(default_factory=list)
    cpu: float = 0.0
    rundirs: list[str] = field(default_factory=list)
    #: Widths whose run carried no flow (clogged: Q = 0).
    clogged: list[float] = field(default_factory=list)


def collect_series(sweepdir: str | Path, keys: tuple[str, ...] = ("hopper.lam",),
                   fixed: dict[str, float] | None = None) -> dict[tuple, Series]:
    """The finished points of a sweep as Q(w) series, keyed by the values of the swept
    fields ``keys`` (the seed field, ``run.seed``, among them): a field the sweep does not vary
    takes its value from ``fixed``, or None. Points with Q = 0 (clogged) count in the series'
    cost but carry no flow rate."""
    from grainflow.sweep import Catalog

    sweepdir = Path(sweepdir)
    series: dict[tuple, Series] = {}
    with Catalog.in_dir(sweepdir) as catalog:
        for row in catalog.rows("done"):
            p = {**row.params, row.seed_field: row.seed}
            key = tuple(float(p[k]) if k in p else (fixed or {}).get(k) for k in keys)
            s = series.setdefault(key, Series())
            if row.summary.get("Q", 0.0) > 0:
                s.w.append(float(p["hopper.orifice_width"]))
                s.Q.append(row.summary["Q"])
                s.Q_err.append(max(row.summary["Q_err"], 1e-12))
                s.rundirs.append(str(sweepdir / row.rundir))  # catalog paths: sweep-relative
            else:
                s.clogged.append(float(p["hopper.orifice_width"]))
            s.cpu += float(row.wall_time or 0.0)
    return series


def fmt(value: float | None, err: float | None = None) -> str:
    """A number (and its error) for a report table; "n/a" when missing or not finite."""
    if value is None or not np.isfinite(value):
        return "n/a"
    return f"{value:.3g}" if err is None else f"{value:.3g} ± {err:.2g}"


def fmt_lambda_c(fit: "SigmoidFit | None") -> str:
    """lambda_c of a :class:`~grainflow.analysis.hopper.SigmoidFit` for a report: value and
    error where the data place it (``fit.resolved``), else the two sampled lambdas the
    transition lies between; "not fit" without a fit."""
    if fit is None:
        return "not fit"
    if fit.resolved:
        return fmt(fit.lambda_c, fit.lambda_c_err)
    low, high = fit.bracket
    return f"not resolved: a step between λ = {low:g} and {high:g}"


def read_events(rundir: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Crossing events ``(times, ids, sizes)`` of a run directory.

    From ``events.csv`` when present (the demo and the study write it), else from the
    reinsertion updater's state in ``checkpoint.npz`` (every run through the runner ends
    with a checkpoint).
    """
    rundir = Path(rundir)
    if (rundir / EVENTS).is_file():
        return read_events_csv(rundir / EVENTS)
    from grainflow.runner import CHECKPOINT, read_checkpoint

    path = rundir / CHECKPOINT
    if not path.is_file():
        raise FileNotFoundError(f"{rundir}: neither {EVENTS} nor {CHECKPOINT}; not a hopper run")
    updaters = read_checkpoint(path)["sim"].get("updaters", {})
    for data in updaters.values():
        if isinstance(data, dict) and "event_times" in data:
            return (np.asarray(data["event_times"], float),
                    np.asarray(data["event_ids"], np.int64),
                    np.asarray(data["event_sizes"], float))
    raise ValueError(f"{path}: holds no hopper crossing events (not a hopper run?)")


def _run_info(rundir: Path) -> dict[str, Any]:
    import tomllib

    info: dict[str, Any] = {}
    cfg = rundir / "config.toml"
    if cfg.is_file():
        data = tomllib.loads(cfg.read_text())
        info["dim"] = data.get("dim")
        info["orifice_width"] = data.get("hopper", {}).get("orifice_width")
        info["particles"] = data.get("hopper", {}).get("particles", "sp")
        info["t_end"] = None
    summary = rundir / "summary.json"
    if summary.is_file():
        import json

        info["t_end"] = json.loads(summary.read_text()).get("time")
        info["wall_time_s"] = json.loads(summary.read_text()).get("wall_time_s")
    return info


def flow_summary(rundir: str | Path) -> dict[str, float]:
    """Sweep analysis: steady flow rate of a hopper run from its saved crossing events.

    Returns ``Q`` and ``Q_err`` (area/volume rate in Q0 = sigma_avg^d/t0, steady window by
    MSER, error bars from 10 blocks, or 5-9 for records of under 200 events:
    :func:`~grainflow.analysis.hopper.flow_rate_from_events`),
    ``number_rate`` and its error (grains per t0), ``n_events``, the steady window
    ``t_start``/``t_end``, ``w`` (from config.toml) and the run's ``wall_time_s``. With saved
    frames (``frames.h5``) also ``Q_prime``/``Q_prime_err``, the overlap-corrected rate of
    seed Appendix B, from the number density in the 2w x w region above the orifice over the
    frames of the steady window (soft particles only: deformable rings keep their area).
    Pure function of files in ``rundir``.
    """
    from grainflow.analysis.hopper import flow_rate_from_events

    rundir = Path(rundir)
    times, _, sizes = read_events(rundir)
    info = _run_info(rundir)
    # 10 blocks for the error bar, fewer (down to 5) for a short record: >= 20 events a block
    n_blocks = int(np.clip(times.size // 20, 5, 10))
    flow = flow_rate_from_events(times, sizes, t_begin=0.0, t_end=info.get("t_end"),
                                 n_blocks=n_blocks)
    out = {"Q": flow.flow_rate, "Q_err": flow.flow_rate_err,
           "number_rate": flow.number_rate, "number_rate_err": flow.number_rate_err,
           "n_events": float(flow.n_events), "t_start": flow.t_start, "t_end": flow.t_end}
    if info.get("orifice_width") is not None:
        out["w"] = float(info["orifice_width"])
    if info.get("wall_time_s") is not None:
        out["wall_time_s"] = float(info["wall_time_s"])
    # Q' corrects for the overlaps of soft particles; rings keep their area (and their
    # frames hold vertices, not grains)
    if ((rundir / "frames.h5").is_file() and info.get("orifice_width") and info.get("dim")
            and info.get("particles", "sp") == "sp"):
        out.update(_overlap_corrected(rundir, flow, int(info["dim"]), float(info["orifice_width"])))
    return out


def _overlap_corrected(rundir: Path, flow: "FlowRate", dim: int, w: float) -> dict[str, float]:
    """Q' of seed Appendix B from the frames of the steady window (empty if < 2 frames)."""
    from grainflow.analysis.hopper import orifice_number_density, overlap_corrected_flow_rate
    from grainflow.io.h5md import read_frames

    positions = [fr.position for fr in read_frames(rundir / "frames.h5")
                 if flow.t_start <= fr.time <= flow.t_end]
    if len(positions) < 2:
        return {}
    rho, rho_err = orifice_number_density(positions, np.zeros(dim), w)
    a_avg = float(np.mean(grain_size(0.5 * SIGMA_SMALL * np.array([1.0, DIAMETER_RATIO]), dim)))
    corrected = overlap_corrected_flow_rate(flow.flow_rate, rho, a_avg,
                                            flow_rate_err=flow.flow_rate_err,
                                            number_density_err=rho_err)
    return {"Q_prime": corrected.flow_rate, "Q_prime_err": corrected.flow_rate_err,
            "number_density": rho}
