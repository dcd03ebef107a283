"""Does a named term take the structure where its own physics acts?

A term's force has a place: a bump stop acts past its onset, a sensor's lag where the
force changes fast, friction at reversal. Refitted beside the model, a term that is the
physics left out takes most of the structure there: as first candidates on the held-out
and reference plants' effects, a channel lag, a bump stop, air and vapour took 92-100 %
of the structure where their own force acts; heat and seal friction on the reference
plant, whose forms are furthest from the library's, 62 % and 61 %. A term that is the
wrong physics can still lower the squared error a little, as a lever for the areas and
globals refitted beside it, or by matching one part of a shape it does not have: it then
leaves most of the structure where it acts, or adds structure where there was none.

Seen on the held-out plant's effects that no term has (benchmarks/unnamed, its runs in
benchmarks/results):
- play in the LVDT's linkage: the measured motion stands still for a moment after each
  reversal. A sensor lag took it as 2.2 ms of delay and 3.4 ms of LVDT lag (p = 0.001),
  acting on both sides of every reversal: it took 22 % of the structure where its force
  acts, added structure before each reversal where there was none, and removed 14 % held
  out (median fold; the 0.5 Hz fold worse with it). It was claimed;
- friction between a valve's shims (its lift opens and closes late): a contact term took
  it as a bump stop and a top-out of 11 N from ±19 mm (p = 0.001), with 18 % of the
  structure where its force acts and the mid-stroke rebound structure untouched, 20 %
  held out. It was claimed.

`in_place_share`: of the structure (Σ phase mean² less its noise variance) in the bins
where the term's own force (candidates.own_force) reaches ACTS_SHARE of its largest
phase mean, the share its refit removes. 0 where those bins hold no structure: the
term's gain then comes from elsewhere.

Heat has no place in the cycle (`Term.place` "session"). Within one test its own force is
the damper's force scaled by the oil's viscosity at that moment: a shape the valves and
areas refitted beside it can take as well, spread over every bin where the damper pushes,
so those bins hold all the structure of the valves' misfit too, which heat cannot take.
What only heat explains is how that scale moves from test to test as the oil warms:
`session_share`, of the structure along its own force test by test (each test's residual
projected on the term's force there, less the projection's noise), the share its refit
removes. Heat fitted to structure that does not follow the warm-up takes little of it
(0.02-0.05 beside LVDT play on the held-out plant), as a lag or a stop fitted to
another shape takes little of its place in the cycle.

A term of the cycle whose own force acts in most of its cells (`acts_share` at least
Settings.placeless_share) has no place apart from the valves': a seal's viscous drag acts
wherever the ram moves, a moving mass wherever it accelerates, and those cells hold the
valves' and areas' misfit too, which it cannot take. On the held-out plant's seal friction
(round 2, after the seal's turn and Coulomb level were calibrated:
an 83 N·s/m drag and a 56 N breakaway against the plant's 106 and 75) the friction acted in
95 % of the cells and took 42-45 % of the structure there, held out 0.55-0.60. Such a
term is judged held out as well (claims.why_not): it is claimable at the held-out gain a
discovered term is claimed at (Settings.unnamed_min_gain), a name needing no less evidence
than a form; a fixture mass fitted to a bypass groove (71 % of the cells, 20 % there)
removed 14 % held out and stays refused.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.cycles import BinnedTest

FloatArray = NDArray[np.float64]

# A bin is where a term acts when its own force there reaches this share of its largest
# phase mean (the held-out gain's ACTS_SHARE, per bin here).
ACTS_SHARE = 0.1


def _where_acts(own: FloatArray) -> NDArray[np.bool_] | None:
    """The cells where `own` reaches ACTS_SHARE of its largest (None: it has no force)."""
    peak = float(np.max(np.abs(own), initial=0.0))
    return None if peak <= 0 else np.abs(own) >= ACTS_SHARE * peak


def _acting(
    own: FloatArray, before: Sequence[BinnedTest], after: FloatArray
) -> tuple[NDArray[np.bool_], FloatArray, FloatArray, FloatArray] | None:
    """Where `own` acts, and there the phase means before and after the refit and the
    noise variance of a mean before it (None: the term has no force of its own)."""
    acts = _where_acts(own)
    if acts is None:
        return None
    r0 = np.concatenate([b.mean for b in before])[acts]
    var = np.concatenate([b.mean_var for b in before])[acts]
    return acts, r0, var, after[acts]


def in_place_share(own: FloatArray, before: Sequence[BinnedTest], after: FloatArray) -> float:
    """The share of the structure where `own` (the term's own force per phase bin) acts
    that the refit removes: `before` the phase means (and their noise variance) without
    the term, `after` the phase means with it (the same bins)."""
    got = _acting(own, before, after)
    if got is None:
        return 1.0  # a term with no force of its own is judged by the own-force rule
    _, r0, var, r1 = got
    there = float(np.sum(r0 * r0 - var))
    if there <= 0:
        return 0.0
    return 1.0 - float(np.sum(r1 * r1 - var)) / there


def share_noise_sd(
    own: FloatArray, before: Sequence[BinnedTest], after: FloatArray, draws: FloatArray
) -> float:
    """How far the recording's noise moves `in_place_share`: its standard deviation with
    each noise draw (`stats.noise_draws`: tests·bins × n, resampled whole cycles of the
    scatter) added to the phase means before and after the refit alike, as noise in the
    data is in both. Where the term acts in a few bins that hold little structure, noise
    alone moves the share by tens of per cent, and the claim's half is then no verdict the
    recording gives."""
    got = _acting(own, before, after)
    if got is None or draws.size == 0:
        return 0.0
    acts, r0, var, r1 = got
    e = draws[acts]
    r0, var, r1 = r0[:, None] + e, var[:, None], r1[:, None] + e
    there = np.sum(r0 * r0 - var, axis=0)
    ok = there > 0
    if np.count_nonzero(ok) < 2:
        return 0.0
    shares = 1.0 - np.sum(r1 * r1 - var, axis=0)[ok] / there[ok]
    return float(np.std(shares))


def acts_share(own: FloatArray) -> float:
    """The share of the (test, phase bin) cells where `own` (the term's own force per
    cell) reaches ACTS_SHARE of its largest: where its force acts."""
    acts = _where_acts(own)
    return 0.0 if acts is None else float(np.mean(acts))


def session_share(own: FloatArray, before: Sequence[BinnedTest], after: FloatArray) -> float:
    """The share of the structure along `own` test by test that the refit removes (a
    term whose place is the session: heat); arguments as `in_place_share`."""
    r0_all = np.concatenate([b.mean for b in before])
    var_all = np.concatenate([b.mean_var for b in before])
    there = left = 0.0
    start = 0
    for b in before:
        sl = slice(start, start + b.mean.size)
        start = sl.stop
        g = own[sl]
        norm2 = float(g @ g)
        if norm2 <= 0:
            continue
        noise = float(var_all[sl] @ (g * g)) / norm2
        there += float(r0_all[sl] @ g) ** 2 / norm2 - noise
        left += float(after[sl] @ g) ** 2 / norm2 - noise
    if there <= 0:
        return 0.0 if np.any(own) else 1.0
    return 1.0 - left / there


def share_where_it_acts(
    place: str, own: FloatArray, before: Sequence[BinnedTest], after: FloatArray
) -> float:
    """Rule 8's share for a term whose `place` (`Term.place`) is "cycle" or "session"."""
    if place == "session":
        return session_share(own, before, after)
    return in_place_share(own, before, after)
