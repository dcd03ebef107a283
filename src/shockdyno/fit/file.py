"""`shockdyno fit` on one recording file, as the command and `batch fit` both run it."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import numpy.typing as npt

from shockdyno.errors import ConfigError, FitError
from shockdyno.fit.result import FitResult
from shockdyno.fit.result_doc import VelocityReach
from shockdyno.fit.sweep import Progress, fit_sweep
from shockdyno.fit.terms import parse_terms
from shockdyno.model.kinematics import differentiate
from shockdyno.record import open_recording
from shockdyno.record.identity import recording_info
from shockdyno.record.types import TestData
from shockdyno.result_files import RecordingRef

# Beyond these a recording is not of a damper on a dyno (a unit mix-up or a corrupt file).
MAX_DISPLACEMENT_M = 1.0
MAX_FORCE_N = 1e6


def check_fit_input(tests: list[TestData], source: str) -> None:
    """Refuse a recording whose samples a fit cannot use (non-finite or absurd values)."""
    for test in tests:
        for name, values in (("time", test.t), ("displacement", test.x), ("force", test.force)):
            if values.size == 0:
                continue
            finite = np.isfinite(values)
            if not finite.all():
                raise FitError(
                    f"{source}: test {test.meta.index} has {int((~finite).sum())} non-finite "
                    f"{name} values; nothing written"
                )
        peak_x, peak_f = _peak(test.x), _peak(test.force)
        if peak_x > MAX_DISPLACEMENT_M or peak_f > MAX_FORCE_N:
            raise FitError(
                f"{source}: test {test.meta.index} is beyond any damper dyno "
                f"(|x| up to {peak_x:.3g} m, |F| up to {peak_f:.3g} N); nothing written"
            )


def _peak(values: npt.NDArray[np.float64]) -> float:
    return float(np.max(np.abs(values))) if values.size else 0.0


def velocity_range(tests: list[TestData]) -> tuple[VelocityReach, ...]:
    """The fastest compression and rebound velocity (m/s, signed) each click setting's
    tests reached over their measured cycles: the fit JSON's `info.velocity_range`, the
    span a damper table may call measured (ride/damper_table.py)."""

    reached: dict[tuple[int, int, tuple[tuple[str, int], ...]], tuple[float, float]] = {}
    for test in tests:
        m = test.measured()
        if m.t.size < 8:
            continue
        try:
            v = differentiate(m.t, m.x)[0]
        except ConfigError:  # a time base the fit refuses too: it reached nothing measured
            continue
        if not np.any(np.isfinite(v)):
            continue
        key = (test.meta.clicks, test.meta.gas_clicks, test.meta.setting)
        lo, hi = reached.get(key, (0.0, 0.0))
        reached[key] = (min(lo, float(np.nanmin(v))), max(hi, float(np.nanmax(v))))
    # a damper with several adjusters: each entry names every adjuster's clicks
    return tuple(
        VelocityReach(clicks=c, gas_clicks=g, adjusters=dict(s), compression_m_s=hi, rebound_m_s=lo)
        for (c, g, s), (lo, hi) in sorted(reached.items())
    )


def result_json(result: FitResult) -> str:
    try:
        return json.dumps(result.to_json(), indent=2, allow_nan=False) + "\n"
    except (TypeError, ValueError) as exc:
        raise FitError(
            f"the fit result cannot be written as JSON ({exc}); nothing written"
        ) from None


def fit_file(
    recording: Path,
    *,
    spec: str | None = None,
    optimizer: str = "fast",
    seed: int = 0,
    terms: str | None = None,
    progress: Progress | None = None,
    warn: Callable[[str], None] | None = None,
) -> tuple[FitResult, list[TestData]]:
    """`shockdyno fit` on one recording, as `batch fit` runs it too: the FitResult (with
    `info.recording` and any `info.recording_loss`) and the tests it read."""
    rec = open_recording(recording).require_recording()
    loss = rec.loss_note()
    if loss and warn is not None:
        warn(f"warning: {recording}: {loss}")
    tests = rec.load_all()
    check_fit_input(tests, str(recording))
    result = fit_sweep(
        tests,
        spec_path=spec,
        optimizer=optimizer,
        seed=seed,
        progress=progress,
        terms=parse_terms(terms),
    )
    result.info = replace(
        result.info,
        recording=RecordingRef(**recording_info(recording)),
        velocity_range=velocity_range(tests),
        recording_loss=loss or None,
    )
    return result, tests
