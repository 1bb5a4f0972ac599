"""Run configurations: the examples load, units convert, bad input is refused by field path."""

from __future__ import annotations

import copy
import re
import tomllib
from pathlib import Path
from typing import Any

import pytest

from grainflow.config.schema import ConfigError, load_config, resolved_dict
from grainflow.scenarios import SCENARIOS, Scenario, get_scenario, register

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.toml"))

BASE: dict[str, Any] = {
    "dim": 3,
    "run": {"steps": 10},
    "box": {"lo": [0, 0, 0], "hi": [10, 10, 10]},
    "particles": [{"fill": "list", "positions": [[1, 1, 1], [3, 1, 1]], "radius": 0.5}],
    "contact": {"law": "granular", "restitution": 0.8, "contact_time": 0.05, "mu": 0.5},
}


def merged(snippet: str) -> dict[str, Any]:
    """BASE with the tables of a TOML snippet merged in (lists and values replaced)."""
    out = copy.deepcopy(BASE)

    def merge(into: dict[str, Any], new: dict[str, Any]) -> None:
        for key, value in new.items():
            if isinstance(value, dict) and isinstance(into.get(key), dict):
                merge(into[key], value)
            else:
                into[key] = value

    merge(out, tomllib.loads(snippet))
    return out


def is_run_config(path: Path) -> bool:
    """Sweep files (with ``base``/``overrides``) live in examples/ too; they are not runs."""
    data = tomllib.loads(path.read_text())
    return not ({"base", "overrides"} & data.keys())


@pytest.mark.parametrize("path", [p for p in EXAMPLES if is_run_config(p)], ids=lambda p: p.name)
def test_examples_load(path: Path) -> None:
    config = load_config(path)
    assert config.run.steps or config.run.duration
    resolved = resolved_dict(config)
    assert resolved["scenario"] == config.scenario


def test_the_required_examples_exist() -> None:
    names = {p.name for p in EXAMPLES}
    assert {"pile3d.toml", "soft2d.toml", "chute.toml"} <= names


def test_generic_examples_build() -> None:
    from grainflow.config.build import build_simulation

    for name in ("pile3d.toml", "soft2d.toml"):
        sim = build_simulation(load_config(EXAMPLES[0].parent / name))
        assert sim.state.n > 50
        assert 0 < sim.dt < sim.contact_time() / 10


def test_units_are_converted() -> None:
    data = merged('[run]\ndt = "10 us"\n[contact]\ncontact_time = "1 ms"\n')
    data["particles"][0]["radius"] = "200 um"
    data["particles"][0]["positions"] = [["1 mm", "1 mm", "1 mm"], ["3 mm", "1 mm", "1 mm"]]
    data["particles"][0]["density"] = "2.5 g/cm^3"
    data["box"]["hi"] = ["1 cm", "1 cm", "1 cm"]
    config = load_config(data)
    assert config.run.dt == pytest.approx(1e-5)
    assert config.particles[0].radius == [pytest.approx(2e-4)]
    assert config.particles[0].density == pytest.approx(2500.0)
    assert config.box.hi == [pytest.approx(0.01)] * 3


def test_resolved_config_round_trips(tmp_path: Path) -> None:
    import tomli_w

    config = load_config(BASE)
    path = tmp_path / "resolved.toml"
    path.write_text(tomli_w.dumps(resolved_dict(config)))
    again = load_config(path)
    assert again.model_dump() == config.model_dump()
    assert again.output.thermo_every == 100  # defaults are written out


def test_relative_files_resolve_against_the_config(tmp_path: Path) -> None:
    (tmp_path / "data").mkdir()
    data_file = tmp_path / "data" / "grains.data"
    data_file.write_text("x\n")
    config = dict(BASE, particles=[{"fill": "lammps_data", "file": "data/grains.data"}])
    path = tmp_path / "run.toml"
    import tomli_w

    path.write_text(tomli_w.dumps(config))
    assert load_config(path).particles[0].file == str(data_file.resolve())


def test_pair_overrides_inherit_the_defaults() -> None:
    data = merged("[[contact.pairs]]\ntypes = [0, 1]\nmu = 0.1\n")
    params = load_config(data).contact.pair_params()
    assert params[(0, 1)]["mu"] == 0.1
    assert params[(0, 1)]["restitution"] == 0.8
    assert params[(-1, -1)]["mu"] == 0.5


