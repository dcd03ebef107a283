"""Force-vs-clicks curves of the click chart: one line per standard velocity.

Compression and rebound side by side; measured as solid lines with filled markers
(hollow where extrapolated), the fitted model dashed over every click of its range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator
from matplotlib.typing import ColorType

from shockdyno.figures import save_png
from shockdyno.report.clickchart import ClickChart, Setting
from shockdyno.report.plots import DPI, readable_colours
from shockdyno.units import SI, Units


def force_vs_clicks(
    chart: ClickChart,
    path: Path,
    band: dict[Setting, dict[float, float]] | None = None,
    units: Units = SI,
    ylims_n: tuple[tuple[float, float], tuple[float, float]] | None = None,
    clicks_label: str = "rod clicks",
) -> Path:
    """``band``: per setting and signed velocity, the half-width (N) of the cycle-to-cycle
    band, drawn as error bars on the measured points (report/repeatability.py).
    ``ylims_n``: the (compression, rebound) force ranges in N, to share scales between
    figures (compare's side by side); default: each axis its own."""
    speeds = sorted({abs(v) for v in chart.velocities_m_s})
    colours = dict(zip(speeds, readable_colours(len(speeds)), strict=True))
    fig = Figure(figsize=(10.0, 4.6), layout="constrained")
    axes = fig.subplots(1, 2, sharex=True)
    gas_values = sorted({g for _, g in chart.settings})
    gas = gas_values[0] if gas_values else 0  # the curves follow one gas setting
    for k, (ax, sign, title) in enumerate(
        ((axes[0], 1.0, "compression"), (axes[1], -1.0, "rebound"))
    ):
        if ylims_n is not None:
            ax.set_ylim(*(units.force(f) for f in ylims_n[k]))
        for speed in speeds:
            target = sign * speed
            _measured_line(ax, chart, gas, target, colours[speed], band, units)
            if chart.model_curve:
                clicks = sorted(chart.model_curve)
                ax.plot(
                    clicks,
                    [units.force(chart.model_curve[c][target]) for c in clicks],
                    "--",
                    color=colours[speed],
                    lw=1.1,
                )
        _label_side(ax, title, sign, chart.raw_force, clicks_label, units)
    _legend(fig, speeds, colours, chart, band, units)
    if len(gas_values) > 1:
        fig.suptitle(f"gas clicks {gas} (the table lists every gas setting)", fontsize=10)
    save_png(fig, path, DPI)
    return path


def _measured_line(
    ax: Axes,
    chart: ClickChart,
    gas: int,
    target: float,
    colour: ColorType,
    band: dict[Setting, dict[float, float]] | None,
    units: Units,
) -> None:
    """The measured force at one signed velocity across the clicks: a line, a marker per
    click (hollow where extrapolated), and the cycle-to-cycle band as error bars."""
    pts = sorted((c, row[target]) for (c, g), row in chart.measured.items() if g == gas)
    pts = [(c, r) for c, r in pts if math.isfinite(r.force_n)]
    if not pts:
        return
    ax.plot(
        [c for c, _ in pts],
        [units.force(r.force_n) for _, r in pts],
        "-",
        color=colour,
        lw=1.4,
    )
    # One artist per kind of mark, not one per click: a long sweep has hundreds of
    # points, and each artist costs its own layout and draw.
    for hollow in (False, True):
        marked = [(c, r) for c, r in pts if r.extrapolated == hollow]
        if marked:
            ax.plot(
                [c for c, _ in marked],
                [units.force(r.force_n) for _, r in marked],
                "o",
                ms=5,
                color=colour,
                mfc="white" if hollow else colour,
            )
    halves = [(c, r, (band or {}).get((c, gas), {}).get(target, math.nan)) for c, r in pts]
    barred = [(c, r, h) for c, r, h in halves if math.isfinite(h) and not r.extrapolated]
    if barred:
        ax.errorbar(
            [c for c, _, _ in barred],
            [units.force(r.force_n) for _, r, _ in barred],
            yerr=[units.force(h) for _, _, h in barred],
            fmt="none",  # the bars alone, no line joining the points that have them
            color=colour,
            capsize=3,
            lw=1.0,
        )


def _label_side(
    ax: Axes, title: str, sign: float, raw_force: bool, clicks_label: str, units: Units
) -> None:
    """One direction's title, axis labels, ticks and grid."""
    ax.set_title(f"{title} (velocity {'+' if sign > 0 else '−'}, force at each speed)")
    ax.set_xlabel(f"{clicks_label} (open →)")
    ax.set_ylabel(
        f"force F ({units.force_label})"
        if raw_force
        else f"damping force ({units.force_label}, gas removed)"
    )
    ax.xaxis.set_major_locator(MaxNLocator(integer=True, nbins=8))
    ax.yaxis.set_major_locator(MaxNLocator(nbins=7))
    ax.grid(True, alpha=0.3)


def _legend(
    fig: Figure,
    speeds: list[float],
    colours: Mapping[float, ColorType],
    chart: ClickChart,
    band: dict[Setting, dict[float, float]] | None,
    units: Units,
) -> None:
    """A line per speed, then what the markers, dashes and bars mean (only those drawn)."""
    handles = [
        Line2D([], [], color=colours[s], marker="o", lw=1.4, label=units.speed_text(s))
        for s in speeds
    ]
    handles.append(Line2D([], [], color="0.3", marker="o", mfc="white", lw=0, label="extrapolated"))
    if chart.model_curve:
        handles.append(Line2D([], [], color="0.3", ls="--", label="fitted model (x = 0)"))
    if band:
        handles.append(Line2D([], [], color="0.3", marker="|", ms=12, lw=0, label="±2 SD, cycles"))
    fig.legend(handles=handles, loc="outside right center", fontsize=9, frameon=False)
