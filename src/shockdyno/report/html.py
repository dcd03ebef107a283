"""The report page: one HTML file with inline CSS (and print script) that links PNGs beside it."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from html import escape
from pathlib import Path

from shockdyno.report.summary import TestSummary
from shockdyno.units import SI, Units

CSS = """
body { font-family: system-ui, sans-serif; margin: 1.2em auto; max-width: 1200px;
       padding: 0 1em; color: #222; line-height: 1.4; }
h1 { margin-bottom: 0.2em; font-size: 1.6em; }
h2 { margin-top: 1.6em; border-bottom: 1px solid #ddd; }
.scroll { overflow-x: auto; max-width: 100%; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.45em; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
th { background: #f2f2f2; font-weight: 600; }
tr.aborted td, tr.flag td { background: #fde8e8; color: #8a1c1c; }
tr.dim td { color: #777; }
td.flag { background: #fde8e8; color: #8a1c1c; font-weight: 600; }
figure { margin: 0.8em 0 1.6em; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #555; }
nav a { margin-right: 1em; white-space: nowrap; }
details { margin: 0.4em 0; }
details > summary { cursor: pointer; font-weight: 600; padding: 0.2em 0; }
dl.defs dt { font-weight: 600; margin-top: 0.4em; }
dl.defs dd { margin-left: 1.5em; }
p.warn { background: #fff4e0; border-left: 4px solid #c76b00; padding: 0.4em 0.7em; }
"""

# Print-to-PDF is the report on paper: every section expanded (with PRINT_SCRIPT), no
# navigation, no figure or table split across pages.
PRINT_CSS = """
@media print {
  body { max-width: none; margin: 0; padding: 0; font-size: 10pt; }
  nav { display: none; }
  details > summary { list-style: none; cursor: auto; }
  details > summary::-webkit-details-marker { display: none; }
  details::details-content { content-visibility: visible; display: contents; }
  .scroll { overflow: visible; }
  figure, table, tr, img, p.warn { break-inside: avoid; page-break-inside: avoid; }
  h2, h3, details > summary { break-after: avoid; page-break-after: avoid; }
  figure img { border: none; max-height: 24cm; }
  a { color: inherit; text-decoration: none; }
}
"""

# CSS cannot open a <details> (its content stays unrendered), and a lazy image that was
# never scrolled to prints blank: a print does not wait for an image that starts loading
# when it begins. So the images load lazily at first (the page opens at once) and the
# rest in the background once it has loaded; before printing, every block is opened (and
# any image still lazy loads); after, what was closed is closed again.
PRINT_SCRIPT = """
const shockdynoEager = () => document.querySelectorAll('img[loading="lazy"]')
  .forEach(i => { i.loading = 'eager'; });
addEventListener('load', () => setTimeout(shockdynoEager, 300));
addEventListener('beforeprint', () => {
  document.querySelectorAll('details:not([open])').forEach(d => {
    d.dataset.printed = '1'; d.open = true; });
  shockdynoEager();
});
addEventListener('afterprint', () => {
  document.querySelectorAll('details[data-printed]').forEach(d => {
    d.open = false; delete d.dataset.printed; });
});
"""

# Short headers, so the 13 columns fit an 800 px window; the section text says what
# each one is.
SUMMARY_HEADER = [
    "test",
    "clicks",
    "gas",
    "f (Hz)",
    "A (mm)",
    "F comp (N)",
    "F reb (N)",
    "v comp (m/s)",
    "v reb (m/s)",
    "T (°C)",
    "dropped",
    "samples",
    "status",
]
SUMMARY_LEGEND = (
    "F comp / F reb: peak compression / rebound force over the measured cycles (forces > 0 "
    "resist compression; rebound values are signed). v comp / v reb: peak compression / "
    "rebound velocity, from the Savitzky-Golay derivative of displacement. T: mean "
    "temperature over the measured cycles. dropped: frames lost over the whole test. "
    "samples: samples in the measured window."
)


def summary_header(units: Units = SI) -> list[str]:
    """SUMMARY_HEADER, or its imperial twin (in, lbf, in/s, °F)."""
    if not units.imperial:
        return SUMMARY_HEADER
    head = list(SUMMARY_HEADER)
    head[4:10] = [
        f"A ({units.length_label})",
        f"F comp ({units.force_label})",
        f"F reb ({units.force_label})",
        f"v comp ({units.velocity_label})",
        f"v reb ({units.velocity_label})",
        f"T ({units.temperature_label})",
    ]
    return head


def _num(value: float | None, spec: str) -> str:
    if value is None or math.isnan(value):
        return "–"
    return format(value, spec)


def summary_row(s: TestSummary, units: Units = SI) -> list[str]:
    """The summary table's cells for one test, formatted as displayed (SI: m/s as of old;
    imperial: in, lbf, in/s, °F)."""
    # m/s to 4 decimals resolves 0.1 mm/s; in/s to 3 resolves 0.025 mm/s.
    v_scale, v_spec = (units.velocity_per_m_s, ".3f") if units.imperial else (1.0, ".4f")
    length = ".2f" if units.imperial else ".1f"
    temp = None if s.temperature_c is None else units.temperature(s.temperature_c)
    m = s.meta
    return [
        str(m.index),
        # every adjuster's clicks of a damper with several
        ", ".join(f"{n} {v}" for n, v in m.adjusters.items()) or str(m.clicks),
        str(m.gas_clicks),
        _num(m.frequency_hz, ".3g"),
        _num(units.length(m.amplitude_m), length),
        _num(units.force(s.peak_compression_force_n), ".1f"),
        _num(units.force(s.peak_rebound_force_n), ".1f"),
        _num(v_scale * s.peak_compression_velocity_m_s, v_spec),
        _num(v_scale * s.peak_rebound_velocity_m_s, v_spec),
        _num(temp, ".1f"),
        "–" if s.dropped_frames is None else str(s.dropped_frames),
        str(s.n_samples),
        m.status,
    ]


@dataclass
class Page:
    """Accumulates sections and renders them in order."""

    title: str
    parts: list[str] = field(default_factory=list)
    toc: list[tuple[str, str]] = field(default_factory=list)
    _open_details: int = 0

    def section(self, heading: str, intro: str = "") -> None:
        self.close_details()
        anchor = f"s{len(self.toc) + 1}"
        self.toc.append((anchor, heading))
        self.parts.append(f'<h2 id="{anchor}">{escape(heading)}</h2>')
        if intro:
            self.parts.append(f"<p>{escape(intro)}</p>")

    def subheading(self, text: str) -> None:
        self.parts.append(f"<h3>{escape(text)}</h3>")

    def details(self, summary: str, *, opened: bool = False) -> None:
        """Start a collapsible block; it ends at the next details, section or the end."""
        self.close_details()
        self.parts.append(
            f"<details{' open' if opened else ''}><summary>{escape(summary)}</summary>"
        )
        self._open_details = 1

    def close_details(self) -> None:
        if self._open_details:
            self.parts.append("</details>")
            self._open_details = 0

    def figure(self, href: str, caption: str) -> None:
        src = escape(href, quote=True)
        self.parts.append(
            f'<figure><a href="{src}"><img src="{src}" alt="{escape(caption, quote=True)}"'
            f' loading="lazy"></a><figcaption>{escape(caption)}</figcaption></figure>'
        )

    def raw(self, fragment: str) -> None:
        """Markup made elsewhere (report/interactive.py's figures and script), as it is."""
        self.parts.append(fragment)

    def table(
        self,
        header: Sequence[str],
        rows: Sequence[Sequence[str]],
        row_classes: Sequence[str] | None = None,
        numeric: Sequence[bool] | None = None,
        cell_classes: Sequence[Sequence[str]] | None = None,
    ) -> None:
        out = ['<div class="scroll"><table>', "<thead><tr>"]
        # str(): tables handed in by other stages may carry numbers, not only text.
        out += [f"<th>{escape(str(h))}</th>" for h in header]
        out.append("</tr></thead><tbody>")
        for i, row in enumerate(rows):
            cls = row_classes[i] if row_classes else ""
            out.append(f'<tr class="{escape(cls, quote=True)}">' if cls else "<tr>")
            for j, value in enumerate(row):
                names = []
                if numeric is not None and j < len(numeric) and numeric[j]:
                    names.append("num")
                if cell_classes is not None and j < len(cell_classes[i]) and cell_classes[i][j]:
                    names.append(cell_classes[i][j])
                attr = f' class="{escape(" ".join(names), quote=True)}"' if names else ""
                out.append(f"<td{attr}>{escape(str(value))}</td>")
            out.append("</tr>")
        out.append("</tbody></table></div>")
        self.parts.append("".join(out))

    def paragraph(self, text: str, *, warn: bool = False) -> None:
        cls = ' class="warn"' if warn else ""
        self.parts.append(f"<p{cls}>{escape(text)}</p>")

    def link(self, text: str, href: str, after: str = "") -> None:
        """A paragraph with one link (to a file beside the page)."""
        a = f'<a href="{escape(href, quote=True)}">{escape(text)}</a>'
        self.parts.append(f"<p>{a}{escape(after)}</p>")

    def definitions(self, items: Sequence[tuple[str, str]]) -> None:
        body = "".join(f"<dt>{escape(t)}</dt><dd>{escape(d)}</dd>" for t, d in items)
        self.parts.append(f'<dl class="defs">{body}</dl>')

    def render(self) -> str:
        self.close_details()
        nav = " ".join(f'<a href="#{a}">{escape(h)}</a>' for a, h in self.toc)
        body = "\n".join(self.parts)
        return (
            "<!DOCTYPE html>\n"
            '<html lang="en"><head><meta charset="utf-8">'
            '<meta name="generator" content="shockdyno">'  # outputs.py: --force may replace it
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{escape(self.title)}</title><style>{CSS}{PRINT_CSS}</style>"
            f"<script>{PRINT_SCRIPT}</script></head>\n"
            f"<body><h1>{escape(self.title)}</h1>\n<nav>{nav}</nav>\n{body}\n</body></html>\n"
        )


def shown_path(text: str) -> str:
    """A path as a page may show it: relative to the working directory when under it, else
    its last two parts. A report is handed on; this machine's layout (/home/jd/...) is
    not the reader's business. Anything that is not an absolute path is left as it is."""
    if not text.startswith("/"):
        return text
    p = Path(text)
    try:
        return str(p.relative_to(Path.cwd()))
    except ValueError:
        return str(Path("…", *p.parts[-2:])) if len(p.parts) > 2 else text
