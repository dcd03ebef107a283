"""Every threshold of the diagnosis in one place: the search, the claim rules, where the
mismatch is and how the verdict words it (docs/diagnose-method.md). `diagnose --alpha` and the
verdict read the same object."""

from __future__ import annotations

from dataclasses import dataclass

from shockdyno.model.terms import LIBRARY


@dataclass(frozen=True)
class Settings:
    alpha: float = 0.01
    screen_alpha: float = 0.05
    # Share of the held-out structure a claimed term must remove (in the median fold).
    min_gain: float = 0.1
    # ... and a term joining terms already claimed. The first claim's form is never exactly
    # the damper's, so what is left held out is its misfit plus any second effect, and a
    # real second effect can be the smaller part: on reference-plant sweeps (seed 501, a
    # development seed) a 30 N breakaway beside 0.5 % air removed 13 % of what the air's
    # model left, vapour beside a 4 ms skew 45 %. A bar of one half (set when a joining
    # term's gain could be the refit's: 12-36 % on single-effect sim-rig sweeps) refused
    # both. What stops a term that only soaks up a claimed one's misfit is now its own
    # force (a candidate's gain counts only if its own force, the model less the model
    # with the term off, matters) and its parameters (moved off, physical, placed): on
    # the same seed's single-effect sweeps (air at 0.5 and 2 %, vapour, a bump stop) those
    # refused every joining candidate, and the best held-out share among them was 0.13
    # (a sensor delaying both channels alike) where it was not negative.
    min_gain_joining: float = 0.1
    # Too weak to matter: a term whose largest effect on a phase mean is below this share
    # of the largest force, or below three noise-σ of a phase mean.
    min_effect_share: float = 0.001
    max_terms: int = 3
    n_boot: int = 999
    seed: int = 0
    max_nfev: int = 15
    final_nfev: int = 60  # the final model's refit, whose values the verdict reports
    fold_nfev: int = 8
    # The search for terms runs on at most this many click settings, spread over the
    # sweep (the terms are the damper's, not a click's); the model it finds is then
    # refitted to every test.
    search_clicks: int = 8
    # Candidates per round scored on held-out tests, largest LR first (None: every one
    # with p < alpha). Two was too few: a second real effect ranked third behind two
    # look-alikes of the first was never claimable.
    heldout_top: int | None = None
    objective_rate_hz: float = 100.0
    full_rate_hz: float | None = None  # fast lags at up to this rate (None: the recording's)
    candidates: tuple[str, ...] = tuple(LIBRARY)
    # Spec values the search may calibrate beside the physics (diagnose/fitting.CALIBRATIONS:
    # a bleed's laminar land, a seal's turn), claimed by the same rules, reported as
    # calibration. Not limited by `--terms`.
    calibrations: tuple[str, ...] = ("bleed_land", "valve_land", "seal_turn")

    @property
    def max_rounds(self) -> int:
        """Search rounds at most: one a claimed term, or a calibration taken."""
        return self.max_terms + len(self.calibrations)

    # A sensor's delay is one time for the sweep (diagnose/consistency.py): a sensor-lag
    # candidate whose per-test delays spread more than this (s, plus a share of their
    # median) is the damper's lag, not a sensor's. Tests place a delay when it removes
    # this share of their squared error.
    sensor_delay_spread_s: float = 0.001
    sensor_delay_spread_share: float = 0.25
    sensor_delay_min_gain: float = 0.3
    sensor_delay_min_shift_s: float = 5e-4  # a sensor shifting less has no time to compare
    # A term must take this share of the structure where its own force acts
    # (diagnose/in_place.py): real lags, stops, air and vapour took 92-100 % of it on the
    # held-out and reference plants, the reference plant's heat and seal friction 62 % and
    # 61 %; a lag standing in for an LVDT's play 22 %, a bump stop standing in for a
    # valve's hysteresis 18 %.
    min_in_place: float = 0.5
    # A term of the cycle whose own force acts in at least placeless_share of the (test,
    # phase bin) cells (seal drag, a fixture's mass, a position force) has no place apart
    # from the valves': the cells where it acts hold their misfit too, which it cannot
    # take. It is judged held out instead, by the bar a discovered term is claimed at
    # (unnamed_min_gain): a named claim needs no less evidence than an unnamed one.
    placeless_share: float = 0.5
    # Shapes: a later candidate whose explained structure has a cosine above same_shape
    # with a claimed one's refines that physics (not a second one). Two candidates of one
    # round are alike (the verdict cannot tell them apart) above alike_cosine when held
    # out the other leaves at most alike_rest_ratio × the claimed one's rest + alike_rest_margin.
    same_shape: float = 0.8
    alike_cosine: float = 0.9
    alike_rest_ratio: float = 1.5
    alike_rest_margin: float = 0.05
    # A calibrated spec value is worth a sentence off the spec's by this share (and 3σ).
    calibration_share: float = 0.05
    # Where (locate.py): at most max_regions cells, the largest first, until they hold
    # region_cover of the structure, none under region_min_share; a region's frequencies
    # are those with region_frequency_share of its structure. Near reversal: slower than
    # reversal_speed_share of the sweep's peak speed. Temperature is an axis when the channel
    # spreads more than temperature_spread_k.
    max_regions: int = 5
    region_cover: float = 0.8
    region_min_share: float = 0.05
    region_frequency_share: float = 0.15
    reversal_speed_share: float = 0.1
    temperature_spread_k: float = 0.5
    # How the structure behaves, in the verdict's words (verdict._signature): "near
    # velocity reversal" from this share, "growing with frequency" when the highest holds
    # frequency_growth × the lowest's, "in compression/rebound" from stroke_share, and
    # "changing over the session" when the halves differ by session_change.
    near_reversal_share: float = 0.3
    frequency_growth: float = 1.5
    stroke_share: float = 0.75
    session_change: float = 0.4
    # Physics outside the library (diagnose/discover.py): what the search leaves, while
    # significant, is described (the `unnamed_follows` signals that explain most of it
    # alone) and a discovered term of at most `unnamed_max_features` features tried for
    # it: claimed ("unnamed: F ≈ ...") when it removes `unnamed_min_gain` of the held-out
    # structure (median fold), the fewest features within `unnamed_size_tolerance` of the
    # best gain.
    unnamed_follows: int = 3
    unnamed_max_features: int = 3
    unnamed_min_gain: float = 0.3
    unnamed_size_tolerance: float = 0.05
    # A form of bands of the stroke is refused when the same signals over the whole stroke
    # explain this share of what the bands do: the position is then not what it follows
    # (on a heat sweep, dev seed 901, two complementary bands of "1 mm² more bleed" had
    # taken a thermal claim's misfit, 64 % held out).
    unnamed_position_share: float = 0.8
