"""A contact candidate whose top-out lands where the data cannot place it (the stroke's
last 10 %) has that side switched off and is fitted again: its bump stop is judged on its
own (a concealed bump had been refused whole for a top-out 0.36 mm deep, and the search
claimed a gas spring and a position force instead)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from bumped import bumped

from shockdyno.diagnose import candidates
from shockdyno.diagnose.candidates import try_candidate
from shockdyno.model.terms.contact import Contact

ONSET, FORCE = 0.021, 200.0  # the damper's bump stop: 200 N 10 mm past 21 mm


def test_a_side_the_data_cannot_place_goes_off_and_the_other_is_judged(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    b = bumped(ONSET, FORCE)
    data, base, means, noise = b.data, b.base, b.means, b.noise
    # The search's start: the bump near its place and a top-out 2 mm from the bottom of
    # the stroke. Left on, the fit takes that side to 0.33 mm deep at 320 N (where it
    # acts at reversal only): the whole term would be refused as not placed.
    bottom = float(np.min(data.prob.inputs.x))
    start = {
        "contact.bump_onset_m": 0.02,
        "contact.bump_force_n": 150.0,
        "contact.topout_onset_m": bottom + 2e-3,
        "contact.topout_force_n": 200.0,
    }
    monkeypatch.setattr(candidates, "best_start", lambda d, m, n, b: m.with_values(start))
    # The stop's loss held at none, as this damper's is: free, it lets this fit take the
    # top-out beyond the stroke instead (-38 mm, where it does nothing on the data), and
    # the side the data cannot place is what this test is about.
    elastic = tuple(
        replace(q, free=False) if q.name in ("hysteresis", "viscous_s_m") else q
        for q in Contact.PARAMS
    )
    monkeypatch.setattr(Contact, "PARAMS", elastic)
    x = data.prob.inputs.x
    with monkeypatch.context() as kept_on:
        kept_on.setattr(candidates, "_unseen", lambda *a: {})
        c = try_candidate(data, base, means, "contact", noise, 30)
        term = c.fitted.model.term("contact")
        assert term is not None
        assert "top-out only in the last" in term.unplaced(c.fitted.model.local_values(term), x)
    c = try_candidate(data, base, means, "contact", noise, 30)
    model = c.fitted.model
    term = model.term("contact")
    assert term is not None
    assert term.unplaced(model.local_values(term), x) == ""
    assert model.value("contact.topout_force_n") == 0.0
    assert not any(q.startswith("contact.topout") for q in c.fitted.free)
    assert model.value("contact.bump_onset_m") == pytest.approx(ONSET, abs=5e-4)
    assert model.value("contact.bump_force_n") == pytest.approx(FORCE, rel=0.1)
    assert c.p_value <= 0.01  # the smallest 99 draws can give
