"""Where a damaged output file goes: next to it, under a name that never replaces another."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["damaged_name", "move_aside"]


def damaged_name(path: Path) -> Path:
    """``<name>.damaged``, or the first free ``<name>.damaged.<i>``: an earlier one is kept."""
    candidate = path.with_name(path.name + ".damaged")
    i = 0
    while candidate.exists():
        i += 1
        candidate = path.with_name(f"{path.name}.damaged.{i}")
    return candidate


def move_aside(path: Path) -> Path:
    """Rename ``path`` to :func:`damaged_name` and return the new path."""
    target = damaged_name(path)
    os.replace(path, target)
    return target
