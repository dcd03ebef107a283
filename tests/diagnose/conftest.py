"""Fixtures of the concealed-effect modules (test_diagnose_sim*.py): each module makes
its own recordings, when a test first asks for one, and diagnoses each once."""

from __future__ import annotations

import pytest
from concealed import Diagnoses, Recordings


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> Recordings:
    return Recordings(tmp_path_factory.mktemp("concealed"))


@pytest.fixture(scope="module")
def diagnoses(recordings: Recordings) -> Diagnoses:
    return Diagnoses(recordings)
