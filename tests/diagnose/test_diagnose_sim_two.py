"""Concealed effects, third part: two effects at once, seal friction beside air (the cases
and checks are in concealed.py). A module of its own: its diagnosis alone takes about a
minute of CPU, and `--dist loadscope` gives each module to one test worker."""

from __future__ import annotations

import pytest
from concealed import Diagnoses, Recordings, check_library_fits, check_named, check_names_hidden

# Diagnosed with the whole library. The timeout is a hang's guard, not a speed check: on
# two cores under a load of 10 this diagnosis took more than 400 s.
pytestmark = [pytest.mark.timeout(900), pytest.mark.slow]


def test_the_recording_does_not_name_its_physics(recordings: Recordings) -> None:
    check_names_hidden(recordings, ["s-two"])


def test_both_concealed_effects_are_named_or_the_second_is_left_unexplained(
    diagnoses: Diagnoses,
) -> None:
    check_named(diagnoses, "s-two")


def test_the_library_at_the_simulated_values_fits_the_recording_to_noise(
    recordings: Recordings,
) -> None:
    check_library_fits(recordings, "s-two")
