"""SimRig: the simulated rig on real transports, in a background thread with its own loop.

A pymodbus TCP server (the drive) and a serial byte stream (the DAQ) on 127.0.0.1, over
`socket://` and/or a pty, both fed by one SimEngine. The engine is paced by an injected
clock: `speed` sim-seconds per clock-second; the frames do not depend on the speed.
"""

from __future__ import annotations

import asyncio
import contextlib
import copy
import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TypeVar

from numpy.typing import ArrayLike
from pymodbus.constants import ExcCodes
from pymodbus.framer import FramerType
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimAction, SimData, SimDevice

from shockdyno import priority
from shockdyno.errors import ConfigError, RigFault
from shockdyno.model.spec import load_spec
from shockdyno.rig.config import RigConfig, default_rig_path, load_rig
from shockdyno.simrig.drive import HEARTBEAT_LOST
from shockdyno.simrig.engine import CHUNK, SimEngine
from shockdyno.simrig.faults import Fault
from shockdyno.simrig.registers import DriveRegisters
from shockdyno.simrig.scenario import Scenario, load_scenario
from shockdyno.simrig.serial_stream import SerialStream
from shockdyno.simrig.single_master import SingleMasterTcpServer
from shockdyno.simrig.stepper import Stepper

T = TypeVar("T")

# The server reports its own failures as one-line RigFaults; without a handler of its own,
# pymodbus's error log would reach stderr through logging's last-resort handler as well.
logging.getLogger("pymodbus").addHandler(logging.NullHandler())

SERVER_FAULTS = ("modbus_timeout", "daq_disconnect")  # faults of the wires, not the engine
MAX_BATCH = 5000  # samples per engine step: keeps Modbus answers prompt when behind
BEHIND_PAUSE_S = 0.002  # between batches when behind: the loop answers Modbus meanwhile
WATCHDOG_PERIOD_S = 0.01  # the simulated drive's watchdog cycle (host time)
LATE_S = 0.005  # a watchdog turn this much late: the loop was starved, not idle (_watchdog)
STEP_WAIT_S = 2.0  # at close, the longest wait for the plant's step under way


