"""Writing a matplotlib figure as PNG with one draw, shared by every command's figures.

``Figure.savefig`` of a figure with a layout engine (``layout="constrained"``, or the
placeholder that ``tight_layout()`` leaves behind) draws the whole figure twice: once
without rendering, to lay it out, and again for the pixels. The first pass costs as
much Python as the second (ticks, text extents: most of a report's time), and for a PNG
it buys nothing: ``Figure.draw`` runs the layout engine itself before it draws, which
is how an interactive window lays a figure out.
"""

from __future__ import annotations

from pathlib import Path
from typing import BinaryIO

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


def save_png(fig: Figure, target: Path | BinaryIO, dpi: float) -> None:
    """``fig.savefig(target, dpi=dpi, format="png")`` with one draw instead of two."""
    # savefig sets the dpi only for its own draws; left set here, the figure is not drawn
    # again, so nothing sees the difference.
    fig.set_dpi(dpi)
    FigureCanvasAgg(fig).print_png(target)  # type: ignore[no-untyped-call]
