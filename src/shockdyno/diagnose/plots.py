"""The diagnosis's figures: residual maps before and after, and loops with both models.

matplotlib's object API on the Agg canvas (no pyplot, no display), like report/plots.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import Diagnosis
from shockdyno.diagnose.fitting import Fitted, full_rate_force
from shockdyno.figures import save_png
from shockdyno.units import SI, Units

FloatArray = NDArray[np.float64]
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2")
DPI = 100


def _velocity(v_m_s: FloatArray, u: Units) -> FloatArray:
    """Velocity as the figures plot it: m/s in SI (the verdict's words use m/s too), in/s
    in imperial."""
    return v_m_s * u.velocity_per_m_s if u.imperial else v_m_s


def _velocity_label(u: Units) -> str:
    return u.velocity_label if u.imperial else "m/s"


def _phase_means(
    data: Data, fitted: Fitted
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Per (test, bin): x, v, residual phase mean and the test's frequency."""
    res = np.concatenate([b.mean for b in data.binned(fitted.residual)])
    xv = data.bin_matrix(np.column_stack([data.prob.inputs.x, data.prob.inputs.v]))
    freq = np.repeat([p.data.meta.frequency_hz for p in data.prepared], res.size // data.n_tests)
    return xv[:, 0], xv[:, 1], res, freq


def residual_maps(d: Diagnosis, path: Path, u: Units = SI) -> Path:
    fig = Figure(figsize=(10, 7), layout="constrained")
    axes = fig.subplots(2, 2, sharey=True)
    freqs = sorted({round(p.data.meta.frequency_hz, 3) for p in d.data.prepared})
    for row, (label, fitted) in enumerate((("before", d.baseline), ("after", d.final))):
        if fitted.residual.size != d.data.prob.size:
            continue
        x, v, r, f = _phase_means(d.data, fitted)
        x, v, r = x * u.length_per_m, _velocity(v, u), r * u.force_per_n
        for k, fr in enumerate(freqs):
            sel = np.isclose(f, fr, atol=1e-3)
            c = COLOURS[k % len(COLOURS)]
            axes[row, 0].plot(x[sel], r[sel], ".", ms=3, color=c, label=f"{fr:g} Hz")
            axes[row, 1].plot(v[sel], r[sel], ".", ms=3, color=c, label=f"{fr:g} Hz")
        names = ", ".join(t.name for t in fitted.model.terms) or "paper's model"
        axes[row, 0].set_ylabel(f"residual {label} ({u.force_label})\n{names}")
        for ax in axes[row]:
            ax.axhline(0.0, color="0.5", lw=0.8)
            ax.grid(alpha=0.3)
    axes[1, 0].set_xlabel(f"displacement ({u.length_label}, + compression)")
    axes[1, 1].set_xlabel(f"velocity ({_velocity_label(u)}, + compression)")
    axes[0, 1].legend(loc="best", fontsize=8)
    fig.suptitle("Phase-locked residual (measured − model) per test, before and after")
    save_png(fig, path, DPI)
    return path


def loops(d: Diagnosis, path: Path, u: Units = SI, n_tests: int = 3) -> Path:
    """The tests with the most structure: measured loop, baseline and augmented model,
    with the F–v loop also zoomed near reversal (where most missing physics shows)."""
    data = d.data
    binned = data.binned(d.baseline.residual)
    energy = [float(np.mean(b.mean**2)) for b in binned]
    pick = sorted(np.argsort(energy)[-n_tests:][::-1].tolist())
    fig = Figure(figsize=(13, 3.4 * len(pick)), layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(pick), 3))
    for row, i in enumerate(pick):
        p = data.prepared[i]
        m = p.data.meta
        step = max(1, p.data.t.size // 4000)
        v = _velocity(p.v[::step], u)
        x_shown, f_meas = p.data.x[::step] * u.length_per_m, p.data.force[::step] * u.force_per_n
        near = np.abs(v) < 0.25 * float(np.max(np.abs(v)))
        for ax, xs, sel in ((axes[row, 0], v, slice(None)), (axes[row, 1], v, near)):
            ax.plot(xs[sel], f_meas[sel], ".", ms=1.5, color="0.35", label="measured")
        axes[row, 2].plot(x_shown, f_meas, ".", ms=1.5, color="0.35", label="measured")
        for label, fitted, colour, ls in (
            ("paper's model", d.baseline, "#d62728", "--"),
            ("with the claimed physics", d.final, "#2ca02c", "-"),
        ):
            f = full_rate_force(fitted, p)[::step] * u.force_per_n
            axes[row, 0].plot(v, f, ls, color=colour, lw=1.1, label=label)
            axes[row, 1].plot(v[near], f[near], ".", color=colour, ms=1.5, label=label)
            axes[row, 2].plot(x_shown, f, ls, color=colour, lw=1.1, label=label)
        axes[row, 0].set_title(f"test {m.index}: {m.clicks} clicks, {m.frequency_hz:g} Hz: F–v")
        axes[row, 1].set_title("F–v near reversal")
        axes[row, 2].set_title("F–x")
        for ax in axes[row, :2]:
            ax.set_xlabel(f"velocity ({_velocity_label(u)}, + compression)")
        axes[row, 2].set_xlabel(f"displacement ({u.length_label}, + compression)")
        for ax in axes[row]:
            ax.set_ylabel(f"force ({u.force_label})")
            ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize=8, markerscale=4)
    save_png(fig, path, DPI)
    return path
