"""What a damper dyno can measure: values beyond these are a unit mix-up or a damaged file.

Generous on purpose (a race-car damper on a large dyno stays far inside them); anything
outside is refused with one line, never stored. Within them, a value that looks like a
mix-up of mm and m, or of N and kN, is only warned about.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from shockdyno.errors import RecordingError

MAX_DISPLACEMENT_M = 1.0  # |x| from the data's own zero
MAX_FORCE_N = 1.0e6
TEMPERATURE_RANGE_C = (-60.0, 300.0)
MAX_CLICKS = 1000
MAX_FREQUENCY_HZ = 1000.0
MAX_AMPLITUDE_M = 0.5
MAX_SAMPLE_RATE_HZ = 1.0e6
SUSPICIOUS_DISPLACEMENT_M = 0.25  # a damper stroke beyond this is more likely mm read as m


def check_samples(
    where: str, x: NDArray[np.float64], force: NDArray[np.float64], temp: NDArray[np.float64]
) -> list[str]:
    """Refuse non-finite or impossible samples (RecordingError); return warnings."""
    for name, values in (("displacement", x), ("force", force)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise RecordingError(
                f"{where}: data row {int(bad[0]) + 1}: {name} is not finite after unit conversion"
            )
    for name, values, limit, hint in (
        ("displacement", x, MAX_DISPLACEMENT_M, "m (mm labelled as m? --displacement-unit mm)"),
        ("force", force, MAX_FORCE_N, "N (no damper dyno makes this)"),
    ):
        over = np.flatnonzero(np.abs(values) > limit)
        if over.size:
            i = int(over[0])
            raise RecordingError(
                f"{where}: data row {i + 1}: {name} {values[i]:.4g} exceeds ±{limit:g} {hint}"
            )
    known = temp[np.isfinite(temp)]
    lo, hi = TEMPERATURE_RANGE_C
    if known.size and (known.min() < lo or known.max() > hi):
        raise RecordingError(f"{where}: temperature outside {lo:g}..{hi:g} °C")
    if np.any(np.isinf(temp)):
        raise RecordingError(f"{where}: temperature is not finite after unit conversion")
    warnings = []
    peak = float(np.max(np.abs(x))) if x.size else 0.0
    if peak > SUSPICIOUS_DISPLACEMENT_M:
        warnings.append(
            f"{where}: displacement reaches {peak:.3g} m, unusual for a damper (mm labelled as m?)"
        )
    return warnings


def check_setting(where: str, name: str, value: float, limit: float) -> None:
    """RecordingError unless `value` is at most `limit`, what any damper dyno could do (a NaN
    fails too)."""
    if not value <= limit:
        raise RecordingError(f"{where}: {name} {value:g} is beyond any damper dyno (max {limit:g})")
