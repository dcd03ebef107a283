"""A candidate's own effect is what the term does to the force, whatever stage it acts at.

A channel delay acts on the motion and a chamber on the pressure: neither adds a force
component of its own. Read from the components, a 7 ms skew of a reference-plant sweep
had an 'own force' of 1e-10 N while it moved the force by 586 N, was refused as too
small to matter, and the skew was named compressibility."""

from __future__ import annotations

import numpy as np

from shockdyno.diagnose.candidates import binned_means, own_force, try_candidate
from shockdyno.diagnose.claims import why_not
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import refit
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.stats import noise_draws
from shockdyno.fit.prepare import prepare_tests
from shockdyno.fit.synthetic import synthetic_sweep
from shockdyno.model.composite import DamperModel
from shockdyno.model.spec import load_spec


def test_a_delay_has_an_own_effect_and_is_claimable() -> None:
    spec = load_spec(None)
    tests = synthetic_sweep(spec, [5, 15], cycles=3, force_delay_s=0.005, seed=3)
    prepared, _ = prepare_tests(tests)
    data = Data.build(spec, prepared)
    base = refit(data, DamperModel(spec), (), None, max_nfev=30)
    means, binned = binned_means(data, base.residual)
    noise = noise_draws(binned, np.random.default_rng(0), 199)
    c = try_candidate(data, base, means, "sensor_lag", noise, 15)
    # A sweep pins the net shift (a delay and a load cell's lag trade off within it).
    m = c.fitted.model
    shift = sum(m.value(f"sensor_lag.{k}") for k in ("delay_s", "load_cell_lag_s"))
    assert abs(shift - m.value("sensor_lag.lvdt_lag_s") - 0.005) < 0.001
    # Its own force is the model with the delay less the same model without it: large,
    # as large as the change the candidate made to the fit.
    assert c.own_peak_n > 0.5 * c.effect_peak_n > 10.0, (c.own_peak_n, c.effect_peak_n)
    assert "too small" not in why_not(c, {"sensor_lag": (0.9, "")}, Settings(), 5.0)
    # The same term held at its off values (no delay, no lags) does nothing of its own.
    off = c.fitted.model.with_values(
        {"sensor_lag.delay_s": 0.0, "sensor_lag.load_cell_lag_s": 0.0, "sensor_lag.lvdt_lag_s": 0.0}
    )
    f = c.fitted
    idle = type(f)(off, f.free, f.areas, {}, f.force, f.residual)
    own = own_force(data, idle, "sensor_lag")
    assert own is not None and float(np.max(np.abs(own))) == 0.0
