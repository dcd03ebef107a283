"""What the diagnosis left, described (DIAG.json `verdict.unexplained[]`): where it lies,
the signals it follows, the discovered term tried for it, and a figure of the residual
against the signal it follows most, drawn from the phase means the document holds.

The figure is embedded in the page (a PNG data URI), so a page built from a DIAG.json
alone shows it, with no file beside the JSON to lose. Read, not recomputed: the points
are the diagnosis's own.
"""

from __future__ import annotations

import base64
import io
from html import escape

import numpy as np
from matplotlib.figure import Figure

from shockdyno.figures import save_png
from shockdyno.report.documents import ResidualPlot, Unexplained, UnnamedTerm
from shockdyno.report.html import Page
from shockdyno.units import SI, Units

DPI = 100


def _axis(unit: str, units: Units) -> tuple[float, str]:
    """Scale and label of a signal stored in SI `unit`, as the figure shows it."""
    if unit == "s":
        return 1 / 60, "min"
    if unit == "m":
        return units.length_per_m, units.length_label
    if unit == "N":
        return units.force_per_n, units.force_label
    if unit == "1":
        return 1.0, ""
    return 1.0, unit


def figure_png(plot: ResidualPlot, units: Units = SI) -> bytes:
    """The residual's phase means against the signal, with the force the discovered term
    removes (beside the model's own parameters: DIAG.json's `plot.term`)."""
    scale, label = _axis(plot.unit, units)
    x = np.asarray(plot.x) * scale
    fn = units.force_per_n
    fig = Figure(figsize=(8, 4.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(x, np.asarray(plot.residual) * fn, ".", ms=3, color="0.45", label="residual")
    if plot.term and len(plot.term) == len(plot.x):
        term = np.asarray(plot.term) * fn
        ax.plot(x, term, ".", ms=3, color="#d62728", label="removed by the discovered term")
    ax.axhline(0.0, color="0.6", lw=0.8)
    name = plot.label_imperial if units.imperial and plot.label_imperial else plot.label
    ax.set_xlabel(name + (f" ({label})" if label else ""))
    ax.set_ylabel(f"measured − model ({units.force_label})")
    ax.set_title("What is left (phase means, every test) against what it follows")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8, markerscale=3)
    buf = io.BytesIO()
    save_png(fig, buf, DPI)
    return buf.getvalue()


def _term_rows(term: UnnamedTerm, units: Units) -> list[list[str]]:
    imperial = units.imperial
    return [
        [
            (c.label_imperial if imperial and c.label_imperial else c.label),
            (c.symbol_imperial if imperial and c.symbol_imperial else c.symbol),
            (c.text_imperial if imperial and c.text_imperial else c.text)
            or f"{c.value} ± {c.sd} {c.unit}",
        ]
        for c in term.coefficients
    ]


def render_unexplained(page: Page, items: tuple[Unexplained, ...], units: Units = SI) -> None:
    """Each described residual: the signals it follows, its discovered term, its figure.
    An older DIAG.json's regions alone show nothing here (the verdict lists them)."""
    for item in items:
        if not (item.follows or item.term or item.plot):
            continue
        page.subheading("What is left: described")
        if item.phase:
            page.paragraph(f"Where in the cycle: {item.phase}.")
        if item.follows:
            page.table(
                ["signal", "share alone", "rises with it", "as a library term would"],
                [
                    [
                        f.label_imperial if units.imperial and f.label_imperial else f.label,
                        f"{100 * f.share:.0f} %",
                        "yes" if f.rises_with_it else "no (falls)",
                        ", ".join(f.resembles) or "– (none)",
                    ]
                    for f in item.follows
                ],
                numeric=[False, True, False, False],
            )
        term = item.term
        if term is not None and term.coefficients:
            form = term.form_imperial if units.imperial and term.form_imperial else term.form
            gain = "–" if term.heldout_gain is None else f"{100 * term.heldout_gain:.0f} %"
            state = (
                "claimed as unnamed physics" + (f" ({term.hint}?)" if term.hint else "")
                if term.claimed
                else f"not claimed: {term.why_not}"
            )
            page.paragraph(
                f"Discovered term: {form}; it removes {gain} of the held-out structure "
                f"(median fold): {state}.",
                warn=term.claimed,
            )
            page.table(
                ["signal", "symbol", "coefficient (± 1σ)"],
                _term_rows(term, units),
                numeric=[False, False, True],
            )
            if term.heldout_detail and not units.imperial:  # its forces are N
                page.paragraph(f"Held out (structure RMS per fold): {term.heldout_detail}.")
        if item.plot is not None and item.plot.x:
            data = base64.b64encode(figure_png(item.plot, units)).decode("ascii")
            shown = item.plot.label
            if units.imperial and item.plot.label_imperial:
                shown = item.plot.label_imperial
            caption = (
                f"The residual left (grey) against {shown}, and the force the discovered "
                "term removes (red): one point per test and phase bin."
            )
            page.raw(
                f'<figure><img src="data:image/png;base64,{data}" '
                f'alt="{escape(caption, quote=True)}"><figcaption>{escape(caption)}'
                "</figcaption></figure>"
            )
