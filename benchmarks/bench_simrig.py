"""The simulated rig's sustained speed factor with zero dropped frames.

A RigSession runs a 30 mm, 1.5 Hz sine (120 s of rig time) over the real transports
(Modbus TCP + socket:// DAQ) at increasing --speed; the figure is the highest speed
sustained (>= 90 % of asked) with zero dropped or corrupt frames. Baseline in the same
run: the same sine at real time (speed 1, 6 s of rig time). The aim is >= 50x.

    .venv/bin/python benchmarks/bench_simrig.py
"""

from __future__ import annotations

import time

from shockdyno.run.session import RigSession
from shockdyno.samples import SampleBlock
from shockdyno.simrig import start_sim_rig


def run(speed: float, rig_seconds: float) -> tuple[float, int, int]:
    cycles = max(3, round(rig_seconds * 1.5))
    count = [0]

    def sink(b: SampleBlock) -> None:
        count[0] += len(b)

    with start_sim_rig(speed=speed) as sim, RigSession(sim.rig_config()) as session:
        t = time.perf_counter()
        out = session.run_sine(0.03, 1.5, 1, cycles - 3, sink)
        wall = time.perf_counter() - t
    assert out.status == "complete", out.reason
    assert out.start_s is not None
    return (out.end_s - out.start_s) / wall, out.dropped_frames, out.corrupt_frames


def main() -> None:
    base, d0, c0 = run(1.0, 6.0)
    print(f"baseline speed 1: achieved {base:.2f}x real time, dropped {d0}, corrupt {c0}")
    best = 0.0
    for speed in (50.0, 100.0, 200.0, 400.0, 800.0, 1600.0):
        achieved, dropped, corrupt = run(speed, 120.0)
        ok = dropped == 0 and corrupt == 0 and achieved >= 0.9 * speed
        print(
            f"speed {speed:4.0f}: achieved {achieved:6.1f}x, dropped {dropped}, "
            f"corrupt {corrupt} {'ok' if ok else 'NOT sustained'}"
        )
        if not ok:
            break
        best = achieved
    print(
        f"sustained speed factor with zero dropped frames: {best:.0f}x real time "
        f"({best / base:.0f}x the real-time baseline; {best / 50:.1f}x the 50x aim)"
    )


if __name__ == "__main__":
    main()
