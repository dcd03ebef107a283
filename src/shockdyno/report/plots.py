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
from matplotlib.colors import Colormap, ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from matplotlib.typing import ColorType
from numpy.typing import NDArray

from shockdyno.figures import save_png
from shockdyno.model.kinematics import velocity
from shockdyno.record.types import TestData
from shockdyno.report.summary import TestSummary
from shockdyno.units import SI, Units

FloatArray = NDArray[np.float64]

DPI = 100
# A line drawn a few hundred pixels wide gains nothing from more points than this, and
# Agg's time grows with the vertex count.
MAX_POINTS = 1500
# viridis without its last 15 %: the pale yellow end is unreadable on a white page.
CMAP: Colormap = ListedColormap(colormaps["viridis"](np.linspace(0.0, 0.85, 256)), "viridis_dark")
# Distinct colours that read on white (tab10 without its olive and grey).
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")
# More clicks than this in one legend column make it taller than the plot.
LEGEND_ROWS = 12


def velocity_label(units: Units = SI) -> str:
    return f"velocity v ({units.velocity_label}, + compression)"


def displacement_label(units: Units = SI) -> str:
    return f"displacement x ({units.length_label}, + compression)"


def force_label(units: Units = SI) -> str:
    return f"force F ({units.force_label})"


def click_label(clicks: int, gas_clicks: int, several_gas: bool) -> str:
    """How an overlay names a curve: 'click 3' (or 'click 3 / gas 2' when gas varies)."""
    return f"click {clicks}" + (f" / gas {gas_clicks}" if several_gas else "")


def readable_colours(n: int) -> list[str | tuple[float, float, float, float]]:
    """n colours that are told apart and read on white: the palette, else the colormap."""
    if n <= len(PALETTE):
        return list(PALETTE[:n])
    return [CMAP(float(k)) for k in np.linspace(0.0, 1.0, n)]


@dataclass(frozen=True)
class Curves:
    """One test's measured cycles, thinned for drawing (x in mm, v in m/s, F in N; the
    figures convert to the page's units)."""

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
    save_png(fig, path, DPI)
    return path


def _ticks(ax: Axes) -> None:
    # Few enough ticks that labels like "-1500" never touch, whatever the panel width.
    ax.xaxis.set_major_locator(MaxNLocator(nbins=6))
    ax.yaxis.set_major_locator(MaxNLocator(nbins=7))


def _label_loops(
    ax_x: Axes, ax_v: Axes, gas_force_n: float | None = None, units: Units = SI
) -> None:
    ax_x.set_xlabel(displacement_label(units))
    ax_x.set_ylabel(force_label(units))
    ax_v.set_xlabel(velocity_label(units))
    ax_v.set_ylabel(force_label(units))
    gas = units.force(gas_force_n) if gas_force_n is not None else math.nan
    for ax in (ax_x, ax_v):
        ax.grid(True, alpha=0.3)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.axvline(0.0, color="0.6", lw=0.6)
        _ticks(ax)
        if math.isfinite(gas):
            ax.axhline(gas, color="0.25", lw=0.9, ls=":")
    if math.isfinite(gas):
        ax_v.annotate(
            f"static gas force {gas:.0f} {units.force_label}",
            xy=(0.02, gas),
            xycoords=("axes fraction", "data"),
            xytext=(0, 3),
            textcoords="offset points",
            fontsize=8,
            color="0.25",
        )


def _status_suffix(c: Curves) -> str:
    return f" ({c.test.meta.status.upper()})" if c.aborted else ""


def click_loops(
    curves: Sequence[Curves], path: Path, gas_force_n: float | None = None, units: Units = SI
) -> Path:
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
        label = f"{meta.frequency_hz:g} Hz, {_length_text(meta.amplitude_m, units)}" + (
            _status_suffix(c)
        )
        width = 2.4 - 1.4 * rank / max(1, len(rows) - 1)
        x, v, f = _in_units(c, units)
        ax_x.plot(x, f, style, color=colour, lw=width, label=label)
        ax_v.plot(v, f, style, color=colour, lw=width)
    _label_loops(ax_x, ax_v, gas_force_n, units)
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


def _length_text(length_m: float, units: Units) -> str:
    return f"{units.length(length_m):.3g} {units.length_label}"


def _in_units(c: Curves, units: Units) -> tuple[FloatArray, FloatArray, FloatArray]:
    """x, v, F of a curve in the page's units."""
    return (
        units.length_per_m * 1e-3 * c.x_mm,
        units.velocity_per_m_s * c.v,
        units.force_per_n * c.force,
    )


