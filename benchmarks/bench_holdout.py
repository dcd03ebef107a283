"""Held-out benchmark of `shockdyno diagnose` on a plant its authors did not write.

The plant (tests/holdout/plant.py) is a monotube damper on a dyno written from first
principles without reading the project's physics; tests/holdout/sweep.py records a
click sweep of it (clicks 2, 5, 10, 15, 20 × 0.5 / 1 / 1.5 Hz, 30 mm, 1 kHz, a ramped
warm-up cycle + 4 measured cycles, state and heat carried test to test, rests between) in
the CSV exchange format. For each case and seed this script writes the CSVs, runs the CLI as
a user would,

    shockdyno import manifest.csv -o REC.mcap
    shockdyno diagnose REC.mcap --json DIAG.json

and scores `verdict.physics` against what the plant did.

    .venv/bin/python benchmarks/bench_holdout.py [--seeds N] [--first-seed S] [--cache DIR]
                                                  [--jobs J] [--only PREFIX[,PREFIX...]]

A seed changes the sensor noise AND draws every strength parameter of every case uniformly
from the ranges below, so each seed is a new plant. `--cache DIR` keeps each recording's
CSVs, truth.json, REC.mcap and DIAG.json in DIR/CASE-sSEED/ and reuses what is there.

Cases and strengths (fixed from physics before any diagnosis was run; ranges are uniform)
------------------------------------------------------------------------------------------
Every recording: spec damper (sim/ohlins-s46.toml), charge 1.6 MPa abs unless said, start
at 40 °C, ambient 22 °C, noise 2 N / 1 µm / 0.02 °C, 200 Hz 4-pole Butterworth anti-alias
on force and displacement.

clean            nothing added.
comp_lo|mid|hi   aerated oil, both chambers: free air at the charge α = 0.1-0.3 % | 0.5-1.0 %
                 | 1.5-3.0 %; bubble index κ 1.0-1.3; oil + tube modulus K_l 1.2-1.6 GPa.
                 K_eff at the charge ≈ 0.45-0.9 GPa | 0.15-0.35 GPa | 50-120 MPa. (Aerated
                 damper oil: a few % air at 1 bar; at a 16 bar charge a badly bled damper
                 keeps 0.5-3 %.)
cav_lo|mid|hi    the operator set a low charge (written in the manifest): 0.70-0.90 MPa |
                 0.55-0.70 | 0.40-0.55 MPa abs; released-gas ratio ε 0.05-0.3, redissolution
                 0.5-2 s. The clean compression Δp reaches ~0.8 MPa at 0.28 m/s on the stiff
                 clicks, so cav_lo may form no void (it then counts as clean).
cav_air          an oil filled without degassing (issue 44): it holds the air that saturates it
                 at 1 atm and releases it below 60-95 kPa (gaseous cavitation), the charge
                 the operator set 0.72-0.80 MPa (written in the manifest), ε and
                 redissolution as cav_*. The floor then binds on the stiffest clicks where
                 a degassed oil's 3 kPa would not: the rebound side boils in compression at
                 a charge the model reads as a spec error of about 2x.
fric_lo|mid|hi   seal lip breakaway F_s = 50-70 | 70-100 | 100-150 N over the spec's 35 N
                 Coulomb; Stribeck speed v_s 3-8 mm/s; lip travel 0.05-0.15 mm; viscous seal
                 drag c_v 20-60 | 60-120 | 120-200 N·s/m. (Racing rod seal + piston band:
                 20-50 N sliding, 1.5-3x to break away after a reversal; 50-200 N·s/m of
                 oil-film drag.)
lag_lo|mid|hi    force channel only: transport delay 0.5-1.5 | 1.5-3 | 3-6 ms (DAQ skew,
                 digital filtering in the amplifier) and a load-cell/amplifier 2nd-order
                 response at f_n = 150-300 | 80-150 | 40-80 Hz, ζ 0.6-0.8. Total
                 low-frequency delay ≈ 1.2-2.8 | 2.4-4.5 | 4.4-8.8 ms.
lag1             force channel only: a first-order (RC) load-cell amplifier, τ = 3-8 ms,
                 no delay (issue 44: a lag the library must read as a lag, not a delay).
thermal_lo|mid|hi  temperature-dependent oil (Vogel: 24 / 11 / 3.1 cSt at 20 / 40 / 100 °C)
                 acting on the gap leak, a valve seat land of 0.5-0.8 | 0.8-1.2 | 1.2-1.6 mm
                 and a needle-passage viscous share of 5-10 | 10-20 | 20-30 % at 40 °C; gas
                 charge ∝ body temperature, oil expansion 7e-4 /K; the damper starts at
                 30-36 | 24-30 | 15-22 °C (taken from the shelf and not warmed up); oil-body
                 conductance 6-14 W/K.
contact_lo|mid|hi  bump rubber from x_b = 26-28.5 | 22-26 | 18-22 mm with k_b = 20-40 |
                 30-60 | 30-60 N/mm (hyperbolic densification at 20 mm, 15 % rate
                 hysteresis); _hi also has a top-out spring from -24 to -28 mm, 20-50 N/mm.
spec_gasvol      gas column off the spec by x0.6-0.8 or x1.3-1.6 (side drawn at random).
spec_charge      true charge = written x0.80-0.90 or x1.10-1.20 (gauge error, a slow leak).
spec_preload     both shim stacks' preload x0.70-0.85 or x1.15-1.30 (dish or shim error).
pair_comp_fric   comp_mid + fric_mid.     pair_lag_contact   lag_mid + contact_mid.
pair_thermal_fric thermal_mid + fric_lo.  pair_cav_lag       cav_mid + lag_lo.
triple_comp_fric_lag  comp_mid + fric_mid + lag_mid.

Visibility was checked only against the raw data (benchmarks/holdout_visibility.py: RMS
force difference from the clean sweep, per test, noise off; the numbers are in that file):
at seed 0 every effect case differs from clean by 10-420 N RMS in its strongest tests
(noise: 2 N); spec_gasvol by 4 N.

Scoring
-------
Truth names (compressibility, cavitation, friction, sensor_lag, thermal, contact) are what
the plant DID: cavitation only if a void > 1 mm³ formed, contact only if the stroke reached
an onset. Claimed names are DIAG.json `verdict.physics`; gas_spring / position_force claims
are shown but are not scored (they are no truth name). Printed: per recording truth,
claimed, mean E_t before -> after over the tests, the plant's key values and each finding's
parameters as DIAG.json gives them; then per physics precision / recall / F1, the clean
false-positive rate (clean = no truth name: clean, spec errors, cavitation cases without a
void; a false positive = any scored name claimed) with the Clopper-Pearson two-sided 95 %
interval's upper end, and the share of effect recordings whose mean E_t after is <= 1.5x
the mean over the `clean` case's recordings.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
import zlib
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import beta

# The plant and its sweep live with the tests (tests/holdout/), which diagnose it too.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from holdout.plant import Effects
from holdout.sweep import run_sweep

PHYSICS = ("compressibility", "cavitation", "friction", "sensor_lag", "thermal", "contact")
Range = tuple[float, ...]  # (lo, hi) or (lo1, hi1, lo2, hi2): one of two intervals


@dataclass(frozen=True)
class Case:
    name: str
    ranges: dict[str, Range] = field(default_factory=dict)
    fixed: dict[str, Any] = field(default_factory=dict)


def _c(name: str, fixed: dict[str, Any] | None = None, **ranges: Range) -> Case:
    return Case(name, dict(ranges), dict(fixed or {}))


COMP = {"air_index": (1.0, 1.3), "liquid_bulk_pa": (1.2e9, 1.6e9)}
CAV = {"gas_release": (0.05, 0.3), "redissolve_s": (0.5, 2.0)}
FRIC = {"stribeck_velocity_m_s": (0.003, 0.008), "lip_travel_m": (0.5e-4, 1.5e-4)}
LAG = {"cell_damping": (0.6, 0.8)}
THERM = {"oil_body_w_k": (6.0, 14.0)}
ON = {"thermal": True}

BASE = [
    _c("clean"),
    _c("comp_lo", air_fraction=(0.001, 0.003), **COMP),
    _c("comp_mid", air_fraction=(0.005, 0.010), **COMP),
    _c("comp_hi", air_fraction=(0.015, 0.030), **COMP),
    _c("cav_lo", charge_pa=(0.70e6, 0.90e6), **CAV),
    _c("cav_mid", charge_pa=(0.55e6, 0.70e6), **CAV),
    _c("cav_hi", charge_pa=(0.40e6, 0.55e6), **CAV),
    _c("cav_air", charge_pa=(0.72e6, 0.80e6), release_pressure_pa=(60e3, 95e3), **CAV),
    _c("fric_lo", breakaway_n=(50.0, 70.0), seal_viscous_n_s_m=(20.0, 60.0), **FRIC),
    _c("fric_mid", breakaway_n=(70.0, 100.0), seal_viscous_n_s_m=(60.0, 120.0), **FRIC),
    _c("fric_hi", breakaway_n=(100.0, 150.0), seal_viscous_n_s_m=(120.0, 200.0), **FRIC),
    _c("lag_lo", force_delay_s=(0.5e-3, 1.5e-3), cell_freq_hz=(150.0, 300.0), **LAG),
    _c("lag_mid", force_delay_s=(1.5e-3, 3e-3), cell_freq_hz=(80.0, 150.0), **LAG),
    _c("lag_hi", force_delay_s=(3e-3, 6e-3), cell_freq_hz=(40.0, 80.0), **LAG),
    _c("lag1", cell_lag_s=(3e-3, 8e-3)),
    _c(
        "thermal_lo",
        ON,
        start_temperature_c=(30.0, 36.0),
        land_length_m=(0.5e-3, 0.8e-3),
        needle_share=(0.05, 0.10),
        **THERM,
    ),
    _c(
        "thermal_mid",
        ON,
        start_temperature_c=(24.0, 30.0),
        land_length_m=(0.8e-3, 1.2e-3),
        needle_share=(0.10, 0.20),
        **THERM,
    ),
    _c(
        "thermal_hi",
        ON,
        start_temperature_c=(15.0, 22.0),
        land_length_m=(1.2e-3, 1.6e-3),
        needle_share=(0.20, 0.30),
        **THERM,
    ),
    _c("contact_lo", bump_onset_m=(0.026, 0.0285), bump_k_n_m=(20e3, 40e3)),
    _c("contact_mid", bump_onset_m=(0.022, 0.026), bump_k_n_m=(30e3, 60e3)),
    _c(
        "contact_hi",
        bump_onset_m=(0.018, 0.022),
        bump_k_n_m=(30e3, 60e3),
        topout_onset_m=(0.024, 0.028),
        topout_k_n_m=(20e3, 50e3),
    ),
    _c("spec_gasvol", gas_volume_factor=(0.6, 0.8, 1.3, 1.6)),
    _c("spec_charge", gas_charge_factor=(0.80, 0.90, 1.10, 1.20)),
    _c("spec_preload", preload_factor=(0.70, 0.85, 1.15, 1.30)),
]
_BY_NAME = {c.name: c for c in BASE}


def _combo(name: str, *parts: str) -> Case:
    ranges: dict[str, Range] = {}
    fixed: dict[str, Any] = {}
    for p in parts:
        ranges.update(_BY_NAME[p].ranges)
        fixed.update(_BY_NAME[p].fixed)
    return Case(name, ranges, fixed)


CASES = [
    *BASE,
    _combo("pair_comp_fric", "comp_mid", "fric_mid"),
    _combo("pair_lag_contact", "lag_mid", "contact_mid"),
    _combo("pair_thermal_fric", "thermal_mid", "fric_lo"),
    _combo("pair_cav_lag", "cav_mid", "lag_lo"),
    _combo("triple_comp_fric_lag", "comp_mid", "fric_mid", "lag_mid"),
]


def draw(case: Case, seed: int) -> Effects:
    """This case's plant for this seed: every range drawn uniformly."""
    rng = np.random.default_rng([seed, zlib.crc32(case.name.encode())])
    kw: dict[str, Any] = dict(case.fixed)
    for key, r in sorted(case.ranges.items()):
        if len(r) == 4:
            side = int(rng.integers(2))
            r = r[2 * side : 2 * side + 2]
        kw[key] = float(rng.uniform(r[0], r[1]))
    return Effects(**kw)


