"""The diagnosis's statistics: honest about how few independent values a residual holds."""

from __future__ import annotations

import numpy as np
from scipy import stats as sps

from shockdyno.diagnose.candidates import step_p
from shockdyno.diagnose.cycles import N_BINS, bin_residual, cycle_starts, phase_of
from shockdyno.diagnose.stats import lr_bootstrap, mismatch_test, noise_draws


def _cycles(n_cycles: int = 5, per: int = 400) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n_cycles * per) / per
    return t, 0.03 * np.sin(2 * np.pi * t)


def _smooth_noise(rng: np.random.Generator, n: int, width: int = 25) -> np.ndarray:
    """Noise correlated over `width` samples, like a residual of a smoothed velocity."""
    white = rng.standard_normal(n + width)
    return np.convolve(white, np.ones(width) / np.sqrt(width), mode="valid")[:n]


def test_cycles_are_found_from_the_motion_for_a_sine_and_a_slider_crank() -> None:
    t, x = _cycles(6)
    starts = cycle_starts(t, x)
    np.testing.assert_allclose(np.diff(starts), 1.0, atol=2e-3)
    theta = 2 * np.pi * 0.8 * t
    crank = 0.025 * np.cos(theta) + np.sqrt(0.1**2 - (0.025 * np.sin(theta)) ** 2) - 0.1
    np.testing.assert_allclose(np.diff(cycle_starts(t, crank)), 1 / 0.8, atol=3e-3)
    ph = phase_of(t, x)
    assert ph.n_cycles == 6 and set(np.unique(ph.bin)) == set(range(N_BINS))


def test_correlated_noise_is_not_called_structure_though_a_per_sample_test_would() -> None:
    """20 records of correlated noise: a per-sample χ² test rejects nearly every one;
    the cycle bootstrap keeps its level (about 1 in 20 at p < 0.05)."""
    rng = np.random.default_rng(3)
    t, x = _cycles(6)
    ph = phase_of(t, x)
    ours, naive = [], []
    for _ in range(20):
        r = _smooth_noise(rng, t.size) * 2.0
        binned = [bin_residual(r, ph)]
        ours.append(mismatch_test(binned, rng, 199).p_value)
        # Per-sample test of the phase means against white noise of the sample σ.
        b = binned[0]
        n_per_bin = b.counts.sum(axis=0)
        chi2 = float(np.sum(b.mean**2 * n_per_bin) / b.noise_sd_n**2)
        naive.append(float(sps.chi2.sf(chi2, N_BINS)))
    assert np.mean(np.array(naive) < 0.05) > 0.8
    assert np.mean(np.array(ours) < 0.05) <= 0.2


def test_structure_beyond_noise_is_found() -> None:
    rng = np.random.default_rng(4)
    t, x = _cycles(5)
    r = _smooth_noise(rng, t.size) * 2.0 + 1.5 * np.sign(np.cos(2 * np.pi * t))
    m = mismatch_test([bin_residual(r, phase_of(t, x))], rng, 199)
    assert m.p_value <= 0.01
    assert 1.0 < m.structured_rms_n < 2.0


def test_the_likelihood_ratio_bootstrap_keeps_its_level_on_noise() -> None:
    """Null data (noise), an extra column that can only fit noise: p is not small more
    often than it should be; a real effect along that column gives a tiny p."""
    rng = np.random.default_rng(5)
    t, x = _cycles(5)
    ph = phase_of(t, x)
    base_cols = np.column_stack([np.ones(N_BINS), np.sin(np.linspace(0, 2 * np.pi, N_BINS))])
    extra = np.cos(np.linspace(0, 4 * np.pi, N_BINS))[:, None]
    j_alt = np.hstack([base_cols, extra])
    ps = []
    for _ in range(30):
        r = _smooth_noise(rng, t.size)
        b = bin_residual(r, ph)
        y = b.mean
        rss0 = np.sum((y - base_cols @ np.linalg.lstsq(base_cols, y, rcond=None)[0]) ** 2)
        rss1 = np.sum((y - j_alt @ np.linalg.lstsq(j_alt, y, rcond=None)[0]) ** 2)
        ps.append(lr_bootstrap(float(rss0 - rss1), base_cols, j_alt, noise_draws([b], rng, 199)))
    assert np.mean(np.array(ps) < 0.05) <= 0.2
    r = _smooth_noise(rng, t.size) + 3.0 * np.cos(4 * np.pi * t)
    b = bin_residual(r, ph)
    y = b.mean
    rss0 = np.sum((y - base_cols @ np.linalg.lstsq(base_cols, y, rcond=None)[0]) ** 2)
    rss1 = np.sum((y - j_alt @ np.linalg.lstsq(j_alt, y, rcond=None)[0]) ** 2)
    assert lr_bootstrap(float(rss0 - rss1), base_cols, j_alt, noise_draws([b], rng, 199)) < 0.01


