"""Quantities with units written out (``"200 um"``, ``"2.5e3 kg/m^3"``), converted to SI.

Grammar: a number, optionally followed by a unit expression. A unit expression is a product
of factors separated by spaces, ``*`` or ``·``; ``/`` divides by the factor that follows it
(``kg/m/s`` = kg m^-1 s^-1). A factor is an optional prefix (n, u or µ, m, c, k, M, G) and a
unit (m, s, g, N, Pa, J; ``kg`` is kilo-gram), with an optional integer power written ``^2``,
``**2``, ``²`` or ``³`` (``s^-1``). ``1`` is allowed as a factor (``1/s``). Plain numbers carry
no unit and pass through unchanged, so reduced-unit studies can write bare numbers.
"""

from __future__ import annotations

import re
from decimal import Decimal
from typing import Annotated, Any

from pydantic import BeforeValidator, Field

__all__ = ["DIMENSIONS", "parse_quantity", "parse_unit", "quantity"]

Dim = tuple[int, int, int]  # exponents of (mass, length, time)

# unit -> (power of ten of its SI value, dimension); all scales are powers of ten, so a
# conversion is an exact decimal shift of the number as written.
_UNITS: dict[str, tuple[int, Dim]] = {
    "1": (0, (0, 0, 0)),
    "m": (0, (0, 1, 0)),
    "s": (0, (0, 0, 1)),
    "g": (-3, (1, 0, 0)),
    "N": (0, (1, 1, -2)),
    "Pa": (0, (1, -1, -2)),
    "J": (0, (1, 2, -2)),
}
_PREFIXES = {"n": -9, "u": -6, "µ": -6, "μ": -6, "m": -3, "c": -2, "k": 3, "M": 6, "G": 9}

#: Named dimensions accepted as ``expected_dimension``, with an example unit for messages.
DIMENSIONS: dict[str, tuple[Dim, str]] = {
    "dimensionless": ((0, 0, 0), ""),
    "length": ((0, 1, 0), "um"),
    "time": ((0, 0, 1), "ms"),
    "mass": ((1, 0, 0), "mg"),
    "force": ((1, 1, -2), "nN"),
    "pressure": ((1, -1, -2), "Pa"),
    "energy": ((1, 2, -2), "J"),
    "velocity": ((0, 1, -1), "m/s"),
    "acceleration": ((0, 1, -2), "m/s^2"),
    "density": ((1, -3, 0), "kg/m^3"),
    "areal density": ((1, -2, 0), "kg/m^2"),  # 2D grains: mass per unit area
    "stiffness": ((1, 0, -2), "N/m"),
    "frequency": ((0, 0, -1), "1/s"),
    "damping": ((1, 0, -1), "kg/s"),
    "area": ((0, 2, 0), "mm^2"),
    "volume": ((0, 3, 0), "mm^3"),
}
_NAMES = {dim: name for name, (dim, _) in DIMENSIONS.items()}

_NUMBER = re.compile(r"\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*", re.S)
_TOKEN = re.compile(  # one factor (symbol with optional power) or one operator
    r"\s*(?:(?P<symbol>[A-Za-zµμ]+|1)(?:(?:\^|\*\*)(?P<power>[+-]?\d+)|(?P<super>[²³]))?"
    r"|(?P<op>[*·/]))\s*"
)
_SUPERSCRIPTS = {"²": 2, "³": 3}
_HELP = "units m, s, g, N, Pa, J with prefixes n, u (µ), m, c, k, M, G, combined like 'kg/m^3'"


def parse_quantity(value: object, expected_dimension: str | None = None, field: str = "value") -> float:
    """Convert ``value`` to an SI float.

    ``value`` is a number (returned unchanged, as a float) or a string: a number with an
    optional unit expression (see the module docstring). ``expected_dimension`` is a name
    from :data:`DIMENSIONS` or a unit expression (``"N/m"``) whose dimension the unit must
    have; None accepts any. A unitless string such as ``"3.5"`` passes through like a number.
    Raises ValueError naming ``field``, the value and what would be valid.
    """
    expected = _expected(expected_dimension)
    example = _example(expected)
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ValueError(
            f"{field}: expected a number or a string like {example}, got {type(value).__name__} {value!r}"
        )
    if not isinstance(value, str):
        return float(value)
    match = _NUMBER.fullmatch(value)
    if match is None:
        raise ValueError(f"{field}: {value!r} is not a number with an optional unit (e.g. {example})")
    number, unit = match.group(1), match.group(2)
    if not unit:
        return float(number)
    try:
        exponent, dim = _parse_unit(unit)
    except ValueError as err:
        raise ValueError(f"{field}: {value!r}: {err} (e.g. {example})") from None
    if expected is not None and dim != expected:
        raise ValueError(
            f"{field}: {value!r} has dimension {_describe(dim)}, "
            f"expected {_describe(expected)} (e.g. {example})"
        )
    return float(Decimal(number).scaleb(exponent))


