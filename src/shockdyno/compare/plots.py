"""The comparison's overlays: one colour per input, in the page's units."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from shockdyno.compare.inputs import Input
from shockdyno.figures import save_png
from shockdyno.report import clickchart, plots
from shockdyno.report.summary import TestSummary
from shockdyno.units import Units

MARKERS = "osD^v<>ph"


def colours(inputs: Sequence[Input]) -> dict[str, str | tuple[float, float, float, float]]:
    return dict(zip((i.label for i in inputs), plots.readable_colours(len(inputs)), strict=True))


def widths(n: int) -> list[float]:
    """Wide first, thinner after: two inputs that agree would otherwise hide one another."""
    return [3.0 - 2.0 * k / max(1, n - 1) for k in range(n)]


def peak_overlay(inputs: Sequence[Input], path: Path, units: Units) -> Path:
    """Peak force vs peak velocity, one colour per input, a marker per click setting;
    a fit as its model's force-velocity curve (dashed) at each fitted click."""
    colour = colours(inputs)
    settings = sorted({s for i in inputs for s in i.settings})
    marker = {s: MARKERS[k % len(MARKERS)] for k, s in enumerate(settings)}
    fig = Figure(figsize=(9.0, 6.0), layout="constrained")
    ax = fig.subplots()
    top = max(
        (abs(v) for i in inputs for s in i.summaries
         for v in (s.peak_compression_velocity_m_s, s.peak_rebound_velocity_m_s)
         if np.isfinite(v)),
        default=0.3,
    )  # fmt: skip
    for inp, lw in zip(inputs, widths(len(inputs)), strict=True):
        c = colour[inp.label]
        by_setting: dict[tuple[int, int], list[TestSummary]] = {}
        for s in inp.summaries:
            by_setting.setdefault((s.meta.clicks, s.meta.gas_clicks), []).append(s)
        for key, group in sorted(by_setting.items()):
            group.sort(key=lambda s: s.meta.frequency_hz)
            for vel, force in (
                ([s.peak_compression_velocity_m_s for s in group],
                 [s.peak_compression_force_n for s in group]),
                ([s.peak_rebound_velocity_m_s for s in group],
                 [s.peak_rebound_force_n for s in group]),
            ):  # fmt: skip
                ax.plot(
                    [units.velocity(v) for v in vel],
                    [units.force(f) for f in force],
                    "-",
                    marker=marker[key],
                    ms=2 + 2.5 * lw,
                    color=c,
                    lw=lw,
                )
        if inp.fit is not None:
            grid = tuple(np.linspace(-top, top, 81))
            for key in inp.settings:
                f = clickchart.model_forces(inp.fit, key[0], grid, key[1])
                if not inp.raw_force:  # damping force, as the recordings' peaks
                    at_rest = clickchart.model_static_force_n(inp.fit, key[0], key[1])
                    f = {v: force - at_rest for v, force in f.items()}
                ax.plot(
                    [units.velocity(v) for v in grid],
                    [units.force(f[v]) for v in grid],
                    "--",
                    color=c,
                    lw=1.0,
                )
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.axvline(0.0, color="0.6", lw=0.6)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel(f"peak velocity ({units.velocity_label}, + compression)")
    raw = any(i.raw_force for i in inputs)
    what = "peak force" if raw else "peak damping force"
    ax.set_ylabel(f"{what} ({units.force_label}{'' if raw else ', gas force removed'})")
    handles = [
        Line2D([], [], color=colour[i.label], ls="--" if i.kind == "fit" else "-",
               label=f"{i.label} ({'fit: model' if i.kind == 'fit' else 'measured'})")
        for i in inputs
    ]  # fmt: skip
    handles += [
        Line2D([], [], color="0.3", marker=marker[s], lw=0, label=f"clicks {s[0]}, gas {s[1]}")
        for s in settings
    ]
    fig.legend(handles=handles, loc="outside right center", fontsize=9, frameon=False)
    save_png(fig, path, plots.DPI)
    return path


def loops_overlay(
    matched: Sequence[tuple[Input, plots.Curves]], title: str, path: Path, units: Units
) -> Path:
    """F-x and F-v of one click setting at one frequency, one colour per input."""
    colour = colours([i for i, _ in matched])
    fig = Figure(figsize=(10.0, 4.2), layout="constrained")
    ax_x, ax_v = fig.subplots(1, 2)
    for (inp, c), lw in zip(matched, widths(len(matched)), strict=True):
        x = c.x_mm * 1e-3 * units.length_per_m
        v = c.v * units.velocity_per_m_s
        f = c.force * units.force_per_n
        ax_x.plot(x, f, color=colour[inp.label], lw=lw, label=inp.label)
        ax_v.plot(v, f, color=colour[inp.label], lw=lw)
    ax_x.set_xlabel(f"displacement x ({units.length_label}, + compression)")
    ax_v.set_xlabel(f"velocity v ({units.velocity_label}, + compression)")
    for ax in (ax_x, ax_v):
        ax.set_ylabel(f"force F ({units.force_label})")
        ax.grid(True, alpha=0.3)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.axvline(0.0, color="0.6", lw=0.6)
    fig.suptitle(title, fontsize=11)
    fig.legend(loc="outside lower center", ncol=min(len(matched), 4), fontsize=9, frameon=False)
    save_png(fig, path, plots.DPI)
    return path
