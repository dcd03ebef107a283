"""The ride study: the quarter car on ISO 8608 roads, clicks × roads × speeds at once.

Every run of the grid shares one time base: the record lasts `duration_s` = T after a
warm-up, at a fixed step dt. At speed v the road is a segment of length L = v T, so each
run sees exactly one period of its road (eq. 20-22 with L chosen per speed); the DFT of
the record then holds whole periods of every harmonic, which makes the RMS and the
Wk-weighted RMS free of leakage, and a linear car's response exactly checkable against
theory. Runs of one road class share the seed's phases: classes differ only in scale,
and the clicks of one road and speed see the very same road.

The RMS of the sprung-mass acceleration is eq. 24 over the record; the Wk-weighted RMS
is ISO 2631-1's; the PSD is Welch's (Hann window, 50 % overlap) up to `psd_max_hz`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from itertools import product

import numpy as np
from numpy.typing import NDArray

from shockdyno.errors import ConfigError
from shockdyno.fit.result import FitResult
from shockdyno.model.iso2631 import weighted_rms
from shockdyno.model.quarter_car import (
    LinearDamper,
    QuarterCar,
    SuspensionDamper,
    TabulatedDamper,
    Trajectory,
    simulate,
    stable_step,
)
from shockdyno.model.road import DEFAULT_BAND_RAD_M, RoadProfile, class_psd, synthesize_road
from shockdyno.report import documents as docs
from shockdyno.result_files import RecordingRef
from shockdyno.schema import to_json

FloatArray = NDArray[np.float64]

GRAVITY_M_S2 = 9.81
SCHEMA = "shockdyno.ride/1"
# Runs × steps held at once: four float64 records plus the road at half steps, ~0.5 GB.
MAX_SAMPLES = 8_000_000

# The paper's Table 7 (m/s²; its header's "%" is a slip): speed -> clicks -> roads A-E.
PAPER_TABLE7: dict[int, dict[int, tuple[float, ...]]] = {
    20: {
        5: (0.028, 0.049, 0.087, 0.165, 0.309),
        10: (0.031, 0.056, 0.099, 0.173, 0.327),
        15: (0.034, 0.061, 0.105, 0.181, 0.332),
    },
    60: {
        5: (0.036, 0.061, 0.112, 0.217, 0.400),
        10: (0.043, 0.069, 0.117, 0.220, 0.418),
        15: (0.046, 0.075, 0.124, 0.222, 0.424),
    },
    80: {
        5: (0.046, 0.079, 0.172, 0.328, 0.596),
        10: (0.049, 0.081, 0.176, 0.339, 0.638),
        15: (0.049, 0.091, 0.179, 0.341, 0.659),
    },
    120: {
        5: (0.048, 0.084, 0.157, 0.291, 0.542),
        10: (0.055, 0.091, 0.163, 0.308, 0.567),
        15: (0.061, 0.098, 0.169, 0.314, 0.581),
    },
}


def paper_rms(clicks: int | None, road: str, speed_kmh: float) -> float | None:
    """The paper's Table 7 value for this run, if it has one."""
    if clicks is None or road not in "ABCDE" or len(road) != 1:
        return None
    row = PAPER_TABLE7.get(round(speed_kmh), {}).get(clicks)
    if row is None or abs(speed_kmh - round(speed_kmh)) > 1e-9:
        return None
    return row["ABCDE".index(road)]


