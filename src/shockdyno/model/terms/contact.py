"""Contact at the ends of travel: a bump stop and a top-out spring, each with a free onset.

F = F_b·(max(0, x − x_b)/δ)^n_b − F_t·(max(0, x_t − x)/δ)^n_t, δ = 10 mm: the bump stop
(compression side, onset x_b) pushes the rod out, the top-out spring (rebound side,
onset x_t < 0) pulls it in. Each side is stated by its force 10 mm past its onset, which
an engineer reads off a bump-stop curve, rather than by a stiffness whose unit changes
with n. Each side has its own n, from 2 (a progressive elastomer): a solid rubber's first
millimetres are nearly linear, a microcellular bumper densifies and stiffens faster, a
top-out is often a linear coil. Held at 2, a densifying bump rubber was read with an
early onset and a top-out it did not have. n_b is fitted with the stop; where the stroke
reaches too little of the curve to tell it (σ above 0.25), `diagnose` holds it at 2.
n_t is held at 2 unless named; `diagnose` frees it in its final refit, as it frees the
loss's v_h, where the data tell it.

A rubber stop pushes harder going in than coming out. Each side's force is multiplied by
max(0, 1 + η·tanh(v_in/v_h) + α·v_in), v_in the speed into the stop (+ẋ at the bump, −ẋ
at the top-out): η a loss that does not depend on speed past v_h (an elastomer's
hysteresis loop; v_h = 10 mm/s unless named or freed as above), α one proportional to
speed (Hunt and Crossley's viscous stop, F ∝ δⁿ(1 + α δ̇)). Never below 0: coming out
faster than the rubber recovers, it leaves the rod. η = α = 0: an elastic stop.

Beside `position_force`, which bends a smooth curve through the whole stroke, this is a
hinge: nothing before the onset, then a power law. Off: both forces 0 (the onsets then
do nothing, and the data cannot place them: their σ is infinite).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import numpy as np

from shockdyno.model.composite import FORCE, Evaluation, FloatArray, Term, Work
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading

REFERENCE_DEPTH_M = 0.010
# A contact must reach this share of the stroke's half-length past its onset on the data:
# one whose onset lies in the last 10 % acts only in the ±26° of phase about reversal
# (acos 0.9), where a lag, a delay or friction acts too, and is no evidence of contact.
MIN_DEPTH_SHARE = 0.10


class Contact(Term):
    """Bump stop (x > onset, force positive: pushes the rod out) and top-out spring (x < onset,
    force negative: pulls it in), each a power law of the depth past a free onset, with optional
    hysteresis and viscous loss going in."""

    name = "contact"
    stage = FORCE + 4
    summary = "bump stop / top-out spring: force past a free onset, F·(depth/10 mm)^n"
    follows = ("position",)
    separated_by: ClassVar[dict[str, str]] = {
        "position_force": "a slow push through the end of the stroke"
    }
    PARAMS = (
        Param(
            "bump_onset_m",
            "m",
            nominal=0.02,
            lo=0.0,
            hi=0.2,
            scale=0.005,
            off=0.2,
            doc="bump stop starts at x",
        ),
        Param(
            "bump_force_n",
            "N",
            nominal=100.0,
            lo=0.0,
            hi=50000.0,
            scale=100.0,
            off=0.0,
            doc="bump force 10 mm past",
        ),
        Param(
            "topout_onset_m",
            "m",
            nominal=-0.02,
            lo=-0.2,
            hi=0.0,
            scale=0.005,
            off=-0.2,
            doc="top-out starts at x",
        ),
        Param(
            "topout_force_n",
            "N",
            nominal=100.0,
            lo=0.0,
            hi=50000.0,
            scale=100.0,
            off=0.0,
            doc="top-out 10 mm past",
        ),
        Param(
            "exponent",
            "1",
            nominal=2.0,
            lo=1.0,
            hi=4.0,
            scale=0.5,
            off=2.0,
            # A stop met only a few mm deep shows too little of its curve to tell a
            # square from 1.5 or 2.5; one met 6 mm deep or more tells n to hundredths
            # (benchmarks/results/contact-exponent-2026-11-30.txt).
            held_above_sd=0.25,
            doc="bump stop: 1 linear, 2 progressive",
        ),
        Param(
            "topout_exponent",
            "1",
            nominal=2.0,
            lo=1.0,
            hi=4.0,
            scale=0.5,
            off=2.0,
            # Its own: a top-out is often a coil spring (linear) beside a bump rubber that
            # densifies; one n for both read a held-out plant's pair as neither. Held while
            # `diagnose` searches (free, it let a candidate's top-out start at mid-stroke
            # as a linear spring, a position force, and the stop was refused as no
            # estimate), freed by its final refit where the data tell it.
            free=False,
            held_above_sd=0.25,
            doc="top-out: 1 linear, 2 progressive",
        ),
        Param(
            "hysteresis",
            "1",
            nominal=0.0,
            lo=0.0,
            hi=0.9,
            scale=0.05,
            off=0.0,
            doc="loss: loading/unloading force share",
        ),
        Param(
            "hysteresis_velocity_m_s",
            "m/s",
            nominal=0.01,
            lo=0.001,
            hi=1.0,
            scale=0.01,
            off=0.01,
            free=False,
            # A rubber's own (a held-out plant's saturates at 50 mm/s): freed by a
            # diagnosis's final refit where the data tell it, as the top-out's n is.
            held_above_sd=0.01,
            doc="speed the loss saturates at",
        ),
        Param(
            "viscous_s_m",
            "s/m",
            nominal=0.0,
            lo=0.0,
            hi=20.0,
            scale=0.5,
            off=0.0,
            doc="loss per speed into the stop",
        ),
    )

    def describe(self, r: Reading) -> str:
        """Each side the data reached and moved: its onset (x, compression positive) and its
        force 10 mm past it, then any loss going in."""
        (fn, fl), (ln, ll) = r.force, r.length
        sides = []
        for key, what, n in (
            ("bump", "a bump stop", "exponent"),
            ("topout", "a top-out spring", "topout_exponent"),
        ):
            # A side whose onset the stroke never reaches did nothing the data saw.
            if r.moved(f"{key}_force_n") and r.reached(r.v(f"{key}_onset_m")):
                curve = f", as depth^{r.v(n):.2g}{r.sd(n)}" if r.moved(n) else ""
                sides.append(
                    f"{what} from x = {ln * r.v(f'{key}_onset_m'):+.3g}"
                    f"{r.sd(f'{key}_onset_m', ln)} {ll} ({fn * r.v(f'{key}_force_n'):.3g}"
                    f"{r.sd(f'{key}_force_n', fn)} {fl} {ln * 0.01:.2g} {ll} past it{curve})"
                )
        text = "contact: " + (" and ".join(sides) or "at the end of travel")
        losses = []
        if sides and r.moved("hysteresis"):
            loop = (
                f"{100 * r.v('hysteresis'):.2g}{r.sd('hysteresis', 100)} % harder going in "
                "than coming out (the rubber's hysteresis"
            )
            if r.moved("hysteresis_velocity_m_s"):
                sn, sl = r.speed
                vh = "hysteresis_velocity_m_s"
                loop += f", taken up by {sn * r.v(vh):.2g}{r.sd(vh, sn)} {sl} into the stop"
            losses.append(loop + ")")
        if sides and r.moved("viscous_s_m"):
            # As a share per 0.1 m/s into the stop, which reads better than s/m.
            (sn, sl), alpha = r.speed, r.v("viscous_s_m")
            losses.append(
                f"{10 * alpha:.2g}{r.sd('viscous_s_m', 10)} % more per {0.1 * sn:.3g} {sl} "
                "into the stop (a viscous loss)"
            )
        return text + (", " + " and ".join(losses) if losses else "")

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        """Onsets at 50, 70 and 85 % of the stroke the data cover (`seen.x`; ±30 mm without it),
        each side alone and both, at 100 N."""
        # Past the onset the force grows fast, before it there is none: a start whose
        # onset lies beyond the stroke has no gradient. So the onsets start inside the
        # stroke the data cover, one side at a time and both.
        hi, lo = 0.03, -0.03
        if seen is not None and seen.x.size:
            hi, lo = float(np.max(seen.x)), float(np.min(seen.x))
        out: list[dict[str, float]] = []
        for q in (0.5, 0.7, 0.85):
            bump = {"bump_onset_m": max(q * hi, 0.0), "bump_force_n": 100.0}
            top = {"topout_onset_m": min(q * lo, 0.0), "topout_force_n": 100.0}
            out.append({**bump, "topout_force_n": 0.0})
            out.append({**top, "bump_force_n": 0.0})
            out.append({**bump, **top})
        return out

    def unseen(self, p: Mapping[str, float], x: FloatArray) -> dict[str, float]:
        """Off values for a side the data reach less than 10 % of the half-stroke past its onset
        (or not at all), and for the loss parameters that then move nothing."""
        # A side whose onset the stroke never reaches is not measured; one reached only in
        # its last 10 % is not placed (see `unplaced`), and along that edge the fit can
        # trade onset for force without end (a 50 kN top-out 0.01 mm deep fits a reversal
        # as well as 26 N 1.4 mm deep). Either way a car must not inherit it.
        # The side's onset goes off with its force: with no force it moves nothing, and a
        # diagnosis that frees the term must not vary it.
        if not x.size:
            return {}
        gone = [s for s in _sides(p, x) if s[4] < MIN_DEPTH_SHARE * _half_stroke(x)]
        return self._off(p, gone)

    def faint(
        self, p: Mapping[str, float], x: FloatArray, v: FloatArray, limit_n: float
    ) -> dict[str, float]:
        """Off values for a side with force whose own force, losses included, stays below
        `limit_n` wherever the data reach past its onset (and the losses' parameters when
        neither side is left)."""
        # A side that small is no estimate: beside a 2-3 mm deep bump stop the fit put
        # 0.14 N of top-out at x = 0, against a 2.7 N limit, and the refit on every test,
        # its onset pinned at the range's end, dropped the stop with it.
        if not x.size:
            return {}
        gone = []
        for side in _sides(p, x):
            _, force, onset, n, _ = side
            if p[force] <= 0:
                continue
            sign = 1.0 if force == "bump_force_n" else -1.0
            depth = np.maximum(sign * (x - p[onset]), 0.0) / REFERENCE_DEPTH_M
            own = p[force] * depth ** p[n] * _loss_factor(p, sign * v)
            if float(np.max(own)) < limit_n:
                gone.append(side)
        return self._off(p, gone)

    def _off(
        self, p: Mapping[str, float], gone: Sequence[tuple[str, str, str, str, float]]
    ) -> dict[str, float]:
        """Off values for the sides `gone`, and for the losses when none is left or there
        is no loss, where they are not off already."""
        off = {q.name: q.off for q in self.params()}
        out: dict[str, float] = {}
        for _, force, onset, n, _ in gone:
            out[force], out[onset] = off[force], off[onset]
            if p[n] != off[n]:
                out[n] = off[n]
        # The loss acts on the stops' force only: with none left, or no loss, its
        # parameters move nothing.
        losses: tuple[str, ...] = ()
        if all(p[force] == off[force] or force in out for force in _FORCES):
            losses = ("hysteresis", "viscous_s_m", "hysteresis_velocity_m_s")
        elif p["hysteresis"] == 0.0:
            losses = ("hysteresis_velocity_m_s",)
        for name in losses:
            if p[name] != off[name]:
                out[name] = off[name]
        return out

    def unplaced(self, p: Mapping[str, float], x: FloatArray) -> str:
        """Names a side with force that the data reach only in the last 10 % of the half-stroke:
        at reversal only, where a lag or friction acts too."""
        if not x.size:
            return ""
        for side, force, _, _, depth in _sides(p, x):
            if p[force] > 0 and 0 < depth < MIN_DEPTH_SHARE * _half_stroke(x):
                return (
                    f"{side} only in the last {1e3 * depth:.2g} mm of the stroke: it acts at "
                    "reversal only, where a lag or friction acts too (a slow push through "
                    "the end of travel would tell)"
                )
        return ""

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """Add the contact force (N, positive resisting compression) at the FORCE stage; no
        state."""
        bump = np.maximum(w.x - p["bump_onset_m"], 0.0) / REFERENCE_DEPTH_M
        top = np.maximum(p["topout_onset_m"] - w.x, 0.0) / REFERENCE_DEPTH_M
        force = p["bump_force_n"] * bump ** p["exponent"]
        force -= p["topout_force_n"] * top ** p["topout_exponent"]
        eta, alpha = p["hysteresis"], p["viscous_s_m"]
        if eta != 0.0 or alpha != 0.0:
            # Going into either stop it pushes harder than coming out. The speed into the
            # stop is +v at the bump and -v at the top-out, i.e. v·sgn(force). Coming out
            # fast, a viscous loss would have the stop pull; a rubber leaves the rod then.
            force = force * _loss_factor(p, w.v * np.sign(force))
        w.add_part(self.name, force)
        return None


def _loss_factor(p: Mapping[str, float], v_in: FloatArray) -> FloatArray:
    """A side's force multiplier at speed `v_in` into the stop: max(0, 1 + η tanh(v_in/v_h)
    + α v_in)."""
    eta, alpha = p["hysteresis"], p["viscous_s_m"]
    loss = eta * np.tanh(v_in / p["hysteresis_velocity_m_s"]) + alpha * v_in
    return np.maximum(1.0 + loss, 0.0)


def _half_stroke(x: FloatArray) -> float:
    return 0.5 * (float(np.max(x)) - float(np.min(x)))


_FORCES = ("bump_force_n", "topout_force_n")


def _sides(p: Mapping[str, float], x: FloatArray) -> tuple[tuple[str, str, str, str, float], ...]:
    """(side, its force, onset and exponent parameters, how far the data reach past its
    onset)."""
    bump = float(np.max(x)) - p["bump_onset_m"]
    top = p["topout_onset_m"] - float(np.min(x))
    return (
        ("bump stop", "bump_force_n", "bump_onset_m", "exponent", bump),
        ("top-out", "topout_force_n", "topout_onset_m", "topout_exponent", top),
    )
