"""Every channel has a schema in a standard encoding, and the messages follow their schemas.

Checked with the `mcap` library's own indexed reader and with decoders written here from the
schema text alone (a ROS 2 CDR decoder driven by the ros2msg definition, and a JSON Schema
type check), so the file is readable by tools that know nothing of shockdyno.
"""

from __future__ import annotations

import json
import struct
import time
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader
from rec_helpers import SAMPLES_PER_TEST, block, seq_range, write_small

STANDARD = {("ros2msg", "cdr"), ("jsonschema", "json"), ("protobuf", "protobuf")}
PRIMITIVES = {
    "bool": "?",
    "int8": "b",
    "uint8": "B",
    "int16": "h",
    "uint16": "H",
    "int32": "i",
    "uint32": "I",
    "int64": "q",
    "uint64": "Q",
    "float32": "f",
    "float64": "d",
}


def decode_cdr(schema: str, data: bytes) -> dict[str, Any]:
    """Plain little-endian CDR of a ros2msg made of primitives and unbounded primitive arrays."""
    assert data[:4] == b"\x00\x01\x00\x00"
    origin, pos, out = 4, 4, {}
    for line in schema.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        typ, name = line.split()
        is_array = typ.endswith("[]")
        code = PRIMITIVES[typ.removesuffix("[]")]
        size = struct.calcsize(code)
        count = 1
        if is_array:
            pos += -(pos - origin) % 4
            (count,) = struct.unpack_from("<I", data, pos)
            pos += 4
        pos += -(pos - origin) % size
        values = struct.unpack_from(f"<{count}{code}", data, pos)
        pos += size * count
        out[name] = list(values) if is_array else values[0]
    assert pos == len(data), "message longer than its schema"
    return out


JSON_TYPES = {
    "number": (int, float),
    "integer": (int,),
    "string": (str,),
    "boolean": (bool,),
    "object": (dict,),
    "array": (list,),
    "null": (type(None),),
}


def check_json(schema: dict[str, Any], obj: dict[str, Any]) -> None:
    for key in schema.get("required", []):
        assert key in obj, key
    props = schema.get("properties", {})
    for key, value in obj.items():
        spec = props.get(key, schema.get("additionalProperties", {}))
        if "enum" in spec:
            assert value in spec["enum"], (key, value)
            continue
        types = spec.get("type")
        if types is None:
            continue
        allowed = tuple(t for name in np.atleast_1d(types) for t in JSON_TYPES[str(name)])
        assert isinstance(value, allowed), (key, value, types)


def test_every_channel_is_schemad_and_decodable_without_shockdyno(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    before = time.time_ns()
    write_small(path)
    after = time.time_ns()
    with open(path, "rb") as f:
        metadata = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
        origin = int(metadata["shockdyno.clock"]["wall_clock_origin_ns"])
        assert before <= origin <= after  # the first sample has t_s = 0
        f.seek(0)
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        channels = summary.channels.values()
        topics = {c.topic for c in channels}
        assert topics == {"/dyno/samples", "/dyno/test", "/dyno/actuator", "/dyno/events"}
        for c in channels:
            schema = summary.schemas[c.schema_id]
            assert c.schema_id != 0 and schema.data, c.topic
            assert (schema.encoding, c.message_encoding) in STANDARD, c.topic
        seen: dict[str, int] = {}
        samples: dict[int, list[dict[str, Any]]] = {}
        for schema, channel, message in reader.iter_messages():
            assert schema is not None
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
            if schema.encoding == "ros2msg":
                msg = decode_cdr(schema.data.decode(), message.data)
                samples.setdefault(msg["test"], []).append(msg)
                # Wall-clock time on Foxglove's timeline, DAQ time in the payload
                assert message.log_time == message.publish_time
                assert message.log_time == origin + round(msg["t_s"][0] * 1e9)
            else:
                check_json(json.loads(schema.data), json.loads(message.data))
        attachments = list(reader.iter_attachments())
        assert [a.name for a in attachments] == ["rig.toml"]
        assert attachments[0].media_type == "application/toml"
        assert metadata["shockdyno.recording"]["operator"] == "ana"
        assert metadata["shockdyno.recording"]["format_version"] == "2"
    assert seen["/dyno/test"] == 6 and seen["/dyno/events"] == 3 and seen["/dyno/actuator"] == 3
    for k in range(3):
        truth = block(seq_range(k)[0], SAMPLES_PER_TEST)
        got = {
            key: np.concatenate([m[key] for m in samples[k]])
            for key in samples[k][0]
            if key != "test"
        }
        assert np.array_equal(got["seq"], truth.seq)
        assert np.array_equal(got["force_n"], truth.force_n)
        assert np.array_equal(got["status"], truth.status)
        # velocity_m_s is dx/dt for display: the sine's derivative, to DAQ-plot accuracy
        # (one-sided at the ends of a test, continuous across messages)
        want_v = 0.03 * 2 * np.pi * np.cos(2 * np.pi * truth.t_s) + 1e-6
        assert np.max(np.abs(got["velocity_m_s"] - want_v)) < 1e-3  # 0.5 % of the peak


def test_a_given_wall_clock_origin_places_every_message(tmp_path: Path) -> None:
    """With the origin given (e.g. a DAQ with its own real-time clock), log_time is exactly
    origin + t_s for samples and the test records alike; the reader reports the origin."""
    from rec_helpers import meta

    from shockdyno.record import RecordingWriter, open_recording

    origin = 1_750_000_000_123_456_789
    path = tmp_path / "r.mcap"
    with RecordingWriter(path, metadata={}, wall_clock_origin_ns=origin) as w:
        w.begin_test(meta(0, 0))
        w.write_samples(block(5000, 1500))  # t_s from 5.0 s
        w.end_test(meta(0, 0, status="complete"))
    with open(path, "rb") as f:
        times = [(c.topic, m.log_time) for _, c, m in make_reader(f).iter_messages()]
    assert [t for topic, t in times if topic == "/dyno/samples"] == [
        origin + 5_000_000_000,
        origin + 6_000_000_000,
    ]
    assert times[-1] == ("/dyno/test", origin + 6_499_000_000)  # end record at the last sample
    assert open_recording(path).parts[0].wall_clock_origin_ns == origin
