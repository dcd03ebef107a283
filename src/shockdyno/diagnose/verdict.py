"""The diagnosis in words an engineer can act on, and as the DIAG.json document (its
classes, the one definition every reader reads: report/documents.py)."""

from __future__ import annotations

import math
from dataclasses import replace
from itertools import pairwise
from typing import Any

import numpy as np

from shockdyno import schema
from shockdyno.diagnose.diagnosis import CalibrationRow, Diagnosis, Trial
from shockdyno.diagnose.locate import Location
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.unexplained import described_doc, described_text
from shockdyno.fit.parameters import SPEC_GLOBALS
from shockdyno.fit.result_doc import EstimateDoc
from shockdyno.model.reading import Reading
from shockdyno.model.terms import LIBRARY
from shockdyno.report import documents as docs
from shockdyno.schema import finite_or_none
from shockdyno.units import IMPERIAL, SI, Units, in_units


def _signature(loc: Location, s: Settings) -> str:
    """How the located structure behaves: near reversal, with frequency, by stroke."""
    bits = []
    speed = loc.axes.get("speed", {})
    if speed.get("near_reversal", 0) >= s.near_reversal_share:
        bits.append("near velocity reversal")
    freq = loc.axes.get("frequency_hz", {})
    if len(freq) >= 2:
        ordered = sorted(freq.items(), key=lambda kv: float(kv[0]))
        shares = [s for _, s in ordered]
        growth = s.frequency_growth
        if all(b >= a for a, b in pairwise(shares)) and shares[-1] > growth * shares[0]:
            bits.append("growing with frequency")
        elif all(b <= a for a, b in pairwise(shares)) and shares[0] > growth * shares[-1]:
            bits.append("strongest at the lowest frequency")
    stroke = loc.axes.get("stroke", {})
    if stroke.get("compression", 0) >= s.stroke_share:
        bits.append("in compression")
    elif stroke.get("rebound", 0) >= s.stroke_share:
        bits.append("in rebound")
    order = loc.axes.get("test_order", {})
    drift = abs(order.get("first_half", 0.5) - order.get("second_half", 0.5)) if order else 0.0
    if drift > s.session_change:
        bits.append("changing over the session")
    return ", ".join(bits)


def describe(
    f: Trial,
    spec_gas_pa: float,
    u: Units = SI,
    reach_m: tuple[float, float] = (-math.inf, math.inf),
) -> str:
    """One finding as physics with its numbers, forces, lengths and speeds in `u`: the
    term's own words (Term.describe). `reach_m`: the stroke the data cover."""
    cls = LIBRARY.get(f.physics)
    if cls is None:
        return f.physics
    return cls().describe(Reading(cls.PARAMS, f.parameters, u, spec_gas_pa, reach_m))


def _reach(d: Diagnosis) -> tuple[float, float]:
    x = d.data.prob.inputs.x
    return (float(np.min(x)), float(np.max(x))) if x.size else (-math.inf, math.inf)


_CALIBRATION_WORDS = {
    "gas_volume_m3": "gas volume",
    "gas_pressure_pa": "gas charge",
    "friction_n": "Coulomb friction",
    "compression_valve.preload_m": "compression valve preload",
    "compression_valve.face_area_m2": "compression valve face area",
    "rebound_valve.preload_m": "rebound valve preload",
    "rebound_valve.face_area_m2": "rebound valve face area",
    "bleed_land_m": "bleed's laminar land",
    "valve_land_m": "shim stacks' seat land",
    "friction_presliding_m": "seal's presliding",
    "friction_velocity_m_s": "friction's smoothing speed at reversal",
}


def _two(x: float) -> str:
    """Two significant digits, without an exponent where a length needs none (200, not
    2e+02)."""
    return f"{float(f'{x:.2g}'):g}"


