"""`shockdyno rig check | jog | tare`: first contact with a rig, before any sweep.

`check` and `tare` only read (the drive is never written to); `jog` moves the ram through
RigSession, so it has exactly a sweep's limits, heartbeat and teardown.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from shockdyno.commands.args import Subparsers, add_force, add_rig, hint_unreachable
from shockdyno.errors import ConfigError, RigFault
from shockdyno.outputs import check_output, write_output
from shockdyno.rig.config import load_rig
from shockdyno.run.signals import stop_on_signals

JOG_HOLD_S = 0.5  # DAQ time at the target: long enough to average the LVDT and load cell


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(value) and 0 < value <= 60):
        raise argparse.ArgumentTypeError(f"must be > 0 and <= 60 s, got {text}")
    return value


def _mm(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text}")
    return value


def register(sub: Subparsers) -> None:
    r = sub.add_parser(
        "rig",
        help="first contact with a rig: check (read only), jog, tare the load cell",
        description="Commission a rig before its first sweep. `check` reads the drive's "
        "registers and a second of DAQ frames without writing anything; `jog` moves the ram "
        "slowly to a position and back, behind a sweep's limits and teardown; `tare` "
        "measures the load cell's zero with the drive disabled. See docs/rig.md.",
    )
    rs = r.add_subparsers(dest="rig_command", metavar="ACTION")
    rs.required = True

    c = rs.add_parser(
        "check",
        help="read the drive's registers and ~1 s of DAQ frames; enables and moves nothing",
        description="Connect to the drive (Modbus TCP or RTU, as the rig file says) and the "
        "DAQ, read every register and about a second of frames, and say what is missing or "
        "implausible. Nothing is written to the drive. Exit 0 when all is well, 1 with the "
        "list of problems otherwise.",
    )
    add_rig(c)
    c.add_argument("--seconds", type=_seconds, default=1.0, help="how long to read the DAQ")
    c.add_argument("--json", metavar="PATH", help="write the findings as JSON (- for stdout)")
    add_force(c, "an existing --json file")
    c.set_defaults(func=cmd_check)

    j = rs.add_parser(
        "jog",
        help="move the ram slowly to a position, then back to centre and disabled",
        description="Enable, ramp to the stroke centre, ramp to the target at the rig file's "
        "ramp.move_velocity_m_s, hold it briefly and report where the LVDT and load cell "
        "say it is, then stop, centre and disable: the session of a sweep, with its limits "
        "watched on every sample, heartbeat and guaranteed teardown. A target outside "
        "limits.travel_m is refused before anything moves.",
    )
    add_rig(j)
    to = j.add_mutually_exclusive_group(required=True)
    to.add_argument("--to-mm", type=_mm, help="target, mm from the stroke centre (+ compression)")
    to.add_argument("--by-mm", type=_mm, help="target, mm from where the ram stands now")
    j.set_defaults(func=cmd_jog)

    t = rs.add_parser(
        "tare",
        help="measure the load cell's zero (drive disabled, load cell unloaded)",
        description="Read the load cell with the drive disabled and the ram at rest, and print "
        "its zero with its noise and the [daq.calibration] force_offset_n line that zeroes "
        "it. The load cell must carry nothing: a mounted damper's gas force is a force, not "
        "an offset. The rig file is never changed: --write PATH writes a copy with the new "
        "offset.",
    )
    add_rig(t)
    t.add_argument("--seconds", type=_seconds, default=2.0, help="how long to average")
    t.add_argument("--write", metavar="PATH", type=Path, help="a copy of the rig file, tared")
    t.add_argument(
        "--unloaded",
        action="store_true",
        help="nothing is mounted: tare even a reading that looks like a load (by default one "
        "beyond max(25 N, 0.5 %% of limits.force_n) is refused as a mounted damper's force)",
    )
    add_force(t, "an existing --write file")
    t.set_defaults(func=cmd_tare)


@hint_unreachable
def cmd_check(args: argparse.Namespace) -> int:
    # The rig commands' own modules are imported when run: at start-up they would add
    # check +15, session +28, tare +17 and actuator (pymodbus's client) +8 ms CPU (measured).
    from shockdyno.rig.check import check_rig

    if args.json is not None:
        check_output(args.json, force=args.force, inputs=[args.rig])
    rig = load_rig(args.rig)
    result = check_rig(rig, seconds=args.seconds)
    out = print if args.json != "-" else _stderr
    out(f"rig check: {rig.name} ({args.rig}), read only: nothing was written to the drive")
    for title, findings in (("drive", result.drive), ("DAQ " + rig.daq.url, result.daq)):
        out(title)
        for f in findings:
            mark = "ok " if f.ok else "BAD"
            note = f"  <- {f.note}" if f.note and not f.ok else ""
            out(f"  {mark} {f.what}: {f.value}{note}")
    if result.ok:
        out("all well: no problems found")
    else:
        n = len(result.problems)
        out(f"{n} problem{'s' if n > 1 else ''}:")
        for p in result.problems:
            out(f"  - {p}")
    if args.json is not None:
        doc = json.dumps(result.as_dict(), indent=2, ensure_ascii=False) + "\n"
        write_output(args.json, doc, force=args.force, inputs=[args.rig])
    return 0 if result.ok else 1


def _stderr(text: str) -> None:
    print(text, file=sys.stderr)


@hint_unreachable
def cmd_jog(args: argparse.Namespace) -> int:
    # here: the drive and the session add 8 and 28 ms to every command's start (measured)
    from shockdyno.rig.actuator import ModbusActuator
    from shockdyno.run.session import RigSession

    rig = load_rig(args.rig)
    travel = rig.limits.travel_m
    if args.to_mm is not None:
        target = args.to_mm / 1e3
    else:
        probe = ModbusActuator(rig)  # read only: where the ram stands before anything moves
        try:
            probe.connect()
            here = probe.status().position_m - rig.stroke_centre_m
        finally:
            probe.close()
        target = here + args.by_mm / 1e3
    if abs(target) > travel:
        raise ConfigError(
            f"target {target * 1e3:+.2f} mm from centre is outside the rig's travel of "
            f"±{travel * 1e3:g} mm ({args.rig} limits.travel_m); refused before moving"
        )
    v = rig.ramp.move_velocity_m_s
    print(
        f"rig jog: {rig.name} ({args.rig}): to {target * 1e3:+.2f} mm from centre at "
        f"{v * 1e3:g} mm/s (ramp.move_velocity_m_s), then back to centre and disabled"
    )
    with stop_on_signals(), RigSession(rig) as session:
        arrived = session.move_to(target)
        held = session.dwell(JOG_HOLD_S)
        x = float(np.mean(held.displacement_m)) if len(held) else math.nan
        f = float(np.mean(held.force_n)) if len(held) else math.nan
        print(
            f"  at target: LVDT {x * 1e3:+.2f} mm, drive "
            f"{(arrived.position_m - rig.stroke_centre_m) * 1e3:+.2f} mm "
            f"(target {target * 1e3:+.2f} mm), load cell {f:+.1f} N"
        )
    kinds = [e.kind for e in session.events]
    ended = "centred and disabled" if {"centre", "disable"} <= set(kinds[-6:]) else "see events"
    print(f"  ended: {ended} ({', '.join(kinds[kinds.index('move') + 1 :])})")
    if "stop_step_failed" in kinds:
        raise RigFault("the teardown did not complete: " + "; ".join(
            e.message for e in session.events if e.kind == "stop_step_failed"))  # fmt: skip
    return 0


@hint_unreachable
def cmd_tare(args: argparse.Namespace) -> int:
    # here: +17 ms at every command's start (measured)
    from shockdyno.rig.tare import KEY, measure_tare, with_offset

    if args.write is not None:
        check_output(args.write, force=args.force, inputs=[args.rig], flag="--write")
    rig = load_rig(args.rig)
    tare = measure_tare(rig, seconds=args.seconds)
    if tare.loaded and not args.unloaded:
        raise RigFault(f"refused: {tare.load_text()}")
    print(
        f"rig tare: {rig.name} ({args.rig}), drive disabled, ram at rest: nothing was "
        "written to the drive"
    )
    if tare.loaded:
        print(
            f"  warning: {tare.mean_n:+.1f} N is more than a zero error usually is "
            f"({tare.loaded_above_n:.0f} N); tared as asked (--unloaded). Were a damper "
            "mounted, this offset would cancel its gas force in every force measured after"
        )
    print(
        f"  load cell reads {tare.mean_n:+.2f} N ± {tare.standard_error_n:.2f} N "
        f"(noise sd {tare.sd_n:.2f} N, {tare.samples} samples; current "
        f"{KEY} {tare.old_offset_n:+.3f} N)"
    )
    print("  to zero it, set in [daq.calibration]:")
    print(f"    {tare.line()}")
    if args.write is not None:
        text = with_offset(rig.raw_toml, tare.new_offset_n, str(args.rig))
        write_output(args.write, text, force=args.force, inputs=[args.rig], flag="--write")
        print(f"  wrote {args.write} (a copy of {args.rig} with the new {KEY})")
    return 0
