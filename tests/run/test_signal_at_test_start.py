"""A stop signal that lands while a test is being opened: the test is still recorded as aborted
by the operator, not left for the recording's close to mark without a reason."""

from __future__ import annotations

import os
import signal

import pytest

from shockdyno.record import RecordingWriter, open_recording
from shockdyno.run.liveview import LiveView
from shockdyno.run.plan import SweepPlan
from shockdyno.run.signals import stop_on_signals
from shockdyno.run.sweep import SweepResult, _meta, _run_test


class NeverRun:
    """A session the interrupted test must never reach."""

    def run_sine(self, *args: object, **kwargs: object) -> None:
        raise AssertionError("the test ran after the stop signal")


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_while_a_test_opens_marks_it_aborted_with_its_reason(tmp_path, signum):
    path = tmp_path / "signalled.mcap"
    plan = SweepPlan(clicks=(3,), frequencies_hz=(1.0,), warmup_cycles=1, measured_cycles=1)
    meta = _meta(0, plan.points()[0], plan, 1000.0, 25.0)
    result = SweepResult()
    with (
        stop_on_signals(),
        RecordingWriter(path, metadata={"damper_id": "signalled"}) as writer,
        LiveView(1, enabled=False) as view,
    ):
        emit = writer._emit_json

        def signalled(*args, **kwargs):  # type: ignore[no-untyped-def]
            os.kill(os.getpid(), signum)  # a real signal, inside the writer's record
            return emit(*args, **kwargs)

        writer._emit_json = signalled  # type: ignore[method-assign]
        with pytest.raises(KeyboardInterrupt):
            _run_test(NeverRun(), plan, meta, writer, view, result, [0.0])  # type: ignore[arg-type]
        writer._emit_json = emit  # type: ignore[method-assign]
    (test,) = open_recording(path).tests
    assert test.status == "aborted"
    want = "Ctrl-C" if signum == signal.SIGINT else "SIGTERM"
    assert want in (test.abort_reason or ""), test.abort_reason
    assert [m.index for m in result.aborted] == [0]
