"""The difference table: each later input against the first, at the standard velocities.

**The rule.** For one click setting and signed velocity, with A the first input and B
another: d = F_B − F_A, and the SD of d is √(SD_A² + SD_B²), each side's SD being the SD
of its chart value (report/repeatability.py: cycle-to-cycle and test-to-test scatter;
0 for a fit, whose model has none). The difference is

- **a difference** when |d| > ``K_SCATTER`` × SD(d) and |d| is at least the practical
  floor, max(``FLOOR_SHARE`` of the larger force, ``FLOOR_N``);
- **within the scatter** when |d| ≤ ``K_SCATTER`` × SD(d);
- **too small to matter** when it is resolved (beyond the scatter) but under the floor:
  a few cycles give an SD of about 1 N on a simulated rig, and 3 N at 1300 N is no
  change a shop would act on;
- **not judged** when either value is extrapolated or has no known scatter, or both
  are models (no scatter on either side: the difference is stated, not judged), or one
  side's gas force is not known (its estimate refused: report/gas.py), so that side holds
  the force with the gas force in and the other without.

Softer or stiffer is read in the direction of travel: the force that resists the stroke
(+F in compression, −F in rebound) is smaller (softer) or larger (stiffer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from shockdyno.compare.inputs import Input, Setting
from shockdyno.units import SI, Units

K_SCATTER = 3.0
FLOOR_SHARE = 0.02
FLOOR_N = 5.0

DIFFERENCE = "difference"
WITHIN = "within the scatter"
SMALL = "too small to matter"
NOT_JUDGED = "not judged"


@dataclass(frozen=True)
class Row:
    a: str
    b: str
    clicks: int
    gas_clicks: int
    velocity_m_s: float  # signed: + compression
    force_a_n: float
    force_b_n: float
    sd_diff_n: float
    verdict: str
    why: str = ""  # for "not judged"

    @property
    def direction(self) -> str:
        return "compression" if self.velocity_m_s > 0 else "rebound"

    @property
    def diff_n(self) -> float:
        return self.force_b_n - self.force_a_n

    @property
    def diff_share(self) -> float:
        return self.diff_n / abs(self.force_a_n) if self.force_a_n else math.nan

    @property
    def ratio(self) -> float:
        """|d| in units of its SD (nan when the SD is 0 or unknown)."""
        return abs(self.diff_n) / self.sd_diff_n if self.sd_diff_n > 0 else math.nan

    @property
    def softer(self) -> bool:
        sign = 1.0 if self.velocity_m_s > 0 else -1.0
        return sign * self.diff_n < 0

    def text(self, units: Units = SI) -> str:
        """'rebound at 50 mm/s is 38 N (12 %) softer, 6x the scatter'."""
        head = f"{self.direction} at {units.speed_text(self.velocity_m_s)}"
        if not math.isfinite(self.diff_n):
            return f"{head}: {self.why or 'no value on one side'}"
        size = f"{units.force(abs(self.diff_n)):.0f} {units.force_label}"
        if math.isfinite(self.diff_share):
            size += f" ({100 * abs(self.diff_share):.0f} %)"
        change = f"{size} {'softer' if self.softer else 'stiffer'}"
        if self.verdict == DIFFERENCE:
            return f"{head} is {change}, {self.ratio:.0f}x the scatter"
        if self.verdict == WITHIN:
            return f"{head}: {change}, within the scatter ({self.ratio:.1f}x)"
        if self.verdict == SMALL:
            return f"{head}: {change}, beyond the scatter but under the practical floor"
        return f"{head}: {change}, not judged ({self.why})"

    def to_json(self) -> dict[str, object]:
        def num(v: float) -> float | None:
            return round(v, 4) if math.isfinite(v) else None

        return {
            "a": self.a,
            "b": self.b,
            "clicks": self.clicks,
            "gas_clicks": self.gas_clicks,
            "direction": self.direction,
            "velocity_m_s": round(self.velocity_m_s, 6),
            "force_a_n": num(self.force_a_n),
            "force_b_n": num(self.force_b_n),
            "diff_n": num(self.diff_n),
            "diff_percent": num(100 * self.diff_share),
            "sd_diff_n": num(self.sd_diff_n),
            "ratio": num(self.ratio),
            "verdict": self.verdict,
            "softer": self.softer if math.isfinite(self.diff_n) else None,
            "text": self.text(),
        }


def judge(
    force_a: float, sd_a: float, force_b: float, sd_b: float, both_models: bool = False
) -> tuple[str, float, str]:
    """(verdict, SD of the difference, why not judged) by the module docstring's rule."""
    if not (math.isfinite(force_a) and math.isfinite(force_b)):
        return NOT_JUDGED, math.nan, "no value on one side"
    if both_models:
        return NOT_JUDGED, 0.0, "two models: no scatter to judge against"
    sd = math.sqrt(sd_a**2 + sd_b**2)
    if not math.isfinite(sd):
        return NOT_JUDGED, sd, "no measured scatter on one side (extrapolated or < 2 cycles)"
    d = abs(force_b - force_a)
    if d <= K_SCATTER * sd:
        return WITHIN, sd, ""
    floor = max(FLOOR_SHARE * max(abs(force_a), abs(force_b)), FLOOR_N)
    return (DIFFERENCE if d >= floor else SMALL), sd, ""


