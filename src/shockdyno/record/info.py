"""`shockdyno info`: what a recording holds, also when it was cut off."""

from __future__ import annotations

from collections import Counter
from typing import NotRequired, TypedDict

from shockdyno.record.reader import Recording
from shockdyno.record.types import TestMeta

SCHEMA_VERSION = 1


class InfoTest(TypedDict):
    """One test's row of `info --json`: its setting, motion and status, damage, sample count and
    rate (Hz), DAQ times and duration (s), frames lost and damaged, the gas force (N) and where
    it came from, a stroke's velocity (m/s) and reversal acceleration (m/s²), and each adjuster's
    clicks."""

    index: int
    clicks: int
    gas_clicks: int
    frequency_hz: float
    amplitude_m: float
    motion: str
    status: str
    damage: str | None
    samples: int
    sample_rate_hz: float
    t_start_s: float | None
    t_end_s: float | None
    duration_s: float | None
    dropped_frames: int | None
    corrupt_frames: int | None
    gas_force_n: float | None
    gas_force_source: str | None
    target_velocity_m_s: float | None
    reversal_accel_m_s2: float | None
    adjusters: NotRequired[dict[str, int]]  # a damper with several adjusters only


class FileRow(TypedDict):
    """One file of the recording's set in `info --json`: size, whether it was cut off and what is
    wrong with it, and its unreadable chunks and messages."""

    path: str
    size_bytes: int
    truncated: bool
    problem: str | None
    bad_chunks: int
    bad_messages: int


class ForeignPart(TypedDict):
    """A file beside the recording that looks like a part of its set but is not, and why."""

    path: str
    why: str


class Totals(TypedDict):
    """The recording's totals in `info --json`: tests by how they ended, samples, duration (s)
    and frames lost and damaged."""

    tests: int
    complete: int
    aborted: int
    damaged: int
    interrupted: int
    samples: int
    duration_s: float
    dropped_frames: int
    corrupt_frames: int


class Event(TypedDict):
    """A session event in `info --json`: DAQ time (s), kind and message."""

    t_s: float
    kind: str
    message: str


class Info(TypedDict):
    """The `info --json` document (recordings/FORMAT.md)."""

    schema_version: int
    path: str
    truncated: bool
    files: list[FileRow]
    metadata: dict[str, str]
    identity: dict[str, str]
    foreign_parts: list[ForeignPart]
    rig_file_attached: bool
    totals: Totals
    tests: list[InfoTest]
    interrupted: list[InfoTest]
    event_counts: dict[str, int]
    events: list[Event]


def _test_row(rec: Recording, meta: TestMeta) -> InfoTest:
    block = rec.samples(meta)
    n = len(block)
    t0 = float(block.t_s[0]) if n else None
    t1 = float(block.t_s[-1]) if n else None
    row: InfoTest = {
        "index": meta.index,
        "clicks": meta.clicks,
        "gas_clicks": meta.gas_clicks,
        "frequency_hz": meta.frequency_hz,
        "amplitude_m": meta.amplitude_m,
        "motion": meta.motion,
        "status": meta.status,
        # Why a test is `damaged` (its samples read back are not those it wrote), else None.
        "damage": meta.extra.get("damage") if meta.status == "damaged" else None,
        "samples": n,
        "sample_rate_hz": meta.sample_rate_hz,
        "t_start_s": t0,
        "t_end_s": t1,
        "duration_s": None if t0 is None or t1 is None else t1 - t0,
        "dropped_frames": meta.dropped_frames,
        "corrupt_frames": meta.corrupt_frames,
        "gas_force_n": meta.gas_force_n,  # as stored (None: not measured)
        "gas_force_source": meta.gas_force_source,
        # A constant-velocity test's (motion triangle | trapezoid); None for a sine.
        "target_velocity_m_s": meta.target_velocity_m_s,
        "reversal_accel_m_s2": meta.reversal_accel_m_s2,
    }
    if meta.adjusters:  # the last key, as before
        row["adjusters"] = dict(meta.adjusters)
    return row


