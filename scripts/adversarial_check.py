#!/usr/bin/env python3
"""Adversarial check of grainflow's command line: bad inputs and faults, run as a user would.

What it measures
----------------
Two totals, each computed from what actually happened in a subprocess running
``python3 -m grainflow ...`` (with ``NUMBA_NUM_THREADS=1`` and a timeout per case):

1. **Bad inputs** ("refused cleanly: X / Y"): about a hundred invalid configurations, config
   files and options covering every section of docs/config.md (run, output, box, every fill
   kind, every wall shape, contact law/model/params/pairs, gravity, drag, tethers,
   insert/delete updaters, the hopper and chute scenarios, files that are empty, not TOML, not
   UTF-8, a directory, malformed LAMMPS data files, ...). A case is *refused cleanly* when the
   exit code is 2, stderr has no ``Traceback``, every stderr line starts with ``error: `` or
   ``warning: ``, the error names the broken field (an expected substring given per case) and
   the run directory was not created or is empty. Otherwise it is classified as ``accepted``
   (exit 0), ``traceback``, ``wrong-exit-code``, ``wrong-field``, ``bad-stderr`` (a line that is
   not ``error:``/``warning:``), ``rundir-left`` (files left in the run directory) or
   ``timeout``.

2. **Fault cases** ("fault cases handled: X / Y"): runs that blow up (periodic boxes with
   outputs every step, unsafe dt with walls, absurd speeds, grains thrown out of an open box,
   ...), real SIGINT/SIGTERM/SIGKILL sent to running ``grainflow run``/``resume`` processes at
   random moments followed by ``grainflow resume`` (compared with an uninterrupted reference
   run), damaged checkpoints / trajectories / thermo logs / manifests, run-directory safety
   (user files next to a run, hand-written config.toml, a user's frames.dump) and sweeps (an
   invalid point, a garbage catalog, relative data paths from another working directory).
   A case is *handled* when the documented exit code and a clean ``error:`` line naming the
   file or cause come back (or the run recovers), no Traceback appears and no user file is lost.

Each case prints one line: id, verdict and a one-line reason (usually the first stderr line).
The script uses only the standard library, numpy, h5py and tomli_w.

Run it from anywhere (about 5-10 minutes on 2 cores)::

    python3 scripts/adversarial_check.py [--keep DIR] [--seed N] [--only PREFIX]

``--keep DIR`` builds the cases in DIR and leaves them there for inspection (default: a
temporary directory that is removed at the end); ``--seed`` fixes the random signal timings
and damage bytes (default: random, printed); ``--only`` runs only the cases whose id starts
with PREFIX. The exit status is 0 when every case was refused cleanly / handled, else 1.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import json
import math
import os
import random
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
import tomli_w

ROOT = Path(__file__).resolve().parent.parent
ENV = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1", PYTHONUNBUFFERED="1")
ENV.pop("GRAINFLOW_DEBUG", None)
CASE_TIMEOUT = 90.0


# --------------------------------------------------------------------------------------------
# running the command
# --------------------------------------------------------------------------------------------


@dataclass
class Result:
    rc: int | None
    out: str
    err: str
    timed_out: bool = False
    wall: float = 0.0

    @property
    def first_err(self) -> str:
        for line in self.err.splitlines():
            if line.strip():
                return line.strip()
        return ""

    @property
    def error_line(self) -> str:
        """The first line starting with 'error:' (else the first stderr line)."""
        for line in self.err.splitlines():
            if line.startswith("error:"):
                return line.strip()
        return self.first_err

    @property
    def traceback(self) -> bool:
        return "Traceback" in self.err or "Traceback" in self.out


def _default_signals():
    """Children start with default SIGINT/SIGTERM handling even when this script was started
    in the background (where the shell ignores SIGINT, and ignored signals are inherited)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def gf(args, cwd=None, timeout=CASE_TIMEOUT) -> Result:
    cmd = [sys.executable, "-m", "grainflow", *[str(a) for a in args]]
    t0 = time.monotonic()
    try:
        p = subprocess.run(cmd, cwd=cwd, env=ENV, capture_output=True, text=True,
                           errors="replace", timeout=timeout, stdin=subprocess.DEVNULL,
                           preexec_fn=_default_signals)
        return Result(p.returncode, p.stdout, p.stderr, False, time.monotonic() - t0)
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or "")
        err = e.stderr.decode(errors="replace") if isinstance(e.stderr, bytes) else (e.stderr or "")
        return Result(None, out, err, True, time.monotonic() - t0)


def start(args, cwd=None, log_prefix: Path | None = None) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "grainflow", *[str(a) for a in args]]
    assert log_prefix is not None
    out = open(str(log_prefix) + ".out", "w")
    err = open(str(log_prefix) + ".err", "w")
    return subprocess.Popen(cmd, cwd=cwd, env=ENV, stdout=out, stderr=err,
                            stdin=subprocess.DEVNULL, preexec_fn=_default_signals)


def finish(p: subprocess.Popen, log_prefix: Path, timeout=CASE_TIMEOUT) -> Result:
    t0 = time.monotonic()
    timed_out = False
    try:
        p.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        timed_out = True
        p.kill()
        p.wait()
    out = Path(str(log_prefix) + ".out").read_text(errors="replace")
    err = Path(str(log_prefix) + ".err").read_text(errors="replace")
    return Result(None if timed_out else p.returncode, out, err, timed_out, time.monotonic() - t0)


def stderr_clean(r: Result) -> str | None:
    """None if every non-empty stderr line is 'error: ...' or 'warning: ...' (indented
    continuation lines of a listed error allowed when allow_indent), else the offending line."""
    for line in r.err.splitlines():
        if not line.strip():
            continue
        if line.startswith("error: ") or line.startswith("warning: "):
            continue
        return line.strip()
    return None


def write_toml(path: Path, data: dict) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(tomli_w.dumps(data).encode())
    return path


def dir_listing(path: Path) -> dict[str, bytes]:
    """Every file under path with its content (for 'nothing lost / changed' checks)."""
    files = {}
    if not path.exists():
        return files
    for p in sorted(path.rglob("*")):
        if p.is_file():
            files[str(p.relative_to(path))] = p.read_bytes()
    return files


def short(s: str, n: int = 150) -> str:
    s = " ".join(s.split())
    return s if len(s) <= n else s[: n - 3] + "..."


# --------------------------------------------------------------------------------------------
# base configurations
# --------------------------------------------------------------------------------------------


def base2d() -> dict:
    return {
        "dim": 2,
        "gravity": [0, -1],
        "run": {"steps": 200, "seed": 1},
        "output": {"thermo_every": 50, "frames_every": 100, "checkpoint_every": 100,
                   "snapshot": False},
        "box": {"lo": [0, 0], "hi": [10, 10]},
        "particles": [{"fill": "lattice", "region": {"lo": [0, 0], "hi": [10, 5]},
                       "radius": 0.4}],
        "contact": {"law": "granular", "restitution": 0.7, "contact_time": 0.05, "mu": 0.5},
        "walls": [{"shape": "plane", "point": [0, 0], "normal": [0, 1]}],
    }