def describe_calibration(r: CalibrationRow) -> str:
    """ "the spec's gas volume is 1.4× too small": the spec against the recording."""
    what = _CALIBRATION_WORDS.get(r.parameter, r.parameter)
    if r.spec_value == 0:
        if r.parameter == "friction_presliding_m":
            return (
                f"the seal deflects {_two(1e6 * r.fitted)} µm before it slides: its friction "
                "turns over the travel after each reversal"
            )
        if r.parameter == "bleed_land_m":
            return (
                f"the bleed is not a sharp orifice: it flows as one with a laminar land of "
                f"{_two(1e3 * r.fitted)} mm, its force more linear at low speed"
            )
        if r.parameter == "valve_land_m":
            return (
                f"the shim stacks do not open as sharp edges: their oil crosses a seat land "
                f"of {_two(1e3 * r.fitted)} mm, laminar where they crack open"
            )
        return f"the spec's {what} is 0, the recording's {r.fitted:.3g} {r.unit}"
    ratio = r.fitted / r.about
    if ratio < 1e-3:  # fitted at (or next to) nothing: a ratio of 1e20 says nothing more
        return f"the recording shows none of the spec's {r.spec_value:.3g} {r.unit} of {what}"
    sd = f" ± {r.sd / abs(r.about):.2g}" if math.isfinite(r.sd) else ""
    word, times = ("small", ratio) if ratio > 1 else ("large", 1 / ratio)
    if r.written:
        # The operator's own reading, not the drawing's: the spec's is beside the point
        # (a sweep charged low on purpose read "the spec's gas charge is 2.9x too large").
        return (
            f"the {what} the recording gives ({_value(r.about, r.unit)}) is {times:.2g}× too "
            f"{word} (fitted {ratio:.3g}{sd} × it; the spec's {_value(r.spec_value, r.unit)})"
        )
    return f"the spec's {what} is {times:.2g}× too {word} (fitted {ratio:.3g}{sd} × the spec's)"


def _value(v: float, unit: str) -> str:
    if unit != "Pa":
        return f"{v:.3g} {unit}"
    return f"{v / 1e6:.3g} MPa" if v >= 1e6 else f"{v / 1e3:.3g} kPa"


def calibration_text(d: Diagnosis) -> str:
    moved = [r for r in d.calibration if r.moved and not r.finding]
    beyond = [r for r in d.calibration if r.beyond]
    ends = [r for r in d.calibration if r.at_range_end and not r.beyond]
    # Asked beyond its tolerance, held within it while the search ran, and a claimed
    # term took its place (the final refit, which frees it, left it within).
    # A term's factor on a spec value (the gas volume) is held whenever any fit of the
    # search asks beyond, a candidate's included (a position force's, traded with the gas
    # spring): back within, it is the spec's error as any other (DIAG.json keeps the ask).
    taken = [
        r
        for r in d.calibration
        if math.isfinite(r.asked) and not r.finding and r.parameter in SPEC_GLOBALS
    ]
    text = []
    if moved:
        text.append(
            "Calibrated, not physics: " + "; ".join(describe_calibration(r) for r in moved) + "."
        )
    held_any = any(math.isfinite(r.asked) for r in d.calibration)
    claims = (
        " and ".join(t.physics.replace("_", " ") for t in d.trials if t.claimed) if held_any else ""
    )
    for r in taken:
        whose = "the recording's" if r.written else "the spec's"
        now = f"{r.fitted / r.about:.2g}× {whose}" if r.about else f"{r.fitted:.3g}"
        text.append(
            f"Held within its tolerance while the search ran: a fit found {_asked(r)}, "
            f"beyond the {_tolerance(r)} {_departs(r)}; "
            + (f"the claimed {claims} took its place" if claims else "it came back")
            + f" (now {now})."
        )
    for r in beyond:
        # A claim beside a value that still ends beyond took part of its place, not all.
        took = (
            f"the claimed {claims} did not take all of its place"
            if claims
            else "no candidate physics took its place"
        )
        held = f"; held within it while the search ran, {took}" if math.isfinite(r.asked) else ""
        text.append(
            f"A finding, not a calibration: {describe_calibration(r)}, beyond the "
            f"{_tolerance(r)} {_departs(r)}{held}; physics the library did not name takes "
            "that place, or the "
            + (
                "recording's value is not this damper's."
                if r.written
                else "spec is not this damper's."
            )
        )
    for r in ends:
        text.append(
            # a bound's σ is no error bar: the value alone
            f"A finding, not a calibration: {describe_calibration(replace(r, sd=math.nan))}, "
            f"at an end of the range the calibration may move it in ({_range(r)}); the "
            "recording asks for more, so it is no estimate: physics the library did not name "
            "takes that place, or the spec is not this damper's."
        )
    return " ".join(text)


