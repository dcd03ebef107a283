"""The inputs of a comparison: a recording (measured) or a fit (the model), any mix.

A recording gives its click chart as measured, the per-cycle scatter of every value
(report/repeatability.py), its peak forces and loops. A fit gives the model's click
chart (mid-stroke, zero acceleration: ``clickchart.model_forces``), whose values carry
no scatter, and its bleed areas.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from shockdyno.errors import ConfigError, RecordingError
from shockdyno.fit.result import FitResult
from shockdyno.record import adjusters, open_recording
from shockdyno.record.types import TestData
from shockdyno.report import clickchart, repeatability
from shockdyno.report import gas as gas_mod
from shockdyno.report.summary import TestSummary, summarise
from shockdyno.result_files import starts_as_mcap

Setting = clickchart.Setting


@dataclass(frozen=True)
class Value:
    """One click-chart value of an input: force (N) and the SD of that value (N; 0 for a
    model, nan when unknown), and whether it is an extrapolation."""

    force_n: float
    sd_n: float
    extrapolated: bool = False


@dataclass
class Input:
    label: str
    path: Path
    kind: str  # "recording" | "fit"
    chart: clickchart.ClickChart
    values: dict[Setting, dict[float, Value]]
    tests: list[TestData] = field(default_factory=list)
    summaries: list[TestSummary] = field(default_factory=list)
    cycles: list[repeatability.TestCycles] = field(default_factory=list)
    fit: FitResult | None = None
    raw_force: bool = False  # True: force as measured; else damping force, gas removed
    gas: gas_mod.GasForces = field(default_factory=dict)  # a recording's, by gas clicks
    # What a cut-off or damaged recording lost (Recording.loss_note), None when whole
    loss: str | None = None

    def gas_removed(self, gas_clicks: int) -> bool:
        """Whether this input's values at that gas setting are damping force (a fit's
        always are; a recording's unless its gas force was refused or is unknown)."""
        if self.raw_force or self.kind == "fit":
            return True
        found = self.gas.get(gas_clicks)
        return found is not None and found.removed

    @property
    def settings(self) -> list[Setting]:
        return sorted(self.values)


def default_labels(paths: Sequence[str], given: Sequence[str]) -> list[str]:
    """Labels from `--label NAME=TEXT` (NAME: the path as given or its stem), else the
    file stems; a stem that repeats gets its position appended."""
    named: dict[str, str] = {}
    for item in given:
        name, sep, text = item.partition("=")
        if not sep or not name or not text:
            raise ConfigError(f"--label {item!r}: use NAME=TEXT, e.g. {Path(paths[0]).stem}=left")
        named[name] = text
    known = set(paths) | {Path(p).stem for p in paths}
    for name in named:
        if name not in known:
            raise ConfigError(f"--label {name}=...: {name} is none of the inputs")
    stems = [Path(p).stem for p in paths]
    labels = []
    for k, p in enumerate(paths):
        label = named.get(p) or named.get(stems[k]) or stems[k]
        if stems.count(stems[k]) > 1 and label == stems[k]:
            label = f"{label} ({k + 1})"
        labels.append(label)
    return labels


def _is_mcap(path: Path) -> bool:
    try:
        return starts_as_mcap(path)
    except FileNotFoundError:
        raise ConfigError(f"{path} not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path} is a folder; expected a recording (.mcap) or a fit") from None


def load_input(
    path: Path,
    label: str,
    speeds_m_s: Sequence[float],
    flag: str = "input",
    raw_force: bool = False,
    gas_given: Mapping[int, float] | None = None,
    spec: str | None = None,
    adjuster: str | None = None,
) -> Input:
    """Read one input; a one-line error for anything that is neither kind. A recording's
    gas force: `gas_given`, else measured, else estimated within `spec`'s charge.
    `adjuster`: of a damper with several, the line compared (record/adjusters.py)."""
    if flag == "input" and _is_mcap(path):
        return _recording(path, label, speeds_m_s, raw_force, gas_given, spec, adjuster)
    try:
        fit = FitResult.load(path, flag=flag).require_usable(f"{flag} {path}")
    except ConfigError as exc:
        if flag != "input":
            raise
        raise ConfigError(f"{exc} or a recording (.mcap)") from None
    _check_adjuster(path, fit.adjuster_names(), adjuster)
    if adjuster is not None:
        fit = fit.for_adjuster(adjuster)
    return _fit(path, label, fit, speeds_m_s, raw_force)


def _check_adjuster(path: Path, names: Sequence[str], adjuster: str | None) -> None:
    """An input of a damper with several adjusters is compared along one named adjuster;
    one of the one rod adjuster is compared as it is."""
    if names and adjuster is None:
        raise ConfigError(
            f"{path}: a damper with adjusters {', '.join(names)}: name the one to compare "
            f"with --adjuster (e.g. --adjuster {names[0]})"
        )
    if adjuster is not None and adjuster not in names:
        have = f"adjusters {', '.join(names)}" if names else "the one rod adjuster (no --adjuster)"
        raise ConfigError(f"{path}: --adjuster {adjuster}: it has {have}")


def _recording(
    path: Path,
    label: str,
    speeds_m_s: Sequence[float],
    raw_force: bool,
    gas_given: Mapping[int, float] | None,
    spec: str | None,
    adjuster: str | None = None,
) -> Input:
    rec = open_recording(path).require_recording()
    tests = [t for t in rec.load_all() if t.meta.status == "complete"]
    if not tests:
        raise RecordingError(f"{path}: no complete test to compare")
    lines = adjusters.lines(tests)
    _check_adjuster(path, list(lines), adjuster)
    if adjuster is not None:
        tests = lines[adjuster]
    forces: gas_mod.GasForces = {}
    if not raw_force:  # each setting's gas force: given, measured, else estimated, bounded
        limit = gas_mod.limit_for(tests, spec, rec.metadata)
        forces = gas_mod.gas_forces(tests, gas_given, limit)
        tests = gas_mod.apply(tests, forces)
    chart = clickchart.click_chart(tests, None, speeds_m_s, raw_force=raw_force, gas=forces)
    # the scatter is of single cycles about their mean: the gas force, a constant, drops out
    cycles = repeatability.sweep_cycles(tests, speeds_m_s)
    scatter = repeatability.chart_scatter(cycles, chart.velocities_m_s)
    values: dict[Setting, dict[float, Value]] = {}
    for key, row in chart.measured.items():
        values[key] = {}
        for t, r in row.items():
            s = scatter.get(key, {}).get(t)
            sd = s.sd_of_mean_n if s is not None and not r.extrapolated else math.nan
            values[key][t] = Value(r.force_n, sd, r.extrapolated)
    summaries = [summarise(t, gas_force_n=None if raw_force else t.meta.gas_force_n) for t in tests]
    return Input(
        label, path, "recording", chart, values, tests, summaries, cycles, None, raw_force, forces,
        rec.loss_note(),
    )  # fmt: skip


def _fit(
    path: Path, label: str, fit: FitResult, speeds_m_s: Sequence[float], raw_force: bool
) -> Input:
    chart = clickchart.click_chart([], fit, speeds_m_s, raw_force=raw_force)
    values = {key: {t: Value(f, 0.0) for t, f in row.items()} for key, row in chart.model.items()}
    return Input(label, path, "fit", chart, values, fit=fit, raw_force=raw_force)
