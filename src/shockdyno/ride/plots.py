"""The ride study's report: the paper's Figs. 17-20 and Table 7, as files in a directory.

Figures use matplotlib's object API (no pyplot, no global backend state), so writing a
report from a server or a test never opens a window.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from shockdyno.atomic import write_text_atomic
from shockdyno.errors import ConfigError
from shockdyno.figures import agg_figure, save_png
from shockdyno.report.build import build_report
from shockdyno.report.ride_section import FLAG_LEGEND, PAPER_EXPLANATION, paper_ratios
from shockdyno.ride.study import RideResult, Run, paper_rms

TRACE_WINDOW_S = 10.0
DPI = 110  # saved at, and laid out at (figures.agg_figure): each text measured once


def _label(clicks: int | None) -> str:
    return "linear damper" if clicks is None else f"{clicks} clicks"


def _save(fig: Figure, path: Path) -> None:
    save_png(fig, path, DPI)


def _pick_road(result: RideResult) -> str:
    roads = result.config.roads
    return "A" if "A" in roads else roads[0]


def _clicks(result: RideResult) -> list[int | None]:
    return list(dict.fromkeys(r.clicks for r in result.runs))


def _grid(n: int) -> tuple[int, int]:
    """Rows and columns for n panels: at most two side by side, so each stays readable
    when the page is 800 px wide."""
    cols = 1 if n == 1 else 2
    return -(-n // cols), cols


def plot_traces(result: RideResult, speed_kmh: float, path: Path) -> None:
    """Figs. 17-18: sprung-mass acceleration against time, one line per click setting."""
    road = _pick_road(result)
    t = result.trajectory.time_s
    keep = t <= TRACE_WINDOW_S
    fig = agg_figure(figsize=(8, 4), dpi=DPI)
    ax = fig.add_subplot()
    for c in _clicks(result):
        i = result.runs.index(Run(c, road, speed_kmh))
        ax.plot(t[keep], result.trajectory.sprung_accel_m_s2[i, keep], lw=0.8, label=_label(c))
    ax.set_xlabel("time (s)")
    ax.set_ylabel("sprung-mass acceleration (m/s²)")
    ax.set_title(f"ISO 8608 road {road}, {speed_kmh:g} km/h")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    _save(fig, path)


def plot_psd(result: RideResult, path: Path) -> None:
    """Fig. 19: Welch PSD of sprung-mass acceleration, 0-20 Hz, per speed on one road."""
    road = _pick_road(result)
    speeds = list(result.config.speeds_kmh)
    rows, cols = _grid(len(speeds))
    fig = agg_figure(figsize=(5 * cols, 3.6 * rows), dpi=DPI)
    for k, v in enumerate(speeds):
        ax = fig.add_subplot(rows, cols, k + 1)
        for c in _clicks(result):
            i = result.runs.index(Run(c, road, v))
            ax.plot(result.psd_hz, result.psd_m2_s4_hz[i], lw=0.9, label=_label(c))
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("PSD ((m/s²)²/Hz)")
        ax.set_yscale("log")
        ax.set_title(f"road {road}, {v:g} km/h")
        ax.set_xlim(0, result.config.psd_max_hz)
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    _save(fig, path)


def plot_rms_vs_speed(result: RideResult, path: Path) -> None:
    """Fig. 20: RMS (solid) and Wk-weighted RMS (dashed) against speed, one panel per road."""
    roads = list(result.config.roads)
    speeds = np.array(result.config.speeds_kmh)
    order = np.argsort(speeds)
    rows, cols = _grid(len(roads))
    fig = agg_figure(figsize=(5 * cols, 3.6 * rows), dpi=DPI)
    for k, road in enumerate(roads):
        ax = fig.add_subplot(rows, cols, k + 1)
        for c in _clicks(result):
            idx = [result.runs.index(Run(c, road, float(v))) for v in speeds[order]]
            line = ax.plot(speeds[order], result.rms_m_s2[idx], "o-", label=_label(c))
            ax.plot(speeds[order], result.rms_wk_m_s2[idx], "--", color=line[0].get_color())
        ax.set_xlabel("speed (km/h)")
        ax.set_ylabel("RMS acceleration (m/s²)")
        ax.set_title(f"road {road} (dashed: Wk-weighted)")
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    _save(fig, path)


def table7_markdown(result: RideResult) -> str:
    """Table 7 analogue: RMS (Wk RMS) per speed and clicks × road; the paper's beside it."""
    roads = list(result.config.roads)
    head = "| speed (km/h) | damper | " + " | ".join(roads) + " |"
    lines = [
        "RMS of sprung-mass acceleration, m/s² (eq. 24); in brackets the ISO 2631-1 "
        "Wk-weighted RMS; after the slash the paper's Table 7 value where it has one.",
        "",
        head,
        "|" + "---|" * (len(roads) + 2),
    ]
    tyre, stroke = result.tyre_leaves_road(), result.stroke_exceeds_travel()
    for v in result.config.speeds_kmh:
        for c in _clicks(result):
            cells = []
            for road in roads:
                i = result.runs.index(Run(c, road, v))
                cell = f"{result.rms_m_s2[i]:.3f} ({result.rms_wk_m_s2[i]:.3f})"
                paper = paper_rms(c, road, v)
                if paper is not None:
                    cell += f" / {paper:.3f}"
                flags = ("T" if tyre[i] else "") + ("S" if stroke[i] else "")
                cells.append(cell + (f" {flags}" if flags else ""))
            lines.append(f"| {v:g} | {_label(c)} | " + " | ".join(cells) + " |")
    if tyre.any() or stroke.any():
        lines += ["", FLAG_LEGEND.replace("its travel", f"±{result.config.travel_m * 1e3:g} mm")]
    doc = result.doc()
    ratios = paper_ratios(doc.rms)
    if ratios:
        lines += [
            "",
            f"Ours are {min(ratios):.1f}-{max(ratios):.1f}× the paper's (median "
            f"{float(np.median(ratios)):.1f}×). {PAPER_EXPLANATION}",
        ]
    return "\n".join(lines) + "\n"


