"""Argument checks shared by the analyses: a number converted to float, or a ValueError that
names the argument, the value and what would be valid."""

from __future__ import annotations

import numpy as np

__all__ = ["finite", "non_negative", "positive"]


def _number(name: str, value: float, expected: str) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected {expected}, got {value!r}") from None


def positive(name: str, value: float) -> float:
    """``value`` as a float if it is finite and > 0."""
    x = _number(name, value, "a positive number")
    if not (np.isfinite(x) and x > 0):
        raise ValueError(f"{name}: expected a positive finite number, got {value!r}")
    return x


def non_negative(name: str, value: float) -> float:
    """``value`` as a float if it is finite and >= 0."""
    x = _number(name, value, "a number >= 0")
    if not (np.isfinite(x) and x >= 0):
        raise ValueError(f"{name}: expected a finite number >= 0, got {value!r}")
    return x


def finite(name: str, value: float) -> float:
    """``value`` as a float if it is finite."""
    x = _number(name, value, "a finite number")
    if not np.isfinite(x):
        raise ValueError(f"{name}: expected a finite number, got {value!r}")
    return x