BAD_INPUTS = [
    # (TOML snippet merged into a valid config, dotted path the message must name)
    ('colour = "red"', "colour"),
    ("dim = 4", "dim"),
    ("[run]\nstep = 10", "run.step"),
    ('[run]\nsteps = "many"', "run.steps"),
    ("[run]\nsteps = 0", "run.steps"),
    ("[run]\nduration = 1.0", "run"),
    ("[run]\ndt = -1e-3", "run.dt"),
    ('[run]\ndt = "1 m"', "run.dt"),
    ('[run]\nintegrator = "euler"', "run.integrator"),
    ("[run]\nmax_overlap_fraction = 0", "run.max_overlap_fraction"),
    ("[output]\nframes_every = -1", "output.frames_every"),
    ("[output]\nfps = 3", "output.fps"),
    ("[box]\nlo = [0, 0]", "box.lo"),
    ("[box]\nhi = [10, 10, -1]", "box.hi"),
    ('particles = [{fill = "list", positions = [[1, 1, 1]], radius = -0.5}]',
     "particles[0].radius[0]"),
    ('particles = [{fill = "list", positions = [[1, 1, 1]], radius = "2 kg"}]',
     "particles[0].radius[0]"),
    ('particles = [{fill = "list", positions = [[1, 1, 1]], radius = "2 furlong"}]',
     "particles[0].radius[0]"),
    ('particles = [{fill = "list", positions = [[1, 1, 1]], radius = 0.5, density = -1}]',
     "particles[0].density"),
    ('particles = [{fill = "list", positions = [[1, 1]], radius = 0.5}]',
     "particles[0].positions[0]"),
    ('particles = [{fill = "list", positions = [[1, 1, 1]], radius = [0.5, 0.7], '
     'fractions = [1.0]}]', "particles[0].fractions"),
    ('particles = [{fill = "poured", radius = 0.5}]', "particles[0].fill"),
    ('particles = [{fill = "lattice", radius = 0.5, lattice = "hcp"}]', "particles[0].lattice"),
    ('particles = [{fill = "lattice", radius = 0.5, region = {shape = "box", lo = [0, 0, 0], '
     'hi = [1, 1, 1], colour = 1}}]', "particles[0].region.colour"),
    ('particles = [{fill = "lammps_data", file = "no/such.data"}]', "particles[0].file"),
    ("[contact]\nrestitution = 1.5", "contact.restitution"),
    ("[contact]\nrestitution = 0.0", "contact.restitution"),
    ("[contact]\nmu = -0.1", "contact.mu"),
    ('[contact]\ncontact_time = "-1 ms"', "contact.contact_time"),
    ('[contact]\nlaw = "hertz"', "contact.law"),
    ("[contact]\nkn = 1000.0", "contact"),  # kn and restitution/contact_time together
    ("[contact]\ncohesion_force = 1e-3", "contact.cohesion_range"),  # missing
    ("[[contact.pairs]]\ntypes = [0, 1]\nmu = -1.0", "contact.pairs[0].mu"),
    ("[[contact.pairs]]\ntypes = [0]\nmu = 0.1", "contact.pairs[0].types"),
    ("gravity = [0, -9.81]", "gravity"),
    ("drag = -0.5", "drag[0]"),
    ('walls = [{shape = "sphere", point = [0, 0, 0]}]', "walls[0].shape"),
    ('walls = [{shape = "plane", point = [0, 0, 0]}]', "walls[0].normal"),
    ('walls = [{shape = "cone", apex = [0, 0, 0], axis = [0, 0, 1], half_angle_deg = 95}]',
     "walls[0].half_angle_deg"),
    # directions are unitless and not all zero; a cylinder's hi is above its lo; an
    # insertion region is bounded (each was accepted, or failed later without a field name)
    ('walls = [{shape = "plane", point = [0, 0, 0], normal = [0, 0, "1 mm"]}]',
     "walls[0].normal[2]"),
    ('walls = [{shape = "plane", point = [0, 0, 0], normal = [0, 0, 0]}]', "walls[0].normal"),
    ('walls = [{shape = "cone", apex = [0, 0, 0], axis = [0, 0, 0], half_angle_deg = 30}]',
     "walls[0].axis"),
    ('particles = [{fill = "random", radius = 0.5, count = 2, region = {shape = "cylinder", '
     'center = [5, 5], radius = 2, lo = 8, hi = 2}}]', "particles[0].region.hi"),
    ('insert = [{kind = "pour", every = 10, radius = 0.5, per_insertion = 5, region = '
     '{shape = "halfspace", point = [0, 0, 5], normal = [0, 0, 1]}}]', "insert[0].region"),
    ('delete = [{every = 10, region = {shape = "halfspace", point = [0, 0, 5], '
     'normal = [0, 0, 0]}}]', "delete[0].region.normal"),
    ('scenario = "volcano"', "scenario"),
    ('scenario = "chute"\n[chute]\ndata_file = "no/such.data"', "chute.data_file"),
    ('scenario = "chute"\n[chute]\ndata_file = "x"', "box"),  # generic section in chute
]


@pytest.mark.parametrize(("snippet", "path"), BAD_INPUTS,
                         ids=[f"{k}-{p}" for k, (_, p) in enumerate(BAD_INPUTS)])