@dataclass(frozen=True)
class RideConfig:
    """The ride study's grid and settings: clicks, ISO 8608 road classes, speeds (km/h), the
    quarter car, duration and warm-up (s), time step (s), the road's band (rad/m) and waviness,
    the seed, a linear damper (N·s/m) in place of the fitted one, the proposed or Talbott model,
    the step check, the damper's travel (m) and the PSD's limits."""

    clicks: tuple[int, ...] = (5, 10, 15)
    roads: tuple[str, ...] = ("A", "B", "C", "D", "E")
    speeds_kmh: tuple[float, ...] = (20.0, 60.0, 80.0, 120.0)
    car: QuarterCar = field(default_factory=QuarterCar)
    duration_s: float = 60.0
    warmup_s: float = 5.0
    dt_s: float = 1e-3
    band_rad_m: tuple[float, float] = DEFAULT_BAND_RAD_M
    waviness: float = 2.0
    seed: int = 0
    linear_damper_ns_m: float | None = None
    model: str = "proposed"  # or "talbott": one fitted bleed area for both strokes
    step_check: bool = True
    # The damper's travel either side of static ride height: the spec does not give the
    # stroke, so runs beyond this are flagged, not stopped (no bump stops are modelled).
    travel_m: float = 0.05
    check_duration_s: float = 4.0
    psd_max_hz: float = 20.0
    psd_segment_s: float = 8.192

    @property
    def n_steps(self) -> int:
        """Time steps recorded per run (after the warm-up)."""
        return round(self.duration_s / self.dt_s)

    @property
    def n_warmup(self) -> int:
        """Time steps of warm-up per run (not recorded)."""
        return round(self.warmup_s / self.dt_s)

    def validate(self) -> None:
        """ConfigError naming the first setting out of range (road class, speed, step, duration,
        warm-up, waviness, linear rate, travel, model, PSD limit)."""
        self.car.validate()
        if not self.roads or not self.speeds_kmh or not self.clicks:
            raise ConfigError("the grid needs at least one road, one speed and one click setting")
        for r in self.roads:
            class_psd(r)
        for v in self.speeds_kmh:
            if not (math.isfinite(v) and 0 < v <= 400):
                raise ConfigError(f"speed must be in (0, 400] km/h, got {v:g}")
        if not (math.isfinite(self.dt_s) and 0 < self.dt_s <= 0.01):
            raise ConfigError(f"time step must be in (0, 10] ms, got {self.dt_s * 1e3:g} ms")
        if not (math.isfinite(self.duration_s) and self.duration_s >= 1.0):
            raise ConfigError(f"duration must be >= 1 s, got {self.duration_s:g} s")
        if self.duration_s / self.dt_s > 2e6:
            raise ConfigError("duration / time step exceeds 2 million steps")
        if abs(self.n_steps * self.dt_s - self.duration_s) > 1e-9 * self.duration_s:
            raise ConfigError("duration must be a whole number of time steps")
        if not (math.isfinite(self.warmup_s) and 0 <= self.warmup_s <= 600):
            raise ConfigError(f"warm-up must be in [0, 600] s, got {self.warmup_s:g} s")
        if not (math.isfinite(self.waviness) and 0 < self.waviness < 5):
            raise ConfigError(f"waviness must be in (0, 5), got {self.waviness:g}")
        if self.linear_damper_ns_m is not None and not (
            math.isfinite(self.linear_damper_ns_m) and self.linear_damper_ns_m >= 0
        ):
            raise ConfigError(f"linear damper rate must be >= 0, got {self.linear_damper_ns_m}")
        if not (math.isfinite(self.travel_m) and self.travel_m > 0):
            raise ConfigError(f"damper travel must be > 0, got {self.travel_m * 1e3:g} mm")
        if self.model not in ("proposed", "talbott"):
            raise ConfigError(f"model must be 'proposed' or 'talbott', got {self.model!r}")
        if not (0 < self.psd_max_hz < 0.5 / self.dt_s):
            raise ConfigError(f"PSD limit must be below Nyquist, got {self.psd_max_hz} Hz")


@dataclass(frozen=True)
class Run:
    """One run of the grid: clicks (None: the linear damper), road class and speed (km/h)."""

    clicks: int | None  # None for the linear damper
    road: str
    speed_kmh: float

    @property
    def speed_m_s(self) -> float:
        """The speed in m/s."""
        return self.speed_kmh / 3.6


