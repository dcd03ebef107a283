"""The fit reads a recording as a sweep leaves it: aborted tests are left out, not fitted."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np

from inprocess import cli
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import load_spec
from shockdyno.record import RecordingWriter
from shockdyno.samples import SampleBlock


def _block(t, x, f, start: int) -> SampleBlock:  # type: ignore[no-untyped-def]
    n = t.size
    return SampleBlock(
        np.arange(start, start + n, dtype=np.int64), t, x, f, np.full(n, 40.0),
        np.zeros(n, np.uint16),
    )  # fmt: skip


def test_fit_leaves_out_an_empty_aborted_test(tmp_path):
    spec = load_spec()
    tests = synthetic_sweep(spec, (5, 15), (1.0, 1.5), cycles=2, seed=4)
    path = tmp_path / "mixed.mcap"
    with RecordingWriter(path, metadata={}) as w:
        seq = 0
        for i, test in enumerate(tests):
            meta = replace(test.meta, index=i, status="complete")
            w.begin_test(meta)
            w.write_samples(_block(test.t, test.x, test.force, seq))
            w.end_test(meta)
            seq += test.t.size
        aborted = replace(tests[0].meta, index=len(tests), clicks=10, status="aborted",
                          measured_start_s=None, measured_end_s=None)  # fmt: skip
        w.begin_test(aborted)  # refused at once: no samples at all
        w.end_test(aborted)
    out = tmp_path / "fit.json"
    res = cli("fit", str(path), "--json", str(out))  # in this process: what it writes
    assert res.returncode == 0, res.stderr
    doc = json.loads(out.read_text())
    assert sorted(c["clicks"] for c in doc["clicks"]) == [5, 15]
    assert len(doc["tests"]) == 4
    a_bc, a_bt = spec.bleed_areas(15)
    c15 = next(c for c in doc["clicks"] if c["clicks"] == 15)
    assert abs(c15["A_bc_m2"] - a_bc) < 0.1 * a_bc and abs(c15["A_bt_m2"] - a_bt) < 0.1 * a_bt
