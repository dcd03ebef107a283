"""The report's diagnose section, rendered from the JSON of `shockdyno diagnose`.

The diagnose command is younger than this page, so every key is read defensively: a
missing or malformed part is skipped (and said so), never an error. Keys read:

- ``mismatch``: {significant, p_value, noise_floor_n, structured_share,
  where: [{stroke, x_range_m, v_range_m_s, frequencies_hz, share}]}
- ``findings``: [{physics, claimed, p_value, heldout_gain,
  parameters: {name: {value, sd, unit}}, ambiguous_with}]
- ``verdict``: {physics: [...], unexplained: [...], text, text_imperial}: the verdict's words
  in SI and in imperial units (``text_imperial`` is newer: an older file's page in imperial
  shows ``text`` and says its numbers are SI)
- ``tests``: [{index, clicks, frequency_hz, E_t_before, E_t_after}]
- ``info.figures``: {residual_maps, loops}: the PNGs `diagnose --report DIR` drew, relative
  to the JSON's folder; copied into the report's directory (`render_figures`)
- ``info.figures_units``: "si" or "imperial", the units they were drawn in (absent: SI)

To show a new key, add a ``_render_<key>`` function and call it from ``render_diagnose``.
Forces, lengths, speeds and temperatures are shown in the page's `Units`; speeds in SI stay in
m/s, as the verdict's own words give them. Other parameters (Pa, s, 1/K, ...) as stored.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from shockdyno.report.html import Page
from shockdyno.units import SI, Units


def _num(value: Any, spec: str = ".3g") -> str:
    """A number as text; '–' for anything that is not a finite number."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return "–"
    return format(value, spec) if math.isfinite(value) else "–"


