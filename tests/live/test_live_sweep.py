"""`sweep --live` end to end: a real sweep process on the simulated rig, watched by a real
Foxglove WebSocket client; the same sweep without --live beside it."""

from __future__ import annotations

import importlib
import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from foxglove_client import FoxgloveClient, Received
from mcap.reader import make_reader

from shockdyno.record import open_recording
from shockdyno.record import schemas as s
from shockdyno.rig.config import load_rig
from shockdyno.samples import SampleBlock

REPO = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "shockdyno.cli"]
AMPLITUDE_M = 0.02
FREQUENCY_HZ = 2.0
WARMUP, MEASURED = 1, 2
# One click, one frequency, a few cycles, at 2x real time.
TINY = ["--rig", str(REPO / "rigs" / "sim.toml"), "--start-sim", "--speed", "2", "--seed", "3",
        "--clicks", "5", "--freq", str(FREQUENCY_HZ), "--amplitude-mm", str(AMPLITUDE_M * 1e3),
        "--warmup-cycles", str(WARMUP), "--cycles", str(MEASURED)]  # fmt: skip


def _sweep(out: Path, *extra: str) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "COLUMNS": "200"}
    return subprocess.Popen(
        [*CLI, "sweep", *TINY, "-o", str(out), *extra],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL,
        text=True,
        env=env,
    )


class Output:
    """A child's stdout, every line kept by a thread of its own (communicate() after a
    partial read would lose what the file object had buffered)."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        self.proc = proc
        self.lines: list[str] = []
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    def url(self, timeout_s: float = 60.0) -> str:
        """The ws:// URL the command says to open."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for line in list(self.lines):
                found = re.search(r"(ws://127\.0\.0\.1:\d+)", line)
                if found:
                    return found.group(1)
            if not self._thread.is_alive():
                break
            time.sleep(0.02)
        raise AssertionError("no live URL said:\n" + self.text)

    def finish(self, timeout_s: float) -> str:
        self.proc.wait(timeout_s)
        self._thread.join(10)
        return self.text

    @property
    def text(self) -> str:
        return "".join(self.lines)


def _reap(proc: subprocess.Popen[str]) -> None:
    if proc.poll() is None:
        proc.kill()
        proc.wait()
    if proc.stdout is not None:
        proc.stdout.close()


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    folder = tmp_path_factory.mktemp("live")
    live_out, plain_out = folder / "live.mcap", folder / "plain.mcap"
    live = _sweep(live_out, "--live", "--live-port", "0")
    plain = _sweep(plain_out)  # at the same time: the same load on both
    live_said, plain_said = Output(live), Output(plain)
    try:
        client = FoxgloveClient(live_said.url())
        said = live_said.finish(110)
        plain_said.finish(110)
        got = client.join(timeout_s=10)
    finally:
        _reap(live)
        _reap(plain)
    assert live.returncode == 0, said
    assert plain.returncode == 0, plain_said.text
    return {"got": got, "live": live_out, "plain": plain_out, "said": said}


def _mcap_channels(path: Path) -> dict[str, tuple[str, str, str, str]]:
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return {
        ch.topic: (
            summary.schemas[ch.schema_id].name,
            summary.schemas[ch.schema_id].encoding,
            summary.schemas[ch.schema_id].data.decode(),
            ch.message_encoding,
        )
        for ch in summary.channels.values()
    }


def test_the_live_server_advertises_the_recordings_channels_and_schemas(runs):
    got: Received = runs["got"]
    assert got.subprotocol == "foxglove.sdk.v1"
    assert got.server_info["name"] == "shockdyno"
    advertised = {
        ch["topic"]: (ch["schemaName"], ch["schemaEncoding"], ch["schema"], ch["encoding"])
        for ch in got.channels.values()
    }
    recorded = _mcap_channels(runs["live"])
    assert set(recorded) == {s.TOPIC_SAMPLES, s.TOPIC_TEST, s.TOPIC_ACTUATOR, s.TOPIC_EVENTS}
    for topic, schema in recorded.items():
        assert advertised[topic] == schema, topic
    assert set(advertised) - set(recorded) == {"/live/position", "/live/cycle"}
    assert "ws://127.0.0.1:" in runs["said"] and "live view closed" in runs["said"]


def _live_blocks(got: Received) -> list[tuple[int, SampleBlock]]:
    out = []
    for data in got.of(s.TOPIC_SAMPLES):
        test, _, version = s.samples_header(data)
        assert version == 2
        out.append((test, s.decode_samples([data])))
    return out


