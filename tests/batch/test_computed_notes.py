"""`batch report` says, as `report` does, when its pages computed model forces that the
fit's saved forces did not hold (a fit of another recording, --allow-other-recording):
one line per fit after the work, naming the pages (issue 48's new-user review). The
pages are real report tasks run in this process, as a worker runs them."""

from __future__ import annotations

from pathlib import Path

from shockdyno.batch.jobs import Job, computed_notes, run_job
from shockdyno.cli import main
from shockdyno.record.identity import recording_sha256

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "recordings" / "examples" / "example.mcap"
MANIFEST = REPO / "recordings" / "examples" / "csv" / "manifest.csv"


def test_pages_that_computed_forces_are_said_once_per_fit(tmp_path: Path) -> None:
    fit = tmp_path / "example.fit.json"
    assert main(["fit", str(EXAMPLE), "--json", str(fit), "--no-history"]) == 0
    recordings = [EXAMPLE]
    for i in range(2):  # other recordings than the fit's: their tests' forces are not saved
        rec = tmp_path / f"r{i}.mcap"
        assert main(["import", str(MANIFEST), "-o", str(rec), "--meta", f"damper_id=D{i}"]) == 0
        recordings.append(rec)
    out = tmp_path / "out"
    out.mkdir()
    jobs = [
        Job("report", str(r), r.stem, recording_sha256(r), str(out),
            {"fit": str(fit), "allow_other_recording": True})
        for r in recordings
    ]  # fmt: skip
    rows = [run_job(j) for j in jobs]
    assert [r.status for r in rows] == ["done"] * 3, [r.error for r in rows]
    assert rows[0].note == ""  # the fit's own recording: every force was saved
    assert all("does not hold test" in r.note for r in rows[1:]), [r.note for r in rows]
    notes = computed_notes(jobs, rows)
    assert len(notes) == 1, notes
    assert notes[0].startswith("example.fit.forces.npz does not hold test")
    assert "computed from the fit" in notes[0] and notes[0].endswith("for 2 pages (r0, r1)")