def test_a_refinements_step_is_judged_by_the_refit_it_points_to_not_by_its_own_error() -> None:
    """`step_p` (is a refinement's start worth a refit?): for a linear model its statistic
    is the linear refit's drop in Σ mean² exactly, whatever the step's length (a start that
    overshoots, with more squared error than the fit, still points at the effect), and a
    step the fit's own columns already span is worth nothing."""
    rng = np.random.default_rng(11)
    t, x = _cycles(5)
    ph = phase_of(t, x)
    grid = np.linspace(0, 2 * np.pi, N_BINS)
    base_cols = np.column_stack([np.ones(N_BINS), np.sin(grid)])
    extra = np.cos(2 * grid)
    j_alt = np.column_stack([base_cols, extra])
    b = bin_residual(_smooth_noise(rng, t.size) + 3.0 * np.cos(4 * np.pi * t), ph)
    fit = base_cols @ np.linalg.lstsq(base_cols, b.mean, rcond=None)[0]
    resid = fit - b.mean  # the fit's residual means (model less data), as candidates' are
    rss1 = np.sum((b.mean - j_alt @ np.linalg.lstsq(j_alt, b.mean, rcond=None)[0]) ** 2)
    drop = float(np.sum(resid**2) - rss1)
    noise = noise_draws([b], np.random.default_rng(1), 199)
    expected = lr_bootstrap(drop, base_cols, j_alt, noise)
    assert expected < 0.01
    for length in (0.1, 100.0):  # short, and far past the effect (more error than the fit)
        step = length * extra + 5.0 * base_cols[:, 1]  # with a part the fit spans already
        assert step_p(resid, step, base_cols, noise) == expected
    overshoot = resid + 100.0 * extra
    assert np.sum(overshoot**2) > np.sum(resid**2)
    assert step_p(resid, 2.0 * base_cols[:, 0] - base_cols[:, 1], base_cols, noise) == 1.0
    # On noise alone a step is not called worth a refit more often than the level says.
    ps = []
    for _ in range(30):
        b = bin_residual(_smooth_noise(rng, t.size), ph)
        fit = base_cols @ np.linalg.lstsq(base_cols, b.mean, rcond=None)[0]
        ps.append(step_p(fit - b.mean, extra, base_cols, noise_draws([b], rng, 199)))
    assert np.mean(np.array(ps) < 0.05) <= 0.2


def _bottom_to_bottom(n_cycles: int = 3, per: int = 1000) -> tuple[np.ndarray, np.ndarray]:
    """A test cut from the bottom of the stroke to the bottom, as the reference plant's
    are: whole cycles and one sample more, on a reversal at each end."""
    t = np.arange(n_cycles * per + 1) / per
    return t, -0.03 * np.cos(2 * np.pi * t)


def test_cells_cut_short_by_a_records_ends_are_left_out() -> None:
    t, x = _bottom_to_bottom()
    plain, whole = phase_of(t, x), phase_of(t, x, whole_cells=True)
    dropped = (plain.cycle >= 0) & (whole.cycle < 0)
    # The last sample is alone in its cell (the bin starts on it): left out. The first
    # sample opens its bin, so its cell is whole: kept.
    assert dropped[-1] and not dropped[0]
    assert np.count_nonzero(dropped) == 1
    # Started 5 ms into a bin, the first cell is part of one: left out with its samples.
    late = phase_of(t[5:], x[5:], whole_cells=True)
    cut = phase_of(t[5:], x[5:])
    same = (cut.cycle == cut.cycle[0]) & (cut.bin == cut.bin[0])
    assert np.all(late.cycle[same] < 0) and np.count_nonzero(same) == 25 - 5


