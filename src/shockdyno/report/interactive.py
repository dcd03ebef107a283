"""Interactive plots on the report page: hover readouts, drag-to-zoom, series toggles.

Drawn in the browser by uPlot 1.6.32 (MIT, ``vendor/``), inlined once per page with the
data as inline JSON, so the page stays one offline, self-contained file. Each interactive
figure keeps its PNG: shown instead when JavaScript is off, and in print (the CSS below).

Why uPlot: 51 KB minified, no dependencies, a single IIFE file to inline (no build step,
no CDN), canvas drawing that stays fast with thousands of points, and a "mode 2" in which
every series has its own x and y, which force-displacement and force-velocity loops need.
Plotly (~3.5 MB) or Vega-Lite (~800 KB with Vega) would dwarf the page.

Data are in the page's units already (``Units``); the script only draws and reads out.
A loop is one cycle of its test (the last measured one), at most ``LOOP_POINTS`` points,
stored once per test and shared by the F-x and F-v plots and by every figure that draws
that test (the overlay of its frequency and the loops of its click).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from html import escape
from importlib import resources
from typing import Any

import numpy as np
from matplotlib.colors import to_hex
from matplotlib.typing import ColorType

from shockdyno.report.plots import (
    CMAP,
    Curves,
    click_label,
    displacement_label,
    force_label,
    readable_colours,
    velocity_label,
)
from shockdyno.units import SI, Units

# One point per degree of phase: a smooth loop at any width the page has, and a
# 24-test sweep's loops in ~150 KB of JSON.
LOOP_POINTS = 360
DIGITS = 4  # significant digits kept in the page's data (0.01 % of full scale)

CSS = """
.sd-live { display: none; }
html.js figure.sd-fig .sd-live { display: flex; flex-wrap: wrap; gap: 0.6em 1.2em; }
html.js figure.sd-fig > a.sd-static { display: none; }
.sd-chart { flex: 1 1 360px; min-width: 0; }
.sd-title { font-size: 0.9em; font-weight: 600; text-align: center; }
.sd-row { display: flex; align-items: center; }
.sd-ylab { writing-mode: vertical-rl; transform: rotate(180deg); font-size: 0.8em;
           color: #333; text-align: center; }
.sd-plot { flex: 1 1 auto; min-width: 0; }
.sd-xlab { font-size: 0.8em; color: #333; text-align: center; }
.sd-readout { font-size: 0.8em; color: #555; min-height: 1.3em;
              font-variant-numeric: tabular-nums; }
.sd-legend { display: flex; flex-wrap: wrap; gap: 0.2em 0.5em; font-size: 0.8em;
             margin: 0.2em 0; padding: 0; list-style: none; }
.sd-legend button { border: 1px solid #ccc; background: #fff; border-radius: 3px;
                    padding: 0 0.4em; cursor: pointer; font: inherit; }
.sd-legend button.off { opacity: 0.35; }
.sd-sw { display: inline-block; width: 0.9em; height: 0.25em; margin-right: 0.3em;
         vertical-align: middle; }
.sd-mark { position: absolute; width: 8px; height: 8px; border: 2px solid #000;
           border-radius: 50%; pointer-events: none; display: none; }
@media print {
  html.js figure.sd-fig .sd-live { display: none; }
  html.js figure.sd-fig > a.sd-static { display: inline; }
}
"""


def _vendor(name: str) -> str:
    return (resources.files("shockdyno.report") / "vendor" / name).read_text(encoding="utf-8")


def _own(name: str) -> str:
    return (resources.files("shockdyno.report") / name).read_text(encoding="utf-8")


def _script_json(value: Any) -> str:  # Any: whatever json.dumps takes
    """JSON safe inside <script>: no '</' to end the element early."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")


def page_value(value: float) -> float | None:
    """A value as the page stores it: DIGITS significant digits; None (a gap) if not finite."""
    if not math.isfinite(value):
        return None
    return float(f"{value:.{DIGITS}g}")


def _nums(values: Sequence[float] | np.ndarray) -> list[float | None]:
    return [page_value(float(v)) for v in values]


def css_colour(colour: ColorType) -> str:
    return str(to_hex(colour))


@dataclass
class Series:
    label: str
    colour: str
    x: str | list[float | None]  # a list, or "loop id.key" of a shared loop column
    y: str | list[float | None]
    line: bool = True
    points: bool = False
    hollow: bool = False
    dash: bool = False
    dotted: bool = False
    width: float = 1.5
    notes: list[str] | None = None  # per point, appended to the readout

    def as_json(self) -> dict[str, Any]:  # Any: a JSON object's values, for json.dumps
        out: dict[str, Any] = {  # Any: as above
            "label": self.label,
            "colour": self.colour,
            "x": self.x,
            "y": self.y,
            "line": self.line,
            "points": self.points,
            "hollow": self.hollow,
            "dash": self.dash,
            "dotted": self.dotted,
            "width": self.width,
        }
        if self.notes is not None:
            out["notes"] = self.notes
        return out


@dataclass
class Chart:
    title: str
    x_label: str  # axis label, e.g. "velocity v (in/s, + compression)"
    y_label: str
    x_name: str  # readout: "v 2.1 in/s, F 120 lbf"
    x_unit: str
    y_name: str
    y_unit: str
    series: list[Series]
    x_integer: bool = False


@dataclass
class Interactive:
    """The page's interactive figures: collects their data, renders the figures and, once,
    the library, the data and the script (``tail``)."""

    units: Units = SI
    loops: dict[str, dict[str, list[float | None]]] = field(default_factory=dict)
    charts: list[dict[str, Any]] = field(default_factory=list)  # JSON objects, for json.dumps
    _ids: dict[int, str] = field(default_factory=dict)  # id(TestData) -> loop id

    # ---- data

    def loop(self, c: Curves) -> str:
        """The id of one cycle of ``c``'s test in the page's store (added once)."""
        key = self._ids.get(id(c.test))
        if key is not None:
            return key
        key = self._ids[id(c.test)] = f"t{len(self._ids)}"
        n = c.force.size
        per = min(n, math.ceil(n / max(1, c.test.meta.measured_cycles)) + 1)  # +1: closed
        step = max(1, math.ceil(per / LOOP_POINTS))
        idx = np.arange(n - per, n)[::step]
        if idx.size and idx[-1] != n - 1:
            idx = np.append(idx, n - 1)  # the loop ends where the next cycle starts
        u = self.units
        self.loops[key] = {
            "x": _nums(u.length_per_m * 1e-3 * c.x_mm[idx]),
            "v": _nums(u.velocity_per_m_s * c.v[idx]),
            "f": _nums(u.force_per_n * c.force[idx]),
        }
        return key

    # ---- markup

    def _chart_html(self, chart: Chart) -> str:
        number = len(self.charts)
        self.charts.append(
            {
                "x_name": chart.x_name,
                "x_unit": chart.x_unit,
                "y_name": chart.y_name,
                "y_unit": chart.y_unit,
                "x_integer": chart.x_integer,
                "series": [s.as_json() for s in chart.series],
            }
        )
        # One legend button per label: a click's compression and rebound curves (or a
        # series and its extrapolated points) are toggled together.
        groups: dict[str, tuple[str, list[int]]] = {}
        for k, s in enumerate(chart.series, start=1):
            groups.setdefault(s.label, (s.colour, []))[1].append(k)
        legend = "".join(
            f'<li><button type="button" data-series="{",".join(map(str, idx))}">'
            f'<span class="sd-sw" style="background:{escape(colour, quote=True)}"></span>'
            f"{escape(label)}</button></li>"
            for label, (colour, idx) in groups.items()
        )
        return (
            f'<div class="sd-chart" data-chart="{number}">'
            f'<div class="sd-title">{escape(chart.title)}</div>'
            f'<div class="sd-row"><div class="sd-ylab">{escape(chart.y_label)}</div>'
            '<div class="sd-plot"></div></div>'
            f'<div class="sd-xlab">{escape(chart.x_label)}</div>'
            f'<ul class="sd-legend">{legend}</ul>'
            '<div class="sd-readout"></div></div>'
        )

    def figure(self, png: str, caption: str, charts: Sequence[Chart]) -> str:
        """A figure: the interactive charts (with JavaScript) or the PNG (without, in print)."""
        src = escape(png, quote=True)
        live = "".join(self._chart_html(c) for c in charts)
        return (
            f'<figure class="sd-fig"><div class="sd-live">{live}</div>'
            f'<a class="sd-static" href="{src}"><img src="{src}" '
            f'alt="{escape(caption, quote=True)}" loading="lazy"></a>'
            f"<figcaption>{escape(caption)}</figcaption></figure>"
        )

    def tail(self) -> str:
        """Style, library, data and script: once per page, after the last figure."""
        if not self.charts:
            return ""
        data = _script_json({"loops": self.loops, "charts": self.charts})
        return (
            f"<style>{_vendor('uPlot.min.css')}{CSS}</style>\n"
            f"<script>{_vendor('uPlot.iife.min.js')}</script>\n"
            f'<script type="application/json" id="sd-data">{data}</script>\n'
            f"<script>{_own('interactive.js')}</script>"
        )

    # ---- the report's figures

    def _force_axis(self) -> tuple[str, str, str]:
        return force_label(self.units), "F", self.units.force_label

    def loop_charts(
        self,
        curves: Sequence[Curves],
        labels: Sequence[str],
        colours: Sequence[str],
        gas_force_n: float | None,
        dashed: Sequence[bool] | None = None,
    ) -> list[Chart]:
        """An F-x and an F-v chart of the given tests, one series each."""
        u = self.units
        ids = [self.loop(c) for c in curves]
        dashed = dashed or [False] * len(curves)
        y_label, y_name, y_unit = self._force_axis()
        out = []
        for key, x_label, x_name, x_unit, title in (
            ("x", displacement_label(u), "x", u.length_label, "force vs displacement"),
            ("v", velocity_label(u), "v", u.velocity_label, "force vs velocity"),
        ):
            series = [
                Series(label, colour, f"{i}.{key}", f"{i}.f", dash=d, width=1.3)
                for i, label, colour, d in zip(ids, labels, colours, dashed, strict=True)
            ]
            gas = self._gas_line(gas_force_n, [self.loops[i][key] for i in ids])
            out.append(Chart(title, x_label, y_label, x_name, x_unit, y_name, y_unit, series + gas))
        return out

    def _gas_line(
        self, gas_force_n: float | None, xs: Sequence[Sequence[float | None]]
    ) -> list[Series]:
        if gas_force_n is None or not math.isfinite(gas_force_n):
            return []
        finite = [v for col in xs for v in col if v is not None]
        if not finite:
            return []
        f = page_value(self.units.force(gas_force_n))
        return [
            Series(
                "static gas force",
                "#404040",
                [min(finite), max(finite)],
                [f, f],
                dotted=True,
                width=1.0,
            )
        ]

    def overlay(self, group: Sequence[Curves], gas_force_n: float | None) -> list[Chart]:
        """Every click at one frequency, named by click."""
        ordered = sorted(group, key=lambda c: (c.test.meta.clicks, c.test.meta.gas_clicks))
        clicks = [c.test.meta.clicks for c in ordered]
        lo, hi = min(clicks), max(clicks)
        several_gas = len({c.test.meta.gas_clicks for c in ordered}) > 1
        colours = [css_colour(CMAP(0.0 if hi == lo else (k - lo) / (hi - lo))) for k in clicks]
        labels = [
            click_label(c.test.meta.clicks, c.test.meta.gas_clicks, several_gas) for c in ordered
        ]
        return self.loop_charts(ordered, labels, colours, gas_force_n)

    def click_loops(self, group: Sequence[Curves], gas_force_n: float | None) -> list[Chart]:
        """One click setting's frequencies; aborted tests dashed."""
        # Fastest first, as in the PNG: the slower loops retrace part of it on the F-v
        # plot and, drawn later, stay visible on top.
        rows = sorted(group, key=lambda c: (-c.test.meta.frequency_hz, c.test.meta.index))
        colours = [css_colour(c) for c in readable_colours(len(rows))]
        u = self.units
        labels = [
            f"{c.test.meta.frequency_hz:g} Hz, "
            f"{u.length(c.test.meta.amplitude_m):.3g} {u.length_label}"
            + (f" ({c.test.meta.status.upper()})" if c.aborted else "")
            for c in rows
        ]
        return self.loop_charts(rows, labels, colours, gas_force_n, [c.aborted for c in rows])
