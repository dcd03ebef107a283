"""The click chart's and the peak curves' interactive twins: their series, built from
the same data as their PNGs (report/clickplots.py, report/plots.py peak_curves).

Unlike the loop figures (report/interactive.py), these keep no shared loop store: each
series carries its own points, so building them needs only the page's units.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from shockdyno.report.clickchart import ClickChart, Setting
from shockdyno.report.interactive import Chart, Series, css_colour, page_value
from shockdyno.report.plots import CMAP, Curves, click_label, force_label, readable_colours
from shockdyno.units import Units


def click_charts(
    units: Units,
    chart: ClickChart,
    band: dict[Setting, dict[float, float]] | None = None,
    clicks_label: str = "rod clicks",
) -> list[Chart]:
    """Force against clicks at each standard speed, compression and rebound; ``band``
    (N, half-widths per setting and signed speed) is read out on hover, as ±2 SD."""
    u = units
    speeds = sorted({abs(v) for v in chart.velocities_m_s})
    colours = [css_colour(c) for c in readable_colours(len(speeds))]
    gas_values = sorted({g for _, g in chart.settings})
    gas = gas_values[0] if gas_values else 0  # as the PNG: the first gas setting

    def spread(c: int, target: float) -> str:
        h = (band or {}).get((c, gas), {}).get(target, math.nan)
        return f", ±{u.force(h):.1f} {u.force_label} (2 SD, cycles)" if math.isfinite(h) else ""

    y_label = force_label(u)
    if not chart.raw_force:
        y_label = f"damping force ({u.force_label}, gas removed)"
    out = []
    for sign, title in ((1.0, "compression"), (-1.0, "rebound")):
        series = _click_side(u, chart, gas, sign, speeds, colours, spread)
        out.append(
            Chart(
                f"{title} (velocity {'+' if sign > 0 else '−'})",
                f"{clicks_label} (open →)",
                y_label,
                "clicks",
                "",
                "F",
                u.force_label,
                series,
                x_integer=True,
            )
        )
    return out


def _click_side(
    u: Units,
    chart: ClickChart,
    gas: int,
    sign: float,
    speeds: Sequence[float],
    colours: Sequence[str],
    spread: Callable[[int, float], str],
) -> list[Series]:
    """One direction's series: per speed the measured points and the model's dashed line,
    then every extrapolated point once more, hollow, as one series of their own."""
    series: list[Series] = []
    hollow_x: list[float | None] = []
    hollow_y: list[float | None] = []
    for speed, colour in zip(speeds, colours, strict=True):
        target = sign * speed
        name = u.speed_text(speed)
        pts = sorted(
            (c, row[target])
            for (c, g), row in chart.measured.items()
            if g == gas and math.isfinite(row[target].force_n)
        )
        if pts:
            series.append(
                Series(
                    name,
                    colour,
                    [float(c) for c, _ in pts],
                    [page_value(u.force(r.force_n)) for _, r in pts],
                    points=True,
                    notes=[
                        " (extrapolated)"
                        if r.extrapolated
                        else f", {r.n_tests} test(s){spread(c, target)}"
                        for c, r in pts
                    ],
                )
            )
            hollow_x += [float(c) for c, r in pts if r.extrapolated]
            hollow_y += [page_value(u.force(r.force_n)) for _, r in pts if r.extrapolated]
        if chart.model_curve:
            clicks = sorted(chart.model_curve)
            series.append(
                Series(
                    name,
                    colour,
                    [float(c) for c in clicks],
                    [page_value(u.force(chart.model_curve[c][target])) for c in clicks],
                    dash=True,
                    width=1.1,
                    notes=[" (fitted model, x = 0)"] * len(clicks),
                )
            )
    if hollow_x:
        series.append(
            Series(
                "extrapolated",
                "#505050",
                hollow_x,
                hollow_y,
                line=False,
                points=True,
                hollow=True,
                notes=[" (extrapolated)"] * len(hollow_x),
            )
        )
    return series


def peak_charts(
    units: Units,
    curves: Sequence[Curves],
    band: dict[int, tuple[float, float]] | None = None,
) -> list[Chart]:
    """Peak force against peak velocity, one curve per click through its frequencies;
    ``band`` (N, per test index: compression, rebound half-widths) read out on hover."""
    u = units

    def spread(c: Curves, branch: int) -> str:
        cv = c.summary.cv
        if cv is not None:  # a constant-velocity test: its mean force's sd
            sd = u.force(cv[branch].force_sd_n)
            return f", ±{sd:.1f} {u.force_label} (1 SD, constant velocity)"
        h = (band or {}).get(c.summary.meta.index, (math.nan, math.nan))[branch]
        return f", ±{u.force(h):.1f} {u.force_label} (2 SD, cycles)" if math.isfinite(h) else ""

    by_click: dict[tuple[int, int], list[Curves]] = {}
    for c in curves:
        by_click.setdefault((c.test.meta.clicks, c.test.meta.gas_clicks), []).append(c)
    several_gas = len({g for _, g in by_click}) > 1
    clicks = [k for k, _ in sorted(by_click)]
    norm_lo, norm_hi = min(clicks), max(clicks)
    series: list[Series] = []
    for (click, gas), group in sorted(by_click.items()):
        group = sorted(group, key=lambda c: c.test.meta.frequency_hz)
        frac = 0.0 if norm_hi == norm_lo else (click - norm_lo) / (norm_hi - norm_lo)
        colour = css_colour(CMAP(frac))
        label = click_label(click, gas, several_gas)
        for branch, (vel, force) in enumerate(
            (
                (
                    [c.summary.point(0)[0] for c in group],
                    [c.summary.point(0)[1] for c in group],
                ),
                (
                    [c.summary.point(1)[0] for c in group],
                    [c.summary.point(1)[1] for c in group],
                ),
            )
        ):
            notes = [f" at {c.test.meta.frequency_hz:g} Hz{spread(c, branch)}" for c in group]
            series.append(
                Series(
                    label,
                    colour,
                    [page_value(u.velocity(v)) for v in vel],
                    [page_value(u.force(f)) for f in force],
                    points=True,
                    width=1.2,
                    notes=notes,
                )
            )
    removed = bool(curves) and all(c.summary.gas_removed_n is not None for c in curves)
    what = "peak damping force" if removed else "peak force"
    return [
        Chart(
            f"{what} vs peak velocity per click",
            f"peak velocity ({u.velocity_label}, + compression, − rebound)",
            f"{what} ({u.force_label}{', gas removed' if removed else ''})",
            "v",
            u.velocity_label,
            "F",
            u.force_label,
            series,
        )
    ]