def base3d() -> dict:
    return {
        "dim": 3,
        "gravity": [0, 0, -1],
        "run": {"steps": 100, "seed": 1},
        "output": {"thermo_every": 50, "frames_every": 50, "checkpoint_every": 100,
                   "snapshot": False},
        "box": {"lo": [-5, -5, 0], "hi": [5, 5, 10]},
        "particles": [{"fill": "lattice", "region": {"lo": [-2, -2, 1], "hi": [2, 2, 4]},
                       "radius": 0.4}],
        "contact": {"law": "granular", "restitution": 0.7, "contact_time": 0.05, "mu": 0.5},
        "walls": [{"shape": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
    }


def base_soft() -> dict:
    c = base2d()
    c["contact"] = {"law": "soft", "epsilon": 100.0, "mu_k": 0.5}
    c["drag"] = 0.5
    return c


def base_hopper() -> dict:
    return {
        "scenario": "hopper2d", "dim": 2,
        "run": {"steps": 50, "minimize": True, "max_overlap_fraction": 1.0, "seed": 0},
        "output": {"thermo_every": 25, "frames_every": 0, "checkpoint_every": 0,
                   "snapshot": False},
        "hopper": {"n": 60, "width": 10.0, "orifice_width": 4.0, "E_sp": 1000.0,
                   "E_w": 1000.0, "lam": math.inf, "dt_fraction": 0.065},
    }


def base_chute() -> dict:
    return {
        "scenario": "chute",
        "run": {"steps": 2},
        "output": {"thermo_every": 1, "frames_every": 0, "checkpoint_every": 0,
                   "snapshot": False},
        "chute": {"replicate": [1, 1], "angle": 26.0},
    }


def lammps_text(atoms: list[str], n_declared=None, style="sphere", box=(0, 10),
                header_extra="") -> str:
    n = len(atoms) if n_declared is None else n_declared
    lo, hi = box
    style_comment = f" # {style}" if style else ""
    return (f"LAMMPS data file\n\n{n} atoms\n1 atom types\n{header_extra}\n"
            f"{lo} {hi} xlo xhi\n{lo} {hi} ylo yhi\n{lo} {hi} zlo zhi\n\n"
            f"Atoms{style_comment}\n\n" + "\n".join(atoms) + "\n")


GOOD_ATOMS = ["1 1 0.8 1.0 2 2 2", "2 1 0.8 1.0 5 5 5", "3 1 0.8 1.0 7 7 7"]


def lammps_cfg(fname="grains.data", **extra) -> dict:
    c = base3d()
    c["box"] = {"lo": [0, 0, 0], "hi": [10, 10, 10]}
    c["particles"] = [{"fill": "lammps_data", "file": fname, **extra}]
    c["walls"] = []
    del c["walls"]
    return c


# --------------------------------------------------------------------------------------------
# 1. bad inputs
# --------------------------------------------------------------------------------------------


@dataclass
class Bad:
    cid: str
    expect: tuple[str, ...]          # any of these substrings must appear in an error line
    config: dict | None = None       # written with tomli_w ...
    raw: bytes | None = None         # ... or these bytes ...
    files: dict | None = None        # extra files next to the config {name: bytes|str}
    args: tuple = ()                 # extra command-line arguments
    config_is_dir: bool = False      # pass a directory as the config
    no_config_file: bool = False     # pass a path that does not exist


def mut(base_fn, fn) -> dict:
    c = base_fn()
    fn(c)
    return c


def setp(path: str, value):
    """Return a mutation setting a dotted path ('particles.0.radius') to value ('DEL' deletes)."""
    def f(c):
        keys = path.split(".")
        cur = c
        for k in keys[:-1]:
            cur = cur[int(k)] if isinstance(cur, list) else cur.setdefault(k, {})
        last = keys[-1]
        if isinstance(cur, list):
            cur[int(last)] = value
        elif value == "DEL":
            cur.pop(last, None)
        else:
            cur[last] = value
    return f


def b2(path, value):
    return mut(base2d, setp(path, value))


def b3(path, value):
    return mut(base3d, setp(path, value))


def with_wall2(wall: dict) -> dict:
    c = base2d()
    c["walls"] = [wall]
    return c


def with_wall3(wall: dict) -> dict:
    c = base3d()
    c["walls"] = [{"shape": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}, wall]
    return c


def with_parts2(p: dict) -> dict:
    c = base2d()
    c["particles"] = [p]
    return c


def with_contact(contact: dict, base_fn=base2d) -> dict:
    c = base_fn()
    c["contact"] = contact
    return c


def with_list(key, value, base_fn=base2d) -> dict:
    c = base_fn()
    c[key] = value
    return c


def pour(**kw) -> dict:
    d = {"kind": "pour", "region": {"lo": [1, 7], "hi": [9, 9]}, "every": 50,
         "per_insertion": 2, "total": 6, "radius": 0.3}
    d.update(kw)
    return {k: v for k, v in d.items() if v != "DEL"}


def repl(**kw) -> dict:
    d = {"kind": "replenish", "region": {"lo": [1, 7], "hi": [9, 9]},
         "count_region": {"lo": [0, 0], "hi": [10, 10]}, "target": 40, "every": 50,
         "radius": 0.3}
    d.update(kw)
    return {k: v for k, v in d.items() if v != "DEL"}


def dele(**kw) -> dict:
    d = {"region": {"lo": [0, 0], "hi": [10, 10]}, "every": 50}
    d.update(kw)
    return {k: v for k, v in d.items() if v != "DEL"}


def hop(path, value):
    return mut(base_hopper, setp(path, value))


def chute(path, value):
    return mut(base_chute, setp(path, value))


def bad_cases() -> list[Bad]:
    nan, inf = math.nan, math.inf
    L: list[Bad] = []
    add = L.append
    # ---- top level / files --------------------------------------------------------------
    add(Bad("file-empty", ("run",), raw=b""))
    add(Bad("file-not-toml", ("case.toml", "line"),
            raw=b"run:\n  steps: 100\nbox:\n  lo: [0, 0]\n"))
    add(Bad("file-not-utf8", ("UTF-8", "utf-8", "case.toml"),
            raw=tomli_w.dumps(base2d()).encode() + b"\n# caf\xe9 cr\xe8me\n"))
    add(Bad("file-binary", ("case.toml",), raw=bytes(random.Random(5).randrange(256)
                                                     for _ in range(400))))
    add(Bad("file-duplicate-key", ("case.toml", "steps", "line"),
            raw=b"dim = 2\n[run]\nsteps = 10\nsteps = 20\n"))
    add(Bad("file-is-directory", ("cfgdir",), config_is_dir=True))
    add(Bad("file-missing", ("nonexistent.toml",), no_config_file=True))
    add(Bad("dim-4", ("dim",), b2("dim", 4)))
    add(Bad("dim-string", ("dim",), b2("dim", "2")))
    add(Bad("scenario-unknown", ("scenario",), b2("scenario", "hopper4d")))
    add(Bad("toplevel-misspelled-gravty", ("gravty",), mut(base2d, lambda c: c.update(
        gravty=c.pop("gravity")))))
    add(Bad("gravity-under-output", ("output.gravity",), b2("output.gravity", [0, -1])))
    add(Bad("gravity-3-in-2d", ("gravity",), b2("gravity", [0, -1, 0])))
    add(Bad("gravity-scalar-string", ("gravity",), b2("gravity", "9.81")))
    add(Bad("gravity-wrong-unit", ("gravity",), b2("gravity", [0, "-9.81 m/s"])))
    add(Bad("gravity-nan", ("gravity",), b2("gravity", [0, nan])))
    add(Bad("drag-negative", ("drag",), mut(base_soft, setp("drag", -0.5))))
    add(Bad("drag-table", ("drag",), mut(base_soft, setp("drag", {"zeta": 0.5}))))
    add(Bad("option-threads-0", ("--threads",), b2("run.steps", 10), args=("--threads", "0")))
    add(Bad("option-progress-bogus", ("--progress", "progress"), b2("run.steps", 10),
            args=("--progress", "fancy")))
    # ---- [run] ---------------------------------------------------------------------------
    add(Bad("run-missing", ("run",), mut(base2d, lambda c: c.pop("run"))))
    add(Bad("run-steps-string", ("run.steps",), b2("run.steps", "300")))
    add(Bad("run-steps-zero", ("run.steps",), b2("run.steps", 0)))
    add(Bad("run-steps-float", ("run.steps",), b2("run.steps", 1e3)))
    add(Bad("run-steps-and-duration", ("run.steps", "run.duration", "run: give exactly one of steps"), b2("run.duration", 0.1)))
    add(Bad("run-no-length", ("run.steps", "run.duration", "run: give exactly one of steps"), b2("run.steps", "DEL")))
    add(Bad("run-duration-metres", ("run.duration",),
            mut(base2d, lambda c: (c["run"].pop("steps"), c["run"].update(duration="5 m")))))
    add(Bad("run-duration-overflow", ("run.duration", "run.steps"),
            mut(base2d, lambda c: (c["run"].pop("steps"), c["run"].update(duration=1e300)))))
    add(Bad("run-dt-negative", ("run.dt",), b2("run.dt", -1e-3)))
    add(Bad("run-dt-nan", ("run.dt",), b2("run.dt", nan)))
    add(Bad("run-dt-inf", ("run.dt",), b2("run.dt", inf)))
    add(Bad("run-dt-above-contact-time", ("run.dt",), b2("run.dt", 0.1)))
    add(Bad("run-dt-kg", ("run.dt",), b2("run.dt", "3 kg")))
    add(Bad("run-dt_fraction-0.5", ("run.dt_fraction",), b2("run.dt_fraction", 0.5)))
    add(Bad("run-integrator-euler", ("run.integrator",), b2("run.integrator", "euler")))
    add(Bad("run-seed-negative", ("run.seed",), b2("run.seed", -1)))
    add(Bad("run-seed-float", ("run.seed",), b2("run.seed", 1.5)))
    add(Bad("run-skin-zero", ("run.skin",), b2("run.skin", 0)))
    add(Bad("run-sort_every-float", ("run.sort_every",), b2("run.sort_every", 2.5)))
    add(Bad("run-check_every-bool", ("run.check_every",), b2("run.check_every", True)))
    add(Bad("run-max_overlap-negative", ("run.max_overlap_fraction",),
            b2("run.max_overlap_fraction", -0.1)))
    add(Bad("run-allow_unsafe_dt-yes", ("run.allow_unsafe_dt",), b2("run.allow_unsafe_dt", "yes")))
    add(Bad("run-minimize-int", ("run.minimize",), b2("run.minimize", 1)))
    add(Bad("run-misspelled-stpes", ("run.stpes",), b2("run.stpes", 300)))
    add(Bad("run-as-list", ("run",), mut(base2d, lambda c: c.update(run=[c["run"]]))))
    # ---- [output] ------------------------------------------------------------------------
    add(Bad("output-thermo_every-zero", ("output.thermo_every",), b2("output.thermo_every", 0)))
    add(Bad("output-frames_every-negative", ("output.frames_every",),
            b2("output.frames_every", -1)))
    add(Bad("output-compression-zstd", ("output.compression",), b2("output.compression", "zstd")))
    add(Bad("output-snapshot_plane-xw", ("output.snapshot_plane",),
            b2("output.snapshot_plane", "xw")))
    add(Bad("output-progress_interval-zero", ("output.progress_interval",),
            b2("output.progress_interval", 0)))
    add(Bad("output-contacts-string", ("output.contacts",), b2("output.contacts", "no")))
    add(Bad("output-checkpoint_every-list", ("output.checkpoint_every",),
            b2("output.checkpoint_every", [100])))
    add(Bad("output-thermo_every-table", ("output.thermo_every",),
            b2("output.thermo_every", {"every": 5})))
    add(Bad("output-snapshot-no", ("output.snapshot",), b2("output.snapshot", "no")))
    # ---- [box] ---------------------------------------------------------------------------
    add(Bad("box-hi-below-lo", ("box",), b2("box.hi", [10, -1])))
    add(Bad("box-lo-3-in-2d", ("box.lo",), b2("box.lo", [0, 0, 0])))
    add(Bad("box-periodic-ints", ("box.periodic",), b2("box.periodic", [1, 0])))
    add(Bad("box-hi-kg", ("box.hi",), b2("box.hi", ["10 kg", 10])))
    add(Bad("box-hi-inf", ("box.hi",), b2("box.hi", [inf, 10])))
    add(Bad("box-missing", ("box",), mut(base2d, lambda c: c.pop("box"))))
    add(Bad("box-flat", ("box",), b2("box.hi", [10, 0])))
    # ---- [[particles]] -------------------------------------------------------------------
    p_lat = {"fill": "lattice", "region": {"lo": [0, 0], "hi": [10, 5]}, "radius": 0.4}
    add(Bad("particles-fill-hexagonal", ("particles[0].fill",),
            with_parts2({**p_lat, "fill": "hexagonal"})))
    add(Bad("particles-missing-fill", ("particles[0].fill", "particles[0]"),
            with_parts2({k: v for k, v in p_lat.items() if k != "fill"})))
    add(Bad("particles-as-table", ("particles",), mut(base2d, lambda c: c.update(
        particles=c["particles"][0]))))
    add(Bad("particles-radius-empty-list", ("particles[0].radius",),
            with_parts2({**p_lat, "radius": []})))
    add(Bad("particles-radius-nan", ("particles[0].radius",), with_parts2({**p_lat, "radius": nan})))
    add(Bad("particles-radius-bool", ("particles[0].radius",), with_parts2({**p_lat, "radius": True})))
    add(Bad("particles-radius-overflow-unit", ("particles[0].radius",),
            with_parts2({**p_lat, "radius": "1e400 m"})))
    add(Bad("particles-radius-furlong", ("particles[0].radius",),
            with_parts2({**p_lat, "radius": "0.4 furlong"})))
    add(Bad("particles-fractions-length", ("particles[0].fractions",),
            with_parts2({**p_lat, "radius": [0.3, 0.4], "fractions": [1.0]})))
    add(Bad("particles-fractions-negative", ("particles[0].fractions",),
            with_parts2({**p_lat, "radius": [0.3, 0.4], "fractions": [1.5, -0.5]})))
    add(Bad("particles-density-and-mass", ("particles[0].mass", "particles[0].density"),
            with_parts2({**p_lat, "density": 1.0, "mass": 2.0})))
    add(Bad("particles-density-metres", ("particles[0].density",),
            with_parts2({**p_lat, "density": "1 m"})))
    add(Bad("particles-mass-zero", ("particles[0].mass",), with_parts2({**p_lat, "mass": 0})))
    add(Bad("particles-type-negative", ("particles[0].type",), with_parts2({**p_lat, "type": -1})))
    add(Bad("particles-type-float", ("particles[0].type",), with_parts2({**p_lat, "type": 0.0})))
    add(Bad("particles-velocity-1-component", ("particles[0].velocity",),
            with_parts2({**p_lat, "velocity": [1]})))
    add(Bad("particles-frozen-string", ("particles[0].frozen",),
            with_parts2({**p_lat, "frozen": "false"})))
    add(Bad("lattice-fcc-in-2d", ("particles[0].lattice",), with_parts2({**p_lat, "lattice": "fcc"})))
    add(Bad("lattice-1e12-sites", ("particles[0]",),
            mut(base2d, lambda c: (c["box"].update(hi=[1e6, 1e6]), c["particles"][0].update(
                region={"lo": [0, 0], "hi": [1e6, 1e6]}, spacing=1.0)))))
    add(Bad("lattice-spacing-overlapping", ("particles[0].spacing",),
            with_parts2({**p_lat, "spacing": 0.2})))
    add(Bad("lattice-packing_fraction-1.5", ("particles[0].packing_fraction",),
            with_parts2({**p_lat, "packing_fraction": 1.5})))
    add(Bad("lattice-region-outside-box", ("particles[0].region",),
            with_parts2({**p_lat, "region": {"lo": [20, 20], "hi": [30, 30]}})))
    add(Bad("lattice-region-disk-negative-radius", ("particles[0].region",),
            with_parts2({**p_lat, "region": {"shape": "disk", "center": [5, 5], "radius": -2}})))
    add(Bad("lattice-region-cylinder-in-2d", ("particles[0].region",),
            with_parts2({**p_lat, "region": {"shape": "cylinder", "center": [5, 5], "radius": 2,
                                             "lo": 0, "hi": 5}})))
    add(Bad("lattice-region-unknown-shape", ("particles[0].region",),
            with_parts2({**p_lat, "region": {"shape": "star", "lo": [0, 0], "hi": [5, 5]}})))
    add(Bad("lattice-region-empty-for-radius", ("particles[0]",),
            with_parts2({**p_lat, "region": {"lo": [1, 1], "hi": [1.5, 1.5]}})))
    p_rnd = {"fill": "random", "count": 20, "radius": 0.4, "region": {"lo": [0, 0], "hi": [10, 5]}}
    add(Bad("random-count-zero", ("particles[0].count",), with_parts2({**p_rnd, "count": 0})))
    add(Bad("random-count-overpacked", ("particles[0].count",),
            with_parts2({**p_rnd, "count": 100000})))
    add(Bad("random-max_attempts-zero", ("particles[0].max_attempts",),
            with_parts2({**p_rnd, "max_attempts": 0})))
    add(Bad("random-with-positions-key", ("particles[0].positions",),
            with_parts2({**p_rnd, "positions": [[1, 1]]})))
    p_list = {"fill": "list", "positions": [[2, 2], [5, 2], [8, 2]], "radius": 0.4}
    add(Bad("list-positions-3d-in-2d", ("particles[0].positions",),
            with_parts2({**p_list, "positions": [[2, 2, 0], [5, 2, 0]]})))
    add(Bad("list-positions-outside-box", ("particles[0].positions",),
            with_parts2({**p_list, "positions": [[2, 2], [50, 2]]})))
    add(Bad("list-positions-empty", ("particles[0].positions",),
            with_parts2({**p_list, "positions": []})))
    add(Bad("list-velocities-count", ("particles[0].velocities",),
            with_parts2({**p_list, "velocities": [[0, 1]]})))
    add(Bad("list-positions-strings", ("particles[0].positions",),
            with_parts2({**p_list, "positions": [["a", "b"]]})))
    add(Bad("list-behind-plane-wall", ("walls[0]", "particles[0]"),
            mut(base2d, lambda c: c["walls"][0].update(point=[0, 6]))))
    add(Bad("list-outside-tube", ("walls[1]", "particles[0]"),
            mut(base3d, lambda c: c["walls"].append({"shape": "cylinder", "axis_point": [0, 0, 0],
                                                     "radius": 1.0}))))
    # LAMMPS data files
    add(Bad("lammps-file-missing", ("particles[0].file", "nothere.data"), lammps_cfg("nothere.data")))
    add(Bad("lammps-malformed", ("particles[0]", "grains.data"), lammps_cfg(),
            files={"grains.data": "LAMMPS data file\n\nthree atoms\nAtoms\n\n1 1 x y z\n"}))
    add(Bad("lammps-duplicate-ids", ("particles[0]", "grains.data"), lammps_cfg(),
            files={"grains.data": lammps_text(GOOD_ATOMS[:2] + ["2 1 0.8 1.0 7 7 7"])}))
    add(Bad("lammps-atom-style-atomic", ("particles[0]", "grains.data"), lammps_cfg(),
            files={"grains.data": lammps_text(["1 1 2 2 2", "2 1 5 5 5"], style="atomic")}))
    add(Bad("lammps-atoms-outside-box", ("particles[0]", "grains.data"), lammps_cfg(),
            files={"grains.data": lammps_text(GOOD_ATOMS[:2] + ["3 1 0.8 1.0 70 7 7"],
                                              box=(0, 100))}))
    add(Bad("lammps-count-mismatch", ("particles[0]", "grains.data"), lammps_cfg(),
            files={"grains.data": lammps_text(GOOD_ATOMS, n_declared=5)}))
    add(Bad("lammps-negative-diameter", ("particles[0]", "grains.data"), lammps_cfg(),
            files={"grains.data": lammps_text(GOOD_ATOMS[:2] + ["3 1 -0.8 1.0 7 7 7"])}))
    add(Bad("lammps-frozen_types-zero", ("particles[0].frozen_types",),
            lammps_cfg(frozen_types=[0]), files={"grains.data": lammps_text(GOOD_ATOMS)}))
    add(Bad("lammps-with-radius-key", ("particles[0].radius",), lammps_cfg(radius=0.4),
            files={"grains.data": lammps_text(GOOD_ATOMS)}))
    add(Bad("lammps-gzip-garbage", ("particles[0]", "grains.data.gz"), lammps_cfg("grains.data.gz"),
            files={"grains.data.gz": gzip.compress(b"LAMMPS data file\n\n3 atoms\n")[:25]}))
    add(Bad("lammps-file-is-dir", ("particles[0]", "datadir"), lammps_cfg("datadir"),
            files={"datadir/": b""}))
    # ---- [[walls]] -----------------------------------------------------------------------
    add(Bad("wall-shape-sphere", ("walls[0].shape",),
            with_wall2({"shape": "sphere", "point": [0, 0], "radius": 1})))
    add(Bad("wall-missing-shape", ("walls[0]",), with_wall2({"point": [0, 0], "normal": [0, 1]})))
    add(Bad("wall-plane-zero-normal", ("walls[0].normal",),
            with_wall2({"shape": "plane", "point": [0, 0], "normal": [0, 0]})))
    add(Bad("wall-plane-z-normal-in-2d", ("walls[0]",),
            with_wall2({"shape": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]})))
    add(Bad("wall-plane-unknown-key-radius", ("walls[0].radius",),
            with_wall2({"shape": "plane", "point": [0, 0], "normal": [0, 1], "radius": 2})))
    add(Bad("wall-plane-point-kg", ("walls[0].point",),
            with_wall2({"shape": "plane", "point": ["0 kg", 0], "normal": [0, 1]})))
    add(Bad("wall-segment-degenerate", ("walls[0].p1", "walls[0]"),
            with_wall2({"shape": "segment", "p0": [1, 1], "p1": [1, 1]})))
    add(Bad("wall-type-negative", ("walls[0].type",),
            with_wall2({"shape": "plane", "point": [0, 0], "normal": [0, 1], "type": -1})))
    add(Bad("wall-velocity-string", ("walls[0].velocity",),
            with_wall2({"shape": "plane", "point": [0, 0], "normal": [0, 1], "velocity": "fast"})))
    cyl = {"shape": "cylinder", "axis_point": [0, 0, 0], "radius": 4.0, "inside": True}
    add(Bad("wall-cylinder-radius-zero", ("walls[1].radius",), with_wall3({**cyl, "radius": 0})))
    add(Bad("wall-cylinder-axial_range-reversed", ("walls[1].axial_range",),
            with_wall3({**cyl, "axial_range": [10, 0]})))
    add(Bad("wall-cylinder-lid-on-infinite-end", ("walls[1].lid_lo", "walls[1]"),
            with_wall3({**cyl, "lid_lo": True})))
    add(Bad("wall-cylinder-zero-axis", ("walls[1].axis_direction",),
            with_wall3({**cyl, "axis_direction": [0, 0, 0]})))
    add(Bad("wall-cylinder-with-lids-in-2d", ("walls[0]",),
            with_wall2({"shape": "cylinder", "axis_point": [5, 5], "radius": 6,
                        "axial_range": [-1, 1], "lid_lo": True, "lid_hi": True})))
    cone = {"shape": "cone", "apex": [0, 0, -2], "axis": [0, 0, 1], "half_angle_deg": 60,
            "axial_range": [2, 12]}
    add(Bad("wall-cone-mixed-forms", ("walls[1]",), with_wall3({**cone, "radius_lo": 2})))
    add(Bad("wall-cone-half-angle-90", ("walls[1].half_angle_deg",),
            with_wall3({**cone, "half_angle_deg": 90})))
    add(Bad("wall-cone-negative-s_min", ("walls[1].axial_range",),
            with_wall3({**cone, "axial_range": [-2, 12]})))
    lcone = {"shape": "cone", "axis": "z", "center": [0, 0], "radius_lo": 5, "radius_hi": 8,
             "lo": -1, "hi": 10}
    add(Bad("wall-cone-lammps-both-radii-zero", ("walls[1].radius", "walls[1]: radius_lo"),
            with_wall3({**lcone, "radius_lo": 0, "radius_hi": 0})))
    add(Bad("wall-cone-lammps-lo-above-hi", ("walls[1].hi", "walls[1].lo"),
            with_wall3({**lcone, "lo": 10, "hi": -1})))
    add(Bad("wall-cone-lammps-axis-w", ("walls[1].axis",), with_wall3({**lcone, "axis": "w"})))
    add(Bad("wall-plate-hole-negative", ("walls[1].hole_radius",),
            with_wall3({"shape": "plate_with_hole", "point": [0, 0, 0], "normal": [0, 0, 1],
                        "hole_radius": -1})))
    hop2 = {"shape": "hopper2d", "W": 9, "orifice_w": 3, "height": 9, "x_center": 5}
    add(Bad("wall-hopper2d-orifice-wider", ("walls[0].orifice_w",),
            with_wall2({**hop2, "orifice_w": 12})))
    add(Bad("wall-hopper2d-theta-120", ("walls[0].theta_w_deg",),
            with_wall2({**hop2, "theta_w_deg": 120})))
    add(Bad("walls-as-table", ("walls",), mut(base2d, lambda c: c.update(walls=c["walls"][0]))))
    # ---- [contact] -----------------------------------------------------------------------
    g = {"law": "granular", "restitution": 0.7, "contact_time": 0.05, "mu": 0.5}
    add(Bad("contact-law-hookean", ("contact.law",), with_contact({**g, "law": "hookean"})))
    add(Bad("contact-missing", ("contact",), mut(base2d, lambda c: c.pop("contact"))))
    add(Bad("contact-restitution-zero", ("contact.restitution",),
            with_contact({**g, "restitution": 0})))
    add(Bad("contact-contact_time-mm", ("contact.contact_time",),
            with_contact({**g, "contact_time": "0.5 mm"})))
    add(Bad("contact-restitution-without-time", ("contact.contact_time", "contact.restitution",
                                                 "contact: kn/restitution/contact_time"),
            with_contact({"law": "granular", "restitution": 0.7})))
    add(Bad("contact-kn-and-restitution", ("contact.kn", "contact.restitution",
                                           "contact: kn/restitution/contact_time"),
            with_contact({**g, "kn": 1000.0})))
    add(Bad("contact-mu-negative", ("contact.mu",), with_contact({**g, "mu": -0.5})))
    add(Bad("contact-mu-inf", ("contact.mu",), with_contact({**g, "mu": inf})))
    add(Bad("contact-epsilon-on-granular", ("contact.epsilon",), with_contact({**g, "epsilon": 1.0})))
    add(Bad("contact-model-normal-unknown", ("contact.model",),
            with_contact({**g, "model": {"normal": "quadratic"}})))
    add(Bad("contact-model-unknown-slot", ("contact.model",),
            with_contact({**g, "model": {"rolling": "sds"}})))
    add(Bad("contact-damping-relative", ("contact.damping",),
            with_contact({**g, "damping": "relative"})))
    add(Bad("contact-cohesion_force-metres", ("contact.cohesion_force",),
            with_contact({**g, "cohesion_force": "1 m"})))
    add(Bad("contact-restitution-without-viscous", ("contact.restitution",),
            with_contact({**g, "model": {"damping": "none"}})))
    add(Bad("contact-hertz-kn-stiffness-units", ("contact.kn",),
            with_contact({"law": "granular", "model": {"normal": "hertz"}, "kn": "1000 N/m"},
                         base3d)))
    add(Bad("contact-soft-mu-key", ("contact.mu",),
            mut(base_soft, lambda c: c["contact"].update(mu=0.3))))
    add(Bad("contact-soft-kinetic_on-half", ("contact.kinetic_on",),
            mut(base_soft, lambda c: c["contact"].update(kinetic_on="half"))))
    add(Bad("contact-soft-epsilon-missing", ("contact.epsilon",),
            mut(base_soft, lambda c: c["contact"].pop("epsilon"))))
    add(Bad("contact-pairs-types-1", ("contact.pairs[0].types",),
            with_contact({**g, "pairs": [{"types": [0], "mu": 0.2}]})))
    add(Bad("contact-pairs-types-negative", ("contact.pairs[0].types",),
            with_contact({**g, "pairs": [{"types": [0, -1], "mu": 0.2}]})))
    add(Bad("contact-pairs-duplicate", ("contact.pairs[1]", "contact.pairs"),
            with_contact({**g, "pairs": [{"types": [0, 1], "mu": 0.2},
                                         {"types": [1, 0], "mu": 0.3}]})))
    add(Bad("contact-pairs-soft-law-no-epsilon", ("contact.pairs[0]",),
            with_contact({**g, "pairs": [{"types": [0, 1], "law": "soft"}]})))
    add(Bad("contact-pairs-unknown-key", ("contact.pairs[0].friction",),
            with_contact({**g, "pairs": [{"types": [0, 1], "friction": 0.2}]})))
    add(Bad("contact-pairs-as-table", ("contact.pairs",),
            with_contact({**g, "pairs": {"types": [0, 1], "mu": 0.2}})))
    # ---- [[tethers]] ---------------------------------------------------------------------
    def teth(**kw):
        c = base2d()
        c["particles"].append({"fill": "list", "positions": [[2, 8], [5, 8]], "radius": 0.4,
                               "type": 1})
        c["tethers"] = [{"type": 1, "k": 100.0, **kw}]
        c["tethers"][0] = {k: v for k, v in c["tethers"][0].items() if v != "DEL"}
        return c
    add(Bad("tethers-k-negative", ("tethers[0].k",), teth(k=-1.0)))
    add(Bad("tethers-type-missing", ("tethers[0].type",), teth(type="DEL")))
    add(Bad("tethers-bond_cutoff-zero", ("tethers[0].bond_cutoff",), teth(bond_cutoff=0)))
    add(Bad("tethers-eta-string", ("tethers[0].eta",), teth(eta="lots")))
    add(Bad("tethers-k-too-stiff-for-dt", ("run.dt",),
            mut(lambda: teth(k=1e9), setp("run.dt", 1e-3))))
    # ---- [[insert]] / [[delete]] ---------------------------------------------------------
    add(Bad("insert-kind-sprinkle", ("insert[0].kind",), with_list("insert", [pour(kind="sprinkle")])))
    add(Bad("insert-pour-every-zero", ("insert[0].every",), with_list("insert", [pour(every=0)])))
    add(Bad("insert-pour-three-radii", ("insert[0].radius",),
            with_list("insert", [pour(radius=[0.2, 0.3, 0.4])])))
    add(Bad("insert-pour-region-outside-box", ("insert[0].region",),
            with_list("insert", [pour(region={"lo": [20, 20], "hi": [30, 30]})])))
    add(Bad("insert-pour-per_insertion-float", ("insert[0].per_insertion",),
            with_list("insert", [pour(per_insertion=2.0)])))
    add(Bad("insert-pour-density-length", ("insert[0].density",),
            with_list("insert", [pour(density="2 mm")])))
    add(Bad("insert-replenish-target-negative", ("insert[0].target",),
            with_list("insert", [repl(target=-5)])))
    add(Bad("insert-replenish-with-total", ("insert[0].total",),
            with_list("insert", [repl(total=5)])))
    add(Bad("delete-region-halfspace-zero-normal", ("delete[0].region",),
            with_list("delete", [dele(region={"shape": "halfspace", "point": [0, 0],
                                              "normal": [0, 0]})])))
    add(Bad("delete-every-negative", ("delete[0].every",), with_list("delete", [dele(every=-1)])))
    add(Bad("delete-outside-string", ("delete[0].outside",), with_list("delete", [dele(outside="true")])))
    add(Bad("delete-types-string", ("delete[0].types",), with_list("delete", [dele(types="0")])))
    # ---- scenarios -----------------------------------------------------------------------
    add(Bad("hopper-with-box-table", ("box",), mut(base_hopper, setp("box", {"lo": [0, 0], "hi": [1, 1]}))))
    add(Bad("hopper-orifice-zero", ("hopper.orifice_width",), hop("hopper.orifice_width", 0)))
    add(Bad("hopper-orifice-wider-than-width", ("hopper.orifice_width",),
            hop("hopper.orifice_width", 20.0)))
    add(Bad("hopper-n-negative", ("hopper.n",), hop("hopper.n", -1)))
    add(Bad("hopper-theta-100", ("hopper.theta_w",), hop("hopper.theta_w", 100.0)))
    add(Bad("hopper-lam-negative", ("hopper.lam",), hop("hopper.lam", -1.0)))
    add(Bad("hopper-misspelled-orifice", ("hopper.orifice",), hop("hopper.orifice", 4.0)))
    add(Bad("hopper3d-dim-2", ("dim",), mut(base_hopper, setp("scenario", "hopper3d"))))
    add(Bad("chute-with-particles", ("particles",), chute("particles", [{"fill": "random",
                                                                         "count": 5, "radius": 1}])))
    add(Bad("chute-replicate-zero", ("chute.replicate",), chute("chute.replicate", [0, 1])))
    add(Bad("chute-data_file-missing", ("chute.data_file", "missing.data"),
            chute("chute.data_file", "missing.data")))
    add(Bad("chute-angle-metres", ("chute.angle",), chute("chute.angle", "26 m")))
    add(Bad("chute-dim-2", ("dim",), chute("dim", 2)))
    return L


def run_bad(case: Bad, work: Path) -> tuple[str, str]:
    d = work / "bad" / case.cid
    d.mkdir(parents=True, exist_ok=True)
    for name, content in (case.files or {}).items():
        if name.endswith("/"):
            (d / name).mkdir(parents=True, exist_ok=True)
        else:
            (d / name).write_bytes(content if isinstance(content, bytes) else content.encode())
    if case.config_is_dir:
        cfg = d / "cfgdir"
        cfg.mkdir(exist_ok=True)
    elif case.no_config_file:
        cfg = d / "nonexistent.toml"
    else:
        cfg = d / "case.toml"
        if case.raw is not None:
            cfg.write_bytes(case.raw)
        else:
            write_toml(cfg, case.config)
    rundir = d / "rundir"
    r = gf(["run", cfg, "-o", rundir, "--progress", "none", *case.args], cwd=d)
    left = dir_listing(rundir) if rundir.exists() else {}
    reason = r.error_line or short(r.out.splitlines()[-1] if r.out.strip() else "(no output)")
    if r.timed_out:
        return "timeout", f"no answer within {CASE_TIMEOUT:.0f} s"
    if r.traceback:
        tb_last = [ln for ln in r.err.splitlines() if ln.strip()][-1:] or [""]
        return "traceback", short(tb_last[0])
    if r.rc == 0:
        return "accepted", short("exit 0; " + (r.out.strip().splitlines() or [""])[-1])
    if r.rc != 2:
        return "wrong-exit-code", short(f"exit {r.rc}; {reason}")
    err_lines = [ln for ln in r.err.splitlines() if ln.startswith("error:")]
    if not any(e in ln for ln in err_lines for e in case.expect):
        return "wrong-field", short(f"expected {' or '.join(repr(e) for e in case.expect)}; got: "
                                    f"{reason}")
    bad = stderr_clean(r)
    if bad is not None:
        return "bad-stderr", short(f"stderr line not error:/warning:: {bad!r}")
    if left:
        return "rundir-left", short(f"run directory holds {sorted(left)[:4]}; {reason}")
    return "refused", short(reason)


# --------------------------------------------------------------------------------------------
# 2. fault cases
# --------------------------------------------------------------------------------------------


class Ctx:
    def __init__(self, work: Path, rng: random.Random):
        self.work = work
        self.rng = rng
        self.ref: dict[str, Path] = {}


def thermo_nonfinite(path: Path) -> str | None:
    if not path.exists():
        return None
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    for i, row in enumerate(rows[1:], start=2):
        for v in row:
            try:
                x = float(v)
            except ValueError:
                return f"line {i}: non-numeric {v!r}"
            if not math.isfinite(x):
                return f"line {i}: {v}"
    return None


def read_thermo(path: Path) -> list[list[str]]:
    with open(path, newline="") as f:
        return list(csv.reader(f))


def frame_steps(path: Path) -> list[int]:
    with h5py.File(path, "r", swmr=True) as f:
        return [int(s) for s in f["particles/all/position/step"][:]]


def text_has_nonfinite(path: Path) -> str | None:
    for i, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
        low = line.lower()
        for tok in low.replace(",", " ").replace('"', " ").replace(">", " ").replace("<", " ").split():
            if tok in ("nan", "-nan", "inf", "-inf", "infinity", "-infinity"):
                return f"{path.name} line {i}: {line.strip()[:80]}"
    return None


def summary_status(rundir: Path) -> str | None:
    try:
        return json.loads((rundir / "summary.json").read_text()).get("status")
    except Exception:  # noqa: BLE001
        return None


def fail(msg: str) -> tuple[bool, str]:
    return False, short(msg)


def ok(msg: str) -> tuple[bool, str]:
    return True, short(msg)


def check_clean_error(r: Result, codes, names, what: str) -> tuple[bool, str] | None:
    """None when r is a clean refusal (exit code in codes, no traceback, error: lines only,
    and one of names in the error); else the failing verdict."""
    if r.timed_out:
        return fail(f"{what}: timed out")
    if r.traceback:
        return fail(f"{what}: Traceback: {[ln for ln in r.err.splitlines() if ln.strip()][-1]}")
    if r.rc not in codes:
        return fail(f"{what}: exit {r.rc} (expected {codes}); {r.error_line}")
    bad = stderr_clean(r)
    if bad is not None:
        return fail(f"{what}: stderr line not error:/warning:: {bad!r}")
    if names and not any(n in r.err for n in names):
        return fail(f"{what}: error does not name {names}: {r.error_line}")
    return None


# ---- unstable runs --------------------------------------------------------------------------


def unstable_case(ctx: Ctx, cid: str, cfg: dict, export_vtk=False) -> tuple[bool, str]:
    d = ctx.work / "fault" / cid
    d.mkdir(parents=True, exist_ok=True)
    write_toml(d / "cfg.toml", cfg)
    run = d / "run"
    r = gf(["run", d / "cfg.toml", "-o", run, "--progress", "none"], cwd=d)
    if r.timed_out:
        return fail("run timed out")
    if r.traceback:
        return fail(f"run: Traceback: {[ln for ln in r.err.splitlines() if ln.strip()][-1]}")
    if r.rc != 1:
        return fail(f"run exit {r.rc} (expected 1 unstable); {r.error_line or r.out[-100:]}")
    bad = stderr_clean(r)
    if bad is not None:
        return fail(f"run: stderr line not error:/warning:: {bad!r}")
    st = summary_status(run)
    if st != "unstable":
        return fail(f"summary.json status {st!r}, expected 'unstable'; {r.error_line}")
    nf = thermo_nonfinite(run / "thermo.csv")
    if nf:
        return fail(f"thermo.csv holds {nf}")
    if (run / "frames.h5").exists():
        ex = gf(["export", run, "--format", "dump", "-o", d / "out.dump"], cwd=d)
        bad_ex = check_clean_error(ex, (0,), None, "export dump")
        if bad_ex:
            return bad_ex
        if (d / "out.dump").exists():
            nf = text_has_nonfinite(d / "out.dump")
            if nf:
                return fail(f"export dump holds {nf}")
        if export_vtk:
            ex = gf(["export", run, "--format", "vtk", "-o", d / "vtk"], cwd=d)
            bad_ex = check_clean_error(ex, (0,), None, "export vtk")
            if bad_ex:
                return bad_ex
            for f in sorted((d / "vtk").glob("*.vt*")):
                if 'format="ascii"' in f.read_text(errors="replace"):
                    nf = text_has_nonfinite(f)
                    if nf:
                        return fail(f"export vtk holds {nf}")
    info = gf(["info", run], cwd=d)
    bad_info = check_clean_error(info, (0,), None, "info")
    if bad_info:
        return bad_info
    if "unstable" not in info.out:
        return fail("grainflow info does not say unstable")
    if "grainflow resume" in info.out:
        return fail("grainflow info suggests 'grainflow resume' for an unstable run")
    res = gf(["resume", run], cwd=d)
    bad_res = check_clean_error(res, (1, 2), ("unstable",), "resume of an unstable run")
    if bad_res:
        return bad_res
    return ok(r.error_line)


def cfg_periodic_blowup(dim=2, integrator="verlet", contacts=False, compression="gzip") -> dict:
    c = {
        "dim": dim,
        "run": {"steps": 400, "dt": 0.04, "allow_unsafe_dt": True, "integrator": integrator},
        "output": {"thermo_every": 1, "frames_every": 1, "checkpoint_every": 1,
                   "contacts": contacts, "compression": compression, "snapshot": False},
        "box": {"lo": [0] * dim, "hi": [6] * dim, "periodic": [True] * dim},
        # two slabs of touching grains driven into each other (closer spacing is refused)
        "particles": [{"fill": "lattice", "spacing": 0.9, "radius": 0.4,
                       "region": {"lo": [0] * dim, "hi": [6, 2.9, 6][:dim]},
                       "velocity": [0.0, 1.0, 0.0][:dim]},
                      {"fill": "lattice", "spacing": 0.9, "radius": 0.4,
                       "region": {"lo": [0, 3.1, 0][:dim], "hi": [6] * dim},
                       "velocity": [0.0, -1.0, 0.0][:dim]}],
        "contact": {"law": "granular", "restitution": 0.95, "contact_time": 0.05},
    }
    return c


def cfg_tunnel() -> dict:
    c = base2d()
    c["gravity"] = [0, -200]
    c["run"] = {"steps": 2000, "dt": 0.03, "allow_unsafe_dt": True}
    c["output"].update(thermo_every=1, frames_every=5)
    c["particles"] = [{"fill": "lattice", "region": {"lo": [0, 1], "hi": [10, 5]}, "radius": 0.4,
                       "velocity": [0, -5]}]
    c["box"]["lo"] = [0, -100]
    return c


def cfg_speed(v) -> dict:
    c = base2d()
    c["particles"] = [{"fill": "list", "positions": [[2, 2], [5, 5]], "radius": 0.4,
                       "velocities": [[v, 0], [0, 0]]}]
    c["output"].update(thermo_every=1, frames_every=1)
    return c


def cfg_thrown_out() -> dict:
    c = base2d()
    c.pop("gravity")
    c.pop("walls")
    c["run"] = {"steps": 1000}
    c["output"].update(thermo_every=10, frames_every=10, checkpoint_every=50)
    c["particles"] = [{"fill": "random", "count": 20, "radius": 0.4,
                       "region": {"lo": [1, 1], "hi": [9, 9]}, "velocity": [0, 150]}]
    return c


def cfg_overlap() -> dict:
    c = base2d()
    c["particles"] = [{"fill": "list", "positions": [[5, 2], [5.1, 2]], "radius": 0.4}]
    c["output"].update(thermo_every=1, frames_every=1)
    return c


def cfg_soft_unsafe() -> dict:
    c = base_soft()
    c["contact"]["epsilon"] = 1e7
    c["run"] = {"steps": 500, "dt": 0.01, "allow_unsafe_dt": True}
    c["particles"][0]["spacing"] = 0.8  # touching (closer is refused as overlapping)
    c["output"].update(thermo_every=1, frames_every=1, contacts=True)
    return c


def cfg_tether_unsafe() -> dict:
    c = base2d()
    c["gravity"] = [0, -10]
    c["particles"].append({"fill": "list", "positions": [[2, 8], [2.85, 8], [3.7, 8]],
                           "radius": 0.4, "type": 1, "velocity": [0, -3]})
    c["tethers"] = [{"type": 1, "k": 1e6, "eta": 0, "bond_cutoff": 1.0}]
    c["run"] = {"steps": 800, "dt": 0.005, "allow_unsafe_dt": True}
    c["output"].update(thermo_every=1, frames_every=1, contacts=True)
    return c


def cfg_pour_fast() -> dict:
    c = base2d()
    c["insert"] = [pour(velocity=[0, -1e5], every=20, per_insertion=3, total=9)]
    c["output"].update(thermo_every=1, frames_every=1)
    return c


def cfg_gravity_huge() -> dict:
    c = base3d()
    c["gravity"] = [0, 0, -1e9]
    c["output"].update(thermo_every=1, frames_every=1, contacts=True)
    return c


def cfg_hopper_unsafe() -> dict:
    c = base_hopper()
    c["run"].update(dt=0.5, allow_unsafe_dt=True, steps=300)
    c["output"].update(thermo_every=1, frames_every=1)
    return c


# ---- interrupted runs -----------------------------------------------------------------------


def cfg_long() -> dict:
    """~4-8 s single-threaded: interrupted by signals, then resumed."""
    c = base2d()
    c["run"] = {"steps": 15000, "seed": 3}
    c["output"] = {"thermo_every": 20, "frames_every": 100, "checkpoint_every": 250,
                   "contacts": True, "snapshot": False, "progress_interval": 1}
    c["box"] = {"lo": [0, 0], "hi": [12, 14]}
    c["particles"] = [{"fill": "random", "count": 110, "radius": [0.3, 0.42],
                       "region": {"lo": [0, 0], "hi": [12, 12]}, "velocity": [0.5, 0]}]
    c["walls"] = [{"shape": "segment", "p0": [0, 0], "p1": [12, 0]},
                  {"shape": "segment", "p0": [0, 0], "p1": [0, 14]},
                  {"shape": "segment", "p0": [12, 0], "p1": [12, 14]}]
    return c


def reference(ctx: Ctx) -> Path:
    if "long" not in ctx.ref:
        d = ctx.work / "fault" / "_reference"
        d.mkdir(parents=True, exist_ok=True)
        write_toml(d / "long.toml", cfg_long())
        t0 = time.monotonic()
        r = gf(["run", d / "long.toml", "-o", d / "run", "--progress", "none"], cwd=d,
               timeout=240)
        ctx.ref_time = time.monotonic() - t0
        if r.rc != 0:
            raise RuntimeError(f"the reference run failed: exit {r.rc}: {r.err[-500:]}")
        ctx.ref["long"] = d / "run"
    return ctx.ref["long"]


def wait_for(path: Path, timeout: float, p: subprocess.Popen | None = None) -> bool:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if path.exists():
            return True
        if p is not None and p.poll() is not None:
            return path.exists()
        time.sleep(0.05)
    return False


def compare_with_reference(ctx: Ctx, run: Path) -> str | None:
    ref = reference(ctx)
    st = summary_status(run)
    if st != "finished":
        return f"summary.json status {st!r} after resume"
    a, b = read_thermo(run / "thermo.csv"), read_thermo(ref / "thermo.csv")
    if len(a) != len(b):
        steps_a = [r[0] for r in a[1:]]
        dup = len(steps_a) - len(set(steps_a))
        return f"thermo.csv has {len(a) - 1} rows, the uninterrupted run {len(b) - 1} ({dup} duplicated steps)"
    for ra, rb in zip(a, b):
        if ra[:-1] != rb[:-1]:
            return f"thermo.csv differs from the uninterrupted run at step {ra[0]}: {ra[:5]} vs {rb[:5]}"
    nf = thermo_nonfinite(run / "thermo.csv")
    if nf:
        return f"thermo.csv holds {nf}"
    try:
        sa, sb = frame_steps(run / "frames.h5"), frame_steps(ref / "frames.h5")
    except Exception as e:  # noqa: BLE001
        return f"frames.h5 unreadable after resume: {short(str(e), 80)}"
    if sa != sb:
        return f"frames.h5 steps {sa[:3]}...{sa[-3:]} ({len(sa)}) differ from the uninterrupted run's ({len(sb)})"
    with h5py.File(run / "frames.h5", "r", swmr=True) as fa, \
            h5py.File(ref / "frames.h5", "r", swmr=True) as fb:
        pa, pb = fa["particles/all/position/value"][-1], fb["particles/all/position/value"][-1]
        if not np.array_equal(pa, pb, equal_nan=True):
            return "last frame's positions differ from the uninterrupted run"
    return None


def signal_case(ctx: Ctx, cid: str, signals: list[int], wait_ckpt=True,
                during_resume: int | None = None) -> tuple[bool, str]:
    """Start a run, send the signals at a random moment, then resume (signalling the resume
    too if during_resume), and compare with the uninterrupted reference run."""
    reference(ctx)
    d = ctx.work / "fault" / cid
    d.mkdir(parents=True, exist_ok=True)
    write_toml(d / "long.toml", cfg_long())
    run = d / "run"
    p = start(["run", d / "long.toml", "-o", run, "--progress", "plain"], cwd=d, log_prefix=d / "run")
    if wait_ckpt:
        wait_for(run / "checkpoint.npz", 60, p)
        delay = ctx.rng.uniform(0.2, max(0.4, 0.7 * ctx.ref_time - 1.0))
    else:
        delay = ctx.rng.uniform(0.05, 1.0)
    time.sleep(delay)
    note = f"{'+'.join(signal.Signals(s).name for s in signals)} after {delay:.2f}s"
    if p.poll() is not None:
        note += " (the run had already ended)"
    for s in signals:
        if p.poll() is None:
            p.send_signal(s)
            time.sleep(0.05)
    r = finish(p, d / "run")
    expected_rc = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGKILL: -9}[signals[0]]
    # a later signal arriving while the run shuts down may end it by that signal: the shell
    # shows 128 + signum either way, so -signum of a later signal is accepted too
    accepted_rc = {expected_rc, 0} | {-int(s) for s in signals[1:]} | {128 + int(s) for s in signals[1:]}
    if r.traceback:
        return fail(f"{note}: run printed a Traceback: {[l for l in r.err.splitlines() if l.strip()][-1]}")
    if r.rc not in accepted_rc:
        return fail(f"{note}: run exit {r.rc}, expected {expected_rc}; {r.error_line}")
    if signals[0] != signal.SIGKILL:
        bad = stderr_clean(r)
        if bad is not None:
            return fail(f"{note}: stderr line not error:/warning:: {bad!r}")
        if r.rc != 0 and summary_status(run) not in ("interrupted", None):
            return fail(f"{note}: summary.json says {summary_status(run)!r} after the signal")
    # resume
    if not (run / "checkpoint.npz").exists():
        # stopped before the first checkpoint: resume must refuse cleanly, run --overwrite works
        res = gf(["resume", run], cwd=d)
        bad = check_clean_error(res, (2,), ("checkpoint", str(run.name)), "resume without checkpoint")
        if bad:
            return bad[0], f"{note}: {bad[1]}"
        rr = gf(["run", d / "long.toml", "-o", run, "--overwrite", "--progress", "none"], cwd=d,
                timeout=240)
        if rr.rc != 0 or rr.traceback:
            return fail(f"{note}: no checkpoint; run --overwrite exit {rr.rc}: {rr.error_line}")
    elif r.rc != 0:
        if during_resume is not None:
            p2 = start(["resume", run], cwd=d, log_prefix=d / "resume1")
            time.sleep(ctx.rng.uniform(0.8, max(1.0, 0.4 * ctx.ref_time)))
            if p2.poll() is None:
                p2.send_signal(during_resume)
            r2 = finish(p2, d / "resume1")
            if r2.traceback:
                return fail(f"{note}; {signal.Signals(during_resume).name} during resume: Traceback")
            exp2 = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGKILL: -9}[during_resume]
            if r2.rc not in (exp2, 0):
                return fail(f"{note}; signal during resume: exit {r2.rc}; {r2.error_line}")
            note += f"; {signal.Signals(during_resume).name} during resume (exit {r2.rc})"
            if r2.rc == 0:
                diff = compare_with_reference(ctx, run)
                return (False, f"{note}: {diff}") if diff else ok(f"{note}: resumed, identical")
        res = gf(["resume", run], cwd=d, timeout=240)
        if res.rc != 0 or res.traceback:
            return fail(f"{note}: resume exit {res.rc}: {res.error_line}")
        bad = stderr_clean(res)
        if bad is not None:
            return fail(f"{note}: resume stderr line not error:/warning:: {bad!r}")
    diff = compare_with_reference(ctx, run)
    if diff:
        return fail(f"{note} (run exit {r.rc}): {diff}")
    return ok(f"{note}: run exit {r.rc}, resumed, bitwise as the uninterrupted run")