def shared_settings(inputs: list[Input]) -> list[Setting]:
    """Click settings of the first input that at least one other input has."""
    first = set(inputs[0].values)
    return sorted(s for s in first if any(s in other.values for other in inputs[1:]))


def difference_rows(inputs: list[Input]) -> list[Row]:
    """Every later input against the first, at each shared setting and velocity."""
    a = inputs[0]
    rows = []
    for b in inputs[1:]:
        for key in sorted(set(a.values) & set(b.values)):
            for t in a.chart.velocities_m_s:
                va, vb = a.values[key][t], b.values[key][t]
                both_models = a.kind == "fit" and b.kind == "fit"
                verdict, sd, why = judge(va.force_n, va.sd_n, vb.force_n, vb.sd_n, both_models)
                if va.extrapolated or vb.extrapolated:
                    verdict, why = NOT_JUDGED, "extrapolated on one side"
                unknown = [i.label for i in (a, b) if not i.gas_removed(key[1])]
                if unknown:  # damping force against force with its gas force in: no judgement
                    verdict = NOT_JUDGED
                    why = f"the gas force of {', '.join(unknown)} is not known (--gas-force-n)"
                rows.append(
                    Row(a.label, b.label, *key, t, va.force_n, vb.force_n, sd, verdict, why)
                )
    return rows


def differences(rows: list[Row], units: Units = SI) -> list[str]:
    """Every difference, one line per input pair, click setting and direction, the
    largest first: its largest value in words, and the other speeds where it also differs.
    The terminal and the page show these lines whole (issue 47.4: the terminal once
    stopped at ten values without saying so, and missed the largest)."""
    groups: dict[tuple[str, str, int, int, str], list[Row]] = {}
    for r in rows:
        if r.verdict == DIFFERENCE:
            groups.setdefault((r.b, r.a, r.clicks, r.gas_clicks, r.direction), []).append(r)
    gas = len({r.gas_clicks for r in rows}) > 1
    lines = []
    for (b, a, clicks, gas_clicks, _), found in sorted(
        groups.items(), key=lambda kv: -max(abs(r.diff_n) for r in kv[1])
    ):
        top = max(found, key=lambda r: abs(r.diff_n))
        others = sorted(abs(r.velocity_m_s) for r in found if r is not top)
        also = ""
        if others:
            speeds = ", ".join(f"{units.velocity(v):.3g}" for v in others)
            also = f" (also at {speeds} {units.velocity_label})"
        where = f"clicks {clicks}" + (f", gas {gas_clicks}" if gas else "")
        lines.append(f"{b} vs {a}, {where}: {top.text(units)}{also}")
    return lines


def bleed_rows(inputs: list[Input]) -> tuple[list[str], list[list[str]], list[dict[str, object]]]:
    """The fitted bleed areas (mm²) of every fit input per click setting: header, rows, JSON."""
    fits = [i for i in inputs if i.fit is not None]
    keys = sorted({(c.clicks, c.gas_clicks) for i in fits for c in i.fit.clicks})  # type: ignore[union-attr]
    header = ["clicks", "gas"]
    for i in fits:
        header += [f"A_bc {i.label} (mm²)", f"A_bt {i.label} (mm²)"]
    for i in fits[1:]:
        header += [f"A_bc {i.label} vs {fits[0].label} (%)", f"A_bt {i.label} (%)"]
    rows: list[list[str]] = []
    doc: list[dict[str, object]] = []
    for key in keys:
        cells = [str(key[0]), str(key[1])]
        areas: dict[str, dict[str, float]] = {}
        for i in fits:
            assert i.fit is not None
            c = next((c for c in i.fit.clicks if (c.clicks, c.gas_clicks) == key), None)
            if c is None:
                cells += ["–", "–"]
                continue
            cells += [f"{c.a_bc_m2 * 1e6:.3f}", f"{c.a_bt_m2 * 1e6:.3f}"]
            areas[i.label] = {"A_bc_m2": c.a_bc_m2, "A_bt_m2": c.a_bt_m2}
        first = areas.get(fits[0].label)
        for i in fits[1:]:
            other = areas.get(i.label)
            for name in ("A_bc_m2", "A_bt_m2"):
                if first is None or other is None or not first[name] > 0:
                    cells.append("–")
                    continue
                cells.append(f"{100 * (other[name] / first[name] - 1):+.1f}")
        rows.append(cells)
        doc.append({"clicks": key[0], "gas_clicks": key[1], "areas": areas})
    return header, rows, doc


def to_json(inputs: list[Input], rows: list[Row]) -> dict[str, object]:
    """The `--json` document (SI; docs/compare.md)."""
    _, _, bleed = bleed_rows(inputs)
    return {
        "schema": "shockdyno.compare/1",
        "reference": inputs[0].label,
        "inputs": [
            {"label": i.label, "path": str(i.path), "kind": i.kind, "loss": i.loss} for i in inputs
        ],
        # "damping": forces with the static gas force removed (each recording's measured or
        # estimated one, each fit's model force at rest); "raw": as measured (--raw-force)
        "force": "raw" if any(i.raw_force for i in inputs) else "damping",
        "rule": {"k_scatter": K_SCATTER, "floor_share": FLOOR_SHARE, "floor_n": FLOOR_N},
        "rows": [r.to_json() for r in rows],
        "bleed_areas": bleed,
    }
