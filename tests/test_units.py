"""Parsing quantities with units written out."""

from __future__ import annotations

import pytest

from grainflow.units import DIMENSIONS, parse_quantity, parse_unit


@pytest.mark.parametrize(
    ("text", "dimension", "si"),
    [
        ("200 um", "length", 2e-4),
        ("200um", "length", 2e-4),
        ("200 µm", "length", 2e-4),
        ("200 μm", "length", 2e-4),
        ("3 mm", "length", 3e-3),
        ("2.5 cm", "length", 0.025),
        ("1.5 km", "length", 1500.0),
        ("100 nN", "force", 1e-7),
        ("3 kN", "force", 3000.0),
        ("2.5e3 kg/m^3", "density", 2500.0),
        ("2.5 g/cm^3", "density", 2500.0),
        ("2.5 g/cm³", "density", 2500.0),
        ("2.5e3 kg m^-3", "density", 2500.0),
        ("9.81 m/s^2", "acceleration", 9.81),
        ("9.81 m/s**2", "acceleration", 9.81),
        ("9.81 m/s²", "acceleration", 9.81),
        ("10 cm/s", "velocity", 0.1),
        ("0.2 ms", "time", 2e-4),
        ("5 us", "time", 5e-6),
        ("4e5 N/m", "stiffness", 4e5),
        ("4e5 N/m", "kg/s^2", 4e5),  # expected dimension as a unit expression
        ("1 GPa", "pressure", 1e9),
        ("70 MPa", "pressure", 7e7),
        ("2 mJ", "energy", 2e-3),
        ("3 N*m", "energy", 3.0),
        ("3 N·m", "energy", 3.0),
        ("50 1/s", "frequency", 50.0),
        ("50 s^-1", "frequency", 50.0),
        ("0.3 kg/s", "damping", 0.3),
        ("1 Mg", "mass", 1000.0),
        ("-4 mm", "length", -4e-3),
        ("+.5 m", "length", 0.5),
        ("1e-3 m", None, 1e-3),
        ("  7 m  ", "length", 7.0),
        ("0.5 m/m", "dimensionless", 0.5),
    ],
)
def test_converts_to_si(text, dimension, si):
    assert parse_quantity(text, dimension, "f") == pytest.approx(si, rel=1e-15)


@pytest.mark.parametrize(("text", "si"), [("200 um", 0.0002), ("100 nN", 1e-7), ("0.1 mm", 0.0001)])
def test_conversion_is_exact_decimal_shift(text, si):
    assert parse_quantity(text, None, "f") == si  # not 200 * 1e-6 = 0.00019999999999999998


@pytest.mark.parametrize("value", [3, 2.5, -1e-9, 0, "3.5", "1e-4", " 42 "])
def test_plain_numbers_pass_through_unchanged(value):
    result = parse_quantity(value, "length", "geometry.radius")
    assert isinstance(result, float) and result == float(value)


@pytest.mark.parametrize(
    ("value", "expected", "message"),
    [
        ("200 uN", "length", "geometry.radius: '200 uN' has dimension force, expected length (e.g. '200 um')"),
        ("3 kg/m^3", "stiffness", "has dimension density, expected stiffness (e.g. '200 N/m')"),
        ("3 kg/m^4", "length", "has dimension kg m^-4, expected length"),
        ("5 m", "dimensionless", "has dimension length, expected dimensionless (e.g. '200')"),
        ("200 furlong", "length", "unknown unit 'furlong'; known are units m, s, g, N, Pa, J"),
        ("200 um/hr", "velocity", "unknown unit 'hr' in 'um/hr'"),
        ("200 Xm", None, "unknown unit 'Xm'"),
        ("200 mx", None, "unknown unit 'mx'"),
        ("abc", "length", "geometry.radius: 'abc' is not a number with an optional unit (e.g. '200 um')"),
        ("", "length", "is not a number"),
        ("m 200", "length", "is not a number"),
        ("3 m/", "length", "ends with an operator"),
        ("3 /m", None, "misplaced '/'"),
        ("3 m//s", None, "misplaced '/'"),
        ("3 m^x", None, "cannot read unit 'm^x'"),
        ("3 m(s)", None, "cannot read unit"),
        ("3 m 1", None, "'1' may only start a unit"),
        (True, "length", "expected a number or a string like '200 um', got bool"),
        (None, "length", "got NoneType"),
        ([200, "um"], "length", "got list"),
    ],
)
def test_bad_inputs_name_field_value_and_fix(value, expected, message):
    with pytest.raises(ValueError) as info:
        parse_quantity(value, expected, "geometry.radius")
    text = str(info.value)
    assert text.startswith("geometry.radius: ")
    assert message in text


def test_unknown_expected_dimension_is_a_programming_error():
    with pytest.raises(ValueError, match="expected_dimension='lenght' is neither one of"):
        parse_quantity("3 m", "lenght", "f")


def test_parse_unit_and_dimension_table():
    assert parse_unit("kg/m^3") == (1.0, (1, -3, 0))
    factor, dim = parse_unit("um")
    assert factor == pytest.approx(1e-6) and dim == (0, 1, 0)
    assert parse_unit("N/m") == (1.0, DIMENSIONS["stiffness"][0])
    for name, (dim, example) in DIMENSIONS.items():  # every example unit has its dimension
        assert parse_quantity(f"200 {example}", name, name) == pytest.approx(
            200 * parse_unit(example)[0] if example else 200.0
        )