def test_the_live_samples_are_the_recordings_and_plausible(runs):
    got: Received = runs["got"]
    blocks = _live_blocks(got)
    in_test = SampleBlock.concat([b for test, b in blocks if test == 0])
    rec = open_recording(runs["live"])
    assert [m.status for m in rec.tests] == ["complete"]
    recorded = rec.samples(0)
    # Every sample of the test reached the viewer, and is the one recorded.
    np.testing.assert_array_equal(in_test.seq, recorded.seq)
    np.testing.assert_array_equal(in_test.displacement_m, recorded.displacement_m)
    np.testing.assert_array_equal(in_test.force_n, recorded.force_n)
    # Positions stay within the sweep's amplitude (a little overshoot and noise aside) and
    # reach it: the drive ran the planned sine.
    x = in_test.displacement_m
    assert np.abs(x).max() <= AMPLITUDE_M * 1.05 + 0.5e-3
    assert np.abs(x).max() >= AMPLITUDE_M * 0.95
    # Timeline as the recording's: log time = wall-clock origin + t_s, one origin.
    log_times = [lt for t, lt, _ in got.messages if t == s.TOPIC_SAMPLES]
    origins = [
        lt - round(float(b.t_s[0]) * 1e9) for lt, (_, b) in zip(log_times, blocks, strict=True)
    ]
    assert max(origins) == min(origins)
    assert abs(origins[0] / 1e9 - time.time()) < 600


