"""The flags the diagnosis reads on a term instead of its name (model/composite.Term):
each names only what exists, so a misspelt one fails here instead of matching nothing."""

from __future__ import annotations

from shockdyno.diagnose.consistency import checked
from shockdyno.diagnose.features import SIGNALS, like
from shockdyno.model.terms import LIBRARY


def test_every_signal_a_term_follows_is_one_the_features_are_made_of() -> None:
    for name, term in LIBRARY.items():
        assert set(term.follows) <= set(SIGNALS), (name, term.follows)


def test_each_signal_is_followed_by_a_term() -> None:
    assert all(like(signal) for signal in SIGNALS)


def test_a_time_shift_names_the_terms_own_parameters_with_a_sign() -> None:
    for name, term in LIBRARY.items():
        own = {p.name for p in term.PARAMS}
        assert set(term.time_shift) <= own, (name, term.time_shift)
        assert all(sign in (-1.0, 1.0) for sign in term.time_shift.values()), name


def test_only_a_sensor_that_shifts_in_time_gets_the_consistency_checks() -> None:
    for name, term in LIBRARY.items():
        assert checked(name) == (term.sensor and bool(term.time_shift)), name
    assert any(checked(name) for name in LIBRARY)
    assert not checked("no_such_term")
