"""Physics outside the library: what the search left, described, and a form found for it.

When the residual of the final model is still significant, the diagnosis says where it
lies (the regions and axes of locate.py, and the part of the cycle), which recorded
signals it follows (diagnose/features.py: each feature's share of the structure alone),
and tries a discovered term F ≈ Σ c_k φ_k over the features that no library term is
(`Feature.unnamed`), held out like every named term.

Everything here works in the diagnosis's binned space (one phase mean per test and
phase bin; cycles.py) and refits the model jointly with the term, linearised at the
final fit: the residual r, the model's Jacobian J (globals, free term parameters, every
click's areas; candidates.binned_jacobian) and the features Φ, all phase means. A
form's coefficients are the least squares of r on [J, Φ_S], so a feature the model's
own parameters can take (a constant force is the gas charge's; x the gas spring's)
explains nothing new. The LR bootstrap of the candidates linearises the same way.

Selection: greedy forward selection (orthogonal matching pursuit on what J cannot
take), at most `unnamed_max_features` features. Chosen over a sequentially thresholded
least squares (STLSQ, as PySINDy): the features are strongly correlated (the elapsed
time and the temperature, a band of the stroke and its neighbours, leads of 2 and 4 ms),
and a threshold spreads a coefficient over correlated columns where a greedy pick names
the one signal that explains most, which is what the verdict must say. The number of
features is chosen held out: the smallest whose held-out gain is within
`unnamed_size_tolerance` of the best.

Held out: the diagnosis's folds (leave one frequency out, one click out, or one half
of a single setting predicted from the other; candidates.folds). In each fold the
features are selected and the coefficients fitted on the training tests alone, with J's
columns (the model refitted), and the left-out tests predicted; a column that only the
left-out tests see (a left-out click's areas) is fitted on them, as a left-out click's
areas are for a named term. The gain is the share of the left-out structure (Σ phase
mean² less their noise variance) removed, in the median fold.

Claimed ("unnamed: F ≈ ...") only when (a) it removes at least `unnamed_min_gain` of the
held-out structure, (b) its own largest phase mean matters (the effect limit of a named
term), and (c) a form of the same size made of features that ARE library physics does
not explain as much in-sample: a residual that follows sgn ẋ as well as any unnamed
form is friction's (the claimed friction's misfit, or friction the search did not
claim), not a new physics.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.candidates import Fold, binned_jacobian, folds
from shockdyno.diagnose.cycles import N_BINS, BinnedTest
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.features import Feature, FeatureTable, Stroke, feature_table
from shockdyno.diagnose.fitting import Fitted, predict
from shockdyno.diagnose.locate import Location, Region
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.stats import basis

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class Rows:
    """One set of tests in the binned space: per (test, phase bin) the residual's phase
    mean, its noise variance, the model's Jacobian and the features."""

    r: FloatArray
    var: FloatArray
    jac: FloatArray
    phi: FloatArray
    test: IntArray  # the row's test, by index in its Data

    def take(self, tests: Sequence[int]) -> Rows:
        keep = np.isin(self.test, np.asarray(tests, dtype=np.intp))
        return Rows(self.r[keep], self.var[keep], self.jac[keep], self.phi[keep], self.test[keep])

    def structure(self, e: FloatArray) -> float:
        """Σ over the rows of the phase mean² less its noise variance (the structure a
        named term's held-out gain counts), for the residual `e` on these rows."""
        return float(np.sum(e * e - self.var))


def build_rows(data: Data, fitted: Fitted, stroke: Stroke) -> tuple[Rows, FeatureTable]:
    """`data` in the binned space at `fitted` (its areas for every click of `data`)."""
    on = fitted if fitted.residual.size == data.prob.size else predict(data, fitted)
    binned = data.binned(on.residual)
    jac, _ = binned_jacobian(data, on)
    table = feature_table(data, on, stroke)
    # a signal a model cannot give everywhere (a held chamber's NaN) explains nothing there
    phi = np.nan_to_num(data.bin_matrix(table.values), nan=0.0, posinf=0.0, neginf=0.0)
    jac = np.nan_to_num(jac, nan=0.0, posinf=0.0, neginf=0.0)
    rows = Rows(
        # measured − model (a Fitted's residual is model − measured): the force left out
        -np.concatenate([b.mean for b in binned]),
        np.concatenate([b.mean_var for b in binned]),
        jac,
        phi,
        np.repeat(np.arange(data.n_tests, dtype=np.intp), N_BINS),
    )
    return rows, table


