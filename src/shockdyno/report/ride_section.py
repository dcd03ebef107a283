"""The report's ride section, rendered from the RIDE.json of `shockdyno ride` (docs/ride.md).

The document is read and checked once (`report/documents.py`: `RideDoc`). The paper
comparison's explanation lives here, beside the Table 7 analogue it explains, and
`ride/plots.py` puts the same text under table7.md.
"""

from __future__ import annotations

import statistics
from collections.abc import Sequence

from shockdyno.report.documents import Car, RideDoc, RunRms
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


def run_flags(entry: RunRms) -> str:
    """'T', 'S', 'TS' or '' for one run of the JSON's `rms` list."""
    return ("T" if entry.tyre_leaves_road else "") + ("S" if entry.stroke_exceeds_travel else "")


def paper_ratios(runs: Sequence[RunRms]) -> list[float]:
    """Our RMS over the paper's, for every run the paper has. (A run as a dict is read as
    RIDE.json would hold it.)"""
    return [e.rms_ms2 / e.paper_rms_ms2 for e in runs if e.paper_rms_ms2]


def _label(clicks: int | None) -> str:
    return "linear" if clicks is None else f"{clicks} clicks"


def _table7(page: Page, entries: tuple[RunRms, ...]) -> None:
    roads = list(dict.fromkeys(e.road for e in entries))
    keys = list(dict.fromkeys((e.speed_kmh, e.clicks) for e in entries))
    cell = {(e.speed_kmh, e.clicks, e.road): e for e in entries}
    rows, classes = [], []
    for speed, clicks in keys:
        row = [f"{speed:g}", _label(clicks)]
        marks = ["", ""]
        for road in roads:
            e = cell.get((speed, clicks, road))
            if e is None:
                row.append("–")
                continue
            text = f"{e.rms_ms2:.3f} ({e.rms_wk_ms2:.3f})"
            if e.paper_rms_ms2 is not None:
                text += f" / {e.paper_rms_ms2:.3f}"
            flags = run_flags(e)
            if flags:
                text += f" {flags}"
            marks.append("flag" if flags else "")
            row.append(text)
        rows.append(row)
        classes.append(marks)
    page.table(["km/h", "damper", *roads], rows, cell_classes=classes)


def car_sentence(car: Car) -> str:
    """The car the study ran, in the paper's Table 5 terms (a reader compares cars)."""
    return (
        f"The car: sprung mass {car.sprung_mass_kg:.4g} kg, unsprung mass "
        f"{car.unsprung_mass_kg:.4g} kg, spring {car.spring_n_m * 1e-3:.4g} kN/m, tyre "
        f"{car.tyre_n_m * 1e-3:.4g} kN/m (the paper's Table 5 unless set on the command line)."
    )


def render_ride(page: Page, doc: RideDoc, units: Units = SI) -> None:
    """Append the ride section for ``doc`` (a read RIDE.json); the damper's travel in
    ``units`` (accelerations stay m/s², as ISO 2631 and the paper give them)."""
    page.section(
        "Ride study",
        "Quarter car with the fitted damper on ISO 8608 roads: RMS of the sprung-mass "
        "acceleration in m/s² (eq. 24), the ISO 2631-1 Wk-weighted RMS in brackets, the "
        "paper's Table 7 after the slash where it has the run.",
    )
    page.paragraph(car_sentence(doc.quarter_car))
    trend = [s.clicks for s in doc.damper.settings if s.source == "trend"]
    if trend:
        page.paragraph(
            "Interpolated from the fit's trend of bleed area against clicks (no test at "
            f"that setting): {', '.join(map(str, trend))} clicks.",
            warn=True,
        )
    entries = doc.rms
    if not entries:
        page.paragraph("The ride file has no runs (key 'rms').")
        return
    flagged = [e for e in entries if run_flags(e)]
    if flagged:
        tyre = sum("T" in run_flags(e) for e in flagged)
        stroke = sum("S" in run_flags(e) for e in flagged)
        limit = f"±{units.length(doc.flags.travel_m):.3g} {units.length_label}"
        page.paragraph(
            f"{len(flagged)} of {len(entries)} runs are outside the model's validity: the tyre "
            f"leaves the road in {tyre}, the stroke exceeds the damper's travel ({limit}) in "
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
