"""Read a recording set (NAME.mcap and its part files) into NumPy, also when cut off mid-write.

The file is read front to back, chunk by chunk, without its summary section: a file cut off by
kill -9 or power loss has no summary, and every complete chunk before the cut is still good.
A chunk whose CRC fails is skipped and counted; reading goes on with the next one.

A test read back is checked against its own end record: the samples it wrote
(`sample_count`) must all be there, in order, with no gap beyond the frames its DAQ lost.
A test that fails is `damaged` (a skipped chunk, an undecodable message): `load_all` leaves
it out and `loss_note` names it, so an analysis never takes a part of a test for the whole,
and `completed_keys` does not count it, so `sweep --resume` runs it again.

A part file belongs to the set only when its identity says so (`set_id` in its metadata,
the first file's; before set ids, the same damper, operator and rig): a separate sweep
saved as NAME.part2.mcap is not merged into NAME.mcap's tests (`foreign` names it).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from mcap.exceptions import EndOfFile, InvalidMagic
from mcap.records import Attachment, Channel, Chunk, Footer, Message, Metadata
from mcap.stream_reader import StreamReader, breakup_chunk

from shockdyno.errors import RecordingError
from shockdyno.record import schemas as s
from shockdyno.record.layout import set_paths
from shockdyno.record.types import TestData, TestMeta
from shockdyno.result_files import starts_as_mcap
from shockdyno.samples import SampleBlock


@dataclass
class PartInfo:
    """What one file of the set held, and how it ended."""

    path: Path
    metadata: dict[str, str]
    truncated: bool = False
    problem: str | None = None  # why reading stopped early, or damage found
    bad_chunks: int = 0
    bad_messages: int = 0
    size_bytes: int = 0
    # Wall-clock time (ns since the Unix epoch) of t_s = 0: log_time = origin + t_s. None in
    # format 1 files, whose log_time is the DAQ time itself.
    wall_clock_origin_ns: int | None = None
    identity: dict[str, str] = field(default_factory=dict)  # shockdyno.identity, if any


@dataclass
class _PartData:
    info: PartInfo
    rig_toml: str | None = None
    begun: dict[int, TestMeta] = field(default_factory=dict)
    # (serial, meta, samples the writer wrote for it: None in files before the count)
    ended: list[tuple[int, TestMeta, int | None]] = field(default_factory=list)
    samples: dict[int, list[bytes]] = field(default_factory=dict)
    events: list[tuple[float, str, str]] = field(default_factory=list)
    # Any: the records' values as json.loads gives them (numbers, text, flags)
    actuator: list[tuple[float, dict[str, Any]]] = field(default_factory=list)


class Recording:
    """A recording set, read. `tests` holds every ended test (complete and aborted) in the order
    they were recorded; `load(i)` loads `tests[i]` (or pass the TestMeta itself). Tests begun but
    never ended (the process died) are in `interrupted`, with status "interrupted".
    """

    def __init__(
        self, path: Path, parts: list[_PartData], foreign: list[tuple[Path, str]] | None = None
    ) -> None:
        self.path = path
        self.foreign = list(foreign or [])  # part files of another recording: (path, why)
        self.parts = [p.info for p in parts]
        first = dict(parts[0].info.metadata) if parts else {}
        first.pop("part", None)
        self.metadata: dict[str, str] = first
        # What the set measures (a sweep's rig set-up and plan; empty before it was kept)
        self.identity: dict[str, str] = dict(parts[0].info.identity) if parts else {}
        self.rig_toml: str | None = next((p.rig_toml for p in parts if p.rig_toml), None)
        self.truncated = any(p.info.truncated for p in parts)
        self.tests: list[TestMeta] = []
        self.interrupted: list[TestMeta] = []
        self.damaged: list[TestMeta] = []  # also in `tests`, with status "damaged"
        self._keys: list[tuple[int, int]] = []
        self._interrupted_keys: list[tuple[int, int]] = []
        self._samples: dict[tuple[int, int], list[bytes]] = {}
        self.events: list[tuple[float, str, str]] = []
        self.actuator: list[tuple[float, dict[str, Any]]] = []  # json.loads's values
        for i, part in enumerate(parts):
            for serial, meta, count in part.ended:
                damage = _damage(part.samples.get(serial, []), meta, count)
                if damage is not None:
                    meta = _as_damaged(meta, damage)
                    self.damaged.append(meta)
                self.tests.append(meta)
                self._keys.append((i, serial))
            ended = {serial for serial, _, _ in part.ended}
            for serial, meta in part.begun.items():
                if serial not in ended:
                    self.interrupted.append(replace(meta, status="interrupted"))
                    self._interrupted_keys.append((i, serial))
            for serial, payloads in part.samples.items():
                self._samples[(i, serial)] = payloads
            self.events.extend(part.events)
            self.actuator.extend(part.actuator)

    def loss_note(self) -> str | None:
        """What a cut-off or damaged recording lost, in one line for an analysis to print
        (None when it is whole): the tests interrupted mid-write and the damaged tests are
        left out (named), nothing after a cut was written, and a part file of another
        recording is not read."""
        said = []
        if self.truncated or self.interrupted:
            problem = next((p.problem for p in self.parts if p.problem), "cut off")
            lost = len(self.interrupted)
            which = ", ".join(str(m.index) for m in self.interrupted)
            said.append(
                f"the recording is cut off ({problem}): {len(self.tests)} tests read; "
                + (
                    f"{lost} interrupted mid-write left out (test {which}); "
                    if lost
                    else "no test was interrupted; "
                )
                + "any test after the cut was never written"
            )
        if self.damaged:
            which = "; ".join(f"test {m.index}: {m.extra.get('damage', '')}" for m in self.damaged)
            said.append(f"{len(self.damaged)} damaged tests left out ({which})")
        for path, why in self.foreign:
            said.append(f"{path.name} is not part of this recording ({why}); not read")
        return "; ".join(said) or None

    def require_recording(self) -> Recording:
        """Refuse (one RecordingError line) a file that holds no shockdyno recording at all:
        empty, or an MCAP file some other program wrote. A cut-off recording passes."""
        if all(p.size_bytes == 0 for p in self.parts):
            raise RecordingError(f"{self.path}: empty file (0 bytes), not a recording")
        if not self.metadata.get("format_version") and not (self.tests or self.interrupted):
            if not _mcap_magic(self.path):
                raise RecordingError(
                    f"{self.path}: not an MCAP file (it does not start with MCAP's magic "
                    "bytes), so not a recording"
                )
            raise RecordingError(
                f"{self.path}: an MCAP file, but not a shockdyno recording "
                "(no shockdyno metadata and no tests)"
            )
        return self

    def _key(self, index: int | TestMeta) -> tuple[int, int]:
        if isinstance(index, TestMeta):
            for metas, keys in (
                (self.tests, self._keys),
                (self.interrupted, self._interrupted_keys),
            ):
                for m, k in zip(metas, keys, strict=True):
                    if m is index or m == index:
                        return k
            raise RecordingError(f"{self.path}: test {index.index} is not in this recording")
        if not 0 <= index < len(self.tests):
            raise RecordingError(f"{self.path}: no test {index} (it has {len(self.tests)})")
        return self._keys[index]

    def _meta(self, key: tuple[int, int]) -> TestMeta:
        if key in self._keys:
            return self.tests[self._keys.index(key)]
        return self.interrupted[self._interrupted_keys.index(key)]

    def samples(self, index: int | TestMeta) -> SampleBlock:
        """Every sample of a test, as the DAQ delivered it (with seq and status)."""
        try:
            return s.decode_samples(self._samples.get(self._key(index), []))
        except RecordingError as exc:
            raise RecordingError(f"{self.path}: {exc}") from exc

    def load(self, index: int | TestMeta) -> TestData:
        """A test's samples as analysis reads them: time (s), displacement (m, compression
        positive), force (N) and temperature (°C; None when never read), with its metadata."""
        key = self._key(index)
        block = self.samples(index)
        temp = block.temperature_c
        return TestData(
            meta=self._meta(key),
            t=block.t_s,
            x=block.displacement_m,
            force=block.force_n,
            temperature=None if temp.size == 0 or np.isnan(temp).all() else temp,
        )

    def load_all(self, damaged: bool = False) -> list[TestData]:
        """Every ended test, complete and aborted; damaged ones only when asked (their
        samples are a part of the test, which no analysis should take for the whole)."""
        return [self.load(i) for i, m in enumerate(self.tests) if damaged or m.status != "damaged"]

    def sample_count(self, index: int | TestMeta) -> int:
        """The number of samples a test holds, from the block headers (nothing decoded)."""
        payloads = self._samples.get(self._key(index), [])
        return sum(s.samples_header(p)[1] for p in payloads)

    def completed_keys(self) -> set[tuple[int, int, float]]:
        """(clicks, gas_clicks, frequency_hz) of every complete test."""
        return {(c, g, f) for c, g, f, _ in self.completed_points()}

    def completed_points(self) -> set[tuple[int, int, float, tuple[tuple[str, int], ...]]]:
        """(clicks, gas_clicks, frequency_hz, every adjuster's clicks sorted by name) of
        every complete test, for a resumed sweep (run/plan.py's point keys)."""
        return {
            (m.clicks, m.gas_clicks, m.frequency_hz, m.setting)
            for m in self.tests
            if m.status == "complete"
        }


def open_recording(path: str | os.PathLike[str]) -> Recording:
    """Read NAME.mcap and its part files NAME.part2.mcap, ... (see recordings/FORMAT.md);
    a part file of another recording (another set id, damper, operator or rig) is left
    out and named in `foreign`."""
    base = Path(path)
    paths = set_paths(base)
    if not paths:
        raise RecordingError(f"{base}: no such recording")
    parts = [_read_part(p) for p in paths]
    if not base.exists():
        return Recording(base, parts)
    members, foreign = [parts[0]], []
    for part in parts[1:]:
        why = not_in_set(parts[0].info.metadata, part.info.metadata)
        if why is None:
            members.append(part)
        else:
            foreign.append((part.info.path, why))
    return Recording(base, members, foreign)


IDENTITY_KEYS = ("damper_id", "operator", "rig")


def not_in_set(first: dict[str, str], part: dict[str, str]) -> str | None:
    """Why a part file with metadata `part` is not of the set whose first file has
    `first` (None: it is). A set id decides where the first file has one; before set
    ids, the damper, operator and rig must agree."""
    set_id = first.get("set_id", "")
    if set_id:
        if part.get("set_id", "") != set_id:
            return f"set id {part.get('set_id') or 'none'}, the recording's is {set_id}"
        return None
    if part.get("set_id", ""):
        return f"set id {part['set_id']}, the recording has none"
    for key in IDENTITY_KEYS:
        if part.get(key, "") != first.get(key, ""):
            return f"{key} {part.get(key, '')!r}, the recording's is {first.get(key, '')!r}"
    return None


def part_metadata(path: Path) -> dict[str, str]:
    """The `shockdyno.recording` metadata of one file, read from its start only (empty
    when there is none or the file cannot be read as MCAP)."""
    if not path.is_file():  # a FIFO would block, a device never end
        return {}
    try:
        with path.open("rb") as f:
            for record in StreamReader(f, emit_chunks=True).records:
                if isinstance(record, Metadata) and record.name == s.METADATA_NAME:
                    return dict(record.metadata)
                if isinstance(record, Chunk | Message | Footer):
                    break  # the writer puts the metadata before the first chunk
    except Exception:  # a damaged or foreign file holds no identity to read
        return {}
    return {}


def set_members(base: Path) -> list[Path]:
    """The files of the recording set at `base` (first file first): its part files that
    belong to it, not a separate recording that happens to be named like one."""
    paths = set_paths(base)
    if not base.is_file():
        return [p for p in paths if p.is_file()]
    first = part_metadata(base)
    return [base] + [p for p in paths[1:] if not_in_set(first, part_metadata(p)) is None]


def _read_part(path: Path) -> _PartData:
    try:
        size = path.stat().st_size
        f = open(path, "rb")  # noqa: SIM115
    except OSError as exc:
        raise RecordingError(f"{path}: {exc.strerror}") from exc
    part = _PartData(PartInfo(path=path, metadata={}, size_bytes=size))
    topics: dict[int, str] = dict(s.CHANNEL_IDS)  # replaced by the file's own Channel records
    saw_footer = False
    with f:
        try:
            for record in StreamReader(f, emit_chunks=True, record_size_limit=size).records:
                if isinstance(record, Chunk):
                    try:
                        inner = breakup_chunk(record, validate_crc=True)
                    except Exception as exc:  # any damage inside a chunk costs only that chunk
                        part.info.bad_chunks += 1
                        part.info.problem = f"damaged chunk skipped ({type(exc).__name__})"
                        continue
                    for r in inner:
                        _take(part, topics, r)
                elif isinstance(record, Footer):
                    saw_footer = True
                else:
                    _take(part, topics, record)
        except InvalidMagic as exc:
            raise RecordingError(f"{path}: not an MCAP file") from exc
        except EndOfFile:
            part.info.problem = "file ends before its footer"
        except Exception as exc:  # a cut-off file fails in many ways; all mean "stop here"
            part.info.problem = f"reading stopped at a damaged record ({type(exc).__name__})"
    if not saw_footer:
        part.info.truncated = True
        if part.info.problem is None:
            part.info.problem = "file ends before its footer"
    return part


def _take(part: _PartData, topics: dict[int, str], record: object) -> None:
    if isinstance(record, Message):
        topic = topics.get(record.channel_id)
        try:
            _message(part, topic, record.data)
        except (RecordingError, ValueError, KeyError, TypeError, RecursionError):
            part.info.bad_messages += 1
    elif isinstance(record, Channel):
        topics[record.id] = record.topic
    elif isinstance(record, Metadata) and record.name == s.METADATA_NAME:
        part.info.metadata = dict(record.metadata)
    elif isinstance(record, Metadata) and record.name == s.IDENTITY_METADATA_NAME:
        part.info.identity = dict(record.metadata)
    elif isinstance(record, Metadata) and record.name == s.CLOCK_METADATA_NAME:
        try:
            part.info.wall_clock_origin_ns = int(record.metadata["wall_clock_origin_ns"])
        except (KeyError, ValueError):
            part.info.problem = "bad shockdyno.clock metadata"
    elif isinstance(record, Attachment) and record.name == s.RIG_ATTACHMENT:
        part.rig_toml = record.data.decode("utf-8", errors="replace")


def _message(part: _PartData, topic: str | None, data: bytes) -> None:
    if topic == s.TOPIC_SAMPLES:
        test, _, _ = s.samples_header(data)
        part.samples.setdefault(test, []).append(data)
        return
    if topic not in (s.TOPIC_TEST, s.TOPIC_EVENTS, s.TOPIC_ACTUATOR):
        return
    obj = json.loads(data)
    if topic == s.TOPIC_TEST:
        serial = int(obj["test"])
        meta = s.meta_from_json(obj)
        if obj["phase"] == "begin":
            part.begun[serial] = meta
        else:
            count = obj.get("sample_count")
            count = count if isinstance(count, int) and not isinstance(count, bool) else None
            part.ended.append((serial, meta, count))
    elif topic == s.TOPIC_EVENTS:
        part.events.append((float(obj["t_s"]), str(obj["kind"]), str(obj["message"])))
    else:
        t = float(obj.pop("t_s"))
        obj.pop("test", None)
        part.actuator.append((t, obj))


def _mcap_magic(path: Path) -> bool:
    """Whether the file starts as every MCAP file does (a text file read as a cut-off MCAP
    holds no records, which alone would call it "an MCAP file")."""
    try:
        return starts_as_mcap(path)
    except OSError:
        return True  # unreadable: say what is known, not that it is no MCAP


def _damage(payloads: list[bytes], meta: TestMeta, written: int | None) -> str | None:
    """Why a test's samples are not the whole test its end record describes (None: they
    are): fewer than it wrote, out of order, or with a gap beyond the frames its DAQ lost."""
    counts = [s.samples_header(p)[1] for p in payloads]
    n = sum(counts)
    if written is not None and n != written:
        return f"{n} of its {written} samples read"
    if n < 2:
        return None
    seq = np.concatenate(
        [np.frombuffer(p, "<i8", c, 12) for p, c in zip(payloads, counts, strict=True)]
    )
    steps = np.diff(seq)
    if np.any(steps <= 0):
        return "its samples are out of order"
    gaps = int(np.sum(steps - 1))
    known = (meta.dropped_frames or 0) + (meta.corrupt_frames or 0)
    if written is None and gaps > known:
        return f"{gaps} samples missing from its time base, {known} lost by its DAQ"
    return None


def _as_damaged(meta: TestMeta, why: str) -> TestMeta:
    extra = {**meta.extra, "damage": why, "recorded_status": meta.status}
    return replace(meta, status="damaged", extra=extra)
