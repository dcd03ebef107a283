"""Assemble the sweep report: PNGs and one ``index.html`` in the output directory.

Files written (all inside ``out_dir``, fixed names, so a re-run overwrites its own files
and touches nothing else):

- ``index.html``
- ``peaks.png``: peak force vs peak velocity per click (complete tests)
- ``overlay_<f>Hz.png``: every click at one frequency, coloured by clicks (complete tests)
- ``loops_c<clicks>_g<gas>.png``: loops of one click setting, a row per test (all tests)
- ``extra/<n>_<name>``: copies of ``extra_sections`` PNGs that live outside ``out_dir``
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Sequence
from pathlib import Path

from shockdyno.errors import ConfigError
from shockdyno.record.atomic import write_text_atomic
from shockdyno.record.types import TestData
from shockdyno.report import plots
from shockdyno.report.html import SUMMARY_HEADER, Page, summary_row
from shockdyno.report.summary import TestSummary, summarise

Section = tuple[str, list[tuple[str, Path]]]
Table = tuple[str, list[str], list[list[str]]]

MIN_SAMPLES = 8  # fewer measured samples than this make no loop worth drawing


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


def build_report(
    tests: list[TestData],
    out_dir: Path,
    *,
    title: str,
    metadata: dict[str, str] | None = None,
    extra_sections: Sequence[Section] = (),
    tables: Sequence[Table] = (),
) -> Path:
    """Write the report for ``tests`` into ``out_dir``; returns the path of index.html."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"report directory is a file: {out_dir}")
    out_dir.mkdir(parents=True, exist_ok=True)

    summaries = [summarise(t) for t in tests]
    drawable = [
        plots.prepare(t, s)
        for t, s in zip(tests, summaries, strict=True)
        if s.n_samples >= MIN_SAMPLES
    ]
    complete = [c for c in drawable if not c.aborted and _finite(c.summary)]

    page = Page(title)
    if metadata:
        page.section("Recording")
        page.table(["key", "value"], [[k, v] for k, v in metadata.items()])

    page.section(
        "Summary",
        "Peaks over the measured cycles; forces > 0 resist compression, rebound values are "
        "signed. Velocity from the Savitzky-Golay derivative of displacement. Temperature is "
        "the mean over the measured cycles.",
    )
    n_aborted = sum(s.status != "complete" for s in summaries)
    if n_aborted:
        page.paragraph(f"{n_aborted} of {len(summaries)} tests did not complete (marked).")
    page.table(
        SUMMARY_HEADER,
        [summary_row(s) for s in summaries],
        row_classes=["" if s.status == "complete" else "aborted" for s in summaries],
        numeric=[True] * (len(SUMMARY_HEADER) - 1) + [False],
    )

    for heading, header, rows in tables:
        page.section(heading)
        page.table(header, rows)

    if complete:
        page.section("Peak force vs peak velocity")
        page.figure(
            plots.peak_curves([c.summary for c in complete], out_dir / "peaks.png").name,
            "One curve per click through its test frequencies; complete tests only.",
        )
        page.section("Overlays across clicks")
        by_freq: dict[float, list[plots.Curves]] = {}
        for c in complete:
            by_freq.setdefault(round(c.test.meta.frequency_hz, 6), []).append(c)
        for f, group in sorted(by_freq.items()):
            png = plots.frequency_overlay(group, f, out_dir / _freq_name(f))
            page.figure(png.name, f"{f:g} Hz: every click, colour by clicks; complete tests.")

    for n, (heading, figures) in enumerate(extra_sections):
        page.section(heading)
        for m, (caption, png) in enumerate(figures):
            page.figure(_link_extra(out_dir, png, 100 * n + m), caption)

    if drawable:
        page.section(
            "Loops per click",
            "Force-displacement and force-velocity over the measured cycles, a row per test; "
            "aborted tests are drawn dashed in red and labelled.",
        )
        by_click: dict[tuple[int, int], list[plots.Curves]] = {}
        for c in drawable:
            by_click.setdefault((c.test.meta.clicks, c.test.meta.gas_clicks), []).append(c)
        for (clicks, gas), group in sorted(by_click.items()):
            png = plots.click_loops(group, out_dir / f"loops_c{clicks:02d}_g{gas:02d}.png")
            page.figure(png.name, f"clicks {clicks}, gas clicks {gas}")

    index = out_dir / "index.html"
    write_text_atomic(index, page.render())
    return index
