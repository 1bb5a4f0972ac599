"""Figure helpers shared by the plotting modules: a figure on its own Agg canvas (no pyplot
state) and saving it as a PNG."""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

#: Resolution of every PNG the plotting modules write.
DPI = 150


def new_figure(ncols: int, width: float = 4.2, height: float = 3.5) -> Figure:
    """A figure of ``ncols`` panels (each ``width`` x ``height`` inches) on its own canvas."""
    fig = Figure(figsize=(width * ncols, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Figure, path: str | Path) -> Path:
    """Write the figure as a PNG, creating the folder; returns the path."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=DPI)
    return out