@dataclass
class RideResult:
    """A ride study's results per run: the trajectory, the body's RMS vertical acceleration
    (m/s²), plain and ISO 2631-1 Wk-weighted, its PSD, the roads, the damper used, the step check
    and the stable RK4 step (s), and the fit it came from."""

    config: RideConfig
    runs: list[Run]
    trajectory: Trajectory
    rms_m_s2: FloatArray
    rms_wk_m_s2: FloatArray
    psd_hz: FloatArray
    psd_m2_s4_hz: FloatArray  # (n_runs, n_freq), Welch, up to psd_max_hz
    roads: dict[tuple[str, float], RoadProfile]
    damper_info: docs.Damper
    step_check: docs.StepCheck | None
    stable_step_s: float
    wall_time_s: float
    fit_path: str | None = None
    # The recording the fit came from (commands/ride.py), so a report can tell a ride of
    # another damper; None for a linear damper or an older fit.
    fit_recording: RecordingRef | None = None

    def run_index(self, clicks: int | None, road: str, speed_kmh: float) -> int:
        """The row of that run (ValueError when the grid has none)."""
        return self.runs.index(Run(clicks, road, float(speed_kmh)))

    def rms_of(self, clicks: int | None, road: str, speed_kmh: float) -> float:
        """The body's RMS vertical acceleration (m/s²) of that run."""
        return float(self.rms_m_s2[self.run_index(clicks, road, speed_kmh)])

    def rms_wk_of(self, clicks: int | None, road: str, speed_kmh: float) -> float:
        """The ISO 2631-1 Wk-weighted RMS of that run."""
        return float(self.rms_wk_m_s2[self.run_index(clicks, road, speed_kmh)])

    def tyre_leaves_road(self) -> NDArray[np.bool_]:
        """Per run: the linear tyre's force would pull (it carries more than the car's
        weight in tension, i.e. the wheel would lift off the road)."""
        car = self.config.car
        lift = (car.sprung_mass_kg + car.unsprung_mass_kg) * GRAVITY_M_S2
        return np.asarray(
            np.max(self.trajectory.tyre_deflection_m, axis=1) * car.tyre_n_m > lift, dtype=bool
        )

    def stroke_exceeds_travel(self) -> NDArray[np.bool_]:
        """Per run: the damper stroke goes beyond ±travel_m of static ride height."""
        peak = np.max(np.abs(self.trajectory.stroke_m), axis=1)
        return np.asarray(peak > self.config.travel_m, dtype=bool)

    def interpolated_clicks(self) -> list[int]:
        """Click settings whose bleed areas come from the fit's trend, not a fitted click."""
        return [s.clicks for s in self.damper_info.settings if s.source == "trend"]

    def flags(self) -> docs.Flags:
        """Runs outside the model's validity, for the console, the JSON and the report."""
        tyre, stroke = self.tyre_leaves_road(), self.stroke_exceeds_travel()

        def listed(mask: NDArray[np.bool_]) -> tuple[docs.FlaggedRun, ...]:
            return tuple(
                docs.FlaggedRun(clicks=r.clicks, road=r.road, speed_kmh=r.speed_kmh)
                for r, m in zip(self.runs, mask, strict=True)
                if m
            )

        return docs.Flags(
            travel_m=self.config.travel_m,
            tyre_leaves_road=listed(tyre),
            stroke_exceeds_travel=listed(stroke),
            interpolated_clicks=tuple(self.interpolated_clicks()),
        )

    def doc(self) -> docs.RideDoc:
        """RIDE.json, as its typed document (report/documents.py; docs/ride.md)."""
        cfg = self.config
        traj = self.trajectory
        tyre, stroke = self.tyre_leaves_road(), self.stroke_exceeds_travel()
        entries = []
        for i, run in enumerate(self.runs):
            road = self.roads[(run.road, run.speed_kmh)]
            entries.append(
                docs.RunRms(
                    clicks=run.clicks,
                    road=run.road,
                    speed_kmh=run.speed_kmh,
                    rms_ms2=float(self.rms_m_s2[i]),
                    rms_wk_ms2=float(self.rms_wk_m_s2[i]),
                    paper_rms_ms2=paper_rms(run.clicks, run.road, run.speed_kmh),
                    road_rms_m=road.rms_m(),
                    max_abs_stroke_m=float(np.max(np.abs(traj.stroke_m[i]))),
                    max_abs_stroke_velocity_m_s=float(np.max(np.abs(traj.stroke_velocity_m_s[i]))),
                    tyre_leaves_road=bool(tyre[i]),
                    stroke_exceeds_travel=bool(stroke[i]),
                )
            )
        road_lengths = []
        for v in sorted(set(cfg.speeds_kmh)):
            prof = self.roads[(cfg.roads[0], v)]
            omega = prof.omega_rad_m
            road_lengths.append(
                docs.RoadLength(
                    speed_kmh=v,
                    length_m=prof.length_m,
                    n_harmonics=int(prof.harmonic.size),
                    harmonic_spacing_rad_per_m=2 * math.pi / prof.length_m,
                    frequency_band_hz=(
                        float(omega[0]) * v / 3.6 / (2 * math.pi),
                        float(omega[-1]) * v / 3.6 / (2 * math.pi),
                    ),
                )
            )
        return docs.RideDoc(
            schema=SCHEMA,
            fit=self.fit_path,
            damper=self.damper_info,
            quarter_car=docs.Car(**asdict(cfg.car)),
            road_band_rad_per_m=(float(cfg.band_rad_m[0]), float(cfg.band_rad_m[1])),
            waviness=cfg.waviness,
            seed=cfg.seed,
            road_classes={r: class_psd(r) for r in cfg.roads},
            roads=tuple(road_lengths),
            dt_s=cfg.dt_s,
            duration_s=cfg.duration_s,
            warmup_s=cfg.warmup_s,
            integrator="classical Runge-Kutta (RK4), fixed step, all runs at once",
            stable_step_s=self.stable_step_s,
            step_check=self.step_check,
            psd=docs.Psd(
                method="Welch, Hann window, 50 % overlap",
                segment_s=min(cfg.psd_segment_s, cfg.duration_s),
                max_hz=cfg.psd_max_hz,
            ),
            rms=tuple(entries),
            flags=self.flags(),
            wall_time_s=self.wall_time_s,
            fit_recording=self.fit_recording,
        )

    def to_json(self) -> dict[str, object]:
        """The RIDE.json document (`doc()`), as JSON values."""
        out: dict[str, object] = to_json(self.doc())
        return out


