"""The fitted damper handed to vehicle simulation: force–velocity tables per click.

The table is the damper as a car carries it (`DamperModel.vehicle`: sensor terms dropped,
the oil at its reference temperature), evaluated quasi-statically at mid-stroke with no
rod acceleration: the same function the ride study tabulates, so a vehicle model fed
these tables and the ride study drive the same damper (docs/damper-tables.md).

Two files per click setting:

- `clicks_NN.csv`: velocity, total force, and damping force (the total less the static
  gas force at mid-stroke, which a vehicle model carries as a preload of the spring or
  strut instead), in the project's sign convention (compression positive), SI or imperial.
- `clicks_NN.dpr`: a TeimOrbit damper property file (`[MDI_HEADER]`, `[UNITS]`,
  `[CURVE]` with `{ velocity force }` rows), the block layout of Adams Car's damper
  property files. Its curve is the damping force with rebound (extension) positive,
  the convention those files use; the static gas force is stated in its comments.

**Measured or extrapolated.** A fit made by `shockdyno fit` records the fastest velocity
each click setting's tests reached (`info.velocity_range`, fit/file.py). Rows beyond it
are the model extrapolated, not a measurement: the CSV marks each row (`measured` 1 or 0)
and the property file's comments give the span; `within_measured` stops the table at it
(its edges added as rows). A click from the trend takes the narrower span of the fitted
clicks either side. A fit that does not record it (older, or the demo's) marks nothing
and says so.

**Friction band.** The fitted Coulomb friction steps from 0 to ±F_f within the model's
`friction_velocity_m_s` (1 mm/s): 35 N within the first 2.5 mm/s row, a slope vehicle-
simulation solvers take badly. `friction_band_m_s` evaluates the table with the friction's
sign smoothed over that wider velocity instead (the same tanh, F_f tanh(v / band)): the
curve then passes through zero with a finite slope, and away from the band (|v| ≥ 4 bands)
it is the fitted one to within 0.07 % of F_f.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shockdyno.atomic import write_text_atomic
from shockdyno.errors import ConfigError, FitError
from shockdyno.fit.result import FitResult
from shockdyno.model.quarter_car import quasi_static_force
from shockdyno.units import M_PER_IN, N_PER_LBF

FloatArray = NDArray[np.float64]


# Dense where a damper's curve bends (bleed to valve knee), coarse at speed. m/s.
DEFAULT_SPEEDS_M_S: tuple[float, ...] = (
    0.0025,
    0.005,
    0.0075,
    0.01,
    0.015,
    0.02,
    0.025,
    0.03,
    0.04,
    0.05,
    0.0625,
    0.075,
    0.1,
    0.125,
    0.15,
    0.2,
    0.25,
    0.3,
    0.4,
    0.5,
    0.6,
    0.8,
    1.0,
)


@dataclass(frozen=True)
class Units:
    """A unit system of the exported damper tables: the velocity and force units and their size
    in SI (m/s, N per unit), and the words TeimOrbit's [UNITS] block uses."""

    name: str
    velocity: str
    force: str
    m_s_per_unit: float
    n_per_unit: float
    # TeimOrbit [UNITS] block words for this system
    length_word: str
    force_word: str


SI = Units("si", "mm/s", "N", 1e-3, 1.0, "mm", "newton")
IMPERIAL = Units("imperial", "in/s", "lbf", M_PER_IN, N_PER_LBF, "inch", "pound_force")
UNITS = {"si": SI, "imperial": IMPERIAL}


Span = tuple[float, float]  # (rebound, compression) speeds a recording reached, m/s, > 0