def test_test_records_and_events_arrive_as_they_happen(runs):
    got: Received = runs["got"]
    records = got.json(s.TOPIC_TEST)
    assert [(r["phase"], r["test"], r["status"]) for r in records] == [
        ("begin", 0, "running"),
        ("end", 0, "complete"),
    ]
    assert records[1]["sample_count"] == len(open_recording(runs["live"]).samples(0))
    kinds = [e["kind"] for e in got.json(s.TOPIC_EVENTS)]
    for kind in ("enable", "start", "complete", "disable"):
        assert kind in kinds
    assert kinds.index("enable") < kinds.index("start") < kinds.index("complete")
    # Each as it happened, in the stream with the samples: the test's start before most of
    # its samples, its completion before its end record.
    seen = [(t, json.loads(d)["kind"] if t == s.TOPIC_EVENTS else None, d)
            for t, _, d in got.messages]  # fmt: skip
    start = next(i for i, (_, kind, _) in enumerate(seen) if kind == "start")
    complete = next(i for i, (_, kind, _) in enumerate(seen) if kind == "complete")
    samples = [i for i, (t, _, d) in enumerate(seen)
               if t == s.TOPIC_SAMPLES and s.samples_header(d)[0] == 0]  # fmt: skip
    begin, end = (i for i, (t, _, _) in enumerate(seen) if t == s.TOPIC_TEST)
    assert begin < start < samples[len(samples) // 2] < complete < end


def _lag_s(t: np.ndarray, x: np.ndarray, plan: np.ndarray) -> tuple[float, float, float]:
    """(delay, gain, rms residual) of x against the planned sine: x = c1 plan + c2 plan'/ω."""
    w = 2 * np.pi * FREQUENCY_HZ
    basis = np.column_stack((plan, np.gradient(plan, t) / w))
    (c1, c2), *_ = np.linalg.lstsq(basis, x, rcond=None)
    rms = float(np.sqrt(np.mean((x - basis @ (c1, c2)) ** 2)))
    return float(np.arctan2(-c2, c1) / w), float(np.hypot(c1, c2)), rms


def test_cycles_build_up_with_the_plan_beside_the_measurement(runs):
    got: Received = runs["got"]
    cycles = got.json("/live/cycle")
    rig = load_rig(REPO / "rigs" / "sim.toml")
    ramp = rig.ramp.sine_ramp_cycles
    parts = ["ramp-in"] * ramp + ["warm-up"] * WARMUP + ["measured"] * MEASURED
    assert [c["part"] for c in cycles] == [*parts, *["ramp-out"] * ramp]
    assert [c["cycle"] for c in cycles] == list(range(len(parts) + ramp))
    # The simulated servo is 2nd order (rigs/sim.toml [simulation]): the ram follows its
    # command with a phase lag of atan(2ζr / (1 - r²)), r = f / f_n: 4.25 ms at 2 Hz.
    f_n, zeta = rig.simulation["servo_bandwidth_hz"], rig.simulation["servo_damping"]
    r = FREQUENCY_HZ / f_n
    servo_lag_s = np.arctan2(2 * zeta * r, 1 - r * r) / (2 * np.pi * FREQUENCY_HZ)
    for c in cycles:
        t, x, f, plan = (np.array(c[k], dtype=float)
                         for k in ("t_s", "displacement_m", "force_n", "commanded_m"))  # fmt: skip
        assert abs(len(x) - rig.sample_rate_hz / FREQUENCY_HZ) <= 1
        assert len(plan) == len(x) == len(f)
        if c["part"] in ("warm-up", "measured"):
            # The plan is the sine asked for, timed from the drive's motion bit: the
            # measured sine is it, delayed by the servo's lag and nothing else (a plan
            # off by one sample would be 1 ms off).
            assert plan.max() == pytest.approx(AMPLITUDE_M, rel=1e-4)
            lag, gain, rms = _lag_s(t, x, plan)
            assert lag == pytest.approx(servo_lag_s, abs=0.2e-3)
            assert gain == pytest.approx(1.0, abs=0.01)
            assert rms < 0.02e-3  # the LVDT's noise is 1 µm
            v_peak = 2 * np.pi * FREQUENCY_HZ * AMPLITUDE_M
            assert c["peak_velocity_m_s"] == pytest.approx(v_peak, rel=0.05)
            assert c["peak_compression_force_n"] > 0 > c["peak_rebound_force_n"]
    positions = [p for p in got.json("/live/position") if "commanded_m" in p]
    assert positions and all(len(p["commanded_m"]) == len(p["t_s"]) for p in positions)


def test_the_recording_is_the_same_without_live(runs):
    live, plain = open_recording(runs["live"]), open_recording(runs["plain"])
    assert _mcap_channels(runs["live"]) == _mcap_channels(runs["plain"])
    assert set(live.metadata) == set(plain.metadata)
    assert live.identity == plain.identity
    keep = ("clicks", "gas_clicks", "frequency_hz", "amplitude_m", "warmup_cycles",
            "measured_cycles", "status")  # fmt: skip
    assert [[getattr(m, k) for k in keep] for m in live.tests] == [
        [getattr(m, k) for k in keep] for m in plain.tests
    ]
    # The measured cycles (the samples before and after them vary with the host's timing).
    measured = []
    for rec in (live, plain):
        test, meta = rec.load(0), rec.tests[0]
        inside = (test.t >= meta.measured_start_s) & (test.t < meta.measured_end_s)
        measured.append((int(inside.sum()), test.force[inside]))
    (n_live, f_live), (n_plain, f_plain) = measured
    expected = MEASURED * 1000 / FREQUENCY_HZ  # ±1: a window's ends fall between samples
    assert abs(n_live - expected) <= 1 and abs(n_plain - expected) <= 1
    assert f_live.max() == pytest.approx(f_plain.max(), rel=0.02)
    assert f_live.min() == pytest.approx(f_plain.min(), rel=0.02)
    assert {k for _, k, _ in live.events} == {k for _, k, _ in plain.events}


def test_replay_live_sends_what_the_sweep_sent(runs):
    """`replay --live` of the recording: the same samples, records and cycles."""
    proc = subprocess.Popen(
        [*CLI, "replay", str(runs["live"]), "--live", "--live-port", "0", "--fast"],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
        text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )  # fmt: skip
    out = Output(proc)
    try:
        client = FoxgloveClient(out.url())  # the replay waits for it
        said = out.finish(60)
        replayed = client.join(timeout_s=10)
    finally:
        _reap(proc)
    assert proc.returncode == 0, said
    assert "waiting for a viewer" in said
    swept: Received = runs["got"]
    live_test = [b for t, b in _live_blocks(swept) if t == 0]
    again = [b for t, b in _live_blocks(replayed) if t == 0]
    np.testing.assert_array_equal(SampleBlock.concat(again).seq, SampleBlock.concat(live_test).seq)
    assert replayed.json("/live/cycle") == swept.json("/live/cycle")
    assert [r["phase"] for r in replayed.json(s.TOPIC_TEST)] == ["begin", "end"]
    kinds = [e["kind"] for e in replayed.json(s.TOPIC_EVENTS)]
    assert kinds == [e["kind"] for e in swept.json(s.TOPIC_EVENTS)]


def test_the_live_layout_plots_what_the_server_advertises(runs, monkeypatch):
    """recordings/foxglove-live-layout.json: every path names a topic the live server
    advertised and a field of its schema (the recording layout's own check)."""
    monkeypatch.syspath_prepend(str(REPO / "tests" / "record"))
    check = importlib.import_module("test_record_foxglove_layout")
    fields = {}
    for ch in runs["got"].channels.values():
        if ch["schemaEncoding"] == "ros2msg":
            fields[ch["topic"]] = check.ros2msg_fields(ch["schema"])
        else:
            props = json.loads(ch["schema"])["properties"]
            fields[ch["topic"]] = {k: v.get("type") == "array" for k, v in props.items()}
    layout = json.loads((REPO / "recordings" / "foxglove-live-layout.json").read_text())
    plotted = check.check_layout(layout, fields)
    assert {"force_n", "displacement_m", "velocity_m_s", "commanded_m"} <= plotted
    latest = [c for c in layout["configById"].values() if c.get("timeRange") == "latest"]
    assert {c["xAxisPath"]["value"] for c in latest} == {
        "/live/cycle.displacement_m[:]",
        "/live/cycle.velocity_m_s[:]",
    }
