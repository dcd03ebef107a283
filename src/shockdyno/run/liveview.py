"""What the engineer watches during `shockdyno sweep` and `shockdyno replay`.

On a terminal: a rich progress bar for the sweep (tests done / total, elapsed, ETA), a live
line for the running test, and one line per finished test printed above them. Anywhere
else (CI, pipes, files): only the one-line-per-test summaries, plain ASCII, no control codes.

The live line is a running estimate over every sample of the test so far (ramp and warm-up
included, since the measured window is only known when the test ends). Its velocity is the
slope of displacement across a 20 ms span centred on each sample, (x[i+h] - x[i-h]) /
(t[i+h] - t[i-h]): on a sine it reads low by 1 - sin(ωτ)/(ωτ), 0.15 % at 1.5 Hz with
τ = 10 ms, and 5 µm of LVDT noise becomes ~0.35 mm/s. It is computed per block with the
previous block's last 2h samples carried over, so it costs O(block) and never
re-reads the test.

The line printed when a test ends comes from :func:`summarise` on the samples the view
received, with the final metadata (measured window), so it agrees with the report's table.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from types import TracebackType

import numpy as np
from numpy.typing import NDArray
from rich.console import Console, Group, RenderableType
from rich.live import Live
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.text import Text

from shockdyno.record.types import TestData, TestMeta
from shockdyno.report.summary import TestSummary, summarise
from shockdyno.run.verify import RunKeeper
from shockdyno.samples import SampleBlock
from shockdyno.units import SI, Units

__all__ = ["LiveStats", "LiveView", "TestSummary", "summarise"]

VELOCITY_SPAN_S = 0.020


@dataclass
class LiveStats:
    """Running numbers of the test in progress (see the module docstring)."""

    n_samples: int = 0
    t_first_s: float = math.nan
    t_last_s: float = math.nan
    peak_compression_force_n: float = -math.inf
    peak_rebound_force_n: float = math.inf
    peak_compression_velocity_m_s: float = -math.inf
    peak_rebound_velocity_m_s: float = math.inf
    temperature_c: float = math.nan
    dropped_frames: int = 0


class _RunningVelocity:
    """Centred-difference velocity over a fixed span, carried across block boundaries."""

    def __init__(self, sample_rate_hz: float) -> None:
        rate = sample_rate_hz if sample_rate_hz > 0 else 1000.0
        self.h = max(1, round(VELOCITY_SPAN_S * rate / 2))
        self._t = np.zeros(0)
        self._x = np.zeros(0)

    def feed(self, t: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Velocities of every new centre sample that now has both neighbours."""
        tt = np.concatenate([self._t, t])
        xx = np.concatenate([self._x, x])
        span = 2 * self.h
        self._t, self._x = tt[-span:], xx[-span:]
        if tt.size <= span:
            return np.zeros(0)
        dt = tt[span:] - tt[:-span]
        ok = dt > 0  # a repeated time stamp must not stop the sweep with a warning
        return np.asarray((xx[span:][ok] - xx[:-span][ok]) / dt[ok], dtype=float)


class _LiveLine:
    """Renders the running test's line; rich calls it at its refresh rate, not per block."""

    def __init__(self, view: LiveView) -> None:
        self.view = view

    def __rich__(self) -> RenderableType:
        meta, s = self.view.current, self.view.stats
        if meta is None:
            done = self.view.done >= self.view.total_tests
            return Text("all tests done" if done else "waiting for the next test", style="dim")
        # Which test is running is on the progress bar; this line holds only the numbers,
        # so it fits an 80-column terminal.
        line = Text(no_wrap=True, overflow="ellipsis")
        if s.n_samples:
            line.append(f"t {s.t_last_s - s.t_first_s:5.1f} s  ")
            # Damping force when the sweep measured the gas force, as the end-of-test line.
            gas = meta.gas_force_n or 0.0
            line.append(
                f"F {s.peak_compression_force_n - gas:+.0f} / "
                f"{s.peak_rebound_force_n - gas:+.0f} N{' (gas removed)' if gas else ''}  ",
                style="cyan",
            )
            if math.isfinite(s.peak_compression_velocity_m_s):
                line.append(
                    f"v {s.peak_compression_velocity_m_s:+.3f} / "
                    f"{s.peak_rebound_velocity_m_s:+.3f} m/s  ",
                    style="magenta",
                )
            if math.isfinite(s.temperature_c):
                line.append(f"T {s.temperature_c:.1f} °C  ")
        else:
            line.append("no samples yet  ", style="dim")
        line.append(f"dropped {s.dropped_frames}", style="red" if s.dropped_frames else "green")
        return line


