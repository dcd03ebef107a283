"""`make test` changes nothing on the system: it builds .venv and runs the checks, and the
browser tests use a Chromium that is already there or are left out with one line that says
how to enable them (issue 47.9: it once apt-get installed chromium, as root, unasked)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
NO_BROWSER = {**os.environ, "SHOCKDYNO_CHROMIUM": "/nonexistent/chrome"}
SYSTEM = re.compile(r"\b(apt-get|apt|dpkg|dnf|yum|zypper|brew|snap|sudo)\b")

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="no make on this machine")


def test_make_test_runs_nothing_that_installs_system_packages() -> None:
    done = subprocess.run(
        ["make", "-n", "test"], cwd=REPO, capture_output=True, text=True, timeout=60, check=True
    )
    lines = [line for line in done.stdout.splitlines() if line.strip()]
    assert any("pytest" in line for line in lines)
    assert [line for line in lines if SYSTEM.search(line)] == []
    # pip only ever runs inside the project's own virtualenv
    assert all(".venv/bin/python -m pip" in line for line in lines if "pip" in line.split())


def test_make_browser_says_in_one_line_how_to_enable_the_browser_tests() -> None:
    done = subprocess.run(
        ["make", "-s", "browser"], cwd=REPO, env=NO_BROWSER, capture_output=True, text=True,
        timeout=60,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    (line,) = done.stdout.splitlines()
    assert "no Chromium found" in line and "SHOCKDYNO_CHROMIUM=" in line
    found = subprocess.run(
        ["make", "-s", "browser"], cwd=REPO, capture_output=True, text=True, timeout=60,
        env={**os.environ, "SHOCKDYNO_CHROMIUM": sys.executable},
    )  # fmt: skip
    assert found.stdout.strip() == f"browser tests: {sys.executable}"


def test_without_a_browser_pytest_skips_the_browser_tests_in_one_line() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-ra", "-p", "no:cacheprovider",
         "tests/report/test_report_browser.py"],
        cwd=REPO, env=NO_BROWSER, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    out = done.stdout
    assert done.returncode == 0, out[-800:]
    assert " passed" not in out and " skipped" in out
    said = [line for line in out.splitlines() if "SKIPPED" in line]
    assert len(said) == 1 and "no Chromium found" in said[0] and "SHOCKDYNO_CHROMIUM=" in said[0]