def _range(r: CalibrationRow) -> str:
    assert r.bounds is not None
    lo, hi = r.bounds
    if r.spec_value > 0:
        return f"{lo / r.spec_value:.2g}-{hi / r.spec_value:.2g}× the spec's"
    return f"{lo:.3g}-{hi:.3g} {r.unit}"


def _departs(r: CalibrationRow) -> str:
    if r.written:
        return "a damper departs from the value written for it by"
    return "a damper departs from its drawing by"


def _tolerance(r: CalibrationRow) -> str:
    assert r.tolerance is not None
    lo, hi = r.tolerance
    return f"{lo:.2g}-{hi:.2g}×"


def _asked(r: CalibrationRow) -> str:
    """What a fit asked of the value before it was held: "the spec's Coulomb friction is
    2.7× too small (fitted 2.7 × the spec's)"."""
    return describe_calibration(replace(r, fitted=r.asked, sd=math.nan))


def short_text(d: Diagnosis) -> str:
    """Which tests are too short to test, and why that means claiming nothing from them."""
    if not d.short_tests:
        return ""
    listed = "; ".join(
        f"test {t.index} ({t.clicks} clicks, {t.frequency_hz:g} Hz): {t.cycles:.1f} cycles"
        for t in d.short_tests
    )
    why = (
        "with fewer than two whole cycles there is no cycle-to-cycle noise to test a "
        "mismatch against"
    )
    if not d.testable:
        return (
            f"Nothing claimed: no test has two whole cycles ({listed}); {why}. "
            "Record at least two measured cycles per test."
        )
    return f"Left out, nothing claimed from them ({why}): {listed}."


def verdict_text(d: Diagnosis, units: Units = SI) -> str:
    """The verdict in words; forces, lengths and speeds in `units` (DIAG.json's is SI)."""
    text = short_text(d) if not d.testable else _physics_text(d, units)
    if d.testable and d.short_tests:
        text = f"{text} {short_text(d)}"
    cal = in_units(calibration_text(d), units)  # a Coulomb friction fitted in N
    text = f"{text} {cal}" if cal else text
    return text + "".join(f" Sensor, not physics: {in_units(line, units)}." for line in d.sensor)


