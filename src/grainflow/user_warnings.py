"""Warnings that point at the user's line.

A warning raised deep inside grainflow (the time-step check that :meth:`Simulation.run`
calls, a pour that places fewer grains than asked) is about the user's call, not the
library's: with a fixed ``stacklevel`` Python reports the library line that happened to call
the check. :func:`warn_user` reports the first frame outside the package instead, so the
warning names the line of the script, test or notebook cell that made the call.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

__all__ = ["warn_user"]

#: files under this directory are grainflow's own
PACKAGE_DIR = str(Path(__file__).resolve().parent) + os.sep


def _outside_stacklevel() -> int:
    """The ``stacklevel`` of the first frame, above the caller of :func:`warn_user`, whose
    file is not in the grainflow package (the outermost frame when all are)."""
    frame = sys._getframe(2)  # the function that called warn_user
    level = 2
    while frame.f_back is not None:
        frame = frame.f_back
        level += 1
        if not str(Path(frame.f_code.co_filename).resolve()).startswith(PACKAGE_DIR):
            return level
    return level


def warn_user(message: str, category: type[Warning] = UserWarning) -> None:
    """``warnings.warn(message, category)`` attributed to the user's line (module
    docstring)."""
    warnings.warn(message, category, stacklevel=_outside_stacklevel())
