"""MCAP recordings: writer, reader, schemas, CSV import and export."""

from shockdyno.record.reader import Recording, open_recording
from shockdyno.record.types import TestData, TestMeta
from shockdyno.record.writer import RecordingWriter

__all__ = ["Recording", "RecordingWriter", "TestData", "TestMeta", "open_recording"]
