"""A model sent to another process and back reads each term's own values: the per-model
lookup of a term's values is by the term's id, and an id from another process (or one an
object took since) is not another term's."""

from __future__ import annotations

import pickle

from shockdyno.model import DamperModel, load_spec
from shockdyno.model.terms import make_term


def _model() -> DamperModel:
    terms = (make_term("friction"), make_term("sensor_lag"))
    values = {"friction.breakaway_n": 31.0, "sensor_lag.delay_s": 0.002}
    return DamperModel(load_spec(), terms, values)


def test_a_model_back_from_a_worker_reads_each_terms_own_values() -> None:
    m = _model()
    before = {t.name: m.local_values(t) for t in m.terms}  # the lookup made and cached
    back = pickle.loads(pickle.dumps(m))
    assert "_locals" not in back.__dict__  # not sent: its ids are this process's
    assert {t.name: back.local_values(t) for t in back.terms} == before
    assert back.local_values(back.term("sensor_lag"))["delay_s"] == 0.002


def test_an_id_another_term_had_is_not_read_as_this_terms() -> None:
    # What a forked worker's ids did: the lookup held, under the sensor lag's id here, the
    # entry of another term (the friction's), as the other process had laid them out.
    m = _model()
    friction, lag = m.term("friction"), m.term("sensor_lag")
    assert friction is not None and lag is not None
    m.__dict__["_locals"] = {id(lag): (friction, m.local_values(friction))}
    got = m.local_values(lag)
    assert set(got) == {"delay_s", "load_cell_lag_s", "lvdt_lag_s"} and got["delay_s"] == 0.002
