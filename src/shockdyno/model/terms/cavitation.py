"""Rebound-chamber cavitation: the chamber behind the piston cannot fall below the oil's
vapour / air-release pressure, and what it could not fill must refill first.

In a monotube the compression chamber sits at gas pressure p_c, so on a fast
compression stroke the rebound chamber, p_r = p_c - Δp, is the one that would go below
p_v once Δp exceeds p_c - p_v. It cannot: it sits at p_v, the compression force
saturates (earlier at lower gas pressure), and vapour fills the volume the flow does not.
After reversal the vapour must be pushed back before the chamber's pressure builds, so
the rebound force lags (model/chamber.py integrates both, with the compressibility
term's compliance when it is in the model). Vapour neither forms nor goes back into
the oil at once: it forms at (p_v - p)/R_e below the floor, so a fast stroke pulls the
chamber under p_v, and condenses at (p - p_v)/R_c, so after reversal the pressure
builds above p_v while the vapour is still going (both resistances 0: at once, a hard
floor). Off: p_v = -∞ (no floor). A recording that never reaches p_v bounds it only
from above.

An oil that holds dissolved air also gives gas up into the void, and that gas outlives
it: while the chamber holds vapour, gas comes out at a fixed rate (cm³/s at one
atmosphere); above the floor it redissolves at G (p - p_v)/(P_atm τ), so after the void
collapses the chamber keeps a Boyle compliance, G P_atm / p, and the rebound force lags
after the top reversal for strokes after (model/chamber.py). Off: no release. Both held
unless named (τ at 5 s at 1 atm over the floor: about 1 s at a few bar); the diagnosis
tries the release rate after the floor's own fit, from it and from the floor's starts,
and keeps it where it is significant.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from shockdyno.model.chamber import Chamber
from shockdyno.model.composite import ATMOSPHERE_PA, PRESSURE, Evaluation, FloatArray, Term, Work
from shockdyno.model.params import Param
from shockdyno.model.reading import Reading
from shockdyno.model.spec import DamperSpec
from shockdyno.model.terms.compressibility import run_chamber

KPA_S_PER_CM3 = 1.0e9  # Pa·s/m³
CM3 = 1.0e-6  # m³
FLOOR_LO = -5.0e6  # below any pressure the data reach: the floor never acts (nests "off")
# The highest pressure at which a rebound chamber can hold vapour or released gas. A damper
# oil's vapour pressure is well under a kPa at 20-100 °C; what comes out first is the air
# dissolved in it, and only below the pressure that oil was saturated at (Henry's law).
# In a monotube the floating piston keeps the nitrogen charge away from the oil, which was
# filled and bled at (or below) one atmosphere, so it holds at most the air that saturates
# it there: below 1 atm gas comes out, above it none can. A floor fitted higher (real
# recordings gave 352-360 kPa) is a saturation of the force for another reason.
FLOOR_HI = ATMOSPHERE_PA


def _gas(r: Reading) -> str:
    """The released gas, in words ("" when none is released): a value a fit moved off 0,
    or one given and held; not one a fit left within its noise of 0 (a reading of gas
    beside a fit that could not tell it from none would be two readings)."""
    release, redissolve = r.v("gas_release_cm3_s"), r.v("redissolve_s")
    est = r.values.get("gas_release_cm3_s")
    if not (math.isfinite(release) and release > 0 and est is not None):
        return ""
    if not (est.fixed or r.moved("gas_release_cm3_s")):
        return ""
    sd = r.sd_value("gas_release_cm3_s")
    pm = f" ± {sd:.2g}" if math.isfinite(sd) and not est.fixed else ""
    return (
        f"; air comes out of the oil into the void at {release:.3g}{pm} cm³/s (at 1 atm) and "
        f"redissolves over {redissolve:.3g} s at 1 atm over the floor, a gas that outlives "
        "the void and softens the rebound chamber after it"
    )


def _rates(form: float, condense: float) -> str:
    """The finite vapour rates, in words ("" when both are instant)."""
    parts = [
        f"{what} at {v:.3g} kPa per cm³/s"
        for what, v in (("vapour forms", form), ("condenses", condense))
        if math.isfinite(v) and v > 0
    ]
    return "; " + " and ".join(parts) if parts else ""


class Cavitation(Term):
    name = "cavitation"
    stage = PRESSURE + 5  # after compressibility: the floor acts on the chamber it found
    stateful = True
    summary = "rebound chamber floored at the vapour / air-release pressure; vapour refills"
    PARAMS = (
        Param(
            "release_pressure_pa",
            "Pa",
            nominal=3000.0,
            lo=FLOOR_LO,
            hi=1.0e6,  # the search may go above FLOOR_HI on its way down; a claim may not
            scale=1.0e5,
            off=-math.inf,
            doc="absolute pressure below which vapour forms (and above which it condenses)",
        ),
        # kPa per cm³/s: the pressure under the floor that forms vapour at 1 cm³/s, and
        # over it that condenses 1 cm³/s. 0 (at once) is the hard floor. Held unless
        # named: freed beside the floor in diagnose's short (15-evaluation) refits, the
        # strongest reference-plant cavitation on a fresh seed stayed at its start and
        # lost its claim (held-out gain -3), where the floor alone is claimed.
        Param(
            "form_kpa_s_per_cm3",
            "kPa·s/cm³",
            nominal=0.0,
            lo=0.0,
            hi=100.0,
            scale=0.01,
            off=0.0,
            free=False,
            doc="pressure under the floor per cm³/s of vapour forming (0: at once)",
        ),
        Param(
            "condense_kpa_s_per_cm3",
            "kPa·s/cm³",
            nominal=0.0,
            lo=0.0,
            hi=100.0,
            scale=0.1,
            off=0.0,
            free=False,
            doc="pressure over the floor per cm³/s of vapour condensing (0: at once)",
        ),
        # Released air (cm³/s at one atmosphere while vapour is held). An oil saturated at
        # 1 atm holds about 9 % air by volume; a void of 0.1 cm³ fed from the oil around it
        # takes up a few cm³/s at most. Held unless named; the diagnosis tries it after
        # the floor (`refinements`): a held-out sweep's vapour moved the force 2 N RMS by
        # its floor and 8.7 N by the gas it left.
        Param(
            "gas_release_cm3_s",
            "cm³/s",
            nominal=0.0,
            lo=0.0,
            hi=100.0,
            scale=1.0,
            off=0.0,
            free=False,
            doc="air released into the void, cm³/s at 1 atm, while vapour is held (0: none)",
        ),
        # Held: a sweep at 0.5/1/1.5 Hz sees the gas's level far better than how fast it
        # goes, and a freed τ ran to its ends.
        Param(
            "redissolve_s",
            "s",
            nominal=5.0,
            lo=0.05,
            hi=500.0,
            scale=1.0,
            off=5.0,
            free=False,
            doc="time released gas takes to redissolve (1/e) at 1 atm over the floor",
        ),
    )

    def describe(self, r: Reading) -> str:
        floor = r.v("release_pressure_pa")
        if not math.isfinite(floor):
            return "cavitation: no floor (off)"
        rates = _rates(r.v("form_kpa_s_per_cm3"), r.v("condense_kpa_s_per_cm3"))
        if floor > 0:  # below vacuum no gas is released (model/chamber.py)
            rates += _gas(r)
        if floor >= 0:
            return (
                f"cavitation: the rebound chamber holds at {floor / 1e3:.3g} kPa absolute; "
                f"compression force saturates{rates}"
            )
        # No chamber holds below vacuum: the saturation is real, but the model's chamber
        # pressure runs low by at least this much (the gas charge, or how the pressure
        # splits across the piston), so the floor's value is not a release pressure, and
        # no gas is released at it (model/chamber.py): the text names none.
        return (
            "cavitation: compression force saturates as if the rebound chamber held at "
            f"{floor / 1e3:.3g} kPa absolute, below vacuum: the model's chamber pressure "
            f"runs at least {-floor / 1e3:.3g} kPa low there, so this is not the release "
            f"pressure{rates}"
        )

    def implausible(self, p: Mapping[str, float], spec: DamperSpec) -> str:
        # A floor a little below vacuum is a real saturation with the chamber's pressure
        # a little off; one lower than the whole gas charge below vacuum would need the
        # chamber to run low by more than the charge that sets it: the force saturates
        # for another reason (a reference-plant friction sweep, no vapour: -3.59 MPa).
        floor = p["release_pressure_pa"]
        if floor > FLOOR_HI:  # a value from outside the fit (a fit file, a scenario)
            return (
                f"a floor at {floor / 1e3:.3g} kPa absolute is above the "
                f"{FLOOR_HI / 1e3:.4g} kPa below which oil filled at one atmosphere can "
                "release gas or vapour"
            )
        if FLOOR_LO < floor < -spec.gas_pressure_pa:  # (at FLOOR_LO it never acts)
            return (
                f"a floor at {floor / 1e3:.3g} kPa absolute is further below vacuum than the "
                f"gas charge ({spec.gas_pressure_pa / 1e3:.3g} kPa) is above it"
            )
        return ""

    def start_grid(self, seen: Evaluation | None = None) -> list[dict[str, float]]:
        # Below the lowest pressure the data reach the floor does nothing (no gradient),
        # and a little above it the floor already moves the force by hundreds of N: the
        # band where it binds but does not overshoot is narrow. So the starts sit just
        # above the lowest rebound-chamber pressure the model without it reaches. Starts
        # above FLOOR_HI stay: a refit from them can come down to a physical floor (a
        # fresh sweep's 12.6 kPa was reached from them, and missed from starts <= 1 atm).
        fixed = [3e3, 1e5, 3e5, 5e5, 7e5, 9e5]
        if seen is not None and seen.p_c.size:
            lowest = float(np.min(seen.p_c - seen.dp))
            span = float(np.median(seen.p_c)) - lowest
            if math.isfinite(lowest) and span > 0:
                fixed += [lowest + q * span for q in (0.01, 0.03, 0.06, 0.1, 0.2, 0.35)]
        hi = self.PARAMS[0].hi
        return [{"release_pressure_pa": p} for p in sorted({min(p, hi) for p in fixed})]

    def refinements(self) -> dict[str, tuple[float, ...]]:
        # The released gas, tried after the floor's own fit, from it and from each of the
        # floor's starts (none, and 3 cm³/s: a 0.1 cm³ void a few tenths of a second a
        # cycle): beside another term the floor alone can be fitted where it does nothing,
        # and gas tried only from there could not act. Freed beside the floor from the start,
        # it cost the sim-rig's hard 3 kPa floor its place (9.4 kPa, with 0.1 cm³/s of
        # gas the plant did not have) in diagnose's short refits.
        return {"gas_release_cm3_s": (0.0, 3.0)}

    def apply(
        self, w: Work, p: Mapping[str, float], carry: FloatArray | None, stage: int
    ) -> FloatArray | None:
        floor = p["release_pressure_pa"]
        if floor == -math.inf:
            return None
        assert w.dp is not None
        found = w.chamber if isinstance(w.chamber, Chamber) else None
        chamber = Chamber(
            air_fraction=found.air_fraction if found else 0.0,
            charge_pa=w.spec.gas_pressure_pa,
            oil_compressibility_per_pa=found.oil_compressibility_per_pa if found else 0.0,
            release_pa=floor,
            length_m=w.spec.oil_column_m,
            form_resistance_pa_s_m3=p["form_kpa_s_per_cm3"] * KPA_S_PER_CM3,
            condense_resistance_pa_s_m3=p["condense_kpa_s_per_cm3"] * KPA_S_PER_CM3,
            gas_release_m3_s=p["gas_release_cm3_s"] * CM3,
            redissolve_s=p["redissolve_s"],
        )
        dp, vapour, state, p_c, gas = run_chamber(w, chamber, carry)
        w.set_p_c(self.name, p_c)
        w.set_dp(self.name, dp)
        w.outputs[f"{self.name}.vapour_m3"] = vapour
        w.outputs[f"{self.name}.gas_m3"] = gas  # at the chamber's pressure
        return state
