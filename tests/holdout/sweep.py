"""A dyno click sweep of the held-out plant, written in the project's CSV exchange format.

Like a real dyno session: clicks 2, 5, 10, 15, 20, at each click 0.5, 1 and 1.5 Hz, a
30 mm sine at 1 kHz. Each test is one warm-up cycle whose amplitude ramps in as
(1 - cos(π t / T)) / 2, then 4 measured cycles, all recorded (the manifest's
measured_start_s / measured_end_s mark the measured window on the sweep's clock). The
damper's state (pressures, seal lip, released gas, heat) carries from test to test in
order; between tests it rests 5 s (same clicks) or 20 s (the operator turns the adjuster).

Output (docs/csv.md): OUT/manifest.csv (file, clicks, frequency_hz, amplitude_m, gas_clicks,
sample_rate_hz, motion, warmup_cycles, measured_cycles, measured_start_s, measured_end_s,
gas_pressure_pa = the charge the operator set) and OUT/cNN-fF.csv per test with time_s,
displacement_m, force_N, temperature_C. OUT/truth.json holds what the plant did.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from holdout.plant import VOID_TRUTH_M3, Daq, Effects, Plant

CLICKS = (2, 5, 10, 15, 20)
FREQS = (0.5, 1.0, 1.5)
AMPLITUDE_M = 0.030
FS_HZ = 1000.0
OVERSAMPLE = 4
WARMUP_CYCLES = 1
MEASURED_CYCLES = 4
REST_SAME_CLICK_S = 5.0
REST_CLICK_CHANGE_S = 20.0


@dataclass
class TestTruth:
    clicks: int
    frequency_hz: float
    max_void_m3: float
    void_time_s: float
    min_p_rebound_pa: float
    oil_c: tuple[float, float]
    body_c: tuple[float, float]
    max_bump_depth_m: float
    max_topout_depth_m: float
    # The largest elastic lip force over the measured cycles: the breakaway the lip reaches
    # at a reversal on this test (F_s is its limit at rest; a reversing rod is past v_s
    # before the lip has reloaded).
    max_lip_n: float = 0.0


@dataclass
class SweepTruth:
    effects: dict[str, Any]
    values: dict[str, Any]
    tests: list[TestTruth] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def cavitated(self) -> bool:
        return any(t.max_void_m3 > VOID_TRUTH_M3 for t in self.tests)

    @property
    def contacted(self) -> bool:
        return any(t.max_bump_depth_m > 0 or t.max_topout_depth_m > 0 for t in self.tests)

    def physics(self) -> list[str]:
        """The truth names: what the plant DID."""
        fx = Effects(**self.effects)
        names = []
        if fx.compliant:
            names.append("compressibility")
        if self.cavitated:
            names.append("cavitation")
        if fx.stiction or fx.seal_viscous_n_s_m > 0:
            names.append("friction")
        if fx.sensor:
            names.append("sensor_lag")
        if fx.thermal:
            names.append("thermal")
        if self.contacted:
            names.append("contact")
        return names


def motion(
    f_hz: float, fs: float, t0: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Time, x, ẋ and ẍ of one test (ramped warm-up cycle + measured cycles) at rate fs."""
    period = 1.0 / f_hz
    n = math.floor((WARMUP_CYCLES + MEASURED_CYCLES) * period * fs + 1e-9) + 1
    t = np.arange(n) / fs
    w = 2 * math.pi * f_hz
    ramp = t < WARMUP_CYCLES * period
    a = math.pi / (WARMUP_CYCLES * period)
    r = np.where(ramp, (1 - np.cos(a * t)) / 2, 1.0)
    r1 = np.where(ramp, a * np.sin(a * t) / 2, 0.0)
    r2 = np.where(ramp, a * a * np.cos(a * t) / 2, 0.0)
    s, c = np.sin(w * t), np.cos(w * t)
    x = AMPLITUDE_M * r * s
    xd = AMPLITUDE_M * (r1 * s + r * w * c)
    xdd = AMPLITUDE_M * (r2 * s + 2 * r1 * w * c - r * w * w * s)
    return t + t0, x, xd, xdd


