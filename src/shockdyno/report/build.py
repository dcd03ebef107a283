"""Assemble the report: PNGs and CSV beside one ``index.html`` in the output directory.

Files written (all inside ``out_dir``, fixed names, so a re-run overwrites its own files
and touches nothing else):

- ``index.html``
- ``click_chart.png``, ``click_chart.csv``: force at standard velocities per click
- ``click_chart_reference.csv``: the same at a reference oil temperature (thermal fit)
- ``peaks.png``: peak force vs peak velocity per click (complete tests)
- ``overlay_<f>Hz.png``: every click at one frequency, coloured by clicks (complete tests)
- ``loops_c<clicks>_g<gas>.png``: one click setting's frequencies overlaid (all tests)
- ``fit-*.png``: the fit's figures (with a fit)
- ``extra/<n>_<name>``: copies of ``extra_sections`` PNGs that live outside ``out_dir``

The page keeps its length in check for a 22-click sweep: the long parts (the summary
table of a big sweep, the loops of each click) sit in collapsed ``<details>`` blocks,
and images load lazily, so only what is opened is drawn by the browser.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from shockdyno.atomic import write_text_atomic
from shockdyno.errors import ConfigError
from shockdyno.fit.display import globals_rows
from shockdyno.fit.validate import table4_rows
from shockdyno.record import adjusters
from shockdyno.record.types import TestData
from shockdyno.report import clickchart, plots, repeatability, temperature
from shockdyno.report import gas as gas_force
from shockdyno.report.clickplots import force_vs_clicks
from shockdyno.report.diagnose_section import render_diagnose, render_figures
from shockdyno.report.documents import DiagnosisDoc, RideDoc, typed
from shockdyno.report.html import SUMMARY_LEGEND, Page, shown_path, summary_header, summary_row
from shockdyno.report.interactive import Interactive
from shockdyno.report.interactive_charts import click_charts, peak_charts
from shockdyno.report.ride_section import render_ride
from shockdyno.report.summary import TestSummary, summarise
from shockdyno.units import SI, Units

if TYPE_CHECKING:  # the fit package is imported only when a fit is drawn
    from shockdyno.fit.result import FitResult

Section = tuple[str, list[tuple[str, Path]]]
Table = tuple[str, list[str], list[list[str]]]

MIN_SAMPLES = 8  # fewer measured samples than this make no loop worth drawing
OPEN_SUMMARY_MAX_ROWS = 12  # a longer summary table starts collapsed

ERROR_MEASURES = [
    (
        "E_t (time)",
        "ε_t / σ_F with ε_t² = ∫ (F_measured − F_model)² dt and σ_F² = ∫ (F_measured − mean F)² dt "
        "over the measured cycles: the model's RMS force error as a share of the force's own "
        "spread (dimensionless; 0 is perfect, 1 is no better than the mean force).",
    ),
    (
        "E_x (displacement)",
        "ε_x / σ_F with ε_x² = ∫ (F_measured − F_model)² |dx/dt| dt: the same error weighted "
        "by stroke travelled, i.e. integrated over displacement (unit √(m/s), as in the paper).",
    ),
    (
        "E_ẋ (velocity)",
        "ε_ẋ / σ_F with ε_ẋ² = ∫ (F_measured − F_model)² |dẋ/dt| dt: weighted by the change of "
        "velocity, i.e. integrated along the force-velocity curve (unit √(m/s²)).",
    ),
]


def _freq_name(frequency_hz: float) -> str:
    return f"overlay_{frequency_hz:g}Hz.png"


def _finite(s: TestSummary) -> bool:
    return all(
        math.isfinite(v)
        for v in (
            s.peak_compression_force_n,
            s.peak_rebound_force_n,
            s.peak_compression_velocity_m_s,
            s.peak_rebound_velocity_m_s,
        )
    )


def _link_extra(out_dir: Path, png: Path, n: int) -> str:
    """A relative link to ``png``, copying it into out_dir when it lives elsewhere."""
    png = Path(png)
    if not png.is_file():
        raise ConfigError(f"report figure not found: {png}")
    resolved = png.resolve()
    try:
        return resolved.relative_to(out_dir.resolve()).as_posix()
    except ValueError:
        target = out_dir / "extra" / f"{n:02d}_{png.name}"
        target.parent.mkdir(exist_ok=True)
        shutil.copyfile(resolved, target)
        return target.relative_to(out_dir).as_posix()


@dataclass(frozen=True)
class _Measured:
    """What the page is drawn from, worked out once from the tests before any section."""

    tests: list[TestData]  # their force as the page shows it (gas force handled)
    forces: gas_force.GasForces
    summaries: list[TestSummary]
    drawable: list[plots.Curves]  # enough samples for a loop
    complete: list[plots.Curves]  # and complete, with finite peaks
    cycles: list[repeatability.TestCycles]  # per-cycle readings of the complete tests
    lines: dict[str, list[TestData]]  # a damper with several adjusters: each one's line
    gas_force_n: float | None  # the static gas force marked on the loops
    force_note: str  # which force the chart and peaks show


def build_report(
    tests: list[TestData],
    out_dir: Path,
    *,
    title: str,
    metadata: dict[str, str] | None = None,
    extra_sections: Sequence[Section] = (),
    tables: Sequence[Table] = (),
    fit: FitResult | None = None,
    # or as json.load gives them (Any: a JSON value), read into their typed documents here
    diagnose: DiagnosisDoc | dict[str, Any] | None = None,
    ride: RideDoc | dict[str, Any] | None = None,
    gas_force_n: float | None = None,
    progress: Callable[[str], None] | None = None,
    warn: Callable[[str], None] | None = None,
    reference_temperature_c: float = temperature.DEFAULT_REFERENCE_C,
    diagnose_dir: Path | None = None,
    units: Units = SI,
    raw_force: bool = False,
    gas_given: Mapping[int, float] | None = None,
    gas_limit: gas_force.Charge | None = None,
) -> Path:
    """Write the report into ``out_dir``; returns the path of index.html.

    Every part is optional: no tests (a ride-only page), no fit (measured click chart
    only), ``diagnose`` and ``ride`` as the documents of those commands
    (`documents.read_diagnosis`, `read_ride`; a dict, as `to_json()` gives it, is read as
    its file would be).
    ``gas_force_n``: the static gas force to mark on loops (taken from the fit if given,
    else the recording's). The click chart, the summary table and the peak-force plot show
    damping force, the gas force removed (report/gas.py: ``gas_given`` by gas clicks,
    else measured, else estimated and checked against ``gas_limit``), unless ``raw_force``;
    the loops show the force as measured.
    ``warn``: called with each warning (one line: a drift, a gas force refused or depending
    on the sample rate), e.g. to print it on the terminal.
    ``reference_temperature_c``: oil temperature of the corrected click chart
    (report/temperature.py). ``diagnose_dir``: the folder of the diagnose JSON, whose
    ``info.figures`` (residual maps, loops) are relative to it and copied into ``out_dir``.
    ``units``: what the page shows (tables, captions, figures); files beside it that are
    JSON stay SI, the click-chart CSV names its units in its header.
    """
    say = progress or (lambda _: None)
    # Read before anything is drawn: a garbled document stops the page in one line.
    diag = None if diagnose is None else typed(diagnose, DiagnosisDoc, "the diagnosis")
    ride_doc = None if ride is None else typed(ride, RideDoc, "the ride study")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"report directory is a file: {out_dir}")
    out_dir.mkdir(parents=True, exist_ok=True)

    say("summaries")
    m = _measure(tests, fit, gas_force_n, raw_force, gas_given, gas_limit, units)
    page = Page(title)
    live = Interactive(units)  # the interactive twins of the figures, and their script
    _recording_section(page, metadata, m.forces, raw_force, units, warn)
    _click_charts(page, m, fit, out_dir, live, raw_force, reference_temperature_c, say)
    if m.tests:
        _summary_section(page, m.summaries, units, m.force_note)
    if m.complete:
        _drift_section(page, m.cycles, warn)
    for heading, header, rows in tables:
        page.section(heading)
        page.table(header, rows)
    _peak_figures(page, m, out_dir, live, raw_force, say)
    if fit is not None:
        say("fit figures")
        _fit_section(page, fit, m.tests, out_dir, units)
    _documents(page, diag, ride_doc, extra_sections, diagnose_dir, out_dir, units)
    if m.drawable:
        say("loops per click")
        _loops_section(page, m.drawable, out_dir, m.gas_force_n, live)
    page.close_details()
    page.raw(live.tail())
    index = out_dir / "index.html"
    write_text_atomic(index, page.render())
    return index


def _measure(
    tests: list[TestData],
    fit: FitResult | None,
    gas_force_n: float | None,
    raw_force: bool,
    gas_given: Mapping[int, float] | None,
    gas_limit: gas_force.Charge | None,
    units: Units,
) -> _Measured:
    """The tests' gas forces, summaries, drawable curves and cycles; the static gas force
    to mark (given, else the fit's, else the median of the recording's)."""
    forces = gas_force.gas_forces(tests, gas_given, gas_limit)  # given, measured, estimated
    tests = gas_force.apply(tests, forces)
    summaries = [summarise(t, gas_force_n=None if raw_force else t.meta.gas_force_n) for t in tests]
    drawable = [
        plots.prepare(t, s)
        for t, s in zip(tests, summaries, strict=True)
        if s.n_samples >= MIN_SAMPLES
    ]
    complete = [c for c in drawable if not c.aborted and _finite(c.summary)]
    if fit is not None and gas_force_n is None:
        gas_force_n = clickchart.static_force_n(fit)
    known = [t.meta.gas_force_n for t in tests if t.meta.gas_force_n is not None]
    if gas_force_n is None and known:
        gas_force_n = float(np.median(known))
    force_note = (
        "raw force (gas force included)" if raw_force else gas_force.describe_forces(forces, units)
    )
    # Per-cycle peaks and chart readings, once: the chart's bands, drift, the peak bands.
    cycles = repeatability.sweep_cycles([c.test for c in complete], units.standard_velocities_m_s)
    lines = adjusters.lines([c.test for c in complete])  # a damper with several adjusters
    return _Measured(
        tests, forces, summaries, drawable, complete, cycles, lines, gas_force_n, force_note
    )


def _recording_section(
    page: Page,
    metadata: dict[str, str] | None,
    forces: gas_force.GasForces,
    raw_force: bool,
    units: Units,
    warn: Callable[[str], None] | None,
) -> None:
    """The recording's metadata table and the gas force's warnings, on the page and
    through ``warn``."""
    if metadata:
        page.section("Recording")
        page.table(["key", "value"], [[k, shown_path(str(v))] for k, v in metadata.items()])
    for text in [] if raw_force else gas_force.warnings(forces, units):
        page.paragraph(f"Gas force: {text}.", warn=True)
        if warn is not None:
            warn(text)


def _click_charts(
    page: Page,
    m: _Measured,
    fit: FitResult | None,
    out_dir: Path,
    live: Interactive,
    raw_force: bool,
    reference_temperature_c: float,
    say: Callable[[str], None],
) -> None:
    """The click chart and its temperature-corrected twin: one adjuster's line each, or
    one for the complete tests of a damper with a single adjuster."""
    units = live.units
    for name, line in m.lines.items():
        say(f"click chart: {name} adjuster")
        held = adjusters.held(name, adjusters.base([t.meta.adjusters for t in line]))
        line_cycles = repeatability.sweep_cycles(line, units.standard_velocities_m_s)
        line_fit = fit.for_adjuster(name) if fit is not None else None
        _click_chart_section(
            page, line, line_fit, out_dir, live, raw_force, line_cycles, m.forces, (name, held)
        )
        temperature.render(
            page, line, line_fit, reference_temperature_c, out_dir, raw_force, units, name
        )
    if m.complete and not m.lines:
        say("click chart")
        _click_chart_section(
            page, [c.test for c in m.complete], fit, out_dir, live, raw_force, m.cycles, m.forces
        )
        temperature.render(
            page,
            [c.test for c in m.complete],
            fit,
            reference_temperature_c,
            out_dir,
            raw_force,
            units,
        )


def _peak_figures(
    page: Page,
    m: _Measured,
    out_dir: Path,
    live: Interactive,
    raw_force: bool,
    say: Callable[[str], None],
) -> None:
    """Peak force against peak velocity and the overlays across clicks: one adjuster's
    line each, or one set for the complete tests of a damper with a single adjuster."""
    units = live.units
    for name, line in m.lines.items():  # a damper with several adjusters: one's line each
        say(f"peak and overlay figures: {name} adjuster")
        drawn = [
            plots.prepare(t, summarise(t, gas_force_n=None if raw_force else t.meta.gas_force_n))
            for t in line
        ]
        line_cycles = repeatability.sweep_cycles(line, units.standard_velocities_m_s)
        _peaks_and_overlays(
            page, drawn, out_dir, m.gas_force_n, live, line_cycles, m.force_note, name
        )
    if m.complete and not m.lines:
        say("peak and overlay figures")
        _peaks_and_overlays(page, m.complete, out_dir, m.gas_force_n, live, m.cycles, m.force_note)


def _documents(
    page: Page,
    diag: DiagnosisDoc | None,
    ride_doc: RideDoc | None,
    extra_sections: Sequence[Section],
    diagnose_dir: Path | None,
    out_dir: Path,
    units: Units,
) -> None:
    """The diagnosis (with its figures), the ride study and the caller's extra figures."""
    if diag is not None:
        render_diagnose(page, diag, units)
        render_figures(page, diag, diagnose_dir, lambda png, n: _link_extra(out_dir, png, n), units)
    if ride_doc is not None:
        render_ride(page, ride_doc, units)
    # After the ride table: the ride page's figures follow the numbers they illustrate.
    for n, (heading, figures) in enumerate(extra_sections):
        page.section(heading)
        for m, (caption, png) in enumerate(figures):
            page.figure(_link_extra(out_dir, png, 100 * n + m), caption)


def _click_chart_section(
    page: Page,
    tests: list[TestData],
    fit: FitResult | None,
    out_dir: Path,
    live: Interactive,
    raw_force: bool,
    cycles: list[repeatability.TestCycles],
    forces: gas_force.GasForces,
    adjuster: tuple[str, str] | None = None,
) -> None:
    """The click chart; `adjuster`: (name, what the others were held at) of one adjuster's
    line of a damper with several, its own section and files (click_chart_NAME.*)."""
    units = live.units
    stem = f"click_chart_{adjuster[0]}" if adjuster else "click_chart"
    chart = clickchart.click_chart(
        tests, fit, units.standard_velocities_m_s, raw_force=raw_force, gas=forces
    )
    u = f"{units.force_label}; velocity in {units.velocity_label}"
    scatter = repeatability.chart_scatter(cycles, chart.velocities_m_s)
    band = repeatability.chart_band(scatter)
    widest = repeatability.widest(band)
    removed = any(f.removed for f in forces.values())
    what = (
        "Force (raw, gas force included: --raw-force)"
        if raw_force
        else ("Damping force (" if removed else "Force (")
        + gas_force.describe_forces(forces, units)
        + ("; the model's own force at rest removed from its values alike" if fit else "")
        + "; --raw-force shows the force as measured)"
    )
    page.section(
        f"Click chart: {adjuster[0]} adjuster ({adjuster[1]})" if adjuster else "Click chart",
        f"{what} at standard velocities per click, compression (comp, velocity > 0) and "
        f"rebound (reb, velocity < 0), in {units.force_label}. Measured: the force of each "
        "test's force-velocity branch where it passes the velocity (every crossing of the "
        "measured cycles averaged), then averaged over the click's frequencies.",
    )
    label = f"{adjuster[0]} clicks" if adjuster else "rod clicks"
    png = force_vs_clicks(chart, out_dir / f"{stem}.png", band, units, clicks_label=label).name
    caption = (
        "Force against clicks at each standard velocity: measured (solid; hollow markers "
        "extrapolated)" + (", fitted model (dashed)" if chart.model_curve else "") + ". "
        "Bars: ±2 SD of the single cycles' readings (cycle-to-cycle band"
        + (
            f", at most ±{units.force(widest):.1f} {units.force_label})."
            if math.isfinite(widest)
            else "; none known)."
        )
    )
    page.raw(live.figure(png, caption, click_charts(live.units, chart, band, label)))
    write_text_atomic(out_dir / f"{stem}.csv", clickchart.to_csv(chart, units))
    header, rows = clickchart.table_rows(chart, "measured", units)
    page.subheading(f"Measured ({u})")
    page.table(header, rows, numeric=[True] * len(header))
    if chart.any_extrapolated:
        page.paragraph(
            "* extrapolated: no test of that click reaches the velocity; the value is a "
            "straight line through the top 30 % of the fastest test's branch. Sweep by target "
            "velocity (shockdyno sweep --velocities-mm-s) to measure it."
        )
    if chart.model:
        header, rows = clickchart.table_rows(chart, "model", units)
        page.subheading(f"Fitted model ({u}; mid-stroke, zero acceleration)")
        # A long sweep's second table of the same shape is opened on demand.
        page.details(f"{len(rows)} click settings", opened=len(rows) <= OPEN_SUMMARY_MAX_ROWS)
        page.table(header, rows, numeric=[True] * len(header))
        page.close_details()
    also = " and the model's" if chart.model else ""
    cols = clickchart.csv_header(units)
    held = "raw force" if raw_force else f"damping force, the gas force removed in {cols[-1]}"
    page.link(
        f"{stem}.csv",
        f"{stem}.csv",
        f": the measured values{also} as CSV ({cols[2]}, {cols[4]}; {held}).",
    )


def _summary_section(
    page: Page, summaries: list[TestSummary], units: Units, force_note: str
) -> None:
    page.section("Summary", f"{SUMMARY_LEGEND} F comp / F reb: {force_note}.")
    n_aborted = sum(s.meta.status != "complete" for s in summaries)
    if n_aborted:
        page.paragraph(f"{n_aborted} of {len(summaries)} tests did not complete (marked).")
    long = len(summaries) > OPEN_SUMMARY_MAX_ROWS
    page.details(f"Summary table: {len(summaries)} tests", opened=not long)
    header = summary_header(units)
    page.table(
        header,
        [summary_row(s, units) for s in summaries],
        row_classes=["" if s.meta.status == "complete" else "aborted" for s in summaries],
        numeric=[True] * (len(header) - 1) + [False],
    )
    page.close_details()


def _drift_section(
    page: Page, cycles: list[repeatability.TestCycles], warn: Callable[[str], None] | None
) -> None:
    """Tests whose cycles drift, on the page and through ``warn`` (one line each)."""
    found = repeatability.drifts(cycles)
    page.section(
        "Repeatability",
        "Cycle-to-cycle bands on the click chart and the peak-force plot are ±2 SD of the "
        "single cycles. A drift: a straight line through a test's per-cycle peak force whose "
        f"slope is over {repeatability.DRIFT_T:g}x its SD and changes the force by "
        f"{100 * repeatability.DRIFT_MIN_SHARE:g} % or more over the test "
        f"({repeatability.DRIFT_MIN_CYCLES} cycles or more).",
    )
    if not found:
        checked = sum(c.n_cycles >= repeatability.DRIFT_MIN_CYCLES for c in cycles)
        page.paragraph(f"No drift in the {checked} tests with enough cycles to tell.")
    for d in found:
        page.paragraph("Drift: " + d.text() + ".", warn=True)
        if warn is not None:
            warn(d.text())


def _peaks_and_overlays(
    page: Page,
    complete: list[plots.Curves],
    out_dir: Path,
    gas_force_n: float | None,
    live: Interactive,
    cycles: list[repeatability.TestCycles],
    force_note: str,
    adjuster: str = "",
) -> None:
    """`adjuster`: the figures of one adjuster's line, named for it (peaks_NAME.png)."""
    units = live.units
    of = f": {adjuster} adjuster" if adjuster else ""
    tag = f"_{adjuster}" if adjuster else ""
    page.section(f"Peak force vs peak velocity{of}")
    band = repeatability.peak_band(cycles)
    peaks = plots.peak_curves(
        [c.summary for c in complete], out_dir / f"peaks{tag}.png", band, units
    )
    caption = (
        f"One curve per click through its test frequencies; complete tests only; {force_note}. "
        "Bars: ±2 SD of the test's per-cycle peak force (cycle-to-cycle band)."
    )
    page.raw(live.figure(peaks.name, caption, peak_charts(live.units, complete, band)))
    page.section(f"Overlays across clicks{of}")
    by_freq: dict[float, list[plots.Curves]] = {}
    for c in complete:
        by_freq.setdefault(round(c.test.meta.frequency_hz, 6), []).append(c)
    for k, (f, group) in enumerate(sorted(by_freq.items())):
        page.details(f"{f:g} Hz: every click", opened=k == 0)
        png = plots.frequency_overlay(
            group,
            f,
            out_dir / _freq_name(f).replace("overlay", f"overlay{tag}"),
            gas_force_n,
            units,
        )
        caption = f"{f:g} Hz: every click, named in the legend; complete tests."
        page.raw(live.figure(png.name, caption, live.overlay(group, gas_force_n)))
    page.close_details()


def _fit_section(
    page: Page, fit: FitResult, tests: list[TestData], out_dir: Path, units: Units
) -> None:
    # Here, not at the top: the fit's plots load 183 modules (matplotlib's) that a report
    # without a fit never needs (bench_startup --marginal).
    from shockdyno.fit.plots import fit_figures

    page.section(
        "Fit and validation",
        f"Damper model of the fit ({len(fit.clicks)} click settings; where it came from: the "
        f"Recording table's 'fit' row; base spec {shown_path(fit.spec_path)}). Errors of the "
        "proposed model and of Talbott's single-bleed model per test frequency, averaged "
        "over clicks (the paper's Table 4):",
    )
    header, rows = table4_rows(fit)
    if rows:
        page.table(header, rows, numeric=[False, False, True, True, True])
    header, rows = globals_rows(fit, units)  # engineering units: bar, mm, mm²; JSON stays SI
    if rows:
        page.paragraph("Calibrated globals (±1σ) beside the spec's values:")
        page.table(header, rows, numeric=[False, True, True, True, False, True])
    page.definitions(ERROR_MEASURES)
    lines = adjusters.lines(tests)
    views = [(f"{n} adjuster: ", fit.for_adjuster(n), line, n) for n, line in lines.items()]
    for head, view, line, name in views or [("", fit, tests, "")]:
        for caption, png in fit_figures(view, line, out_dir, units, name):
            page.figure(_link_extra(out_dir, png, 0), head + caption)


def _loops_section(
    page: Page,
    drawable: list[plots.Curves],
    out_dir: Path,
    gas_force_n: float | None,
    live: Interactive,
) -> None:
    units = live.units
    page.section(
        "Loops per click",
        "Force-displacement and force-velocity over the measured cycles, one click's "
        "frequencies overlaid; aborted tests dashed and labelled. Open a click to see it."
        + (" Dotted: the static gas force." if gas_force_n is not None else ""),
    )
    by_click: dict[tuple[int, int, tuple[tuple[str, int], ...]], list[plots.Curves]] = {}
    for c in drawable:
        m = c.test.meta
        by_click.setdefault((m.clicks, m.gas_clicks, m.setting), []).append(c)
    for (clicks, gas, _setting), group in sorted(by_click.items()):
        freqs = ", ".join(f"{c.test.meta.frequency_hz:g}" for c in group)
        aborted = sum(c.aborted for c in group)
        # a damper with several adjusters: every adjuster named, in the sweep's order
        named = group[0].test.meta.adjusters
        where = ", ".join(f"{n} {v}" for n, v in named.items()) or f"clicks {clicks}"
        label = f"{where}, gas clicks {gas}: {freqs} Hz"
        if aborted:
            label += f" ({aborted} not complete)"
        page.details(label, opened=len(by_click) == 1)
        stem = "".join(f"_{n}{v:02d}" for n, v in named.items()) or f"_c{clicks:02d}"
        png = plots.click_loops(group, out_dir / f"loops{stem}_g{gas:02d}.png", gas_force_n, units)
        caption = f"{where}, gas clicks {gas}"
        page.raw(live.figure(png.name, caption, live.click_loops(group, gas_force_n)))
    page.close_details()
