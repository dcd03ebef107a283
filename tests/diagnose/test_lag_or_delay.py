"""A load cell's first-order lag is read as a lag, a transport delay as a delay (issue 44).

At 0.5-1.5 Hz a delay and a lag shift the loop alike; they differ only at sharp events
(the seal's friction flip at each reversal), so the diagnosis frees both and must put the
shift where the plant has it. The plant is the held-out one (tests/holdout/plant.py), its
load cell an RC amplifier filtered at its own 4 kHz rate, not the library's lag. With the
load-cell lag held at 0 (the fit's default) this sweep's 5 ms lag reads as a 4.7 ms delay
and leaves 9.3 N RMS of structure; held at the start grid's 3 ms, a 1.9 ms delay and 4.8 N.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from plants import claimed_values

from holdout.plant import Effects
from holdout.recording import holdout_recording
from shockdyno.diagnose.file import diagnose_file
from shockdyno.schema import to_json

pytestmark = pytest.mark.timeout(600)

CLICKS = (2, 12)
FREQS = (0.5, 1.5)
SEED = 6213  # fresh: no rule was looked at on it


def _diagnosed(effects: Effects, where: Path) -> dict[str, Any]:
    rec, truth = holdout_recording(effects, where, SEED, clicks=CLICKS, freqs=FREQS)
    assert truth.physics() == ["sensor_lag"]
    doc: dict[str, Any] = to_json(diagnose_file(Path(rec), terms="sensor_lag")[1])
    assert doc["verdict"]["physics"] == ["sensor_lag"], doc["verdict"]["text"]
    # Modelled to the noise: what is left repeats by about the clean plant's 0.8 N.
    assert doc["verdict"]["remaining_rms_n"] < 1.5, doc["verdict"]["text"]
    return doc


def test_a_first_order_load_cell_lag_is_read_as_a_lag(tmp_path: Path) -> None:
    doc = _diagnosed(Effects(cell_lag_s=0.005), tmp_path)
    v = claimed_values(doc, "sensor_lag")
    assert v["load_cell_lag_s"] == pytest.approx(0.005, rel=0.15), v
    # What the fit leaves as a delay of the force against the motion is no more than a
    # tenth of the lag (a delay and an LVDT lag cancel: only their difference is a shift).
    assert abs(v["delay_s"] - v["lvdt_lag_s"]) < 0.0005, v
    # Its advice carries the lag into a fit (`--terms sensor_lag` alone frees only the delay
    # and read this lag as a 4 ms delay).
    assert "fit --terms sensor_lag,sensor_lag.load_cell_lag_s." in doc["verdict"]["text"]


def test_a_transport_delay_is_read_as_a_delay(tmp_path: Path) -> None:
    doc = _diagnosed(Effects(force_delay_s=0.004), tmp_path)
    v = claimed_values(doc, "sensor_lag")
    assert v["delay_s"] - v["lvdt_lag_s"] == pytest.approx(0.004, abs=0.0004), v
    assert v["load_cell_lag_s"] < 0.0004, v