def _unit_columns(a: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Columns scaled to unit norm (a zero column stays zero), and the norms."""
    norm = np.linalg.norm(a, axis=0)
    safe = np.where(norm > 0, norm, 1.0)
    return a / safe, norm


def _off_model(rows: Rows) -> tuple[FloatArray, FloatArray]:
    """The residual and the features less what the model's parameters can take (the
    joint refit, linearised)."""
    q = basis(rows.jac, 1e-8)
    r = rows.r - q @ (q.T @ rows.r)
    phi = rows.phi - q @ (q.T @ rows.phi)
    return r, phi


def greedy(r: FloatArray, phi: FloatArray, allowed: Sequence[int], size: int) -> list[int]:
    """Forward selection: the `size` columns of `phi` (of `allowed`) that, one by one,
    remove most of r's squared sum (orthogonal matching pursuit)."""
    chosen: list[int] = []
    e = r.copy()
    basis = np.zeros((r.size, 0))
    for _ in range(size):
        best, best_gain, best_u = -1, 0.0, None
        for k in allowed:
            if k in chosen:
                continue
            u = phi[:, k] - basis @ (basis.T @ phi[:, k])
            nu = float(np.linalg.norm(u))
            if nu <= 1e-9 * max(float(np.linalg.norm(phi[:, k])), 1e-300):
                continue
            g = float(u @ e) ** 2 / nu**2
            if g > best_gain:
                best, best_gain, best_u = k, g, u / nu
        if best < 0 or best_u is None:
            break
        chosen.append(best)
        e = e - best_u * float(best_u @ e)
        basis = np.column_stack([basis, best_u])
    return chosen


def _lstsq(a: FloatArray, y: FloatArray) -> FloatArray:
    scaled, norm = _unit_columns(a)
    coef = np.linalg.lstsq(scaled, y, rcond=1e-10)[0]
    return np.asarray(np.where(norm > 0, coef / np.where(norm > 0, norm, 1.0), 0.0))


def predicted_structure(train: Rows, test: Rows, chosen: Sequence[int]) -> tuple[float, FloatArray]:
    """The left-out tests' structure after the model and the features `chosen` are
    refitted on the training rows and `test` predicted; and the residual. Columns of the
    model that only the left-out rows see (a left-out click's areas) are fitted on them."""
    a_train = np.column_stack([train.jac, train.phi[:, list(chosen)]])
    a_test = np.column_stack([test.jac, test.phi[:, list(chosen)]])
    placed = np.linalg.norm(a_train, axis=0) > 0
    coef = _lstsq(a_train[:, placed], train.r)
    e = test.r - a_test[:, placed] @ coef
    njac = train.jac.shape[1]
    unplaced = ~placed[:njac] & (np.linalg.norm(test.jac, axis=0) > 0)
    if np.any(unplaced):
        cols = test.jac[:, unplaced]
        e = e - cols @ _lstsq(cols, e)
    return test.structure(e), e


@dataclass(frozen=True)
class FoldRows:
    label: str
    train: Rows
    test: Rows


def fold_rows(
    data: Data, rows: Rows, fitted: Fitted, stroke: Stroke, keys: Sequence[str]
) -> list[FoldRows]:
    """The diagnosis's folds in the binned space: a fold that leaves tests out takes their
    rows; one that splits tests in time (a single setting) bins its halves anew, their
    features in the columns of the whole recording's (`keys`)."""
    out = []
    index = {id(p): i for i, p in enumerate(data.prepared)}
    for fold in folds(data):
        ids = [index.get(id(p)) for p in (*fold.train.prepared, *fold.test.prepared)]
        if all(i is not None for i in ids):
            test = [index[id(p)] for p in fold.test.prepared]
            train = [index[id(p)] for p in fold.train.prepared]
            out.append(FoldRows(fold.label, rows.take(train), rows.take(test)))
        else:
            out.append(_halves(fold, fitted, stroke, keys))
    return out


def _halves(fold: Fold, fitted: Fitted, stroke: Stroke, keys: Sequence[str]) -> FoldRows:
    train = _in_columns(*build_rows(fold.train, fitted, stroke), keys)
    test = _in_columns(*build_rows(fold.test, fitted, stroke), keys)
    return FoldRows(fold.label, train, test)


