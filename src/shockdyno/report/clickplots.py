"""Force-vs-clicks curves of the click chart: one line per standard velocity.

Compression and rebound side by side; measured as solid lines with filled markers
(hollow where extrapolated), the fitted model dashed over every click of its range.
"""

from __future__ import annotations

import math
from pathlib import Path

from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from shockdyno.report.clickchart import ClickChart
from shockdyno.report.plots import DPI, readable_colours


def force_vs_clicks(chart: ClickChart, path: Path) -> Path:
    speeds = sorted({abs(v) for v in chart.velocities_m_s})
    colours = dict(zip(speeds, readable_colours(len(speeds)), strict=True))
    fig = Figure(figsize=(10.0, 4.6), layout="constrained")
    axes = fig.subplots(1, 2, sharex=True)
    gas_values = sorted({g for _, g in chart.settings})
    gas = gas_values[0] if gas_values else 0  # the curves follow one gas setting
    for ax, sign, title in ((axes[0], 1.0, "compression"), (axes[1], -1.0, "rebound")):
        for speed in speeds:
            target = sign * speed
            colour = colours[speed]
            pts = sorted((c, row[target]) for (c, g), row in chart.measured.items() if g == gas)
            pts = [(c, r) for c, r in pts if math.isfinite(r.force_n)]
            if pts:
                ax.plot([c for c, _ in pts], [r.force_n for _, r in pts], "-", color=colour, lw=1.4)
                for c, r in pts:
                    ax.plot(
                        c,
                        r.force_n,
                        "o",
                        ms=5,
                        color=colour,
                        mfc="white" if r.extrapolated else colour,
                    )
            if chart.model_curve:
                clicks = sorted(chart.model_curve)
                ax.plot(
                    clicks,
                    [chart.model_curve[c][target] for c in clicks],
                    "--",
                    color=colour,
                    lw=1.1,
                )
        ax.set_title(f"{title} (velocity {'+' if sign > 0 else '−'}, force at each speed)")
        ax.set_xlabel("rod clicks (open →)")
        ax.set_ylabel("force F (N)" if chart.raw_force else "damping force (N, gas removed)")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, nbins=8))
        ax.yaxis.set_major_locator(MaxNLocator(nbins=7))
        ax.grid(True, alpha=0.3)
    handles = [
        Line2D([], [], color=colours[s], marker="o", lw=1.4, label=f"{s * 1e3:g} mm/s")
        for s in speeds
    ]
    handles.append(Line2D([], [], color="0.3", marker="o", mfc="white", lw=0, label="extrapolated"))
    if chart.model_curve:
        handles.append(Line2D([], [], color="0.3", ls="--", label="fitted model (x = 0)"))
    fig.legend(handles=handles, loc="outside right center", fontsize=9, frameon=False)
    if len(gas_values) > 1:
        fig.suptitle(f"gas clicks {gas} (the table lists every gas setting)", fontsize=10)
    fig.savefig(path, dpi=DPI, format="png")
    return path
