"""A long test runs in bounded memory (issue 46.6): `run_sine` kept every sample until the
test ended (~40 B a sample: a day-long durability test ~3.7 GB). Now it keeps the last
MAX_KEPT_SAMPLES and every cycle's extremes; the samples themselves go to the recording
as they come."""

from __future__ import annotations

import tracemalloc

import pytest

from shockdyno.run import verify
from shockdyno.run.session import RigSession


def test_a_long_sine_is_judged_in_bounded_memory(sim_rig_factory, monkeypatch) -> None:
    monkeypatch.setattr(verify, "MAX_KEPT_SAMPLES", 20_000)
    sim = sim_rig_factory(speed=100.0)
    seen = [0]

    def count(block) -> None:  # type: ignore[no-untyped-def]
        seen[0] += len(block)  # the recording's place: gone once handed on

    with RigSession(sim.rig_config()) as session:
        tracemalloc.start()
        try:
            before = tracemalloc.get_traced_memory()[0]
            out = session.run_sine(0.01, 5.0, 2, 1500, count)  # 300 s: 300 000 samples
            held, peak = (m - before for m in tracemalloc.get_traced_memory())
        finally:
            tracemalloc.stop()
    assert out.status == "complete", out.reason
    assert "measured 5 Hz" in out.reason
    assert seen[0] > 300_000
    kept_all = seen[0] * 42  # bytes of SampleBlocks, had every sample been kept
    # What the run still holds is its kept tail; the peak also counts what the host's
    # threads had in flight (frames read, blocks queued), more of it on a loaded machine.
    assert held < kept_all / 4, (held, kept_all)
    assert peak < kept_all / 2, (peak, kept_all)


def test_the_kept_tail_is_judged_like_the_whole_run() -> None:
    """A run longer than what is kept is measured on its last whole cycles: the same
    frequency, amplitude and centre as on all of it."""
    import numpy as np

    from shockdyno.rig.config import load_rig
    from shockdyno.rig.types import SampleBlock
    from shockdyno.run.verify import RunKeeper, judge_run

    rig = load_rig(verify.__file__.replace("src/shockdyno/run/verify.py", "rigs/sim.toml"))
    f, a, fs = 2.0, 0.02, 1000.0
    seq = np.arange(int(60 * fs))
    t = seq / fs
    x = a * np.sin(2 * np.pi * f * t) + 1e-6 * np.sin(7.3 * t)
    run = SampleBlock(
        seq, t, x, np.zeros_like(t), np.full_like(t, 40.0), np.zeros_like(seq, np.uint16)
    )
    window = (1.0, 59.0)
    whole = judge_run(run, window, a, f, rig, 0)
    keeper = RunKeeper(keep=5_000)
    for lo in range(0, len(t), 700):
        if lo == 700:
            keeper.measure(window, f)
        keeper.add(run.slice(lo, lo + 700))
    tail = judge_run(keeper, window, a, f, rig, 0)
    assert keeper.trimmed and len(keeper.tail) < 6_000
    assert whole.status == tail.status == "complete"
    assert "measured 2 Hz, 20 mm" in tail.reason and "measured 2 Hz, 20 mm" in whole.reason
    assert keeper.cycles is not None and int(keeper.cycles.count.sum()) == pytest.approx(
        (window[1] - window[0]) * fs, abs=2
    )