def _physics_text(d: Diagnosis, u: Units = SI) -> str:
    spec_gas = d.final.model.spec.gas_pressure_pa
    m = d.mismatch
    fl = u.force_label
    # Measured with spec values held within their tolerance: the spec as a damper may
    # depart from it, which is what the search was offered; the free fit took the
    # structure as a calibration beyond it (a finding, calibration_text).
    held = " and ".join(f"the spec's {_CALIBRATION_WORDS.get(k, k)}" for k in d.held)
    its = "its" if len(d.held) == 1 else "their"
    held = f", with {held} held within {its} tolerance" if held else ""
    if m.p_value >= d.alpha:
        return (
            f"No mismatch beyond noise{held}: the model's residual repeats by "
            f"{u.force(m.structured_rms_n):.2g} {fl} RMS against {u.force(m.noise_floor_n):.2g} "
            f"{fl} of noise (p = {m.p_value:.2g}). Nothing claimed."
        )
    where = _signature(d.location, d.settings)
    lines = [
        f"Mismatch{held}: {u.force(m.structured_rms_n):.3g} {fl} RMS repeats every cycle "
        f"(noise {u.force(m.noise_floor_n):.2g} {fl})" + (f", {where}" if where else "") + "."
    ]
    claimed = [f for f in d.trials if f.claimed]
    if not claimed:
        # Freed, a held value can take it all back: then no region is left to point to.
        see = "" if held and not d.unexplained.regions else "; see the unexplained regions"
        lines.append(f"No candidate physics explains it on held-out tests{see}.")
    for f in claimed:
        alike = (
            f" (indistinguishable here from {', '.join(f.ambiguous_with)})"
            if f.ambiguous_with
            else ""
        )
        note = f"; {f.note}" if f.note else ""
        lines.append(
            f"Claimed {describe(f, spec_gas, u, _reach(d))}{alike}: p = {f.p_value:.2g}, it "
            f"removes {100 * f.heldout_gain:.0f} % of the held-out structure (median fold)"
            f"{note}."
        )
    if claimed:
        lines.append(f"To carry {'it' if len(claimed) == 1 else 'them'} into a fit: "
                     f"fit --terms {fit_terms(claimed)}.")  # fmt: skip
    for g in d.indistinguishable:
        by = in_units(g.separate_by, u)
        lines.append(f"To separate {' and '.join(g.group)}: {by}.")
    if d.single_frequency:
        lines.append(
            "One frequency only: a lag, a delay and compressibility all open the loop alike "
            "here; tests at two or more frequencies would separate them."
        )
    if d.described:  # what is left, described, with a discovered form (unexplained.py)
        rms = d.remaining.structured_rms_n
        lines += [in_units(described_text(x, rms, u), u) for x in d.described]
    elif d.unexplained.regions:
        r = d.unexplained.regions[0]
        vs, vl = (u.velocity_per_m_s, u.velocity_label) if u.imperial else (1.0, "m/s")
        lines.append(
            f"Still unexplained: {u.force(d.remaining.structured_rms_n):.2g} {fl} RMS, most in "
            f"{r.stroke} at {u.length(r.x_range_m[0]):.3g}…{u.length(r.x_range_m[1]):.3g} "
            f"{u.length_label}, {vs * r.v_range_m_s[0]:.2g}…{vs * r.v_range_m_s[1]:.2g} {vl}."
        )
    return " ".join(lines)


def fit_terms(claimed: list[Trial]) -> str:
    """`fit --terms` for the claimed terms, with each parameter the fit holds unless named
    (Param.free False) that the diagnosis moved: `--terms sensor_lag` alone would fit a
    load cell's lag as a delay. A term the diagnosis fitted with one of its usual
    parameters held (Search.as_claimed: kept in the form it was claimed in) is named by
    the parameters it fitted, so the fit holds that one too."""
    names: list[str] = []
    for t in claimed:
        cls = LIBRARY.get(t.physics)
        if cls is None:
            names.append(t.physics)
            continue
        reading = Reading(cls.PARAMS, t.parameters)
        extra = [p.name for p in cls.PARAMS if not p.free and reading.moved(p.name)]
        usual = [p.name for p in cls.PARAMS if p.free]
        held = {k for k in usual if k in t.parameters and t.parameters[k].fixed}
        if held:
            own = [k for k in usual if k not in held]
            names += [f"{t.physics}.{k}" for k in own + extra]
        else:
            names += [t.physics, *(f"{t.physics}.{k}" for k in extra)]
    return ",".join(names)


def finding(t: Trial) -> docs.Finding:
    """A trial of the search as a row of DIAG.json's `findings`: the one place the
    in-memory result becomes the file's."""
    return docs.Finding(
        physics=t.physics,
        round=t.round,
        claimed=t.claimed,
        p_value=t.p_value,
        heldout_gain=finite_or_none(t.heldout_gain),
        heldout_detail=t.heldout_detail,
        lr_n2=t.lr_n2,
        effect_rms_n=t.effect_rms_n,
        effect_peak_n=t.effect_peak_n,
        parameters={k: EstimateDoc.of(e) for k, e in t.parameters.items()},
        ambiguous_with=tuple(t.ambiguous_with),
        why_not=t.why_not,
    )


