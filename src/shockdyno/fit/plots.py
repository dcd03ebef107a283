"""Figures of a fit: areas against clicks with their trend (the paper's Fig. 12) and
force-displacement / force-velocity overlays of measured, proposed and Talbott (Figs. 13-15).

Figures are drawn on `matplotlib.figure.Figure` objects (Agg canvas), not pyplot, so no
global backend or figure state is touched.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.ticker import MaxNLocator

from shockdyno.figures import agg_figure, save_png
from shockdyno.fit.forces import representative
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.result import FitResult
from shockdyno.fit.validate import ModelForces, model_forces
from shockdyno.record.types import TestData
from shockdyno.units import SI, Units

# The dpi the figures are saved at, and laid out at (tight_layout) on the canvas they are
# drawn on: the layout and the draw then measure each text and formula once, not twice.
DPI = 110


def _areas_figure(result: FitResult, path: Path) -> None:
    fig = agg_figure(figsize=(11, 4.2), dpi=DPI)
    axes = fig.subplots(1, 2)
    # One adjuster's line of a damper with several (FitResult.for_adjuster): its clicks
    by = next((t.adjuster for t in result.trend.values() if t.adjuster), "rod")
    panels = (
        ("A_bc", "a_bc_m2", "a_bc_sd_m2", "identifiable_bc", "compression $A_{bc}$"),
        ("A_bt", "a_bt_m2", "a_bt_sd_m2", "identifiable_bt", "rebound $A_{bt}$"),
    )
    for ax, (name, attr, sd_attr, ok_attr, label) in zip(axes, panels, strict=True):
        clicks = np.array([c.clicks for c in result.clicks], dtype=float)
        vals = np.array([getattr(c, attr) for c in result.clicks]) * 1e6
        sds = np.nan_to_num(np.array([getattr(c, sd_attr) for c in result.clicks]) * 1e6)
        ok = np.array([getattr(c, ok_attr) for c in result.clicks], dtype=bool)
        if ok.any():
            ax.errorbar(
                clicks[ok],
                vals[ok],
                yerr=2 * sds[ok],
                fmt="o",
                color="C0",
                capsize=3,
                label=f"{label} (±2σ)",
            )
        if (~ok).any():
            ax.errorbar(
                clicks[~ok],
                vals[~ok],
                yerr=2 * sds[~ok],
                fmt="o",
                mfc="none",
                color="C3",
                capsize=3,
                label="not identifiable",
            )
        talb = np.array([c.a_b_talbott_m2 for c in result.clicks]) * 1e6
        ax.plot(clicks, talb, "x", color="C2", label="Talbott $A_b$")
        trend = result.trend.get(name)
        if trend is not None:
            used = trend.clicks_used
            n = np.linspace(min(used), max(used), 200)
            ax.plot(
                n,
                np.polyval(trend.coefficients, n) * 1e6,
                "-",
                color="C1",
                label=f"trend, degree {trend.degree} (R² {trend.r2:.4f})",
            )
        ax.set_xlabel(f"{by} clicks")
        ax.set_ylabel("bleed area (mm²)")
        ax.set_title(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Fitted bleed areas against clicks (paper's Fig. 12)")
    fig.tight_layout()
    save_png(fig, path, DPI)


def _overlay_figure(mf: ModelForces, path: Path, units: Units = SI) -> str:
    m = mf.test.meta
    title = f"{m.clicks} clicks, {m.frequency_hz:g} Hz: measured vs proposed vs Talbott"
    fig = agg_figure(figsize=(11, 4.2), dpi=DPI)
    ax1, ax2 = fig.subplots(1, 2)
    # SI keeps its m/s velocity axis; imperial reads in, in/s and lbf like the report.
    v_scale, v_label = (
        (units.velocity_per_m_s, units.velocity_label) if units.imperial else (1.0, "m/s")
    )
    f = units.force_per_n
    for ax, xs, xlabel in (
        (
            ax1,
            mf.test.x * units.length_per_m,
            f"displacement ({units.length_label}, + compression)",
        ),
        (ax2, mf.v * v_scale, f"velocity ({v_label}, + compression)"),
    ):
        # Measured wide and pale underneath, so a model lying on it stays visible.
        ax.plot(xs, f * mf.test.force, color="C3", lw=3.0, alpha=0.45, label="measured")
        ax.plot(xs, f * mf.proposed, color="C0", lw=1.0, ls="--", label="proposed")
        ax.plot(xs, f * mf.talbott, color="C2", lw=1.0, label="Talbott")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"force ({units.force_label})")
        # Few ticks: labels such as "-0.075" must not run into each other.
        ax.xaxis.set_major_locator(MaxNLocator(nbins=6))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    save_png(fig, path, DPI)
    return title


def fit_figures(
    result: FitResult,
    tests: Sequence[TestData],
    out_dir: str | Path,
    units: Units = SI,
    adjuster: str = "",
) -> list[tuple[str, Path]]:
    """Write the figures as PNG into out_dir; returns (title, path) of each. ``units``:
    of the overlays' axes (bleed areas stay mm², as the fit states them). ``adjuster``:
    the figures of one adjuster's line (FitResult.for_adjuster), named for it."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures: list[tuple[str, Path]] = []
    tag = f"-{adjuster}" if adjuster else ""
    path = out / f"fit-areas-vs-clicks{tag}.png"
    _areas_figure(result, path)
    figures.append(("Bleed areas against clicks with trend (Fig. 12 analogue)", path))
    keys = {(c.clicks, c.gas_clicks, c.setting) for c in result.clicks}
    usable = [t for t in tests if (t.meta.clicks, t.meta.gas_clicks, t.meta.setting) in keys]
    for mf in overlay_forces(result, usable):
        m = mf.test.meta
        path = out / f"fit-overlay{tag}-{m.clicks}clicks-{m.frequency_hz:g}hz.png"
        figures.append((_overlay_figure(mf, path, units), path))
    return figures


def overlay_forces(result: FitResult, tests: Sequence[TestData]) -> list[ModelForces]:
    """Both models on the overlays' tests (`representative`): as the fit saved them
    (`result.saved`, fit/forces.py), else computed from the fit."""
    prepared, _ = prepare_tests(tests)
    picks = representative([p.data.meta for p in prepared])
    out = []
    for p in (p for m in picks for p in prepared if p.data.meta is m):
        saved = result.saved.test(p.data.meta.index, p.data.t.size) if result.saved else None
        if saved is None:
            out += model_forces(result.model(), result, [p])
        else:
            out.append(ModelForces(p.data, p.v, p.a, saved.proposed, saved.talbott))
    return out