@dataclass(frozen=True)
class ClickTable:
    """One click's damper table for vehicle software: quasi-static force (N, compression
    positive) at mid-stroke against velocity (m/s, rebound negative to compression positive), the
    bleed areas (m²) it came from (the fit, or the trend between fitted clicks), the gas force at
    rest (N), and the speeds the recording reached."""

    clicks: int
    source: str  # "fit" or "trend"
    a_bc_m2: float
    a_bt_m2: float
    velocity_m_s: FloatArray  # ascending, rebound (negative) to compression (positive)
    force_n: FloatArray  # total quasi-static force, compression positive
    gas_force_n: float  # the force at rest at mid-stroke
    measured_m_s: Span | None = None  # what the recording reached (None: not recorded)
    friction_band_m_s: float | None = None  # the friction's smoothing, if widened
    # One adjuster's table of a damper with several: its name, and what the others were
    # held at ("rebound at 10"); "" for the one rod adjuster
    adjuster: str = ""
    held: str = ""

    @property
    def label(self) -> str:
        """'12 clicks', or 'compression 12 clicks (rebound at 10)'."""
        if not self.adjuster:
            return f"{self.clicks} clicks"
        return f"{self.adjuster} {self.clicks} clicks" + (f" ({self.held})" if self.held else "")

    @property
    def stem(self) -> str:
        """The files' name: clicks_NN, or NAME_NN for one adjuster of several."""
        return f"{self.adjuster or 'clicks'}_{self.clicks:02d}"

    @property
    def damping_force_n(self) -> FloatArray:
        """The force less the static gas force (N): the damping alone."""
        return self.force_n - self.gas_force_n

    @property
    def measured(self) -> NDArray[np.bool_] | None:
        """Which rows lie within the measured span (None when it is not known)."""
        if self.measured_m_s is None:
            return None
        rebound, compression = self.measured_m_s
        v = self.velocity_m_s
        slack = 1e-9
        return np.asarray((v <= compression + slack) & (v >= -rebound - slack))


# The imperial default: round in/s values over the same span (0.1 to 40 in/s, 2.5 to
# 1016 mm/s), so an imperial table's rows read 1, 2, 3, 5, 10 in/s, not 0.984252.
IMPERIAL_SPEEDS_IN_S: tuple[float, ...] = (
    0.1, 0.2, 0.3, 0.4, 0.5, 0.75, 1, 1.25, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10, 12, 15, 20, 25, 30, 40,
)  # fmt: skip
IMPERIAL_SPEEDS_M_S: tuple[float, ...] = tuple(v * M_PER_IN for v in IMPERIAL_SPEEDS_IN_S)


def velocity_grid(speeds_m_s: Sequence[float] = DEFAULT_SPEEDS_M_S) -> FloatArray:
    """The table's velocities (m/s): the speeds given, each in rebound (negative) and
    compression, and 0, ascending; ConfigError without a finite non-zero speed."""
    s = np.asarray(sorted({abs(float(v)) for v in speeds_m_s if v != 0}), dtype=float)
    if s.size == 0 or not np.all(np.isfinite(s)):
        raise ConfigError("the velocity grid needs at least one finite non-zero speed")
    return np.concatenate([-s[::-1], [0.0], s])


def measured_spans(fit: FitResult) -> dict[int, Span]:
    """The span each fitted click of the main gas setting reached, from the fit's
    `info.velocity_range` (empty when the fit does not record it)."""
    gas = fit.main_gas_clicks()
    spans: dict[int, Span] = {}
    for e in fit.info.velocity_range or ():
        if e.gas_clicks != gas:
            continue
        span = (-e.rebound_m_s, e.compression_m_s)
        if all(math.isfinite(x) and x >= 0 for x in span):
            spans[e.clicks] = span
    return spans


def _span(spans: dict[int, Span], n: int) -> Span | None:
    """A click's own span, or for a click between fitted ones the narrower of theirs."""
    if n in spans:
        return spans[n]
    below = [c for c in spans if c < n]
    above = [c for c in spans if c > n]
    if not (below and above):
        return None
    a, b = spans[max(below)], spans[min(above)]
    return (min(a[0], b[0]), min(a[1], b[1]))


def within(v: FloatArray, span: Span) -> FloatArray:
    """The grid cut at the measured span, its two edges added as rows."""
    rebound, compression = span
    kept = v[(v > -rebound) & (v < compression)]
    return np.unique(np.concatenate([kept, [-rebound, 0.0, compression]]))