def write_psd_csv(result: RideResult, path: Path) -> None:
    """Write each run's body-acceleration PSD ((m/s²)²/Hz against Hz) as CSV, a row per run and
    frequency."""
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["clicks", "road", "speed_kmh", "frequency_hz", "psd_m2_s4_per_hz"])
        for i, run in enumerate(result.runs):
            for f, p in zip(result.psd_hz, result.psd_m2_s4_hz[i], strict=True):
                w.writerow(
                    [
                        "" if run.clicks is None else run.clicks,
                        run.road,
                        run.speed_kmh,
                        f"{f:.6g}",
                        f"{p:.6g}",
                    ]
                )


def write_report(result: RideResult, directory: str | Path) -> list[Path]:
    """Write index.html with the figures and Table 7 (flags, the paper comparison), and
    beside it the figures, table7.md and the PSD as CSV; return the files."""
    out = Path(directory)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot create report directory {out}: {exc.strerror}") from None
    speeds = sorted(result.config.speeds_kmh)
    files = []
    for name, v in (
        ("fig17_traces_low_speed.png", speeds[0]),
        ("fig18_traces_high_speed.png", speeds[-1]),
    ):
        plot_traces(result, v, out / name)
        files.append(out / name)
    plot_psd(result, out / "fig19_psd.png")
    plot_rms_vs_speed(result, out / "fig20_rms_vs_speed.png")
    write_text_atomic(out / "table7.md", table7_markdown(result))
    write_psd_csv(result, out / "psd.csv")
    files += [out / n for n in ("fig19_psd.png", "fig20_rms_vs_speed.png", "table7.md", "psd.csv")]

    captions = [
        f"Sprung-mass acceleration, {speeds[0]:g} km/h (Fig. 17 analogue)",
        f"Sprung-mass acceleration, {speeds[-1]:g} km/h (Fig. 18 analogue)",
        "PSD of sprung-mass acceleration (Fig. 19 analogue)",
        "RMS against speed, dashed Wk-weighted (Fig. 20 analogue)",
    ]
    index = build_report(
        [],
        out,
        title="shockdyno ride study",
        ride=result.doc(),
        extra_sections=[("Ride figures", list(zip(captions, files[:4], strict=True)))],
    )
    return [index, *files]
