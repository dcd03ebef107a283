"""The imperial page in headless Chromium: the rendered tables and the interactive plots'
axis labels in in/s and lbf, numbers equal to the SI page's converted, the plots drawn
(canvases of non-zero size, no script error), hover, zoom and reset working, nothing
requested from the network, and the PNGs in print. Skipped without Chromium."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from browser import find_chromium, open_page

CHROMIUM = find_chromium()
pytestmark = pytest.mark.browser  # skipped without Chromium (tests/conftest.py)

LBF = 4.4482216152605  # N per lbf
INCH = 0.0254

# Runs after the probe has opened every <details> (building the plots inside them).
# Hovers the first point of the click chart's first series, then drags a box and
# double-clicks on the peak-force plot.
READ = """
(async () => {
  const frame = () => new Promise(r => requestAnimationFrame(() => r()));
  await frame();
  const text = e => e ? e.innerText.trim() : null;
  const charts = Array.from(document.querySelectorAll('.sd-chart')).map(el => {
    const c = el.querySelector('canvas');
    return {title: text(el.querySelector('.sd-title')), x: text(el.querySelector('.sd-xlab')),
            y: text(el.querySelector('.sd-ylab')),
            canvas: c ? [c.clientWidth, c.clientHeight] : [0, 0], built: !!el._uplot};
  });
  const tables = Array.from(document.querySelectorAll('table')).map(
      t => Array.from(t.rows).map(r => Array.from(r.cells).map(c => c.innerText.trim())));
  const staticShown = Array.from(document.querySelectorAll('figure.sd-fig > a.sd-static'))
      .map(a => getComputedStyle(a).display !== 'none');
  // uPlot reads its plot's position on mouseenter, ignores moves of zero movement and
  // ends a drag on the document's mouseup: events as a real mouse sends them.
  const mouse = (u, type, x, y) => {
    const r = u.over.getBoundingClientRect();
    const target = type === 'mouseup' ? document : u.over;
    target.dispatchEvent(new MouseEvent(type, {clientX: r.left + x, clientY: r.top + y,
        movementX: 1, movementY: 1, bubbles: true, button: 0, buttons: 1}));
  };
  const first = document.querySelector('.sd-chart');
  let hover = null;
  if (first && first._uplot) {
    const u = first._uplot, x = u.data[1][0][0], y = u.data[1][1][0];
    mouse(u, 'mouseenter', 1, 1);
    mouse(u, 'mousemove', u.valToPos(x, 'x'), u.valToPos(y, 'y'));
    await frame();
    hover = {text: text(first.querySelector('.sd-readout')), x: x, y: y,
             label: first.querySelector('.sd-legend button').innerText.trim()};
  }
  let zoom = null;
  const peaks = Array.from(document.querySelectorAll('.sd-chart')).find(
      el => el.querySelector('.sd-title').innerText.startsWith('peak '));
  if (peaks && peaks._uplot) {
    const u = peaks._uplot, w = u.over.clientWidth, h = u.over.clientHeight;
    const before = [u.scales.x.min, u.scales.x.max];
    mouse(u, 'mouseenter', 1, 1);
    mouse(u, 'mousedown', 0.6 * w, 0.1 * h);
    mouse(u, 'mousemove', 0.9 * w, 0.5 * h);
    mouse(u, 'mouseup', 0.9 * w, 0.5 * h);
    await frame();
    const zoomed = [u.scales.x.min, u.scales.x.max];
    mouse(u, 'dblclick', 0.5 * w, 0.5 * h);
    await frame();
    zoom = {before: before, zoomed: zoomed, reset: [u.scales.x.min, u.scales.x.max]};
  }
  return {charts, tables, staticShown, hover, zoom};
})()
"""


def _table(tables: list[list[list[str]]], first: str, contains: str) -> list[list[str]]:
    return next(t for t in tables if t and t[0][0] == first and contains in t[0])


def _measured(tables: list[list[list[str]]], contains: str) -> dict[tuple[int, str], float]:
    t = _table(tables, "clicks", contains)
    return {
        (int(r[0]), h): float(c.rstrip("*"))
        for r in t[1:]
        for h, c in zip(t[0][1:], r[1:], strict=True)
    }


@pytest.fixture(scope="module")
def seen(imperial_report: Path) -> dict:
    assert CHROMIUM is not None
    report = open_page(CHROMIUM, imperial_report, width=1280, evaluate=READ)
    assert report.errors == [] and report.failed_loads == []
    # Offline: the page asked for itself only (and its own PNGs beside it).
    assert [u for u in report.requests if not u.startswith("file://")] == []
    return dict(report.evaluated)


def test_rendered_tables_and_axis_labels_are_imperial(seen: dict, full_report: Path) -> None:
    charts = seen["charts"]
    assert len(charts) >= 10  # 2 click chart, peaks, 2 per overlay, 2 per click's loops
    for c in charts:
        assert c["built"] and c["canvas"][0] > 100 and c["canvas"][1] > 100, c
        assert "lbf" in c["y"] and "(N)" not in c["y"], c
        assert c["x"] == "rod clicks (open →)" or "in/s" in c["x"] or "(in," in c["x"], c
        assert "mm" not in c["x"] and "m/s" not in c["x"].replace("in/s", ""), c
    assert {c["x"] for c in charts} >= {
        "velocity v (in/s, + compression)",
        "displacement x (in, + compression)",
        "peak velocity (in/s, + compression, − rebound)",
    }
    # The summary as rendered against the SI page's, converted.
    imperial = _table(seen["tables"], "test", "F comp (lbf)")
    assert CHROMIUM is not None
    si_tables = open_page(CHROMIUM, full_report, width=1280, evaluate=READ).evaluated["tables"]
    si = _table(si_tables, "test", "F comp (N)")
    col = {h: k for k, h in enumerate(imperial[0])}
    si_col = {h: k for k, h in enumerate(si[0])}
    assert len(imperial) == len(si) > 1
    for row, si_row in zip(imperial[1:], si[1:], strict=True):
        assert row[0] == si_row[0]
        f_si = float(si_row[si_col["F comp (N)"]])
        assert float(row[col["F comp (lbf)"]]) == pytest.approx(f_si / LBF, abs=0.06)
        v_si = float(si_row[si_col["v reb (m/s)"]])
        assert float(row[col["v reb (in/s)"]]) == pytest.approx(v_si / INCH, abs=0.004)
        t_si = float(si_row[si_col["T (°C)"]])
        assert float(row[col["T (°F)"]]) == pytest.approx(t_si * 1.8 + 32, abs=0.1)
    # Both click-chart tables (measured, fitted model) at the imperial speeds.
    speeds = [["reb 10", "reb 5", "reb 3", "reb 2", "reb 1", "comp 1", "comp 2", "comp 3",
               "comp 5", "comp 10"]]  # fmt: skip
    headers = [t[0][1:] for t in seen["tables"] if t and t[0][0] == "clicks"]
    assert headers == speeds * 2


def test_hover_reads_the_point_in_page_units(seen: dict) -> None:
    hover = seen["hover"]
    assert hover is not None, "the click chart was not drawn"
    # The first series of the compression chart: 1 in/s, its first point click 0.
    assert hover["label"] == "1 in/s"
    text = hover["text"]
    assert text.startswith("1 in/s: clicks 0, F "), text
    assert re.search(r"test\(s\)(, ±[0-9.]+ lbf \(2 SD, cycles\))?$", text), text
    force = float(text.split(", F ")[1].split(" lbf")[0])
    assert force == pytest.approx(hover["y"], rel=1e-3), text
    # The same value as the rendered table's cell (comp 1, click 0), to its rounding.
    measured = _measured(seen["tables"], "comp 1")
    assert hover["y"] == pytest.approx(measured[(0, "comp 1")], abs=0.51)


def test_drag_zooms_and_double_click_resets(seen: dict) -> None:
    zoom = seen["zoom"]
    assert zoom is not None, "the peak-force plot was not drawn"
    lo, hi = zoom["before"]
    zlo, zhi = zoom["zoomed"]
    assert lo < zlo < zhi < hi and (zhi - zlo) < 0.5 * (hi - lo)
    assert zoom["reset"] == pytest.approx(zoom["before"])


def test_every_interactive_figure_keeps_its_png_for_print(imperial_report: Path) -> None:
    assert CHROMIUM is not None
    read = "Array.from(document.querySelectorAll('figure.sd-fig')).map(f => [" \
        "getComputedStyle(f.querySelector('a.sd-static')).display, " \
        "getComputedStyle(f.querySelector('.sd-live')).display])"  # fmt: skip
    screen = open_page(CHROMIUM, imperial_report, evaluate=read).evaluated
    printed = open_page(CHROMIUM, imperial_report, evaluate=read, media="print").evaluated
    assert screen and all(png == "none" and live != "none" for png, live in screen)
    assert all(png != "none" and live == "none" for png, live in printed)