def parse_unit(expression: str) -> tuple[float, Dim]:
    """SI factor and (mass, length, time) exponents of a unit expression like ``"kg/m^3"``."""
    exponent, dim = _parse_unit(expression)
    return 10.0**exponent, dim


def _parse_unit(expression: str) -> tuple[int, Dim]:
    """Power of ten of the SI factor, and dimension, of a unit expression."""
    text = expression.strip()
    exponent, dim = 0, (0, 0, 0)
    pos, operator, seen_factor = 0, "", False
    while pos < len(text):
        token = _TOKEN.match(text, pos)
        if token is None:
            raise ValueError(f"cannot read unit {expression!r} at {text[pos:]!r}; use {_HELP}")
        pos = token.end()
        if token["op"]:
            if operator or not seen_factor:
                raise ValueError(f"misplaced {token['op']!r} in unit {expression!r}")
            operator = token["op"]
            continue
        if token["symbol"] == "1" and (seen_factor or operator):
            raise ValueError(f"'1' may only start a unit, as in '1/s'; got {expression!r}")
        unit_exponent, unit_dim = _unit(token["symbol"], expression)
        power = int(token["power"]) if token["power"] else _SUPERSCRIPTS.get(token["super"], 1)
        power = -power if operator == "/" else power
        exponent += power * unit_exponent
        dim = (dim[0] + power * unit_dim[0], dim[1] + power * unit_dim[1], dim[2] + power * unit_dim[2])
        operator, seen_factor = "", True
    if operator or not seen_factor:
        raise ValueError(f"unit {expression!r} is empty or ends with an operator")
    return exponent, dim


def _unit(symbol: str, expression: str) -> tuple[int, Dim]:
    """Power of ten and dimension of one (possibly prefixed) unit symbol."""
    if symbol in _UNITS:
        return _UNITS[symbol]
    prefix, base = symbol[:1], symbol[1:]
    if prefix in _PREFIXES and base in _UNITS and base != "1":
        exponent, dim = _UNITS[base]
        return _PREFIXES[prefix] + exponent, dim
    where = f" in {expression!r}" if expression.strip() != symbol else ""
    raise ValueError(f"unknown unit {symbol!r}{where}; known are {_HELP}")


def _expected(expected_dimension: str | None) -> Dim | None:
    """Dimension tuple for a dimension name or unit expression (None passes through)."""
    if expected_dimension is None:
        return None
    if expected_dimension in DIMENSIONS:
        return DIMENSIONS[expected_dimension][0]
    try:
        return _parse_unit(expected_dimension)[1]
    except ValueError:
        raise ValueError(
            f"expected_dimension={expected_dimension!r} is neither one of {sorted(DIMENSIONS)} "
            "nor a unit expression"
        ) from None


def _describe(dim: Dim) -> str:
    """Name of a dimension, or its expression in SI base units."""
    if dim in _NAMES:
        return _NAMES[dim]
    parts = [f"{unit}^{power}" if power != 1 else unit for unit, power in zip(("kg", "m", "s"), dim) if power]
    return " ".join(parts)


def _example(dim: Dim | None) -> str:
    """A valid input for a dimension, used in error messages."""
    if dim is None:
        return "'200 um'"
    unit = DIMENSIONS[_NAMES[dim]][1] if dim in _NAMES else _describe(dim)
    return f"'200 {unit}'" if unit else "'200'"


def _to_si(dimension: str | None) -> BeforeValidator:
    def convert(value: Any) -> Any:
        try:
            return parse_quantity(value, dimension, field="\0")
        except ValueError as err:
            raise ValueError(str(err).removeprefix("\0: ")) from None
    # the dimension, read by grainflow.config.reference for the field's SI unit
    convert.dimension = dimension  # type: ignore[attr-defined]
    return BeforeValidator(convert)


def quantity(dimension: str | None, **constraints: Any) -> Any:
    """A pydantic float field type that may be written with a unit of ``dimension`` and is
    converted to SI (``quantity("length", gt=0)`` accepts ``"200 um"`` and stores 2e-4);
    used by the config schema and by scenario sections written in SI units."""
    if constraints.pop("allow_inf_nan", False):  # pydantic's float default
        return Annotated[float, _to_si(dimension), Field(**constraints)]
    return Annotated[float, _to_si(dimension), Field(allow_inf_nan=False, **constraints)]