# ---- damaged files -------------------------------------------------------------------------


def interrupted_template(ctx: Ctx) -> Path:
    """A run killed (SIGKILL) around the middle, with a checkpoint after step 0."""
    if "killed" in ctx.ref:
        return ctx.ref["killed"]
    ref = reference(ctx)
    d = ctx.work / "fault" / "_killed"
    d.mkdir(parents=True, exist_ok=True)
    write_toml(d / "long.toml", cfg_long())
    run = d / "run"
    p = start(["run", d / "long.toml", "-o", run, "--progress", "none"], cwd=d, log_prefix=d / "run")
    # wait until thermo.csv reaches ~ 40 % of the run, then kill
    n_rows_ref = len(read_thermo(ref / "thermo.csv"))
    t0 = time.monotonic()
    while p.poll() is None and time.monotonic() - t0 < 120:
        try:
            if len((run / "thermo.csv").read_text().splitlines()) > 0.45 * n_rows_ref:
                break
        except OSError:
            pass
        time.sleep(0.05)
    p.kill()
    finish(p, d / "run")
    ctx.ref["killed"] = run
    return run


def copy_template(ctx: Ctx, cid: str) -> tuple[Path, Path]:
    src = interrupted_template(ctx)
    d = ctx.work / "fault" / cid
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    shutil.copy(src.parent / "long.toml", d / "long.toml")
    run = d / "run"
    shutil.copytree(src, run)
    return d, run


