"""The report reads the model's forces `fit` saved beside FIT.json (fit/forces.py), and
does not run the model: the page is the one it makes when it computes them."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

import report_helpers
from report_helpers import sweep_tests, write_recording
from shockdyno.cli import main
from shockdyno.fit import forces
from shockdyno.fit.plots import overlay_forces
from shockdyno.fit.result import FitResult
from shockdyno.model.composite import DamperModel
from shockdyno.record import open_recording


@pytest.fixture(scope="module")
def fitted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A recording of two click settings at two frequencies, and `fit`'s FIT.json of it."""
    d = tmp_path_factory.mktemp("saved")
    rec = write_recording(d / "sweep.mcap", sweep_tests((0, 21), (1.0, 1.5)), {})
    fit = d / "sweep.fit.json"
    assert main(["fit", str(rec), "--json", str(fit), "--no-history"]) == 0
    return rec, fit


def _page(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def _no_model(*_args: object, **_kw: object) -> np.ndarray:
    raise AssertionError("the report ran the model")


def _report_without_sidecar(fit: Path, args: list[str], out: Path) -> None:
    """`report ARGS -o OUT` with the fit's sidecar moved away (and back): computed."""
    sidecar = forces.sidecar_path(fit)
    moved = out.parent / "away.npz"
    sidecar.rename(moved)
    try:
        assert main([*args, "-o", str(out)]) == 0
    finally:
        moved.rename(sidecar)


@pytest.mark.parametrize("units", ["si", "imperial"])
def test_the_report_reads_the_saved_forces_and_draws_what_it_computed(
    fitted: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    units: str,
) -> None:
    rec, fit = fitted
    sidecar = forces.sidecar_path(fit)
    assert sidecar.name == "sweep.fit.forces.npz" and sidecar.is_file()
    args = ["report", str(rec), "--fit", str(fit), "--units", units]
    # Computed, as the report did before the fit saved them: the sidecar moved away.
    _report_without_sidecar(fit, args, tmp_path / "computed")
    err = capsys.readouterr().err
    assert "sweep.fit.forces.npz not found beside sweep.fit.json" in err
    assert "computed from the fit instead" in err

    with monkeypatch.context() as m:
        m.setattr(DamperModel, "force", _no_model)
        assert main([*args, "-o", str(tmp_path / "saved")]) == 0
    assert "report: note" not in capsys.readouterr().err
    computed, saved = _page(tmp_path / "computed"), _page(tmp_path / "saved")
    assert computed.keys() == saved.keys()
    assert any(n.startswith("fit-overlay") for n in saved)  # the overlays were drawn
    for name in computed:  # the page, its CSV and every figure, byte for byte
        assert saved[name] == computed[name], name
    assert "Fitted model (" in saved["index.html"].decode()


def test_the_saved_overlay_forces_are_the_models_on_the_same_tests(
    fitted: tuple[Path, Path],
) -> None:
    rec, fit_path = fitted
    tests = open_recording(rec).load_all()
    fit = FitResult.load(fit_path)
    assert forces.attach(fit, fit_path) == ""
    assert fit.saved is not None and len(fit.saved.tests) >= 2  # the overlays of the paper's picks
    saved = overlay_forces(fit, tests)
    fit.saved = None
    computed = overlay_forces(fit, tests)
    assert [m.test.meta.index for m in saved] == [m.test.meta.index for m in computed]
    for a, b in zip(saved, computed, strict=True):
        assert np.array_equal(a.proposed, b.proposed) and np.array_equal(a.talbott, b.talbott)
        assert np.ptp(a.proposed) > 100  # a damper's force, not zeros


def test_a_stale_sidecar_is_said_and_not_used(
    fitted: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rec, fit = fitted
    other = tmp_path / "edited.json"
    doc = json.loads(fit.read_text())
    doc["globals"] = {k: 1.01 * v for k, v in doc["globals"].items()}  # another fit
    other.write_text(json.dumps(doc, indent=2) + "\n")
    forces.sidecar_path(other).write_bytes(forces.sidecar_path(fit).read_bytes())
    assert main(["report", str(rec), "--fit", str(other), "-o", str(tmp_path / "r")]) == 0
    err = capsys.readouterr().err
    assert "edited.forces.npz belongs to another version of edited.json" in err
    assert "(stale: the JSON was edited, or written again without it)" in err
    loaded = FitResult.load(other)
    assert "stale" in forces.attach(loaded, other) and loaded.saved is None


def test_fit_refuses_to_overwrite_a_sidecar_without_force(
    fitted: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rec, _ = fitted
    out = tmp_path / "new.json"
    forces.sidecar_path(out).write_bytes(b"mine")
    assert main(["fit", str(rec), "--json", str(out), "--no-history"]) != 0
    err = capsys.readouterr().err
    assert "new.forces.npz exists (use --force" in err and not out.exists()
    assert forces.sidecar_path(out).read_bytes() == b"mine"
    # With --force both are written, and the last line names both (they travel together).
    assert main(["fit", str(rec), "--json", str(out), "--no-history", "--force"]) == 0
    said = capsys.readouterr().out
    assert f"wrote {out} and the model's forces new.forces.npz beside it\n" in said
    saved, note = forces.read(out)
    assert saved is not None and note == ""


@pytest.mark.parametrize("damage", ["member", "garbage"])
def test_a_damaged_sidecar_is_said_and_not_used(
    fitted: tuple[Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    damage: str,
) -> None:
    """A sidecar whose compressed data is damaged (the zip's directory intact), or that is
    no zip at all, is one line and the forces computed: never a traceback."""
    rec, fit = fitted
    copy = tmp_path / "copy.json"
    copy.write_bytes(fit.read_bytes())
    data = bytearray(forces.sidecar_path(fit).read_bytes())
    if damage == "member":
        with zipfile.ZipFile(io.BytesIO(bytes(data))) as z:
            info = max(z.infolist(), key=lambda i: i.compress_size)
        start = info.header_offset + 30 + len(info.filename.encode()) + len(info.extra)
        middle = start + info.compress_size // 2
        data[middle : middle + 64] = bytes(b ^ 0xFF for b in data[middle : middle + 64])
    else:
        data = bytearray(b"not an npz file\n" * 50)
    forces.sidecar_path(copy).write_bytes(bytes(data))
    assert main(["report", str(rec), "--fit", str(copy), "-o", str(tmp_path / "r")]) == 0
    err = capsys.readouterr().err
    assert "copy.forces.npz is not readable" in err and "Traceback" not in err
    assert "computed from the fit instead" in err
    assert (tmp_path / "r" / "index.html").is_file()
    if damage == "garbage":
        assert "pickled" not in err  # not np.load's advice to unpickle it


def test_a_report_of_another_recording_computes_the_overlays_on_its_own_motion(
    fitted: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The saved overlays are the model on the fit's recording's motion: a recording of
    the same plan at another amplitude (the same tests, the same sample counts) shown with
    --allow-other-recording gets its own, the page it gets without the sidecar."""
    _, fit = fitted
    with monkeypatch.context() as m:
        m.setattr(report_helpers, "AMPLITUDE_M", 0.6 * report_helpers.AMPLITUDE_M)
        other = write_recording(tmp_path / "other.mcap", sweep_tests((0, 21), (1.0, 1.5)), {})
    args = ["report", str(other), "--fit", str(fit), "--allow-other-recording"]
    assert main([*args, "-o", str(tmp_path / "saved")]) == 0
    err = capsys.readouterr().err
    assert "sweep.fit.forces.npz does not hold test" in err  # said after the page
    _report_without_sidecar(fit, args, tmp_path / "computed")
    saved, computed = _page(tmp_path / "saved"), _page(tmp_path / "computed")
    overlays = [n for n in computed if n.startswith("fit-overlay")]
    assert overlays and computed.keys() == saved.keys()
    for name in computed:
        assert saved[name] == computed[name], name


def test_a_sidecar_whose_arrays_do_not_fit_together_is_not_read(
    fitted: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Bound to its FIT.json (the right SHA-256) but with a characteristic row short: one
    line and computed, not an IndexError from the click chart."""
    rec, fit = fitted
    copy = tmp_path / "short.json"
    copy.write_bytes(fit.read_bytes())
    with np.load(forces.sidecar_path(fit), allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["char_f_si"] = arrays["char_f_si"][:-1]
    np.savez_compressed(forces.sidecar_path(copy), **arrays)
    saved, note = forces.read(copy)
    assert saved is None and "short.forces.npz is not readable (char_f_si is" in note
    assert main(["report", str(rec), "--fit", str(copy), "-o", str(tmp_path / "r")]) == 0
    assert "short.forces.npz is not readable" in capsys.readouterr().err