def noise_seed(case: Case, seed: int) -> int:
    return (seed * 1_000_003 + zlib.crc32(case.name.encode())) % (2**31)


def _cli() -> str:
    exe = Path(sys.executable).parent / "shockdyno"
    return str(exe) if exe.exists() else "shockdyno"


def run_one(case: Case, seed: int, cache: Path) -> dict[str, Any]:
    """Sweep, import, diagnose one recording (reusing what the cache holds)."""
    d = cache / f"{case.name}-s{seed}"
    manifest, truth_file = d / "manifest.csv", d / "truth.json"
    rec, diag = d / "REC.mcap", d / "DIAG.json"
    timing: dict[str, float] = {}
    if not (manifest.exists() and truth_file.exists()):
        t = time.perf_counter()
        run_sweep(draw(case, seed), d, seed=noise_seed(case, seed))
        timing["sweep_s"] = time.perf_counter() - t
    if not rec.exists():
        t = time.perf_counter()
        _run([_cli(), "import", str(manifest), "-o", str(rec)], d / "import.log")
        timing["import_s"] = time.perf_counter() - t
    if not diag.exists():
        t = time.perf_counter()
        _run([_cli(), "diagnose", str(rec), "--json", str(diag)], d / "diagnose.log")
        timing["diagnose_s"] = time.perf_counter() - t
    return {
        "case": case.name,
        "seed": seed,
        "truth": json.loads(truth_file.read_text()),
        "diag": json.loads(diag.read_text()),
        "timing": timing,
    }


