"""The start-up interrupt: SIGINT or SIGTERM while the program's modules are imported.

A signal handler raises :class:`KeyboardInterrupt` wherever Python happens to be; inside a
C extension's import (numba's, for one) that extension may replace it with its own
``ImportError``. :func:`install` therefore records that an interrupt arrived, so that the
program reports "interrupted" (exit 130) whatever exception the interrupted import left.
Runs replace these handlers with their own (checkpoint, then exit 130 / 143)."""

import signal
from types import FrameType

_received: list[int] = []


def _handler(signum: int, frame: FrameType | None) -> None:
    _received.append(signum)
    raise KeyboardInterrupt


def install() -> None:
    """Make SIGINT and SIGTERM raise :class:`KeyboardInterrupt`, and remember them."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _handler)


def received() -> bool:
    """True once an interrupt has arrived through :func:`install`'s handler."""
    return bool(_received)
