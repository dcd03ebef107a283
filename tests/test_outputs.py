"""The output-path policy: no overwrite without --force, never an input, `-` is stdout."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from shockdyno.cli import main
from shockdyno.errors import ConfigError
from shockdyno.outputs import check_output, write_output
from shockdyno.record import RecordingWriter
from shockdyno.record.types import TestMeta
from shockdyno.samples import SampleBlock

EXAMPLE = Path(__file__).resolve().parents[1] / "recordings" / "examples" / "example.mcap"
FAST_RIDE = ["--linear-damper-ns-m", "1500", "--clicks", "5", "--roads", "A", "--speeds-kmh",
             "60", "--duration-s", "2", "--warmup-s", "0.5", "--no-step-check"]  # fmt: skip


def test_the_helper_refuses_inputs_existing_files_and_unwritable_folders(tmp_path):
    src = tmp_path / "in.mcap"
    src.write_bytes(b"x")
    link = tmp_path / "link.mcap"
    link.symlink_to(src)
    for path, force in ((src, True), (link, True)):
        with pytest.raises(ConfigError, match="input of this command"):
            check_output(path, force=force, inputs=[src])
    with pytest.raises(ConfigError, match="exists"):
        check_output(src, force=False)
    with pytest.raises(ConfigError, match="cannot create files"):
        check_output("/proc/x.json", force=False)
    with pytest.raises(ConfigError, match="does not exist"):
        check_output(tmp_path / "no" / "x.json", force=False)
    assert check_output("-", force=False, inputs=[src]) is None
    assert write_output(tmp_path / "new.json", "{}\n", force=False) == tmp_path / "new.json"
    assert (tmp_path / "new.json").read_text() == "{}\n"
    assert not list(tmp_path.glob(".*probe"))  # the probe file is gone


@pytest.fixture
def rec(tmp_path: Path) -> Path:
    path = tmp_path / "rec.mcap"
    shutil.copy(EXAMPLE, path)
    return path


@pytest.mark.parametrize("command", ["info", "fit"])
def test_json_onto_the_input_is_refused_and_the_input_survives(capsys, rec, command):
    before = rec.read_bytes()
    assert main([command, str(rec), "--json", str(rec), "--force"]) == 2
    assert "input of this command" in capsys.readouterr().err
    assert rec.read_bytes() == before


@pytest.mark.parametrize("command", ["info", "ride"])
def test_an_existing_json_needs_force(capsys, rec, tmp_path, command):
    out = tmp_path / "out.json"
    out.write_text("keep me")
    args = [command, str(rec)] if command == "info" else [command, *FAST_RIDE]
    assert main([*args, "--json", str(out)]) == 2
    assert "--force" in capsys.readouterr().err and out.read_text() == "keep me"
    assert main([*args, "--json", str(out), "--force"]) == 0
    json.loads(out.read_text())


@pytest.mark.parametrize("command", ["info", "ride"])
def test_json_dash_writes_only_json_to_stdout(capsys, rec, command):
    args = [command, str(rec)] if command == "info" else [command, *FAST_RIDE]
    assert main([*args, "--json", "-"]) == 0
    json.loads(capsys.readouterr().out)


def test_fit_refuses_a_recording_with_an_absurd_force_and_writes_nothing(capsys, tmp_path):
    path = tmp_path / "bad.mcap"
    n = 2000
    t = np.arange(n) / 1000.0
    x = 0.03 * np.sin(2 * np.pi * t)
    force = 1000 * np.cos(2 * np.pi * t)
    force[100] = 1e308
    meta = TestMeta(0, 3, 0, 1.0, 0.03, 1000.0, measured_cycles=2)
    block = SampleBlock(np.arange(n), t, x, force, np.full(n, 40.0), np.zeros(n, np.uint16))
    with RecordingWriter(path, metadata={}) as w:
        w.begin_test(meta)
        w.write_samples(block)
        w.end_test(meta)
    out = tmp_path / "fit.json"
    assert main(["fit", str(path), "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert "beyond any damper dyno" in err and "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize("command", ["info", "replay"])
@pytest.mark.parametrize("kind", ["empty", "foreign", "text"])
def test_empty_or_foreign_mcap_is_named_not_shown_as_zero_tests(capsys, tmp_path, command, kind):
    path = tmp_path / "x.mcap"
    if kind == "empty":
        path.write_bytes(b"")
    elif kind == "text":
        path.write_text("x,y\n")  # a CSV shorter than the magic: read, it only ends early
    else:
        from mcap.writer import Writer

        with path.open("wb") as fh:
            w = Writer(fh)
            w.start(profile="", library="someone else")
            schema = w.register_schema(name="s", encoding="jsonschema", data=b"{}")
            ch = w.register_channel(topic="/other", message_encoding="json", schema_id=schema)
            w.add_message(ch, 0, b"{}", 0)
            w.finish()
    assert main([command, str(path)]) == 2
    err = capsys.readouterr().err
    want = {"empty": "empty file", "foreign": "an MCAP file, but not a shockdyno recording"}
    assert want.get(kind, "not an MCAP file") in err and "Traceback" not in err


def test_sweep_never_records_over_its_own_rig_file(capsys, tmp_path):
    """Issue 21.2: `--rig copy.toml -o copy.toml --force` made the rig file an MCAP."""
    rig = tmp_path / "copy.toml"
    shutil.copy(Path(__file__).resolve().parents[1] / "rigs" / "sim.toml", rig)
    before = rig.read_bytes()
    args = ["sweep", "--rig", str(rig), "--start-sim", "--clicks", "0", "--freq", "1"]
    assert main([*args, "-o", str(rig), "--force"]) == 2
    assert "input of this command" in capsys.readouterr().err
    assert rig.read_bytes() == before
    scenario = tmp_path / "s.toml"
    scenario.write_text("[scenario]\nname = 's'\ndescription = 'x'\n")
    assert main([*args, "--scenario", str(scenario), "-o", str(scenario), "--force"]) == 2
    assert scenario.read_text().startswith("[scenario]")


@pytest.mark.parametrize("command", ["fit", "diagnose", "ride"])
def test_an_existing_report_is_refused_before_any_work(capsys, rec, tmp_path, command):
    """Issue 21.5: --report DIR is checked first; an existing index.html needs --force,
    and nothing (not the JSON either) is written by the refused call."""
    report = tmp_path / "report"
    report.mkdir()
    (report / "index.html").write_text("keep me")
    out = tmp_path / "out.json"
    args = [command, str(rec)] if command != "ride" else [command, *FAST_RIDE]
    assert main([*args, "--json", str(out), "--report", str(report)]) == 2
    err = capsys.readouterr().err
    assert "index.html exists" in err and "--force" in err and err.count("\n") == 1
    assert not out.exists()
    assert (report / "index.html").read_text() == "keep me"
    # A report DIR that is a file is refused the same way.
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert main([*args, "--json", str(out), "--report", str(afile)]) == 2
    assert "not a directory" in capsys.readouterr().err and not out.exists()


def test_a_folder_of_someone_elses_figures_is_not_written_over(capsys, rec, tmp_path):
    """report -o into a folder that is not a report but holds a peaks.png and a
    click_chart.csv of its own: refused in one line, both kept; --force writes."""
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "peaks.png").write_bytes(b"my own plot")
    (mine / "click_chart.csv").write_text("my,own\n")
    (mine / "notes.txt").write_text("unrelated files are no obstacle")
    assert main(["report", str(rec), "-o", str(mine)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "would write over (click_chart.csv, peaks.png)" in err
    assert (mine / "peaks.png").read_bytes() == b"my own plot"
    assert not (mine / "index.html").exists()
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("x")
    assert main(["report", str(rec), "-o", str(other)]) == 0
    assert main(["report", str(rec), "-o", str(mine), "--force"]) == 0
    assert (mine / "peaks.png").read_bytes() != b"my own plot"


def test_force_replaces_only_a_report_this_tool_wrote(capsys, rec, tmp_path):
    """Issue 46.4: --force may replace a report folder this tool wrote, never another page."""
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "index.html").write_text("<html>a web site</html>")
    assert main(["report", str(rec), "-o", str(theirs), "--force"]) == 2
    err = capsys.readouterr().err
    assert "not a page shockdyno wrote" in err and err.count("\n") == 1
    assert (theirs / "index.html").read_text() == "<html>a web site</html>"
    ours = tmp_path / "ours"
    assert main(["report", str(rec), "-o", str(ours)]) == 0
    assert '<meta name="generator" content="shockdyno">' in (ours / "index.html").read_text()
    assert main(["report", str(rec), "-o", str(ours), "--force"]) == 0
