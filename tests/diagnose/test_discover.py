"""A residual no library term explains is described and modelled by a discovered term,
held out; a clean sweep gets none (in-process, on the synthetic sweep of fit/synthetic.py
with an effect added that no term has: rod-guide friction growing toward full extension,
as a misaligned fixture's side load makes)."""

from __future__ import annotations

import base64
from dataclasses import replace
from html import unescape
from pathlib import Path

import numpy as np
import pytest

from shockdyno.diagnose.candidates import folds
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.diagnosis import Diagnosis
from shockdyno.diagnose.discover import build_rows, fold_rows
from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.features import Stroke
from shockdyno.diagnose.fitting import refit
from shockdyno.diagnose.report import write_report
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.verdict import document, to_json
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model import load_spec
from shockdyno.model.composite import DamperModel
from shockdyno.model.kinematics import differentiate
from shockdyno.record.types import TestData
from shockdyno.report.build import build_report
from shockdyno.units import IMPERIAL

ONSET_M = -0.005  # the side load starts here and grows toward full extension
RATE_N_PER_M = 1.5e3  # 1.5 N per mm: 37 N at -30 mm
# the search with one named candidate: the test is of the discovery after it
SETTINGS = Settings(candidates=("friction",), calibrations=(), n_boot=199)


def _sweep(side_load: bool) -> list[TestData]:
    tests = synthetic_sweep(load_spec(), [4, 16], cycles=4, seed=11)
    if not side_load:
        return tests
    out = []
    for t in tests:
        v, _ = differentiate(t.t, t.x)
        load = RATE_N_PER_M * np.maximum(ONSET_M - t.x, 0.0)
        out.append(replace(t, force=t.force + load * np.tanh(v / 1e-3)))
    return out


@pytest.fixture(scope="module")
def side_load() -> Diagnosis:
    return diagnose(_sweep(True), settings=SETTINGS)


def test_side_load_friction_is_located_described_and_modelled_unnamed(side_load: Diagnosis) -> None:
    doc = to_json(side_load)
    verdict = doc["verdict"]
    assert verdict["physics"] == [], verdict["text"]  # no named physics stands in for it
    left = verdict["unexplained"][0]
    assert left["stroke"] in ("rebound", "compression")
    assert left["x_range_m"][0] < ONSET_M  # it lies where the rod is extended
    term = left["term"]
    assert term["claimed"], term["why_not"]
    families = {c["family"] for c in term["coefficients"]}
    assert families == {"position × friction"}, term["form"]
    assert term["heldout_gain"] >= 0.5, term["heldout_detail"]
    assert "Unnamed: F ≈" in verdict["text"] and "side load" in verdict["text"]
    # the plot's points are the phase means of every test
    assert len(left["plot"]["x"]) == len(left["plot"]["residual"]) == 40 * len(doc["tests"])


def test_its_coefficient_is_the_side_load_s_rate(side_load: Diagnosis) -> None:
    term = side_load.described[0].term
    assert term is not None and term.claimed
    (c,) = term.coefficients
    # a hinge at the nearest knot, (k - x)+ · sgn ẋ: its rate within a third of the truth
    assert c.feature.unit == "m"
    assert c.value == pytest.approx(RATE_N_PER_M, rel=0.35), (c.feature.key, c.value)


def test_a_clean_sweep_gets_no_discovered_term() -> None:
    d = diagnose(_sweep(False), settings=SETTINGS)
    doc = to_json(d)
    claimed = [u for u in doc["verdict"]["unexplained"] if (u.get("term") or {}).get("claimed")]
    assert claimed == [], doc["verdict"]["text"]


def _embedded_png(html: str) -> bytes:
    start = html.index('src="data:image/png;base64,') + len('src="data:image/png;base64,')
    return base64.b64decode(html[start : html.index('"', start)])


