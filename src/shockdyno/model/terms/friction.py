"""Seal friction with a Stribeck curve, added to the paper's Coulomb friction.

    F = F_c tanh(v/v_ε)                              (paper: spec friction_n, v_ε)
      + F_b exp(-(v/v_s)²) tanh(v/v_ε) + c_v v       (this term)

F_b is the breakaway force above the Coulomb level (static = F_c + F_b), v_s the
Stribeck velocity over which it decays, c_v the viscous drag of the seals. Off: F_b =
c_v = 0. The Coulomb level stays the fitted global `friction_n`. Where the spec's seal
has a presliding distance (`friction_presliding_m`, calibrated by the diagnosis:
model/seal.py), the breakaway rides on the same deflection state: the whole seal is the
LuGre form with g(v) = F_c + F_b exp(-(v/v_s)²), and this term's component is that less
the Coulomb seal alone. There F_c + F_b is a level the seal approaches after a reversal but,
the rod past v_s before it has turned, does not reach: the breakaway a dyno shows is the
seal's largest force on the recording (`Friction.reached`), which the diagnosis reports.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from shockdyno.model.composite import FORCE, Evaluation, FloatArray, Term, Work
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading
from shockdyno.model.seal import seal_force
from shockdyno.model.spec import DamperSpec


class Friction(Term):
    """Seal friction beyond the spec's Coulomb level: a Stribeck breakaway decaying with speed,
    and viscous drag (module doc), on the seal's presliding state where the spec has one."""

    name = "friction"
    stage = FORCE
    summary = (
        "Stribeck seal friction: breakaway above Coulomb, decaying with speed, plus viscous drag"
    )
    follows = ("velocity", "direction", "presliding")
    PARAMS = (
        Param(
            "breakaway_n",
            "N",
            nominal=25.0,
            lo=0.0,
            hi=1000.0,
            scale=10.0,
            off=0.0,
            doc="breakaway above Coulomb",
        ),
        Param(
            "stribeck_velocity_m_s",
            "m/s",
            nominal=0.005,
            lo=0.0005,
            hi=0.05,
            scale=0.005,
            off=0.005,
            doc="speed over which the breakaway decays (exists only with F_b > 0)",
        ),
        Param(
            "viscous_n_s_m",
            "N·s/m",
            nominal=40.0,
            lo=0.0,
            hi=5000.0,
            scale=50.0,
            off=0.0,
            doc="viscous seal drag",
        ),
    )

    def describe(self, r: Reading) -> str:
        """The breakaway the seal reaches on the recording where the diagnosis read it, the
        Stribeck level above Coulomb and its velocity, and the viscous drag, each when the
        data moved it, in the reader's units."""
        (fn, fl), (vn, vl), (cn, cl) = r.force, r.speed, r.damping
        parts = []
        reached = r.v(REACHED)
        if r.moved("breakaway_n") and math.isfinite(reached):
            # What a dyno engineer calls the breakaway: the force the seal holds at reversal
            # before it slides, sliding friction included. The Stribeck level is a parameter
            # of the law, approached but not reached where the seal turns over a travel.
            parts.append(
                f"breakaway {fn * reached:.3g} {fl} at reversal on these tests (the peak "
                f"seal force, Coulomb included), on a Stribeck level "
                f"{fn * r.v('breakaway_n'):.3g}{r.sd('breakaway_n', fn)} {fl} above Coulomb "
                f"falling over {vn * r.v('stribeck_velocity_m_s'):.2g}"
                f"{r.sd('stribeck_velocity_m_s', vn)} {vl}"
            )
        elif r.moved("breakaway_n"):
            parts.append(
                f"breakaway {fn * r.v('breakaway_n'):.3g}{r.sd('breakaway_n', fn)} {fl} "
                f"above Coulomb, falling over {vn * r.v('stribeck_velocity_m_s'):.2g}"
                f"{r.sd('stribeck_velocity_m_s', vn)} {vl} (Stribeck)"
            )
        if r.moved("viscous_n_s_m"):
            parts.append(
                f"viscous drag {cn * r.v('viscous_n_s_m'):.3g}{r.sd('viscous_n_s_m', cn)} {cl}"
            )
        return "seal friction: " + (", ".join(parts) or "beyond the spec's Coulomb friction")

    def implausible(self, p: Mapping[str, float], spec: DamperSpec) -> str:
        """Refuses a breakaway that decays within the reversal's sign change, or (on the
        paper's smoothed sign) one over 5 times the sliding friction."""
        # A breakaway that decays within the sign change of the Coulomb term lives where
        # the velocity estimate cannot resolve it (a fit patching the reversal); seals do
        # not break away at many times their sliding friction. On the smoothed sign the
        # seal reaches F_c + F_b at every reversal; on a presliding travel it need not
        # (implausible_on).
        if p["breakaway_n"] > 0 and p["stribeck_velocity_m_s"] < 1.5 * spec.friction_velocity_m_s:
            return (
                f"Stribeck velocity {1e3 * p['stribeck_velocity_m_s']:.2g} mm/s is inside the "
                "sign change at reversal"
            )
        if spec.friction_presliding_m == 0.0 and p["breakaway_n"] > _over(spec):
            return f"breakaway {p['breakaway_n']:.3g} N is over 5x the sliding friction"
        return ""

    def implausible_on(self, p: Mapping[str, float], spec: DamperSpec, ev: Evaluation) -> str:
        """On a presliding travel, refuses a seal whose force after reversal reaches over 5
        times the sliding friction above it."""
        # The seal deflects over δ g(v)/F_c toward its level g(v), and g falls off by the
        # Stribeck speed: after a reversal the rod is past v_s before the seal is deflected,
        # so F_c + F_b is a level it approaches but does not reach, and a fit can put it at
        # many times the Coulomb level. What a dyno sees, and what a seal's breakaway is, is
        # the force it reaches.
        if spec.friction_presliding_m <= 0.0 or p["breakaway_n"] <= 0:
            return ""  # on the smoothed sign the level is reached: `implausible` reads it
        seal = self.reached(p, spec, ev).get(REACHED)
        if seal is None:
            return ""
        reached = seal[0] - spec.friction_n
        if reached > _over(spec):
            return (
                f"the seal reaches {reached:.3g} N above its Coulomb level after reversal, over "
                "5x the sliding friction"
            )
        return ""

    def reached(
        self, p: Mapping[str, float], spec: DamperSpec, ev: Evaluation
    ) -> dict[str, tuple[float, str]]:
        """The breakaway on the recording: the largest seal force (Coulomb included, the
        viscous drag not), which the seal reaches at a reversal before it slides."""
        seal = ev.outputs.get(f"{self.name}.seal_n")
        if seal is None or seal.size == 0:
            return {}
        return {REACHED: (float(np.max(np.abs(seal))), "N")}

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        """Stribeck velocities of 2, 5, 15 and 40 mm/s."""
        return [{"stribeck_velocity_m_s": v} for v in (0.002, 0.005, 0.015, 0.04)]

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        """Add the breakaway and viscous force (N, the sign of v: resisting the motion) at the
        FORCE stage; returns the seal's deflection state where the spec has a presliding
        distance."""
        v = w.v
        vs = p["stribeck_velocity_m_s"]
        spec = w.spec
        viscous = p["viscous_n_s_m"] * v
        if spec.friction_presliding_m > 0.0 and spec.friction_n > 0.0:
            seal, state = seal_force(
                v,
                w.starts,
                w.dt_s,
                spec.friction_n,
                spec.friction_presliding_m,
                spec.friction_velocity_m_s,
                w.inputs.periodic,
                p["breakaway_n"],
                vs,
                carry,
            )
            w.add_part(self.name, seal - w.parts["coulomb"] + viscous)
            w.outputs[f"{self.name}.seal_n"] = seal
            return state
        sign = np.tanh(v / spec.friction_velocity_m_s)
        breakaway = p["breakaway_n"] * np.exp(-((v / vs) ** 2)) * sign
        w.add_part(self.name, breakaway + viscous)
        w.outputs[f"{self.name}.seal_n"] = w.parts["coulomb"] + breakaway
        return None


# The finding's readout of the breakaway the seal reaches (Term.reached).
REACHED = "breakaway_reached_n"


def _over(spec: DamperSpec) -> float:
    """The most a seal breaks away above its sliding friction: 5x it (5x 20 N below 20 N)."""
    return 5 * max(spec.friction_n, 20.0)
