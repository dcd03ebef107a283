"""Where a structured residual lives, along the axes an engineer thinks in.

Works on the phase-locked means: each (test, phase bin) has a structured residual, a
mean displacement and velocity, and its test's frequency, click, order and temperature.
Energy is the mean square above the noise of the mean. Regions are cells of stroke ×
displacement third × speed band (near reversal, low, mid, high), ranked by the share of
the energy they hold; the axis summaries say how the energy splits by stroke,
frequency, click, test order and temperature.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from shockdyno.diagnose.cycles import N_BINS, BinnedTest
from shockdyno.diagnose.data import Data
from shockdyno.diagnose.settings import Settings
from shockdyno.report import documents as docs

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Region:
    stroke: str  # compression | rebound | both
    x_range_m: tuple[float, float]
    v_range_m_s: tuple[float, float]
    frequencies_hz: list[float]
    share: float
    rms_n: float
    near_reversal: bool = False

    def doc(self) -> docs.Region:
        """As DIAG.json holds it (mismatch.where[], verdict.unexplained[])."""
        return docs.Region(
            stroke=self.stroke,
            x_range_m=self.x_range_m,
            v_range_m_s=self.v_range_m_s,
            frequencies_hz=tuple(self.frequencies_hz),
            share=self.share,
            rms_n=self.rms_n,
            near_reversal=self.near_reversal,
        )


@dataclass(frozen=True)
class Location:
    regions: list[Region]
    axes: dict[str, dict[str, float]] = field(default_factory=dict)


def _bin_features(data: Data) -> dict[str, FloatArray]:
    x = data.bin_matrix(data.prob.inputs.x[:, None])[:, 0]
    v = data.bin_matrix(data.prob.inputs.v[:, None])[:, 0]
    metas = [p.data.meta for p in data.prepared]
    per_test = {
        "frequency": np.array([m.frequency_hz for m in metas], dtype=float),
        "click": np.array([m.clicks for m in metas], dtype=float),
        "order": np.array([m.index for m in metas], dtype=float),
    }
    temps = []
    for p in data.prepared:
        t = p.data.temperature
        ok = t is not None and np.any(np.isfinite(t))
        temps.append(float(np.nanmean(t)) if ok and t is not None else np.nan)
    per_test["temperature"] = np.array(temps)
    out = {"x": x, "v": v}
    for k, arr in per_test.items():
        out[k] = np.repeat(arr, N_BINS)
    return out


def _energy(binned: Sequence[BinnedTest]) -> FloatArray:
    means = np.concatenate([b.mean for b in binned])
    var = np.concatenate([b.mean_var for b in binned])
    return np.asarray(np.maximum(means**2 - var, 0.0), dtype=float)


def _shares(e: FloatArray, labels: FloatArray) -> dict[str, float]:
    total = float(np.sum(e))
    out: dict[str, float] = {}
    for lab in np.unique(labels[np.isfinite(labels)]):
        out[f"{lab:g}"] = float(np.sum(e[labels == lab]) / total) if total > 0 else 0.0
    return out


def locate(data: Data, binned: Sequence[BinnedTest], s: Settings | None = None) -> Location:
    s = s or Settings()
    e = _energy(binned)
    means = np.concatenate([b.mean for b in binned])
    feat = _bin_features(data)
    total = float(np.sum(e))
    if total <= 0:
        return Location([], {})
    x, v = feat["x"], feat["v"]
    vmax = float(np.max(np.abs(v))) or 1.0
    speed = np.abs(v) / vmax
    edges_v = [0.0, s.reversal_speed_share, 0.35, 0.7, 1.0001]
    xq = np.quantile(x, [0, 1 / 3, 2 / 3, 1])
    xq[-1] += 1e-9
    cells = []
    for stroke, sel in (("compression", v > 0), ("rebound", v <= 0)):
        for i in range(3):
            in_x = (x >= xq[i]) & (x < xq[i + 1])
            for j in range(4):
                in_v = (speed >= edges_v[j]) & (speed < edges_v[j + 1])
                m = sel & in_x & in_v
                if not np.any(m):
                    continue
                share = float(np.sum(e[m]) / total)
                freqs = _shares(e[m], feat["frequency"][m])
                cells.append(
                    Region(
                        stroke=stroke,
                        x_range_m=(float(np.min(x[m])), float(np.max(x[m]))),
                        v_range_m_s=(float(np.min(v[m])), float(np.max(v[m]))),
                        frequencies_hz=sorted(
                            float(f) for f, fs in freqs.items() if fs >= s.region_frequency_share
                        ),
                        share=share,
                        rms_n=float(np.sqrt(np.mean(means[m] ** 2))),
                        near_reversal=j == 0,
                    )
                )
    cells.sort(key=lambda r: -r.share)
    chosen: list[Region] = []
    acc = 0.0
    for r in cells:
        if len(chosen) >= s.max_regions or acc >= s.region_cover or r.share < s.region_min_share:
            break
        chosen.append(r)
        acc += r.share
    near = speed < s.reversal_speed_share
    axes = {
        "stroke": {
            "compression": float(np.sum(e[v > 0]) / total),
            "rebound": float(np.sum(e[v <= 0]) / total),
        },
        "speed": {
            "near_reversal": float(np.sum(e[near]) / total),
            "elsewhere": float(np.sum(e[~near]) / total),
        },
        "frequency_hz": _shares(e, feat["frequency"]),
        "clicks": _shares(e, feat["click"]),
    }
    order = feat["order"]
    half = np.median(order)
    if data.n_tests >= 4:
        axes["test_order"] = {
            "first_half": float(np.sum(e[order <= half]) / total),
            "second_half": float(np.sum(e[order > half]) / total),
        }
    temp = feat["temperature"]
    if np.sum(np.isfinite(temp)) > 1 and np.nanstd(temp) > s.temperature_spread_k:
        cold = temp <= np.nanmedian(temp)
        axes["temperature"] = {
            "cooler_half": float(np.sum(e[cold]) / total),
            "warmer_half": float(np.sum(e[~cold & np.isfinite(temp)]) / total),
        }
    return Location(chosen, axes)
