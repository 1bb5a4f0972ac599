"""The start-up interrupt: SIGINT or SIGTERM while the program's modules are imported.

A signal handler raises :class:`KeyboardInterrupt` wherever Python happens to be; inside a
C extension's import (numba's, for one) that extension may replace it with its own
``ImportError``. :func:`install` therefore records that an interrupt arrived, so that the
program reports "interrupted" (exit 130) whatever exception the interrupted import left.
Where Python cannot raise at all (the interrupt lands in a callback of its import machinery,
e.g. a module lock's weak-reference callback), it prints the exception as "ignored" with a
traceback and goes on: :func:`install` keeps that quiet for the interrupts it recorded, and
the program reports them once the imports are done.
Runs replace these handlers with their own (checkpoint, then exit 130 / 143).
:func:`run` does the same for a script's ``main`` (the sweeps of ``scripts/``)."""

import signal
import sys
from collections.abc import Callable
from types import FrameType
from typing import Any

_received: list[int] = []


def _handler(signum: int, frame: FrameType | None) -> None:
    _received.append(signum)
    raise KeyboardInterrupt


def _unraisable(previous: Any) -> Any:
    """A ``sys.unraisablehook`` silent for a recorded interrupt, ``previous`` otherwise."""

    def hook(info: Any) -> None:
        if _received and isinstance(info.exc_value, KeyboardInterrupt):
            return
        previous(info)

    return hook


def install() -> None:
    """Make SIGINT and SIGTERM raise :class:`KeyboardInterrupt`, and remember them."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _handler)
    sys.unraisablehook = _unraisable(sys.unraisablehook)


def received() -> bool:
    """True once an interrupt has arrived through :func:`install`'s handler."""
    return bool(_received)


def run(main: Callable[[], object]) -> None:
    """Run a script's ``main`` as the ``grainflow`` program runs a verb: Ctrl-C and SIGTERM
    stop it (a sweep sets its running points back to pending and closes its workers, so a
    rerun continues it), and the script exits 130 with one line, not a traceback."""
    install()
    try:
        main()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
