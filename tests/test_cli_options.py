"""Options every command shares: --help shows each default, -v / --log-level show the Modbus
traffic, and list flags fail in one line."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from shockdyno.cli import build_parser, main

REPO = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "shockdyno.cli"]


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    out = dict(sub.choices)
    for name, command in sub.choices.items():  # and nested ones: `rig check`
        for action in command._actions:
            if isinstance(action, argparse._SubParsersAction):
                out.update({f"{name} {k}": v for k, v in action.choices.items()})
    return out


def test_every_command_help_shows_every_default() -> None:
    commands = _commands()
    assert {"demo", "sweep", "replay", "sim-rig", "import", "fit", "ride", "rig check"} <= set(
        commands
    )
    checked = 0
    for name, parser in commands.items():
        formatter = parser._get_formatter()
        for action in parser._actions:
            default = action.default
            if not action.option_strings or default in (None, False, [], "", argparse.SUPPRESS):
                continue
            text = formatter._expand_help(action) if action.help is not None else ""
            if action.help is None:  # argparse shows no help line at all then
                text = formatter._get_help_string(action) % {"default": default}
            assert "default" in text.lower(), f"{name} {action.option_strings}: {text!r}"
            checked += 1
    assert checked >= 30  # the commands' defaulted options, not a loop over nothing


def test_help_states_the_speed_and_list_defaults() -> None:
    demo = " ".join(_commands()["demo"].format_help().split())
    assert "(default: 50.0)" in demo and "(default: 0-21:3)" in demo
    sweep = " ".join(_commands()["sweep"].format_help().split())
    assert "(default: 0.5,1,1.5)" in sweep and "x real time" in sweep


def _sweep(tmp_path: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    cmd = [*CLI, "sweep", "--rig", "rigs/sim.toml", "--start-sim", "--speed", "20",
           "--clicks", "3", "--freq", "1.5", "--cycles", "1", "--warmup-cycles", "0",
           "-o", str(tmp_path / "r.mcap"), *extra]  # fmt: skip
    return subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=90)


def test_verbose_shows_the_modbus_traffic_and_is_quiet_without(tmp_path: Path) -> None:
    loud = _sweep(tmp_path, "-v")
    assert loud.returncode == 0, loud.stderr
    # The driver's requests in register-map terms, and pymodbus's frames and decoded PDUs
    assert "shockdyno.rig.actuator DEBUG write position_command = " in loud.stderr
    assert "pymodbus.logging DEBUG" in loud.stderr and "WriteMultipleRegisters" in loud.stderr
    assert "matplotlib" not in loud.stderr  # other libraries stay at warnings
    (tmp_path / "r.mcap").unlink()
    quiet = _sweep(tmp_path)
    assert quiet.returncode == 0, quiet.stderr
    assert "pymodbus" not in quiet.stderr and "DEBUG" not in quiet.stderr


def test_log_level_before_the_command_also_works(tmp_path: Path) -> None:
    res = subprocess.run(
        [*CLI, "--log-level", "debug", "sim-rig", "--duration", "0.5",
         "--modbus-port", "0", "--serial-port", "0"],  # a sim-rig of someone else may hold 5020
        cwd=REPO, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "pymodbus.logging" in res.stderr


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        (["demo", "--clicks", "0-21:x"], "--clicks"),
        (["sweep", "--rig", "rigs/sim.toml", "--freq", "0.5-2", "-o", "x.mcap"], "--freq"),
        (["ride", "--linear-damper-ns-m", "2000", "--speeds-kmh", "20,,60", "--json", "-"],
         "--speeds-kmh"),
    ],
)  # fmt: skip
def test_a_bad_list_is_one_line_naming_its_flag(
    argv: list[str], flag: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and flag in err


def test_sim_rig_help_names_every_fault_it_accepts(capsys: pytest.CaptureFixture[str]) -> None:
    from shockdyno.simrig.faults import KINDS

    with pytest.raises(SystemExit):
        main(["sim-rig", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert [k for k in KINDS if k not in text] == []


def test_ctrl_c_while_the_commands_load_is_one_line_not_a_traceback() -> None:
    """The command modules take seconds to import on a loaded machine: a Ctrl-C then (a
    real SIGINT, sent while the first one imports) is said as an interrupt, exit 130."""
    code = (
        "import os, signal, sys\n"
        # A suite started as a shell's background job (`make test &`) has SIGINT ignored,
        # and so would this child: Python's own handler back, as a terminal's process has.
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from shockdyno import cli\n"
        "real = cli.importlib.import_module\n"
        "def interrupted(name):\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "    return real(name)\n"
        "cli.importlib.import_module = interrupted\n"
        "sys.exit(cli.main(['--version']))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 130
    assert done.stderr == "shockdyno: interrupted\n"