def _in_columns(rows: Rows, table: FeatureTable, keys: Sequence[str]) -> Rows:
    """`rows` with their features in the columns `keys` name (zero where these tests have
    no such feature). A half's table can differ from the whole recording's (the
    temperature's features, where the oil warmed in one half only), and the columns
    chosen on the whole were then read off the wrong features, or past the last."""
    at = {f.key: i for i, f in enumerate(table.features)}
    phi = np.zeros((rows.phi.shape[0], len(keys)))
    for j, k in enumerate(keys):
        if k in at:
            phi[:, j] = rows.phi[:, at[k]]
    return replace(rows, phi=phi)


def nested_gain(
    folds_: Sequence[FoldRows], allowed: Sequence[int], size: int
) -> tuple[float, str, list[float]]:
    """Median over the folds of the share of the left-out structure a form of `size`
    features removes, its features chosen and fitted on each fold's training rows."""
    gains, parts = [], []
    for f in folds_:
        base, _ = predicted_structure(f.train, f.test, [])
        r, phi = _off_model(f.train)
        chosen = greedy(r, phi, allowed, size)
        after, _ = predicted_structure(f.train, f.test, chosen)
        n = max(int(f.test.r.size), 1)
        shown = f"{math.sqrt(max(base, 0.0) / n):.3g} → {math.sqrt(max(after, 0.0) / n):.3g} N"
        parts.append(f"{f.label}: {shown}")
        if base > 0:
            gains.append(1.0 - after / base)
    return (float(np.median(gains)) if gains else 0.0), "; ".join(parts), gains


@dataclass(frozen=True)
class Follows:
    """A signal the structure follows: its share of the structure explained alone."""

    feature: Feature
    share: float
    sign: int  # +1: the residual rises with it


@dataclass(frozen=True)
class Coefficient:
    feature: Feature
    value: float
    sd: float


@dataclass(frozen=True)
class Discovered:
    """A form for what is left, F ≈ Σ c_k φ_k, and how it did held out."""

    coefficients: tuple[Coefficient, ...]
    heldout_gain: float
    heldout_detail: str
    in_sample_share: float  # of the structure left, removed in-sample
    effect_peak_n: float  # its largest phase mean
    claimed: bool
    why_not: str
    binned: FloatArray  # its force per (test, bin) of the whole data

    @property
    def features(self) -> tuple[Feature, ...]:
        return tuple(c.feature for c in self.coefficients)


@dataclass(frozen=True)
class Described:
    """What the search left: where, what it follows, and the form tried for it."""

    regions: tuple[Region, ...]
    axes: dict[str, dict[str, float]]
    rms_n: float
    phase_deg: tuple[float, float]  # the shortest part of the cycle holding half of it
    follows: tuple[Follows, ...]
    term: Discovered | None
    plot_feature: Feature | None = None
    plot: dict[str, list[float]] = field(default_factory=dict)


def _phase_window(energy: FloatArray, share: float = 0.5) -> tuple[float, float]:
    """The shortest circular run of phase bins holding `share` of the energy (degrees
    from the upward mid-stroke crossing: 90 at full compression, 270 at full extension)."""
    total = float(np.sum(energy))
    if total <= 0:
        return (0.0, 360.0)
    best = (N_BINS, 0)
    for width in range(1, N_BINS + 1):
        for start in range(N_BINS):
            idx = [(start + k) % N_BINS for k in range(width)]
            if float(np.sum(energy[idx])) >= share * total:
                best = (width, start)
                break
        else:
            continue
        break
    width, start = best
    lo = 360.0 * start / N_BINS
    return (lo, lo + 360.0 * width / N_BINS)


def phase_words(window: tuple[float, float]) -> str:
    """Where in the cycle a phase window lies, in a dyno engineer's words."""
    lo, hi = window
    if hi - lo >= 300:
        return "all round the cycle"
    mid = (0.5 * (lo + hi)) % 360
    marks = [
        (0.0, "mid-stroke in compression"),
        (45.0, "in compression, slowing toward full compression"),
        (90.0, "around full compression (the top reversal)"),
        (135.0, "in rebound, speeding up after full compression"),
        (180.0, "mid-stroke in rebound"),
        (225.0, "in rebound, slowing toward full extension"),
        (270.0, "around full extension (the bottom reversal)"),
        (315.0, "in compression, speeding up after full extension"),
    ]
    near = min(marks, key=lambda m: min(abs(mid - m[0]), 360 - abs(mid - m[0])))
    return f"{near[1]} ({lo:.0f}–{hi:.0f}° of the cycle)"