def _run(cmd: list[str], log: Path) -> None:
    with log.open("w") as fh:
        r = subprocess.run(cmd, stdout=fh, stderr=subprocess.STDOUT, check=False)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({r.returncode}); see {log}")


# -- reading DIAG.json generically ---------------------------------------------------------
def claimed(diag: dict[str, Any]) -> list[str]:
    phys = (diag.get("verdict") or {}).get("physics") or []
    return [p if isinstance(p, str) else str(p.get("name", p)) for p in phys]


def mean_et(diag: dict[str, Any]) -> tuple[float, float]:
    before = [t.get("E_t_before") for t in diag.get("tests", [])]
    after = [t.get("E_t_after") for t in diag.get("tests", [])]
    b = [v for v in before if isinstance(v, int | float)]
    a = [v for v in after if isinstance(v, int | float)]
    return (sum(b) / len(b) if b else math.nan, sum(a) / len(a) if a else math.nan)


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v[:6]) + (", ..." if len(v) > 6 else "") + "]"
    if isinstance(v, dict) and "value" in v:  # a parameter given as {value, sd, unit, ...}
        sd = f"±{_fmt(v['sd'])}" if isinstance(v.get("sd"), int | float) else ""
        unit = f" {v['unit']}" if v.get("unit") not in (None, "", "1") else ""
        return f"{_fmt(v['value'])}{sd}{unit}" + (" (fixed)" if v.get("fixed") else "")
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}={_fmt(x)}" for k, x in v.items()) + "}"
    return str(v)