def _build_damper(
    config: RideConfig, fit: FitResult | None, runs: list[Run]
) -> tuple[SuspensionDamper, float, docs.Damper, FloatArray]:
    """The damper of every run, its steepest slope, its description, start rates."""
    n = len(runs)
    if config.linear_damper_ns_m is not None:
        c = config.linear_damper_ns_m
        linear = docs.Damper(kind="linear", c_ns_m=c)
        return LinearDamper(np.full(n, c)), c, linear, np.full(n, max(c, 1.0))
    if fit is None:
        raise ConfigError("a fit result (--fit) is needed unless the damper is linear")
    model = fit.model()
    spec = model.spec
    settings = list(dict.fromkeys(config.clicks))
    areas = [fit.areas(c, config.model) for c in settings]
    for c, (a_bc, a_bt) in zip(settings, areas, strict=True):
        if not (a_bc >= 0 and a_bt >= 0 and math.isfinite(a_bc + a_bt)):
            raise ConfigError(f"the fit's bleed areas at {c} clicks are not usable: {a_bc}, {a_bt}")
    row = [settings.index(r.clicks) for r in runs if r.clicks is not None]
    table = TabulatedDamper(model, areas, row)
    # Start each run from the linear car whose rate is the damper's secant at ±0.1 m/s.
    v = np.array([-0.1, 0.1])
    secant = [
        float(np.diff(np.interp(v, table.v_grid, table.h_table[s]))[0] / 0.2)
        for s in range(len(settings))
    ]
    start = np.array([secant[i] for i in row])
    info = docs.Damper(
        kind=f"fitted damper model ({config.model})",
        spec=spec.name,
        spec_path=fit.spec_path,
        globals=fit.globals,
        terms=tuple(t.name for t in table.model.terms),
        terms_dropped=tuple(t.name for t in model.terms if not t.vehicle_ok()),
        settings=tuple(
            docs.ClickSetting(
                clicks=c,
                A_bc_m2=a,
                A_bt_m2=b,
                source=_source(fit, c),
                secant_rate_0p1_ns_m=s,
            )
            for c, (a, b), s in zip(settings, areas, secant, strict=True)
        ),
        force_at_rest_n=table.force_at_rest_n,
        moving_mass_kg=table.added_mass_kg,
        table=docs.DamperTable(
            stroke_range_m=(-table.x_max_m, table.x_max_m),
            velocity_range_m_s=(-table.v_max_m_s, table.v_max_m_s),
            max_error_n=table.max_error_n,
        ),
    )
    return table, table.max_slope_ns_m, info, start