def damaged_checkpoint_case(ctx: Ctx, cid: str, damage) -> tuple[bool, str]:
    d, run = copy_template(ctx, cid)
    damage(run / "checkpoint.npz")
    res = gf(["resume", run], cwd=d)
    bad = check_clean_error(res, (2,), ("checkpoint.npz",), "resume")
    if bad:
        return bad
    if "--overwrite" not in res.err:
        return fail(f"resume error gives no way out (--overwrite): {res.error_line}")
    info = gf(["info", run], cwd=d)
    bad = check_clean_error(info, (0,), None, "info")
    if bad:
        return bad
    if "damaged" not in info.out and "checkpoint.npz" not in info.out:
        return fail("grainflow info does not report the damaged checkpoint")
    rr = gf(["run", d / "long.toml", "-o", run, "--overwrite", "--progress", "none"], cwd=d,
            timeout=240)
    if rr.rc != 0 or rr.traceback:
        return fail(f"run --overwrite after a damaged checkpoint: exit {rr.rc}: {rr.error_line}")
    return ok(res.error_line)


def truncate_to(frac):
    def f(p: Path):
        data = p.read_bytes()
        p.write_bytes(data[: int(len(data) * frac)])
    return f


def random_bytes(rng: random.Random, n=None):
    def f(p: Path):
        size = n if n is not None else max(64, p.stat().st_size)
        p.write_bytes(bytes(rng.randrange(256) for _ in range(size)))
    return f


