"""Crash-safe MCAP recording writer.

Every `end_test` closes the current MCAP chunk, flushes it and fsyncs the file, so a completed
test survives kill -9 or power loss; only the test in progress is at risk.

A recording that replaces another (`replaces=`, `sweep --force`) is written beside it under
its own name and takes the old one's place (and removes the old set's part files, only
those that belong to it) when its first test completes: a sweep whose rig or first test
fails leaves the old recording as it was. The file a writer creates is locked by its inode
(record/lock.py) for as long as the writer has it open. Each new recording gets a `set_id`
(metadata), which the parts of a resumed sweep carry too (record/reader.py). Small sample blocks
are coalesced into messages of up to `max_block_samples` samples: fewer, larger messages write
and decode faster (figures in recordings/FORMAT.md).

Message log_time is wall-clock time (so Foxglove's timeline shows when the test ran) while the
payloads keep the DAQ time base: log_time = wall-clock origin + t_s, the origin being the host
clock at the first sample minus that sample's t_s, recorded as metadata `shockdyno.clock`.
"""

from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import signal
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from types import TracebackType
from typing import IO, ParamSpec, TypeVar

import numpy as np
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer
from numpy.typing import NDArray

from shockdyno import __version__
from shockdyno.errors import RecordingError
from shockdyno.record import schemas as s
from shockdyno.record.layout import next_part_path
from shockdyno.record.lock import lock_file
from shockdyno.record.reader import part_metadata, set_members
from shockdyno.record.types import TestMeta
from shockdyno.samples import SampleBlock

_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


_GUARDED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
P = ParamSpec("P")
R = TypeVar("R")


