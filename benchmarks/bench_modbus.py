"""Modbus round trip on loopback: the driver's status read and a register write against the
simulated drive (pymodbus server), vs a raw TCP echo round trip in the same run.

    .venv/bin/python benchmarks/bench_modbus.py
"""

from __future__ import annotations

import socket
import statistics
import threading
import time

from shockdyno.rig.actuator import ModbusActuator
from shockdyno.simrig import start_sim_rig

N = 2000


def percentiles(xs: list[float]) -> tuple[float, float]:
    xs = sorted(xs)
    return statistics.median(xs) * 1e3, xs[int(0.99 * len(xs))] * 1e3


def echo_round_trip() -> list[float]:
    srv = socket.create_server(("127.0.0.1", 0))
    port = srv.getsockname()[1]

    def serve() -> None:
        conn, _ = srv.accept()
        with conn:
            while data := conn.recv(256):
                conn.sendall(data)

    th = threading.Thread(target=serve)
    th.start()
    out = []
    with socket.create_connection(("127.0.0.1", port)) as c:
        c.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        msg = bytes(12)  # the size of a Modbus TCP read request
        for _ in range(N):
            t = time.perf_counter()
            c.sendall(msg)
            c.recv(256)
            out.append(time.perf_counter() - t)
    th.join()
    srv.close()
    return out


def main() -> None:
    base = echo_round_trip()
    with start_sim_rig(speed=1.0) as sim:
        act = ModbusActuator(sim.rig_config())
        act.connect()
        reads, writes = [], []
        for i in range(N):
            t = time.perf_counter()
            act.status()
            reads.append(time.perf_counter() - t)
            t = time.perf_counter()
            act.write({"heartbeat": i & 0xFFFF})
            writes.append(time.perf_counter() - t)
        act.close()
    b50, b99 = percentiles(base)
    r50, r99 = percentiles(reads)
    w50, w99 = percentiles(writes)
    print(f"raw TCP echo (baseline): median {b50:.3f} ms, p99 {b99:.3f} ms")
    print(f"status read (FC3, 29 regs): median {r50:.3f} ms, p99 {r99:.3f} ms -> {r50 / b50:.1f}x")
    print(f"register write (FC16):     median {w50:.3f} ms, p99 {w99:.3f} ms -> {w50 / b50:.1f}x")
    print(f"status polls per 20 ms poll period at the median: {20 / r50:.0f}")


if __name__ == "__main__":
    main()
