"""The signals a residual the library cannot explain may follow: the feature library of
the discovered terms (diagnose/discover.py).

Each feature is a column over the diagnosis's objective samples, made from what a dyno
records (time, displacement, force, temperature) and from the fitted model (its damping
force, shifted in time): a force the model left out is sought as Σ c_k φ_k. A feature
says what it is in words and as a symbol, its unit (a coefficient's unit is N per it),
its family, and the library terms whose physics it already is (`resembles`: the terms whose
force follows its signal, `Term.follows`): those
describe what a residual follows, but a discovered ("unnamed") term is made only of
features that resemble none, so a discovered term is never a named physics under
another name.

Families (x: displacement, ẋ, ẍ its rates, F_d the model's damping force, the model's
force less its gas, inertia and Coulomb parts; positions over the stroke the data cover):

- time: the elapsed time t since the recording's first sample, and 1 - exp(-t/τ)
  (τ = 1, 3, 10 min): a load cell's zero drifting, the damper changing over a session.
  Heat's (`thermal`) when the temperature channel moved with the elapsed time (by 1 K or
  more, correlation 0.9 or more): the two cannot be told apart on such a recording.
- temperature: T - T̄ and (T - T̄)·F_d: the oil's temperature, which `thermal` models.
- motion: x, ẋ, |ẋ|ẋ, sgn ẋ, ẍ: the gas spring, a bleed's and a seal's laws, a moving
  mass: each a library term's or a calibration's.
- position × damping: w(x)·F_d, w a smooth band over part of the stroke: damping that
  changes over part of the stroke (a bypass groove, a position-sensitive valve, a
  scored tube).
- position × bleed: w(x)·[F_d(A + ΔA) − F_d(A)], the model's damping force with ΔA more
  bleed each way (the model's own flow law, each click's areas) over part of the stroke
  (over the whole stroke it is the areas' or heat's: the motion family):
  a bypass groove or port uncovered over part of the stroke (ΔA = 0.5-4 mm²; a
  coefficient near 1 is that path, a negative one a restriction).
- position × friction: w(x)·sgn ẋ and (k - x)₊·sgn ẋ, (x - k)₊·sgn ẋ: friction that
  changes along the stroke (a side load from a misaligned fixture, a worn guide).
- position: (x - k)₊, (k - x)₊: a force of position (contact, position_force).
- hysteresis of x: x − P_b[x] (the play operator of half-width b) and sgn ẋ·exp(−s/λ)
  (s: travel since the last reversal): a seal's presliding turn (friction, seal_turn).
- force hysteresis: P_h[F_d] − F_d, the damping force through a play of a share of each
  test's peak: a valve that opens and closes late whatever the speed (friction between
  the shims), which no library term has (its lags are times, not widths).
- force in travel: F_d(s + λ) − F_d(s), s the path travelled: the damping force λ of
  travel later, the same at every frequency. A force that leads the measured motion by a
  distance is a play in the position channel (the recorded x stands still while the rod
  takes up the lash after each reversal); earlier is a seal's presliding (friction).
- force in time: F_d(t + τ) − F_d(t): the damping force later (τ > 0: the measured force
  leads the measured motion, which no sensor and no damper physics of the library does:
  play or lag in the displacement channel) or earlier (τ < 0: a lag, which sensor_lag and
  compressibility model).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.data import Data
from shockdyno.diagnose.fitting import Fitted
from shockdyno.model.filters import segment_bounds
from shockdyno.model.terms import LIBRARY
from shockdyno.units import SI, Units

FloatArray = NDArray[np.float64]

DRIFT_TAUS_S = (60.0, 180.0, 600.0)
SHIFTS_S = (-0.008, -0.004, -0.002, 0.002, 0.004, 0.008, 0.016)
PLAY_HALF_WIDTHS_M = (2e-4, 5e-4, 1e-3, 2e-3)
TURN_TRAVELS_M = (3e-4, 1e-3, 3e-3)
FORCE_PLAY_SHARES = (0.02, 0.05, 0.1)
WARMED_K = 1.0  # a temperature channel that moved this much over the recording
WARMED_CORRELATION = 0.9  # ... in step with the elapsed time
TRAVEL_SHIFTS_M = (-1e-3, 2e-4, 5e-4, 1e-3, 2e-3)
EXTRA_AREAS_M2 = (0.5e-6, 1e-6, 2e-6, 4e-6)  # a second flow path, each way (the model's law)
N_KNOTS = 7  # knots over the stroke, its ends included: 6 sixths
EDGE_SHARE = 1 / 40  # a band's edge: a logistic over this share of the stroke
SIGN_SPEED_SHARE = 0.01  # sgn ẋ is tanh(ẋ / (this share of the peak speed))
NOT_MODEL = ("gas", "inertia", "coulomb")  # the parts of the model's force not its damping


# The signals the features below are made of, as a term's `follows` names them.
SIGNALS = (
    "displacement",
    "velocity",
    "direction",
    "acceleration",
    "temperature",
    "position",
    "presliding",
    "lag",
)


def like(signal: str) -> tuple[str, ...]:
    """The library terms whose force follows `signal` (Term.follows), in library order."""
    assert signal in SIGNALS, signal
    return tuple(name for name, term in LIBRARY.items() if signal in term.follows)


@dataclass(frozen=True)
class Feature:
    key: str  # stable name (DIAG.json)
    label: str  # in words: "the elapsed time"
    symbol: str  # in a form: "t"
    unit: str  # the feature's unit ("N": a force, whose coefficient is a share); SI
    family: str
    resembles: tuple[str, ...] = ()  # library terms (or calibrations) whose physics it is
    # The lengths and areas the label and symbol name ({0}, {1}, ...), SI, each with its
    # kind: "at" a position on the stroke, "len" a distance, "area" an area.
    quantities: tuple[tuple[str, float], ...] = ()
    # A feature of a band of the stroke: the key of the same signal over the whole stroke
    # (what it follows if the band is not what matters).
    base: str = ""

    def label_in(self, u: Units = SI) -> str:
        return self.label.format(*(_quantity(k, v, u) for k, v in self.quantities))

    def symbol_in(self, u: Units = SI) -> str:
        return self.symbol.format(*(_quantity(k, v, u) for k, v in self.quantities))

    @property
    def unnamed(self) -> bool:
        return not self.resembles

    @property
    def coefficient_unit(self) -> str:
        """The unit of a coefficient on this feature: N per its unit (a force's: 1)."""
        return {"1": "N", "N": "1", "N·K": "1/K"}.get(self.unit, f"N/{self.unit}")


@dataclass(frozen=True)
class FeatureTable:
    features: tuple[Feature, ...]
    values: FloatArray  # objective samples × features

    def column(self, key: str) -> FloatArray:
        return np.asarray(self.values[:, self.index(key)])

    def index(self, key: str) -> int:
        return next(i for i, f in enumerate(self.features) if f.key == key)


@dataclass(frozen=True)
class Stroke:
    """Where the knots of the position features lie: the stroke the whole recording covers
    (the same for every subset of its tests, so a fold's features are the full data's)."""

    lo_m: float
    hi_m: float
    peak_speed_m_s: float
    origin_s: float  # the recording's first sample: elapsed time counts from it
    temperature_c: float  # the recording's mean temperature (NaN: no channel)

    @staticmethod
    def of(data: Data) -> Stroke:
        x = data.prob.inputs.x
        temps = [p.data.temperature for p in data.prepared if p.data.temperature is not None]
        finite = [t[np.isfinite(t)] for t in temps]
        mean_t = float(np.mean(np.concatenate(finite))) if any(f.size for f in finite) else np.nan
        return Stroke(
            float(np.min(x)),
            float(np.max(x)),
            float(np.max(np.abs(data.prob.inputs.v))) or 1.0,
            float(min(p.data.t[0] for p in data.prepared)),
            mean_t,
        )

    @property
    def knots(self) -> FloatArray:
        return np.linspace(self.lo_m, self.hi_m, N_KNOTS)


def _quantity(kind: str, value: float, u: Units) -> str:
    """A position, distance or area of a feature's words in the reader's units."""
    ln, ll = u.length_per_m, u.length_label
    if kind == "at":
        digits = 2 if u.imperial else 0
        shown = round(ln * value, digits) + 0.0  # no "-0 mm" for a knot a hair below zero
        return f"{shown:+.{digits}f} {ll}"
    if kind == "area":
        return f"{ln**2 * value:.3g} {ll}²"
    return f"{ln * value:.3g} {ll}"


def _mm(x: float) -> str:
    """A knot in a feature's key (keys stay SI: they name the feature, not a reading)."""
    return f"{round(1e3 * x) + 0:+d}"


def _band(x: FloatArray, lo: float, hi: float, edge: float) -> FloatArray:
    """A smooth 1 over [lo, hi] (an infinite end: no edge there), 0 elsewhere."""
    up = 1.0 if not np.isfinite(lo) else 0.5 * (1.0 + np.tanh((x - lo) / edge))
    down = 1.0 if not np.isfinite(hi) else 0.5 * (1.0 - np.tanh((x - hi) / edge))
    return np.asarray(up * down * np.ones_like(x), dtype=float)


def play(x: FloatArray, half_width: float, starts: Sequence[int]) -> FloatArray:
    """The play (backlash) operator, segment by segment: the output stands still until
    the input has moved `half_width` away from it, then follows at that distance. Each
    segment starts centred on its first sample."""
    out = np.empty_like(x)
    for lo, hi in segment_bounds(np.asarray(starts, dtype=np.intp), x.size):
        y = float(x[lo]) if hi > lo else 0.0
        for i in range(lo, hi):
            xi = float(x[i])
            if xi - y > half_width:
                y = xi - half_width
            elif y - xi > half_width:
                y = xi + half_width
            out[i] = y
    return out


def travel_since_reversal(x: FloatArray, v: FloatArray, starts: Sequence[int]) -> FloatArray:
    """|x − x at the last change of sign of ẋ|, segment by segment (from the segment's
    start before its first reversal)."""
    out = np.empty_like(x)
    for lo, hi in segment_bounds(np.asarray(starts, dtype=np.intp), x.size):
        if hi <= lo:
            continue
        s = np.sign(v[lo:hi])
        turn = np.flatnonzero(np.diff(s) != 0) + 1
        idx = np.zeros(hi - lo, dtype=np.intp)
        idx[turn] = turn
        idx = np.maximum.accumulate(idx)
        seg = x[lo:hi]
        out[lo:hi] = np.abs(seg - seg[idx])
    return out


def _warmed_with_time(t: FloatArray, temp: FloatArray | None) -> bool:
    """Whether the temperature channel followed the elapsed time over the recording (it
    moved by WARMED_K at least, correlated with t by WARMED_CORRELATION): then a drift over
    the session and the oil's heat cannot be told apart (a heat term's misfit followed the
    session as closely as a load cell's drift would)."""
    if temp is None:
        return False
    ok = np.isfinite(temp)
    if np.count_nonzero(ok) < 3 or float(np.ptp(temp[ok])) < WARMED_K:
        return False
    if float(np.std(t[ok])) == 0.0:
        return False
    return abs(float(np.corrcoef(t[ok], temp[ok])[0, 1])) >= WARMED_CORRELATION


def _force_play(force: FloatArray, share: float, starts: Sequence[int]) -> FloatArray:
    """P[F] − F, P the play operator of half-width `share` of each test's peak |F|."""
    out = np.empty_like(force)
    for lo, hi in segment_bounds(np.asarray(starts, dtype=np.intp), force.size):
        seg = force[lo:hi]
        width = share * float(np.max(np.abs(seg))) if hi > lo else 0.0
        out[lo:hi] = play(seg, width, [0]) - seg if width > 0 else 0.0
    return out


def _damping_full(
    data: Data, fitted: Fitted, extra_area_m2: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """The model's damping force F_d at every sample of the full-rate inputs (with
    `extra_area_m2` more bleed each way), and the same at the objective samples."""
    prob = data.prob
    bc, bt = fitted.area_vectors(data)
    full = prob.full_inputs
    g = prob.full_group
    ev = fitted.model.evaluate(full, bc[g] + extra_area_m2, bt[g] + extra_area_m2)
    damping = ev.force - sum((ev.components[k] for k in NOT_MODEL), np.zeros(full.size))
    return damping, damping[prob.obj_in_full]


def _shifted(values: FloatArray, data: Data, shift_s: float) -> FloatArray:
    """A full-rate signal `shift_s` later (earlier for a negative shift), segment by
    segment, held at a segment's ends; at the objective samples."""
    full = data.prob.full_inputs
    out = np.empty_like(values)
    for k, (lo, hi) in enumerate(segment_bounds(full.starts, full.size)):
        t = np.arange(hi - lo) * float(full.dt_s[k])
        out[lo:hi] = np.interp(t + shift_s, t, values[lo:hi])
    return np.asarray(out[data.prob.obj_in_full])


def _travelled(values: FloatArray, data: Data, shift_m: float) -> FloatArray:
    """A full-rate signal where the motion will have travelled `shift_m` further (earlier
    for a negative shift), segment by segment, held at a segment's ends; at the objective
    samples. The travel is the path length ∫|ẋ| dt, so a shift is a distance, not a time:
    the same at every frequency."""
    full = data.prob.full_inputs
    out = np.empty_like(values)
    for k, (lo, hi) in enumerate(segment_bounds(full.starts, full.size)):
        path = np.concatenate([[0.0], np.cumsum(np.abs(full.v[lo : hi - 1]))]) * float(full.dt_s[k])
        out[lo:hi] = np.interp(path + shift_m, path, values[lo:hi])
    return np.asarray(out[data.prob.obj_in_full])


Columns = list[tuple[Feature, FloatArray]]  # features with their values, in the table's order


def feature_table(data: Data, fitted: Fitted, stroke: Stroke) -> FeatureTable:
    """Every feature on `data`'s objective samples, with `fitted`'s model (its areas for
    these tests' clicks) and the whole recording's `stroke`."""
    inputs = data.prob.inputs
    x, v = inputs.x, inputs.v
    starts = [int(s) for s in inputs.starts]
    t = np.concatenate([p.data.t[p.obj] for p in data.prepared]) - stroke.origin_s
    sign = np.tanh(v / (SIGN_SPEED_SHARE * stroke.peak_speed_m_s))
    damping_full, damping = _damping_full(data, fitted)
    opened = {a: _damping_full(data, fitted, a)[1] - damping for a in EXTRA_AREAS_M2}
    feats = [
        *_time_features(t, inputs.temperature_c),
        *_temperature_features(inputs.temperature_c, stroke, damping),
        *_motion_features(x, v, inputs.a, sign, damping, opened),
        *_band_features(x, sign, damping, opened, stroke),
        *_hinge_features(x, sign, stroke),
        *_hysteresis_features(x, v, sign, damping, starts),
        *_shift_features(damping_full, damping, data),
    ]
    values = np.column_stack([np.asarray(c, dtype=float) for _, c in feats])
    return FeatureTable(tuple(f for f, _ in feats), values)


def _time_features(t: FloatArray, temp: FloatArray | None) -> Columns:
    """A zero drift, or the damper changing over the session; heat's when the
    temperature channel rose or fell with the session (no telling them apart then)."""
    heat = like("temperature") if _warmed_with_time(t, temp) else ()
    feats: Columns = [(Feature("t", "the elapsed time", "t", "s", "time", heat), t)]
    for tau in DRIFT_TAUS_S:
        feats.append(
            (
                Feature(
                    f"drift_{tau:.0f}s",
                    f"the elapsed time, settling over {tau / 60:.0f} min",
                    f"(1 − e^(−t/{tau / 60:.0f} min))",
                    "1",
                    "time",
                    heat,
                ),
                1.0 - np.exp(-t / tau),
            )
        )
    return feats


def _temperature_features(temp: FloatArray | None, stroke: Stroke, damping: FloatArray) -> Columns:
    """The thermal term's: none unless the channel moved about the recording's mean."""
    if temp is None or not np.isfinite(stroke.temperature_c) or not np.any(np.isfinite(temp)):
        return []
    dt_c = np.where(np.isfinite(temp), temp - stroke.temperature_c, 0.0)
    if float(np.std(dt_c)) <= 0.05:
        return []
    return [
        (Feature("T", "the temperature", "(T − T̄)", "K", "temperature", like("temperature")), dt_c),
        (
            Feature(
                "T*F_d",
                "the damping force as the temperature changes",
                "(T − T̄)·F_d",
                "N·K",
                "temperature",
                like("temperature"),
            ),
            dt_c * damping,
        ),
    ]


def _motion_features(
    x: FloatArray,
    v: FloatArray,
    a: FloatArray,
    sign: FloatArray,
    damping: FloatArray,
    opened: dict[float, FloatArray],
) -> Columns:
    """The library's and the calibrations' own forms; a bleed opened over the whole
    stroke is the areas' (or heat's)."""
    feats: Columns = [
        (Feature("x", "the displacement", "x", "m", "motion", like("displacement")), x),
        (Feature("v", "the velocity", "ẋ", "m/s", "motion", (*like("velocity"), "bleed_land")), v),
        (
            Feature("v|v|", "the velocity squared", "|ẋ|ẋ", "m²/s²", "motion", ("bleed areas",)),
            v * np.abs(v),
        ),
        (
            Feature("sgn_v", "the direction of motion", "sgn ẋ", "1", "motion", like("direction")),
            sign,
        ),
        (Feature("a", "the acceleration", "ẍ", "m/s²", "motion", like("acceleration")), a),
        (
            Feature("F_d", "the damping force", "F_d", "N", "motion", ("bleed areas", "valves")),
            damping,
        ),
    ]
    for area, change in opened.items():
        feats.append(
            (
                Feature(
                    f"A+{1e6 * area:g}mm2",
                    "{0} more bleed over the whole stroke",
                    "ΔF_d(A + {0})",
                    "N",
                    "motion",
                    ("bleed areas", *like("temperature")),
                    (("area", area),),
                ),
                change,
            )
        )
    return feats


def _band_features(
    x: FloatArray,
    sign: FloatArray,
    damping: FloatArray,
    opened: dict[float, FloatArray],
    stroke: Stroke,
) -> Columns:
    """The damping force, each bleed opened and the direction of motion, each over a band
    of the stroke between two knots (every band but the whole stroke)."""
    knots = stroke.knots
    edge = EDGE_SHARE * (stroke.hi_m - stroke.lo_m)
    feats: Columns = []
    for i in range(N_KNOTS - 1):
        for j in range(i + 1, N_KNOTS):
            if i == 0 and j == N_KNOTS - 1:
                continue  # the whole stroke: no position in it
            lo = knots[i] if i > 0 else -np.inf
            hi = knots[j] if j < N_KNOTS - 1 else np.inf
            w = _band(x, lo, hi, edge)
            where, sym, at = _where(lo, hi)
            feats.append(
                (Feature(f"band{i}{j}*F_d", f"the damping force {where}", f"{sym}·F_d", "N",
                         "position × damping", (), at, "F_d"),
                 w * damping)
            )  # fmt: skip
            for area, change in opened.items():
                more = len(at)  # the area's place among the quantities
                feats.append(
                    (
                        Feature(
                            f"band{i}{j}*A+{1e6 * area:g}mm2",
                            f"{{{more}}} more bleed {where}",
                            f"{sym}·ΔF_d(A + {{{more}}})",
                            "N",
                            "position × bleed",
                            (),
                            (*at, ("area", area)),
                            f"A+{1e6 * area:g}mm2",
                        ),
                        w * change,
                    )
                )
            feats.append(
                (Feature(f"band{i}{j}*sgn_v", f"the direction of motion {where}", f"{sym}·sgn ẋ",
                         "1", "position × friction", (), at, "sgn_v"),
                 w * sign)
            )  # fmt: skip
    return feats


def _hinge_features(x: FloatArray, sign: FloatArray, stroke: Stroke) -> Columns:
    """Hinges at each inner knot: friction and a force of position growing below or
    above it."""
    feats: Columns = []
    for k in stroke.knots[1:-1]:
        below, above = np.maximum(k - x, 0.0), np.maximum(x - k, 0.0)
        at = (("at", float(k)),)
        for side, col, sym in (("below", below, "({0} − x)₊"), ("above", above, "(x − {0})₊")):
            feats.append(
                (
                    Feature(
                        f"{side}{_mm(k)}*sgn_v",
                        f"the direction of motion, growing {side} x = {{0}}",
                        f"{sym}·sgn ẋ",
                        "m",
                        "position × friction",
                        (),
                        at,
                        "sgn_v",
                    ),
                    col * sign,
                )
            )
            feats.append(
                (
                    Feature(
                        f"{side}{_mm(k)}",
                        f"the displacement {side} x = {{0}}",
                        sym,
                        "m",
                        "position",
                        like("position"),
                        at,
                    ),
                    col,
                )
            )
    return feats


def _hysteresis_features(
    x: FloatArray, v: FloatArray, sign: FloatArray, damping: FloatArray, starts: list[int]
) -> Columns:
    """Hysteresis of x (a seal's presliding turn), and of the damping force: a play of a
    share of each test's peak."""
    feats: Columns = []
    for b in PLAY_HALF_WIDTHS_M:
        feats.append(
            (
                Feature(
                    f"play{1e3 * b:g}mm",
                    "x through a play of ±{0}",
                    "(x − P_b[x])/b, b = {0}",
                    "1",
                    "hysteresis",
                    (*like("presliding"), "seal_turn"),
                    (("len", b),),
                ),
                (x - play(x, b, starts)) / b,
            )
        )
    travel = travel_since_reversal(x, v, starts)
    for lam in TURN_TRAVELS_M:
        feats.append(
            (
                Feature(
                    f"turn{1e3 * lam:g}mm",
                    "the direction of motion, fading over {0} after a reversal",
                    "sgn ẋ·e^(−s/{0})",
                    "1",
                    "hysteresis",
                    (*like("presliding"), "seal_turn"),
                    (("len", lam),),
                ),
                sign * np.exp(-travel / lam),
            )
        )
    for share in FORCE_PLAY_SHARES:
        feats.append(
            (
                Feature(
                    f"Fplay{100 * share:g}%",
                    f"the damping force through a play of ±{100 * share:g} % of its peak",
                    f"(P_{100 * share:g}%[F_d] − F_d)",
                    "N",
                    "force hysteresis",
                ),
                _force_play(damping, share, starts),
            )
        )
    return feats


def _shift_features(damping_full: FloatArray, damping: FloatArray, data: Data) -> Columns:
    """The damping force shifted in travel and in time."""
    feats: Columns = []
    # λ of travel later (the measured motion trails the rod's by a play: its position
    # channel's linkage) or earlier (a play the rod takes up)
    for lam in TRAVEL_SHIFTS_M:
        lead = lam > 0
        label = (
            "the damping force {0} of travel later (the force leads the measured motion)"
            if lead
            else "the damping force {0} of travel earlier"
        )
        feats.append(
            (
                Feature(
                    f"F_d{1e3 * lam:+g}mm",
                    label,
                    "[F_d(s + {0}) − F_d]" if lead else "[F_d(s − {0}) − F_d]",
                    "N",
                    "force in travel",
                    () if lead else (*like("presliding"), "seal_turn"),
                    (("len", abs(lam)),),
                ),
                _travelled(damping_full, data, lam) - damping,
            )
        )
    # in time: a lead no library physics has, a lag two terms model
    for tau in SHIFTS_S:
        lead = tau > 0
        label = (
            f"the damping force {1e3 * tau:g} ms later (the force leads the motion)"
            if lead
            else f"the damping force {-1e3 * tau:g} ms earlier (the force lags the motion)"
        )
        feats.append(
            (
                Feature(
                    f"F_d{1e3 * tau:+g}ms",
                    label,
                    f"[F_d(t{1e3 * tau:+g} ms) − F_d]",
                    "N",
                    "force in time",
                    () if lead else like("lag"),
                ),
                _shifted(damping_full, data, tau) - damping,
            )
        )
    return feats


def _where(lo: float, hi: float) -> tuple[str, str, tuple[tuple[str, float], ...]]:
    """A band's words, its symbol and the positions they name ({0}, {1})."""
    if not np.isfinite(lo):
        return "below x = {0}", "w[…, {0}](x)", (("at", hi),)
    if not np.isfinite(hi):
        return "above x = {0}", "w[{0}, …](x)", (("at", lo),)
    return "between x = {0} and {1}", "w[{0}, {1}](x)", (("at", lo), ("at", hi))
