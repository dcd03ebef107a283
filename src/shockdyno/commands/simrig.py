"""`shockdyno sim-rig`: run the simulated rig on 127.0.0.1 until Ctrl-C."""

from __future__ import annotations

import argparse
import math
import sys
import time

from shockdyno.commands.args import Subparsers, add_seed, add_spec
from shockdyno.errors import ConfigError
from shockdyno.rig.config import default_rig_path, load_rig
from shockdyno.simrig.faults import parse_fault
from shockdyno.simrig.server import start_sim_rig


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "sim-rig",
        help="run the simulated rig (Modbus drive + serial DAQ on 127.0.0.1)",
        description=(
            "Serve the simulated dyno: a Modbus TCP drive and a serial DAQ stream "
            "(socket:// and/or a pty), fed by the damper model. Prints one line per "
            "endpoint, then runs until Ctrl-C."
        ),
    )
    p.add_argument(
        "--rig", default=str(default_rig_path()), help="rig file (default rigs/sim.toml)"
    )
    add_spec(p)
    p.add_argument("--scenario", default=None, help="scenario name or file in sim/scenarios/")
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        help="x real time: simulated seconds per wall-clock second",
    )
    add_seed(p, "the noise (same seed, same bytes)")
    p.add_argument(
        "--serial", choices=("socket", "pty", "both"), default="socket", help="DAQ transport"
    )
    p.add_argument(
        "--modbus",
        choices=("tcp", "rtu"),
        default="tcp",
        help="Modbus framing: tcp, or rtu over a TCP socket (driver URL socket://HOST:PORT)",
    )
    p.add_argument("--modbus-port", type=int, default=None, help="default: the rig file's port")
    p.add_argument("--serial-port", type=int, default=None, help="default: the rig file's port")
    p.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="KIND@S[:N]",
        help="inject a fault at sim time S: garble, drop (N frames), freeze, modbus_timeout, "
        "daq_disconnect, actuator_fault, over_force (N: duration s); repeatable",
    )
    p.add_argument(
        "--single-master",
        action="store_true",
        help="accept Modbus writes from one connection only (the first to write, until it "
        "disconnects; others get 'device busy'): how a real drive should be set up",
    )
    p.add_argument("--duration", type=float, default=None, help="stop after this many seconds")
    p.set_defaults(func=run)


def _port_from_url(url: str) -> int:
    if url.startswith("socket://"):
        return int(url.rsplit(":", 1)[1].split("?")[0])
    return 0


def run(args: argparse.Namespace) -> int:
    if not (math.isfinite(args.speed) and args.speed > 0):
        raise ConfigError(f"--speed must be a number > 0, got {args.speed:g}")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise ConfigError(f"--duration must be a number of seconds > 0, got {args.duration:g}")
    for flag, port in (("--modbus-port", args.modbus_port), ("--serial-port", args.serial_port)):
        if port is not None and not 0 <= port <= 65535:
            raise ConfigError(f"{flag} must be 0-65535 (0: any free port), got {port}")
    rig = load_rig(args.rig)
    faults = [parse_fault(f) for f in args.fault]
    modbus_port = args.modbus_port if args.modbus_port is not None else rig.actuator.port
    serial_port = args.serial_port if args.serial_port is not None else _port_from_url(rig.daq.url)
    with start_sim_rig(
        rig,
        spec_path=args.spec,
        scenario=args.scenario,
        speed=args.speed,
        seed=args.seed,
        serial=args.serial,
        faults=faults,
        modbus_port=modbus_port,
        serial_port=serial_port,
        modbus=args.modbus,
        single_master=args.single_master,
    ) as sim:
        for line in sim.endpoints:
            print(line, flush=True)
        start = time.monotonic()
        try:
            while args.duration is None or time.monotonic() - start < args.duration:
                time.sleep(0.1)
        except KeyboardInterrupt:
            print("sim-rig: stopped", file=sys.stderr)
    return 0