def findings_text(diag: dict[str, Any], claim: list[str], truth: list[str]) -> list[str]:
    """The parameters DIAG.json gives (read generically) for each claimed finding, and for
    each true physics that was not claimed (marked so)."""
    out = []
    for f in diag.get("findings", []) or []:
        if not isinstance(f, dict):
            continue
        label = next(
            (str(f[k]) for k in ("physics", "term", "name") if isinstance(f.get(k), str)), "?"
        )
        if label in claim:
            out.append(f"found: {label}: {_fmt(f.get('parameters', {}))}")
        elif label in truth:
            out.append(f"not claimed: {label}: {_fmt(f.get('parameters', {}))}")
    return out


def key_values(truth: dict[str, Any]) -> str:
    v = truth["values"]
    parts = []
    if "bulk_modulus_at_charge_pa" in v:
        parts.append(f"K_eff(charge) {v['bulk_modulus_at_charge_pa'] / 1e6:.0f} MPa")
    if truth.get("cavitated"):
        vmax = max(t["max_void_m3"] for t in truth["tests"])
        ntest = sum(t["max_void_m3"] > 1e-9 for t in truth["tests"])
        parts.append(f"void max {vmax * 1e6:.2f} cm³ in {ntest} tests")
    if v["gas_charge_true_pa"] != v["gas_charge_written_pa"] or v["gas_charge_true_pa"] != 1.6e6:
        parts.append(
            f"charge {v['gas_charge_true_pa'] / 1e6:.3f} MPa"
            f" (written {v['gas_charge_written_pa'] / 1e6:.3f})"
        )
    if "breakaway_n" in v:
        # What the lip reaches at a reversal on the sweep (a finding's breakaway_reached_n
        # reads the same), beside its static level F_s, which a reversing rod does not reach.
        lip = max((t.get("max_lip_n", math.nan) for t in truth["tests"]), default=math.nan)
        parts.append(
            f"breakaway reached {lip:.0f} N (static {v['breakaway_n']:.0f}, Coulomb "
            f"{v['coulomb_n']:.0f}, c_v {v['seal_viscous_n_s_m']:.0f} N·s/m)"
        )
    if "force_delay_s" in v:
        parts.append(
            f"force delay {v['force_delay_s'] * 1e3:.2f} ms (transport "
            f"{v['transport_delay_s'] * 1e3:.2f} ms, cell {v['cell_freq_hz']:.0f} Hz, "
            f"RC {v.get('cell_lag_s', 0.0) * 1e3:.2f} ms)"
        )
    if "bump_onset_m" in v:
        parts.append(f"bump onset {v['bump_onset_m'] * 1e3:.1f} mm")
    if "topout_onset_m" in v:
        parts.append(f"top-out onset {v['topout_onset_m'] * 1e3:.1f} mm")
    fx = truth["effects"]
    if fx.get("thermal"):
        oil = [t["oil_c"] for t in truth["tests"]]
        parts.append(f"oil {min(o[0] for o in oil):.1f}-{max(o[1] for o in oil):.1f} °C")
    for key, label in (
        ("gas_volume_factor", "gas volume"),
        ("gas_charge_factor", "charge"),
        ("preload_factor", "preload"),
    ):
        if fx.get(key, 1.0) != 1.0:
            parts.append(f"{label} x{fx[key]:.3f}")
    return "; ".join(parts) or "-"


