"""``[contact]`` comes from the sub-model registry: presets, named sub-models, per-pair
laws (several interactions), walls through each pair's law, and the generated reference in
docs/config.md."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grainflow.config.build import build_simulation
from grainflow.config.contact import reference_markdown, write_reference
from grainflow.config.schema import ConfigError, load_config
from grainflow.models.registry import SUBMODELS, submodel

DOCS = Path(__file__).resolve().parents[1] / "docs" / "config.md"


def _config(contact: dict, **extra) -> dict:
    return {
        "dim": 3, "run": {"steps": 5},
        "box": {"lo": [0, 0, 0], "hi": [10, 10, 10]},
        "particles": [{"fill": "list", "positions": [[1, 1, 1], [3, 1, 1]], "radius": 0.5},
                      {"fill": "list", "positions": [[1, 5, 1], [3, 5, 1]], "radius": 0.5,
                       "type": 1}],
        "contact": contact, **extra}


def test_a_named_sub_model_loads_with_units_and_builds() -> None:
    config = load_config(_config({"model": {"normal": "hertz", "tangential": "history"},
                                  "kn": "10 MPa", "kt": "2 kN/m", "mu": 0.4}))
    sim = build_simulation(config)
    (inter,) = sim.interactions
    assert inter.law.name == "hertz/none/history/none"
    assert inter.law.row(0, 1)["kn"] == pytest.approx(1e7)
    assert inter.law.row(0, 1)["kt"] == pytest.approx(2e3)


def test_a_preset_slot_can_be_replaced() -> None:
    config = load_config(_config({"law": "soft", "model": {"tangential": "history"},
                                  "epsilon": 10.0, "kt": 100.0, "mu": 0.3,
                                  "kinetic_on": "tangential"}))
    law = build_simulation(config).interactions[0].law
    assert law.name == "harmonic/kinetic/history/none"
    assert law.row(0, 0)["kinetic_on"] == 0.0


def test_pairs_with_another_law_become_another_interaction_and_meet_walls_through_it() -> None:
    config = load_config(_config(
        {"law": "granular", "kn": 1e4, "mu": 0.5,
         "pairs": [{"types": [1, 1], "law": "soft", "epsilon": 20.0},
                   {"types": [1, 2], "law": "soft", "epsilon": 40.0}]},
        walls=[{"shape": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "type": 2}],
        run={"steps": 5, "dt": 1e-4}))
    sim = build_simulation(config)
    laws = {i.law.name: i for i in sim.interactions}
    assert set(laws) == {"hooke/viscous/history/constant", "harmonic/kinetic/none/none"}
    assert laws["harmonic/kinetic/none/none"].types == frozenset({(1, 1), (1, 2)})
    walls = [f for f in sim.forces if type(f).__name__ == "WallForce"]
    assert sorted((f.law.name, tuple(f.particle_types)) for f in walls) == [
        ("harmonic/kinetic/none/none", (1,)), ("hooke/viscous/history/constant", (0,))]
    sim.run(5)


@pytest.mark.parametrize("contact, message", [
    ({"law": "soft", "epsilon": 1.0, "kn": 1.0},
     "contact.kn: not a parameter of the law harmonic/kinetic/none/none; it belongs to "
     "hooke (normal), hertz (normal)"),
    ({"law": "granular"}, "contact.kn: missing; the normal model 'hooke' needs it"),
    ({"model": {"normal": "hertz"}, "kn": "1 N/m"}, "contact.kn"),
    ({"kn": 1.0}, "contact.law: missing; choose a preset"),
    ({"law": "granular", "kn": 1.0, "pairs": [{"types": [0, 1], "mu": -1}]},
     "contact.pairs[0].mu: -1.0 is not valid; expected a finite value >= 0"),
    ({"law": "granular", "kn": 1.0, "model": {"normal": "spring"}}, "contact.model.normal"),
    ({"law": "soft", "epsilon": 1.0, "kinetic_on": "sideways"},
     "contact.kinetic_on: 'sideways' is not valid; use one of 'full', 'tangential'"),
])
def test_bad_contact_tables_name_the_field(contact, message) -> None:
    with pytest.raises(ConfigError) as info:
        load_config(_config(contact))
    assert any(m.startswith(message) for m in info.value.messages), info.value.messages


def test_every_registered_parameter_is_a_config_field() -> None:
    from grainflow.config.contact import Contact

    for slot, name in SUBMODELS:
        for p in submodel(slot, name).params:
            assert p.name in Contact.model_fields, (slot, name, p.name)


def test_docs_reference_is_generated_from_the_registry(tmp_path) -> None:
    """docs/config.md holds the current generated block; regenerate it with
    ``python -m grainflow.config.contact docs/config.md``."""
    copy = tmp_path / "config.md"
    copy.write_text(DOCS.read_text())
    assert not write_reference(copy), ("docs/config.md's [contact] reference is stale; run "
                                       "python -m grainflow.config.contact docs/config.md")
    for slot, name in SUBMODELS:
        assert f'`"{name}"`' in reference_markdown()


def test_the_documented_contact_example_loads_and_builds() -> None:
    import re
    import tomllib

    section = DOCS.read_text().split("## `[contact]`", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```toml\n(.*?)```", section, flags=re.S)
    contact = tomllib.loads(block)["contact"]
    sim = build_simulation(load_config(_config(contact)))
    names = sorted(i.law.name for i in sim.interactions)
    assert names == ["hertz/none/history/none", "hooke/viscous/history/constant"]
    assert np.isfinite(sim.dt)


def test_the_old_soft_friction_key_points_to_its_new_name() -> None:
    with pytest.raises(ConfigError, match=r"contact.mu: not a parameter of the law "
                                          r"harmonic/kinetic/none/none; it belongs to history "
                                          r"\(tangential\); did you mean 'mu_k'\?"):
        load_config(_config({"law": "soft", "epsilon": 1.0, "mu": 0.5}))


# --- a unit that follows an option: the harmonic epsilon (Param.dimension_by) -------------
def _contact_errors(contact: dict) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_config(_config(contact))
    return info.value.messages


def test_harmonic_epsilon_is_a_force_with_epsilon_scales_diameter() -> None:
    """With ``epsilon_scales = "diameter"`` (eps_mn = epsilon sigma_mn) epsilon is a force."""
    config = load_config(_config({"law": "soft", "epsilon_scales": "diameter",
                                  "epsilon": "2 N"}))
    assert config.contact.entry(0, 0)[1] == {"epsilon_scales": "diameter", "epsilon": 2.0}
    law = build_simulation(config).interactions[0].law
    assert law.row(0, 1)["epsilon"] == 2.0 and law.row(0, 1)["epsilon_scales"] == 1.0
    config = load_config(_config({"law": "soft", "epsilon": "100 nN",
                                  "epsilon_scales": "diameter"}))  # order does not matter
    assert config.contact.entry(0, 0)[1]["epsilon"] == pytest.approx(1e-7)
    (message,) = _contact_errors({"law": "soft", "epsilon_scales": "diameter",
                                  "epsilon": "2 J"})
    assert message.startswith("contact.epsilon: '2 J' has dimension energy, expected force"), \
        message
    assert "with epsilon_scales = 'diameter', epsilon is a force" in message, message


def test_harmonic_epsilon_is_an_energy_with_epsilon_scales_constant() -> None:
    for given in ({"epsilon_scales": "constant"}, {}):  # "constant" is the default
        config = load_config(_config({"law": "soft", "epsilon": "2 J", **given}))
        assert config.contact.entry(0, 0)[1]["epsilon"] == 2.0
        (message,) = _contact_errors({"law": "soft", "epsilon": "2 N", **given})
        assert message.startswith("contact.epsilon: '2 N' has dimension force, expected "
                                  "energy"), message
        assert "with epsilon_scales = 'constant', epsilon is an energy" in message, message
    # a bare number has no unit to check (reduced units), with either option
    for scales in ("constant", "diameter"):
        config = load_config(_config({"law": "soft", "epsilon": 2, "epsilon_scales": scales}))
        assert config.contact.entry(0, 0)[1]["epsilon"] == 2.0


def test_an_override_that_changes_epsilon_scales_checks_the_inherited_epsilon_again() -> None:
    (message,) = _contact_errors({"law": "soft", "epsilon": "2 J",
                                  "pairs": [{"types": [0, 1], "epsilon_scales": "diameter"}]})
    assert message.startswith("contact.pairs[0].epsilon: '2 J' has dimension energy, "
                              "expected force"), message
    assert "inherited from [contact]" in message, message
    config = load_config(_config({"law": "soft", "epsilon": "2 J", "pairs": [
        {"types": [0, 1], "epsilon_scales": "diameter", "epsilon": "3 nN"},
        {"types": [1, 1], "mu_k": 0.2}]}))
    assert config.contact.entry(0, 1)[1] == {"epsilon_scales": "diameter",
                                             "epsilon": pytest.approx(3e-9)}
    assert config.contact.entry(1, 1)[1] == {"epsilon": 2.0, "mu_k": 0.2}


def test_the_reference_gives_the_unit_of_epsilon_for_each_option(tmp_path) -> None:
    text = reference_markdown()
    line = next(s for s in text.splitlines() if s.lstrip().startswith("- `epsilon` ("))
    assert ('energy if `epsilon_scales = "constant"`, force if `epsilon_scales = "diameter"`'
            in line), line
    assert line in DOCS.read_text()  # docs/config.md holds it (regenerated)


def test_dimension_by_must_name_a_choice_of_the_same_sub_model() -> None:
    from grainflow.models.submodel import NormalModel, Param

    eps = Param("epsilon", "x", dimension_by=("scales", {"a": "energy", "b": "force"}))
    assert eps.dimension_for({"scales": "b"}) == "force"
    with pytest.raises(TypeError, match="dimension_by"):
        type("Bad", (NormalModel,), {"params": (eps,)})
    with pytest.raises(TypeError, match="dimension_by"):
        type("Bad", (NormalModel,), {"params": (
            eps, Param("scales", "y", default="a", choices={"a": 0.0, "c": 1.0}))})
    with pytest.raises(TypeError, match="dimension_by"):
        Param("epsilon", "x", "energy", dimension_by=("scales", {"a": "energy"}))
