"""The report page: one HTML file with inline CSS that links PNGs beside it."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from html import escape

from shockdyno.report.summary import TestSummary

CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; }
h1 { margin-bottom: 0.2em; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.55em; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
th { background: #f2f2f2; }
tr.aborted td { background: #fde8e8; color: #8a1c1c; }
figure { margin: 0.8em 0 1.6em; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #555; }
nav a { margin-right: 1em; }
"""

SUMMARY_HEADER = [
    "test",
    "clicks",
    "gas clicks",
    "frequency (Hz)",
    "amplitude (mm)",
    "peak compression force (N)",
    "peak rebound force (N)",
    "peak compression velocity (m/s)",
    "peak rebound velocity (m/s)",
    "temperature (°C)",
    "dropped frames",
    "samples",
    "status",
]


def _num(value: float | None, spec: str) -> str:
    if value is None or math.isnan(value):
        return "–"
    return format(value, spec)


def summary_row(s: TestSummary) -> list[str]:
    """The summary table's cells for one test, formatted as displayed."""
    return [
        str(s.index),
        str(s.clicks),
        str(s.gas_clicks),
        _num(s.frequency_hz, ".3g"),
        _num(s.amplitude_m * 1e3, ".1f"),
        _num(s.peak_compression_force_n, ".1f"),
        _num(s.peak_rebound_force_n, ".1f"),
        _num(s.peak_compression_velocity_m_s, ".4f"),
        _num(s.peak_rebound_velocity_m_s, ".4f"),
        _num(s.temperature_c, ".1f"),
        "–" if s.dropped_frames is None else str(s.dropped_frames),
        str(s.n_samples),
        s.status,
    ]


@dataclass
class Page:
    """Accumulates sections and renders them in order."""

    title: str
    parts: list[str] = field(default_factory=list)
    toc: list[tuple[str, str]] = field(default_factory=list)

    def section(self, heading: str, intro: str = "") -> None:
        anchor = f"s{len(self.toc) + 1}"
        self.toc.append((anchor, heading))
        self.parts.append(f'<h2 id="{anchor}">{escape(heading)}</h2>')
        if intro:
            self.parts.append(f"<p>{escape(intro)}</p>")

    def subheading(self, text: str) -> None:
        self.parts.append(f"<h3>{escape(text)}</h3>")

    def figure(self, href: str, caption: str) -> None:
        src = escape(href, quote=True)
        self.parts.append(
            f'<figure><a href="{src}"><img src="{src}" alt="{escape(caption, quote=True)}"'
            f' loading="lazy"></a><figcaption>{escape(caption)}</figcaption></figure>'
        )

    def table(
        self,
        header: Sequence[str],
        rows: Sequence[Sequence[str]],
        row_classes: Sequence[str] | None = None,
        numeric: Sequence[bool] | None = None,
    ) -> None:
        out = ["<table>", "<thead><tr>"]
        # str(): tables handed in by other stages may carry numbers, not only text.
        out += [f"<th>{escape(str(h))}</th>" for h in header]
        out.append("</tr></thead><tbody>")
        for i, row in enumerate(rows):
            cls = row_classes[i] if row_classes else ""
            out.append(f'<tr class="{escape(cls, quote=True)}">' if cls else "<tr>")
            for j, value in enumerate(row):
                cell = str(value)
                num = numeric is not None and j < len(numeric) and numeric[j]
                out.append(
                    f'<td class="num">{escape(cell)}</td>' if num else f"<td>{escape(cell)}</td>"
                )
            out.append("</tr>")
        out.append("</tbody></table>")
        self.parts.append("".join(out))

    def paragraph(self, text: str) -> None:
        self.parts.append(f"<p>{escape(text)}</p>")

    def render(self) -> str:
        nav = " ".join(f'<a href="#{a}">{escape(h)}</a>' for a, h in self.toc)
        body = "\n".join(self.parts)
        return (
            "<!DOCTYPE html>\n"
            '<html lang="en"><head><meta charset="utf-8">'
            f"<title>{escape(self.title)}</title><style>{CSS}</style></head>\n"
            f"<body><h1>{escape(self.title)}</h1>\n<nav>{nav}</nav>\n{body}\n</body></html>\n"
        )