def clopper_pearson_upper(k: int, n: int) -> float:
    """Upper end of the two-sided 95 % Clopper-Pearson interval for k of n."""
    if n == 0:
        return math.nan
    return 1.0 if k == n else float(beta.ppf(0.975, k + 1, n - k))


def summarise(results: list[dict[str, Any]]) -> None:
    print()
    rows = []
    for r in sorted(results, key=lambda r: (r["case"], r["seed"])):
        truth = list(r["truth"]["physics"])
        claim = claimed(r["diag"])
        scored = [c for c in claim if c in PHYSICS]
        other = [c for c in claim if c not in PHYSICS]
        b, a = mean_et(r["diag"])
        rows.append((r, truth, scored, a))
        extra = f" (+{','.join(other)})" if other else ""
        mark = "ok " if set(truth) == set(scored) else "ERR"
        print(
            f"{mark} {r['case']:<22} s{r['seed']:<3} truth=[{','.join(truth)}] "
            f"claimed=[{','.join(scored)}]{extra}  E_t {b:.3f} -> {a:.3f}"
        )
        print(f"      plant: {key_values(r['truth'])}")
        for line in findings_text(r["diag"], claim, truth):
            print(f"      {line}")
    print("\nper physics (over all recordings):")
    print(f"  {'physics':<16} {'TP':>3} {'FP':>3} {'FN':>3} {'prec':>6} {'recall':>6} {'F1':>6}")
    for ph in PHYSICS:
        tp = sum(ph in t and ph in s for _, t, s, _ in rows)
        fp = sum(ph not in t and ph in s for _, t, s, _ in rows)
        fn = sum(ph in t and ph not in s for _, t, s, _ in rows)
        prec = tp / (tp + fp) if tp + fp else math.nan
        rec = tp / (tp + fn) if tp + fn else math.nan
        f1 = 2 * prec * rec / (prec + rec) if prec + rec > 0 else math.nan
        print(f"  {ph:<16} {tp:>3} {fp:>3} {fn:>3} {prec:>6.2f} {rec:>6.2f} {f1:>6.2f}")
    clean = [(r, s) for r, t, s, _ in rows if not t]
    k = sum(bool(s) for _, s in clean)
    n = len(clean)
    rate = k / n if n else math.nan
    print(
        f"\nclean false positives: {k}/{n} = {rate:.2f} "
        f"(Clopper-Pearson 95 % upper bound {clopper_pearson_upper(k, n):.2f}); "
        f"clean = {', '.join(sorted({r['case'] for r, _ in clean})) or 'none'}"
    )
    clean_after = [a for r, _, _, a in rows if r["case"] == "clean" and not math.isnan(a)]
    effect = [a for _, t, _, a in rows if t and not math.isnan(a)]
    if clean_after and effect:
        ref = sum(clean_after) / len(clean_after)
        good = sum(a <= 1.5 * ref for a in effect)
        print(
            f"effect recordings with mean E_t after <= 1.5x the clean mean ({ref:.3f}): "
            f"{good}/{len(effect)} = {good / len(effect):.2f}"
        )
    else:
        print("E_t share: needs recordings of the clean case and of effects")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=1, help="seeds per case (default 1)")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--cache", type=Path, default=None, help="keep recordings here")
    ap.add_argument("--jobs", type=int, default=1, help="recordings at once (default 1)")
    ap.add_argument("--only", default="", help="case-name prefixes, comma-separated")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    args = ap.parse_args(argv)
    prefixes = [p for p in args.only.split(",") if p]
    cases = [c for c in CASES if not prefixes or any(c.name.startswith(p) for p in prefixes)]
    if args.list or not cases:
        for c in CASES:
            print(c.name, c.fixed or "", c.ranges or "")
        return
    cache = args.cache or Path(tempfile.mkdtemp(prefix="holdout-"))
    cache.mkdir(parents=True, exist_ok=True)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    jobs = [(c, s) for s in seeds for c in cases]
    print(f"{len(jobs)} recordings, cache {cache}, {args.jobs} at once", flush=True)
    results: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(run_one, c, s, cache): (c, s) for c, s in jobs}
        for fut, (c, s) in futures.items():
            try:
                r = fut.result()
            except Exception as exc:  # one failed recording does not stop the rest
                print(f"FAILED {c.name} s{s}: {exc}", flush=True)
                continue
            results.append(r)
            tm = " ".join(f"{k} {v:.0f}" for k, v in r["timing"].items())
            print(
                f"done {c.name} s{s}: truth={r['truth']['physics']} "
                f"claimed={claimed(r['diag'])} {tm}",
                flush=True,
            )
    print(f"wall time {time.perf_counter() - t0:.0f} s")
    summarise(results)


if __name__ == "__main__":
    main()
