"""Serial DAQ driver: pyserial `serial_for_url` + the frame codec + calibration.

The same driver reads `/dev/ttyUSB0`, a pty from the simulated rig, or
`socket://127.0.0.1:5021`. Reads are bulk (everything waiting), and time comes from the
DAQ's sequence counter, never from the host clock.
"""

from __future__ import annotations

import contextlib

import numpy as np
import serial

from shockdyno.errors import RigFault
from shockdyno.rig.config import Calibration, DaqConfig
from shockdyno.rig.frames import FrameDecoder, Plausible, RawFrames
from shockdyno.samples import SampleBlock

READ_WAIT_S = 0.005  # a read returns what arrived within this time
READ_SIZE = 1 << 16


def calibrate(
    raw: RawFrames, cal: Calibration, sample_rate_hz: float, stroke_centre_m: float
) -> SampleBlock:
    """Counts to SI; displacement relative to the stroke centre."""
    return SampleBlock(
        seq=raw.seq,
        t_s=raw.seq / sample_rate_hz,
        displacement_m=np.asarray(
            raw.lvdt * cal.position_m_per_count + (cal.position_offset_m - stroke_centre_m),
            np.float64,
        ),
        force_n=np.asarray(raw.load * cal.force_n_per_count + cal.force_offset_n, np.float64),
        temperature_c=np.asarray(
            raw.temp * cal.temperature_c_per_count + cal.temperature_offset_c, np.float64
        ),
        status=raw.status,
    )


def _counts(lo_hi: tuple[float, float], gain: float, offset: float, bits: int) -> tuple[int, int]:
    """A range in SI as inclusive raw counts (clipped to the field's width)."""
    a, b = sorted(((lo_hi[0] - offset) / gain, (lo_hi[1] - offset) / gain))
    top = 2 ** (bits - 1)
    lo = -top if not np.isfinite(a) else max(-top, int(np.floor(a + 1e-6)))  # float noise
    hi = top - 1 if not np.isfinite(b) else min(top - 1, int(np.ceil(b - 1e-6)))
    return lo, hi


def plausible_counts(config: DaqConfig) -> Plausible:
    """The sensors' ranges from the rig file, in the counts the frames carry."""
    cal = config.calibration
    return Plausible(
        load=_counts(config.force_range_n, cal.force_n_per_count, cal.force_offset_n, 32),
        lvdt=_counts(config.position_range_m, cal.position_m_per_count, cal.position_offset_m, 32),
        temp=_counts(
            config.temperature_range_c, cal.temperature_c_per_count, cal.temperature_offset_c, 16
        ),
    )


class SerialDaq:
    """Implements the `Daq` protocol over any pyserial URL."""

    def __init__(self, config: DaqConfig, stroke_centre_m: float) -> None:
        self.config = config
        self.sample_rate_hz = config.sample_rate_hz
        self._centre = stroke_centre_m
        self._decoder = FrameDecoder(plausible_counts(config))
        try:
            self._port = serial.serial_for_url(
                config.url, baudrate=config.baudrate, timeout=READ_WAIT_S
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            raise RigFault(f"DAQ {config.url}: cannot open ({exc})") from None
        self._closed = False

    @property
    def dropped_frames(self) -> int:
        """Frames the sequence numbers show were never received (since open)."""
        return self._decoder.dropped_frames

    @property
    def corrupt_frames(self) -> int:
        """Frames refused by their CRC (since open)."""
        return self._decoder.corrupt_frames

    @property
    def rejected_frames(self) -> int:
        """Frames that passed the CRC but not a plausibility check (since open)."""
        return self._decoder.rejected_frames

    @property
    def garbage_bytes(self) -> int:
        """Bytes skipped outside any good frame (since open)."""
        return self._decoder.garbage_bytes

    @property
    def frames(self) -> int:
        """Good frames decoded (since open)."""
        return self._decoder.frames

    def read_bytes(self) -> bytes:
        """The bytes the port has now, or within its short timeout; RigFault when closed or the
        link is lost."""
        if self._closed:
            raise RigFault(f"DAQ {self.config.url}: closed")
        try:
            # One bulk read: whatever arrives within the port's short timeout.
            data: bytes = self._port.read(READ_SIZE)
        except (serial.SerialException, OSError) as exc:
            raise RigFault(f"DAQ {self.config.url}: link lost ({exc})") from None
        return data

    def read(self) -> SampleBlock:
        """Every complete, valid sample waiting now (waits at most ~5 ms for the first)."""
        raw = self._decoder.feed(self.read_bytes())
        if not len(raw):
            return SampleBlock.empty()
        return calibrate(raw, self.config.calibration, self.sample_rate_hz, self._centre)

    def close(self) -> None:
        """Close the port (once; errors on close ignored)."""
        if not self._closed:
            self._closed = True
            with contextlib.suppress(serial.SerialException, OSError):
                self._port.close()

    def __enter__(self) -> SerialDaq:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
