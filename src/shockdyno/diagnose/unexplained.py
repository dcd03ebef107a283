"""What the search left, in words and as DIAG.json's `verdict.unexplained` (discover.py
finds it; verdict.py calls these; the document's classes: report/documents.py).

`verdict.unexplained` was a list of regions. It is now a list of described residuals;
each keeps the keys of its largest region (so a reader of regions still reads one) and
adds `regions` (all of them), `axes`, `phase_deg`, `phase`, `follows` (the signals it
follows), `term` (the discovered form, claimed or not, with its coefficients and
held-out gain) and `plot` (the phase means against the signal the term follows most,
for the report's figure). docs/diagnose.md documents the keys.
"""

from __future__ import annotations

import math

from shockdyno.diagnose.discover import Coefficient, Described, Discovered, hint, phase_words
from shockdyno.report import documents as docs
from shockdyno.schema import finite_or_none
from shockdyno.units import IMPERIAL, SI, Units


def coefficient_text(c: Coefficient, u: Units = SI) -> str:
    """A coefficient in the reader's units: "+1.2 ± 0.1 N/min·t"'s number and unit."""
    fn, fl = u.force_per_n, u.force_label
    ln, ll = u.length_per_m, u.length_label
    unit = c.feature.unit
    scale, label = {
        "1": (fn, fl),
        "N": (1.0, ""),  # a share of a force
        "N·K": ((1 / 1.8, "/°F") if u.imperial else (1.0, "/K")),
        "s": (60.0 * fn, f"{fl}/min"),
        "K": ((fn / 1.8, f"{fl}/°F") if u.imperial else (fn, f"{fl}/K")),
        "m": (fn / ln, f"{fl}/{ll}"),
        "m/s": (fn / ln, f"{fl}·s/{ll}"),
        "m/s²": (1.0, "kg"),
        "m²/s²": (fn / ln**2, f"{fl}·s²/{ll}²"),
    }.get(unit, (1.0, c.feature.coefficient_unit))
    sd = f" ± {abs(scale * c.sd):.2g}" if math.isfinite(c.sd) else ""
    return f"{scale * c.value:+.3g}{sd}" + (f" {label}" if label else "")


def form_words(term: Discovered, u: Units = SI) -> str:
    """ "F ≈ (+1.2 ± 0.1 N/min)·t + (-0.05 ± 0.01)·w[-10,+10](x)·F_d", time in minutes."""
    parts = []
    for c in term.coefficients:
        symbol = "t/min" if c.feature.unit == "s" else c.feature.symbol_in(u)
        parts.append(f"({coefficient_text(c, u)})·{symbol}")
    return "F ≈ " + " + ".join(parts)


def described_text(d: Described, remaining_rms_n: float, u: Units = SI) -> str:
    """ "Still unexplained: ..., it follows ...; Unnamed: F ≈ ..." (or why no form is)."""
    fl = u.force_label
    r = d.regions[0]
    vs, vl = (u.velocity_per_m_s, u.velocity_label) if u.imperial else (1.0, "m/s")
    where = (
        f"Still unexplained: {u.force(remaining_rms_n):.2g} {fl} RMS, most in {r.stroke} at "
        f"{u.length(r.x_range_m[0]):.3g}…{u.length(r.x_range_m[1]):.3g} {u.length_label}, "
        f"{vs * r.v_range_m_s[0]:.2g}…{vs * r.v_range_m_s[1]:.2g} {vl}, "
        f"{phase_words(d.phase_deg)}"
    )
    order = d.axes.get("test_order", {})
    if order:
        late = order.get("second_half", 0.0)
        if late >= 0.7:
            where += ", most in the later tests"
        elif late <= 0.3:
            where += ", most in the earlier tests"
    lines = [where]
    if d.follows:
        lines.append(
            "it follows "
            + ", ".join(
                f"{f.feature.label_in(u)} ({100 * f.share:.0f} % alone"
                + (f", as {' or '.join(f.feature.resembles)} would" if f.feature.resembles else "")
                + ")"
                for f in d.follows
            )
        )
    text = "; ".join(lines) + "."
    t = d.term
    if t is None or not t.coefficients:
        return text
    form = form_words(t, u)
    gain = f"{100 * t.heldout_gain:.0f} % of the held-out structure (median fold)"
    if t.claimed:
        why = hint(t)
        return f"{text} Unnamed: {form}{f' ({why}?)' if why else ''}; it removes {gain}."
    return f"{text} A discovered form {form} removes {gain}: not claimed ({t.why_not})."


def described_doc(d: Described) -> docs.Unexplained:
    """One described residual of `verdict.unexplained` (docs/diagnose.md)."""
    plot = None
    if d.plot_feature is not None and d.plot:
        plot = docs.ResidualPlot(
            signal=d.plot_feature.key,
            label=d.plot_feature.label_in(SI),
            label_imperial=d.plot_feature.label_in(IMPERIAL),
            unit=d.plot_feature.unit,
            x=tuple(d.plot["x"]),
            residual=tuple(d.plot["residual"]),
            term=tuple(d.plot["term"]),
        )
    return docs.Unexplained(
        **vars(d.regions[0].doc()),  # its largest region's keys, as an older file's
        regions=tuple(r.doc() for r in d.regions),
        axes=d.axes,
        phase_deg=tuple(d.phase_deg),
        phase=phase_words(d.phase_deg),
        follows=tuple(
            docs.Follows(
                signal=f.feature.key,
                label=f.feature.label_in(SI),
                label_imperial=f.feature.label_in(IMPERIAL),
                family=f.feature.family,
                share=f.share,
                rises_with_it=f.sign > 0,
                resembles=tuple(f.feature.resembles),
            )
            for f in d.follows
        ),
        term=None if d.term is None else _term_doc(d.term),
        plot=plot,
    )


def _term_doc(t: Discovered) -> docs.UnnamedTerm:
    return docs.UnnamedTerm(
        name="unnamed",
        claimed=t.claimed,
        form=form_words(t),
        form_imperial=form_words(t, IMPERIAL),
        features=tuple(c.feature.key for c in t.coefficients),
        coefficients=tuple(
            docs.Coefficient(
                feature=c.feature.key,
                label=c.feature.label_in(SI),
                label_imperial=c.feature.label_in(IMPERIAL),
                family=c.feature.family,
                symbol=c.feature.symbol_in(SI),
                symbol_imperial=c.feature.symbol_in(IMPERIAL),
                value=finite_or_none(c.value),
                sd=finite_or_none(c.sd),
                unit=c.feature.coefficient_unit,
                text=coefficient_text(c, SI),
                text_imperial=coefficient_text(c, IMPERIAL),
            )
            for c in t.coefficients
        ),
        heldout_gain=finite_or_none(t.heldout_gain),
        heldout_detail=t.heldout_detail,
        in_sample_share=finite_or_none(t.in_sample_share),
        effect_peak_n=finite_or_none(t.effect_peak_n),
        hint=hint(t),
        why_not=t.why_not,
    )
