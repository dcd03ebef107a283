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
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.print_png(target)  # type: ignore[no-untyped-call]


def agg_figure(figsize: tuple[float, float], dpi: float) -> Figure:
    """A figure on the Agg canvas that ``save_png`` draws it on, at the dpi it is saved at.

    ``tight_layout()`` on a bare Figure measures its texts with a renderer of its own at
    the figure's dpi; the draw then measures them again with another. Laid out on this
    canvas, the draw reuses the layout's renderer and its cache of text extents (and of
    parsed formulas, which are cached per dpi).
    """
    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)  # sets fig.canvas
    return fig
