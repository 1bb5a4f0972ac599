"""Progress reports of long runs: a rich bar on a terminal, plain lines elsewhere.

:func:`make_progress` picks the display: ``"rich"`` (bar, ETA, particle-steps/s) when the
stream is a terminal, ``"plain"`` (one line every ``interval`` seconds, for CI logs and sweep
workers) otherwise; ``"none"`` prints nothing. Every display has the same three calls::

    with make_progress("auto") as p:
        p.start(total=10_000, done=0)
        p.update(step=5000, n=1200, rate=2.1e6)
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from rich.console import Console
from rich.progress import (BarColumn, MofNCompleteColumn, Progress as RichBar, TextColumn,
                           TimeRemainingColumn)

__all__ = ["PlainProgress", "Progress", "RichProgress", "make_progress"]


class Progress:
    """A display that shows nothing; base class of the others."""

    def start(self, total: int, done: int = 0) -> None:
        """Announce ``total`` steps, of which ``done`` are already done (a resumed run)."""

    def update(self, step: int, n: int, rate: float) -> None:
        """Report that the run is at ``step`` with ``n`` particles and ``rate``
        particle-steps per second."""

    def close(self) -> None:
        """Finish the display."""

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RichProgress(Progress):
    """A live bar with steps done, ETA and particle-steps/s (terminals)."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self._bar = RichBar(
            BarColumn(bar_width=20), MofNCompleteColumn(), TextColumn("eta"),
            TimeRemainingColumn(), TextColumn("{task.fields[info]}"),
            console=Console(file=stream or sys.stdout), transient=False)
        self._task = None

    def start(self, total: int, done: int = 0) -> None:
        self._bar.start()
        self._task = self._bar.add_task("run", total=total, completed=done, info="")

    def update(self, step: int, n: int, rate: float) -> None:
        self._bar.update(self._task, completed=step, info=f"N={n} {rate:.3g} particle-steps/s")

    def close(self) -> None:
        self._bar.stop()


class PlainProgress(Progress):
    """One line per ``interval`` seconds: step, percentage, N, particle-steps/s, ETA."""

    def __init__(self, stream: TextIO | None = None, interval: float = 10.0) -> None:
        self.stream = stream or sys.stdout
        self.interval = float(interval)
        self._total = 0
        self._last = 0.0
        self._t0 = 0.0
        self._done0 = 0
        self._step = 0

    def start(self, total: int, done: int = 0) -> None:
        self._total, self._done0, self._step = total, done, done
        self._t0 = self._last = time.perf_counter()
        self._print(f"run: {total} steps" + (f", resuming at step {done}" if done else ""))

    def update(self, step: int, n: int, rate: float) -> None:
        self._step = step
        now = time.perf_counter()
        if now - self._last < self.interval:
            return
        self._last = now
        pct = 100.0 * step / self._total if self._total else 100.0
        speed = (step - self._done0) / (now - self._t0) if now > self._t0 else 0.0
        eta = (self._total - step) / speed if speed > 0 else float("inf")
        self._print(f"step {step}/{self._total} ({pct:.1f}%)  N={n}  "
                    f"{rate:.3g} particle-steps/s  eta {_clock(eta)}")

    def close(self) -> None:
        if self._total:
            self._print(f"step {self._step}/{self._total} done in "
                        f"{_clock(time.perf_counter() - self._t0)}")

    def _print(self, line: str) -> None:
        print(line, file=self.stream, flush=True)


def make_progress(mode: str = "auto", stream: TextIO | None = None,
                  interval: float = 10.0) -> Progress:
    """``"auto"`` (rich on a terminal, plain otherwise), ``"rich"``, ``"plain"`` or ``"none"``."""
    stream = stream or sys.stdout
    if mode == "auto":
        mode = "rich" if stream.isatty() else "plain"
    if mode == "rich":
        return RichProgress(stream)
    if mode == "plain":
        return PlainProgress(stream, interval)
    if mode == "none":
        return Progress()
    raise ValueError(f"progress: {mode!r} is not valid; use auto, rich, plain or none")


def _clock(seconds: float) -> str:
    if seconds == float("inf"):
        return "?"
    s = int(round(seconds))
    return f"{s // 3600:d}:{s // 60 % 60:02d}:{s % 60:02d}"
