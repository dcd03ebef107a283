"""The verdict's words: a term's text names only the parameters the data moved, with σ,
and a calibrated spec value reads as the spec's error, not as physics."""

from __future__ import annotations

import math

import numpy as np

from shockdyno.diagnose.diagnosis import CalibrationRow, Trial
from shockdyno.diagnose.verdict import describe, describe_calibration
from shockdyno.model.params import Estimate


def _finding(physics: str, params: dict[str, tuple[float, float | None]]) -> Trial:
    return Trial(
        physics=physics,
        round=1,
        claimed=True,
        p_value=0.001,
        lr_n2=1.0,
        heldout_gain=0.9,
        heldout_detail="",
        effect_rms_n=10.0,
        effect_peak_n=20.0,
        parameters={
            k: Estimate(v, math.nan if sd is None else sd, "") for k, (v, sd) in params.items()
        },
    )


def test_thermal_text_leaves_out_a_coupling_that_did_not_move() -> None:
    f = _finding(
        "thermal", {"gas_coupling": (8e-12, 0.01), "viscosity_coeff_per_k": (0.031, 0.002)}
    )
    text = describe(f, 1.6e6)
    assert "coupling" not in text
    assert "viscosity falls 3.1 ± 0.2 %/K" in text
    moved = _finding(
        "thermal", {"gas_coupling": (0.9, 0.05), "viscosity_coeff_per_k": (3.5e-21, 0.001)}
    )
    text = describe(moved, 1.6e6)
    assert "coupling 0.9 ± 0.05" in text and "viscosity" not in text


def test_friction_text_names_what_moved() -> None:
    f = _finding(
        "friction",
        {
            "breakaway_n": (24.0, 1.5),
            "stribeck_velocity_m_s": (0.005, 0.0004),
            "viscous_n_s_m": (2.0, 5.0),  # within 3σ of off
        },
    )
    text = describe(f, 1.6e6)
    assert "breakaway 24 ± 1.5 N" in text and "5 ± 0.4 mm/s" in text
    assert "viscous" not in text


def test_imperial_text_is_the_si_text_converted() -> None:
    """diagnose --units imperial: the same finding in lbf, in/s, in and lbf·s/in, each number
    the SI one times the factor (issue 20); DIAG.json keeps the SI text."""
    from shockdyno.units import IMPERIAL, M_PER_IN, N_PER_LBF

    f = _finding(
        "friction",
        {
            "breakaway_n": (24.0, 1.5),
            "stribeck_velocity_m_s": (0.005, 0.0004),
            "viscous_n_s_m": (400.0, 5.0),
        },
    )
    si, imp = describe(f, 1.6e6), describe(f, 1.6e6, IMPERIAL)
    assert "viscous drag 400 ± 5 N·s/m" in si
    assert f"breakaway {24 / N_PER_LBF:.3g} ± {1.5 / N_PER_LBF:.2g} lbf" in imp
    assert f"{0.005 / M_PER_IN:.2g} ± {0.0004 / M_PER_IN:.2g} in/s (Stribeck)" in imp
    assert f"viscous drag {400 / N_PER_LBF * M_PER_IN:.3g}" in imp and "lbf·s/in" in imp
    bump = _finding("contact", {"bump_onset_m": (0.02, 0.001), "bump_force_n": (500.0, 10.0)})
    text = describe(bump, 1.6e6, IMPERIAL)
    assert f"x = {0.02 / M_PER_IN:+.3g} ± {0.001 / M_PER_IN:.2g} in" in text
    assert (
        f"({500 / N_PER_LBF:.3g} ± {10 / N_PER_LBF:.2g} lbf {0.01 / M_PER_IN:.2g} in past" in text
    )
    assert "x = +20 ± 1 mm (500 ± 10 N 10 mm past it)" in describe(bump, 1.6e6)


