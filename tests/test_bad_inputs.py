"""Broken configurations, one table: each is refused with a ConfigError naming the field.

Every case is loaded with :func:`~grainflow.config.schema.load_config` and, if that passes,
built with :func:`~grainflow.config.build.build_simulation` (the checks that need the
particles); the error's text must contain the dotted path of the bad field (and, where it
helps, the bad value). A case's source is a whole config as a dict (``generic(...)``
merges a TOML snippet into a valid generic config), as TOML text, or as raw bytes; text and
bytes are written to ``run.toml`` and loaded from there. LAMMPS data files that the cases
name are written next to it (:data:`DATA_FILES`).
"""

from __future__ import annotations

import copy
import textwrap
import tomllib
from pathlib import Path
from typing import Any

import pytest

from grainflow.config.build import build_simulation
from grainflow.config.schema import ConfigError, load_config

#: one grain or a few gain nothing from threads (see conftest.numba_one_thread)
pytestmark = pytest.mark.usefixtures("numba_one_thread")

BASE: dict[str, Any] = {
    "dim": 3,
    "run": {"steps": 10},
    "box": {"lo": [0, 0, 0], "hi": [10, 10, 10]},
    "particles": [{"fill": "list", "positions": [[1, 1, 1], [3, 1, 1]], "radius": 0.5}],
    "contact": {"law": "granular", "restitution": 0.8, "contact_time": 0.05, "mu": 0.5},
}


def generic(snippet: str = "", *, drop: tuple[str, ...] = ()) -> dict[str, Any]:
    """:data:`BASE` without the keys ``drop``, with the tables of a TOML snippet merged in
    (lists and values replaced)."""
    out = {k: v for k, v in copy.deepcopy(BASE).items() if k not in drop}

    def merge(into: dict[str, Any], new: dict[str, Any]) -> None:
        for key, value in new.items():
            if isinstance(value, dict) and isinstance(into.get(key), dict):
                merge(into[key], value)
            else:
                into[key] = value

    merge(out, tomllib.loads(snippet))
    return out


def lammps(atoms: str, style: str = " # sphere") -> str:
    """A LAMMPS data file with three atoms in a box 0..10 and the given Atoms lines."""
    return textwrap.dedent(f"""\
        LAMMPS data file written by hand

        3 atoms
        2 atom types

        0.0 10.0 xlo xhi
        0.0 10.0 ylo yhi
        0.0 10.0 zlo zhi

        Atoms{style}

        """) + textwrap.dedent(atoms)


SPHERE_ATOMS = """\
    1 1 1.0 1.0 1.0 1.0 1.0
    2 1 1.0 1.0 3.0 1.0 1.0
    3 1 1.0 1.0 5.0 1.0 1.0
    """

#: data files the cases name, written next to the config
DATA_FILES = {
    "duplicate_ids.data": lammps(SPHERE_ATOMS.replace("3 1 1.0", "2 1 1.0")),
    "atomic.data": lammps("""\
        1 1 1.0 1.0 1.0
        2 1 3.0 1.0 1.0
        3 1 5.0 1.0 1.0
        """, style=" # atomic"),
    "atomic_unlabelled.data": lammps("""\
        1 1 1.0 1.0 1.0
        2 1 3.0 1.0 1.0
        3 1 5.0 1.0 1.0
        """, style=""),
    "outside_box.data": lammps(SPHERE_ATOMS.replace("5.0 1.0 1.0", "5.0 1.0 30.0")),
    "negative.data": lammps(SPHERE_ATOMS.replace("2 1 1.0", "2 1 -1.0")),
    "header.data": lammps(SPHERE_ATOMS).replace("3 atoms", "three atoms"),
}


def hopper(section: str, scenario: str = "hopper2d", dim: int = 2, extra: str = "") -> str:
    """A small hopper config (TOML text) with the given ``[hopper]`` lines."""
    return (f'scenario = "{scenario}"\ndim = {dim}\n{extra}\n[run]\nsteps = 10\n'
            f"[hopper]\nn = 40\nwidth = 15.0\norifice_width = 5.0\n{section}\n")