def _click_legend(fig: Figure, axes: Sequence[Axes], n: int) -> None:
    """The curves' labels beside the plot: clicks told apart by name, not only by shade."""
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(
        handles,
        labels,
        loc="outside right center",
        ncol=max(1, math.ceil(n / LEGEND_ROWS)),
        fontsize=8,
        frameon=False,
        handlelength=1.2,
        columnspacing=0.8,
    )


def _direct_labels(ax: Axes, ends: Sequence[tuple[float, float, str, ColorType]]) -> None:
    """Name each curve at its end, right of it; labels of curves that end close together
    are pushed apart vertically (a leader line back to the point) so none overlaps."""
    ends = [e for e in ends if math.isfinite(e[0]) and math.isfinite(e[1])]
    if not ends:
        return
    lo, hi = ax.get_ylim()
    gap = 0.035 * (hi - lo)  # about one 7-pt label on the 5.6 in tall figure
    left, right = ax.get_xlim()
    shift = 0.015 * (right - left)
    ends = sorted(ends, key=lambda e: e[1])
    placed: list[float] = []
    for _, y, _, _ in ends:
        placed.append(max(y, placed[-1] + gap) if placed else y)
    # Pushed apart upwards only, the stack would climb out of the axes: centre it on the
    # points it names, and keep it inside.
    offset = float(np.mean([e[1] for e in ends]) - np.mean(placed))
    offset = min(offset, hi - 0.5 * gap - (placed[-1] + offset))
    placed = [p + offset for p in placed]
    for (x, y, text, colour), at in zip(ends, placed, strict=True):
        ax.annotate(
            text,
            xy=(x, y),
            xytext=(x + 2 * shift, at),
            fontsize=7,
            va="center",
            ha="left",
            color=colour,
            annotation_clip=False,
            arrowprops={"arrowstyle": "-", "color": colour, "lw": 0.5, "shrinkA": 0, "shrinkB": 2},
        )
    ax.set_xlim(left, right + 6 * shift)


def _click_norm(clicks: Sequence[int]) -> Normalize:
    lo, hi = min(clicks), max(clicks)
    if lo == hi:  # a colorbar over an empty range would be degenerate
        return Normalize(lo - 0.5, hi + 0.5)
    return Normalize(lo, hi)


def frequency_overlay(
    curves: Sequence[Curves],
    frequency_hz: float,
    path: Path,
    gas_force_n: float | None = None,
    units: Units = SI,
) -> Path:
    """Loops of every click at one frequency, coloured by clicks and named in a legend."""
    norm = _click_norm([c.test.meta.clicks for c in curves])
    cmap = CMAP
    fig = Figure(figsize=(11.0, 4.4), layout="constrained")
    ax_x, ax_v = fig.subplots(1, 2)
    gas = sorted({c.test.meta.gas_clicks for c in curves})
    ordered = sorted(curves, key=lambda c: (c.test.meta.clicks, c.test.meta.gas_clicks))
    for c in ordered:
        colour = cmap(norm(c.test.meta.clicks))
        label = click_label(c.test.meta.clicks, c.test.meta.gas_clicks, len(gas) > 1)
        x, v, f = _in_units(c, units)
        ax_x.plot(x, f, color=colour, lw=0.8, label=label)
        ax_v.plot(v, f, color=colour, lw=0.8)
    _label_loops(ax_x, ax_v, gas_force_n, units)
    fig.suptitle(f"{frequency_hz:g} Hz, every click (gas clicks {', '.join(map(str, gas))})")
    _click_legend(fig, [ax_x, ax_v], len(ordered))
    return _save(fig, path)