def test_a_contact_side_the_stroke_never_reaches_is_not_described() -> None:
    """A top-out "from x = -197 mm" on a ±30 mm sweep did nothing the data saw (issue 44)."""
    both = _finding(
        "contact",
        {
            "bump_onset_m": (0.021, 0.0005),
            "bump_force_n": (200.0, 5.0),
            "topout_onset_m": (-0.197, 0.01),
            "topout_force_n": (40.0, 2.0),
        },
    )
    text = describe(both, 1.6e6, reach_m=(-0.03, 0.03))
    assert "a bump stop from x = +21" in text
    assert "top-out" not in text and "-197" not in text
    # Without the data's reach every moved side is read, as before.
    assert "top-out" in describe(both, 1.6e6)


def test_compressibility_text_gives_one_reading() -> None:
    """A modulus carried by the oil's own compressibility is not also "4.2e-26 % free air"."""
    oil = _finding(
        "compressibility",
        {"air_fraction": (4.2e-28, 7e-5), "oil_compressibility_per_gpa": (3.19, 0.05)},
    )
    text = describe(oil, 1.6e6)
    assert "313 MPa" in text and "free air" in text and "no free air resolved" in text
    assert "e-26" not in text and "%" not in text
    air = _finding(
        "compressibility",
        {"air_fraction": (0.02, 0.0001), "oil_compressibility_per_gpa": (0.0, 0.01)},
    )
    text = describe(air, 1.6e6)
    assert "about 2 ± 0.01 % free air" in text and "80 MPa" in text


def test_a_sensor_never_leads_the_motion() -> None:
    """The force channel's delay is bounded at 0; a lagging motion channel reads as such."""
    from shockdyno.model.terms.sensor_lag import SensorLag

    delay = next(p for p in SensorLag.PARAMS if p.name == "delay_s")
    assert delay.lo == 0.0
    lvdt = _finding(
        "sensor_lag",
        {"lvdt_lag_s": (0.003, 0.0002), "delay_s": (0.0, None), "load_cell_lag_s": (0.0, None)},
    )
    assert "the motion channel lags the force by 3 ms" in describe(lvdt, 1.6e6)


def test_a_calibrated_gas_volume_reads_as_the_spec_s_error() -> None:
    small = CalibrationRow("gas_volume_m3", 1.0e-4, 1.4e-4, 1e-7, "m³")
    assert small.moved
    assert "gas volume is 1.4× too small (fitted 1.4 ± 0.001 × the spec's)" in (
        describe_calibration(small)
    )
    large = CalibrationRow("gas_volume_m3", 1.0e-4, 0.7e-4, 1e-7, "m³")
    assert "1.4× too large" in describe_calibration(large)
    # Within 5 % or within 3σ: not worth a word.
    assert not CalibrationRow("friction_n", 35.0, 36.0, 0.1, "N").moved
    assert not CalibrationRow("friction_n", 35.0, 45.0, 5.0, "N").moved


def test_the_verdict_judges_significance_at_the_search_s_alpha() -> None:
    """`--alpha 0.05` with p = 0.03: the search claims at 0.05, so the verdict may not say
    "nothing claimed" because a 0.01 was written into it."""
    from types import SimpleNamespace

    from shockdyno.diagnose.locate import Location
    from shockdyno.diagnose.settings import Settings
    from shockdyno.diagnose.stats import MismatchStat
    from shockdyno.diagnose.verdict import verdict_text

    stat = MismatchStat(0.03, 1.0, 5.0, 12.0, 0.2, 40.0)
    f = _finding("friction", {"breakaway_n": (24.0, 1.5)})
    f.p_value = 0.03

    def diagnosis(alpha: float) -> SimpleNamespace:
        return SimpleNamespace(
            alpha=alpha,
            settings=Settings(alpha=alpha),
            mismatch=stat,
            location=Location([]),
            trials=[f],
            indistinguishable=[],
            single_frequency=False,
            unexplained=Location([]),
            remaining=stat,
            calibration=[],
            sensor=[],
            described=[],
            held=(),
            testable=True,
            short_tests=[],
            final=SimpleNamespace(
                model=SimpleNamespace(spec=SimpleNamespace(gas_pressure_pa=1.6e6))
            ),
            data=SimpleNamespace(prob=SimpleNamespace(inputs=SimpleNamespace(x=np.zeros(0)))),
        )

    loose = verdict_text(diagnosis(0.05))  # type: ignore[arg-type]
    assert "Nothing claimed" not in loose and "Claimed seal friction" in loose
    strict = verdict_text(diagnosis(0.01))  # type: ignore[arg-type]
    assert "No mismatch beyond noise" in strict