def test_the_report_shows_it_with_a_figure_of_the_residual_against_what_it_follows(
    side_load: Diagnosis, tmp_path: Path
) -> None:
    doc = to_json(side_load)
    form = doc["verdict"]["unexplained"][0]["term"]["form"]
    index = build_report([], tmp_path / "page", title="t", diagnose=doc)
    html = unescape(index.read_text())
    assert "What is left: described" in html and form in html
    assert "the direction of motion, growing below" in html  # the signal, in words
    png = _embedded_png(html)
    assert png.startswith(b"\x89PNG") and len(png) > 5000
    # the diagnose command's own page, in imperial units
    page = write_report(side_load, document(side_load), tmp_path / "diag", IMPERIAL)
    text = unescape(page.read_text())
    assert doc["verdict"]["unexplained"][0]["term"]["form_imperial"] in text
    assert "lbf/in" in text and _embedded_png(text).startswith(b"\x89PNG")


def test_one_setting_is_held_out_by_its_halves() -> None:
    # One click at one frequency: the folds are its first and second halves in time.
    tests = synthetic_sweep(load_spec(), [16], (1.0,), cycles=8, seed=12)
    t = tests[0]
    v, _ = differentiate(t.t, t.x)
    load = RATE_N_PER_M * np.maximum(ONSET_M - t.x, 0.0) * np.tanh(v / 1e-3)
    d = diagnose([replace(t, force=t.force + load)], settings=SETTINGS)
    (left,) = d.described
    assert left.term is not None
    assert "half predicted" in left.term.heldout_detail, left.term.heldout_detail
    assert "Still unexplained" in to_json(d)["verdict"]["text"]


def test_the_figure_s_term_lies_on_the_residual_it_removes(side_load: Diagnosis) -> None:
    # The term is fitted beside the model's own parameters (the gas charge takes a constant,
    # the Coulomb friction a step): the figure draws the force it removes with them, so the
    # red points lie on the grey where the term explains them, as its share says.
    (left,) = side_load.described
    assert left.term is not None and left.term.claimed
    residual = np.asarray(left.plot["residual"])
    term = np.asarray(left.plot["term"])
    removed = 1.0 - float(np.sum((residual - term) ** 2)) / float(np.sum(residual**2))
    assert removed == pytest.approx(left.term.in_sample_share, abs=0.05)


def test_a_half_s_features_sit_in_the_whole_recording_s_columns() -> None:
    # One setting whose oil warms in its second half only: the first half has no
    # temperature features (T, T*F_d), the whole recording and the second half do. The
    # halves' rows must still put each feature in the whole's column, or a form chosen on
    # the whole is read off the wrong features (a recording cut short raised IndexError).
    spec = load_spec()
    (t,) = synthetic_sweep(spec, [16], (1.0,), cycles=8, seed=12)
    mid = 0.5 * (t.t[0] + t.t[-1])
    temp = 40.0 + np.clip(t.t - mid, 0.0, None) * 0.5
    prepared, _ = prepare_tests([replace(t, temperature=temp)])
    data = Data.build(spec, prepared)
    fitted = refit(data, DamperModel(spec), (), None, max_nfev=10)
    stroke = Stroke.of(data)
    rows, table = build_rows(data, fitted, stroke)
    keys = [f.key for f in table.features]
    assert "T" in keys
    halves = fold_rows(data, rows, fitted, stroke, keys)
    assert {f.label for f in halves} == {"second half predicted", "first half predicted"}
    own = {f.label: build_rows(f.train, fitted, stroke) for f in folds(data)}
    without_t = 0
    for f in halves:
        assert f.train.phi.shape[1] == f.test.phi.shape[1] == len(keys)
        own_rows, own_table = own[f.label]
        own_keys = [ft.key for ft in own_table.features]
        for key in ("x", "v"):  # after the temperature's columns in the table
            mine = f.train.phi[:, keys.index(key)]
            assert np.array_equal(mine, own_rows.phi[:, own_keys.index(key)])
        if "T" not in own_keys:
            without_t += 1
            assert not np.any(f.train.phi[:, keys.index("T")])
    assert without_t == 1  # the case this test is about: one half has no temperature