def _finite(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def _text(value: Any) -> str:
    if value is None:
        return "–"
    if isinstance(value, list | tuple):
        return ", ".join(_text(v) for v in value) or "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return _num(value)
    return str(value)


def _range(value: Any, scale: float, unit: str) -> str:
    if isinstance(value, list | tuple) and len(value) == 2:
        lo, hi = value
        if all(isinstance(v, int | float) and not isinstance(v, bool) for v in (lo, hi)):
            return f"{lo * scale:.3g} to {hi * scale:.3g} {unit}"
    return "–"


def _times(value: Any, scale: float) -> Any:
    """A number of DIAG.json scaled into display units; anything else as it is (for `_num`)."""
    return value * scale if _finite(value) is not None else value


def _speed(units: Units) -> tuple[float, str]:
    """Scale and label of a speed: m/s in SI, as the verdict's own words give it; in/s."""
    return (units.velocity_per_m_s, units.velocity_label) if units.imperial else (1.0, "m/s")


def _dicts(value: Any) -> list[dict[str, Any]]:
    return [v for v in value if isinstance(v, dict)] if isinstance(value, list) else []


def _render_verdict(page: Page, verdict: Any, units: Units) -> bool:
    if not isinstance(verdict, dict):
        return False
    text = verdict.get("text")
    imperial = verdict.get("text_imperial")
    if units.imperial and isinstance(imperial, str) and imperial.strip():
        page.paragraph(imperial.strip())
    elif isinstance(text, str) and text.strip():
        page.paragraph(text.strip())
        if units.imperial:  # a DIAG.json older than text_imperial: its words are SI only
            page.paragraph(
                "The verdict above is in the diagnosis's own words, in SI units (N, mm, m/s): "
                "its DIAG.json predates the imperial text. The tables below are converted."
            )
    physics = verdict.get("physics")
    unexplained = verdict.get("unexplained")
    if physics is not None:
        page.paragraph(f"Physics named: {_text(physics)}.")
    regions = _dicts(unexplained)
    if regions:
        page.paragraph(
            "Still unexplained: " + "; ".join(region_text(r, units) for r in regions) + ".",
            warn=True,
        )
    elif unexplained:
        page.paragraph(f"Still unexplained: {_text(unexplained)}.", warn=True)
    return True


def region_text(r: dict[str, Any], units: Units = SI) -> str:
    """A region of DIAG.json in words: "in rebound at 15.6 to 29.2 mm, -0.097 to -0.036 m/s,
    near reversal (1, 1.5 Hz; 25 % of the structure, 19 N RMS)", in ``units``."""
    x = _range(r.get("x_range_m"), units.length_per_m, units.length_label)
    head = " ".join(
        w
        for w in (
            f"in {r['stroke']}" if isinstance(r.get("stroke"), str) else "",
            f"at {x}" if x != "–" else "",
        )
        if w
    )
    where = [
        head,
        _range(r.get("v_range_m_s"), *_speed(units)),
        "near reversal" if r.get("near_reversal") is True else "",
    ]
    extra = []
    freqs = r.get("frequencies_hz")
    if isinstance(freqs, list) and freqs:
        extra.append(f"{_text(freqs)} Hz")
    share = _finite(r.get("share"))
    if share is not None:
        extra.append(f"{100 * share:.0f} % of the structure")
    rms = _finite(r.get("rms_n"))
    if rms is not None:
        extra.append(f"{units.force(rms):.3g} {units.force_label} RMS")
    text = ", ".join(w for w in where if w and w != "–")
    return text + (f" ({'; '.join(extra)})" if extra else "")


def _render_mismatch(page: Page, mismatch: Any, units: Units) -> bool:
    if not isinstance(mismatch, dict):
        return False
    significant = mismatch.get("significant")
    head = "significance unknown"
    if isinstance(significant, bool):
        head = "significant" if significant else "not significant"
    if mismatch.get("tested") is False:  # every test under two cycles: no noise to test by
        head = "not tested (no test has two whole cycles)"
    page.paragraph(
        f"Mismatch between model and measurement: {head} "
        f"(p = {_num(mismatch.get('p_value'))}; noise floor "
        f"{_num(_times(mismatch.get('noise_floor_n'), units.force_per_n))} "
        f"{units.force_label}; structured share "
        f"{_num(mismatch.get('structured_share'))})."
    )
    where = _dicts(mismatch.get("where"))
    if where:
        page.table(
            ["stroke", "x range", "v range", "frequencies (Hz)", "share"],
            [
                [
                    _text(w.get("stroke")),
                    _range(w.get("x_range_m"), units.length_per_m, units.length_label),
                    _range(w.get("v_range_m_s"), *_speed(units)),
                    _text(w.get("frequencies_hz")),
                    _num(w.get("share")),
                ]
                for w in where
            ],
            numeric=[False, False, False, False, True],
        )
    return True


def _in_units(unit: str, units: Units) -> tuple[float, float, str]:
    """(scale, offset, label) of a parameter stored in SI ``unit``, shown in ``units``: the
    forces, lengths, speeds, damping coefficients and temperatures the units module converts;
    anything else (Pa, s, 1/K, ...) and everything in SI as stored."""
    if not units.imperial:
        return 1.0, 0.0, unit
    fn, ln, vn = units.force_per_n, units.length_per_m, units.velocity_per_m_s
    zero = units.temperature(0.0)  # °C is affine: a spread (sd) takes the scale only
    return {
        "N": (fn, 0.0, units.force_label),
        "m": (ln, 0.0, units.length_label),
        "m/s": (vn, 0.0, units.velocity_label),
        "N·s/m": (fn / ln, 0.0, f"{units.force_label}·s/{units.length_label}"),
        "°C": (units.temperature(1.0) - zero, zero, units.temperature_label),
    }.get(unit, (1.0, 0.0, unit))


def _parameters(value: Any, units: Units) -> str:
    if not isinstance(value, dict):
        return "–"
    out = []
    for name, p in value.items():
        if isinstance(p, dict):
            stored = p["unit"] if isinstance(p.get("unit"), str) else ""
            scale, offset, label = _in_units(stored, units)
            v = _finite(p.get("value"))
            shown = v * scale + offset if v is not None else None
            unit = f" {label}" if label else ""
            sd = _num(_times(p.get("sd"), scale), ".2g")  # a spread: no offset
            out.append(f"{name} = {_num(shown, '.4g')} ± {sd}{unit}")
        else:
            out.append(f"{name} = {_text(p)}")
    return "; ".join(out) or "–"


def _render_findings(page: Page, findings: Any, units: Units) -> bool:
    rows = _dicts(findings)
    if not rows:
        return False
    page.subheading("Findings: candidate physics")
    page.table(
        [
            "physics",
            "claimed",
            "p",
            "held-out gain",
            f"peak effect ({units.force_label})",
            "parameters (± 1σ)",
            "ambiguous with",
        ],
        [
            [
                _text(f.get("physics")),
                _text(f.get("claimed")),
                _num(f.get("p_value")),
                _num(f.get("heldout_gain")),
                _num(_times(f.get("effect_peak_n"), units.force_per_n)),
                _parameters(f.get("parameters"), units),
                _text(f.get("ambiguous_with")),
            ]
            for f in rows
        ],
        row_classes=["" if f.get("claimed") is True else "dim" for f in rows],
        numeric=[False, False, True, True, True, False, False],
    )
    return True


def _render_tests(page: Page, tests: Any) -> bool:
    rows = _dicts(tests)
    if not rows:
        return False
    page.subheading("E_t per test, before and after the named physics")
    body = []
    for t in rows:
        before, after = t.get("E_t_before"), t.get("E_t_after")
        change = "–"
        b, a = _finite(before), _finite(after)
        if b is not None and a is not None and b > 0:
            change = f"{100 * (a - b) / b:+.1f} %"
        body.append(
            [
                _text(t.get("index")),
                _text(t.get("clicks")),
                _num(t.get("frequency_hz"), "g"),
                _num(before, ".4g"),
                _num(after, ".4g"),
                change,
            ]
        )
    page.details(f"E_t of {len(rows)} tests", opened=len(rows) <= 12)
    page.table(
        ["test", "clicks", "f (Hz)", "E_t before", "E_t after", "change"],
        body,
        numeric=[True] * 6,
    )
    page.close_details()
    return True


def spec_shown(used: dict[str, Any]) -> str:
    """The diagnosis's damper spec (``info.spec``) as a page shows it: never an absolute
    path of the machine that ran it."""
    from shockdyno.report.build import shown_path

    path = shown_path(str(used.get("path", "?")))
    text = f"{'built-in default ' if used.get('default') else ''}{path} ({used.get('name', '?')})"
    fit = used.get("from_fit")
    return f"{text}, the base spec of the fit {shown_path(str(fit))}" if fit else text


def render_diagnose(page: Page, doc: Any, units: Units = SI) -> None:
    """Append the diagnose section for ``doc`` (the parsed diagnose JSON), in ``units``."""
    page.section(
        "Diagnosis",
        "Where the fitted model and the measurement disagree, which extra physics explains "
        "it, and how much the error falls with it. E_t = ε_t / σ_F with ε_t² = ∫ (F_measured "
        "− F_model)² dt and σ_F² = ∫ (F_measured − mean F)² dt: the model's RMS force error "
        "as a share of the measured force's spread (0 is perfect).",
    )
    if not isinstance(doc, dict):
        page.paragraph("The diagnose file holds no object; nothing to show.", warn=True)
        return
    info = doc.get("info")
    if isinstance(info, dict) and isinstance(info.get("spec"), dict):
        page.paragraph(f"Damper spec of the diagnosis: {spec_shown(info['spec'])}.")
    shown = [
        _render_verdict(page, doc.get("verdict"), units),
        _render_mismatch(page, doc.get("mismatch"), units),
        _render_findings(page, doc.get("findings"), units),
        _render_tests(page, doc.get("tests")),
    ]
    missing = [
        k
        for k, ok in zip(("verdict", "mismatch", "findings", "tests"), shown, strict=True)
        if not ok
    ]
    if missing:
        page.paragraph(f"Not in the diagnose file: {', '.join(missing)}.")


FIGURE_CAPTIONS = {
    "residual_maps": "Residual maps: the phase-locked residual (measured − model) against "
    "displacement and velocity, before (paper's model) and after (with the claimed physics).",
    "loops": "Residual loops: the tests with the most structure, measured against both models "
    "(F–v, F–v near reversal, F–x).",
}


def render_figures(
    page: Page,
    doc: Any,
    base_dir: Path | None,
    link: Callable[[Path, int], str],
    units: Units = SI,
) -> None:
    """The residual maps and loops `diagnose --report` drew, named in ``info.figures``
    relative to ``base_dir`` (the JSON's folder); ``link`` copies one into the report's
    directory and returns its href, so the page links nothing outside it. Copied as drawn:
    a note when they were drawn in other units than the page's ``units``."""
    info = doc.get("info") if isinstance(doc, dict) else None
    named = info.get("figures") if isinstance(info, dict) else None
    if not isinstance(named, dict) or not named or base_dir is None:
        page.paragraph(
            "No residual maps or loops: this diagnosis was written without its figures "
            "(shockdyno diagnose ... --report DIR draws them, and DIAG.json then names them)."
        )
        return
    missing, shown = [], 0
    for n, (key, caption) in enumerate(FIGURE_CAPTIONS.items()):
        rel = named.get(key)
        if not isinstance(rel, str):
            continue
        png = base_dir / rel
        if png.suffix.lower() != ".png" or not png.is_file():
            missing.append(rel)
            continue
        page.figure(link(png, 50 + n), caption)
        shown += 1
    drawn = info.get("figures_units", "si") if isinstance(info, dict) else "si"
    if shown and drawn != units.name and drawn in ("si", "imperial"):
        axes = "in, in/s, lbf" if drawn == "imperial" else "mm, m/s, N"
        page.paragraph(
            f"The residual maps and loops are drawn in {axes}, as diagnose --units {drawn} "
            "drew them; the rest of the page is converted."
        )
    if missing:
        page.paragraph(
            f"Figures of the diagnosis not found beside its JSON: {', '.join(missing)} "
            "(moved apart from DIAG.json?).",
            warn=True,
        )