def _source(fit: FitResult, clicks: int) -> str:
    """Where the areas of a click setting come from: the fit itself, or its trend."""
    for c in fit.clicks:
        if c.clicks == clicks:
            shaky = not (c.identifiable_bc and c.identifiable_bt)
            return "fit (flagged not identifiable)" if shaky else "fit"
    return "trend"


def _roads(config: RideConfig, duration_s: float) -> dict[tuple[str, float], RoadProfile]:
    return {
        (r, v): synthesize_road(
            class_psd(r), v / 3.6 * duration_s, config.band_rad_m, config.waviness, config.seed
        )
        for r, v in product(config.roads, config.speeds_kmh)
    }


def _integrate(
    config: RideConfig,
    damper: SuspensionDamper,
    runs: list[Run],
    start_c: FloatArray,
    dt_s: float,
    duration_s: float,
    warmup_s: float,
) -> tuple[Trajectory, dict[tuple[str, float], RoadProfile]]:
    roads = _roads(config, duration_s)
    n = round(duration_s / dt_s)
    samples = {key: prof.period_samples(2 * n) for key, prof in roads.items()}
    road = np.array([samples[(r.road, r.speed_kmh)] for r in runs])
    traj = simulate(config.car, damper, road, dt_s, round(warmup_s / dt_s), start_c)
    return traj, roads


def _step_check(
    config: RideConfig, damper: SuspensionDamper, runs: list[Run], start_c: FloatArray
) -> docs.StepCheck:
    """Repeat the extreme runs (smoothest road at the lowest speed, roughest at the
    highest, each click) over a shorter record at dt and dt / 2; compare their RMS.

    RK4's error falls 16-fold when the step halves, so the change is the error at dt to
    within about 7 %."""
    lo = (min(config.roads, key=class_psd), min(config.speeds_kmh))
    hi = (max(config.roads, key=class_psd), max(config.speeds_kmh))
    pick = [i for i, r in enumerate(runs) if (r.road, r.speed_kmh) in (lo, hi)]
    sub = [runs[i] for i in pick]
    sub_damper = _subset(damper, pick)
    duration = min(config.check_duration_s, config.duration_s)
    # Both steps start from the same state and see the same road, so a short warm-up
    # serves: the check compares the integrators, not the record with the study's.
    warmup = min(config.warmup_s, 1.0)
    rms: list[FloatArray] = []
    for dt in (config.dt_s, config.dt_s / 2):
        traj, _ = _integrate(config, sub_damper, sub, start_c[pick], dt, duration, warmup)
        rms.append(np.sqrt(np.mean(traj.sprung_accel_m_s2**2, axis=1)))
    change = np.abs(rms[1] / rms[0] - 1)
    return docs.StepCheck(
        dt_s=config.dt_s,
        half_dt_s=config.dt_s / 2,
        duration_s=duration,
        warmup_s=warmup,
        max_relative_change=float(np.max(change)),
        runs=tuple(
            docs.StepRun(
                clicks=r.clicks,
                road=r.road,
                speed_kmh=r.speed_kmh,
                rms_dt_ms2=float(a),
                rms_half_dt_ms2=float(b),
                relative_change=float(c),
            )
            for r, a, b, c in zip(sub, rms[0], rms[1], change, strict=True)
        ),
    )


