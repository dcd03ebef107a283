"""Channel schemas and message codecs of a shockdyno MCAP recording (see recordings/FORMAT.md).

Samples are ROS 2 CDR (schema encoding `ros2msg`) so Foxglove and the `mcap` CLI decode them
without our code, while our reader slices the same bytes straight into NumPy arrays: every
array in the message is a plain CDR sequence of a fixed-size primitive, so its position follows
from the sample count alone. Low-rate channels (test metadata, actuator, events) are JSON with
a JSON Schema: readable by eye and by every MCAP tool.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import asdict, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shockdyno.errors import RecordingError
from shockdyno.record.types import TestMeta
from shockdyno.samples import SampleBlock

FORMAT_VERSION = "2"  # 2: SampleBlock2 (velocity_m_s), wall-clock log_time
METADATA_NAME = "shockdyno.recording"
CLOCK_METADATA_NAME = "shockdyno.clock"  # wall_clock_origin_ns: log_time = origin + t_s
# What a sweep's set is a measurement of (rig set-up, plan), kept apart from the
# recording's metadata, which pages and `info` show: a resumed part must match it.
IDENTITY_METADATA_NAME = "shockdyno.identity"
RIG_ATTACHMENT = "rig.toml"

TOPIC_SAMPLES = "/dyno/samples"
TOPIC_TEST = "/dyno/test"
TOPIC_ACTUATOR = "/dyno/actuator"
TOPIC_EVENTS = "/dyno/events"

# Channel ids our writer always assigns; the reader falls back on them when the chunk that
# defined the channels is damaged.
CHANNEL_IDS = {1: TOPIC_SAMPLES, 2: TOPIC_TEST, 3: TOPIC_ACTUATOR, 4: TOPIC_EVENTS}

NO_TEST = 0xFFFFFFFF  # `test` field of samples written outside any test

SAMPLES_SCHEMA_NAME = "shockdyno/msg/SampleBlock2"
SAMPLES_SCHEMA = """\
# A block of consecutive DAQ samples in SI units (x > 0 compression, force > 0 resists it).
# Message log_time is the first sample's wall-clock time: the recording's wall-clock origin
# (metadata shockdyno.clock) + t_s. t_s, the DAQ counter's time, is the time base for analysis.
uint32 test              # writer's test serial within this file (see /dyno/test); 4294967295: none
int64[] seq              # DAQ sequence numbers, unwrapped; gaps are dropped frames
float64[] t_s            # sample time on the DAQ time base, s (from the time column when imported)
float64[] displacement_m
float64[] force_n
float64[] temperature_c  # NaN when not measured
float32[] velocity_m_s   # dx/dt for display (5-point central difference); analysis recomputes it
uint16[] status          # DAQ status bits per sample
"""

# Format 1 (shockdyno 0.1.0): the same block without velocity_m_s. Still read.
SAMPLES_V1_SCHEMA_NAME = "shockdyno/msg/SampleBlock"

_CDR_LE = b"\x00\x01\x00\x00"  # encapsulation header: plain CDR, little endian
_HEAD = struct.Struct("<II")
_LEN_PAD = struct.Struct("<I4x")  # sequence length, then padding to the 8-byte-aligned elements
_LEN = struct.Struct("<I")


def encode_samples(test: int, block: SampleBlock, velocity_m_s: NDArray[np.floating]) -> bytes:
    """CDR bytes of one SampleBlock2 message (layout: recordings/FORMAT.md)."""
    n = len(block)
    return b"".join(
        (
            _CDR_LE,
            _HEAD.pack(test, n),
            np.ascontiguousarray(block.seq, "<i8").tobytes(),
            _LEN_PAD.pack(n),
            np.ascontiguousarray(block.t_s, "<f8").tobytes(),
            _LEN_PAD.pack(n),
            np.ascontiguousarray(block.displacement_m, "<f8").tobytes(),
            _LEN_PAD.pack(n),
            np.ascontiguousarray(block.force_n, "<f8").tobytes(),
            _LEN_PAD.pack(n),
            np.ascontiguousarray(block.temperature_c, "<f8").tobytes(),
            _LEN.pack(n),
            np.ascontiguousarray(velocity_m_s, "<f4").tobytes(),
            _LEN.pack(n),
            np.ascontiguousarray(block.status, "<u2").tobytes(),
        )
    )


def samples_size(n: int, version: int = 2) -> int:
    """The size (bytes) of an encoded block of `n` samples in layout `version` (1 or 2)."""
    return 52 + 46 * n if version == 2 else 48 + 42 * n


def samples_header(data: bytes) -> tuple[int, int, int]:
    """(test serial, sample count, layout version) of an encoded sample block.

    The two layouts differ in size for every sample count, so the size alone tells them apart;
    the reader needs no Schema record (which may sit in a damaged chunk).
    """
    if len(data) < 48 or data[:2] != _CDR_LE[:2]:
        raise RecordingError("sample message is not little-endian CDR")
    test, n = _HEAD.unpack_from(data, 4)
    for version in (2, 1):
        if len(data) == samples_size(n, version):
            return test, n, version
    raise RecordingError(f"sample message of {len(data)} bytes cannot hold {n} samples")


# Byte offset of each array in a message holding n samples: (name, dtype, a + b * n), per
# layout version. Velocity is display-only and not read back (SampleBlock has no velocity).
_ARRAYS_V1: tuple[tuple[str, str, int, int], ...] = (
    ("seq", "<i8", 12, 0),
    ("t_s", "<f8", 20, 8),
    ("displacement_m", "<f8", 28, 16),
    ("force_n", "<f8", 36, 24),
    ("temperature_c", "<f8", 44, 32),
    ("status", "<u2", 48, 40),
)
_ARRAYS = {1: _ARRAYS_V1, 2: (*_ARRAYS_V1[:5], ("status", "<u2", 52, 44))}


def decode_samples(payloads: list[bytes]) -> SampleBlock:
    """Concatenate encoded sample blocks into one SampleBlock (copies once, no per-sample loop)."""
    headers = [samples_header(p) for p in payloads]
    total = sum(n for _, n, _ in headers)
    out: dict[str, NDArray[Any]] = {  # Any: each column's own dtype (_ARRAYS_V1)
        name: np.empty(total, dtype) for name, dtype, _, _ in _ARRAYS_V1
    }
    pos = 0
    for data, (_, n, version) in zip(payloads, headers, strict=True):
        for name, dtype, a, b in _ARRAYS[version]:
            out[name][pos : pos + n] = np.frombuffer(data, dtype, n, a + b * n)
        pos += n
    return SampleBlock(
        seq=out["seq"].astype(np.int64, copy=False),
        t_s=out["t_s"].astype(np.float64, copy=False),
        displacement_m=out["displacement_m"].astype(np.float64, copy=False),
        force_n=out["force_n"].astype(np.float64, copy=False),
        temperature_c=out["temperature_c"].astype(np.float64, copy=False),
        status=out["status"].astype(np.uint16, copy=False),
    )


def display_velocity(
    t_s: NDArray[np.floating], x_m: NDArray[np.floating], k: int = 2
) -> NDArray[np.float32]:
    """dx/dt by central difference over +-k samples (+-1 and one-sided near the ends), float32.

    A display quantity for Foxglove's F-v plots: wide enough to tame DAQ quantisation noise at
    1 kHz, short enough to add no visible lag. Whatever the input (repeated times, huge values
    from an import), the result is finite or NaN, never an error or a warning.
    """
    n = len(x_m)
    v = np.full(n, np.nan)
    with np.errstate(all="ignore"):
        if n >= 2 and np.all(np.diff(t_s) > 0):
            v = np.gradient(x_m, t_s)
            if n > 2 * k:
                v[k:-k] = (x_m[2 * k :] - x_m[: -2 * k]) / (t_s[2 * k :] - t_s[: -2 * k])
        out = v.astype(np.float32)
    out[~np.isfinite(out)] = np.nan
    return out


def _json_schema(title: str, properties: dict[str, object], **more: object) -> bytes:
    schema: dict[str, object] = {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
    }
    schema.update(type="object", properties=properties, **more)
    return json.dumps(schema, indent=1).encode()


_NUM = {"type": "number"}
_INT = {"type": "integer"}
_STR = {"type": "string"}
_OPT_NUM = {"type": ["number", "null"]}
_OPT_INT = {"type": ["integer", "null"]}

TEST_SCHEMA_NAME = "shockdyno.TestMeta"
TEST_SCHEMA = _json_schema(
    TEST_SCHEMA_NAME,
    {
        "phase": {"enum": ["begin", "end"]},
        "test": {**_INT, "description": "writer's test serial; matches SampleBlock.test"},
        "t_s": {**_NUM, "description": "time of this record on the DAQ time base, s"},
        "sample_count": _INT,
        "index": _INT,
        "clicks": _INT,
        "gas_clicks": _INT,
        "frequency_hz": _NUM,
        "amplitude_m": _NUM,
        "sample_rate_hz": _NUM,
        "warmup_cycles": _INT,
        "measured_cycles": _INT,
        "motion": _STR,
        "measured_start_s": _OPT_NUM,
        "measured_end_s": _OPT_NUM,
        "status": _STR,
        "extra": {"type": "object", "additionalProperties": _STR},
        "cycle_start_s": {"type": "array", "items": _NUM},
        "dropped_frames": _OPT_INT,
        "corrupt_frames": _OPT_INT,
        "gas_pressure_pa": {**_OPT_NUM, "description": "gas charge, absolute Pa"},
        "abort_reason": {"type": ["string", "null"]},
        "start_temperature_c": _OPT_NUM,
        "gas_force_n": {**_OPT_NUM, "description": "static gas force at mid-stroke, N"},
        "gas_force_source": {"enum": ["measured", "estimated", None]},
        "target_velocity_m_s": {
            **_NUM,
            "description": "constant-velocity test (motion triangle | trapezoid): v, m/s",
        },
        "reversal_accel_m_s2": {**_NUM, "description": "trapezoid: reversal acceleration"},
    },
    required=["phase", "test", "index", "clicks", "gas_clicks", "frequency_hz", "amplitude_m"],
)

ACTUATOR_SCHEMA_NAME = "shockdyno.Actuator"
ACTUATOR_SCHEMA = _json_schema(
    ACTUATOR_SCHEMA_NAME,
    {"t_s": _NUM, "test": _OPT_INT},
    required=["t_s"],
    additionalProperties={"type": ["number", "integer", "boolean", "string"]},
    description="Actuator command or status: t_s, test, then the fields the runner sends.",
)

EVENT_SCHEMA_NAME = "shockdyno.Event"
EVENT_SCHEMA = _json_schema(
    EVENT_SCHEMA_NAME,
    {"t_s": _NUM, "test": _OPT_INT, "kind": _STR, "message": _STR},
    required=["t_s", "kind", "message"],
    description="Safety event, fault or operator prompt.",
)


# Written only when set: a sine's record keeps the keys it always had.
_ONLY_WHEN_SET = ("target_velocity_m_s", "reversal_accel_m_s2")


def meta_to_json(meta: TestMeta) -> dict[str, object]:
    """A test's metadata as the recording's test channel stores it (keys a sine does not use, and
    an empty adjuster setting, left out)."""
    d = asdict(meta)
    d["cycle_start_s"] = [float(v) for v in meta.cycle_start_s]
    for key in _ONLY_WHEN_SET:
        if d[key] is None:
            del d[key]
    if not meta.adjusters:  # a test of the one rod adjuster is written as it always was
        del d["adjusters"]
    return d


_META_FIELDS = {f.name for f in fields(TestMeta)}
# What each field of a test record must be: a record that says otherwise (a frequency of
# "fast") is a bad message, counted, never a TypeError in whatever reads it later.
_INTS = ("index", "clicks", "gas_clicks", "warmup_cycles", "measured_cycles")
_NUMBERS = ("frequency_hz", "amplitude_m", "sample_rate_hz")
_OPTIONAL_INTS = ("dropped_frames", "corrupt_frames")
_OPTIONAL_NUMBERS = (
    "measured_start_s",
    "measured_end_s",
    "gas_pressure_pa",
    "start_temperature_c",
    "gas_force_n",
    "target_velocity_m_s",
    "reversal_accel_m_s2",
)
_TEXTS = ("motion", "status")
_OPTIONAL_TEXTS = ("abort_reason", "gas_force_source")


def _check_types(kw: dict[str, object]) -> None:
    def is_int(v: object) -> bool:
        return isinstance(v, int) and not isinstance(v, bool)

    def is_number(v: object) -> bool:
        return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)

    rules = (
        (_INTS, is_int, False, "a whole number"),
        (_NUMBERS, is_number, False, "a number"),
        (_OPTIONAL_INTS, is_int, True, "a whole number"),
        (_OPTIONAL_NUMBERS, is_number, True, "a number"),
        (_TEXTS, lambda v: isinstance(v, str), False, "text"),
        (_OPTIONAL_TEXTS, lambda v: isinstance(v, str), True, "text"),
    )
    for names, ok, optional, what in rules:
        for name in names:
            if name not in kw or (optional and kw[name] is None):
                continue
            if not ok(kw[name]):
                raise RecordingError(f"bad test record: {name} must be {what}, got {kw[name]!r}")


def _adjusters(value: object) -> dict[str, int]:
    if not isinstance(value, dict) or not all(
        isinstance(k, str) and isinstance(v, int) and not isinstance(v, bool) and v >= 0
        for k, v in value.items()
    ):
        raise RecordingError(
            f"bad test record: adjusters must map names to clicks >= 0, got {value!r}"
        )
    return dict(value)


def meta_from_json(d: dict[str, Any]) -> TestMeta:  # Any: json.loads's, checked here
    """TestMeta from a /dyno/test record; unknown keys (newer writers) are ignored, a
    field of the wrong type is a RecordingError."""
    kw = {k: v for k, v in d.items() if k in _META_FIELDS}
    _check_types(kw)
    try:
        kw["cycle_start_s"] = tuple(float(v) for v in kw.get("cycle_start_s", ()))
        extra = {str(k): str(v) for k, v in dict(kw.get("extra", {})).items()}
        # Recordings before the typed fields kept these as strings in `extra`.
        if kw.get("abort_reason") is None and "reason" in extra:
            kw["abort_reason"] = extra.pop("reason")
        if kw.get("start_temperature_c") is None and "start_temperature_c" in extra:
            kw["start_temperature_c"] = float(extra.pop("start_temperature_c"))
        if kw.get("gas_pressure_pa") is None and "gas_pressure_pa" in extra:
            kw["gas_pressure_pa"] = float(extra.pop("gas_pressure_pa"))
        stored = extra.pop("dropped_frames", "").strip()
        if stored.isdigit():
            kw["dropped_frames"] = max(int(stored), int(kw.get("dropped_frames") or 0))
        kw["extra"] = extra
        kw["adjusters"] = _adjusters(kw.get("adjusters", {}))
        return TestMeta(**kw)
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"bad test record: {exc}") from exc
