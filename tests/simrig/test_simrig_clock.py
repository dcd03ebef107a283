"""The sim-rig is paced by the clock it is given, not by the host's."""

from __future__ import annotations

import time

import serial

from shockdyno.rig.frames import FrameDecoder


def test_frames_follow_the_injected_clock(sim_rig_factory) -> None:
    now = [100.0]
    sim = sim_rig_factory(speed=1.0, clock=lambda: now[0])
    port = serial.serial_for_url(sim.rig_config().daq.url, timeout=0.1)
    try:
        dec = FrameDecoder()
        time.sleep(0.2)  # host time passes, the injected clock does not
        assert len(dec.feed(port.read(100_000))) == 0
        now[0] += 0.25  # 250 ms of rig time
        got = 0
        deadline = time.monotonic() + 5
        while got < 250 and time.monotonic() < deadline:
            got += len(dec.feed(port.read(100_000)))
        assert got == 250  # exactly the 250 samples of 250 ms at 1 kHz
        assert sim.engine.produced == 250
    finally:
        port.close()
