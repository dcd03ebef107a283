"""The report's ride section, rendered from the JSON of `shockdyno ride` (docs/ride.md).

Read defensively like the diagnose section: a key that is missing is skipped. The
paper comparison's explanation lives here, beside the Table 7 analogue it explains, and
`ride/plots.py` puts the same text under table7.md.
"""

from __future__ import annotations

import math
import statistics
from typing import Any

from shockdyno.report.html import Page
from shockdyno.units import SI, Units

PAPER_EXPLANATION = (
    "Why ours are several times the paper's: the paper's values cannot come from the "
    "Table 5 car on ISO 8608 geometric-mean roads with Ω in rad/m. The smallest RMS any "
    "linear damper gives that car (the comfort optimum, c ≈ 3 kN·s/m, from |H|² S) is "
    "0.212 m/s² on class A at 20 km/h (paper: 0.028-0.034), 0.528 on A at 120 km/h (paper: "
    "0.048-0.061) and 1.49 on C at 60 km/h (paper: 0.112-0.124), 7-13× above the paper. "
    "Its numbers would need a road PSD ~50-150× smaller (or another unit or scaling) than "
    "its Table 6 states; the text does not say which. Trends shared: RMS grows with road "
    "class and with speed. The click ordering differs on smooth roads because this damper "
    "is past the comfort optimum at every click (docs/ride.md)."
)

FLAG_LEGEND = (
    "T: the tyre leaves the road (the linear tyre is pulled in tension); S: the damper "
    "stroke exceeds its travel. Such runs are outside the model's validity (no bump stops, "
    "no tyre lift-off)."
)


def _f(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def run_flags(entry: dict[str, Any]) -> str:
    """'T', 'S', 'TS' or '' for one run of the JSON's `rms` list."""
    return ("T" if entry.get("tyre_leaves_road") else "") + (
        "S" if entry.get("stroke_exceeds_travel") else ""
    )


def paper_ratios(entries: list[dict[str, Any]]) -> list[float]:
    """Our RMS over the paper's, for every run the paper has."""
    out = []
    for e in entries:
        ours, paper = _f(e.get("rms_ms2")), _f(e.get("paper_rms_ms2"))
        if ours is not None and paper:
            out.append(ours / paper)
    return out


def _label(clicks: Any) -> str:
    return "linear" if clicks is None else f"{clicks} clicks"


def _table7(page: Page, entries: list[dict[str, Any]]) -> None:
    roads = list(dict.fromkeys(str(e.get("road")) for e in entries))
    keys = list(dict.fromkeys((e.get("speed_kmh"), e.get("clicks")) for e in entries))
    cell: dict[tuple[Any, Any, str], dict[str, Any]] = {
        (e.get("speed_kmh"), e.get("clicks"), str(e.get("road"))): e for e in entries
    }
    rows, classes = [], []
    for speed, clicks in keys:
        row = [f"{_f(speed) or 0:g}", _label(clicks)]
        marks = ["", ""]
        for road in roads:
            e = cell.get((speed, clicks, road))
            if e is None:
                row.append("–")
                continue
            ours, wk, paper = (_f(e.get(k)) for k in ("rms_ms2", "rms_wk_ms2", "paper_rms_ms2"))
            text = "–" if ours is None else f"{ours:.3f}"
            if wk is not None:
                text += f" ({wk:.3f})"
            if paper is not None:
                text += f" / {paper:.3f}"
            flags = run_flags(e)
            if flags:
                text += f" {flags}"
            marks.append("flag" if flags else "")
            row.append(text)
        rows.append(row)
        classes.append(marks)
    page.table(["km/h", "damper", *roads], rows, cell_classes=classes)


def car_sentence(car: dict[str, Any]) -> str:
    """The car the study ran, in the paper's Table 5 terms (a reader compares cars)."""
    parts = []
    for key, label, scale, unit in (
        ("sprung_mass_kg", "sprung mass", 1.0, "kg"),
        ("unsprung_mass_kg", "unsprung mass", 1.0, "kg"),
        ("spring_n_m", "spring", 1e-3, "kN/m"),
        ("tyre_n_m", "tyre", 1e-3, "kN/m"),
    ):
        value = _f(car.get(key))
        if value is not None:
            parts.append(f"{label} {value * scale:.4g} {unit}")
    if not parts:
        return "The ride file does not state its car."
    return "The car: " + ", ".join(parts) + " (the paper's Table 5 unless set on the command line)."


def render_ride(page: Page, doc: Any, units: Units = SI) -> None:
    """Append the ride section for ``doc`` (the parsed ride JSON); the damper's travel in
    ``units`` (accelerations stay m/s², as ISO 2631 and the paper give them)."""
    page.section(
        "Ride study",
        "Quarter car with the fitted damper on ISO 8608 roads: RMS of the sprung-mass "
        "acceleration in m/s² (eq. 24), the ISO 2631-1 Wk-weighted RMS in brackets, the "
        "paper's Table 7 after the slash where it has the run.",
    )
    if not isinstance(doc, dict):
        page.paragraph("The ride file holds no object; nothing to show.", warn=True)
        return
    car = doc.get("quarter_car")
    if isinstance(car, dict):
        page.paragraph(car_sentence(car))
    damper = doc.get("damper") if isinstance(doc.get("damper"), dict) else {}
    settings = damper.get("settings") if isinstance(damper, dict) else None
    if isinstance(settings, list):
        trend = [
            s.get("clicks") for s in settings if isinstance(s, dict) and s.get("source") == "trend"
        ]
        if trend:
            page.paragraph(
                "Interpolated from the fit's trend of bleed area against clicks (no test at "
                f"that setting): {', '.join(map(str, trend))} clicks.",
                warn=True,
            )
    rms = doc.get("rms")
    entries = [e for e in rms if isinstance(e, dict)] if isinstance(rms, list) else []
    if not entries:
        page.paragraph("The ride file has no runs (key 'rms').")
        return
    flagged = [e for e in entries if run_flags(e)]
    flags = doc.get("flags")
    travel = _f(flags.get("travel_m")) if isinstance(flags, dict) else None
    if flagged:
        tyre = sum("T" in run_flags(e) for e in flagged)
        stroke = sum("S" in run_flags(e) for e in flagged)
        limit = f" (±{units.length(travel):.3g} {units.length_label})" if travel is not None else ""
        page.paragraph(
            f"{len(flagged)} of {len(entries)} runs are outside the model's validity: the tyre "
            f"leaves the road in {tyre}, the stroke exceeds the damper's travel{limit} in "
            f"{stroke}. They are marked T / S in the table.",
            warn=True,
        )
    page.subheading("Table 7 analogue")
    _table7(page, entries)
    if flagged:
        page.paragraph(FLAG_LEGEND)
    ratios = paper_ratios(entries)
    if ratios:
        page.paragraph(
            f"Ours are {min(ratios):.1f}-{max(ratios):.1f}× the paper's Table 7 "
            f"(median {statistics.median(ratios):.1f}×). " + PAPER_EXPLANATION
        )