def peak_curves(
    summaries: Sequence[TestSummary],
    path: Path,
    band: dict[int, tuple[float, float]] | None = None,
    units: Units = SI,
) -> Path:
    """Peak force vs peak velocity, one curve per click through its frequencies.

    Compression peaks sit in the upper right, rebound peaks (signed) in the lower left;
    each click is named in the legend and at the fast end of its compression curve.
    ``band``: per test index, the half-width (N) of the cycle-to-cycle band of its peak
    compression and rebound force, drawn as error bars (report/repeatability.py).
    A constant-velocity test is drawn at its own point in each direction: the mean force
    over the constant-velocity part of its strokes at their mean velocity, its error bar
    the force's standard deviation there (report/constant_velocity.py).
    """
    norm = _click_norm([s.meta.clicks for s in summaries])
    cmap = CMAP
    fig = Figure(figsize=(8.0, 5.6), layout="constrained")
    ax = fig.subplots()
    by_click: dict[tuple[int, int], list[TestSummary]] = {}
    for s in summaries:
        by_click.setdefault((s.meta.clicks, s.meta.gas_clicks), []).append(s)
    gas_values = sorted({g for _, g in by_click})
    ends: list[tuple[float, float, str, ColorType]] = []  # fast end of each compression curve
    for (clicks, gas), group in sorted(by_click.items()):
        group = sorted(group, key=lambda s: s.meta.frequency_hz)
        colour = cmap(norm(clicks))
        marker = _GAS_MARKERS[gas_values.index(gas) % len(_GAS_MARKERS)]
        label = click_label(clicks, gas, len(gas_values) > 1)
        _peak_branches(ax, group, colour, marker, label, units)
        _peak_error_bars(ax, group, colour, band, units)
        fast = group[-1].point(0)
        ends.append((units.velocity(fast[0]), units.force(fast[1]), str(clicks), colour))
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.axvline(0.0, color="0.6", lw=0.6)
    ax.grid(True, alpha=0.3)
    _ticks(ax)
    _direct_labels(ax, ends)
    _label_peak_axes(ax, summaries, gas_values, units)
    _click_legend(fig, [ax], len(by_click))
    return _save(fig, path)


_GAS_MARKERS = "osD^v<>"  # peak_curves: one marker per gas setting


def _peak_branches(
    ax: Axes,
    group: Sequence[TestSummary],
    colour: ColorType,
    marker: str,
    label: str,
    units: Units,
) -> None:
    """One click's compression and rebound peaks through its frequencies."""
    branches = (
        ([s.point(0)[0] for s in group], [s.point(0)[1] for s in group]),
        ([s.point(1)[0] for s in group], [s.point(1)[1] for s in group]),
    )
    for branch, (vel, force) in enumerate(branches):
        ax.plot(
            [units.velocity(v) for v in vel],
            [units.force(f) for f in force],
            "-",
            marker=marker,
            ms=4,
            color=colour,
            lw=1.0,
            # One legend entry per click: its compression branch.
            label=None if branch else label,
        )


def _peak_error_bars(
    ax: Axes,
    group: Sequence[TestSummary],
    colour: ColorType,
    band: dict[int, tuple[float, float]] | None,
    units: Units,
) -> None:
    """A constant-velocity test's mean ± sd, and a sine's cycle-to-cycle band if given."""
    # (velocity, force, half-width) of every bar: drawn as one artist, not one per test.
    bars: list[tuple[float, float, float]] = []
    for s in group:
        bars += [(p.velocity_m_s, p.force_n, p.force_sd_n) for p in s.cv or ()]
    for s in group if band else ():
        half = band.get(s.meta.index) if band and s.cv is None else None
        if half is None:
            continue
        for vel1, f1, h in (
            (s.peak_compression_velocity_m_s, s.peak_compression_force_n, half[0]),
            (s.peak_rebound_velocity_m_s, s.peak_rebound_force_n, half[1]),
        ):
            if math.isfinite(h):
                bars.append((vel1, f1, h))
    if bars:
        ax.errorbar(
            [units.velocity(v) for v, _, _ in bars],
            [units.force(f) for _, f, _ in bars],
            yerr=[units.force(h) for _, _, h in bars],
            fmt="none",  # the bars alone, no line joining the points that have them
            color=colour,
            capsize=3,
            lw=1.0,
        )


def _label_peak_axes(
    ax: Axes, summaries: Sequence[TestSummary], gas_values: Sequence[int], units: Units
) -> None:
    """Axis labels and title: peak or constant-velocity force, damping or raw."""
    cv = any(s.cv is not None for s in summaries)
    what = "velocity (sines: peak; constant-velocity tests: their speed)" if cv else "peak velocity"
    ax.set_xlabel(f"{what} ({units.velocity_label}, + compression, − rebound)")
    removed = bool(summaries) and all(s.gas_removed_n is not None for s in summaries)
    fl = units.force_label
    peak = "force (sines: peak; constant velocity: mean ± sd)" if cv else "peak force"
    ax.set_ylabel(
        f"{peak.replace('force', 'damping force', 1) if removed else peak} ({fl}"
        f"{', gas force removed' if removed else ''})"
    )
    title = f"peak {'damping ' if removed else ''}force vs peak velocity per click"
    if cv:
        title = f"{'damping ' if removed else ''}force vs velocity per click"
    if len(gas_values) > 1:
        marks = _GAS_MARKERS
        title += (
            " (marker: gas clicks "
            + ", ".join(f"{g}={marks[i % len(marks)]}" for i, g in enumerate(gas_values))
            + ")"
        )
    ax.set_title(title, fontsize=10)