class LiveView:
    """Progress of a sweep and the running test; a context manager.

    ``enabled=False`` prints nothing (summaries are still computed and returned).
    ``dropped_frames`` given to :meth:`update` is the DAQ's cumulative counter
    (``Daq.dropped_frames``); the test's count is its increase since the test's first
    block, or the gaps in the blocks' sequence numbers, whichever is larger (the counter
    also sees frames lost after the last sample received; the sequence gaps work when the
    caller has no counter, e.g. a replay).
    """

    def __init__(
        self,
        total_tests: int,
        *,
        console: Console | None = None,
        enabled: bool = True,
        title: str = "sweep",
        units: Units = SI,
    ) -> None:
        self.total_tests = total_tests
        self.units = units  # of the end-of-test lines
        self.title = title
        self.console = console if console is not None else Console()
        self.enabled = enabled
        self.interactive = enabled and self.console.is_terminal
        self.done = 0
        self.summaries: list[TestSummary] = []
        self.current: TestMeta | None = None
        self.stats = LiveStats()
        # The running test's samples, bounded (run/verify.py): its end-of-test line is
        # summarised from them; a longer test's from its last MAX_KEPT_SAMPLES.
        self._kept = RunKeeper()
        self._velocity = _RunningVelocity(1000.0)
        self._last_seq: int | None = None
        self._seq_gaps = 0
        self._counter0: int | None = None
        self._counter_delta = 0
        # A long estimate period: tests last seconds to minutes, so the ETA should average
        # over the sweep, not over the last 30 s (rich's default).
        self._progress = Progress(
            TextColumn("{task.description}", style="bold", markup=False),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("tests  elapsed"),
            TimeElapsedColumn(),
            TextColumn("eta"),
            TimeRemainingColumn(),
            console=self.console,
            speed_estimate_period=24 * 3600.0,
        )
        self._task = self._progress.add_task(title, total=total_tests)
        self._live: Live | None = None

    # -- lifecycle -----------------------------------------------------------------------
    def start(self) -> None:
        """Show the live display (on a terminal only; no-op when shown already)."""
        if self.interactive and self._live is None:
            self._live = Live(
                Group(self._progress, _LiveLine(self)),
                console=self.console,
                refresh_per_second=4,
            )
            self._live.start()

    def stop(self) -> None:
        """Take the live display down (no-op when not shown)."""
        if self._live is not None:
            self._live.stop()
            self._live = None

    @contextmanager
    def paused(self) -> Iterator[None]:
        """Hold the live display, e.g. while an operator prompt waits for Enter: a display
        redrawn under the cursor would garble what the operator types."""
        live = self._live
        self.stop()
        try:
            yield
        finally:
            if live is not None:
                self.start()

    def __enter__(self) -> LiveView:
        self.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()

    # -- per test --------------------------------------------------------------------------
    def start_test(self, meta: TestMeta) -> None:
        """Begin a test's line: its clicks and frequency, fresh statistics."""
        self.start()
        self.current = meta
        self._progress.update(
            self._task,
            description=f"clicks {meta.clicks} gas {meta.gas_clicks} {meta.frequency_hz:g} Hz",
        )
        self.stats = LiveStats()
        self._kept = RunKeeper()
        self._velocity = _RunningVelocity(meta.sample_rate_hz)
        self._last_seq = None
        self._seq_gaps = 0
        self._counter0 = None
        self._counter_delta = 0

    def update(self, block: SampleBlock, dropped_frames: int = 0) -> None:
        """Take one block of the running test. Cheap: O(len(block)) NumPy, no drawing."""
        if self.current is None:
            raise RuntimeError("LiveView.update() before start_test()")
        if self._counter0 is None:
            self._counter0 = dropped_frames
        self._counter_delta = max(0, dropped_frames - self._counter0)
        if len(block):
            self._take(block)
        self.stats.dropped_frames = max(self._seq_gaps, self._counter_delta)

    def _take(self, block: SampleBlock) -> None:
        self._kept.add(block)
        s = self.stats
        self._seq_gaps += block.frames_missing(self._last_seq)
        self._last_seq = int(block.seq[-1])
        if not s.n_samples:
            s.t_first_s = float(block.t_s[0])
        s.n_samples += len(block)
        s.t_last_s = float(block.t_s[-1])
        f = block.force_n[np.isfinite(block.force_n)]
        if f.size:
            s.peak_compression_force_n = max(s.peak_compression_force_n, float(f.max()))
            s.peak_rebound_force_n = min(s.peak_rebound_force_n, float(f.min()))
        v = self._velocity.feed(block.t_s, block.displacement_m)
        v = v[np.isfinite(v)]
        if v.size:
            s.peak_compression_velocity_m_s = max(s.peak_compression_velocity_m_s, float(v.max()))
            s.peak_rebound_velocity_m_s = min(s.peak_rebound_velocity_m_s, float(v.min()))
        s.temperature_c = float(block.temperature_c[-1])

    @staticmethod
    def warm_up() -> None:
        """Summarise a made-up test once, before the drive is enabled: the first summary
        imports scipy.signal (two seconds on a busy host), which between two tests of a
        running sweep is two seconds without a heartbeat, and the drive stops itself."""
        t = np.arange(400) / 100.0
        x = 0.01 * np.sin(2 * np.pi * t)
        meta = TestMeta(0, 0, 0, 1.0, 0.01, 100.0, measured_start_s=1.0, measured_end_s=3.0)
        summarise(TestData(meta, t, x, 100.0 * x, np.full(t.size, 20.0)))

    def end_test(self, meta: TestMeta) -> TestSummary:
        """Close the running test with its final metadata; prints and returns its summary.

        The summary is :func:`summarise` of the samples received, so a dropped-frame count
        stored in ``meta.dropped_frames`` counts too. A gas force the sweep measured
        (``meta.gas_force_n``) is removed from the peak forces, and the line says so.
        """
        if self.current is None:
            raise RuntimeError("LiveView.end_test() before start_test()")
        data = self._kept.tail
        test = TestData(meta, data.t_s, data.displacement_m, data.force_n, data.temperature_c)
        summary = summarise(
            test, dropped_frames=self.stats.dropped_frames, gas_force_n=meta.gas_force_n
        )
        self.done += 1
        self.summaries.append(summary)
        self.current = None
        trimmed = self._kept.trimmed
        self._kept = RunKeeper()
        self._progress.update(self._task, advance=1, description=self.title)
        self._emit(summary)
        if trimmed and self.enabled and data.t_s.size:
            self.console.print(
                f"  (test {meta.index}: peaks over its last {data.t_s[-1] - data.t_s[0]:.0f} s; "
                "the recording holds every sample)",
                soft_wrap=True,
            )
        return summary

    def _emit(self, summary: TestSummary) -> None:
        if not self.enabled:
            return
        line = summary.line(self.done, self.total_tests, self.units)
        if not self.interactive:
            # Straight to the stream: rich would wrap long lines at its idea of the width.
            self.console.file.write(line + "\n")
            self.console.file.flush()
            return
        text = Text(line)
        status = summary.meta.status
        text.stylize("green" if status == "complete" else "bold red", len(line) - len(status))
        self.console.print(text, soft_wrap=True)