CHUTE = 'scenario = "chute"\n[run]\nsteps = 10\n[chute]\n'
FLOOR = '[[walls]]\nshape = "plane"\npoint = [0, 0, 2]\nnormal = [0, 0, 1]\n'
LIST = 'fill = "list", positions = [[1, 1, 1], [3, 1, 1]]'
LATTICE = 'fill = "lattice", radius = 0.5'
RANDOM = 'fill = "random", radius = 0.5'
POUR = ('kind = "pour", every = 10, radius = 0.5, per_insertion = 5, '
        'region = {lo = [0, 0, 8], hi = [10, 10, 10]}')
REPLENISH = ('kind = "replenish", every = 10, radius = 0.5, target = 5, '
             'region = {lo = [0, 0, 8], hi = [10, 10, 10]}, '
             'count_region = {lo = [0, 0, 0], hi = [10, 10, 8]}')
TETHER = 'tethers = [{type = 0, k = 100.0}]\n'

CASES: list[tuple[str, dict[str, Any] | str | bytes, str]] = [
    # ----------------------------------------------------------------------------- [run]
    ("run-steps-string", generic('[run]\nsteps = "10"'), "run.steps: '10'"),
    ("run-steps-negative", generic("[run]\nsteps = -5"), "run.steps: -5"),
    ("run-steps-float", generic("[run]\nsteps = 2.5"), "run.steps: 2.5"),
    ("run-steps-and-duration", generic("[run]\nduration = 1.0"), "run: give exactly one"),
    ("run-dt-zero", generic("[run]\ndt = 0"), "run.dt: 0"),
    ("run-dt-nan", generic("[run]\ndt = nan"), "run.dt: nan"),
    ("run-dt-inf", generic("[run]\ndt = inf"), "run.dt: inf"),
    ("run-duration-length", generic('[run]\nsteps = 0\nduration = "5 m"'), "run.duration: '5 m'"),
    ("run-dt_fraction-large", generic("[run]\ndt_fraction = 0.5"), "run.dt_fraction: 0.5"),
    ("run-seed-negative", generic("[run]\nseed = -1"), "run.seed: -1"),
    ("run-seed-bool", generic("[run]\nseed = true"), "run.seed: True"),
    ("run-seed-string", generic('[run]\nseed = "7"'), "run.seed: '7'"),
    ("run-unsafe-string", generic('[run]\nallow_unsafe_dt = "yes"'), "run.allow_unsafe_dt: 'yes'"),
    ("run-minimize-int", generic("[run]\nminimize = 1"), "run.minimize: 1"),
    ("run-overlap-inf", generic("[run]\nmax_overlap_fraction = inf"),
     "run.max_overlap_fraction: inf"),
    ("run-skin-negative", generic('[run]\nskin = "-1 mm"'), "run.skin: '-1 mm'"),
    ("run-sort_every-string", generic('[run]\nsort_every = "10"'), "run.sort_every: '10'"),
    ("run-missing", generic(drop=("run",)), "run: missing"),
    # -------------------------------------------------------------------------- [output]
    ("output-thermo-string", generic('[output]\nthermo_every = "500"'),
     "output.thermo_every: '500'"),
    ("output-snapshot-string", generic('[output]\nsnapshot = "no"'), "output.snapshot: 'no'"),
    ("output-contacts-int", generic("[output]\ncontacts = 1"), "output.contacts: 1"),
    ("output-checkpoint-string", generic('[output]\ncheckpoint_every = "0"'),
     "output.checkpoint_every: '0'"),
    ("output-compression", generic('[output]\ncompression = "zip"'),
     "output.compression: 'zip'"),
    ("output-progress-nan", generic("[output]\nprogress_interval = nan"),
     "output.progress_interval: nan"),
    # ----------------------------------------------------------------------------- [box]
    ("box-periodic-length", generic("[box]\nperiodic = [true, true]"), "box.periodic"),
    ("box-periodic-string", generic('[box]\nperiodic = ["yes", "no", "no"]'),
     "box.periodic[0]: 'yes'"),
    ("box-lo-inf", generic("[box]\nlo = [0, 0, -inf]"), "box.lo[2]: -inf"),
    ("box-hi-time", generic('[box]\nhi = ["10 s", 10, 10]'), "box.hi[0]: '10 s'"),
    ("box-missing", generic(drop=("box",)), "box: missing"),
    # ------------------------------------------------------------------ [[particles]] list
    ("list-outside-box", generic(f"particles = [{{{LIST[:-1]}, [1, 1, 20]], radius = 0.5}}]"),
     "particles[0].positions[2]: [1.0, 1.0, 20.0]"),
    ("list-outside-box-2d", {**generic(), "dim": 2, "box": {"lo": [0, 0], "hi": [10, 10]},
                             "particles": [{"fill": "list", "positions": [[1, 1], [-3, 1]],
                                            "radius": 0.5}]},
     "particles[0].positions[1]: [-3.0, 1.0]"),
    ("list-velocities-count", generic(f"particles = [{{{LIST}, radius = 0.5, "
                                      "velocities = [[0, 0, 1]]}]"),
     "particles[0].velocities"),
    ("list-radius-zero", generic(f"particles = [{{{LIST}, radius = 0}}]"),
     "particles[0].radius[0]: 0"),
    ("list-mass-and-density", generic(f"particles = [{{{LIST}, radius = 0.5, mass = 1.0, "
                                      "density = 1.0}]"), "particles[0].mass"),
    ("list-type-negative", generic(f"particles = [{{{LIST}, radius = 0.5, type = -1}}]"),
     "particles[0].type: -1"),
    ("list-type-string", generic(f'particles = [{{{LIST}, radius = 0.5, type = "1"}}]'),
     "particles[0].type: '1'"),
    ("list-frozen-string", generic(f'particles = [{{{LIST}, radius = 0.5, frozen = "true"}}]'),
     "particles[0].frozen: 'true'"),
    ("list-fractions-inf", generic(f"particles = [{{{LIST}, radius = [0.5, 0.6], "
                                   "fractions = [1, inf]}]"), "particles[0].fractions[1]: inf"),
    ("list-below-floor", generic(FLOOR), "particles[0].positions[0]: [1.0, 1.0, 1.0]"),
    ("list-outside-tube", generic('[[walls]]\nshape = "cylinder"\naxis_point = [6, 6, 0]\n'
                                  "radius = 2\n"), "particles[0].positions[0]"),
    ("list-positions-empty", generic('particles = [{fill = "list", positions = [], '
                                     "radius = 0.5}]"), "particles[0].positions"),
    # --------------------------------------------------------------- [[particles]] lattice
    ("lattice-region-outside-box", generic(f"particles = [{{{LATTICE}, region = "
                                           "{lo = [0, 0, 0], hi = [12, 10, 10]}}]"),
     "particles[0].region"),
    ("lattice-huge", generic(f'particles = [{{fill = "lattice", radius = "1 um"}}]'),
     "particles[0].radius"),
    ("lattice-square-in-3d", generic(f'particles = [{{{LATTICE}, lattice = "square"}}]'),
     "particles[0].lattice"),
    ("lattice-packing-one", generic(f"particles = [{{{LATTICE}, packing_fraction = 1}}]"),
     "particles[0].packing_fraction: 1"),
    ("lattice-halfspace", generic(f'particles = [{{{LATTICE}, region = {{shape = "halfspace", '
                                  "point = [0, 0, 0], normal = [0, 0, 1]}}]"),
     "particles[0].region"),
    ("lattice-disk-in-3d", generic(f'particles = [{{{LATTICE}, region = {{shape = "disk", '
                                   "center = [5, 5], radius = 3}}]"), "particles[0].region"),
    ("lattice-below-floor", generic(f"particles = [{{{LATTICE}, region = "
                                    "{lo = [0, 0, 0], hi = [10, 10, 1.5]}}]\n" + FLOOR),
     "particles[0].region"),
    ("lattice-empty-region", generic(f"particles = [{{{LATTICE}, region = "
                                     "{lo = [0, 0, 0], hi = [0.5, 10, 10]}}]"),
     "particles[0].region"),
    ("lattice-spacing-negative", generic(f"particles = [{{{LATTICE}, spacing = -1}}]"),
     "particles[0].spacing: -1"),
    # ---------------------------------------------------------------- [[particles]] random
    ("random-count-zero", generic(f"particles = [{{{RANDOM}, count = 0}}]"),
     "particles[0].count: 0"),
    ("random-count-string", generic(f'particles = [{{{RANDOM}, count = "100"}}]'),
     "particles[0].count: '100'"),
    ("random-count-missing", generic(f"particles = [{{{RANDOM}}}]"),
     "particles[0].count: missing"),
    ("random-region-outside-box", generic(f"particles = [{{{RANDOM}, count = 5, region = "
                                          "{lo = [-5, 0, 0], hi = [5, 10, 10]}}]"),
     "particles[0].region"),
    ("random-overfull", generic(f"particles = [{{{RANDOM}, count = 100000}}]"),
     "particles[0].count: 100000"),
    ("random-cylinder-axis", generic(f'particles = [{{{RANDOM}, count = 5, region = {{shape = '
                                     '"cylinder", center = [5, 5], radius = 2, lo = 0, '
                                     "hi = 10, axis = 3}}]"), "particles[0].region.axis: 3"),
    ("random-max_attempts-zero", generic(f"particles = [{{{RANDOM}, count = 5, "
                                         "max_attempts = 0}]"), "particles[0].max_attempts: 0"),
    # ----------------------------------------------------------- [[particles]] lammps_data
    ("lammps-duplicate-ids", generic('particles = [{fill = "lammps_data", '
                                     'file = "duplicate_ids.data"}]'),
     "particles[0].file"),
    ("lammps-atomic-style", generic('particles = [{fill = "lammps_data", file = "atomic.data"}]'),
     "particles[0].file"),
    ("lammps-atomic-unlabelled", generic('particles = [{fill = "lammps_data", '
                                         'file = "atomic_unlabelled.data"}]'),
     "particles[0].file"),
    ("lammps-outside-box", generic('particles = [{fill = "lammps_data", '
                                   'file = "outside_box.data"}]'), "particles[0].file"),
    ("lammps-frozen-types-zero", generic('particles = [{fill = "lammps_data", '
                                         'file = "atomic.data", frozen_types = [0]}]'),
     "particles[0].frozen_types[0]: 0"),
    ("lammps-radius-key", generic('particles = [{fill = "lammps_data", file = "atomic.data", '
                                  "radius = 1.0}]"), "particles[0].radius: unknown key"),
    ("particles-none", generic(drop=("particles",)), "particles: no particles"),
    ("particles-fill-missing", generic("particles = [{radius = 0.5}]"), "particles[0].fill"),
    # --------------------------------------------------------------------------- [[walls]]
    ("wall-plane-normal-zero", generic('[[walls]]\nshape = "plane"\npoint = [0, 0, 0]\n'
                                       "normal = [0, 0, 0]\n"), "walls[0].normal"),
    ("wall-segment-points-equal", generic('dim = 3\n[[walls]]\nshape = "segment"\n'
                                          "p0 = [0, 0, 0]\np1 = [0, 0, 0]\n"), "walls[0].p1"),
    ("wall-cylinder-radius-negative", generic('[[walls]]\nshape = "cylinder"\n'
                                              "axis_point = [5, 5, 0]\nradius = -2\n"),
     "walls[0].radius: -2"),
    ("wall-cylinder-lid-infinite", generic('[[walls]]\nshape = "cylinder"\n'
                                           "axis_point = [5, 5, 0]\nradius = 8\nlid_lo = true\n"),
     "walls[0].lid_lo"),
    ("wall-cone-two-forms", generic('[[walls]]\nshape = "cone"\napex = [5, 5, 0]\n'
                                    'axis = "z"\ncenter = [5, 5]\nradius_lo = 1\n'
                                    "radius_hi = 5\nlo = 0\nhi = 10\n"), "walls[0]"),
    ("wall-plate-hole-zero", generic('[[walls]]\nshape = "plate_with_hole"\npoint = [5, 5, 0]\n'
                                     "normal = [0, 0, 1]\nhole_radius = 0\n"),
     "walls[0].hole_radius: 0"),
    ("wall-hopper2d-orifice-wide", generic('[[walls]]\nshape = "hopper2d"\nW = 4\n'
                                           "orifice_w = 6\nheight = 10\n"), "walls[0]"),
    ("wall-inside-string", generic('[[walls]]\nshape = "cylinder"\naxis_point = [5, 5, 0]\n'
                                   'radius = 8\ninside = "yes"\n'), "walls[0].inside: 'yes'"),
    ("wall-type-float", generic('[[walls]]\nshape = "plane"\npoint = [0, 0, 0]\n'
                                "normal = [0, 0, 1]\ntype = 1.5\n"), "walls[0].type: 1.5"),
    ("wall-point-four", generic('[[walls]]\nshape = "plane"\npoint = [0, 0, 0, 0]\n'
                                "normal = [0, 0, 1]\n"), "walls[0].point"),
    ("wall-without-contact", generic('[[walls]]\nshape = "plane"\npoint = [0, 0, 0]\n'
                                     "normal = [0, 0, 1]\n", drop=("contact",)), "walls"),
    # --------------------------------------------------------------------------- [contact]
    ("contact-no-law", generic(drop=("contact",)) | {"contact": {"mu": 0.5}}, "contact.law"),
    ("contact-mu-word", generic('[contact]\nmu = "high"'), "contact.mu"),
    ("contact-time-length", generic('[contact]\ncontact_time = "1 m"'), "contact.contact_time"),
    ("contact-pair-types-string", generic('[[contact.pairs]]\ntypes = ["0", "1"]\nmu = 0.1'),
     "contact.pairs[0].types[0]: '0'"),
    ("contact-kt-nan", generic("[contact]\nkt = nan"), "contact.kt"),
    ("contact-damping-choice", generic('[contact]\ndamping = "heavy"'), "contact.damping"),
    ("contact-epsilon-granular", generic("[contact]\nepsilon = 1.0"), "contact.epsilon"),
    # ---------------------------------------------------------------------- gravity, drag
    ("gravity-string", generic('gravity = "down"'), "gravity"),
    ("gravity-velocity", generic('gravity = [0, 0, "-9.81 m/s"]'), "gravity[2]"),
    ("drag-inf", generic("drag = inf"), "drag[0]: inf"),
    # ------------------------------------------------------------------------- [[tethers]]
    ("tether-k-negative", generic("tethers = [{type = 0, k = -1.0}]"), "tethers[0].k: -1"),
    ("tether-type-absent", generic("tethers = [{type = 5, k = 1.0}]"), "tethers[0].type: 5"),
    ("tether-k-missing", generic("tethers = [{type = 0}]"), "tethers[0].k: missing"),
    ("tether-cutoff-zero", generic("tethers = [{type = 0, k = 1.0, bond_cutoff = 0}]"),
     "tethers[0].bond_cutoff: 0"),
    ("tether-type-string", generic('tethers = [{type = "0", k = 1.0}]'),
     "tethers[0].type: '0'"),
    # ---------------------------------------------------------------- [[insert]], [[delete]]
    ("pour-per-insertion-zero", generic(f"insert = [{{{POUR.replace('= 5', '= 0')}}}]"),
     "insert[0].per_insertion: 0"),
    ("pour-three-radii", generic(f"insert = [{{{POUR.replace('radius = 0.5', 'radius = [0.3, 0.4, 0.5]')}}}]"),
     "insert[0].radius"),
    ("pour-region-missing", generic('insert = [{kind = "pour", every = 10, radius = 0.5, '
                                    "per_insertion = 5}]"), "insert[0].region: missing"),
    ("pour-kind-unknown", generic(f"insert = [{{{POUR.replace('pour', 'spray')}}}]"),
     "insert[0].kind"),
    ("pour-velocity-2d", generic(f"insert = [{{{POUR}, velocity = [0, -1]}}]"),
     "insert[0].velocity"),
    ("pour-total-string", generic(f'insert = [{{{POUR}, total = "100"}}]'),
     "insert[0].total: '100'"),
    ("replenish-target-negative", generic(f"insert = [{{{REPLENISH.replace('= 5', '= -5')}}}]"),
     "insert[0].target: -5"),
    ("replenish-every-string", generic("insert = [{" + REPLENISH.replace("every = 10", 'every = "10"') + "}]"),
     "insert[0].every: '10'"),
    ("replenish-count-region-missing", generic(f"insert = [{{{REPLENISH.split(', count_region')[0]}}}]"),
     "insert[0].count_region: missing"),
    ("delete-outside-string", generic('delete = [{every = 10, outside = "false", '
                                      "region = {lo = [0, 0, 0], hi = [10, 10, 10]}}]"),
     "delete[0].outside: 'false'"),
    ("delete-every-zero", generic("delete = [{every = 0, region = {lo = [0, 0, 0], "
                                  "hi = [10, 10, 10]}}]"), "delete[0].every: 0"),
    ("delete-halfspace-normal-zero", generic('delete = [{every = 10, region = {shape = '
                                             '"halfspace", point = [0, 0, 0], '
                                             "normal = [0, 0, 0]}}]"), "delete[0].region"),
    # --------------------------------------------------------------------- hopper, chute
    ("hopper-E_sp-inf", hopper("E_sp = inf"), "hopper.E_sp: inf"),
    ("hopper-E_w-nan", hopper("E_w = nan"), "hopper.E_w: nan"),
    ("hopper-n-string", hopper("", extra="").replace("n = 40", 'n = "40"'), "hopper.n: '40'"),
    ("hopper-orifice-wide", hopper("").replace("orifice_width = 5.0", "orifice_width = 20.0"),
     "hopper.orifice_width"),
    ("hopper3d-in-2d", hopper("", scenario="hopper3d"), "dim"),
    ("hopper-unknown-key", hopper("angle = 30"), "hopper.angle: unknown key"),
    ("hopper-zeta-alone", hopper("zeta = 0.1"), "zeta"),
    ("hopper-walls", hopper("", extra='[[walls]]\nshape = "plane"\npoint = [0, 0]\n'
                                      "normal = [0, 1]\n"), "walls: not used"),
    ("hopper-lam-negative", hopper("lam = -1"), "hopper.lam: -1"),
    ("hopper-reinsert-every-string", hopper('reinsert_every = "5"'),
     "hopper.reinsert_every: '5'"),
    ("chute-replicate-zero", CHUTE + "replicate = [0, 1]\n", "chute.replicate[0]: 0"),
    ("chute-replicate-string", CHUTE + 'replicate = ["2", 1]\n', "chute.replicate[0]: '2'"),
    ("chute-angle-90", CHUTE + "angle = 90\n", "chute.angle: 90"),
    ("chute-angle-nan", CHUTE + "angle = nan\n", "chute.angle: nan"),
    ("chute-data-atomic", CHUTE + 'data_file = "atomic.data"\n', "chute.data_file"),
    # ----------------------------------------------------------------- the file, top level
    ("file-binary", bytes(range(256)) * 4, "not UTF-8 TOML text"),
    ("file-utf16", 'scenario = "generic"\n[run]\nsteps = 10\n'.encode("utf-16"),
     "not UTF-8 TOML text"),
    ("file-utf16-no-bom", 'scenario = "generic"\n[run]\nsteps = 10\n'.encode("utf-16-le"),
     "not UTF-8 TOML text"),
    ("file-toml-syntax", "[run]\nsteps = 10\n[output\nthermo_every = 5\n", "line 3"),
    ("dim-string", generic('dim = "3"'), "dim: '3'"),
    ("scenario-number", generic("scenario = 3"), "scenario"),
    ("unknown-section", generic("[colour]\nred = 1"), "colour: unknown key"),
    # ------------------------------------- found by scripts/adversarial_check.py (issue 10)
    ("radius-empty-list", generic(f"particles = [{{{LIST}, radius = []}}]"),
     "particles[0].radius: []"),
    ("restitution-without-a-dashpot", generic('[contact]\nmodel = {damping = "none"}'),
     "contact.restitution: 0.8 (with contact_time) gives gamma_n"),
    ("lattice-spacing-overlapping",
     generic(f"particles = [{{{LATTICE}, spacing = 0.2}}]"),
     "particles[0].spacing: 0.2 is less than the largest diameter 1"),
    ("region-unknown-shape", generic(
        f"particles = [{{{LATTICE}, region = {{shape = 'blob'}}}}]"),
     "particles[0].region.shape: 'blob'"),
    ("wall-off-the-plane-of-a-2d-run",
     'dim = 2\n[run]\nsteps = 10\n[box]\nlo = [0, 0]\nhi = [10, 10]\n'
     '[[particles]]\nfill = "list"\npositions = [[5, 5]]\nradius = 0.5\n'
     '[contact]\nlaw = "granular"\nrestitution = 0.8\ncontact_time = 0.05\n'
     '[[walls]]\nshape = "plane"\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n',
     "walls[0]: a 'plane' wall with these fields does not lie in the z = 0 plane"),
    ("pour-region-outside-the-box",
     generic("insert = [{" + POUR.replace("[0, 0, 8], hi = [10, 10, 10]",
                                          "[20, 20, 20], hi = [30, 30, 30]") + "}]"),
     "insert[0].region: lo [20.0, 20.0, 20.0]"),
    ("data-negative-diameter", generic(
        'particles = [{fill = "lammps_data", file = "negative.data"}]'),
     "atom id 2 has diameter -1: negative diameters"),
    ("data-header-not-a-number", generic(
        'particles = [{fill = "lammps_data", file = "header.data"}]'),
     "header.data, line 3: 'three atoms'"),
]