def summarise(rec: Recording) -> Info:
    """The `info --json` document (documented in recordings/FORMAT.md)."""
    tests = [_test_row(rec, m) for m in rec.tests]
    interrupted = [_test_row(rec, m) for m in rec.interrupted]
    kinds = Counter(kind for _, kind, _ in rec.events)
    return {
        "schema_version": SCHEMA_VERSION,
        "path": str(rec.path),
        "truncated": rec.truncated,
        "files": [
            {
                "path": str(p.path),
                "size_bytes": p.size_bytes,
                "truncated": p.truncated,
                "problem": p.problem,
                "bad_chunks": p.bad_chunks,
                "bad_messages": p.bad_messages,
            }
            for p in rec.parts
        ],
        "metadata": rec.metadata,
        "identity": rec.identity,
        "foreign_parts": [{"path": str(p), "why": why} for p, why in rec.foreign],
        "rig_file_attached": rec.rig_toml is not None,
        "totals": {
            "tests": len(tests),
            "complete": sum(t["status"] == "complete" for t in tests),
            "aborted": sum(t["status"] == "aborted" for t in tests),
            "damaged": sum(t["status"] == "damaged" for t in tests),
            "interrupted": len(interrupted),
            "samples": sum(t["samples"] for t in tests),
            "duration_s": sum(t["duration_s"] or 0.0 for t in tests),
            "dropped_frames": sum(t["dropped_frames"] or 0 for t in tests),
            "corrupt_frames": sum(t["corrupt_frames"] or 0 for t in tests),
        },
        "tests": tests,
        "interrupted": interrupted,
        "event_counts": dict(sorted(kinds.items())),
        "events": [{"t_s": t, "kind": k, "message": m} for t, k, m in rec.events],
    }


def _opt(v: int | None) -> str:
    return "-" if v is None else str(v)


def format_text(doc: Info, max_events: int = 20) -> str:
    """The `info` document as the text `shockdyno info` prints: files, metadata, totals, each
    test, and the first `max_events` events."""
    lines = [f"recording {doc['path']}"]
    for f in doc["files"]:
        state = "TRUNCATED: " + (f["problem"] or "") if f["truncated"] else "complete file"
        if not f["truncated"] and f["problem"]:
            state += f" ({f['problem']})"
        if f["bad_messages"]:
            state += f"; {f['bad_messages']} messages could not be read"
        lines.append(f"  file {f['path']}: {f['size_bytes']} bytes, {state}")
    for part in doc["foreign_parts"]:
        lines.append(f"  NOT PART OF THIS RECORDING, not read: {part['path']} ({part['why']})")
    for k, v in doc["metadata"].items():
        lines.append(f"  {k}: {v}")
    lines.append(f"  rig file attached: {'yes' if doc['rig_file_attached'] else 'no'}")
    tot = doc["totals"]
    lines.append(
        f"tests: {tot['tests']} ({tot['complete']} complete, {tot['aborted']} aborted, "
        f"{tot['damaged']} damaged), "
        f"{tot['interrupted']} interrupted; {tot['samples']} samples, {tot['duration_s']:.1f} s; "
        f"dropped frames {tot['dropped_frames']}, corrupt frames {tot['corrupt_frames']}"
    )
    head = f"{'#':>4} {'clicks':>6} {'gas':>4} {'f Hz':>6} {'ampl mm':>8} {'motion':>8} "
    head += f"{'status':>11} {'samples':>8} {'dur s':>7} {'dropped':>7} {'corrupt':>7}"
    if doc["tests"] or doc["interrupted"]:
        lines.append(head)
    for t in doc["tests"] + doc["interrupted"]:
        dur = "-" if t["duration_s"] is None else f"{t['duration_s']:.2f}"
        lines.append(
            f"{t['index']:>4} {t['clicks']:>6} {t['gas_clicks']:>4} {t['frequency_hz']:>6g} "
            f"{t['amplitude_m'] * 1e3:>8.2f} {t['motion']:>8} {t['status']:>11} "
            f"{t['samples']:>8} {dur:>7} {_opt(t['dropped_frames']):>7} "
            f"{_opt(t['corrupt_frames']):>7}"
        )
        if t.get("adjusters"):  # a damper with several: every adjuster's clicks
            lines.append(
                f"{'':>4} adjusters: " + ", ".join(f"{n} {v}" for n, v in t["adjusters"].items())
            )
        if t["damage"]:
            lines.append(f"{'':>4} DAMAGED: {t['damage']}; left out of fit and diagnose")
    if doc["event_counts"]:
        counts = ", ".join(f"{k} {n}" for k, n in doc["event_counts"].items())
        lines.append(f"events: {counts}")
        for e in doc["events"][:max_events]:
            lines.append(f"  {e['t_s']:10.3f} s  {e['kind']}: {e['message']}")
        if len(doc["events"]) > max_events:
            lines.append(f"  ... {len(doc['events']) - max_events} more (see --json)")
    return "\n".join(lines)