def _verdict(d: Diagnosis) -> docs.Verdict:
    claimed = [t for t in d.trials if t.claimed]
    # Most important first: by the share of the held-out structure removed.
    order = sorted(claimed, key=lambda t: -t.heldout_gain)
    return docs.Verdict(
        physics=tuple(t.physics for t in order),
        # described residuals (unexplained.py); regions alone where none was described
        unexplained=tuple(described_doc(x) for x in d.described)
        or tuple(docs.Unexplained(**vars(r.doc())) for r in d.unexplained.regions),
        indistinguishable=tuple(d.indistinguishable),
        calibration=tuple(
            docs.Calibration(
                parameter=r.parameter,
                spec_value=r.spec_value,
                fitted=r.fitted,
                sd=finite_or_none(r.sd),
                unit=r.unit,
                moved=r.moved,
                # beyond the spec's tolerance: a finding, not a calibration
                beyond_tolerance=r.beyond,
                # fitted at an end of the calibration's range: no estimate, a finding
                at_range_end=r.at_range_end,
                asked=r.asked if math.isfinite(r.asked) else None,
                written=r.about if r.written else None,
            )
            for r in d.calibration
        ),
        sensor=tuple(d.sensor),
        text=verdict_text(d),
        # The same words in in/s, lbf, in: a report in imperial units shows them
        # (report may not import diagnose to write them itself).
        text_imperial=verdict_text(d, IMPERIAL),
        remaining_rms_n=finite_or_none(d.remaining.structured_rms_n),
        remaining_p_value=finite_or_none(d.remaining.p_value),
    )


def document(d: Diagnosis) -> docs.DiagnosisDoc:
    """The diagnosis as DIAG.json holds it (report/documents.py defines every key);
    `diagnose_file` adds the recording and the spec to its `info`."""
    m = d.mismatch
    return docs.DiagnosisDoc(
        mismatch=docs.Mismatch(
            tested=d.testable,
            significant=d.testable and m.p_value < d.alpha,
            p_value=finite_or_none(m.p_value),
            noise_floor_n=finite_or_none(m.noise_floor_n),
            structured_rms_n=finite_or_none(m.structured_rms_n),
            structured_share=finite_or_none(m.structured_share),
            effective_values=m.effective_values,
            lone_cells=m.lone_cells,
            where=tuple(r.doc() for r in d.location.regions),
            axes=d.location.axes,
        ),
        findings=tuple(finding(t) for t in d.trials),
        verdict=_verdict(d),
        short_tests=tuple(
            docs.ShortTest(
                index=t.index,
                clicks=t.clicks,
                frequency_hz=t.frequency_hz,
                cycles=t.cycles,
                reason="fewer than two whole cycles: no cycle-to-cycle noise to test against",
            )
            for t in d.short_tests
        ),
        tests=tuple(
            docs.ScoredTest(
                index=t.index,
                clicks=t.clicks,
                frequency_hz=t.frequency_hz,
                E_t_before=finite_or_none(t.e_t_before),
                E_t_after=finite_or_none(t.e_t_after),
            )
            for t in d.tests
        ),
        info=docs.DiagnosisInfo(
            wall_s=d.wall_s,
            n_tests=len(d.tests),
            single_frequency=d.single_frequency,
            skipped=tuple(d.notes),
            final_terms=tuple(t.name for t in d.final.model.terms),
        ),
    )


def to_json(d: Diagnosis) -> dict[str, Any]:  # Any: a JSON object's values, for json.dumps
    """DIAG.json's value (before `diagnose_file`'s info.recording and info.spec)."""
    doc: dict[str, Any] = schema.to_json(document(d))
    return doc
