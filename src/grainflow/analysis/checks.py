"""What the analyses share at their edges: argument checks (a number converted to float, or a
ValueError that names the argument, the value and what would be valid), the iteration over
one frame or many, and read-only copies of results."""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
from numpy.typing import ArrayLike

from grainflow.frame import Frame

__all__ = ["each_frame", "finite", "frozen", "non_negative", "paired_arrays", "positive"]


def frozen(values: ArrayLike, dtype: type = float) -> np.ndarray:
    """A read-only copy of ``values`` (results never alias the caller's arrays)."""
    out = np.array(values, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


def each_frame(frames: Frame | Iterable[Frame], *, dim: int | None = None,
               who: str = "the analysis") -> Iterator[Frame]:
    """The frames of a Frame or an iterable of Frames, each checked to be a Frame (and of
    dimension ``dim`` when given; ``who`` names the analysis in that message)."""
    if isinstance(frames, Frame):
        frames = [frames]
    try:
        iterator = iter(frames)
    except TypeError:
        raise ValueError(f"frames: expected a Frame or an iterable of Frames, got "
                         f"{type(frames).__name__}") from None
    for frame in iterator:
        if not isinstance(frame, Frame):
            raise ValueError(f"frames: expected Frame objects, got {type(frame).__name__}")
        if dim is not None and frame.dim != dim:
            raise ValueError(f"frames: expected {dim}D frames for {who}, got a "
                             f"{frame.dim}D frame at step {frame.step}")
        yield frame


def paired_arrays(x_name: str, x: ArrayLike, y_name: str, y: ArrayLike
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``x`` as a 1-D float array and ``y`` as a float array of its shape."""
    xa = np.asarray(x, dtype=float)
    ya = np.asarray(y, dtype=float)
    if xa.ndim != 1:
        raise ValueError(f"{x_name}: expected a 1-D array, got shape {xa.shape}")
    if ya.shape != xa.shape:
        raise ValueError(f"{y_name}: expected shape {xa.shape} like {x_name}, got {ya.shape}")
    return xa, ya


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
