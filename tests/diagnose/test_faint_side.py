"""A contact side whose own force stays below the least force that matters is held off
(`Term.faint`), as a side the data cannot place is: beside a 2-3 mm deep bump stop on the
held-out plant the fit put 0.14 N of top-out at x = 0, the refit on every test pinned its
onset at the range's end, and the stop was dropped with it as no estimate."""

from __future__ import annotations

import numpy as np
import pytest
from bumped import bumped

from shockdyno.diagnose import candidates
from shockdyno.diagnose.candidates import try_candidate
from shockdyno.model.terms.contact import Contact

STROKE = 0.03
OFF = {q.name: q.off for q in Contact.PARAMS}


def _values(**given: float) -> dict[str, float]:
    p = {q.name: q.nominal for q in Contact.PARAMS}
    p.update(hysteresis=0.0, viscous_s_m=0.0, exponent=2.0)
    p.update(given)
    return p


def test_a_side_below_the_limit_goes_off_with_its_onset() -> None:
    t = np.linspace(0.0, 2.0, 2001)
    x, v = STROKE * np.sin(2 * np.pi * t), STROKE * 2 * np.pi * np.cos(2 * np.pi * t)
    p = _values(bump_onset_m=0.027, bump_force_n=560.0, topout_onset_m=-0.01, topout_force_n=0.5)
    # The top-out's largest force: 0.5 N at 20 mm past its onset, (20/10)² x 0.5 = 2 N.
    peak = 0.5 * ((STROKE - 0.01) / 0.01) ** 2
    off = Contact().faint(p, x, v, limit_n=1.01 * peak)
    assert off == {"topout_force_n": 0.0, "topout_onset_m": OFF["topout_onset_m"]}
    assert Contact().faint(p, x, v, limit_n=0.99 * peak) == {}
    # Both sides too weak: the stop's shape and losses move nothing either.
    both = Contact().faint({**p, "exponent": 1.5}, x, v, limit_n=1e4)
    assert both["bump_force_n"] == 0.0 and both["topout_force_n"] == 0.0
    assert both["exponent"] == OFF["exponent"] != 1.5


def test_a_loss_counts_toward_a_sides_force() -> None:
    t = np.linspace(0.0, 1.0, 1001)
    x, v = STROKE * np.sin(2 * np.pi * t), STROKE * 2 * np.pi * np.cos(2 * np.pi * t)
    elastic = _values(bump_onset_m=0.02, bump_force_n=1.0, topout_force_n=0.0)
    lossy = {**elastic, "viscous_s_m": 10.0}
    # Elastic, 1 N at the stroke's end (where v = 0); going in at 10 mm past the onset
    # less 1 mm (v = 48 mm/s there) the loss makes 0.81 N x (1 + 10 s/m x 0.048 m/s) = 1.2 N.
    peak = 1.0 * ((STROKE - 0.02) / 0.01) ** 2
    assert Contact().faint(elastic, x, v, limit_n=1.05 * peak) != {}
    assert Contact().faint(lossy, x, v, limit_n=1.05 * peak) == {}


def test_the_candidate_is_judged_without_a_faint_top_out(monkeypatch: pytest.MonkeyPatch) -> None:
    onset, force = 0.026, 400.0  # a 4 mm deep bump stop, 400 N 10 mm past its onset
    b = bumped(onset, force)
    data, base, means, noise = b.data, b.base, b.means, b.noise
    start = {
        "contact.bump_onset_m": 0.025,
        "contact.bump_force_n": 300.0,
        "contact.topout_onset_m": -0.001,
        "contact.topout_force_n": 0.01,
    }
    monkeypatch.setattr(candidates, "best_start", lambda d, m, n, b: m.with_values(start))
    limit = 3.0
    # Without the limit the fit keeps a top-out too weak to matter (6.5 N beyond the stroke).
    kept = try_candidate(data, base, means, "contact", noise, 30)
    top = kept.fitted.model.value("contact.topout_force_n")
    assert top > 0
    c = try_candidate(data, base, means, "contact", noise, 30, limit)
    model = c.fitted.model
    assert model.value("contact.topout_force_n") == 0.0
    assert not any(q.startswith("contact.topout") for q in c.fitted.free)
    assert model.value("contact.bump_onset_m") == pytest.approx(onset, abs=5e-4)
    assert c.p_value <= 0.01
