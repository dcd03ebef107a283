"""Import dyno data from CSV: the exchange format (docs/csv.md) and other dynos' exports.

Everything is parsed and checked before the output is written (csv_table.py reads a data
file, manifest.py the manifest), and the output is written to a temporary file that
replaces the target only on success: a bad file leaves nothing behind.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

from shockdyno.atomic import atomic_file
from shockdyno.errors import RecordingError
from shockdyno.record.csv_table import ImportOptions
from shockdyno.record.layout import part_paths
from shockdyno.record.lock import recording_lock
from shockdyno.record.manifest import SOURCE_KEY, read_manifest
from shockdyno.record.types import TestMeta
from shockdyno.record.writer import RecordingWriter


def import_csv(
    manifest: Path,
    output: Path,
    opts: ImportOptions,
    *,
    force: bool = False,
    progress: Callable[[str, float], None] | None = None,
) -> list[TestMeta]:
    """Read MANIFEST and its data files and write one recording at `output`.

    `progress(stage, fraction)` is told of each file read (first half) and test written."""
    with recording_lock(output):
        return _import_locked(manifest, output, opts, force, progress)


def _import_locked(
    manifest: Path,
    output: Path,
    opts: ImportOptions,
    force: bool,
    progress: Callable[[str, float], None] | None,
) -> list[TestMeta]:
    stale = part_paths(output)
    if stale and not force:
        raise RecordingError(f"{stale[0]} exists (use --force to replace the recording set)")
    if output.exists() and not force:
        raise RecordingError(f"{output} exists (use --force to overwrite it)")
    tests = read_manifest(manifest, opts, progress)
    for source in [manifest, *(manifest.parent / t.meta.extra[SOURCE_KEY] for t in tests)]:
        if output.exists() and output.samefile(source):
            raise RecordingError(f"-o {output} is an input of the import; refusing to overwrite it")
    options = {k: v for k, v in asdict(opts).items() if k != "metadata"}
    metadata = {
        "source": "csv import",
        "manifest": manifest.name,
        "import_options": json.dumps(options, sort_keys=True),
        **opts.metadata,
    }
    try:
        with atomic_file(output, force) as tmp:
            with RecordingWriter(tmp, metadata=metadata, overwrite=True) as writer:
                for i, test in enumerate(tests):
                    if progress is not None:
                        progress(f"write test {i + 1}/{len(tests)}", 0.5 + 0.5 * i / len(tests))
                    writer.begin_test(test.meta)
                    writer.write_samples(test.block)
                    writer.end_test(test.meta)
            for p in stale:
                p.unlink()
    except RecordingError as exc:  # name the recording, not only its temporary file
        raise RecordingError(f"-o {output}: {exc}") from None
    return [t.meta for t in tests]