@pytest.mark.parametrize(("case", "source", "expected"), CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_refused_naming_the_field(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                               case: str, source: dict[str, Any] | str | bytes,
                                               expected: str) -> None:
    monkeypatch.chdir(tmp_path)
    for name, text in DATA_FILES.items():
        (tmp_path / name).write_text(text)
    if isinstance(source, dict):
        target: dict[str, Any] | Path = source
    else:
        target = tmp_path / "run.toml"
        target.write_bytes(source if isinstance(source, bytes) else source.encode())
    with pytest.raises(ConfigError) as info:
        build_simulation(load_config(target), prepare=False)
    assert isinstance(info.value.messages, list)
    assert all("\n" not in m for m in info.value.messages)
    assert expected in str(info.value), info.value.messages


def test_the_table_is_large_enough() -> None:
    assert len(CASES) >= 40
    assert len({c[0] for c in CASES}) == len(CASES)


# ------------------------------------------------------- what must still be accepted
def test_periodic_axes_wrap_and_toml_integers_are_numbers() -> None:
    """A position past a periodic side is fine; integers are accepted for float fields."""
    config = load_config(generic('particles = [{fill = "list", positions = [[11, 1, 1], '
                                 "[3, 1, 1]], radius = 1, density = 2}]\n"
                                 "[box]\nperiodic = [true, false, false]\n"))
    assert config.particles[0].radius == [1.0] and config.particles[0].density == 2.0
    assert build_simulation(config).state.n == 2


def test_frozen_grains_and_grains_on_the_acting_side_pass_the_wall_check() -> None:
    data = generic(f'particles = [{{{LIST}, radius = 0.5, frozen = true}}, '
                   '{fill = "list", positions = [[5, 5, 5]], radius = 0.5}]\n' + FLOOR)
    assert build_simulation(load_config(data)).state.n == 3


# ------------------------------------------------------------------ details of messages
def test_every_problem_is_reported() -> None:
    """Independent problems come one per message: field errors together, and the placement
    checks (which need valid fields) together."""
    with pytest.raises(ConfigError) as info:
        load_config(generic('[run]\nsteps = "10"\n[output]\nsnapshot = "no"\n'
                            "[contact]\nrestitution = 2\n"))
    assert [m.split(":")[0] for m in info.value.messages] == [
        "run.steps", "output.snapshot", "contact.restitution"]
    with pytest.raises(ConfigError) as info:
        load_config(generic(f"particles = [{{{LIST[:-1]}, [1, 1, 20], [-1, 1, 1]], "
                            f'radius = 0.5}}, {{{LATTICE}, lattice = "square"}}]'))
    assert [m.split(":")[0] for m in info.value.messages] == [
        "particles[0].positions[2]", "particles[0].positions[3]", "particles[1].lattice"]


def test_duplicate_atom_ids_name_the_file_id_and_both_lines(tmp_path: Path) -> None:
    from grainflow.insertion.lammps_data import read_lammps_data

    path = tmp_path / "dup.data"
    path.write_text(DATA_FILES["duplicate_ids.data"])
    with pytest.raises(ValueError, match=r"dup\.data: atom id 2 appears twice .* lines 13 "
                                         r"and 14"):
        read_lammps_data(path)


def test_the_atoms_style_comment_is_read(tmp_path: Path) -> None:
    from grainflow.insertion.lammps_data import read_lammps_data

    path = tmp_path / "full.data"
    path.write_text(lammps(SPHERE_ATOMS, style="  # full"))
    with pytest.raises(ValueError, match=r"full\.data: the Atoms section is atom_style 'full'"):
        read_lammps_data(path)
    path.write_text(lammps(SPHERE_ATOMS, style=""))  # no comment, 7 columns: sphere
    assert read_lammps_data(path).id.tolist() == [1, 2, 3]


def test_a_huge_lattice_is_refused_before_allocating() -> None:
    from grainflow.insertion import MAX_LATTICE_SITES, BoxRegion, lattice_points

    with pytest.raises(ValueError, match="lattice sites"):
        lattice_points(BoxRegion((0, 0, 0), (1, 1, 1)), 1e-4, "fcc")
    with pytest.raises(ConfigError) as info:
        load_and_build = generic('particles = [{fill = "lattice", radius = "1 um", '
                                 "packing_fraction = 0.1}]")
        build_simulation(load_config(load_and_build))
    message = str(info.value)
    assert message.startswith("particles[0].radius: 1e-06") and f"{MAX_LATTICE_SITES:,}" in message
    assert "packing_fraction 0.1 asks for about" in message


def test_a_pour_without_initial_particles_asks_for_dt() -> None:
    data = generic(f"insert = [{{{POUR}}}]", drop=("particles",))
    with pytest.raises(ConfigError, match="run.dt: missing; there are no particles at step 0"):
        build_simulation(load_config(data))