def run_sweep(
    effects: Effects,
    out_dir: Path | str,
    seed: int = 0,
    clicks: tuple[int, ...] = CLICKS,
    freqs: tuple[float, ...] = FREQS,
    noise: bool = True,
    write: bool = True,
) -> tuple[SweepTruth, list[dict[str, np.ndarray]]]:
    """Simulate the sweep; write the CSVs (unless write=False); return the truth and the
    recorded arrays per test."""
    out = Path(out_dir)
    if write:
        out.mkdir(parents=True, exist_ok=True)
    wall = time.perf_counter()
    plant = Plant(effects=effects)
    daq = Daq(effects, np.random.default_rng(seed), OVERSAMPLE * FS_HZ, OVERSAMPLE, noise)
    truth = SweepTruth(effects=asdict(effects), values=plant.true_values())
    rows: list[list[str]] = []
    records: list[dict[str, np.ndarray]] = []
    clock = 0.0
    h = 1.0 / (OVERSAMPLE * FS_HZ)
    for ci, c in enumerate(clicks):
        plant.set_clicks(c)
        for fi, f in enumerate(freqs):
            if ci or fi:
                rest = REST_SAME_CLICK_S if fi else REST_CLICK_CHANGE_S
                plant.rest(rest)
                daq.rest(rest, plant.T_body)
                clock += rest
            t0 = round(clock, 3)
            t_fine, x_fine, xd_fine, xdd_fine = motion(f, OVERSAMPLE * FS_HZ, t0)
            sim = plant.run(x_fine, xd_fine, xdd_fine, h)
            clock = float(t_fine[-1])
            n = (len(t_fine) - 1) // OVERSAMPLE + 1
            t_rec = t0 + np.arange(n) / FS_HZ
            rec = {
                "time_s": t_rec,
                "displacement_m": daq.displacement(x_fine)[:n],
                "force_N": daq.force(t_fine, sim["force"])[:n],
                "temperature_C": daq.temperature(sim["t_body"])[:n],
                "force_true_N": sim["force"][::OVERSAMPLE][:n],
            }
            records.append(rec)
            void = sim["void"]
            truth.tests.append(
                TestTruth(
                    clicks=c,
                    frequency_hz=f,
                    max_void_m3=float(void.max()),
                    void_time_s=float(np.count_nonzero(void > VOID_TRUTH_M3) * h),
                    min_p_rebound_pa=float(sim["p_r"].min()),
                    oil_c=(float(sim["t_oil"].min()), float(sim["t_oil"].max())),
                    body_c=(float(sim["t_body"].min()), float(sim["t_body"].max())),
                    max_bump_depth_m=max(0.0, float(x_fine.max()) - effects.bump_onset_m),
                    max_topout_depth_m=max(0.0, -float(x_fine.min()) - effects.topout_onset_m),
                    max_lip_n=float(np.max(np.abs(sim["lip"][t_fine >= t0 + WARMUP_CYCLES / f]))),
                )
            )
            name = f"c{c:02d}-f{f:g}.csv"
            period = 1.0 / f
            rows.append(
                [
                    name,
                    str(c),
                    f"{f:g}",
                    f"{AMPLITUDE_M:g}",
                    "0",
                    f"{FS_HZ:g}",
                    "sine",
                    str(WARMUP_CYCLES),
                    str(MEASURED_CYCLES),
                    f"{t0 + WARMUP_CYCLES * period:.3f}",
                    f"{t0 + (WARMUP_CYCLES + MEASURED_CYCLES) * period:.3f}",
                    f"{plant.charge_written_pa:.6g}",
                ]
            )
            if write:
                _write_data(out / name, rec)
    truth.seconds = time.perf_counter() - wall
    if write:
        header = [
            "file",
            "clicks",
            "frequency_hz",
            "amplitude_m",
            "gas_clicks",
            "sample_rate_hz",
            "motion",
            "warmup_cycles",
            "measured_cycles",
            "measured_start_s",
            "measured_end_s",
            "gas_pressure_pa",
        ]
        lines = [",".join(header)] + [",".join(r) for r in rows]
        (out / "manifest.csv").write_text("\n".join(lines) + "\n")
        doc = _finite(asdict(truth))
        doc["physics"] = truth.physics()
        doc["cavitated"] = truth.cavitated
        (out / "truth.json").write_text(json.dumps(doc, indent=1) + "\n")
    return truth, records


def _finite(o: Any) -> Any:
    """JSON-safe copy: an infinite onset (no bump stop) becomes null."""
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [_finite(v) for v in o]
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return o


def _write_data(path: Path, rec: dict[str, np.ndarray]) -> None:
    cols = np.column_stack(
        [rec["time_s"], rec["displacement_m"], rec["force_N"], rec["temperature_C"]]
    )
    np.savetxt(
        path,
        cols,
        fmt=["%.3f", "%.6f", "%.2f", "%.2f"],
        delimiter=",",
        header="time_s,displacement_m,force_N,temperature_C",
        comments="",
    )