def foreign_npz(p: Path):
    with open(p, "wb") as f:
        np.savez(f, a=np.arange(10.0), b=np.ones((3, 3)))


def frames_damage_case(ctx: Ctx, cid: str, damage) -> tuple[bool, str]:
    d, run = copy_template(ctx, cid)
    damage(run / "frames.h5")
    res = gf(["resume", run], cwd=d, timeout=240)
    if res.rc != 0 or res.traceback:
        bad = check_clean_error(res, (1, 2), ("frames.h5",), "resume")
        return bad if bad else fail(f"resume did not recover (exit {res.rc}): {res.error_line}")
    bad = stderr_clean(res)
    if bad is not None:
        return fail(f"resume stderr line not error:/warning:: {bad!r}")
    if summary_status(run) != "finished":
        return fail(f"summary.json status {summary_status(run)!r} after resume")
    try:
        steps = frame_steps(run / "frames.h5")
    except Exception as e:  # noqa: BLE001
        return fail(f"frames.h5 unreadable after resume: {short(str(e), 90)}")
    if any(b <= a for a, b in zip(steps, steps[1:])):
        return fail(f"frame steps not increasing after resume: {steps}")
    if not steps or steps[-1] != cfg_long()["run"]["steps"]:
        return fail(f"last frame step {steps[-1:]} is not the final step")
    kept = sorted(p.name for p in run.glob("frames.h5.damaged*"))
    ex = gf(["export", run, "--format", "dump", "-o", d / "out.dump"], cwd=d)
    if ex.rc != 0 or ex.traceback:
        return fail(f"export after repaired resume: exit {ex.rc}: {ex.error_line}")
    rows = read_thermo(run / "thermo.csv")
    tsteps = [int(r[0]) for r in rows[1:]]
    if tsteps != sorted(set(tsteps)) or thermo_nonfinite(run / "thermo.csv"):
        return fail("thermo.csv after the repaired resume has duplicated/unordered or non-finite rows")
    return ok(f"resumed; {len(steps)} frames; original kept as {kept or 'nothing'}")