def _subset(damper: SuspensionDamper, pick: list[int]) -> SuspensionDamper:
    if isinstance(damper, LinearDamper):
        return LinearDamper(damper.c_ns_m[pick], damper.added_mass_kg)
    if isinstance(damper, TabulatedDamper):
        return damper.for_runs(damper.run_table[pick])
    raise ConfigError("cannot take a subset of this damper")


def run_study(
    config: RideConfig,
    fit: FitResult | None = None,
    fit_path: str | None = None,
    progress: Callable[[str, float], None] | None = None,
) -> RideResult:
    """Simulate the whole grid and compute the RMS, Wk RMS and PSD of every run.

    `progress(stage, fraction)` hears of each stage; the runs integrate together (vectorised),
    so the bar moves by stage, not by run."""
    report = progress or (lambda stage, fraction: None)
    config.validate()
    config = _normalised(config)
    t0 = time.perf_counter()
    clicks: list[int | None] = (
        [None] if config.linear_damper_ns_m is not None else list(dict.fromkeys(config.clicks))
    )
    runs = [
        Run(c, r.strip().upper(), float(v))
        for c, r, v in product(clicks, config.roads, config.speeds_kmh)
    ]
    if len(runs) * config.n_steps > MAX_SAMPLES:
        raise ConfigError(
            f"{len(runs)} runs x {config.n_steps} steps exceeds the {MAX_SAMPLES:.0e} samples "
            "kept in memory: shorten --duration-s, lengthen --dt-ms or split the grid"
        )
    damper, slope, info, start_c = _build_damper(config, fit, runs)
    stable = stable_step(config.car, slope, damper.added_mass_kg)
    if config.dt_s > stable:
        raise ConfigError(
            f"time step {config.dt_s * 1e3:g} ms exceeds RK4's stability limit "
            f"{stable * 1e3:.3g} ms for this damper (steepest slope {slope:.3g} N·s/m)"
        )
    # The first report comes after every check, so bad input prints its one line alone
    report(f"integrate {len(runs)} runs x {config.n_steps} steps", 0.0)
    traj, roads = _integrate(
        config, damper, runs, start_c, config.dt_s, config.duration_s, config.warmup_s
    )
    if isinstance(damper, TabulatedDamper) and info.table is not None:
        outside = (np.max(np.abs(traj.stroke_m), axis=1) > damper.x_max_m) | (
            np.max(np.abs(traj.stroke_velocity_m_s), axis=1) > damper.v_max_m_s
        )
        info = replace(info, table=replace(info.table, runs_outside_table=int(np.sum(outside))))
    report("RMS, Wk RMS and spectra", 0.8)
    acc = traj.sprung_accel_m_s2
    rms = np.sqrt(np.mean(acc**2, axis=1))
    rms_wk = weighted_rms(acc, config.dt_s)
    nper = min(round(config.psd_segment_s / config.dt_s), acc.shape[1])
    # here: scipy.signal would add 840 ms CPU to every command's start-up (measured)
    from scipy.signal import welch

    f, p = welch(acc, fs=1 / config.dt_s, nperseg=nper, axis=1)
    keep = f <= config.psd_max_hz
    if config.step_check:
        report("step check at dt and dt/2", 0.85)
    check = _step_check(config, damper, runs, start_c) if config.step_check else None
    return RideResult(
        config=config,
        runs=runs,
        trajectory=traj,
        rms_m_s2=rms,
        rms_wk_m_s2=rms_wk,
        psd_hz=f[keep],
        psd_m2_s4_hz=p[:, keep],
        roads=roads,
        damper_info=info,
        step_check=check,
        stable_step_s=stable,
        wall_time_s=time.perf_counter() - t0,
        fit_path=fit_path,
    )


def _normalised(config: RideConfig) -> RideConfig:
    """Upper-case road letters, float speeds, no duplicates (order kept)."""
    return replace(
        config,
        clicks=tuple(dict.fromkeys(config.clicks)),
        roads=tuple(dict.fromkeys(r.strip().upper() for r in config.roads)),
        speeds_kmh=tuple(dict.fromkeys(float(v) for v in config.speeds_kmh)),
    )
