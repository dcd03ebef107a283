"""The comparison page: ``index.html`` with PNGs beside it, offline and self-contained.

Files (fixed names inside the output directory): ``index.html``, ``peaks.png``,
``loops_c<clicks>_g<gas>_<f>Hz.png`` per matched test, ``chart_<n>.png`` per input.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from shockdyno.atomic import write_text_atomic
from shockdyno.compare import plots as cplots
from shockdyno.compare.inputs import Input
from shockdyno.compare.table import (
    DIFFERENCE,
    FLOOR_N,
    FLOOR_SHARE,
    K_SCATTER,
    NOT_JUDGED,
    SMALL,
    WITHIN,
    Row,
    bleed_rows,
    differences,
)
from shockdyno.report import clickchart, gas, plots, repeatability
from shockdyno.report.clickplots import force_vs_clicks
from shockdyno.report.html import Page, shown_path
from shockdyno.units import Units

RULE = (
    f"A difference: |B − A| > {K_SCATTER:g} × the SD of the difference (both sides' "
    "scatter combined: cycle-to-cycle, and test-to-test where a click has several tests "
    "at the velocity; a fit has none) and at least "
    f"{100 * FLOOR_SHARE:g} % of the force or {FLOOR_N:g} N. Within the scatter: "
    f"|B − A| ≤ {K_SCATTER:g} SD. Too small to matter: beyond the scatter but under "
    "that floor. Not judged: extrapolated on one side, or two models."
)


def _matched_loops(inputs: Sequence[Input]) -> tuple[dict, list[str]]:  # type: ignore[type-arg]
    """(setting, frequency) -> [(input, curves)] for tests two or more recordings have;
    and a line per test that has no partner."""
    found: dict[tuple[int, int, float], list[tuple[Input, plots.Curves]]] = {}
    for inp in inputs:
        seen = set()
        for test, s in zip(inp.tests, inp.summaries, strict=True):
            key = (test.meta.clicks, test.meta.gas_clicks, round(test.meta.frequency_hz, 6))
            if key in seen:  # a repeated test: the first stands for the input
                continue
            seen.add(key)
            found.setdefault(key, []).append((inp, plots.prepare(test, s)))
    matched = {k: v for k, v in found.items() if len(v) >= 2}
    unmatched = [
        f"{v[0][0].label}: clicks {k[0]}, gas {k[1]}, {k[2]:g} Hz"
        for k, v in sorted(found.items())
        if len(v) < 2
    ]
    return matched, unmatched


def _chart_table(inp: Input, units: Units) -> tuple[list[str], list[list[str]]]:
    velocities = inp.chart.velocities_m_s
    header = ["clicks", "gas"] + [clickchart.velocity_label(v, units) for v in velocities]
    rows = []
    for key, row in sorted(inp.values.items()):
        cells = [str(key[0]), str(key[1])]
        for v in velocities:
            val = row[v]
            if not math.isfinite(val.force_n):
                cells.append("–")
                continue
            text = f"{units.force(val.force_n):.0f}"
            if math.isfinite(val.sd_n) and val.sd_n > 0:
                text += f" ±{units.force(2 * val.sd_n):.1f}"
            cells.append(text + ("*" if val.extrapolated else ""))
        rows.append(cells)
    return header, rows


def render(
    inputs: Sequence[Input], rows: Sequence[Row], out_dir: Path, units: Units, title: str
) -> Path:
    out_dir.mkdir(parents=True, exist_ok=True)
    page = Page(title)
    _inputs_section(page, inputs, units)
    _difference_section(page, inputs, rows, units)
    _peaks_section(page, inputs, out_dir, units)
    _loops_section(page, inputs, rows, out_dir, units)
    _charts_section(page, inputs, out_dir, units)
    _bleed_section(page, inputs)
    index = out_dir / "index.html"
    write_text_atomic(index, page.render())
    return index


def _inputs_section(page: Page, inputs: Sequence[Input], units: Units) -> None:
    page.section("Inputs")
    page.table(
        ["label", "file", "what", "click settings"],
        [
            [i.label, shown_path(str(i.path.resolve())) if i.path.is_absolute() else str(i.path),
             "measured (recording)" if i.kind == "recording" else "fitted model (fit)",
             ", ".join(f"{c}/{g}" for c, g in i.settings)]
            for i in inputs
        ],
    )  # fmt: skip

    page.paragraph(force_note(inputs, units))
    for i in inputs:
        if i.loss:
            page.paragraph(f"{i.label}: {i.loss}; compared on what was read.", warn=True)
        for text in gas.warnings(i.gas, units):
            page.paragraph(f"{i.label}: {text}.", warn=True)


def _peaks_section(page: Page, inputs: Sequence[Input], out_dir: Path, units: Units) -> None:
    page.section(
        "Peak force vs peak velocity",
        "One colour per input; a marker per click setting; fits as their model's "
        "force-velocity curve (dashed; mid-stroke, zero acceleration).",
    )
    page.figure(
        cplots.peak_overlay(inputs, out_dir / "peaks.png", units).name,
        "Peak force against peak velocity of every test, one colour per input.",
    )


def _loops_section(
    page: Page, inputs: Sequence[Input], rows: Sequence[Row], out_dir: Path, units: Units
) -> None:
    """The F-x and F-v loops of the tests two or more recordings share."""
    matched, unmatched = _matched_loops(inputs)
    page.section(
        "Loops: same click and frequency",
        "F-x and F-v over the measured cycles of the tests two or more recordings share "
        "(same rod and gas clicks, same frequency), one colour per input.",
    )
    # Open the loops of the settings where the table found a difference (the first two),
    # else the first two: the loops that show something first.
    differing = {(r.clicks, r.gas_clicks) for r in rows if r.verdict == DIFFERENCE}
    keys = sorted(matched)
    shown_first = [k for k in keys if (k[0], k[1]) in differing][:2] or keys[:2]
    if differing:
        page.paragraph(
            "Opened: the loops of click settings where the table finds a difference; "
            "the others are collapsed below."
        )
    for key in keys:
        group = matched[key]
        label = f"clicks {key[0]}, gas {key[1]}, {key[2]:g} Hz: " + ", ".join(
            i.label for i, _ in group
        )
        page.details(label, opened=key in shown_first)
        name = f"loops_c{key[0]:02d}_g{key[1]:02d}_{key[2]:g}Hz.png"
        page.figure(cplots.loops_overlay(group, label, out_dir / name, units).name, label)
    page.close_details()
    if not matched:
        page.paragraph("No test matched: the recordings share no click and frequency.")
    if unmatched:
        page.paragraph("Without a partner (not overlaid): " + "; ".join(unmatched) + ".")
    if any(i.kind == "fit" for i in inputs):
        page.paragraph("Fits have no loops: they are compared by their click charts.")


def _charts_section(page: Page, inputs: Sequence[Input], out_dir: Path, units: Units) -> None:
    f_unit, v_unit = units.force_label, units.velocity_label
    page.section(
        "Click charts side by side",
        f"Force ({f_unit}) at the standard velocities ({v_unit}); measured values ± 2 SD of "
        "the value (cycle-to-cycle and test-to-test scatter); * extrapolated. Figures: "
        f"force against clicks ({f_unit}, {v_unit}), every input on the same force scale "
        "so they read side by side; measured solid with the cycle-to-cycle band, a fit's "
        "model dashed.",
    )
    ylims = _shared_limits(inputs)
    for n, inp in enumerate(inputs):
        page.subheading(f"{inp.label} ({inp.kind})")
        header, table = _chart_table(inp, units)
        page.table(header, table, numeric=[True] * len(header))
        band = repeatability.chart_band(
            repeatability.chart_scatter(inp.cycles, inp.chart.velocities_m_s)
        )
        png = force_vs_clicks(inp.chart, out_dir / f"chart_{n + 1}.png", band, units, ylims)
        page.figure(png.name, f"{inp.label}: force against clicks")


def _bleed_section(page: Page, inputs: Sequence[Input]) -> None:
    header, bleed, _ = bleed_rows(list(inputs))
    if bleed:
        page.section("Fitted bleed areas", "Per click setting, from each fit given (mm²).")
        page.table(header, bleed, numeric=[True] * len(header))


def _shared_limits(inputs: Sequence[Input]) -> tuple[tuple[float, float], tuple[float, float]]:
    """One force range per stroke (compression, rebound) over every input's chart (N), with
    a margin, so the side-by-side figures share their scales."""
    ranges = []
    for sign in (1.0, -1.0):
        values = [
            f
            for inp in inputs
            for row in inp.values.values()
            for v, val in row.items()
            if v * sign > 0 and math.isfinite(f := val.force_n)
        ]
        lo, hi = (min(values), max(values)) if values else (0.0, 1.0)
        pad = 0.05 * max(hi - lo, 1.0)
        ranges.append((lo - pad, hi + pad))
    return ranges[0], ranges[1]


def force_note(inputs: Sequence[Input], units: Units) -> str:
    """What force the tables and peak plots hold, per input (loops are always raw)."""
    if any(i.raw_force for i in inputs):
        return "Force as measured, gas force included (--raw-force), in tables and plots."
    parts = [
        f"{i.label}: "
        + (
            gas.describe_forces(i.gas, units).removeprefix("gas force removed: ")
            if i.kind == "recording"
            else "the model's own force at rest removed"
        )
        for i in inputs
    ]
    return (
        "Damping force: the difference table, click charts and peak-force plot have the "
        "static gas force removed (" + "; ".join(parts) + "); the loops show the force as "
        "measured. --raw-force compares the force as measured."
    )


def _difference_section(
    page: Page, inputs: Sequence[Input], rows: Sequence[Row], units: Units
) -> None:
    f_unit = units.force_label
    page.section(
        "Differences at the standard velocities",
        f"Each input against {inputs[0].label}, per click setting both have: B − A in "
        f"{f_unit} and % of A. {RULE}",
    )
    found = [r for r in rows if r.verdict == DIFFERENCE]
    if found:
        page.paragraph(
            f"{len(found)} of {len(rows)} values differ beyond the scatter (largest first): "
            + "; ".join(differences(list(rows), units))
            + ".",
            warn=True,
        )
    else:
        page.paragraph(f"Every one of the {len(rows)} values is within the scatter or not judged.")
    header = ["B vs A", "clicks", "gas", "stroke", f"v ({units.velocity_label})",
              f"A ({f_unit})", f"B ({f_unit})", f"B − A ({f_unit})", "%",
              f"SD ({f_unit})", "× SD", "judgement"]  # fmt: skip
    cells, classes = [], []
    for r in rows:
        fin = math.isfinite(r.diff_n)
        cells.append([
            f"{r.b} vs {r.a}", str(r.clicks), str(r.gas_clicks), r.direction,
            f"{units.velocity(abs(r.velocity_m_s)):.3g}",
            f"{units.force(r.force_a_n):.0f}" if math.isfinite(r.force_a_n) else "–",
            f"{units.force(r.force_b_n):.0f}" if math.isfinite(r.force_b_n) else "–",
            f"{units.force(r.diff_n):+.1f}" if fin else "–",
            f"{100 * r.diff_share:+.1f}" if math.isfinite(r.diff_share) else "–",
            f"{units.force(r.sd_diff_n):.1f}" if math.isfinite(r.sd_diff_n) else "–",
            f"{r.ratio:.1f}" if math.isfinite(r.ratio) else "–",
            _short(r),
        ])  # fmt: skip
        classes.append("flag" if r.verdict == DIFFERENCE else "dim" if r.verdict != WITHIN else "")
    page.table(header, cells, row_classes=classes, numeric=[False] * 4 + [True] * 7 + [False])


def _short(r: Row) -> str:
    if r.verdict == DIFFERENCE:
        return f"{'softer' if r.softer else 'stiffer'}, {r.ratio:.0f}× the scatter"
    if r.verdict == SMALL:
        return "too small to matter"
    if r.verdict == NOT_JUDGED:
        return f"not judged: {r.why}"
    return WITHIN
