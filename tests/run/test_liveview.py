"""The live view: running numbers, end-of-test summaries, plain output off a terminal."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from report_helpers import AMPLITUDE_M, make_test, temperature_at
from shockdyno.record import RecordingWriter, open_recording
from shockdyno.record.types import TestData as Recorded  # aliased: pytest collects Test*
from shockdyno.report import build_report
from shockdyno.run.liveview import LiveView, TestSummary, summarise
from shockdyno.samples import SampleBlock

LINE = re.compile(
    r"test (\d+)/(\d+) clicks=(\d+) gas=(\d+) f=([\d.]+)Hz A=([\d.]+)mm"
    r" Fc=([+-]\d+)N Fr=([+-]\d+)N vc=([+-][\d.]+)m/s vr=([+-][\d.]+)m/s"
    r" T=([\d.]+)C dropped=(\d+) (complete|aborted)"
)


def shown(s: TestSummary) -> tuple[str, dict[str, object]]:
    """A summary's line and every number summarise measured; not the test's metadata, which
    a recording reads back more complete than the sweep had it when the test ended."""
    return s.line(), {f.name: getattr(s, f.name) for f in fields(s) if f.name != "meta"}


def blocks_of(test: Recorded, sizes: list[int], seq0: int = 1000) -> list[SampleBlock]:
    """The test cut into blocks of varying sizes, as a DAQ read loop would deliver it."""
    out, i, k = [], 0, 0
    assert test.temperature is not None
    while i < test.t.size:
        n = sizes[k % len(sizes)]
        sl = slice(i, i + n)
        m = test.t[sl].size
        out.append(
            SampleBlock(
                seq=seq0 + np.arange(i, i + m, dtype=np.int64),
                t_s=test.t[sl],
                displacement_m=test.x[sl],
                force_n=test.force[sl],
                temperature_c=test.temperature[sl],
                status=np.zeros(m, np.uint16),
            )
        )
        i, k = i + m, k + 1
    return out


def run(view: LiveView, tests: list[Recorded], sizes: list[int]) -> None:
    with view:
        for test in tests:
            view.start_test(replace(test.meta, measured_start_s=None, measured_end_s=None))
            for block in blocks_of(test, sizes):
                view.update(block)
            view.end_test(test.meta)


def test_summary_peaks_match_independent_values() -> None:
    tests = [make_test(i, c, f) for i, (c, f) in enumerate([(0, 1.5), (12, 1.0)])]
    view = LiveView(len(tests), enabled=False)
    run(view, tests, sizes=[1, 37, 250, 16])
    assert len(view.summaries) == 2
    for s, test in zip(view.summaries, tests, strict=True):
        meta = test.meta
        assert meta.measured_start_s is not None and meta.measured_end_s is not None
        window = (test.t >= meta.measured_start_s) & (test.t <= meta.measured_end_s)
        assert s.peak_compression_force_n == test.force[window].max()
        assert s.peak_rebound_force_n == test.force[window].min()
        v_peak = AMPLITUDE_M * 2 * np.pi * meta.frequency_hz
        assert s.peak_compression_velocity_m_s == pytest.approx(v_peak, rel=1e-3)
        assert s.peak_rebound_velocity_m_s == pytest.approx(-v_peak, rel=1e-3)
        t_mid = test.t[window].mean()
        assert s.temperature_c == pytest.approx(float(temperature_at(t_mid)), abs=1e-9)
        assert s.dropped_frames == 0
        assert s.meta is meta and meta.status == "complete"
        # The end-of-test line and the report's table come from the same numbers:
        assert s == summarise(test)


def test_running_numbers_while_the_test_runs() -> None:
    test = make_test(0, 4, 1.5)
    view = LiveView(1, enabled=False)
    view.start_test(test.meta)
    for block in blocks_of(test, [73, 5, 400]):
        view.update(block)
    live = view.stats
    # Forces over everything so far, the start-up knock included:
    assert live.peak_compression_force_n == test.force.max()
    assert live.peak_rebound_force_n == test.force.min()
    assert live.n_samples == test.t.size
    assert live.temperature_c == test.temperature[-1]  # type: ignore[index]
    # 20 ms centred difference on a 1.5 Hz sine: low by 1 - sin(wτ)/(wτ) = 0.15 %.
    w = 2 * np.pi * 1.5
    expected = AMPLITUDE_M * w * np.sin(w * 0.01) / (w * 0.01)
    assert live.peak_compression_velocity_m_s == pytest.approx(expected, rel=2e-4)
    assert live.peak_rebound_velocity_m_s == pytest.approx(-expected, rel=2e-4)


def test_running_velocity_does_not_depend_on_block_size() -> None:
    test = make_test(0, 9, 1.0)
    peaks = []
    for sizes in ([1], [7, 300], [test.t.size]):
        view = LiveView(1, enabled=False)
        view.start_test(test.meta)
        for block in blocks_of(test, sizes):
            view.update(block)
        peaks.append(
            (view.stats.peak_compression_velocity_m_s, view.stats.peak_rebound_velocity_m_s)
        )
    assert peaks[0] == peaks[1] == peaks[2]


def test_dropped_frames_from_sequence_gaps_and_from_the_daq_counter() -> None:
    test = make_test(0, 2, 1.5)
    blocks = blocks_of(test, [100])
    # Lose 3 frames inside block 4 and the whole of block 6 (100 frames):
    b = blocks[4]
    keep = np.ones(len(b), bool)
    keep[10:13] = False
    blocks[4] = SampleBlock(*(np.asarray(getattr(b, f))[keep] for f in b.__dataclass_fields__))
    del blocks[6]
    view = LiveView(2, enabled=False)
    view.start_test(test.meta)
    for block in blocks:
        view.update(block, dropped_frames=40)  # a counter that did not move
    assert view.stats.dropped_frames == 103
    assert view.end_test(test.meta).dropped_frames == 103
    # The DAQ counter can know more (frames lost after the last one received):
    view.start_test(test.meta)
    for k, block in enumerate(blocks_of(test, [500])):
        view.update(block, dropped_frames=40 + 2 * k)
    assert view.end_test(test.meta).dropped_frames == 2 * (len(blocks_of(test, [500])) - 1)


def test_plain_output_off_a_terminal_has_no_control_codes() -> None:
    tests = [make_test(0, 0, 1.5), make_test(1, 21, 1.5, status="aborted")]
    buf = io.StringIO()
    console = Console(file=buf)
    assert not console.is_terminal
    view = LiveView(2, console=console)
    run(view, tests, sizes=[50])
    out = buf.getvalue()
    assert "\x1b" not in out and "\r" not in out
    assert out.isascii()
    lines = out.splitlines()
    assert len(lines) == 2
    for k, (line, s) in enumerate(zip(lines, view.summaries, strict=True)):
        m = LINE.fullmatch(line)
        assert m, line
        assert (int(m[1]), int(m[2]), int(m[3])) == (k + 1, 2, s.meta.clicks)
        assert int(m[7]) == round(s.peak_compression_force_n)
        assert int(m[8]) == round(s.peak_rebound_force_n)
        assert float(m[9]) == pytest.approx(s.peak_compression_velocity_m_s, abs=5e-4)
        assert m[13] == s.meta.status
    assert lines[1].endswith(" aborted")


def test_terminal_shows_progress_and_the_live_line() -> None:
    test = make_test(0, 6, 1.5)
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=160, color_system="standard")
    with LiveView(3, console=console) as view:
        view.start_test(test.meta)
        for block in blocks_of(test, [200]):
            view.update(block)
        assert view._live is not None
        view._live.refresh()  # what the refresh thread draws a few times a second
        running = buf.getvalue()
        view.end_test(test.meta)
    out = buf.getvalue()
    assert "\x1b[" in out  # a terminal gets colour and cursor control
    assert "0/3" in running and "clicks 6 gas 0" in running and "dropped 0" in running
    assert "1/3" in out
    plain = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", out)
    assert summarise(test).line(1, 3) in plain


def test_disabled_view_prints_nothing_and_misuse_is_an_error() -> None:
    buf = io.StringIO()
    view = LiveView(1, console=Console(file=buf, force_terminal=True), enabled=False)
    test = make_test(0, 1, 1.5)
    with pytest.raises(RuntimeError):
        view.update(blocks_of(test, [100])[0])
    run(view, [test], sizes=[300])
    assert buf.getvalue() == ""
    assert view.summaries[0].meta.clicks == 1


def test_end_of_test_line_agrees_with_the_report_of_the_recording(tmp_path: Path) -> None:
    """Live view and MCAP writer fed as the sweep runner feeds them; the report of the
    recording read back shows the numbers the engineer saw when each test ended."""
    # As a sweep records them: the gas force it measured at mid-stroke with each test, which
    # the line and the report both remove from the peak forces.
    tests = [make_test(0, 3, 1.5), make_test(1, 15, 1.0, t0=5.0)]
    tests = [replace(t, meta=replace(t.meta, gas_force_n=230.7, gas_force_source="measured"))
             for t in tests]  # fmt: skip
    gappy = blocks_of(tests[1], [64], seq0=5000)
    del gappy[10]  # 64 frames lost on the way from the DAQ
    buf = io.StringIO()
    path = tmp_path / "sweep.mcap"
    with (
        RecordingWriter(path, metadata={"damper_id": "t1"}) as writer,
        LiveView(2, console=Console(file=buf)) as view,
    ):
        for test, blocks in zip(tests, [blocks_of(tests[0], [100]), gappy], strict=True):
            start = replace(test.meta, measured_start_s=None, measured_end_s=None)
            writer.begin_test(start)
            view.start_test(start)
            for block in blocks:
                writer.write_samples(block)
                view.update(block)
            writer.end_test(test.meta)
            view.end_test(test.meta)
    rec = open_recording(path)
    recorded = [summarise(t, gas_force_n=t.meta.gas_force_n) for t in rec.load_all()]
    assert [shown(s) for s in recorded] == [shown(s) for s in view.summaries]
    assert view.summaries[1].dropped_frames == 64
    assert all(s.gas_removed_n == 230.7 for s in view.summaries)
    assert "gas_removed=231N" in buf.getvalue()
    index = build_report(rec.load_all(), tmp_path / "report", title="t1")
    html = index.read_text(encoding="utf-8")
    for s in view.summaries:
        assert f'<td class="num">{s.peak_compression_force_n:.1f}</td>' in html
        assert f'<td class="num">{s.peak_rebound_velocity_m_s:.4f}</td>' in html
    assert len(buf.getvalue().splitlines()) == 2


def test_paused_display_lets_an_operator_prompt_through() -> None:
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=120)
    with LiveView(2, console=console) as view:
        assert view._live is not None and view._live.is_started
        with view.paused():
            assert view._live is None
            mark = len(buf.getvalue())
            console.print("set clicks to 6, then press Enter", highlight=False)
            # Nothing redraws under the prompt while it waits:
            assert buf.getvalue()[mark:] == "set clicks to 6, then press Enter\n"
        assert view._live is not None and view._live.is_started
    assert view._live is None


def test_default_console_into_a_pipe_prints_plain_lines() -> None:
    """The real CI case: stdout is a pipe and nobody built a Console for the view."""
    script = (
        "import numpy as np\n"
        "from shockdyno.record.types import TestMeta\n"
        "from shockdyno.rig.types import SampleBlock\n"
        "from shockdyno.run.liveview import LiveView\n"
        "t = np.arange(2000) / 1000.0\n"
        "x = 0.03 * np.sin(2 * np.pi * t)\n"
        "meta = TestMeta(0, 5, 0, 1.0, 0.03, 1000.0)\n"
        "with LiveView(1) as view:\n"
        "    view.start_test(meta)\n"
        "    for i in range(0, 2000, 100):\n"
        "        s = slice(i, i + 100)\n"
        "        view.update(SampleBlock(np.arange(i, i + 100), t[s], x[s], 1e4 * x[s],\n"
        "                                np.full(100, 25.0), np.zeros(100, np.uint16)))\n"
        "    view.end_test(meta)\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("FORCE_COLOR", "TTY_COMPATIBLE")}
    proc = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=60
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert "\x1b" not in proc.stdout and "\r" not in proc.stdout
    # F = 1e4 x: peaks ±300 N; v peak = 0.03 * 2π = 0.188 m/s.
    assert proc.stdout == (
        "test 1/1 clicks=5 gas=0 f=1.00Hz A=30.0mm Fc=+300N Fr=-300N vc=+0.188m/s"
        " vr=-0.188m/s T=25.0C dropped=0 complete\n"
    )


def test_glitched_samples_do_not_stop_the_sweep() -> None:
    """A repeated time stamp and a NaN force: no warning (pytest makes it an error), no
    exception; the velocity is left undefined rather than wrong."""
    test = make_test(0, 8, 1.5)
    t = test.t.copy()
    t[900] = t[899]  # inside the measured window
    force = test.force.copy()
    force[700] = np.nan
    glitched = replace(test, t=t, force=force)
    view = LiveView(1, enabled=False)
    view.start_test(test.meta)
    for block in blocks_of(glitched, [100]):
        view.update(block)
    assert view.stats.peak_compression_force_n == np.nanmax(force)
    assert view.stats.peak_compression_velocity_m_s == pytest.approx(
        AMPLITUDE_M * 3 * np.pi, rel=2e-3
    )
    s = view.end_test(test.meta)
    assert np.isnan(s.peak_compression_velocity_m_s)
    assert "vc=nanm/s" in s.line()


def test_imperial_end_of_test_line_is_the_si_line_converted() -> None:
    """sweep/replay --units imperial: the Fc=... Fr=... line in in, lbf, in/s and F, each
    number the SI one converted (issue 20), through the live view as a sweep prints it."""
    from shockdyno.units import IMPERIAL, M_PER_IN, N_PER_LBF

    test = make_test(0, 6, 1.5)
    s = summarise(test)
    buf = io.StringIO()
    with LiveView(1, console=Console(file=buf, force_terminal=False), units=IMPERIAL) as view:
        view.start_test(test.meta)
        for block in blocks_of(test, [200]):
            view.update(block)
        view.end_test(test.meta)
    line = buf.getvalue().strip().splitlines()[-1]
    assert line == s.line(1, 1, IMPERIAL)
    got = dict(re.findall(r"(\w+)=([-+]?[0-9.]+)", line))
    assert f" A={s.meta.amplitude_m / M_PER_IN:.2f}in " in line  # 30 mm: 1.18 in
    assert float(got["Fc"]) == pytest.approx(s.peak_compression_force_n / N_PER_LBF, abs=0.5)
    assert float(got["Fr"]) == pytest.approx(s.peak_rebound_force_n / N_PER_LBF, abs=0.5)
    assert float(got["vc"]) == pytest.approx(s.peak_compression_velocity_m_s / M_PER_IN, abs=5e-3)
    assert s.temperature_c is not None
    assert float(got["T"]) == pytest.approx(s.temperature_c * 1.8 + 32, abs=0.05)
    assert "lbf" in line and "in/s" in line and "F " in line and "N " not in line


def test_live_line_removes_the_measured_gas_force_like_the_end_line() -> None:
    test = make_test(0, 6, 1.5)
    meta = replace(test.meta, gas_force_n=230.7, gas_force_source="measured")
    lines = []
    for m in (test.meta, meta):
        buf = io.StringIO()
        console = Console(file=buf, force_terminal=True, width=200, color_system=None)
        with LiveView(1, console=console) as view:
            view.start_test(m)
            for block in blocks_of(test, [200]):
                view.update(block)
            assert view._live is not None
            view._live.refresh()
            lines.append(buf.getvalue())
            view.end_test(m)
    raw = re.findall(r"F ([+-]\d+) / ([+-]\d+) N", lines[0])[-1]
    damping = re.findall(r"F ([+-]\d+) / ([+-]\d+) N \(gas removed\)", lines[1])[-1]
    for r, d in zip(raw, damping, strict=True):
        assert abs(int(r) - 231 - int(d)) <= 1  # rounding of each
