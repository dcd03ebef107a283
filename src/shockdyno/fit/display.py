"""A fit's numbers as a table shows them: engineering units, and a value at a bound named.

The fit JSON is SI (Pa, m², m³, m); a person reads a gas charge in bar, a valve face in mm²,
a gas volume in cm³, a preload in mm, a delay in ms; or in psi, in², in³, in, lbf with
`--units imperial` (factors from units.py, nothing converted twice). An optimiser pressed
against a bound leaves a number such as 1.7e-28 there: that is the bound, not a measurement,
so the table says "at lower bound (0 mm)" instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from shockdyno.fit.parameters import spec_global
from shockdyno.model.terms import LIBRARY
from shockdyno.units import SI, Units

if TYPE_CHECKING:
    from shockdyno.fit.result import FitResult

BOUND_SHARE = 1e-3  # of the range: as close to a bound as fit/sweep.py's at_bound flag


@dataclass(frozen=True)
class Shown:
    """How one quantity is displayed: label, and display = SI * factor + offset."""

    label: str
    factor: float = 1.0
    offset: float = 0.0

    def value(self, si: float) -> float:
        return si * self.factor + self.offset

    def spread(self, si: float) -> float:
        """A difference or a σ: scaled, never offset."""
        return si * self.factor

    def text(self, si: float, spec: str = ".4g") -> str:
        return "?" if not math.isfinite(si) else format(self.value(si), spec)


# A global's SI unit, from the suffix of its name (fit/problem.py's keys).
_SUFFIX_UNITS = (("_pa", "Pa"), ("_m2", "m²"), ("_m3", "m³"), ("_n", "N"), ("_m", "m"))


def unit_of_key(key: str) -> str:
    for suffix, unit in _SUFFIX_UNITS:
        if key.endswith(suffix):
            return unit
    return ""


def shown(unit: str, units: Units, magnitude: float = math.inf) -> Shown:
    """The display of a quantity in SI `unit` (a Param's unit text); `magnitude` (SI)
    picks bar or kPa for a pressure: a gas charge in bar, a chamber's 2 kPa in kPa."""
    length = units.length_per_m
    force = units.force_per_n
    if unit == "N":
        return Shown(units.force_label, force)
    if unit == "m":
        return Shown(units.length_label, length)
    if unit == "m/s":
        return Shown(units.velocity_label, units.velocity_per_m_s)
    if unit == "s":  # a delay in ms, a thermal time constant (minutes) in s
        return Shown("ms", 1e3) if abs(magnitude) < 1.0 else Shown("s")
    if unit == "°C":
        return Shown(units.temperature_label, 1.8, 32.0) if units.imperial else Shown("°C")
    if units.imperial:
        if unit == "m²":
            return Shown("in²", length**2)
        if unit == "m³":
            return Shown("in³", length**3)
        if unit == "Pa":
            return Shown("psi", force / length**2)
        if unit == "N·s/m":
            return Shown("lbf·s/in", force / length)
    else:
        if unit == "m²":
            return Shown("mm²", 1e6)
        if unit == "m³":
            return Shown("cm³", 1e6)
        if unit == "Pa":
            return Shown("bar", 1e-5) if abs(magnitude) >= 1e4 else Shown("kPa", 1e-3)
    return Shown(unit)


def bound_hit(value: float, lo: float, hi: float) -> str:
    """'lower', 'upper' or '' : which bound of [lo, hi] a fitted value is pressed against."""
    if not (math.isfinite(value) and math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return ""
    near = BOUND_SHARE * (hi - lo)
    if abs(value - lo) <= near:
        return "lower"
    if abs(hi - value) <= near:
        return "upper"
    return ""


def bound_text(side: str, bound_si: float, show: Shown) -> str:
    """'at lower bound (0 mm)': what the table prints in place of the value."""
    label = f" {show.label}" if show.label not in ("", "1") else ""
    return f"at {side} bound ({show.value(bound_si):.4g}{label})"


def globals_rows(result: FitResult, units: Units = SI) -> tuple[list[str], list[list[str]]]:
    """The calibrated globals (every key of result.globals, whatever the fit calibrates)
    beside the spec's values, in engineering units, and the force channel's delay; a
    global pressed against its calibration range reads "at lower bound (...)". Shared by
    the terminal table and the report's fit section."""
    cal = result.info.calibration
    nominal = cal.globals_nominal if cal is not None else {}
    sd = cal.globals_sd if cal is not None else {}
    header = ["parameter", "fitted", "±1σ", "spec", "unit", "change"]
    rows: list[list[str]] = []
    for key, value in result.globals.items():
        given = nominal.get(key)
        base = given if given is not None and math.isfinite(given) else math.nan
        known = math.isfinite(base)
        show = shown(unit_of_key(key), units, base if known else value)
        fitted = show.text(value)
        if known:
            lo, hi = spec_global(key).bounds(base)
            side = bound_hit(value, lo, hi)
            if side:
                fitted = bound_text(side, lo if side == "lower" else hi, show)
        change = "?"
        if known and base != 0:
            change = f"{100 * (value / base - 1):+.1f}%"
        spread = sd.get(key)
        sd_text = (
            f"{show.spread(spread):.4g}" if spread is not None and math.isfinite(spread) else "?"
        )
        rows.append([key, fitted, sd_text, show.text(base) if known else "?", show.label, change])
    if cal is not None and cal.force_delay_s is not None:
        delay, delay_sd = cal.force_delay_s, cal.force_delay_sd_s
        ms = shown("s", units, 0.0)  # a delay: always ms
        sd_ms = ms.text(delay_sd) if isinstance(delay_sd, int | float) else "?"
        delay_p = next(q for q in LIBRARY["sensor_lag"].PARAMS if q.name == "delay_s")
        side = bound_hit(delay, delay_p.lo, delay_p.hi)
        bounds = {"lower": delay_p.lo, "upper": delay_p.hi}
        text = bound_text(side, bounds[side], ms) if side else ms.text(delay)
        rows.append(["force delay", text, sd_ms, "0", "ms", ""])
    return header, rows