def click_tables(
    fit: FitResult,
    clicks: Sequence[int] | None = None,
    speeds_m_s: Sequence[float] = (),
    *,
    within_measured: bool = False,
    friction_band_m_s: float | None = None,
) -> list[ClickTable]:
    """A table per click setting: the fitted ones by default, any within their range by
    the fit's trend when `clicks` names them. `within_measured`: each table stops at the
    velocities its recording reached; `friction_band_m_s`: the friction's sign smoothed
    over that velocity (module docstring)."""
    settings = [c.clicks for c in fit.clicks] if clicks is None else list(clicks)
    if not settings:
        raise ConfigError("the fit has no click settings to export")
    fitted = {c.clicks for c in fit.clicks}
    model = fit.model().vehicle()
    if friction_band_m_s is not None:
        model = model.with_spec(model.spec.with_changes(friction_velocity_m_s=friction_band_m_s))
    spans = measured_spans(fit)
    if within_measured and not spans:
        raise ConfigError(
            "--within-measured: the fit does not record the velocities its recording reached "
            "(a fit made before they were recorded, or the demo's); fit the recording again "
            "with shockdyno fit"
        )
    grid = velocity_grid(speeds_m_s or DEFAULT_SPEEDS_M_S)
    out = []
    for n in dict.fromkeys(settings):
        try:
            a_bc, a_bt = fit.areas(n)
        except FitError as exc:
            raise ConfigError(f"--clicks {n}: {exc}") from None
        if not (math.isfinite(a_bc + a_bt) and a_bc >= 0 and a_bt >= 0):
            raise ConfigError(f"the fit's bleed areas at {n} clicks are not usable: {a_bc}, {a_bt}")
        span = _span(spans, n)
        if within_measured and span is None:
            raise ConfigError(f"--within-measured: no measured span for {n} clicks in the fit")
        v = within(grid, span) if within_measured and span is not None else grid
        zeros = np.zeros_like(v)
        force = np.asarray(quasi_static_force(model, zeros, v, zeros, a_bc, a_bt), dtype=float)
        if not np.all(np.isfinite(force)):
            raise ConfigError(f"the fitted model gives a non-finite force at {n} clicks")
        gas = float(force[int(np.flatnonzero(v == 0.0)[0])])
        source = "fit" if n in fitted else "trend"
        out.append(ClickTable(n, source, a_bc, a_bt, v, force, gas, span, friction_band_m_s))
    return out


def _g(x: float) -> str:
    """Six significant digits: 0.1 % of a table value is three orders above that, and
    no float noise such as 229.10000000000002 reaches the file."""
    text = f"{x:.6g}"
    return "0" if text in ("-0", "0") else text


def notes(t: ClickTable, units: Units) -> list[str]:
    """What the rows are, beyond the curve itself: the measured span, the friction band.
    No apostrophe: the property file quotes each line in single quotes."""

    def speed(x: float) -> str:
        return f"{_g(x / units.m_s_per_unit)} {units.velocity}"

    out = []
    if t.measured_m_s is None:
        out.append(
            "the fit does not record the velocities its recording reached: rows are not "
            "marked measured or extrapolated"
        )
    else:
        rebound, compression = t.measured_m_s
        where = "this setting" if t.source == "fit" else "the fitted clicks either side"
        out.append(
            f"measured to {speed(rebound)} in rebound and {speed(compression)} in compression "
            f"({where}); beyond, the model extrapolated"
        )
    if t.friction_band_m_s is not None:
        out.append(
            f"friction smoothed over {speed(t.friction_band_m_s)} (F_f tanh(v / band), in "
            "place of the sharper step of the fitted model)"
        )
    return out


def table_csv(t: ClickTable, units: Units, spec_name: str) -> str:
    """The table as CSV in `units` (velocity, force, damping force, and a `measured` flag where
    known), with comment lines on sign, gas force and extrapolation."""
    v = t.velocity_m_s / units.m_s_per_unit
    f = t.force_n / units.n_per_unit
    d = t.damping_force_n / units.n_per_unit
    u_v, u_f = units.velocity.replace("/", "_"), units.force
    measured = t.measured
    lines = [
        f"# shockdyno damper table: {spec_name}, {t.label} ({t.source}); "
        "quasi-static force at mid-stroke, no rod acceleration",
        "# sign: velocity > 0 compression (bump), force > 0 resists compression; "
        f"damping force = force less the static gas force {_g(t.gas_force_n / units.n_per_unit)}"
        f" {units.force}",
        *(
            f"# {line}" + (" (measured = 0)" if "extrapolated" in line else "")
            for line in notes(t, units)
        ),
        f"velocity_{u_v},force_{u_f},damping_force_{u_f}"
        + (",measured" if measured is not None else ""),
    ]
    for k, (a, b, c) in enumerate(zip(v, f, d, strict=True)):
        mark = "" if measured is None else f",{int(measured[k])}"
        lines.append(f"{_g(a)},{_g(b)},{_g(c)}{mark}")
    return "\n".join(lines) + "\n"