def _whole_records(method: Callable[P, R]) -> Callable[P, R]:
    """Hold Ctrl-C, SIGTERM and SIGHUP until the call returns: an exception that lands
    half-way through an MCAP record would tear it and cost its whole chunk. A signal caught
    meanwhile goes to its own handler after the call (which may raise)."""

    @functools.wraps(method)
    def guarded(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return _held(*args, **kwargs)
        except OSError as exc:  # a full disk, a pulled USB stick: name the file
            path = getattr(args[0], "path", "the recording") if args else "the recording"
            raise RecordingError(
                f"cannot write {path} ({exc.strerror or exc}); what was written before is kept"
            ) from None

    def _held(*args: P.args, **kwargs: P.kwargs) -> R:
        if threading.current_thread() is not threading.main_thread():
            return method(*args, **kwargs)
        handlers = {sig: signal.getsignal(sig) for sig in _GUARDED}
        live = {sig: h for sig, h in handlers.items() if callable(h)}
        caught: list[int] = []
        for sig in live:
            signal.signal(sig, lambda signum, frame: caught.append(signum))
        try:
            result = method(*args, **kwargs)
        finally:
            for sig, h in live.items():
                signal.signal(sig, h)
        for signum in caught:
            live[signal.Signals(signum)](signum, None)
        return result

    return guarded


def _ns(t_s: float) -> int:
    """Nanoseconds of a time on the DAQ time base."""
    if not math.isfinite(t_s):
        raise RecordingError(f"time {t_s!r} is not finite")
    return round(t_s * 1e9)


def _create(base: Path, overwrite: bool, resume: bool) -> tuple[Path, int, str, IO[bytes]]:
    """The file a writer writes (`base`, or with `resume` the set's next part), created
    (over `base` and its parts only with `overwrite`) and locked; its part number and the
    set's id (a new one unless resumed)."""
    part = 1
    target = base
    if resume:
        target, part = next_part_path(base)
    elif base.exists() and not overwrite:
        raise RecordingError(f"{base} exists (overwrite it explicitly, or resume into it)")
    set_id = part_metadata(base).get("set_id", "") if resume else uuid.uuid4().hex
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        if overwrite:
            for stale in set_members(base)[1:]:  # its own parts, not another recording
                stale.unlink()
        file: IO[bytes] = open(target, "wb" if overwrite else "xb")  # noqa: SIM115
    except FileExistsError as exc:
        raise RecordingError(f"{target} exists") from exc
    except OSError as exc:
        raise RecordingError(f"cannot create {target}: {exc.strerror}") from exc
    try:
        lock_file(target, file.fileno(), target)
    except RecordingError:
        file.close()
        raise
    return target, part, set_id, file


def _recording_metadata(metadata: dict[str, str], part: int, set_id: str) -> dict[str, str]:
    meta = {str(k): str(v) for k, v in metadata.items()}
    meta.setdefault("software", f"shockdyno {__version__}")
    meta["format_version"] = s.FORMAT_VERSION
    meta["part"] = str(part)
    if set_id:  # a resumed set from before set ids has none: its parts have none either
        meta["set_id"] = set_id
    else:
        meta.pop("set_id", None)
    return meta


def _start(
    mcap: Writer, meta: dict[str, str], identity: dict[str, str] | None, rig_toml: str | None
) -> tuple[int, int, int, int]:
    """The file's header, metadata, rig attachment and channels; the channels' ids
    (samples, test, actuator, events)."""
    mcap.start(profile="", library=f"shockdyno {__version__}")
    mcap.add_metadata(s.METADATA_NAME, meta)
    if identity:
        mcap.add_metadata(s.IDENTITY_METADATA_NAME, dict(identity))
    if rig_toml is not None:
        mcap.add_attachment(0, 0, s.RIG_ATTACHMENT, "application/toml", rig_toml.encode())
    # Registered in this order, so channel ids are always those of schemas.CHANNEL_IDS
    return (
        _channel(
            mcap,
            s.TOPIC_SAMPLES,
            s.SAMPLES_SCHEMA_NAME,
            SchemaEncoding.ROS2,
            s.SAMPLES_SCHEMA.encode(),
            MessageEncoding.CDR,
        ),
        _json_channel(mcap, s.TOPIC_TEST, s.TEST_SCHEMA_NAME, s.TEST_SCHEMA),
        _json_channel(mcap, s.TOPIC_ACTUATOR, s.ACTUATOR_SCHEMA_NAME, s.ACTUATOR_SCHEMA),
        _json_channel(mcap, s.TOPIC_EVENTS, s.EVENT_SCHEMA_NAME, s.EVENT_SCHEMA),
    )


def _channel(mcap: Writer, topic: str, name: str, enc: str, data: bytes, msg_enc: str) -> int:
    schema_id = mcap.register_schema(name=name, encoding=enc, data=data)
    return mcap.register_channel(topic=topic, message_encoding=msg_enc, schema_id=schema_id)


def _json_channel(mcap: Writer, topic: str, name: str, schema: bytes) -> int:
    return _channel(mcap, topic, name, SchemaEncoding.JSONSchema, schema, MessageEncoding.JSON)


class RecordingWriter:
    """Write one recording (or, with resume=True, the next part file of a recording set).

    `path` is NAME.mcap. An existing file is never overwritten unless overwrite=True (which also
    removes the set's part files). With resume=True and NAME.mcap present, writing goes to the
    next free NAME.partN.mcap; `open_recording(NAME.mcap)` reads the whole set. With
    `replaces=OLD.mcap`, `path` (a new file beside it) replaces the set at OLD.mcap when its
    first complete test ends (`replaced` then says so, and `path` is OLD.mcap).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        metadata: dict[str, str],
        rig_toml: str | None = None,
        overwrite: bool = False,
        resume: bool = False,
        max_block_samples: int = 1000,
        compression: str = "zstd",
        chunk_size: int = 1 << 20,
        wall_clock_origin_ns: int | None = None,
        replaces: Path | None = None,
        identity: dict[str, str] | None = None,
    ) -> None:
        if compression not in _COMPRESSION:
            raise RecordingError(f"unknown compression {compression!r}")
        if overwrite and resume:
            raise RecordingError("overwrite and resume exclude each other")
        target, part, set_id, self._file = _create(Path(path), overwrite, resume)
        self.path = target
        self.part = part
        self.replaces = replaces
        self.replaced = False
        self.tests_begun = 0
        self._max_block = max(1, int(max_block_samples))
        try:
            self._mcap = Writer(
                self._file, chunk_size=chunk_size, compression=_COMPRESSION[compression]
            )
            meta = _recording_metadata(metadata, part, set_id)
            channels = _start(self._mcap, meta, identity, rig_toml)
            self._ch_samples, self._ch_test, self._ch_act, self._ch_event = channels
        except OSError as exc:  # a full disk at the first write: nothing of it is kept
            self._abandon(target)
            raise RecordingError(f"cannot write {target} ({exc.strerror or exc})") from None
        self._seq = 0
        self._test_serial = -1
        self._open: TestMeta | None = None
        self._pending: list[SampleBlock] = []
        self._pending_n = 0
        self._last_t = 0.0
        self._last_seq: int | None = None
        self._gaps = 0
        self._count = 0
        self._closed = False
        # (t, x) of the last samples written in this test: context for the next velocity
        self._vel_tail: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        self._origin_ns: int | None = None
        if wall_clock_origin_ns is not None:
            self._set_origin(int(wall_clock_origin_ns), "given by the caller")
        try:
            self._sync()
        except RecordingError:
            self._abandon(target)
            raise

    def _abandon(self, target: Path) -> None:
        """Close and remove a file the writer could not even start (a full disk)."""
        with contextlib.suppress(OSError):  # its buffer cannot be written either
            self._file.close()
        target.unlink(missing_ok=True)

    # -- low-level writes ---------------------------------------------------------------------

    def _set_origin(self, origin_ns: int, source: str) -> None:
        self._origin_ns = origin_ns
        clock = {"wall_clock_origin_ns": str(origin_ns), "source": source}
        self._mcap.add_metadata(s.CLOCK_METADATA_NAME, clock)

    def _emit(self, channel: int, t_s: float, data: bytes) -> None:
        # Before the first sample fixes the origin (setup events), host time is the best guess.
        log_time = time.time_ns() if self._origin_ns is None else self._origin_ns + _ns(t_s)
        log_time = max(0, log_time)
        self._mcap.add_message(channel, log_time, data, log_time, self._seq)
        self._seq += 1

    def _emit_json(self, channel: int, t_s: float, obj: Mapping[str, object]) -> None:
        try:
            data = json.dumps(obj, allow_nan=False).encode()
        except ValueError as exc:  # NaN or infinity in a metadata field
            raise RecordingError(f"cannot record {obj}: {exc}") from exc
        self._emit(channel, t_s, data)

    def _sync(self) -> None:
        """Close the open chunk and push everything to the disk."""
        try:
            self._mcap.flush()  # type: ignore[no-untyped-call]
            os.fsync(self._file.fileno())
        except OSError as exc:
            raise RecordingError(f"cannot write {self.path}: {exc.strerror}") from exc

    def _check_open(self) -> None:
        if self._closed:
            raise RecordingError(f"{self.path} is closed")

    @property
    def _test_field(self) -> int | None:
        return self._test_serial if self._open is not None else None

    # -- the recording API ------------------------------------------------------------------

    @_whole_records
    def begin_test(self, meta: TestMeta) -> None:
        """Open the next test: its metadata written as the test channel's begin record;
        RecordingError while another test is open."""
        self._check_open()
        if self._open is not None:
            raise RecordingError(f"test {self._open.index} is still open (call end_test first)")
        self._flush_samples()
        self._vel_tail = None
        self._test_serial += 1
        self.tests_begun += 1
        self._open = meta
        self._last_seq = None
        self._gaps = 0
        self._count = 0
        record = {"phase": "begin", "test": self._test_serial, "t_s": self._last_t}
        self._emit_json(self._ch_test, self._last_t, {**record, **s.meta_to_json(meta)})

    @_whole_records
    def write_samples(self, block: SampleBlock) -> None:
        """Add a block of samples (to the open test, or between tests), written in chunks with a
        display velocity (m/s, central difference) beside them."""
        self._check_open()
        n = len(block)
        if n == 0:
            return
        arrays = (block.t_s, block.displacement_m, block.force_n, block.temperature_c)
        if any(a.shape != (n,) for a in (*arrays, block.status)):
            raise RecordingError("SampleBlock arrays differ in length")
        if self._open is not None:
            self._gaps += block.frames_missing(self._last_seq)
            self._last_seq = int(block.seq[-1])
            self._count += n
        if self._origin_ns is None:
            self._set_origin(
                time.time_ns() - _ns(float(block.t_s[0])), "host clock at the first sample"
            )
        self._pending.append(block)
        self._pending_n += n
        self._last_t = float(block.t_s[-1])
        if self._pending_n >= self._max_block:
            self._flush_samples()

    def _flush_samples(self) -> None:
        if not self._pending:
            return
        merged = self._pending[0] if len(self._pending) == 1 else SampleBlock.concat(self._pending)
        self._pending = []
        self._pending_n = 0
        test = self._test_serial if self._open is not None else s.NO_TEST
        # Velocity over the previous message's last samples too, so it is continuous across
        # messages; the tail is dropped at each test boundary.
        t, x = merged.t_s, merged.displacement_m
        if self._vel_tail is not None:
            t = np.concatenate((self._vel_tail[0], t))
            x = np.concatenate((self._vel_tail[1], x))
        velocity = s.display_velocity(t, x)[len(t) - len(merged) :]
        self._vel_tail = (t[-4:], x[-4:])
        step = self._max_block
        for lo in range(0, len(merged), step):
            part = merged.slice(lo, lo + step) if len(merged) > step else merged
            data = s.encode_samples(test, part, velocity[lo : lo + step])
            self._emit(self._ch_samples, float(part.t_s[0]), data)

    @_whole_records
    def write_actuator(self, t_s: float, fields: dict[str, float | int | bool | str]) -> None:
        """Record the drive's fields at DAQ time `t_s` (s), tagged with the open test."""
        self._check_open()
        obj: dict[str, object] = {"t_s": float(t_s), "test": self._test_field}
        for k, v in fields.items():
            if k in obj:
                raise RecordingError(f"actuator field {k!r} is reserved")
            if isinstance(v, float) and not math.isfinite(v):
                v = str(v)  # JSON has no NaN; keep the value readable
            obj[k] = v
        self._emit_json(self._ch_act, t_s, obj)

    @_whole_records
    def write_event(self, t_s: float, kind: str, message: str) -> None:
        """Record an event; when this returns it is on disk (a kill -9 after it keeps it)."""
        self._check_open()
        obj = {"t_s": float(t_s), "test": self._test_field, "kind": kind, "message": message}
        self._emit_json(self._ch_event, t_s, obj)
        self._flush_samples()
        self._sync()

    @_whole_records
    def end_test(self, meta: TestMeta) -> None:
        """Record the final meta; when this returns the test is on disk."""
        self._check_open()
        if self._open is None:
            raise RecordingError("end_test without begin_test")
        self._flush_samples()
        if meta.dropped_frames is None:
            meta = replace(meta, dropped_frames=self._gaps)
        record = {
            "phase": "end",
            "test": self._test_serial,
            "t_s": self._last_t,
            "sample_count": self._count,
        }
        self._emit_json(self._ch_test, self._last_t, {**record, **s.meta_to_json(meta)})
        self._open = None
        self._vel_tail = None
        self._sync()
        if self.replaces is not None and meta.status == "complete":
            self._take_the_place_of(self.replaces)

    def _take_the_place_of(self, old: Path) -> None:
        """This recording's first test is complete and on disk: it becomes `old`, and the
        old set's part files go (a crash between the two leaves them as parts of another
        set, which the reader leaves out and names)."""
        stale = set_members(old)[1:]
        try:
            os.replace(self.path, old)
            for p in stale:
                p.unlink(missing_ok=True)
            dir_fd = os.open(old.parent, os.O_RDONLY)
            try:
                os.fsync(dir_fd)
            finally:
                os.close(dir_fd)
        except OSError as exc:
            raise RecordingError(
                f"cannot put {self.path} in place of {old} ({exc.strerror}); both are kept"
            ) from None
        self.path, self.replaces, self.replaced = old, None, True

    def discard(self) -> None:
        """Close and remove the file: nothing in it is worth keeping (the session never
        started). Only a file with no test begun is removed."""
        self.close()
        if self.tests_begun == 0 and not self.replaced:
            self.path.unlink(missing_ok=True)

    @_whole_records
    def close(self) -> None:
        """Finish the file. A test still open is ended as aborted, keeping its samples."""
        if self._closed:
            return
        try:
            if self._open is not None:
                begun = self._open
                why = "recording closed during the test"
                self.end_test(replace(begun, status="aborted", abort_reason=why))
            self._flush_samples()
            self._mcap.finish()  # type: ignore[no-untyped-call]
            self._sync()
        finally:
            self._closed = True
            self._file.close()

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
