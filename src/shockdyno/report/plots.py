"""The report's figures, drawn with matplotlib's object API on the Agg canvas.

``matplotlib.figure.Figure`` is used without pyplot: no global figure registry to leak,
no GUI backend to pick, nothing that needs a display.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Colormap, ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from numpy.typing import NDArray

from shockdyno.record.types import TestData
from shockdyno.report.summary import TestSummary, velocity

FloatArray = NDArray[np.float64]

DPI = 100
# A line drawn a few hundred pixels wide gains nothing from more points than this, and
# Agg's time grows with the vertex count.
MAX_POINTS = 1500
# viridis without its last 15 %: the pale yellow end is unreadable on a white page.
CMAP: Colormap = ListedColormap(colormaps["viridis"](np.linspace(0.0, 0.85, 256)), "viridis_dark")
# Distinct colours that read on white (tab10 without its olive and grey).
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")
VELOCITY_LABEL = "velocity v (m/s, + compression)"
DISPLACEMENT_LABEL = "displacement x (mm, + compression)"


def readable_colours(n: int) -> list[str | tuple[float, float, float, float]]:
    """n colours that are told apart and read on white: the palette, else the colormap."""
    if n <= len(PALETTE):
        return list(PALETTE[:n])
    return [CMAP(float(k)) for k in np.linspace(0.0, 1.0, n)]


@dataclass(frozen=True)
class Curves:
    """One test's measured cycles, thinned for drawing (x in mm, v in m/s, F in N)."""

    test: TestData
    summary: TestSummary
    x_mm: FloatArray
    v: FloatArray
    force: FloatArray

    @property
    def aborted(self) -> bool:
        return self.test.meta.status != "complete"


def prepare(test: TestData, summary: TestSummary) -> Curves:
    m = test.measured()
    v = velocity(m.t, m.x)
    step = max(1, math.ceil(m.t.size / MAX_POINTS))
    return Curves(test, summary, m.x[::step] * 1e3, v[::step], m.force[::step])


def _save(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=DPI, format="png")
    return path


def _ticks(ax: Axes) -> None:
    # Few enough ticks that labels like "-1500" never touch, whatever the panel width.
    ax.xaxis.set_major_locator(MaxNLocator(nbins=6))
    ax.yaxis.set_major_locator(MaxNLocator(nbins=7))


def _label_loops(ax_x: Axes, ax_v: Axes, gas_force_n: float | None = None) -> None:
    ax_x.set_xlabel(DISPLACEMENT_LABEL)
    ax_x.set_ylabel("force F (N)")
    ax_v.set_xlabel(VELOCITY_LABEL)
    ax_v.set_ylabel("force F (N)")
    for ax in (ax_x, ax_v):
        ax.grid(True, alpha=0.3)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.axvline(0.0, color="0.6", lw=0.6)
        _ticks(ax)
        if gas_force_n is not None and math.isfinite(gas_force_n):
            ax.axhline(gas_force_n, color="0.25", lw=0.9, ls=":")
    if gas_force_n is not None and math.isfinite(gas_force_n):
        ax_v.annotate(
            f"static gas force {gas_force_n:.0f} N",
            xy=(0.02, gas_force_n),
            xycoords=("axes fraction", "data"),
            xytext=(0, 3),
            textcoords="offset points",
            fontsize=8,
            color="0.25",
        )


def _status_suffix(c: Curves) -> str:
    return f" ({c.test.meta.status.upper()})" if c.aborted else ""


def click_loops(curves: Sequence[Curves], path: Path, gas_force_n: float | None = None) -> Path:
    """One click setting: its frequencies overlaid on one F-x and one F-v plot.

    A colour per frequency; an aborted test is dashed and labelled in the legend.
    """
    rows = sorted(curves, key=lambda c: (c.test.meta.frequency_hz, c.test.meta.index))
    fig = Figure(figsize=(10.0, 4.0), layout="constrained")
    ax_x, ax_v = fig.subplots(1, 2)
    first = rows[0].test.meta
    fig.suptitle(f"clicks {first.clicks}, gas clicks {first.gas_clicks}", fontsize=11)
    colours = readable_colours(len(rows))
    # Fastest first, wide, underneath: on the F-v plot the slower tests retrace part of
    # it, and drawn on top in thinner lines they stay visible.
    order = sorted(range(len(rows)), key=lambda k: -rows[k].test.meta.frequency_hz)
    for rank, k in enumerate(order):
        c, colour = rows[k], colours[k]
        meta = c.test.meta
        style = "--" if c.aborted else "-"
        label = f"{meta.frequency_hz:g} Hz, {meta.amplitude_m * 1e3:g} mm{_status_suffix(c)}"
        width = 2.4 - 1.4 * rank / max(1, len(rows) - 1)
        ax_x.plot(c.x_mm, c.force, style, color=colour, lw=width, label=label)
        ax_v.plot(c.v, c.force, style, color=colour, lw=width)
    _label_loops(ax_x, ax_v, gas_force_n)
    handles, labels = ax_x.get_legend_handles_labels()
    fig.legend(
        handles[::-1],  # drawn fastest first; listed slowest first
        labels[::-1],
        loc="outside lower center",
        ncol=min(len(rows), 4),
        fontsize=9,
        frameon=False,
    )
    return _save(fig, path)