def test_a_sharp_turn_at_the_ends_is_not_read_as_noise_with_whole_cells() -> None:
    """A 40 N turn in the 3 ms after every bottom reversal repeats each cycle: it is
    structure. Cut at a reversal, the last cell holds only the turn's first sample, and
    the scatter of the cells reads its difference from the whole cells as noise."""
    rng = np.random.default_rng(5)
    t, x = _bottom_to_bottom()
    since = np.mod(t, 1.0)
    r = 40.0 * np.exp(-since / 0.002) + rng.standard_normal(t.size)
    true_var = N_BINS * 1.0 / (t.size / N_BINS)  # σ²/n per bin, summed over bins
    plain_phase = phase_of(t, x)
    plain = bin_residual(r, plain_phase)
    whole = bin_residual(r, phase_of(t, x, whole_cells=True))
    # Without whole cells the last one (the turn's first sample) is far from the others
    # at its phase; the lone-cell rule takes it out too, as the scatter's largest term.
    last = plain_phase.cycle[-1], plain_phase.bin[-1]
    assert np.isnan(plain.cell[last])
    assert float(np.sum(plain.mean_var)) < 2 * true_var
    assert float(np.sum(whole.mean_var)) < 2 * true_var
    assert mismatch_test([whole], rng, 199).p_value <= 0.01


def _grid(n_cycles: int = 5, per: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """The diagnosis's grid: every 10th sample of a 1 Hz test at 1 kHz (2-3 per bin)."""
    t = np.arange(n_cycles * per) / per
    return t, 0.03 * np.sin(2 * np.pi * t)


def test_a_sample_on_a_force_step_in_one_cycle_does_not_set_the_noise() -> None:
    """A closed click's force steps 1900 N within 2 ms of a reversal; in one cycle a grid
    sample fell on the step (a 227 N residual). With it, its bin's scatter hid 1.5 N of
    structure; without it, the structure is seen, and nothing else is dropped."""
    rng = np.random.default_rng(7)
    t, x = _grid()
    ph = phase_of(t, x, whole_cells=True)
    structure = 1.5 * np.sign(np.cos(2 * np.pi * t))
    r = rng.standard_normal(t.size) * 2.0 + structure
    clean = bin_residual(r, ph)
    hit = r.copy()
    hit[np.flatnonzero((ph.cycle == 2) & (ph.bin == 10))[0]] += 227.0
    stepped = bin_residual(hit, ph)
    # The lone cell is left out: the same phase means as without it, but for that bin.
    others = np.arange(N_BINS) != 10
    np.testing.assert_allclose(stepped.mean[others], clean.mean[others])
    assert np.isnan(stepped.cell[2, 10]) and np.isfinite(clean.cell).all()
    assert (stepped.lone, clean.lone) == (1, 0)
    assert stepped.noise_sd_n < 1.2 * clean.noise_sd_n
    m = mismatch_test([stepped], rng, 199)
    assert m.p_value <= 0.01 and m.lone_cells == 1
    # Kept when it is not alone: the same excess in every cycle is structure, and a
    # drift over the cycles (oil warming) is neither structure nor a glitch.
    every = r + 227.0 * (ph.bin == 10)
    assert np.isfinite(bin_residual(every, ph).cell).all()
    drift = r + 30.0 * ph.cycle
    assert np.isfinite(bin_residual(drift, ph).cell[ph.cycle.max() >= 0]).all()


def test_a_window_that_starts_on_the_centre_going_up_keeps_its_first_cycle() -> None:
    """A measured window begins where the sine crosses its centre going up: that crossing
    was not seen, so a 3-cycle test read as one cycle and a 2-cycle test too, and the
    structure in them had no cycle-to-cycle scatter to be judged against (p = 1 on a
    3-cycle sim-rig sweep with 25 N of stiction that 4 cycles named)."""
    rng = np.random.default_rng(5)
    for cycles in (2, 3):
        t = np.arange(0.0, cycles / 1.0, 1e-3)
        x = 0.03 * np.sin(2 * np.pi * t) + rng.normal(0, 2e-6, t.size)
        starts = cycle_starts(t, x)
        np.testing.assert_allclose(starts, np.arange(cycles), atol=2e-3)
        ph = phase_of(t, x, whole_cells=True)
        assert ph.n_cycles == cycles
        # 10 N of structure near reversal beside 2 N of noise: seen.
        v = np.gradient(x, t)
        r = 10.0 * np.exp(-((v / 0.02) ** 2)) * np.sign(x) + rng.normal(0, 2.0, t.size)
        assert mismatch_test([bin_residual(r, ph)], rng, 199).p_value < 0.01
