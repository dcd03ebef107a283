"""Fault campaign: what reaches the recording, and how fast the ram is safe, for every way a
session can be hurt. Prints figures; asserts nothing.

1. Byte errors: a stream of frames with each byte replaced at random with probability p,
   decoded with the rig's checks (CRC, sensor ranges, sequence jumps) and with the CRC alone.
2. Faults, signals, kill -9, a second Modbus master and the hostile inputs of issue 46,
   each against a real `shockdyno sweep` child process and a simulated rig in this process.
   The simulated drive logs every control word as it arrives: `stop` is the time from the
   cause (the signal sent, the fault injected, the intruder's write) to the first stop
   command on the wire. An independent Modbus client (the probe) times the cause to
   "at rest" (not running) and to "disabled"; then the recording is read back. The table
   is run idle, and again beside 2x cores of CPU-bound processes (--load).
3. Time to rest per rig (Modbus TCP, Modbus RTU) and per frequency, at real time (speed 1):
   SIGTERM in the measured cycles of a 20 mm sine; the stop on the wire, the ram at rest and
   disabled, against the drive's own ramp-out (max(its stop time, one cycle)).

    .venv/bin/python benchmarks/bench_faults.py [--quick] [--no-load] [--no-rest]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from shockdyno.errors import RecordingError, RigFault
from shockdyno.fit.result import FitResult
from shockdyno.model.spec import default_spec_path
from shockdyno.record import open_recording
from shockdyno.rig.actuator import ModbusActuator
from shockdyno.rig.config import load_rig
from shockdyno.rig.daq import plausible_counts
from shockdyno.rig.frames import FRAME_DTYPE, FRAME_LEN, FrameDecoder, Plausible, encode_frames
from shockdyno.simrig import start_sim_rig
from shockdyno.simrig.drive import DriveParams
from shockdyno.simrig.faults import Fault

REPO = Path(__file__).resolve().parents[1]
SIM = REPO / "rigs" / "sim.toml"
CLI = [sys.executable, "-m", "shockdyno.cli"]
SPEED = 4.0


# -- 1. byte errors ---------------------------------------------------------------------------


def byte_errors(rate: float, n: int, plausible: Plausible) -> dict[str, int]:
    """Frames whose load counts are their own index, so each delivered frame names its origin."""
    rng = np.random.default_rng(int(rate * 1e6))
    i = np.arange(n, dtype=np.int64)
    lvdt = (75_000 + 30_000 * np.sin(2 * np.pi * i / 1000)).astype(np.int32)
    truth = np.stack([i, lvdt, np.full(n, 2500), i % 2], axis=1)
    data = bytearray(encode_frames(i, i.astype(np.int32), lvdt, truth[:, 2], truth[:, 3]))
    hit = np.flatnonzero(rng.random(len(data)) < rate)
    arr = np.frombuffer(data, np.uint8).copy()
    arr[hit] = (arr[hit] + rng.integers(1, 256, hit.size)) & 0xFF  # always a different byte
    damaged = np.unique(hit // FRAME_LEN).size
    dec = FrameDecoder(plausible)
    raw = arr.tobytes()
    got = []
    step = 1000 * FRAME_LEN
    for lo in range(0, len(raw), step):
        got.append(dec.feed(raw[lo : lo + step]))
    seq = np.concatenate([g.seq for g in got])
    rows = np.stack(
        [
            np.concatenate([g.load for g in got]).astype(np.int64),
            np.concatenate([g.lvdt for g in got]),
            np.concatenate([g.temp for g in got]),
            np.concatenate([g.status for g in got]),
        ],
        axis=1,
    )
    origin = rows[:, 0]
    valid = (origin >= 0) & (origin < n)
    genuine = np.zeros(len(rows), bool)
    genuine[valid] = np.all(rows[valid] == truth[origin[valid]], axis=1)
    return {
        "frames": n,
        "damaged": damaged,
        "rejected": n - len(rows),
        "corrupt_accepted": int((~genuine).sum()),
        "timebase_errors": int((genuine & (seq != origin)).sum()),
        "checks_rejected": dec.rejected_frames,
    }


def forced_collisions(n: int, k: int, plausible: Plausible) -> tuple[int, int, int]:
    """k frames with 2 body bytes damaged and the CRC recomputed: what a CRC collision
    delivers. Returns (rejected by the checks, bad accepted, time-base errors)."""
    rng = np.random.default_rng(7)
    i = np.arange(n, dtype=np.int64)
    lvdt = (75_000 + 30_000 * np.sin(2 * np.pi * i / 1000)).astype(np.int32)
    temp = np.full(n, 2500)
    frames = np.frombuffer(encode_frames(i, i.astype(np.int32), lvdt, temp, i % 2), np.uint8)
    rows = frames.reshape(n, FRAME_LEN).copy()
    hit = rng.choice(np.arange(10, n - 10), k, replace=False)
    for f in hit:
        for b in rng.choice(np.arange(2, 16), 2, replace=False):
            rows[f, b] ^= rng.integers(1, 256)
    seq = rows[hit, 2].astype(np.int64) | (rows[hit, 3].astype(np.int64) << 8)
    fields = rows[hit].copy().reshape(-1).view(FRAME_DTYPE)
    rows[hit] = np.frombuffer(
        encode_frames(seq, fields["load"], fields["lvdt"], fields["temp"], fields["status"]),
        np.uint8,
    ).reshape(k, FRAME_LEN)
    dec = FrameDecoder(plausible)
    out = dec.feed(rows.tobytes())
    origin = out.load.astype(np.int64)
    valid = (origin >= 0) & (origin < n)
    truth = np.stack([lvdt, temp, i % 2], axis=1)
    got = np.stack([out.lvdt, out.temp, out.status], axis=1).astype(np.int64)
    genuine = np.zeros(len(out), bool)
    genuine[valid] = np.all(got[valid] == truth[origin[valid]], axis=1)
    genuine[valid] &= np.isin(origin[valid], hit, invert=True)
    return dec.rejected_frames, int((~genuine).sum()), int((genuine & (out.seq != origin)).sum())


def table_byte_errors(quick: bool) -> None:
    rig = load_rig(SIM)
    full = plausible_counts(rig.daq)
    crc_only = Plausible(check_sequence=False)  # the decoder before this campaign's checks
    n = 50_000 if quick else 100_000
    print(f"\n1. byte errors: {n} frames per rate, each byte replaced with probability p")
    head = (
        f"{'p':>7} {'damaged':>8} {'rejected':>8} {'checks':>7} "
        f"{'bad accepted':>12} {'time-base':>9} | {'CRC only: bad':>13} {'time-base':>9}"
    )
    print(head)
    for rate in (1e-4, 1e-3, 1e-2, 5e-2):
        a = byte_errors(rate, n, full)
        b = byte_errors(rate, n, crc_only)
        print(
            f"{rate:>7.0e} {a['damaged']:>8} {a['rejected']:>8} {a['checks_rejected']:>7} "
            f"{a['corrupt_accepted']:>12} {a['timebase_errors']:>9} | "
            f"{b['corrupt_accepted']:>13} {b['timebase_errors']:>9}"
        )
    print("(checks: frames that passed the CRC and were rejected by sensor range or counter jump)")
    k = 2000
    print(f"\n1b. {k} CRC collisions forced in {n} frames (2 body bytes damaged, CRC recomputed)")
    print(f"{'decoder':<22} {'rejected':>8} {'bad accepted':>12} {'time-base errors':>16}")
    for name, p in (("CRC + checks", full), ("CRC only", crc_only)):
        rej, bad, tb = forced_collisions(n, k, p)
        print(f"{name:<22} {rej:>8} {bad:>12} {tb:>16}")
    print(
        "(bad accepted: damage inside the sensors' ranges and in the right order cannot be "
        "told from data; time-base errors: delivered frames whose time is wrong)"
    )


# -- 2. faults, signals, kills, tampering -----------------------------------------------------


def rig_file(sim: Any, folder: Path, text: str | None = None) -> Path:
    """rigs/sim.toml (or `text`) pointed at this simulated rig, over its own transport."""
    text = text or SIM.read_text()
    if sim.endpoints[0].startswith("modbus rtu"):
        text = text.replace(
            'transport = "tcp"\nhost = "127.0.0.1"\nport = 5020',
            f'transport = "rtu"\nserial_port = "socket://127.0.0.1:{sim.modbus_port}"\n'
            "baudrate = 115200",
        )
    text = text.replace("port = 5020", f"port = {sim.modbus_port}")
    text = text.replace("socket://127.0.0.1:5021", f"socket://127.0.0.1:{sim.serial_port}")
    text = text.replace("[daq]\n", f"[daq]\ntime_scale = {sim.speed}\n", 1)
    path = folder / "rig.toml"
    path.write_text(text)
    return path


STOP_BITS = 0b1100  # control word: stop (bit 2) or quick stop (bit 3), rigs/sim.toml


def stop_on_wire(sim: Any, t0: float) -> float:
    """Seconds from t0 to the first stop command the drive received after it (nan: none)."""
    for t, word in list(sim.registers.control_log):
        if t >= t0 and word & STOP_BITS:
            return t - t0
    return float("nan")


class Probe:
    def __init__(self, sim: Any) -> None:
        self.sim = sim
        self.act = ModbusActuator(sim.rig_config())
        self.act.connect()

    def state(self, internal: bool) -> tuple[bool, bool] | None:
        """(running, enabled); `internal` reads the sim itself (when Modbus is muted)."""
        if internal:
            d = self.sim.engine.drive
            return self.sim.call(lambda: (d.running(self.sim.engine.now_s), d.enabled))
        try:
            st = self.act.status()
        except RigFault:
            return None
        return st.running, st.enabled

    def times(self, t0: float, internal: bool, limit_s: float = 8.0) -> tuple[float, float]:
        stopped = disabled = float("nan")
        while time.monotonic() - t0 < limit_s:
            s = self.state(internal)
            now = time.monotonic() - t0
            if s is not None:
                if not s[0] and stopped != stopped:
                    stopped = now
                if not s[1] and disabled != disabled:
                    disabled = now
                if stopped == stopped and disabled == disabled:
                    break
            time.sleep(0.005)
        return stopped, disabled

    def close(self) -> None:
        self.act.close()


def wait_running_test(out: Path, proc: subprocess.Popen[bytes], complete: int = 0) -> None:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError("the sweep ended early")
        try:
            rec = open_recording(out)
            n_complete = sum(m.status == "complete" for m in rec.tests)
            started = sum(k == "start" for _, k, _ in rec.events)
            if n_complete >= complete and rec.interrupted and started > n_complete:
                return
        except RecordingError:
            pass
        time.sleep(0.02)
    raise RuntimeError("no test running")


def describe(out: Path) -> str:
    try:
        rec = open_recording(out)
    except RecordingError as exc:
        return f"unreadable: {exc}"
    status = [m.status[0] for m in rec.tests] + ["i"] * len(rec.interrupted)
    starts = [i for i, (_, k, _) in enumerate(rec.events) if k == "start"]
    kinds = {k for _, k, _ in rec.events[starts[-1] if starts else 0 :]}  # after the last start
    safe = "+".join(k for k in ("stop", "centre", "disable") if k in kinds) or "-"
    reason = next(
        (m.abort_reason or m.extra.get("reason", "") for m in rec.tests if m.status != "complete"),
        "",
    )
    cut = "cut" if rec.truncated else "closed"
    # the control loop's longest gap between two heartbeats (the session's closed event)
    gaps = [re.search(r"between two (\d+) ms", m) for _, k, m in rec.events if k == "closed"]
    gap = gaps[-1].group(1) if gaps and gaps[-1] else "-"
    return (
        f"{''.join(status) or '-':<5} {len(rec.events):>3} ev {gap:>4} {safe:<19} {cut:<6} "
        f"{reason[:110]}"
    )


Action = Callable[[Any, subprocess.Popen[bytes]], "str | None"]


Check = Callable[[Path], str]


def case(
    name: str,
    action: Action,
    *,
    complete: int = 0,
    internal: bool = False,
    setup: Callable[[Path], Check] | None = None,
    stops: bool = True,
    clicks: str = "0,10,20",
) -> None:
    """`setup(folder)` prepares the folder before the sweep (an old recording: the sweep is
    then forced, its new file watched) and returns a check run after it. `stops`: the
    action is a stop cause (a second writer is not: its times are the sweep's end)."""
    with tempfile.TemporaryDirectory() as tmp, start_sim_rig(SIM, speed=SPEED, seed=1) as sim:
        folder = Path(tmp)
        out = folder / "rec.mcap"
        check = setup(folder) if setup is not None else None
        forced = ["--force"] if out.exists() else []
        watch = folder / "rec.new.mcap" if forced else out
        cmd = [*CLI, "sweep", "--rig", str(rig_file(sim, folder)), "--clicks", clicks,
               "--freq", "1", "--cycles", "3", "--warmup-cycles", "1", "-o", str(out),
               *forced]  # fmt: skip
        proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        probe = Probe(sim)
        try:
            wait_running_test(watch, proc, complete)
            time.sleep(0.3)
            t0 = time.monotonic()
            ended = watch_exit(proc)
            note = action(sim, proc)
            stopped, disabled = probe.times(t0, internal)
            code = proc.wait(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            probe.close()
        wire = f"{stop_on_wire(sim, t0) * 1e3:.0f}" if stops else "-"
        gone = ended[0] - t0 if ended else float("nan")
        print(f"{name:<30} {wire:>6} {stopped:>7.2f} {disabled:>8.2f} {gone:>5.2f} {code:>5}  "
              f"{describe(watch)}")  # fmt: skip
        if check is not None:
            note = f"{check(folder)}; {note}" if note else check(folder)
        if note:
            print(f"{'':<30} {note}")


def watch_exit(proc: subprocess.Popen[bytes]) -> list[float]:
    """The monotonic time the process ends, appended by a thread that waits for it."""
    ended: list[float] = []

    def wait() -> None:
        proc.wait()
        ended.append(time.monotonic())

    threading.Thread(target=wait, daemon=True).start()
    return ended


def refused(name: str, run: Callable[[Any, Path], tuple[list[str], str]]) -> None:
    """A hostile input (issue 46): the command run against a simulated rig, refused or not,
    whether the drive was ever enabled, and what it said."""
    with tempfile.TemporaryDirectory() as tmp, start_sim_rig(SIM, speed=SPEED, seed=1) as sim:
        folder = Path(tmp)
        args, after = run(sim, folder)
        t0 = time.monotonic()
        done = subprocess.run([*CLI, *args], cwd=REPO, capture_output=True, text=True,
                              timeout=120, stdin=subprocess.DEVNULL)  # fmt: skip
        took = time.monotonic() - t0
        enabled = any(word & 1 for _, word in list(sim.registers.control_log))
        said = (done.stderr.strip().splitlines() or done.stdout.strip().splitlines() or ["-"])[-1]
        tb = " TRACEBACK" if "Traceback" in done.stderr else ""
        check = after(folder) if callable(after) else after
        print(
            f"{name:<30} {'-':>6} {'-':>7} {'-':>8} {took:>5.2f} {done.returncode:>5}  "
            f"enabled: {'yes' if enabled else 'no '} {check}{tb}"
        )
        print(f"{'':<30} {said[:160]}")


def inject(fault: Fault) -> Action:
    return lambda sim, proc: sim.inject(fault)


def send(sig: int) -> Action:
    return lambda sim, proc: proc.send_signal(sig)


def double_ctrl_c(sim: Any, proc: subprocess.Popen[bytes]) -> None:
    proc.send_signal(signal.SIGINT)
    time.sleep(0.1)
    proc.send_signal(signal.SIGINT)


def rogue_control(*commands: str, enable: bool) -> Action:
    """Another master's control word: 0 (disable), or stop / quick stop with enable set."""

    def act(sim: Any, proc: subprocess.Popen[bytes]) -> None:
        other = ModbusActuator(sim.rig_config())
        other.connect()
        try:
            other.control(*commands, enable=enable)
        finally:
            other.close()

    return act


# A second writer meets a first that writes 22 tests (~60 s at 4x), SIGINTed once it is
# done: its times are the first's end, not a stop.
WRITER: dict[str, Any] = {"stops": False, "clicks": "0-21"}


def second_writer(*extra: str, link: str = "") -> Action:
    """A second `sweep` onto the recording being written (--resume, --force), by its name
    or through a symlink or a hard link to it: it must be refused, the first must go on."""

    def act(sim: Any, proc: subprocess.Popen[bytes]) -> str:
        folder = Path(proc.args[proc.args.index("--rig") + 1]).parent
        out = folder / "rec.mcap"
        if link == "symlink":
            (folder / "link.mcap").symlink_to(out.name)
            out = folder / "link.mcap"
        elif link == "hard":
            os.link(out, folder / "link.mcap")
            out = folder / "link.mcap"
        cmd = [*CLI, "sweep", "--rig", str(folder / "rig.toml"), "--clicks", "0", "--freq", "1",
               "-o", str(out), *extra]  # fmt: skip
        done = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=120)
        said = (done.stderr.strip().splitlines() or ["(nothing)"])[-1]
        alive = "still writing" if proc.poll() is None else "ENDED BEFORE"
        proc.send_signal(signal.SIGINT)  # the first's long sweep has done its part
        return (
            f"second sweep {' '.join(extra)}{' via ' + link if link else ''}: exit "
            f"{done.returncode}, first {alive}: {said[:140]}"
        )

    return act


def rogue(values: dict[str, float], then_kill: bool = False) -> Action:
    def act(sim: Any, proc: subprocess.Popen[bytes]) -> None:
        other = ModbusActuator(sim.rig_config())
        other.connect()
        try:
            other.write(values)
        finally:
            other.close()
        if then_kill:
            time.sleep(0.05)
            proc.kill()

    return act


def table_sessions(quick: bool, load: str = "idle") -> None:
    print(
        f"\n2. sessions ({load}): `shockdyno sweep` child process, sim rig at {SPEED:g}x, "
        "3 tests of 1 Hz x 3 cycles; stop: ms from the cause to the stop command on the "
        "wire; at rest, disabled: s from the cause (probe client); ended: s from the cause "
        "to the sweep process's exit"
    )
    print(f"{'event':<30} {'stop':>6} {'at rest':>7} {'disabled':>8} {'ended':>5} {'exit':>5}  "
          f"{'tests':<5} {'events':>6} {'gap':>4} {'teardown':<19} {'file':<6} reason")  # fmt: skip
    cases: list[tuple[str, Action, dict[str, Any]]] = [
        ("fault over_force", inject(Fault("over_force", duration_s=2.0)), {}),
        ("fault actuator_fault", inject(Fault("actuator_fault")), {}),
        ("fault freeze (DAQ)", inject(Fault("freeze")), {}),
        ("fault daq_disconnect", inject(Fault("daq_disconnect")), {}),
        ("fault drop 120 frames", inject(Fault("drop", count=120)), {}),
        ("fault garble 25 frames", inject(Fault("garble", count=25)), {"stops": False}),
        (
            "fault modbus_timeout 3 s",
            inject(Fault("modbus_timeout", duration_s=3.0)),
            {"internal": True},
        ),
        ("SIGINT", send(signal.SIGINT), {}),
        ("SIGINT twice, 0.1 s apart", double_ctrl_c, {}),
        ("SIGTERM", send(signal.SIGTERM), {}),
        ("SIGHUP", send(signal.SIGHUP), {}),
        ("kill -9 in test 1", send(signal.SIGKILL), {"stops": False}),
        ("kill -9 in test 2", send(signal.SIGKILL), {"complete": 1, "stops": False}),
        ("kill -9 in test 3", send(signal.SIGKILL), {"complete": 2, "stops": False}),
        ("2nd master: sine_frequency 3", rogue({"sine_frequency": 3.0}), {}),
        ("2nd master: rod_clicks 21", rogue({"rod_clicks": 21}), {}),
        ("2nd master: watchdog 65535 ms", rogue({"heartbeat_timeout_ms": 65535}), {}),
        ("2nd master: watchdog, kill -9", rogue({"heartbeat_timeout_ms": 65535}, True), {}),
        ("2nd master: disable (word 0)", rogue_control(enable=False), {}),
        ("2nd master: stop", rogue_control("stop", enable=True), {}),
        ("2nd master: quick stop", rogue_control("quick_stop", enable=True), {}),
        ("concurrent writer: --resume", second_writer("--resume"), WRITER),
        ("concurrent writer: --force", second_writer("--force"), WRITER),
        ("46.3 writer via symlink --force", second_writer("--force", link="symlink"), WRITER),
        ("46.3 writer via hard link", second_writer("--force", link="hard"), WRITER),
        (
            "46.4 --force, 1st test aborted",
            inject(Fault("over_force", duration_s=2.0)),
            {"setup": old_recording},
        ),
    ]
    if quick:
        cases = [cases[i] for i in (0, 2, 3, 7, 9, 11, 14, 18, 22, 23, 25)]
    for name, action, kw in cases:
        case(name, action, **kw)
    for name, run in [] if quick else HOSTILE:
        refused(name, run)
    print(
        "tests: c complete, a aborted, d degraded, i interrupted (begun, cut by the kill); "
        "events: safety events in the file; teardown: stop/centre/disable events after the "
        "last start; gap: the control loop's longest time between two heartbeats, ms "
        "(the drive's watchdog: 1000 ms); kill -9 leaves the stop to the drive's watchdog "
        "(heartbeat.timeout_s = 1.0 s in rigs/sim.toml, host time); the DAQ's freeze is seen after "
        "daq.frozen_timeout_s (1.0 s). Ramps run on DAQ time, 4x faster than at 1x; "
        "garble is counted, not a stop: its times are the sweep's normal end. Hostile "
        "inputs (issue 46): ended, the command's time to its answer; whether the drive was ever "
        "enabled, what was checked after, and its last line"
    )


# -- issue 46's hostile inputs: each a command run beside the simulated rig -----------------

QUICK = ["--clicks", "0", "--freq", "2", "--cycles", "1", "--warmup-cycles", "0",
         "--no-gas-measure"]  # fmt: skip


def _sweep(sim: Any, folder: Path, out: str, *extra: str, text: str | None = None) -> list[str]:
    return ["sweep", "--rig", str(rig_file(sim, folder, text)), *QUICK, "-o", out, *extra]


def _fifo(sim: Any, folder: Path) -> tuple[list[str], str]:
    os.mkfifo(folder / "out.fifo")
    return _sweep(sim, folder, str(folder / "out.fifo"), "--force"), "-"


def _absurd_limits(sim: Any, folder: Path) -> tuple[list[str], str]:
    text = SIM.read_text().replace("travel_m = 0.045", "travel_m = 10")
    return _sweep(sim, folder, str(folder / "r.mcap"), text=text), "-"


def _slow_daq(sim: Any, folder: Path) -> tuple[list[str], str]:
    text = SIM.read_text().replace("sample_rate_hz = 1000.0", "sample_rate_hz = 50.0")
    return _sweep(sim, folder, str(folder / "r.mcap"), text=text), "-"


def _other_kind(sim: Any, folder: Path) -> tuple[list[str], Callable[[Path], str]]:
    (folder / "other_rig.toml").write_text("[rig]\n")
    return _sweep(
        sim, folder, str(folder / "other_rig.toml"), "--force"
    ), lambda f: "toml kept" if (f / "other_rig.toml").read_text() == "[rig]\n" else "TOML REPLACED"


def _tiny(sim: Any, folder: Path) -> tuple[list[str], str]:
    return [*_sweep(sim, folder, str(folder / "r.mcap")), "--amplitude-mm", "0.000001"], "-"


def _slowest(sim: Any, folder: Path) -> tuple[list[str], str]:
    return [*_sweep(sim, folder, str(folder / "r.mcap")), "--freq", "1e-9"], "-"


def _deep(sim: Any, folder: Path) -> tuple[list[str], str]:
    (folder / "deep.toml").write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    return ["sweep", "--rig", str(folder / "deep.toml"), "-o", str(folder / "r.mcap")], "-"


def old_recording(folder: Path) -> Check:
    """An old recording at rec.mcap (the example): the sweep is forced onto it."""
    rec = folder / "rec.mcap"
    shutil.copy(REPO / "recordings" / "examples" / "example.mcap", rec)
    before = rec.read_bytes()

    def check(f: Path) -> str:
        kept = rec.read_bytes() == before
        beside = (f / "rec.new.mcap").exists()
        new = "beside it" if beside else "gone"
        return f"old recording {'kept' if kept else 'LOST'}, this run's {new}"

    return check


def _spec_fifo(sim: Any, folder: Path) -> tuple[list[str], str]:
    """A fit JSON whose spec_path names a FIFO (with a .toml name), given to export."""
    os.mkfifo(folder / "spec.toml")
    fit = folder / "fit.json"
    FitResult.from_spec(default_spec_path(), [0, 10]).save(fit)
    doc = json.loads(fit.read_text())
    fit.write_text(json.dumps({**doc, "spec_path": str(folder / "spec.toml")}))
    return ["export", str(fit), "--damper-table", str(folder / "table")], "-"


HOSTILE: list[tuple[str, Callable[[Any, Path], Any]]] = [
    ("46.1b -o out.fifo --force", _fifo),
    ("46.9 -o /dev/null --force", lambda s, f: (_sweep(s, f, "/dev/null", "--force"), "-")),
    ("46.2 limits.travel_m = 10", _absurd_limits),
    ("46.2 daq.sample_rate_hz = 50", _slow_daq),
    ("46.4 -o other_rig.toml --force", _other_kind),
    ("46.9 --amplitude-mm 1e-6", _tiny),
    ("46.9 --freq 1e-9", _slowest),
    ("46.10 rig TOML 100k deep", _deep),
    ("46.11 fit's spec_path a FIFO", _spec_fifo),
]


@contextlib.contextmanager
def burning(n: int) -> Iterator[None]:
    """n CPU-bound processes at the normal priority for as long as the block runs."""
    code = "import os\nparent = os.getppid()\nwhile os.getppid() == parent:\n    pass\n"
    procs = [subprocess.Popen([sys.executable, "-c", code]) for _ in range(n)]
    try:
        yield
    finally:
        for p in procs:
            p.kill()
            p.wait()


# -- 3. time to rest per rig and per frequency -----------------------------------------------


def rest_case(modbus: str, frequency: float) -> tuple[float, float, float, float]:
    """(stop on the wire ms, at rest s, disabled s, a status round trip ms) after SIGTERM in
    the measured cycles of a 20 mm sine at `frequency`, at real time."""
    with tempfile.TemporaryDirectory() as tmp, start_sim_rig(SIM, speed=1.0, seed=1,
                                                             modbus=modbus) as sim:  # fmt: skip
        folder = Path(tmp)
        out = folder / "rec.mcap"
        cmd = [*CLI, "sweep", "--rig", str(rig_file(sim, folder)), "--clicks", "0",
               "--freq", f"{frequency:g}", "--amplitude-mm", "20", "--cycles", "20",
               "--warmup-cycles", "1", "--no-gas-measure", "-o", str(out)]  # fmt: skip
        proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        probe = Probe(sim)
        try:
            wait_running_test(out, proc)
            time.sleep(2.0 / frequency + 0.3)  # the ramp and the warm-up cycle: at full amplitude
            rtt0 = time.monotonic()
            probe.state(False)
            rtt = time.monotonic() - rtt0
            t0 = time.monotonic()
            proc.send_signal(signal.SIGTERM)
            stopped, disabled = probe.times(t0, False, limit_s=20.0)
            proc.wait(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            probe.close()
        return stop_on_wire(sim, t0) * 1e3, stopped, disabled, rtt * 1e3


DRIVE_STOP_S = DriveParams(0.0, 0.0, 0.0, 0.0).stop_time_s  # the simulated drive's own


def table_rest(quick: bool) -> None:
    print(
        "\n3. time to rest after SIGTERM, real time (speed 1), 20 mm sine, per rig and "
        f"frequency; ramp-out: the drive's own, max(its stop time {DRIVE_STOP_S:g} s, one "
        "cycle)"
    )
    print(f"{'rig':<14} {'f Hz':>5} {'stop ms':>7} {'rtt ms':>6} {'at rest s':>9} "
          f"{'ramp-out s':>10} {'ratio':>6} {'disabled s':>10}")  # fmt: skip
    freqs = (1.0, 4.0) if quick else (0.5, 1.0, 2.0, 4.0)
    for modbus in ("tcp", "rtu"):
        for f in freqs:
            wire, rest, off, rtt = rest_case(modbus, f)
            ramp = max(DRIVE_STOP_S, 1.0 / f)
            print(f"{'sim ' + modbus:<14} {f:>5g} {wire:>7.0f} {rtt:>6.1f} {rest:>9.2f} "
                  f"{ramp:>10.2f} {rest / ramp:>6.2f} {off:>10.2f}")  # fmt: skip
    print(
        "stop: signal to the stop command on the wire; rtt: one status read of the probe in "
        "the same run (the wire's own time); at rest: the drive no longer running; ratio: "
        "at rest / ramp-out; disabled: after the ramp to centre"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer frames and cases")
    parser.add_argument("--no-load", action="store_true", help="skip the run under CPU load")
    parser.add_argument("--no-rest", action="store_true", help="skip the time-to-rest table")
    args = parser.parse_args()
    t0 = time.perf_counter()
    table_byte_errors(args.quick)
    table_sessions(args.quick)
    if not args.no_load:
        n = 2 * (os.cpu_count() or 1)
        with burning(n):
            table_sessions(args.quick, f"beside {n} CPU-bound processes, 2x the cores")
    if not args.no_rest:
        table_rest(args.quick)
    print(f"\ncampaign took {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