def _click_norm(clicks: Sequence[int]) -> Normalize:
    lo, hi = min(clicks), max(clicks)
    if lo == hi:  # a colorbar over an empty range would be degenerate
        return Normalize(lo - 0.5, hi + 0.5)
    return Normalize(lo, hi)


def _click_colorbar(fig: Figure, norm: Normalize, axes: list[Axes]) -> None:
    bar = fig.colorbar(ScalarMappable(norm=norm, cmap=CMAP), ax=axes, label="clicks")
    bar.locator = MaxNLocator(integer=True)
    bar.update_ticks()


def frequency_overlay(
    curves: Sequence[Curves], frequency_hz: float, path: Path, gas_force_n: float | None = None
) -> Path:
    """Loops of every click at one frequency, coloured by clicks."""
    norm = _click_norm([c.test.meta.clicks for c in curves])
    cmap = CMAP
    fig = Figure(figsize=(11.0, 4.4), layout="constrained")
    ax_x, ax_v = fig.subplots(1, 2)
    for c in sorted(curves, key=lambda c: c.test.meta.clicks):
        colour = cmap(norm(c.test.meta.clicks))
        ax_x.plot(c.x_mm, c.force, color=colour, lw=0.8)
        ax_v.plot(c.v, c.force, color=colour, lw=0.8)
    _label_loops(ax_x, ax_v, gas_force_n)
    gas = sorted({c.test.meta.gas_clicks for c in curves})
    fig.suptitle(f"{frequency_hz:g} Hz, every click (gas clicks {', '.join(map(str, gas))})")
    _click_colorbar(fig, norm, [ax_x, ax_v])
    return _save(fig, path)


def peak_curves(summaries: Sequence[TestSummary], path: Path) -> Path:
    """Peak force vs peak velocity, one curve per click through its frequencies.

    Compression peaks sit in the upper right, rebound peaks (signed) in the lower left.
    """
    norm = _click_norm([s.clicks for s in summaries])
    cmap = CMAP
    fig = Figure(figsize=(8.0, 5.6), layout="constrained")
    ax = fig.subplots()
    by_click: dict[tuple[int, int], list[TestSummary]] = {}
    for s in summaries:
        by_click.setdefault((s.clicks, s.gas_clicks), []).append(s)
    markers = "osD^v<>"
    gas_values = sorted({g for _, g in by_click})
    for (clicks, gas), group in sorted(by_click.items()):
        group = sorted(group, key=lambda s: s.frequency_hz)
        colour = cmap(norm(clicks))
        marker = markers[gas_values.index(gas) % len(markers)]
        for vel, force in (
            (
                [s.peak_compression_velocity_m_s for s in group],
                [s.peak_compression_force_n for s in group],
            ),
            ([s.peak_rebound_velocity_m_s for s in group], [s.peak_rebound_force_n for s in group]),
        ):
            ax.plot(vel, force, "-", marker=marker, ms=4, color=colour, lw=1.0)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.axvline(0.0, color="0.6", lw=0.6)
    ax.grid(True, alpha=0.3)
    _ticks(ax)
    ax.set_xlabel("peak velocity (m/s, + compression, − rebound)")
    removed = bool(summaries) and all(s.gas_force_n is not None for s in summaries)
    ax.set_ylabel("peak damping force (N, gas force removed)" if removed else "peak force (N)")
    title = f"peak {'damping ' if removed else ''}force vs peak velocity per click"
    if len(gas_values) > 1:
        title += (
            " (marker: gas clicks "
            + ", ".join(f"{g}={markers[i % len(markers)]}" for i, g in enumerate(gas_values))
            + ")"
        )
    ax.set_title(title, fontsize=10)
    _click_colorbar(fig, norm, [ax])
    return _save(fig, path)
