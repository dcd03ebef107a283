"""How a damper changed: its recordings in order, the quantities each fit and diagnosis
gave, what moved beyond its uncertainty from the first recording to the last, and a plot.

A quantity **changed** when, between the first and the last recording that have it,
|Δ| ≥ ``MIN_SHARE`` of the first value and |Δ| > ``K_SIGMA`` × √(σ₁² + σ₂²): a bleed area
fitted at ±0.03 % moves by more than its σ from sweep to sweep of the same damper (the
sim-rig's runs differ), so the share is what keeps a re-test from reading as a rebuild.
A quantity that moved by the share but has no σ on one side (a parameter a fit could not
identify, E_t) is listed apart, **not judged**: the compression valve's preload is no
longer seen once a wider bleed carries the flow, and its fitted value wanders. A change
under ``FLOORS`` of its unit is no change a shop would act on, whatever its share (a
closed needle's area going from 0 to 0.0004 mm², a channel delay from +0.013 to
-0.007 ms), as compare has its practical floor.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from shockdyno.history.store import Visit

K_SIGMA = 3.0
MIN_SHARE = 0.05
AREA_UNIT = ("mm²", 1e6)
CHANGED, STEADY, UNJUDGED = "changed", "steady", "no σ to judge"
# The smallest change worth a line, by SI unit: 0.01 mm² of bleed, 1 µm, 0.1 ms, 1 N,
# 0.1 bar.
FLOORS = {"m²": 1e-8, "m": 1e-6, "s": 1e-4, "N": 1.0, "Pa": 1e4}
# SI units shown as a dyno engineer reads them: (scale, unit).
SHOWN = {"Pa": (1e-5, "bar"), "m": (1e3, "mm"), "m²": (1e6, "mm²"), "s": (1e3, "ms")}


@dataclass(frozen=True)
class Series:
    """One quantity over a damper's recordings (None where a recording lacks it)."""

    name: str  # "A_bc at 10 clicks", "friction_n", "gas force", "E_t"
    unit: str
    scale: float  # SI value x scale = shown value
    values: tuple[float | None, ...]
    sds: tuple[float | None, ...]
    floor: float = 0.0  # SI: a smaller change is none (FLOORS)

    @property
    def present(self) -> list[int]:
        """The recordings (indices) that have a finite value."""
        return [k for k, v in enumerate(self.values) if v is not None and math.isfinite(v)]

    def change(self) -> tuple[float, float, str] | None:
        """(first, last, verdict) over the recordings that have it (None with fewer than
        2): CHANGED, STEADY, or UNJUDGED (moved by MIN_SHARE or more, but a σ is unknown:
        a parameter the fit could not identify, E_t)."""
        have = self.present
        if len(have) < 2:
            return None
        i, j = have[0], have[-1]
        a, b = self.values[i], self.values[j]
        assert a is not None and b is not None
        sa, sb = self.sds[i], self.sds[j]
        d = abs(b - a)
        if d < MIN_SHARE * abs(a) or d <= self.floor:
            return a, b, STEADY
        if sa is None or sb is None or not math.isfinite(sa + sb):
            return a, b, UNJUDGED
        return a, b, CHANGED if d > K_SIGMA * math.hypot(sa, sb) else STEADY

    def shown(self, k: int) -> str:
        """The value of recording `k` in the shown unit, with its σ as a percentage (`–` when
        unknown)."""
        v = self.values[k]
        if v is None or not math.isfinite(v):
            return "–"
        text = f"{v * self.scale:.4g}"
        sd = self.sds[k]
        if sd is not None and math.isfinite(sd) and abs(v) < 1e-3 * sd:
            # An optimiser at a bound of 0 leaves 4e-17 there: zero within its σ, said so
            # (as a percentage it read ±1.5e+16 %).
            return f"0 ±{sd * self.scale:.2g}"
        if sd is not None and math.isfinite(sd) and v:
            text += f" ±{100 * sd / abs(v):.2g}%"
        return text

    def line(self) -> str:
        """'A_bc at 10 clicks: 10.03 → 10.02 → 15.04 mm² (+50 %, changed)'."""
        have = self.present
        path = " → ".join(f"{self.values[k] * self.scale:.4g}" for k in have)  # type: ignore[operator]
        got = self.change()
        if got is None:
            return f"{self.name}: {path} {self.unit}".rstrip()
        a, b, verdict = got
        share = f"{100 * (b - a) / abs(a):+.0f} %" if a else f"{(b - a) * self.scale:+.3g}"
        return f"{self.name}: {path} {self.unit} ({share}, {verdict})".replace("  ", " ")