def test_the_engine_s_si_sentences_convert_their_forces_and_speeds() -> None:
    """The sentences the engine writes in SI (a spike count, a why-not, what separates two
    terms) shown in imperial: each force and speed the SI one over 4.448 N/lbf and
    25.4 mm/in; every other number left alone; SI untouched."""
    from shockdyno.diagnose.claims import separate_by
    from shockdyno.diagnose.spikes import Spikes
    from shockdyno.units import IMPERIAL, in_units

    spikes = Spikes(count=217, samples=12000, tests=6, largest_n=1234.0).sentence()
    assert "up to 1.23e+03 N off" in spikes
    text = in_units(spikes, IMPERIAL)
    assert "up to 277 lbf off" in text  # 1230 N / 4.448 N/lbf, to the 3 digits given
    assert "217 isolated spikes in 6 tests (18.1 per 1000 samples" in text
    assert in_units(spikes) == spikes
    why = "its own force peaks at 0.017 N, too small to matter: p = 0.3 ≥ 0.01"
    assert in_units(why, IMPERIAL) == (
        "its own force peaks at 0.0038 lbf, too small to matter: p = 0.3 ≥ 0.01"
    )
    slow = separate_by("friction", "sensor_lag")
    assert in_units(slow, IMPERIAL) == slow.replace("25 mm/s", "0.98 in/s")


def test_a_floor_below_vacuum_is_not_called_a_release_pressure() -> None:
    """On the reference plant the library's floor landed 32-78 kPa below vacuum where the
    plant's vapour pressure is 3 kPa: the saturation is found, its value is the model's
    pressure offset, and the text must not present it as an absolute pressure."""
    from shockdyno.diagnose.verdict import describe

    above = describe(_finding("cavitation", {"release_pressure_pa": (3.0e3, 500.0)}), 1.6e6)
    assert above.startswith("cavitation: the rebound chamber holds at 3 kPa absolute")
    below = describe(_finding("cavitation", {"release_pressure_pa": (-6.0e4, 500.0)}), 1.6e6)
    assert "below vacuum" in below and "not the release pressure" in below
    assert "holds at -60 kPa" not in below and "at least 60 kPa low" in below
    off = describe(_finding("cavitation", {"release_pressure_pa": (-math.inf, None)}), 1.6e6)
    assert off == "cavitation: no floor (off)"


def test_a_calibration_beyond_the_spec_s_tolerance_is_a_finding() -> None:
    """Issue 44.3: a Coulomb friction 2.7x the spec's is not a spec's error (a damper
    departs from its drawing by half to twice), a gas charge 0.62x of it is; a friction
    fitted at nothing reads as none, not as a ratio of 1e20."""
    from types import SimpleNamespace

    from shockdyno.diagnose.verdict import calibration_text
    from shockdyno.fit.parameters import spec_global

    def row(key: str, spec: float, fitted: float) -> CalibrationRow:
        g = spec_global(key)
        return CalibrationRow(key, spec, fitted, 0.01 * spec, g.unit, 0.1, g.fallback, g.tolerance)

    gas = row("gas_pressure_pa", 1.6e6, 1.0e6)
    stuck = row("friction_n", 35.0, 2.7 * 35.0)
    gone = row("friction_n", 35.0, 6.98e-21 * 35.0)
    assert not gas.beyond and stuck.beyond and gone.beyond
    text = calibration_text(SimpleNamespace(calibration=[gas, stuck]))  # type: ignore[arg-type]
    calibrated, finding = text.split("A finding, not a calibration:")
    assert "gas charge is 1.6× too large" in calibrated and "friction" not in calibrated
    assert "Coulomb friction is 2.7× too small" in finding and "0.5-2×" in finding
    text = calibration_text(SimpleNamespace(calibration=[gone]))  # type: ignore[arg-type]
    assert "shows none of the spec's 35 N of Coulomb friction" in text and "e+" not in text


