"""ISO 2631-1 Wk weighting against the standard's tabulated factors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shockdyno.model.iso2631 import weighted_rms, wk_gain

# ISO 2631-1:1997 Table 3, Wk factors (×1000) at one-third-octave centres.
ISO_TABLE = {
    0.5: 418, 1.0: 482, 2.0: 531, 4.0: 967, 5.0: 1039, 6.3: 1054,
    8.0: 1036, 10.0: 988, 12.5: 902, 20.0: 636, 31.5: 405, 80.0: 132,
}  # fmt: skip


def test_wk_gain_matches_iso_table() -> None:
    f = np.array(list(ISO_TABLE))
    expected = np.array(list(ISO_TABLE.values())) / 1000
    np.testing.assert_allclose(wk_gain(f), expected, rtol=4e-3)


def test_weighted_rms_of_sines_is_amplitude_times_gain_over_root_two() -> None:
    dt, n = 1e-3, 20_000  # 20 s: 0.05 Hz lines, so 1.5 Hz and 6.3 Hz are whole periods
    t = np.arange(n) * dt
    x = 0.7 * np.sin(2 * math.pi * 1.5 * t + 0.3) + 0.2 * np.cos(2 * math.pi * 6.3 * t) + 0.05
    expected = math.sqrt((0.7 * wk_gain(1.5)) ** 2 / 2 + (0.2 * wk_gain(6.3)) ** 2 / 2)
    assert float(weighted_rms(x, dt)) == pytest.approx(expected, rel=1e-9)
    both = weighted_rms(np.vstack([x, 2 * x]), dt)
    np.testing.assert_allclose(both, [expected, 2 * expected], rtol=1e-9)
