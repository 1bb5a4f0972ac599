"""LAMMPS's granular chute benchmark (``bench/in.chute``) as a grainflow simulation.

32,000 spheres of diameter 1 and density 1 on a frozen rough base (type 2), periodic in x and
y, gravity of magnitude 1 tilted 26 degrees down-slope, ``pair_style gran/hooke/history
200000.0 NULL 50.0 NULL 0.5 0`` (kn = 2e5, kt = 2/7 kn, gamma_n = 50, gamma_t = 0 because
dampflag = 0, mu = 0.5), dt = 1e-4, skin 0.1. Replicas along x and y give larger systems at
the same density for the scaling benchmark.

The benchmark's files ship with grainflow (``grainflow/data/chute``: ``data.chute.gz``,
``in.chute`` and LAMMPS's reference log); :func:`chute_files` returns their paths and the
functions here read the shipped data file unless given another.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import NamedTuple

import numpy as np

from grainflow.engine.forces import Gravity
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.insertion.lammps_data import LammpsData, read_lammps_data
from grainflow.models.base import ContactLaw
from grainflow.state import ParticleState

#: The deck's parameters.
CHUTE = {"kn": 2.0e5, "gamma_n": 50.0, "mu": 0.5, "dt": 1.0e-4, "skin": 0.1, "angle": 26.0}


class ChuteFiles(NamedTuple):
    """Paths of the shipped LAMMPS chute benchmark files."""

    data: Path  #: ``data.chute.gz``: the initial state (gzip; the reader opens it directly)
    deck: Path  #: ``in.chute``: LAMMPS's input deck
    log: Path  #: LAMMPS's reference log of the deck's 100 steps


def chute_files() -> ChuteFiles:
    """The LAMMPS chute benchmark files shipped in ``grainflow/data/chute``."""
    folder = Path(str(resources.files("grainflow").joinpath("data", "chute")))
    return ChuteFiles(data=folder / "data.chute.gz", deck=folder / "in.chute",
                      log=folder / "log.6Oct16.chute.fixed.icc.1.upstream_reference")


def chute_state(data: LammpsData, replicate: tuple[int, int] = (1, 1)) -> ParticleState:
    """The chute particles, replicated ``replicate[0] x replicate[1]`` times in x and y."""
    lx, ly = data.hi[:2] - data.lo[:2]
    rx, ry = replicate
    hi = data.hi.copy()
    hi[0] = data.lo[0] + rx * lx
    hi[1] = data.lo[1] + ry * ly
    st = ParticleState(3, Box(lo=data.lo.copy(), hi=hi, periodic=(True, True, False)))
    n = data.id.shape[0]
    for a in range(rx):
        for b in range(ry):
            x = data.x + np.array([a * lx, b * ly, 0.0])
            copy = a * ry + b
            st.add_particles(x, 0.5 * data.diameter, density=data.density, v=data.v,
                             omega=data.omega, type=data.type - 1, frozen=data.type == 2,
                             ids=data.id + copy * n)
    if rx == 1 and ry == 1:
        st.image[:] = data.image
    return st


def chute_simulation(data_path: str | Path | None = None, replicate: tuple[int, int] = (1, 1),
                     sort_every: int = 1) -> Simulation:
    """A ready-to-run chute simulation reading LAMMPS's ``data.chute`` (default: the shipped
    copy, :func:`chute_files`)."""
    data = read_lammps_data(chute_files().data if data_path is None else data_path)
    return _chute_model(chute_state(data, replicate), sort_every)


def chute_law() -> ContactLaw:
    """The deck's ``gran/hooke/history``: Hooke spring, mass-weighted normal dashpot,
    tangential history with Coulomb cap (no cohesion), for types 0 (grains) and 1 (base)."""
    law = ContactLaw(n_types=2, normal="hooke", damping="viscous", tangential="history")
    law.set_all(kn=CHUTE["kn"], gamma_n=CHUTE["gamma_n"], gamma_t=0.0, mu=CHUTE["mu"])
    return law


def _chute_model(st: ParticleState, sort_every: int = 1) -> Simulation:
    """The deck's contact law, time step, skin and tilted gravity around ``st``."""
    sim = Simulation(st, CHUTE["dt"], chute_law(), skin=CHUTE["skin"], sort_every=sort_every)
    sim.add_force(Gravity.chute(1.0, CHUTE["angle"]))
    return sim


def chute_cut(fraction_x: float = 0.5, fraction_y: float = 0.5,
              data_path: str | Path | None = None) -> Simulation:
    """A smaller chute, :func:`chute_cut_data`, ready to run. ``chute_cut(0.5, 0.5)`` is
    8,000 grains; ``chute_cut(0.25, 0.16)`` about 1,000."""
    return _chute_model(chute_state(chute_cut_data(fraction_x, fraction_y, data_path)))


def chute_cut_data(fraction_x: float = 0.5, fraction_y: float = 0.5,
                   data_path: str | Path | None = None) -> LammpsData:
    """The grains of the chute with ``x < fraction_x Lx`` and ``y < fraction_y Ly``, in a box
    of that size (still periodic in x and y), as a data file's contents (LAMMPS can run
    the same cut: :func:`~grainflow.insertion.lammps_data.write_lammps_data`).

    Grains that would overlap by more than 1 % of a diameter across the new periodic seams
    are dropped (the later of each such pair), so the cut system starts without violent
    contacts. Used for the size-scaling benchmarks. ``data_path`` defaults to the shipped
    ``data.chute.gz``.
    """
    from scipy.spatial import cKDTree

    if not (0.0 < fraction_x <= 1.0 and 0.0 < fraction_y <= 1.0):
        raise ValueError(f"fraction_x, fraction_y: {fraction_x!r}, {fraction_y!r}; each must "
                         "be in (0, 1]")
    data = read_lammps_data(chute_files().data if data_path is None else data_path)
    keep_len = np.array([fraction_x, fraction_y]) * (data.hi[:2] - data.lo[:2])
    keep = np.all(data.x[:, :2] - data.lo[:2] < keep_len, axis=1)
    idx = np.flatnonzero(keep)
    x = data.x[idx] - np.r_[data.lo[:2], 0.0]
    z_span = 10.0 * (np.ptp(x[:, 2]) + 1.0)
    tree = cKDTree(np.c_[x[:, :2], x[:, 2] - x[:, 2].min()],
                   boxsize=[keep_len[0], keep_len[1], z_span])
    radius = 0.5 * data.diameter[idx]
    drop = np.zeros(idx.size, dtype=bool)
    for a, b in sorted(tree.query_pairs(2.0 * radius.max())):
        if drop[a] or drop[b]:
            continue
        d = x[a] - x[b]
        d[:2] -= keep_len * np.rint(d[:2] / keep_len)
        if np.linalg.norm(d) < radius[a] + radius[b] - 0.02 * radius.max():
            drop[b] = True
    return LammpsData(lo=np.r_[0.0, 0.0, data.lo[2]], hi=np.r_[keep_len, data.hi[2]],
                      id=data.id[idx][~drop], type=data.type[idx][~drop],
                      diameter=data.diameter[idx][~drop], density=data.density[idx][~drop],
                      x=x[~drop], image=np.zeros((int((~drop).sum()), 3), dtype=np.int64),
                      v=data.v[idx][~drop], omega=data.omega[idx][~drop])