def test_a_calibration_at_the_end_of_its_range_is_a_finding() -> None:
    """Issue 44.3: a value the fit left at an end of the range the calibration may move it in
    (the seal's smoothing speed at 0.01x the spec's, a held-out pair's) is no estimate: the
    recording asked for more. Not "calibrated", whether or not it has a tolerance; a value
    fitted at a physical 0 (a sharp orifice) and one within its range stay calibrations."""
    from types import SimpleNamespace

    from shockdyno.diagnose.verdict import calibration_text
    from shockdyno.fit.parameters import spec_global

    def row(key: str, spec: float, fitted: float) -> CalibrationRow:
        g = spec_global(key)
        return CalibrationRow(
            key, spec, fitted, 1e-3 * (spec or g.fallback), g.unit, 0.1, g.fallback,
            g.tolerance, bounds=g.bounds(spec),
        )  # fmt: skip

    end = row("friction_velocity_m_s", 1e-3, 1.01e-5)  # 0.0101x: within 1e-3 of the scale
    inside = row("friction_velocity_m_s", 1e-3, 1.0e-4)  # 0.1x
    land = row("bleed_land_m", 0.0, 0.2)  # 40x the 5 mm fallback: the top of its range
    sharp = row("bleed_land_m", 0.01, 0.0)  # at 0: a sharp orifice, a physical end
    assert end.at_range_end and end.finding and not end.beyond
    assert land.at_range_end and not inside.at_range_end and not sharp.at_range_end
    text = calibration_text(SimpleNamespace(calibration=[inside, end]))  # type: ignore[arg-type]
    calibrated, finding = text.split("A finding, not a calibration:")
    assert "10× too large" in calibrated  # inside its range: the spec's error
    assert "99× too large" in finding and "(0.01-5× the spec's)" in finding
    assert "±" not in finding  # a bound's σ is no error bar
    text = calibration_text(SimpleNamespace(calibration=[land, sharp]))  # type: ignore[arg-type]
    calibrated, finding = text.split("A finding, not a calibration:")
    assert "200 mm" in finding and "(0-0.2 m)" in finding
    assert "sharp" in calibrated or "none" in calibrated or "0" in calibrated


def test_a_written_gas_charge_is_what_its_calibration_is_about() -> None:
    """A sweep charged to 406 kPa on purpose (the spec's 1.6 MPa) and fitted at 556 kPa:
    the text names the recording's charge, not "the spec's gas charge is 2.9x too large";
    fitted at the written charge, no sentence at all; three times the written charge is
    a finding against it (0.5-2x), not against the drawing (1.1x of it)."""
    from types import SimpleNamespace

    from shockdyno.diagnose.verdict import calibration_text
    from shockdyno.fit.parameters import spec_global

    g = spec_global("gas_pressure_pa")

    def row(fitted: float, written: float = 406e3) -> CalibrationRow:
        return CalibrationRow(
            "gas_pressure_pa", 1.6e6, fitted, 5e3, g.unit, 0.1, g.fallback, g.tolerance,
            reference=written,
        )  # fmt: skip

    high, same, far = row(556e3), row(410e3), row(1.8e6)
    assert high.moved and not high.beyond and not same.moved and far.beyond
    text = describe_calibration(high)
    assert "gives (406 kPa) is 1.4× too small" in text and "spec's 1.6 MPa" in text
    assert "2.9" not in text
    assert calibration_text(SimpleNamespace(calibration=[same])) == ""  # type: ignore[arg-type]
    text = calibration_text(SimpleNamespace(calibration=[far]))  # type: ignore[arg-type]
    assert text.startswith("A finding, not a calibration:") and "4.4× too small" in text
    assert "value written for it" in text and "spec is not" not in text
    # Where the recording's charge is the spec's, the text is the spec's as before.
    plain = row(1.0e6, written=1.6e6)
    assert plain.moved and describe_calibration(plain).startswith("the spec's gas charge is 1.6×")