def _follows(r: FloatArray, phi: FloatArray, table: FeatureTable, top: int) -> list[Follows]:
    """The features that explain most of `r` alone (distinct labels), largest first."""
    total = float(r @ r)
    if total <= 0:
        return []
    norms = np.linalg.norm(phi, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        dots = phi.T @ r
        share = np.where(norms > 0, dots**2 / np.where(norms > 0, norms, 1.0) ** 2 / total, 0.0)
    out: list[Follows] = []
    for k in np.argsort(-share):
        if len(out) >= top or share[k] < 0.05:
            break
        f = table.features[int(k)]
        if any(o.feature.family == f.family and o.feature.unnamed == f.unnamed for o in out):
            continue  # one per family: the best band, not its neighbours as well
        out.append(Follows(f, float(share[k]), 1 if dots[k] > 0 else -1))
    return out


def _explained_share(r: FloatArray, phi: FloatArray, chosen: Sequence[int]) -> float:
    if not chosen or float(r @ r) <= 0:
        return 0.0
    cols = phi[:, list(chosen)]
    e = r - cols @ _lstsq(cols, r)
    return 1.0 - float(e @ e) / float(r @ r)


def discover(
    data: Data,
    final: Fitted,
    binned: Sequence[BinnedTest],
    left: Location,
    rms_n: float,
    s: Settings,
    effect_limit_n: float,
) -> Described:
    """Describe what the final model leaves (significant: `left` has regions) and try a
    discovered term for it."""
    stroke = Stroke.of(data)
    rows, table = build_rows(data, final, stroke)
    r, phi = _off_model(rows)
    energy = np.maximum(rows.r**2 - rows.var, 0.0).reshape(data.n_tests, N_BINS).sum(axis=0)
    follows = _follows(r, phi, table, s.unnamed_follows)
    unnamed = [i for i, f in enumerate(table.features) if f.unnamed]
    named = [i for i, f in enumerate(table.features) if not f.unnamed]
    term = None
    plot_feature = follows[0].feature if follows else None
    fold_list = fold_rows(data, rows, final, stroke, [f.key for f in table.features])
    if fold_list and unnamed:
        term = _discovered(rows, r, phi, table, fold_list, unnamed, named, s, effect_limit_n)
        if term.coefficients:
            plot_feature = max(
                term.coefficients,
                key=lambda c: float(np.std(c.value * rows.phi[:, table.index(c.feature.key)])),
            ).feature
    plot: dict[str, list[float]] = {}
    if plot_feature is not None:
        plot_feature = plot_signal(plot_feature, table)
        k = table.index(plot_feature.key)
        removed: FloatArray | list[float] = []
        if term is not None and term.coefficients:
            # the force the term removes: it is fitted beside the model's own parameters,
            # which take what they can of it (a constant the gas charge, a step the Coulomb
            # friction), so the figure's red points lie on the residual where it explains it
            q = basis(rows.jac, 1e-8)
            removed = term.binned - q @ (q.T @ term.binned)
        plot = {
            "x": _round(rows.phi[:, k]),
            "residual": _round(rows.r),
            "term": _round(np.asarray(removed)) if len(removed) else [],
        }
    return Described(
        tuple(left.regions),
        dict(left.axes),
        rms_n,
        _phase_window(energy),
        tuple(follows),
        term,
        plot_feature,
        plot,
    )


def plot_signal(feature: Feature, table: FeatureTable) -> Feature:
    """The signal the figure's axis shows for `feature`: a drift's settling 1 − e^(−t/τ)
    runs 0…1 with no unit, so a residual of time is drawn against the elapsed time."""
    if feature.family == "time" and any(f.key == "t" for f in table.features):
        return table.features[table.index("t")]
    return feature


def _round(values: FloatArray) -> list[float]:
    """Four digits, as the figure needs them (a result file holds no NaN: 0 instead)."""
    finite = np.nan_to_num(np.asarray(values, dtype=float), nan=0.0, posinf=0.0, neginf=0.0)
    return [float(f"{v:.4g}") for v in finite]


def _discovered(
    rows: Rows,
    r: FloatArray,
    phi: FloatArray,
    table: FeatureTable,
    fold_list: Sequence[FoldRows],
    unnamed: Sequence[int],
    named: Sequence[int],
    s: Settings,
    effect_limit_n: float,
) -> Discovered:
    scored = []
    for size in range(1, s.unnamed_max_features + 1):
        gain, detail, _ = nested_gain(fold_list, unnamed, size)
        scored.append((size, gain, detail))
    best_gain = max(g for _, g, _ in scored)
    size, gain, detail = next(
        (z, g, d) for z, g, d in scored if g >= best_gain - s.unnamed_size_tolerance
    )
    chosen = greedy(r, phi, unnamed, size)
    a = np.column_stack([rows.jac, rows.phi[:, chosen]])
    scaled, norm = _unit_columns(a)
    keep = norm > 0
    coef_s, *_ = np.linalg.lstsq(scaled[:, keep], rows.r, rcond=1e-10)
    e = rows.r - scaled[:, keep] @ coef_s
    dof = max(rows.r.size - int(np.sum(keep)), 1)
    sigma2 = float(e @ e) / dof
    cov = sigma2 * np.linalg.pinv(scaled[:, keep].T @ scaled[:, keep])
    full = np.zeros(a.shape[1])
    sd_full = np.full(a.shape[1], math.nan)
    full[keep] = coef_s / norm[keep]
    sd_full[keep] = np.sqrt(np.maximum(np.diag(cov), 0.0)) / norm[keep]
    njac = rows.jac.shape[1]
    coefficients = tuple(
        Coefficient(table.features[k], float(full[njac + i]), float(sd_full[njac + i]))
        for i, k in enumerate(chosen)
    )
    own = rows.phi[:, chosen] @ full[njac:]
    peak = float(np.max(np.abs(own))) if own.size else 0.0
    share = _explained_share(r, phi, chosen)
    rival = greedy(r, phi, named, size)
    rival_share = _explained_share(r, phi, rival)
    bases = [table.index(table.features[k].base) if table.features[k].base else k for k in chosen]
    twin_share = _explained_share(r, phi, list(dict.fromkeys(bases)))
    why = ""
    if not chosen:
        why = "no feature explains any of it"
    elif not gain >= s.unnamed_min_gain:
        why = f"held-out gain {gain:.2g} < {s.unnamed_min_gain:g}"
    elif peak < effect_limit_n:
        why = f"its own force peaks at {peak:.2g} N, too small to matter"
    elif bases != chosen and twin_share >= s.unnamed_position_share * share:
        why = (
            f"over the whole stroke the same signals explain {100 * twin_share:.0f} % (the "
            f"bands {100 * share:.0f} %): not a force of part of the stroke, what the areas "
            "or heat would take"
        )
    elif rival and rival_share >= share:
        terms = sorted({t for k in rival for t in table.features[k].resembles})
        why = (
            f"signals of {' or '.join(terms)}'s form explain as much "
            f"({100 * rival_share:.0f} % against {100 * share:.0f} %): "
            "the misfit of a named physics or one the search did not claim, not a new one"
        )
    return Discovered(
        coefficients, gain, detail, share, peak, not why, why, np.asarray(own, dtype=float)
    )


# -- words -----------------------------------------------------------------------------

HINTS = {
    "time": "a load-cell zero drifting, or the damper changing over the session",
    "position × bleed": (
        "a second flow path over part of the stroke: a bypass groove or port, a "
        "position-sensitive valve"
    ),
    "position × damping": (
        "damping that changes over part of the stroke: a bypass groove, a position-sensitive "
        "valve, a scored tube"
    ),
    "position × friction": (
        "friction that changes along the stroke: a side load from a misaligned fixture, a "
        "worn guide"
    ),
    "force hysteresis": (
        "a valve that opens and closes late whatever the speed: friction between the shims"
    ),
    "force in travel": (
        "the force leads the measured motion by a distance: play in the position channel's linkage"
    ),
    "force in time": (
        "the force leads the measured motion: play or a lag in the displacement channel's linkage"
    ),
}


def hint(term: Discovered) -> str:
    families = dict.fromkeys(c.feature.family for c in term.coefficients)
    return "; ".join(HINTS[f] for f in families if f in HINTS)