def test_bad_input_names_the_field(snippet: str, path: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_config(merged(snippet))
    assert any(m.startswith(f"{path}:") for m in info.value.messages), info.value.messages
    assert "\n" not in str(info.value)


def test_a_2d_grain_density_is_per_area() -> None:
    """A 2D grain is a disk: its density is mass per area, so "1 g/cm^2" is 10 kg/m^2 and a
    per-volume unit is refused rather than converted with the wrong power of length."""
    flat = {"dim": 2, "run": {"steps": 10}, "box": {"lo": [0, 0], "hi": [10, 10]},
            "particles": [{"fill": "list", "positions": [[1, 1], [3, 1]], "radius": 0.5,
                           "density": "1 g/cm^2"}],
            "contact": {"law": "granular", "restitution": 0.8, "contact_time": 0.05,
                        "mu": 0.5}}
    assert load_config(flat).particles[0].density == pytest.approx(10.0)
    flat["particles"][0]["density"] = "1 g/cm^3"
    with pytest.raises(ConfigError, match=r"^particles\[0\]\.density: .*expected areal density"):
        load_config(flat)
    with pytest.raises(ConfigError, match=r"^particles\[0\]\.density: .*expected density"):
        load_config(merged('particles = [{fill = "list", positions = [[1, 1, 1]], '
                           'radius = 0.5, density = "2.5 g/cm^2"}]'))
    assert load_config(merged('particles = [{fill = "list", positions = [[1, 1, 1]], '
                              'radius = 0.5, density = "2.5 g/cm^3"}]')
                       ).particles[0].density == pytest.approx(2500.0)


def test_messages_give_value_and_what_is_valid() -> None:
    with pytest.raises(ConfigError) as info:
        load_config(merged("[contact]\nrestitution = 1.5"))
    assert str(info.value) == ("contact.restitution: 1.5 is not valid; expected a finite "
                               "value > 0 and <= 1")
    with pytest.raises(ConfigError) as info:
        load_config(merged("[run]\nstep = 10"))
    assert "valid keys here:" in str(info.value) and "steps" in str(info.value)


# run.dt against the stability limit needs the built particles (their masses and sizes), so
# build_simulation checks it, not load_config (which stays free of the engine); the message
# is the same one-line, field-named ConfigError.
def test_dt_past_the_stability_limit_is_refused_when_built() -> None:
    from grainflow.config.build import build_simulation

    config = load_config(merged("[run]\ndt = 0.1"))
    with pytest.raises(ConfigError) as info:
        build_simulation(config)
    assert info.value.messages == [
        "run.dt: 0.1 exceeds the stability limit 0.0125 set by pair law "
        "hooke/viscous/history/constant, types (0, 0) (oscillation time 0.05); use "
        "dt <= 0.00333333, or leave dt out to get dt_fraction x the shortest time scale"]


def test_allow_unsafe_dt_lets_a_large_step_through() -> None:
    from grainflow.config.build import build_simulation

    sim = build_simulation(load_config(merged("[run]\ndt = 0.1\nallow_unsafe_dt = true")))
    assert sim.dt == 0.1


def test_unreadable_toml_is_a_config_error(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text("[run\nsteps = 1")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(path)


def test_scenarios_register_with_their_own_section() -> None:
    from pydantic import BaseModel, ConfigDict

    class Toy(BaseModel):
        model_config = ConfigDict(extra="forbid")
        size: float

    register(Scenario("toy", "grainflow.config.build:build_generic", section="toy", model=Toy,
                      uses=frozenset({"box"})))
    try:
        config = load_config({"scenario": "toy", "run": {"steps": 1}, "toy": {"size": 2},
                              "box": {"lo": [0, 0, 0], "hi": [1, 1, 1]}})
        assert config.section == Toy(size=2.0)
        assert resolved_dict(config)["toy"] == {"size": 2.0}
        with pytest.raises(ConfigError, match=r"^toy\.size: 'big' is not valid"):
            load_config({"scenario": "toy", "run": {"steps": 1}, "toy": {"size": "big"}})
    finally:
        del SCENARIOS["toy"]
    assert get_scenario("generic").name == "generic"


def test_every_field_is_documented() -> None:
    from pydantic import BaseModel

    from grainflow.config import schema

    doc = (Path(__file__).resolve().parents[1] / "docs" / "config.md").read_text()
    models = [m for m in vars(schema).values() if isinstance(m, type)
              and issubclass(m, BaseModel) and m.__module__ == schema.__name__]
    missing = {f"{m.__name__}.{name}" for m in models for name in m.model_fields
               if not re.search(rf"`\[*{name}\]*`", doc)}  # `name`, `[name]`, `[[name]]`
    assert not missing
