"""A held-out sweep as a user would have it: the CSV exchange files the sweep writes,
imported into a recording by the same code as `shockdyno import` (in-process)."""

from __future__ import annotations

from pathlib import Path

from holdout.plant import Effects
from holdout.sweep import CLICKS, FREQS, SweepTruth, run_sweep
from shockdyno.record.csv_import import import_csv
from shockdyno.record.csv_table import ImportOptions


def holdout_recording(
    effects: Effects,
    out_dir: Path,
    seed: int,
    clicks: tuple[int, ...] = CLICKS,
    freqs: tuple[float, ...] = FREQS,
) -> tuple[Path, SweepTruth]:
    """(OUT_DIR/REC.mcap, what the plant did) for a sweep of this plant."""
    truth, _ = run_sweep(effects, out_dir, seed=seed, clicks=clicks, freqs=freqs)
    rec = out_dir / "REC.mcap"
    import_csv(out_dir / "manifest.csv", rec, ImportOptions(), force=True)
    return rec, truth
