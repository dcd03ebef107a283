"""Isolated load-cell spikes are a sensor finding, not physics (issue 20): one sample in a
hundred at ten times the force once read as 674 N of structure; on this synthetic sweep it
made a noise floor of 690 N that hid everything."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.spikes import remove_spikes
from shockdyno.diagnose.verdict import to_json
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import load_spec


def _spiked(every: int = 100, factor: float = 10.0):
    """One sample in `every`, at random (so some fall on the fit's 100 Hz samples), read
    at `factor` times the force: the issue's spiky load cell."""
    clean = synthetic_sweep(load_spec(), [5, 15], cycles=3, seed=11)
    rng = np.random.default_rng(5)
    spiked, where = [], []
    for t in clean:
        f = t.force.copy()
        idx = np.sort(rng.choice(np.arange(2, f.size - 2, 3), f.size // every, replace=False))
        f[idx] *= factor
        spiked.append(replace(t, force=f))
        where.append(idx)
    return clean, spiked, where


def test_lone_spikes_go_and_a_real_step_stays() -> None:
    clean, spiked, where = _spiked()
    cleaned, found = remove_spikes(spiked)
    assert found is not None and found.tests == len(clean)
    injected = sum(idx.size for idx in where)
    assert 0.9 * injected <= found.count <= injected
    for c, s, sp in zip(clean, cleaned, spiked, strict=True):
        # What stays is a spike on a small force: inside the test's range (+20 %).
        missed = np.flatnonzero(np.abs(s.force - c.force) > 30.0)
        lo, hi = float(np.min(c.force)), float(np.max(c.force))
        margin = 0.25 * (hi - lo)
        assert np.all((sp.force[missed] > lo - margin) & (sp.force[missed] < hi + margin))
    # A step in one sample (a closed bleed at reversal) is physics: it stays.
    t = clean[0]
    step = replace(t, force=np.where(np.arange(t.force.size) < 500, 200.0, -900.0))
    kept, none = remove_spikes([step])
    assert none is None and np.array_equal(kept[0].force, step.force)
    assert remove_spikes(clean)[1] is None  # and a clean sweep has none


def test_a_clean_sim_recording_has_no_spikes() -> None:
    """The shipped example (a sim-rig sweep with a closed-bleed click, whose reversal
    samples depart by hundreds of N from their neighbours) holds none."""
    from pathlib import Path

    from shockdyno.record import open_recording

    example = Path(__file__).resolve().parents[2] / "recordings" / "examples" / "example.mcap"
    assert remove_spikes(open_recording(example).load_all())[1] is None


@pytest.mark.timeout(300)
def test_a_spiky_load_cell_is_reported_as_the_sensor_and_claims_nothing() -> None:
    _, spiked, _ = _spiked()
    d = to_json(diagnose(spiked, settings=Settings(n_boot=199)))
    assert d["verdict"]["physics"] == [], d["verdict"]["text"]
    assert d["verdict"]["sensor"] and "isolated spikes" in d["verdict"]["sensor"][0]
    assert "Sensor, not physics" in d["verdict"]["text"]
    # Left in, the spikes made a noise floor of 690 N that would hide any physics.
    assert d["mismatch"]["noise_floor_n"] < 20.0