def table_teimorbit(t: ClickTable, units: Units, spec_name: str, version: str) -> str:
    """The table as a TeimOrbit damper property file (Adams and similar) in `units`: damping
    force against velocity, both signs flipped (extension positive there)."""
    # Extension (rebound) positive in the property file: flip both axes of ours.
    v = -t.velocity_m_s[::-1] / units.m_s_per_unit
    f = -t.damping_force_n[::-1] / units.n_per_unit
    rows = "\n".join(f" {_g(a):>14} {_g(b):>14}" for a, b in zip(v, f, strict=True))
    gas = _g(t.gas_force_n / units.n_per_unit)
    comments = "".join(f"'{line}'\n" for line in notes(t, units))
    return f"""$--------------------------------------------------------------------MDI_HEADER
[MDI_HEADER]
 FILE_TYPE     =  'dpr'
 FILE_VERSION  =  4.0
 FILE_FORMAT   =  'ASCII'
(COMMENTS)
{{comment_string}}
'shockdyno {version}: {spec_name}, {t.label} ({t.source})'
'quasi-static damping force at mid-stroke; velocity > 0 extension (rebound)'
'static gas force {gas} {units.force_word} pushing the rod out, not in this curve'
'bleed areas A_bc {_g(t.a_bc_m2)} m^2, A_bt {_g(t.a_bt_m2)} m^2'
{comments}$-------------------------------------------------------------------------UNITS
[UNITS]
 LENGTH  =  '{units.length_word}'
 FORCE   =  '{units.force_word}'
 ANGLE   =  'degrees'
 MASS    =  'kg'
 TIME    =  'second'
$-------------------------------------------------------------------------CURVE
[CURVE]
{{ velocity  force }}
{rows}
"""


_BLOCK = re.compile(r"^\s*\[(\w+)\]\s*$")
_ASSIGN = re.compile(r"^\s*(\w+)\s*=\s*'?([^']*?)'?\s*$")


@dataclass(frozen=True)
class PropertyCurve:
    """A damper property file read back: its units and curve, as written."""

    units: dict[str, str]
    velocity: FloatArray
    force: FloatArray


def read_teimorbit(text: str) -> PropertyCurve:
    """Parse the blocks a damper property file has ([UNITS], [CURVE]); `$` lines are
    comments, `{...}` lines headers, `(COMMENTS)` blocks free text."""
    block = ""
    units: dict[str, str] = {}
    rows: list[tuple[float, float]] = []
    for line in text.splitlines():
        if not line.strip() or line.lstrip().startswith("$"):
            continue
        if m := _BLOCK.match(line):
            block = m.group(1).upper()
            continue
        if block == "UNITS" and (m := _ASSIGN.match(line)):
            units[m.group(1).upper()] = m.group(2)
        elif block == "CURVE" and not line.lstrip().startswith("{"):
            parts = line.split()
            if len(parts) != 2:
                raise ConfigError(
                    f"damper property file: curve row {line.strip()!r} is not 2 numbers"
                )
            rows.append((float(parts[0]), float(parts[1])))
    if not rows:
        raise ConfigError("damper property file has no [CURVE] rows")
    arr = np.asarray(rows, dtype=float)
    return PropertyCurve(units, arr[:, 0], arr[:, 1])


def write_tables(
    tables: Sequence[ClickTable], out_dir: Path, units: Units, spec_name: str, version: str
) -> list[Path]:
    """Write every file into out_dir (which the caller has checked), each atomically."""
    written = []
    for t in tables:
        stem = out_dir / t.stem
        for path, text in (
            (stem.with_suffix(".csv"), table_csv(t, units, spec_name)),
            (stem.with_suffix(".dpr"), table_teimorbit(t, units, spec_name, version)),
        ):
            try:
                write_text_atomic(path, text)
            except OSError as exc:
                raise ConfigError(f"--damper-table: cannot write {path} ({exc.strerror})") from None
            written.append(path)
    return written
