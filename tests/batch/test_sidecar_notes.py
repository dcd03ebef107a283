"""`batch report` says, as `report` does, when a fit's saved model forces will not be read
(fit/forces.py): one line per fit, before the cluster starts."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from shockdyno.batch.jobs import Job, sidecar_notes
from shockdyno.fit import forces


def _job(name: str, kind: str, fit: Path) -> Job:
    return Job(kind, f"{name}.mcap", name, "0" * 64, str(fit), {"fit": str(fit)})


def test_a_missing_stale_or_damaged_sidecar_is_one_line_each(tmp_path: Path) -> None:
    text = '{"a fit": 1}\n'
    empty = forces.SavedForces("", np.zeros((0, 2)), {}, {})
    for name in ("good", "missing", "stale", "junk"):
        (tmp_path / f"{name}.fit.json").write_text(text)
    good = forces.to_bytes(empty, text)
    forces.sidecar_path(tmp_path / "good.fit.json").write_bytes(good)
    stale = forces.to_bytes(empty, text + " ")
    forces.sidecar_path(tmp_path / "stale.fit.json").write_bytes(stale)
    forces.sidecar_path(tmp_path / "junk.fit.json").write_bytes(b"junk")
    jobs = [_job(n, "report", tmp_path) for n in ("good", "missing", "stale", "junk", "gone")]
    notes = sidecar_notes(jobs)
    assert len(notes) == 3  # good says nothing; gone has no fit (said as a missing fit)
    assert "missing.fit.forces.npz not found beside missing.fit.json" in notes[0]
    assert "stale.fit.forces.npz belongs to another version" in notes[1]
    assert "junk.fit.forces.npz is not readable" in notes[2]
    assert all(n.endswith("computed from the fit instead") for n in notes)
    # One --fit FILE for every recording: one line; and only `batch report` reads them.
    one = tmp_path / "missing.fit.json"
    assert len(sidecar_notes([_job(n, "report", one) for n in ("a", "b")])) == 1
    assert sidecar_notes([_job("missing", "diagnose", tmp_path)]) == []
