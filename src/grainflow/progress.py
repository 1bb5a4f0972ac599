"""Progress reports of long tasks: a rich bar on a terminal, plain lines elsewhere.

Two families, with the same four modes (``"auto"``: rich on a terminal, plain otherwise;
``"rich"``; ``"plain"``; ``"none"``):

* :func:`make_progress`, for a simulation run: ``"rich"`` (bar, ETA, particle-steps/s),
  ``"plain"`` (one line every ``interval`` seconds, for CI logs and sweep workers). Every
  display has the same three calls::

      with make_progress("auto") as p:
          p.start(total=10_000, done=0)
          p.update(step=5000, n=1200, rate=2.1e6)

* :func:`make_item_progress`, for counting items of any kind (frames rendered, runs done,
  analysis phases), with an estimate of the time left from the mean time per item so far::

      with make_item_progress("auto", total=120, label="frame") as p:
          for frame in frames:
              render(frame)
              p.advance(info=f"step {frame.step}")

  A plain display prints ``frame 40/120 (33.3%)  eta 0:00:12  step 4000`` at most once every
  ``interval`` seconds, a first line when it starts and a last one with the time taken.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from rich.console import Console
from rich.progress import (BarColumn, MofNCompleteColumn, Progress as RichBar, TextColumn,
                           TimeRemainingColumn)

__all__ = ["ItemProgress", "PlainItemProgress", "PlainProgress", "Progress",
           "RichItemProgress", "RichProgress", "hms", "make_item_progress", "make_progress"]


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
                    f"{rate:.3g} particle-steps/s  eta {hms(eta)}")

    def close(self) -> None:
        if self._total:
            self._print(f"step {self._step}/{self._total} done in "
                        f"{hms(time.perf_counter() - self._t0)}")

    def _print(self, line: str) -> None:
        print(line, file=self.stream, flush=True)


def make_progress(mode: str = "auto", stream: TextIO | None = None,
                  interval: float = 10.0) -> Progress:
    """``"auto"`` (rich on a terminal, plain otherwise), ``"rich"``, ``"plain"`` or ``"none"``."""
    stream = stream or sys.stdout
    mode = _mode(mode, stream)
    if mode == "rich":
        return RichProgress(stream)
    if mode == "plain":
        return PlainProgress(stream, interval)
    return Progress()


# ----------------------------------------------------------------------------- item counts
class ItemProgress:
    """Progress over ``total`` items of one kind (``label``: its singular noun, e.g.
    ``"frame"``, ``"run"``, ``"phase"``); shows nothing. Base class of the displays made by
    :func:`make_item_progress`.

    Call :meth:`advance` after each item (or ``k`` items) and :meth:`close` at the end, or
    use the display as a context manager, which closes it. ``done`` is the count so far.
    """

    def __init__(self, total: int, label: str = "item") -> None:
        if total < 0:
            raise ValueError(f"progress: total={total!r}; expected a count >= 0")
        self.total = int(total)
        self.label = label
        self.done = 0
        self._t0 = time.perf_counter()

    def advance(self, k: int = 1, info: str = "") -> None:
        """Count ``k`` more items as done; ``info``: a short note shown with the count (the
        item just finished, a current value)."""
        self.done += k

    def close(self) -> None:
        """Finish the display (safe to call twice)."""

    @property
    def elapsed(self) -> float:
        """Seconds since the display was made."""
        return time.perf_counter() - self._t0

    def eta(self) -> float:
        """Seconds left at the mean time per item so far (inf before the first item)."""
        if self.done <= 0:
            return float("inf")
        return max(self.total - self.done, 0) * self.elapsed / self.done

    def __enter__(self) -> "ItemProgress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RichItemProgress(ItemProgress):
    """A live bar on a terminal: label, bar, done/total, eta, the latest ``info``."""

    def __init__(self, total: int, label: str = "item", stream: TextIO | None = None) -> None:
        super().__init__(total, label)
        self._bar = RichBar(
            TextColumn(label), BarColumn(bar_width=20), MofNCompleteColumn(), TextColumn("eta"),
            TimeRemainingColumn(), TextColumn("{task.fields[info]}"),
            console=Console(file=stream or sys.stdout), transient=False)
        self._task = self._bar.add_task(label, total=self.total, info="")
        self._bar.start()
        self._open = True

    def advance(self, k: int = 1, info: str = "") -> None:
        super().advance(k, info)
        self._bar.update(self._task, completed=self.done, info=info)

    def close(self) -> None:
        if self._open:
            self._open = False
            self._bar.stop()


class PlainItemProgress(ItemProgress):
    """Plain lines for logs: one at the start, then ``label done/total (pct)  eta H:MM:SS
    info`` at most once per ``interval`` seconds (and for the last item), and one at the end
    with the time taken."""

    def __init__(self, total: int, label: str = "item", stream: TextIO | None = None,
                 interval: float = 10.0) -> None:
        super().__init__(total, label)
        self.stream = stream or sys.stdout
        self.interval = float(interval)
        self._last = self._t0
        self._open = True
        self._print(f"{label} 0/{self.total}")

    def advance(self, k: int = 1, info: str = "") -> None:
        super().advance(k, info)
        now = time.perf_counter()
        if now - self._last < self.interval and self.done < self.total:
            return
        self._last = now
        pct = 100.0 * self.done / self.total if self.total else 100.0
        note = f"  {info}" if info else ""
        self._print(f"{self.label} {self.done}/{self.total} ({pct:.1f}%)  "
                    f"eta {hms(self.eta())}{note}")

    def close(self) -> None:
        if self._open:
            self._open = False
            self._print(f"{self.label} {self.done}/{self.total} done in {hms(self.elapsed)}")

    def _print(self, line: str) -> None:
        print(line, file=self.stream, flush=True)


def make_item_progress(mode: str = "auto", total: int = 0, label: str = "item", *,
                       stream: TextIO | None = None, interval: float = 10.0) -> ItemProgress:
    """A display counting ``total`` items called ``label`` (singular, e.g. ``"frame"``).

    ``mode``: ``"auto"`` (``"rich"`` when ``stream`` is a terminal, else ``"plain"``),
    ``"rich"`` (a bar with an ETA), ``"plain"`` (a line every ``interval`` seconds with the
    count and ETA) or ``"none"``. ``stream``: where to print (default stdout).
    """
    stream = stream or sys.stdout
    mode = _mode(mode, stream)
    if mode == "rich":
        return RichItemProgress(total, label, stream)
    if mode == "plain":
        return PlainItemProgress(total, label, stream, interval)
    return ItemProgress(total, label)


def _mode(mode: str, stream: TextIO) -> str:
    """The display ``mode`` resolved (``"auto"`` by ``stream`` being a terminal); raises a
    ValueError naming the valid ones."""
    if mode not in ("auto", "rich", "plain", "none"):
        raise ValueError(f"progress: {mode!r} is not valid; use auto, rich, plain or none")
    if mode == "auto":
        return "rich" if stream.isatty() else "plain"
    return mode


def hms(seconds: float) -> str:
    """``seconds`` as ``H:MM:SS`` (``"?"`` when unknown: infinite)."""
    if seconds == float("inf"):
        return "?"
    s = int(round(seconds))
    return f"{s // 3600:d}:{s // 60 % 60:02d}:{s % 60:02d}"
