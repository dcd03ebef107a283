"""ISO 8608 road synthesis (eq. 20-23) against its defining PSD."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.signal import welch

from shockdyno.errors import ConfigError
from shockdyno.model.road import (
    DEFAULT_BAND_RAD_M,
    class_psd,
    road_psd,
    synthesize_road,
)


def test_classes_are_the_papers_table6_geometric_means() -> None:
    got = [class_psd(c) * 1e6 for c in "ABCDE"]
    assert got == pytest.approx([1, 4, 16, 64, 256], rel=1e-12)
    assert class_psd(" c ") == class_psd("C")
    with pytest.raises(ConfigError, match="road class"):
        class_psd("Z")


def test_same_seed_same_road_other_seed_other_road() -> None:
    a = synthesize_road(16e-6, 500.0, seed=7).period_samples(2**15)
    b = synthesize_road(16e-6, 500.0, seed=7).period_samples(2**15)
    c = synthesize_road(16e-6, 500.0, seed=8).period_samples(2**15)
    np.testing.assert_array_equal(a, b)
    assert np.corrcoef(a, c)[0, 1] < 0.5


def test_fft_synthesis_equals_the_direct_sum_of_eq20() -> None:
    road = synthesize_road(4e-6, 200.0, seed=1)
    n = 2**14
    s = np.arange(0, n, 37) * road.length_m / n
    np.testing.assert_allclose(road.period_samples(n)[::37], road.elevation(s), atol=1e-12)


def test_road_classes_with_one_seed_differ_by_the_square_root_of_their_psd() -> None:
    a = synthesize_road(class_psd("A"), 300.0, seed=3).period_samples(8192)
    c = synthesize_road(class_psd("C"), 300.0, seed=3).period_samples(8192)
    np.testing.assert_allclose(c, 4.0 * a, rtol=1e-12, atol=1e-15)


def test_profile_psd_matches_eq23_across_the_band() -> None:
    """Welch's estimate of the synthesised profile's PSD is S_g(Ω) (one-sided, rad/m)."""
    a_g, length = 16e-6, 4000.0
    road = synthesize_road(a_g, length, seed=11)
    n = 2**18
    z = road.period_samples(n)
    # Welch gives m² per (cycle/m); per (rad/m) divides by 2π.
    f_cyc, g = welch(z, fs=n / length, nperseg=2**14)
    omega = 2 * math.pi * f_cyc
    est = g / (2 * math.pi)
    edges = np.geomspace(0.3, 15.0, 8)
    for lo, hi in itertools.pairwise(edges):
        sel = (omega >= lo) & (omega < hi)
        ratio = np.mean(est[sel]) / np.mean(road_psd(omega[sel], a_g))
        assert ratio == pytest.approx(1.0, abs=0.08), (lo, hi)
    # And the road's variance is the PSD's integral over the band (1/Ω_min - 1/Ω_max).
    lo, hi = DEFAULT_BAND_RAD_M
    assert road.rms_m() ** 2 == pytest.approx(a_g * (1 / lo - 1 / hi), rel=0.03)
    assert float(np.var(z)) == pytest.approx(road.rms_m() ** 2, rel=1e-9)


def test_bad_road_requests_are_config_errors() -> None:
    with pytest.raises(ConfigError, match="band"):
        synthesize_road(1e-6, 100.0, band_rad_m=(2.0, 1.0))
    with pytest.raises(ConfigError, match="no harmonic"):
        synthesize_road(1e-6, 1.0, band_rad_m=(0.1, 1.0))
    with pytest.raises(ConfigError, match="too coarse"):
        synthesize_road(1e-6, 1000.0).period_samples(1000)