def thermo_damage_case(ctx: Ctx, cid: str, damage) -> tuple[bool, str]:
    d, run = copy_template(ctx, cid)
    damage(run / "thermo.csv")
    res = gf(["resume", run], cwd=d, timeout=240)
    if res.rc == 0 and not res.traceback:
        bad = stderr_clean(res)
        if bad is not None:
            return fail(f"resume stderr line not error:/warning:: {bad!r}")
        nf = thermo_nonfinite(run / "thermo.csv")
        if nf:
            return fail(f"resumed, but thermo.csv holds {nf}")
        rows = read_thermo(run / "thermo.csv")
        if not rows or rows[0][:3] != ["step", "time", "N"]:
            return fail(f"resumed, but thermo.csv has no header: {rows[:1]}")
        steps = [int(r[0]) for r in rows[1:]]
        if steps != sorted(set(steps)):
            return fail("resumed, but thermo.csv steps are duplicated or out of order")
        return ok(f"resumed (exit 0); thermo.csv rows {len(rows) - 1}; {res.error_line or ''}")
    bad = check_clean_error(res, (1, 2), ("thermo.csv",), "resume")
    return bad if bad else ok(res.error_line)


def manifest_case(ctx: Ctx, cid: str, damage) -> tuple[bool, str]:
    d, run = copy_template(ctx, cid)
    (run / "notes.txt").write_text("my precious notes\n")
    (run / "analysis").mkdir()
    (run / "analysis" / "fit.py").write_text("print(1)\n")
    damage(run / ".grainflow-manifest")
    before_user = {k: v for k, v in dir_listing(run).items() if k in ("notes.txt", "analysis/fit.py")}
    rr = gf(["run", d / "long.toml", "-o", run, "--overwrite", "--progress", "none"], cwd=d, timeout=240)
    after = dir_listing(run)
    lost = [k for k, v in before_user.items() if after.get(k) != v]
    if lost:
        return fail(f"user files lost or changed by --overwrite: {lost}")
    if rr.traceback:
        return fail(f"run --overwrite: Traceback: {[l for l in rr.err.splitlines() if l.strip()][-1]}")
    if rr.rc == 0:
        return ok("overwrote the run; user files kept")
    bad = check_clean_error(rr, (2,), (".grainflow-manifest", "manifest"), "run --overwrite")
    return bad if bad else ok(rr.error_line)


# ---- run directory safety ------------------------------------------------------------------


def small_cfg(d: Path) -> Path:
    return write_toml(d / "small.toml", base2d())


