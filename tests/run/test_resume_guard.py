"""A resumed sweep may not mix two dampers (or operators) in one recording set; refused
before the rig is touched (no rig listens here: reaching it would be a different error)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from shockdyno.cli import main
from shockdyno.record import RecordingWriter
from shockdyno.record.types import TestMeta
from shockdyno.samples import SampleBlock

SIM = Path(__file__).resolve().parents[2] / "rigs" / "sim.toml"


@pytest.fixture
def earlier(tmp_path: Path) -> Path:
    path = tmp_path / "set.mcap"
    meta = TestMeta(0, 0, 0, 0.5, 0.03, 1000.0, warmup_cycles=2, measured_cycles=5)
    n = 100
    block = SampleBlock(np.arange(n), np.arange(n) / 1e3, np.zeros(n), np.zeros(n),
                        np.full(n, 40.0), np.zeros(n, np.uint16))  # fmt: skip
    with RecordingWriter(path, metadata={"damper_id": "S46-A", "operator": "ana"}) as w:
        w.begin_test(meta)
        w.write_samples(block)
        w.end_test(meta)
    return path


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["--damper-id", "S46-B", "--operator", "ana"], "damper_id 'S46-A'"),
        (["--damper-id", "S46-A", "--operator", "bob"], "operator 'ana'"),
        (["--operator", "ana"], "damper_id 'S46-A'"),
    ],
)
def test_resume_with_another_damper_or_operator_is_refused(capsys, earlier, flags, words):
    before = earlier.read_bytes()
    code = main(["sweep", "--rig", str(SIM), "--resume", "-o", str(earlier), *flags])
    err = capsys.readouterr().err
    assert code == 2 and words in err and "mix two" in err
    assert earlier.read_bytes() == before
    assert not list(earlier.parent.glob("*.part*.mcap"))