class SimRig:
    """Context manager; see `start_sim_rig`."""

    def __init__(
        self,
        rig: RigConfig,
        *,
        spec_path: str | Path | None = None,
        scenario: Scenario | None = None,
        speed: float = 1.0,
        seed: int = 0,
        serial: str = "socket",
        faults: Sequence[Fault] = (),
        modbus_port: int = 0,
        serial_port: int = 0,
        modbus: str = "tcp",
        clock: Callable[[], float] = time.monotonic,
        single_master: bool = False,
    ) -> None:
        _check_options(modbus, speed, modbus_port, serial_port, serial)
        self.rig = rig
        self.spec = load_spec(spec_path)
        self.scenario = scenario
        self.speed = speed
        self.clock = clock
        sched = [f for f in faults if f.kind not in SERVER_FAULTS]
        self._wire_faults = sorted(
            (f for f in faults if f.kind in SERVER_FAULTS), key=lambda f: f.at_s
        )
        self.engine = SimEngine(
            rig,
            self.spec,
            terms=scenario.terms if scenario else None,
            term_values=scenario.values if scenario else None,
            lvdt_lag_s=scenario.lvdt_lag_s if scenario else 0.0,
            plant=scenario.plant if scenario else None,
            seed=seed,
            faults=sched,
        )
        # A first step costs what later ones do not (lazy imports, compiled kernels: 0.4 s,
        # more on a busy host), and on the loop it would hold up the first Modbus answers
        # past the host's timeout. A real drive answers from the moment it listens: the
        # first step is taken here, on a copy, before the servers start.
        copy.deepcopy(self.engine).advance(self.engine.min_batch)
        self.registers = DriveRegisters(self.engine, rig.registers, clock)
        self._serial = SerialStream(serial)
        self._modbus = modbus
        self._single_master = single_master
        self._ports = (modbus_port, serial_port)
        self._mute_until = -1.0  # clock time until which Modbus goes unanswered (inf: for good)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self.endpoints: list[str] = []
        self.modbus_port = 0
        self.serial_port = 0
        self.pty_path = ""
        self.behind_s = 0.0  # worst lag of the engine behind its schedule, sim seconds
        self._closed = False
        # A slow plant (the reference plant's stiff solver) steps in a thread of its own,
        # so the loop answers Modbus meanwhile: a 30-sample step once took 1.0 s on a
        # loaded machine, twice the host's timeout. The term-library engine, fast and
        # deterministic, steps on the loop as before.
        self._stepper: Stepper | None = None
        self._stepping: asyncio.Future[bytes] | None = None
        self._nice_before: int | None = None  # the plant's steps run at the host's priority

    # -- lifecycle ---------------------------------------------------------------------
    def start(self) -> SimRig:
        """Start the Modbus server and the serial stream in a thread of their own; returns once
        both listen (RigFault if they do not within 10 s)."""
        self._thread = threading.Thread(target=self._run, name="sim-rig", daemon=True)
        self._thread.start()
        self._ready.wait(10)
        if self._error is not None:
            self.close()
            raise RigFault(f"sim-rig failed to start: {self._error}")
        if not self._ready.is_set():
            self.close()
            raise RigFault("sim-rig failed to start in 10 s")
        return self

    def __enter__(self) -> SimRig:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop the servers and wait (at most 10 s) for their thread; idempotent."""
        if self._closed:
            return
        self._closed = True
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(stop.set)
        if self._thread is not None:
            self._thread.join(10)

    def _run(self) -> None:
        # The simulated drive answers as a drive with a processor of its own would: a busy
        # host must not starve it (where the process may raise its priority).
        self._nice_before, _ = priority.raise_priority()
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except BaseException as exc:  # surfaced by start()
            self._error = exc
            self._ready.set()
        finally:
            with contextlib.suppress(Exception):
                loop.run_until_complete(loop.shutdown_asyncgens())
            loop.close()

    async def _main(self) -> None:
        self._stop = asyncio.Event()
        server = _modbus_server(
            self.registers,
            self.rig.actuator.device_id,
            self._action,
            self._modbus,
            self._ports[0],
            self._single_master,
        )
        self.modbus_server = server
        try:
            await server.serve_forever(background=True)
        except Exception:
            raise RigFault(
                f"cannot listen for Modbus on 127.0.0.1:{self._ports[0]} (port in use?)"
            ) from None
        sockets = server.transport.sockets  # type: ignore[attr-defined]
        self.modbus_port = int(sockets[0].getsockname()[1])
        if self._modbus == "rtu":
            self.endpoints = [f"modbus rtu socket://127.0.0.1:{self.modbus_port}"]
        else:
            self.endpoints = [f"modbus tcp://127.0.0.1:{self.modbus_port}"]
        self.endpoints += await self._serial.open(self._ports[1])
        self.serial_port, self.pty_path = self._serial.port, self._serial.pty_path
        if self.engine.plant is not None:
            self._stepper = Stepper(self._nice_before)
        ticker = asyncio.create_task(self._tick())
        watchdog = asyncio.create_task(self._watchdog())
        self._ready.set()
        try:
            await self._stop.wait()
        finally:
            for task in (ticker, watchdog):
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task  # one that failed is ended all the same
            if self._stepper is not None:
                # The step under way ends first, if it ends: a plant stuck in a step must
                # not hold the rig's close (and its process's exit) for ever.
                self._stepper.shutdown(STEP_WAIT_S)
            await server.shutdown()  # type: ignore[no-untyped-call]
            await self._serial.close()
            for task in asyncio.all_tasks():
                if task is not asyncio.current_task():
                    task.cancel()

    # -- the DAQ stream ----------------------------------------------------------------
    async def _tick(self) -> None:
        fs = self.engine.fs
        wall0 = self.clock()
        sim0 = self.engine.produced
        sleep = max(0.002, CHUNK / (fs * self.speed))
        while True:
            now = self.clock()
            due = int((now - wall0) * self.speed * fs) + sim0 - self.engine.produced
            due = due // CHUNK * CHUNK
            if due >= self.engine.min_batch:
                self.behind_s = max(self.behind_s, (due - self.engine.max_batch) / fs)
                self._watchdogs(now)
                n = min(due, self.engine.max_batch)
                if self._stepper is None:
                    self._serial.send(self.engine.advance(n))
                else:
                    loop = asyncio.get_running_loop()
                    self._stepping = self._stepper.submit(loop, self.engine.advance, n)
                    try:
                        self._serial.send(await self._stepping)
                    finally:
                        self._stepping = None
            self._serial.flush()
            # Behind schedule, still sleep a little: with sleep(0) every turn of the loop
            # ran a batch, and a Modbus request needs several turns (read, decode, answer),
            # so a plant slower than real time (the reference plant's stiff solver on a
            # loaded machine) let requests time out at 0.5 s.
            await asyncio.sleep(sleep if due <= self.engine.max_batch else BEHIND_PAUSE_S)

    async def _watchdog(self) -> None:
        """The drive's heartbeat watchdog, every WATCHDOG_PERIOD_S.

        A real drive's watchdog runs on the drive's own processor. The simulated one runs
        on this loop, which a loaded host can starve (other processes, or another thread
        of its process holding the interpreter's lock): the time the loop ran late is not
        time the host failed to beat in (its beats wait in the socket meanwhile), so the
        watchdog's period is moved on by it. Without this, a starved simulator tripped
        "heartbeat lost" on a host that beat on time (issue 46.12). A loop on time (late
        by less than LATE_S a turn) moves nothing: a host that stops beating trips it in
        its watchdog time."""
        last = time.monotonic()  # the loop's own starvation, whatever clock paces the rig
        while True:
            await asyncio.sleep(WATCHDOG_PERIOD_S)
            woke = time.monotonic()
            late = woke - last - WATCHDOG_PERIOD_S
            if late > LATE_S:
                self.registers.last_beat_wall += late
            last = woke
            d = self.engine.drive
            timeout = d.heartbeat_timeout_ms / 1000.0
            if d.enabled and timeout > 0 and self.clock() - self.registers.last_beat_wall > timeout:
                step = self._stepping
                if step is not None:  # the drive's state changes between the plant's steps
                    with contextlib.suppress(Exception):
                        await asyncio.shield(step)
                t = self.engine.now_s
                if not d.fault_code:
                    d.trip(HEARTBEAT_LOST, t, disable=True)
                elif d.disable_at is None:
                    d.disable_at = max(d.sine_end, t) + 0.05

    def _watchdogs(self, now: float) -> None:
        t = self.engine.now_s
        while self._wire_faults and self._wire_faults[0].at_s <= t:
            self._server_fault(self._wire_faults.pop(0), now)
        for f in self.engine.state.extra.pop("server_faults", []):
            self._server_fault(f, now)

    def _server_fault(self, f: Fault, now: float) -> None:
        if f.kind == "modbus_timeout":
            self._mute_until = now + f.duration_s if f.duration_s > 0 else float("inf")
        elif f.kind == "daq_disconnect":
            self._serial.disconnect()

    async def _action(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> ExcCodes | None:
        while self.clock() < self._mute_until:
            await asyncio.sleep(0.05)  # no answer: the host's request times out
        step = self._stepping
        if set_values and step is not None and not self.registers.only_heartbeat(address, count):
            # A command reaches the engine between steps, as on the loop: wait for the
            # plant's step under way. Reads and heartbeats are answered at once.
            with contextlib.suppress(Exception):
                await asyncio.shield(step)
        if set_values:
            return self.registers.write(
                registers, start_address, address, [int(v) for v in set_values]
            )
        self.registers.refresh(registers, start_address)
        return None

    # -- public helpers ----------------------------------------------------------------
    def rig_config(self) -> RigConfig:
        """The rig config pointing at this instance's actual endpoints."""
        url = f"socket://127.0.0.1:{self.serial_port}" if self.serial_port else self.pty_path
        return self._with_daq(url)

    def pty_config(self) -> RigConfig:
        """The rig config with the DAQ read from this instance's pty; ConfigError when it has
        none."""
        if not self.pty_path:
            raise ConfigError("this sim-rig has no pty (start it with serial='pty' or 'both')")
        return self._with_daq(self.pty_path)

    def _with_daq(self, url: str) -> RigConfig:
        return loopback_config(self.rig, self.modbus_port, url, self.speed, self._modbus)

    def true_bleed_areas(self, clicks: ArrayLike, gas_clicks: ArrayLike = 0) -> tuple[float, float]:
        """The simulated damper's true bleed areas (A_bc, A_bt; m²) at the given clicks, to check
        a fit against."""
        a_bc, a_bt = self.spec.bleed_areas(clicks, gas_clicks)
        return float(a_bc), float(a_bt)

    def inject(self, fault: Fault) -> None:
        """Trigger a fault now (from any thread)."""
        loop = self._loop
        if loop is None:
            raise RigFault("sim-rig is not running")

        def apply() -> None:
            if fault.kind in SERVER_FAULTS:
                self._server_fault(fault, self.clock())
            else:
                self.engine.inject(fault)

        loop.call_soon_threadsafe(apply)

    def call(self, fn: Callable[[], T]) -> T:
        """Run fn on the sim-rig's loop and return its result (to inspect state safely)."""
        loop = self._loop
        if loop is None or loop.is_closed():
            raise RigFault("sim-rig is not running")

        async def wrapped() -> T:
            return fn()

        return asyncio.run_coroutine_threadsafe(wrapped(), loop).result(5)


def _check_options(
    modbus: str, speed: float, modbus_port: int, serial_port: int, serial: str
) -> None:
    if modbus not in ("tcp", "rtu"):
        raise ConfigError(f"modbus must be tcp or rtu, got {modbus!r}")
    if not (isinstance(speed, int | float) and math.isfinite(speed) and speed > 0):
        raise ConfigError(f"speed must be a number > 0, got {speed}")
    for name, port in (("modbus_port", modbus_port), ("serial_port", serial_port)):
        if not 0 <= port <= 65535:
            raise ConfigError(f"{name} must be 0-65535 (0: any free port), got {port}")
    if serial not in ("socket", "pty", "both"):
        raise ConfigError(f"serial must be socket, pty or both, got {serial!r}")


def _modbus_server(
    registers: DriveRegisters,
    device_id: int,
    action: SimAction,
    modbus: str,
    port: int,
    single_master: bool,
) -> ModbusTcpServer:
    """The drive's Modbus server on 127.0.0.1:`port` (0: any free one), not yet listening:
    its register block, each request answered by `action`."""
    device = SimDevice(
        id=device_id,
        simdata=[
            SimData(registers.start, count=registers.count, values=0, datatype=DataType.REGISTERS)
        ],
        action=action,
    )
    # RTU framing is served over a TCP socket (an RTU line behind a serial server):
    # the RTU driver reaches it as the pyserial URL socket://127.0.0.1:PORT.
    framer = FramerType.RTU if modbus == "rtu" else FramerType.SOCKET
    cls = SingleMasterTcpServer if single_master else ModbusTcpServer
    return cls(device, address=("127.0.0.1", port), framer=framer)


def start_sim_rig(
    rig: RigConfig | str | Path | None = None,
    *,
    spec_path: str | Path | None = None,
    scenario: str | Path | None = None,
    speed: float = 1.0,
    seed: int = 0,
    serial: str = "socket",
    faults: Sequence[Fault] = (),
    modbus_port: int = 0,
    serial_port: int = 0,
    modbus: str = "tcp",
    clock: Callable[[], float] = time.monotonic,
    single_master: bool = False,
) -> SimRig:
    """Start a simulated rig on 127.0.0.1 (ephemeral ports unless given) and return it."""
    cfg = rig if isinstance(rig, RigConfig) else load_rig(rig or default_rig_path())
    sc = load_scenario(scenario) if scenario is not None else None
    return SimRig(
        cfg,
        spec_path=spec_path,
        scenario=sc,
        speed=speed,
        seed=seed,
        serial=serial,
        faults=faults,
        modbus_port=modbus_port,
        serial_port=serial_port,
        modbus=modbus,
        clock=clock,
        single_master=single_master,
    ).start()


def loopback_config(
    rig: RigConfig, port: int, daq_url: str, speed: float, modbus: str
) -> RigConfig:
    """`rig` pointed at a sim-rig on this machine: its Modbus server on `port` (TCP, or RTU
    framed over a socket), its DAQ at `daq_url`, delivering `speed` DAQ seconds of frames
    per wall second (the host checks)."""
    out = rig.with_endpoints(host="127.0.0.1", port=port, daq_url=daq_url)
    out = replace(out, daq=replace(out.daq, time_scale=speed))
    if modbus == "rtu":
        act = replace(
            rig.actuator,
            kind="rtu",
            serial_port=f"socket://127.0.0.1:{port}",
            baudrate=115200,
        )
        out = replace(out, actuator=act)
    return out