def series(visits: Sequence[Visit]) -> list[Series]:
    """Every quantity the damper's recordings carry, in a fixed order: bleed areas per
    click, fitted parameters, gas force per gas setting, E_t."""
    fits = [v.latest("fit") for v in visits]
    diags = [v.latest("diagnose") for v in visits]
    out: list[Series] = []
    keys = sorted({(a.gas_clicks, a.clicks) for f in fits if f for a in f.areas})
    gas_shown = len({g for g, _ in keys}) > 1
    for side in ("bc", "bt"):
        for g, c in keys:
            vals, sds = [], []
            for f in fits:
                found = [a for a in f.areas if (a.gas_clicks, a.clicks) == (g, c)] if f else []
                vals.append(getattr(found[0], f"a_{side}_m2") if found else None)
                sds.append(getattr(found[0], f"a_{side}_sd_m2") if found else None)
            where = f"{c} clicks" + (f", gas {g}" if gas_shown else "")
            name = f"A_{side} at {where}"
            out.append(Series(name, *AREA_UNIT, tuple(vals), tuple(sds), FLOORS["m²"]))
    names = sorted({p.name for f in fits if f for p in f.parameters})
    for name in names:
        got = [next((p for p in f.parameters if p.name == name), None) if f else None for f in fits]
        unit = next((p.unit for p in got if p is not None), "")
        scale, shown = SHOWN.get(unit, (1.0, unit))
        fitted = tuple(p.value if p else None for p in got)
        spread = tuple(p.sd if p else None for p in got)
        out.append(Series(name, shown, scale, fitted, spread, FLOORS.get(unit, 0.0)))
    gas_settings = sorted({g.gas_clicks for v in visits for g in v.recording.gas})
    for g in gas_settings:
        entries = [next((e for e in v.recording.gas if e.gas_clicks == g), None) for v in visits]
        name = "gas force" + (f" at gas {g}" if len(gas_settings) > 1 else "")
        forces = tuple(e.gas_force_n if e else None for e in entries)
        spread = tuple(e.sd_n if e else None for e in entries)
        out.append(Series(name, "N", 1.0, forces, spread, FLOORS["N"]))
    out.append(Series("E_t (fit)", "", 1.0, tuple(f.e_t if f else None for f in fits),
                      (None,) * len(fits)))  # fmt: skip
    if any(d is not None for d in diags):
        after = tuple(d.e_t if d else None for d in diags)
        out.append(Series("E_t after diagnosis", "", 1.0, after, (None,) * len(diags)))
    return out


def gas_text(visit: Visit) -> str:
    """A recording's gas forces in one cell: `231 N measured`, `240 ±12 N estimated`, or the
    source where none is known."""
    parts = []
    for g in visit.recording.gas:
        if g.gas_force_n is None:
            parts.append(f"{g.source}")
            continue
        sd = f" ±{g.sd_n:.0f}" if g.sd_n is not None and g.source == "estimated" else ""
        parts.append(f"{g.gas_force_n:.0f}{sd} N {g.source}")
    return "; ".join(parts) or "–"


def diagnosis_text(visit: Visit) -> str:
    """The physics the recording's latest diagnosis claimed (`–` without one)."""
    d = visit.latest("diagnose")
    if d is None:
        return "–"
    return d.physics.replace(",", ", ") or "nothing claimed"


def _steady_base(s: Series) -> bool:
    """A parameter worth a line on the plot: its first value non-zero and known to 20 %
    (a term at its off value, or one no fit could identify, would only add noise)."""
    have = s.present
    if not have:
        return False
    v, sd = s.values[have[0]], s.sds[have[0]]
    if s.name.startswith("gas force"):
        return bool(v)
    return bool(v) and sd is not None and math.isfinite(sd) and sd < 0.2 * abs(v or 1.0)


def plot(visits: Sequence[Visit], all_series: Sequence[Series], damper: str, path: Path) -> Path:
    """Areas per click, fitted parameters and the gas force, and E_t, against the
    recordings' dates (one point per recording, ±1σ where known)."""
    import matplotlib  # here: +120-420 ms CPU at every command's start-up (measured)

    matplotlib.use("Agg")
    import matplotlib.dates as mdates
    import matplotlib.pyplot as plt

    when = [datetime.fromisoformat(v.recording.recorded_utc.replace("Z", "+00:00")) for v in visits]
    areas = [s for s in all_series if s.name.startswith("A_")]
    others = [s for s in all_series if not s.name.startswith(("A_", "E_t")) and _steady_base(s)]
    groups = [
        ("Bleed areas (mm²): A_bc solid, A_bt dashed", areas),
        ("Identified parameters and gas force: change from the first recording (%)", others),
        ("E_t (model error, 0 = perfect)", [s for s in all_series if s.name.startswith("E_t")]),
    ]
    fig, axes = plt.subplots(3, 1, figsize=(9, 10), sharex=True, constrained_layout=True)
    colours = plt.get_cmap("viridis")
    clicks = sorted({s.name.split(" at ")[1] for s in groups[0][1]})
    for ax, (title, members) in zip(axes, groups, strict=True):
        ax.set_title(title, fontsize=10, loc="left")
        for s in members:
            have = s.present
            if not have:
                continue
            x = [when[k] for k in have]
            y = [s.values[k] * s.scale for k in have]  # type: ignore[operator]
            err = [((s.sds[k] or 0.0) * s.scale) for k in have]
            style: dict[str, object] = {"marker": "o", "capsize": 3}
            if s.name.startswith("A_"):
                where = s.name.split(" at ")[1]
                style["color"] = colours(0.85 * clicks.index(where) / max(1, len(clicks) - 1))
                style["linestyle"] = "-" if s.name.startswith("A_bc") else "--"
                label = where if s.name.startswith("A_bc") else None
            elif s.name.startswith("E_t"):
                label = s.name
            else:
                first = y[0]
                y = [100 * (v / first - 1) for v in y]
                err = [100 * e / abs(first) for e in err]
                label = f"{s.name} (first {first:.4g} {s.unit})"
            ax.errorbar(x, y, yerr=err, label=label, **style)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, ncol=2)
        ax.grid(alpha=0.3)
    locator = mdates.AutoDateLocator()  # type: ignore[no-untyped-call]
    axes[-1].xaxis.set_major_locator(locator)
    axes[-1].xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))  # type: ignore[no-untyped-call]
    axes[-1].set_xlabel("recorded (UTC)")
    fig.suptitle(f"History of damper {damper}: {len(visits)} recordings")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