def rundir_overwrite_userfiles(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "rundir-overwrite-userfiles"
    d.mkdir(parents=True, exist_ok=True)
    cfg = small_cfg(d)
    run = d / "run"
    r = gf(["run", cfg, "-o", run, "--progress", "none"], cwd=d)
    if r.rc != 0:
        return fail(f"first run exit {r.rc}: {r.error_line}")
    (run / "notes.md").write_text("lab notebook\n")
    (run / "plots").mkdir()
    (run / "plots" / "fig.png").write_bytes(b"\x89PNG fake")
    (run / "thermo_old.csv").write_text("mine\n")
    user = {k: v for k, v in dir_listing(run).items() if k in ("notes.md", "plots/fig.png", "thermo_old.csv")}
    r2 = gf(["run", cfg, "-o", run, "--overwrite", "--progress", "none"], cwd=d)
    after = dir_listing(run)
    lost = [k for k, v in user.items() if after.get(k) != v]
    if lost:
        return fail(f"--overwrite removed/changed user files {lost}")
    if r2.rc != 0 or r2.traceback:
        return fail(f"--overwrite exit {r2.rc}: {r2.error_line}")
    return ok("overwrote; user files kept")


def rundir_handwritten_config(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "rundir-handwritten-config"
    d.mkdir(parents=True, exist_ok=True)
    cfg = small_cfg(d)
    run = d / "run"
    run.mkdir(exist_ok=True)
    (run / "config.toml").write_text("# my hand-written config, keep!\n" + cfg.read_text())
    before = dir_listing(run)
    r = gf(["run", cfg, "-o", run, "--overwrite", "--progress", "none"], cwd=d)
    after = dir_listing(run)
    if after.get("config.toml") != before["config.toml"]:
        return fail(f"hand-written config.toml was replaced (exit {r.rc})")
    bad = check_clean_error(r, (2,), ("config.toml",), "run --overwrite")
    return bad if bad else ok(r.error_line)


def rundir_config_inside(ctx: Ctx) -> tuple[bool, str]:
    """The user runs a config that lives in the run directory itself, with --overwrite."""
    d = ctx.work / "fault" / "rundir-config-inside"
    d.mkdir(parents=True, exist_ok=True)
    run = d / "run"
    run.mkdir(exist_ok=True)
    cfg = write_toml(run / "my_setup.toml", base2d())
    before = cfg.read_bytes()
    r = gf(["run", cfg, "-o", run, "--progress", "none"], cwd=d)
    if cfg.read_bytes() != before:
        return fail("the config file inside the run directory was changed")
    if r.rc == 0:
        r2 = gf(["run", cfg, "-o", run, "--overwrite", "--progress", "none"], cwd=d)
        if not cfg.exists() or cfg.read_bytes() != before:
            return fail("--overwrite removed the config file it was reading")
        if r2.rc != 0 or r2.traceback:
            return fail(f"second run --overwrite exit {r2.rc}: {r2.error_line}")
        return ok("ran next to its config, twice; config kept")
    bad = check_clean_error(r, (2,), (str(run.name),), "run")
    if bad:
        return bad
    r2 = gf(["run", cfg, "-o", run, "--overwrite", "--progress", "none"], cwd=d)
    if not cfg.exists() or cfg.read_bytes() != before:
        return fail("--overwrite removed the config file it was reading")
    if r2.rc != 0 or r2.traceback:
        return fail(f"run --overwrite next to its config: exit {r2.rc}: {r2.error_line}")
    return ok(f"refused without --overwrite ({r.error_line}); ran with it, config kept")


def rundir_export_user_dump(ctx: Ctx, fmt="dump") -> tuple[bool, str]:
    d = ctx.work / "fault" / f"rundir-export-user-{fmt}"
    d.mkdir(parents=True, exist_ok=True)
    cfg = small_cfg(d)
    run = d / "run"
    r = gf(["run", cfg, "-o", run, "--progress", "none"], cwd=d)
    if r.rc != 0:
        return fail(f"run exit {r.rc}: {r.error_line}")
    if fmt == "dump":
        (run / "frames.dump").write_text("ITEM: TIMESTEP\n0\n# my own dump from LAMMPS\n")
    else:
        (run / "vtk").mkdir()
        (run / "vtk" / "frame.pvd").write_text("<VTKFile>mine</VTKFile>\n")
    before = dir_listing(run)
    ex = gf(["export", run, "--format", fmt], cwd=d)
    after = dir_listing(run)
    changed = [k for k, v in before.items() if after.get(k) != v]
    if changed:
        return fail(f"export changed user files {changed} (exit {ex.rc})")
    bad = check_clean_error(ex, (2,), ("frames.dump", "vtk"), f"export {fmt}")
    return bad if bad else ok(ex.error_line)


def rundir_export_twice(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "rundir-export-twice"
    d.mkdir(parents=True, exist_ok=True)
    cfg = small_cfg(d)
    run = d / "run"
    r = gf(["run", cfg, "-o", run, "--progress", "none"], cwd=d)
    if r.rc != 0:
        return fail(f"run exit {r.rc}: {r.error_line}")
    for i in range(2):
        ex = gf(["export", run, "--format", "dump"], cwd=d)
        if ex.rc != 0 or ex.traceback:
            return fail(f"export #{i + 1} of grainflow's own frames.dump: exit {ex.rc}: {ex.error_line}")
    nf = text_has_nonfinite(run / "frames.dump")
    if nf:
        return fail(nf)
    return ok("exported twice (its own frames.dump replaced)")


def rundir_nonempty_no_overwrite(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "rundir-nonempty"
    d.mkdir(parents=True, exist_ok=True)
    cfg = small_cfg(d)
    run = d / "run"
    run.mkdir(exist_ok=True)
    (run / "data.csv").write_text("1,2,3\n")
    before = dir_listing(run)
    r = gf(["run", cfg, "-o", run, "--progress", "none"], cwd=d)
    if dir_listing(run) != before:
        return fail(f"the non-empty directory was changed (exit {r.rc})")
    bad = check_clean_error(r, (2,), ("run", "--overwrite"), "run")
    return bad if bad else ok(r.error_line)


def rundir_is_file(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "rundir-is-file"
    d.mkdir(parents=True, exist_ok=True)
    cfg = small_cfg(d)
    target = d / "results.txt"
    target.write_text("precious\n")
    r = gf(["run", cfg, "-o", target, "--overwrite", "--progress", "none"], cwd=d)
    if not target.is_file() or target.read_text() != "precious\n":
        return fail(f"the file given as run directory was changed (exit {r.rc})")
    bad = check_clean_error(r, (2,), ("results.txt",), "run -o FILE")
    return bad if bad else ok(r.error_line)


def rundir_foreign_thermo(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "rundir-foreign-thermo"
    d.mkdir(parents=True, exist_ok=True)
    cfg = small_cfg(d)
    run = d / "run"
    run.mkdir(exist_ok=True)
    (run / "thermo.csv").write_text("Step Temp E_pair\n0 1.0 -3.2\n")
    before = dir_listing(run)
    r = gf(["run", cfg, "-o", run, "--overwrite", "--progress", "none"], cwd=d)
    if dir_listing(run).get("thermo.csv") != before["thermo.csv"]:
        return fail(f"another program's thermo.csv was replaced (exit {r.rc})")
    bad = check_clean_error(r, (2,), ("thermo.csv",), "run --overwrite")
    return bad if bad else ok(r.error_line)


def rundir_edited_config_overwrite(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "rundir-edited-config"
    d.mkdir(parents=True, exist_ok=True)
    cfg = small_cfg(d)
    run = d / "run"
    r = gf(["run", cfg, "-o", run, "--progress", "none"], cwd=d)
    if r.rc != 0:
        return fail(f"run exit {r.rc}: {r.error_line}")
    with open(run / "config.toml", "a") as f:
        f.write("\n# edited by hand: tried mu = 0.9\n")
    before = dir_listing(run)
    r2 = gf(["run", cfg, "-o", run, "--overwrite", "--progress", "none"], cwd=d)
    after = dir_listing(run)
    if after != before:
        return fail(f"--overwrite changed the directory although config.toml was edited (exit {r2.rc})")
    bad = check_clean_error(r2, (2,), ("config.toml",), "run --overwrite")
    return bad if bad else ok(r2.error_line)


def summary_garbage_case(ctx: Ctx) -> tuple[bool, str]:
    d, run = copy_template(ctx, "damaged-summary-json")
    (run / "summary.json").write_bytes(b"{\"status\": \"fini\x00\xff")
    info = gf(["info", run], cwd=d)
    if info.traceback or info.timed_out:
        return fail(f"info: Traceback/timeout: {info.error_line}")
    if info.rc not in (0, 2):
        return fail(f"info exit {info.rc}: {info.error_line}")
    bad = stderr_clean(info)
    if bad is not None:
        return fail(f"info stderr line not error:/warning:: {bad!r}")
    res = gf(["resume", run], cwd=d, timeout=240)
    if res.rc == 0 and not res.traceback:
        return ok("info and resume coped with a garbage summary.json")
    bad = check_clean_error(res, (2,), ("summary.json",), "resume")
    return bad if bad else ok(res.error_line)


def info_missing_checkpoint_case(ctx: Ctx) -> tuple[bool, str]:
    d, run = copy_template(ctx, "damaged-checkpoint-deleted")
    (run / "checkpoint.npz").unlink()
    res = gf(["resume", run], cwd=d)
    bad = check_clean_error(res, (2,), ("checkpoint",), "resume")
    if bad:
        return bad
    info = gf(["info", run], cwd=d)
    bad = check_clean_error(info, (0, 2), None, "info")
    return bad if bad else ok(res.error_line)


def resume_not_a_rundir(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "resume-not-a-rundir"
    d.mkdir(parents=True, exist_ok=True)
    (d / "photos").mkdir(exist_ok=True)
    (d / "photos" / "a.jpg").write_bytes(b"\xff\xd8jpeg")
    before = dir_listing(d / "photos")
    res = gf(["resume", d / "photos"], cwd=d)
    if dir_listing(d / "photos") != before:
        return fail("resume changed a directory that is not a run")
    bad = check_clean_error(res, (2,), ("photos",), "resume")
    if bad:
        return bad
    info = gf(["info", d / "photos"], cwd=d)
    bad = check_clean_error(info, (2,), ("photos",), "info")
    return bad if bad else ok(res.error_line)


# ---- sweeps --------------------------------------------------------------------------------


def sweep_base(d: Path) -> Path:
    c = base2d()
    c["run"]["steps"] = 100
    c["output"].update(frames_every=0)
    return write_toml(d / "base.toml", c)


def sweep_invalid_point(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "sweep-invalid-point"
    d.mkdir(parents=True, exist_ok=True)
    sweep_base(d)
    write_toml(d / "sw.toml", {"name": "bad", "base": "base.toml",
                               "overrides": {"contact.mu": [0.3, -0.2],
                                             "contact.restitution": [0.5, 1.5]}})
    r = gf(["sweep", d / "sw.toml", "-o", d / "out", "-n", "1", "--progress", "plain"], cwd=d, timeout=120)
    bad = check_clean_error_sweep(r, (2,), ("contact.mu", "contact.restitution"), "sweep")
    if bad:
        return bad
    runs = list((d / "out" / "runs").glob("*")) if (d / "out" / "runs").exists() else []
    if runs:
        return fail(f"points were run although the sweep is invalid: {len(runs)} run dirs")
    return ok(r.error_line)


def check_clean_error_sweep(r: Result, codes, names, what) -> tuple[bool, str] | None:
    """Like check_clean_error, but indented continuation lines of an error are allowed."""
    if r.timed_out:
        return fail(f"{what}: timed out")
    if r.traceback:
        return fail(f"{what}: Traceback: {[ln for ln in r.err.splitlines() if ln.strip()][-1]}")
    if r.rc not in codes:
        return fail(f"{what}: exit {r.rc} (expected {codes}); {r.error_line}")
    for line in r.err.splitlines():
        if line.strip() and not (line.startswith(("error: ", "warning: ")) or line.startswith("  ")):
            return fail(f"{what}: stderr line not error:/warning:: {line.strip()!r}")
    if names and not any(n in r.err for n in names):
        return fail(f"{what}: error does not name {names}: {r.error_line}")
    return None


def sweep_done(ctx: Ctx, cid: str) -> tuple[Path, Path, Result]:
    d = ctx.work / "fault" / cid
    d.mkdir(parents=True, exist_ok=True)
    sweep_base(d)
    write_toml(d / "sw.toml", {"name": "ok", "base": "base.toml",
                               "overrides": {"contact.mu": [0.3, 0.5]}})
    r = gf(["sweep", d / "sw.toml", "-o", d / "out", "-n", "2", "--progress", "plain"], cwd=d, timeout=180)
    return d, d / "out", r


def sweep_garbage_catalog(ctx: Ctx, cid: str, damage) -> tuple[bool, str]:
    d, out, r = sweep_done(ctx, cid)
    if r.rc != 0:
        return fail(f"the initial sweep failed: exit {r.rc}: {r.error_line}")
    damage(out / "catalog.sqlite")
    runs_before = dir_listing(out / "runs")
    r2 = gf(["sweep", d / "sw.toml", "-o", out, "-n", "1", "--progress", "plain"], cwd=d, timeout=180)
    bad = check_clean_error_sweep(r2, (2,), ("catalog.sqlite",), "sweep on a damaged catalog")
    if bad:
        return bad
    st = gf(["sweep-status", out], cwd=d)
    bad = check_clean_error_sweep(st, (2,), ("catalog.sqlite",), "sweep-status on a damaged catalog")
    if bad:
        return bad
    if dir_listing(out / "runs") != runs_before:
        return fail("the run directories changed after the damaged-catalog refusal")
    r3 = gf(["sweep", d / "sw.toml", "-o", out, "-n", "1", "--rebuild-catalog", "--progress", "plain"],
            cwd=d, timeout=180)
    if r3.rc != 0 or r3.traceback:
        return fail(f"--rebuild-catalog: exit {r3.rc}: {r3.error_line}")
    return ok(r2.error_line)


def sweep_relative_data(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "sweep-relative-data-path"
    (d / "proj" / "data").mkdir(parents=True, exist_ok=True)
    (d / "elsewhere").mkdir(exist_ok=True)
    (d / "proj" / "data" / "grains.data").write_text(lammps_text(GOOD_ATOMS))
    c = lammps_cfg("data/grains.data")
    c["run"]["steps"] = 50
    write_toml(d / "proj" / "base.toml", c)
    write_toml(d / "proj" / "sw.toml", {"name": "rel", "base": "base.toml",
                                        "overrides": {"contact.mu": [0.2, 0.4]}})
    r = gf(["sweep", "../proj/sw.toml", "-o", "../out", "-n", "2", "--progress", "plain"],
           cwd=d / "elsewhere", timeout=180)
    if r.rc != 0 or r.traceback:
        return fail(f"sweep from another directory: exit {r.rc}: {r.error_line}")
    st = gf(["sweep-status", d / "out", "--csv", "-"], cwd=d)
    if st.rc != 0 or st.out.count("done") < 2:
        return fail(f"sweep-status does not show 2 done points (exit {st.rc}): {short(st.out, 100)}")
    return ok("2 points done from another working directory")


def sweep_unstable_point(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "sweep-unstable-point"
    d.mkdir(parents=True, exist_ok=True)
    c = base2d()
    c["run"]["steps"] = 100
    write_toml(d / "base.toml", c)
    write_toml(d / "sw.toml", {"name": "boom", "base": "base.toml",
                               "overrides": {"gravity": [[0, -1], [0, -1e12]]}})
    r = gf(["sweep", d / "sw.toml", "-o", d / "out", "-n", "2", "--progress", "plain"], cwd=d, timeout=180)
    bad = check_clean_error_sweep(r, (1,), None, "sweep with an unstable point")
    if bad:
        return bad
    if "unstable" not in r.err:
        where = "stdout only" if "unstable" in r.out else "neither stream"
        return fail(f"exit 1, but no 'error:' line on stderr names the failed point (reported on {where})")
    r2 = gf(["sweep", d / "sw.toml", "-o", d / "out", "-n", "1", "--progress", "plain"], cwd=d, timeout=180)
    bad = check_clean_error_sweep(r2, (1,), ("unstable",), "sweep re-run with an unstable point")
    if bad:
        return bad
    return ok(r.error_line)


def sweep_garbage_file(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "sweep-garbage-file"
    d.mkdir(parents=True, exist_ok=True)
    (d / "sw.toml").write_bytes(b"name = \"x\"\nbase = \n[overrides\n\xff\xfe")
    r = gf(["sweep", d / "sw.toml", "-o", d / "out", "-n", "1"], cwd=d)
    bad = check_clean_error_sweep(r, (2,), ("sw.toml",), "sweep of a garbage file")
    return bad if bad else ok(r.error_line)


def sweep_unknown_field(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "sweep-unknown-field"
    d.mkdir(parents=True, exist_ok=True)
    sweep_base(d)
    write_toml(d / "sw.toml", {"name": "typo", "base": "base.toml",
                               "overrides": {"contact.muu": [0.1, 0.2]}})
    r = gf(["sweep", d / "sw.toml", "-o", d / "out", "-n", "1"], cwd=d)
    bad = check_clean_error_sweep(r, (2,), ("contact.muu",), "sweep with a misspelled field")
    return bad if bad else ok(r.error_line)


def sweep_missing_base(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "sweep-missing-base"
    d.mkdir(parents=True, exist_ok=True)
    write_toml(d / "sw.toml", {"name": "nobase", "base": "nothere.toml",
                               "overrides": {"contact.mu": [0.1]}})
    r = gf(["sweep", d / "sw.toml", "-o", d / "out", "-n", "1"], cwd=d)
    bad = check_clean_error_sweep(r, (2,), ("nothere.toml",), "sweep with a missing base")
    return bad if bad else ok(r.error_line)


def sweep_sigint(ctx: Ctx) -> tuple[bool, str]:
    d = ctx.work / "fault" / "sweep-sigint"
    d.mkdir(parents=True, exist_ok=True)
    c = cfg_long()
    c["run"]["steps"] = 40000
    write_toml(d / "base.toml", c)
    write_toml(d / "sw.toml", {"name": "int", "base": "base.toml",
                               "overrides": {"contact.mu": [0.3, 0.5]}})
    p = start(["sweep", d / "sw.toml", "-o", d / "out", "-n", "2", "--progress", "plain"], cwd=d,
              log_prefix=d / "sweep")
    wait_for(d / "out" / "runs", 60, p)
    time.sleep(ctx.rng.uniform(1.5, 3.0))
    if p.poll() is not None:
        return fail(f"the sweep ended (exit {p.returncode}) before the SIGINT; lengthen the runs")
    p.send_signal(signal.SIGINT)
    r = finish(p, d / "sweep", timeout=120)
    if r.traceback:
        return fail(f"sweep after SIGINT printed a Traceback: {[l for l in r.err.splitlines() if l.strip()][-1]}")
    if r.rc not in (130, 0):
        return fail(f"sweep after SIGINT: exit {r.rc}, expected 130; {r.error_line}")
    r2 = gf(["sweep", d / "sw.toml", "-o", d / "out", "-n", "2", "--progress", "plain"], cwd=d, timeout=240)
    if r2.rc != 0 or r2.traceback:
        return fail(f"sweep re-run after SIGINT: exit {r2.rc}: {r2.error_line}")
    return ok(f"SIGINT: exit {r.rc}; re-run finished")


# ---- registry of fault cases ---------------------------------------------------------------


def fault_cases(ctx: Ctx):
    rng = ctx.rng
    S = signal
    cases = [
        ("unstable-periodic-2d-every-step", lambda: unstable_case(ctx, "unstable-periodic-2d-every-step",
                                                                  cfg_periodic_blowup(2))),
        ("unstable-periodic-2d-ab2-contacts-lzf", lambda: unstable_case(
            ctx, "unstable-periodic-2d-ab2-contacts-lzf",
            cfg_periodic_blowup(2, "adams_bashforth2", True, "lzf"), export_vtk=True)),
        ("unstable-periodic-3d-contacts-nocompress", lambda: unstable_case(
            ctx, "unstable-periodic-3d-contacts-nocompress", cfg_periodic_blowup(3, "verlet", True, "none"))),
        ("unstable-tunnel-through-floor", lambda: unstable_case(ctx, "unstable-tunnel-through-floor",
                                                                cfg_tunnel())),
        ("unstable-speed-1e200", lambda: unstable_case(ctx, "unstable-speed-1e200", cfg_speed(1e200))),
        ("unstable-speed-1e308-x10", lambda: unstable_case(ctx, "unstable-speed-1e308-x10",
                                                           cfg_speed(1.7e308))),
        ("unstable-thrown-out-of-open-box", lambda: unstable_case(ctx, "unstable-thrown-out-of-open-box",
                                                                  cfg_thrown_out())),
        ("unstable-initial-overlap", lambda: unstable_case(ctx, "unstable-initial-overlap", cfg_overlap())),
        ("unstable-soft-stiff-unsafe-dt", lambda: unstable_case(ctx, "unstable-soft-stiff-unsafe-dt",
                                                                cfg_soft_unsafe())),
        ("unstable-tether-stiff-unsafe-dt", lambda: unstable_case(ctx, "unstable-tether-stiff-unsafe-dt",
                                                                  cfg_tether_unsafe())),
        ("unstable-pour-at-1e5", lambda: unstable_case(ctx, "unstable-pour-at-1e5", cfg_pour_fast())),
        ("unstable-gravity-1e9", lambda: unstable_case(ctx, "unstable-gravity-1e9", cfg_gravity_huge())),
        ("unstable-hopper-unsafe-dt", lambda: unstable_case(ctx, "unstable-hopper-unsafe-dt",
                                                            cfg_hopper_unsafe())),
        ("signal-SIGINT-random", lambda: signal_case(ctx, "signal-SIGINT-random", [S.SIGINT])),
        ("signal-SIGTERM-random", lambda: signal_case(ctx, "signal-SIGTERM-random", [S.SIGTERM])),
        ("signal-SIGKILL-random", lambda: signal_case(ctx, "signal-SIGKILL-random", [S.SIGKILL])),
        ("signal-SIGINT-twice", lambda: signal_case(ctx, "signal-SIGINT-twice", [S.SIGINT, S.SIGINT])),
        ("signal-SIGTERM-then-SIGINT", lambda: signal_case(ctx, "signal-SIGTERM-then-SIGINT",
                                                           [S.SIGTERM, S.SIGINT])),
        ("signal-SIGINT-at-startup", lambda: signal_case(ctx, "signal-SIGINT-at-startup", [S.SIGINT],
                                                         wait_ckpt=False)),
        ("signal-SIGKILL-at-startup", lambda: signal_case(ctx, "signal-SIGKILL-at-startup", [S.SIGKILL],
                                                          wait_ckpt=False)),
        ("signal-SIGTERM-during-resume", lambda: signal_case(ctx, "signal-SIGTERM-during-resume",
                                                             [S.SIGINT], during_resume=S.SIGTERM)),
        ("signal-SIGKILL-during-resume", lambda: signal_case(ctx, "signal-SIGKILL-during-resume",
                                                             [S.SIGKILL], during_resume=S.SIGKILL)),
        ("damaged-checkpoint-empty", lambda: damaged_checkpoint_case(
            ctx, "damaged-checkpoint-empty", lambda p: p.write_bytes(b""))),
        ("damaged-checkpoint-truncated", lambda: damaged_checkpoint_case(
            ctx, "damaged-checkpoint-truncated", truncate_to(0.5))),
        ("damaged-checkpoint-random-bytes", lambda: damaged_checkpoint_case(
            ctx, "damaged-checkpoint-random-bytes", random_bytes(rng))),
        ("damaged-checkpoint-foreign-npz", lambda: damaged_checkpoint_case(
            ctx, "damaged-checkpoint-foreign-npz", foreign_npz)),
        ("damaged-checkpoint-deleted", lambda: info_missing_checkpoint_case(ctx)),
        ("damaged-frames-truncated-30", lambda: frames_damage_case(ctx, "damaged-frames-truncated-30",
                                                                   truncate_to(0.30))),
        ("damaged-frames-truncated-60", lambda: frames_damage_case(ctx, "damaged-frames-truncated-60",
                                                                   truncate_to(0.60))),
        ("damaged-frames-truncated-90", lambda: frames_damage_case(ctx, "damaged-frames-truncated-90",
                                                                   truncate_to(0.90))),
        ("damaged-frames-truncated-99", lambda: frames_damage_case(ctx, "damaged-frames-truncated-99",
                                                                   truncate_to(0.99))),
        ("damaged-frames-random-bytes", lambda: frames_damage_case(ctx, "damaged-frames-random-bytes",
                                                                   random_bytes(rng, 5000))),
        ("damaged-frames-emptied", lambda: frames_damage_case(ctx, "damaged-frames-emptied",
                                                              lambda p: p.write_bytes(b""))),
        ("damaged-thermo-garbage", lambda: thermo_damage_case(
            ctx, "damaged-thermo-garbage", lambda p: p.write_bytes(b"\x00\xffgarbage,,,\nnan,inf\n"))),
        ("damaged-thermo-truncated-midline", lambda: thermo_damage_case(
            ctx, "damaged-thermo-truncated-midline", truncate_to(0.77))),
        ("damaged-thermo-deleted", lambda: thermo_damage_case(
            ctx, "damaged-thermo-deleted", lambda p: p.unlink())),
        ("damaged-manifest-garbage-overwrite", lambda: manifest_case(
            ctx, "damaged-manifest-garbage-overwrite", lambda p: p.write_bytes(b"{not json\xff"))),
        ("damaged-manifest-deleted-overwrite", lambda: manifest_case(
            ctx, "damaged-manifest-deleted-overwrite", lambda p: p.unlink())),
        ("damaged-summary-json", lambda: summary_garbage_case(ctx)),
        ("rundir-overwrite-userfiles", lambda: rundir_overwrite_userfiles(ctx)),
        ("rundir-handwritten-config", lambda: rundir_handwritten_config(ctx)),
        ("rundir-config-inside", lambda: rundir_config_inside(ctx)),
        ("rundir-edited-config-overwrite", lambda: rundir_edited_config_overwrite(ctx)),
        ("rundir-foreign-thermo", lambda: rundir_foreign_thermo(ctx)),
        ("rundir-nonempty-no-overwrite", lambda: rundir_nonempty_no_overwrite(ctx)),
        ("rundir-is-a-file", lambda: rundir_is_file(ctx)),
        ("rundir-export-user-dump", lambda: rundir_export_user_dump(ctx, "dump")),
        ("rundir-export-user-vtk", lambda: rundir_export_user_dump(ctx, "vtk")),
        ("rundir-export-twice", lambda: rundir_export_twice(ctx)),
        ("resume-not-a-rundir", lambda: resume_not_a_rundir(ctx)),
        ("sweep-invalid-point", lambda: sweep_invalid_point(ctx)),
        ("sweep-garbage-catalog", lambda: sweep_garbage_catalog(
            ctx, "sweep-garbage-catalog", random_bytes(rng, 8192))),
        ("sweep-emptied-catalog", lambda: sweep_garbage_catalog(
            ctx, "sweep-emptied-catalog", lambda p: p.write_bytes(b""))),
        ("sweep-foreign-sqlite-catalog", lambda: sweep_garbage_catalog(
            ctx, "sweep-foreign-sqlite-catalog", foreign_sqlite)),
        ("sweep-relative-data-path", lambda: sweep_relative_data(ctx)),
        ("sweep-unstable-point", lambda: sweep_unstable_point(ctx)),
        ("sweep-garbage-file", lambda: sweep_garbage_file(ctx)),
        ("sweep-unknown-field", lambda: sweep_unknown_field(ctx)),
        ("sweep-missing-base", lambda: sweep_missing_base(ctx)),
        ("sweep-sigint", lambda: sweep_sigint(ctx)),
    ]
    return cases


def foreign_sqlite(p: Path):
    for suffix in ("", "-wal", "-shm"):
        q = Path(str(p) + suffix)
        if q.exists():
            q.unlink()
    con = sqlite3.connect(p)
    con.execute("CREATE TABLE recipes (name TEXT, flour REAL)")
    con.execute("INSERT INTO recipes VALUES ('bread', 500)")
    con.commit()
    con.close()


# --------------------------------------------------------------------------------------------
# main
# --------------------------------------------------------------------------------------------


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--keep", type=Path, help="build the cases in this directory and keep it")
    ap.add_argument("--seed", type=int, default=None, help="random seed (signal timings, bytes)")
    ap.add_argument("--only", default="", help="run only cases whose id starts with this")
    args = ap.parse_args()
    seed = args.seed if args.seed is not None else random.SystemRandom().randrange(1 << 30)
    t_start = time.monotonic()
    if args.keep:
        work = args.keep.resolve()
        if work.exists():
            shutil.rmtree(work)
        work.mkdir(parents=True)
        tmp = None
    else:
        tmp = tempfile.TemporaryDirectory(prefix="grainflow-adversarial-")
        work = Path(tmp.name)
    print(f"grainflow adversarial check; work dir {work}; seed {seed}", flush=True)
    ctx = Ctx(work, random.Random(seed))

    bad = [c for c in bad_cases() if c.cid.startswith(args.only)]
    ids = [c.cid for c in bad]
    assert len(ids) == len(set(ids)), "duplicate case ids"
    print(f"\n== 1. bad inputs ({len(bad)} cases) ==", flush=True)
    n_refused = 0
    not_ok_bad = []
    for c in bad:
        verdict, reason = run_bad(c, work)
        n_refused += verdict == "refused"
        if verdict != "refused":
            not_ok_bad.append((c.cid, verdict, reason))
        print(f"{c.cid:42s} {verdict:15s} {reason}", flush=True)

    faults = [(cid, fn) for cid, fn in fault_cases(ctx) if cid.startswith(args.only)]
    print(f"\n== 2. fault cases ({len(faults)} cases) ==", flush=True)
    n_handled = 0
    not_ok_fault = []
    for cid, fn in faults:
        t0 = time.monotonic()
        try:
            handled, reason = fn()
        except Exception as e:  # noqa: BLE001  (a failure of this script, reported as such)
            handled, reason = False, f"check script error: {type(e).__name__}: {short(str(e), 120)}"
        n_handled += handled
        verdict = "handled" if handled else "NOT-HANDLED"
        if not handled:
            not_ok_fault.append((cid, reason))
        print(f"{cid:42s} {verdict:12s} {time.monotonic() - t0:5.1f}s  {reason}", flush=True)

    print("\n== not refused cleanly / not handled ==")
    for cid, verdict, reason in not_ok_bad:
        print(f"  [bad]   {cid}: {verdict}: {reason}")
    for cid, reason in not_ok_fault:
        print(f"  [fault] {cid}: {reason}")
    if not not_ok_bad and not not_ok_fault:
        print("  (none)")
    counts: dict[str, int] = {}
    for _, v, _ in not_ok_bad:
        counts[v] = counts.get(v, 0) + 1
    print(f"\nbad inputs refused cleanly: {n_refused} / {len(bad)}"
          + (f"  ({', '.join(f'{k} {v}' for k, v in sorted(counts.items()))})" if counts else ""))
    print(f"fault cases handled: {n_handled} / {len(faults)}")
    print(f"total wall time: {time.monotonic() - t_start:.0f} s (seed {seed})")
    if tmp is not None:
        tmp.cleanup()
    return 0 if (n_refused == len(bad) and n_handled == len(faults)) else 1


if __name__ == "__main__":
    sys.exit(main())
