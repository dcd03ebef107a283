"""The model's forces a report draws, saved by `fit` beside FIT.json (docs/fit.md).

A report shows the fitted model in three places: the click chart (the model at
mid-stroke and zero acceleration at the standard velocities, SI or imperial, with each
click's areas and at rest), the fit's overlays of measured, proposed and Talbott on a few
tests, and for a thermal fit the temperature-corrected chart (the model at each setting's
oil temperature and at the reference). `fit` computes them once, with the model it
fitted, and writes them to `NAME.forces.npz` beside `NAME.json` (`sidecar_path`); the
report reads them instead of evaluating the model again on the recording.

The file is a NumPy .npz (read with `allow_pickle=False`): the SHA-256 of the FIT.json
text it belongs to, the characteristic (`char_areas` (N, 2) by `char_v_<set>` and
`char_f_<set>` (N, V) per velocity set), the corrected chart's (`thermal_keys` (M, 3):
areas and °C, `thermal_f_<set>` (M, 1 + V): at rest, then the velocities) and each saved
test's `proposed_<index>` and `talbott_<index>` on its measured cycles at the full rate.
A file from another FIT.json (the fit written again, the sidecar left) is stale: not
used, and said in one line.

A value the file does not hold (a report of another recording, another reference
temperature) is computed from the fit as before, and counted
(`SavedForces.computed`) so the caller can say so.
"""

from __future__ import annotations

import hashlib
import io
import os
import zipfile
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from shockdyno.atomic import write_bytes_atomic
from shockdyno.errors import ConfigError, FitError
from shockdyno.model.composite import ModelInputs
from shockdyno.model.quarter_car import quasi_static_force
from shockdyno.record import adjusters
from shockdyno.record.types import TestData, TestMeta
from shockdyno.units import IMPERIAL, SI, signed_velocities

if TYPE_CHECKING:  # result.py holds a SavedForces: no import cycle at run time
    from shockdyno.fit.result import FitResult

FloatArray = NDArray[np.float64]

FORMAT = "shockdyno model forces 1"
SUFFIX = ".forces.npz"
MAX_BYTES = 256 << 20  # a few representative tests and a table: far below this
# The temperature-corrected chart's default reference (report/temperature.py's
# DEFAULT_REFERENCE_C, which is this): another --reference-temperature-c is computed.
REFERENCE_C = 40.0


# The velocity sets a report evaluates the characteristic at, exactly as it passes them
# (a vectorised solve is not promised to give a point the same bits in another batch).
VELOCITY_SETS: dict[str, tuple[float, ...]] = {
    "si": signed_velocities(SI.standard_velocities_m_s),
    "imperial": signed_velocities(IMPERIAL.standard_velocities_m_s),
    "rest": (0.0,),
}


@dataclass(frozen=True)
class TestForces:
    """Both models' forces on one test's measured cycles, at the full rate."""

    __test__ = False  # not a pytest class

    index: int
    proposed: FloatArray
    talbott: FloatArray


@dataclass
class SavedForces:
    """What `fit` saved for the report; `computed` counts the values asked of it that it
    did not hold (the caller computed those from the fit)."""

    fit_sha256: str
    areas_m2: FloatArray  # (N, 2): A_bc, A_bt of each characteristic row
    characteristic: dict[str, FloatArray]  # velocity set -> (N, V) forces, N
    tests: dict[int, TestForces]
    # The temperature-corrected chart's (thermal fits): (N, 3) A_bc, A_bt, oil °C, and per
    # velocity set the (N, 1 + V) forces at rest and at the velocities, at that temperature.
    thermal_keys: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    thermal: dict[str, FloatArray] = field(default_factory=dict)
    computed: list[str] = field(default_factory=list)

    def at(self, a_bc: float, a_bt: float, velocities: Sequence[float]) -> FloatArray | None:
        """The characteristic at these areas and velocities, or None (counted)."""
        wanted = tuple(float(v) for v in velocities)
        name = next((k for k, vs in VELOCITY_SETS.items() if vs == wanted), None)
        rows = np.flatnonzero((self.areas_m2[:, 0] == a_bc) & (self.areas_m2[:, 1] == a_bt))
        if name is None or not rows.size or name not in self.characteristic:
            self.computed.append(f"the characteristic at A_bc {a_bc:.6g}, A_bt {a_bt:.6g} m²")
            return None
        return np.array(self.characteristic[name][rows[0]], dtype=float)

    def at_temperature(
        self, a_bc: float, a_bt: float, temperature_c: float, velocities: Sequence[float]
    ) -> FloatArray | None:
        """The forces at rest and at `velocities` with the oil at `temperature_c`, or None
        (counted): `report/temperature.py`'s `model_forces_at`."""
        wanted = tuple(float(v) for v in velocities)
        name = next((k for k, vs in VELOCITY_SETS.items() if vs == wanted), None)
        k = self.thermal_keys
        rows = np.flatnonzero((k[:, 0] == a_bc) & (k[:, 1] == a_bt) & (k[:, 2] == temperature_c))
        if name is None or not rows.size or name not in self.thermal:
            self.computed.append(f"the model at {temperature_c:.4g} °C")
            return None
        return np.array(self.thermal[name][rows[0]], dtype=float)

    def test(self, index: int, n_samples: int) -> TestForces | None:
        """Test `index`'s forces when saved for a test of `n_samples` samples, or None."""
        saved = self.tests.get(index)
        if saved is None or saved.proposed.size != n_samples:
            self.computed.append(f"test {index}'s forces")
            return None
        return saved


def sidecar_path(fit_json: str | os.PathLike[str]) -> Path:
    """`NAME.json` -> `NAME.forces.npz` (any other name: the suffix added)."""
    p = Path(fit_json)
    stem = p.name[: -len(".json")] if p.name.lower().endswith(".json") else p.name
    return p.with_name(stem + SUFFIX)


def text_sha256(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def representative(metas: Sequence[TestMeta]) -> list[TestMeta]:
    """Like the paper: lowest frequency near 5 clicks, middle near 10, highest near 15."""
    freqs = sorted({round(m.frequency_hz, 3) for m in metas})
    if not freqs:
        return []
    picks: list[TestMeta] = []
    chosen_freqs = [freqs[0], freqs[len(freqs) // 2], freqs[-1]]
    for target, freq in zip([5, 10, 15], chosen_freqs, strict=True):
        pool = [m for m in metas if round(m.frequency_hz, 3) == freq]
        best = min(pool, key=lambda m: abs(m.clicks - target))
        if all(best is not p for p in picks):
            picks.append(best)
    return picks


def overlay_picks(result: FitResult, metas: Sequence[TestMeta]) -> set[int]:
    """The tests (by index) the report's overlays show of a fit and of each adjuster's
    line (`fit_figures`), among the tests the fit validated."""
    views: list[tuple[FitResult, list[TestMeta]]] = [(result, list(metas))]
    settings = [m.adjusters for m in metas if m.adjusters]
    at = adjusters.base(settings)
    for name in adjusters.names(settings):
        line = [
            adjusters.line_meta(m, name) for m in metas if adjusters.on_line(m.adjusters, name, at)
        ]
        views.append((result.for_adjuster(name), line))
    picks: set[int] = set()
    for view, line in views:
        keys = {(c.clicks, c.gas_clicks, c.setting) for c in view.clicks}
        usable = [m for m in line if (m.clicks, m.gas_clicks, m.setting) in keys]
        picks |= {m.index for m in representative(usable)}
    return picks


def characteristic_areas(result: FitResult) -> list[tuple[float, float]]:
    """Every (A_bc, A_bt) the click chart asks of the model: each fitted setting's, and
    each click of the fitted range at the main gas setting (the trend's), of the fit and
    of each adjuster's line (report/clickchart.py `click_chart`)."""
    views = [result, *(result.for_adjuster(n) for n in result.adjuster_names())]
    out: list[tuple[float, float]] = []
    for view in views:
        if not view.clicks:
            continue
        for c in view.clicks:
            out.append(view.areas(c.clicks, gas_clicks=c.gas_clicks))
        main_gas = view.main_gas_clicks()
        fitted = sorted({c.clicks for c in view.clicks if c.gas_clicks == main_gas})
        for n in range(fitted[0], fitted[-1] + 1):
            try:
                out.append(view.areas(n))
            except FitError:  # no trend to interpolate between fitted clicks
                continue
    return list(dict.fromkeys(out))


def setting_temperatures(tests: Sequence[TestData]) -> dict[tuple[int, int], float]:
    """Mean temperature over the measured cycles of each (clicks, gas clicks) setting's
    complete tests (each test weighted alike, as the click chart averages them); settings
    without a reading are left out. The temperature-corrected chart's (report/temperature.py)."""
    per: dict[tuple[int, int], list[float]] = {}
    for test in tests:
        if test.meta.status != "complete":
            continue
        temp = test.measured().temperature
        if temp is None or not np.any(np.isfinite(temp)):
            continue
        key = (test.meta.clicks, test.meta.gas_clicks)
        per.setdefault(key, []).append(float(np.nanmean(temp)))
    return {k: float(np.mean(v)) for k, v in per.items()}


def thermal_points(result: FitResult, tests: Sequence[TestData]) -> list[tuple[float, ...]]:
    """Every (A_bc, A_bt, oil °C) the temperature-corrected chart asks of a thermal fit
    at the default reference temperature: each setting's mean temperature over the
    recording's complete tests and REFERENCE_C, of the fit and of each adjuster's line."""
    if "thermal" not in {t.name for t in result.model().vehicle().terms}:
        return []
    complete = [t for t in tests if t.meta.status == "complete"]
    views = [(result, complete)]
    views += [(result.for_adjuster(n), line) for n, line in adjusters.lines(complete).items()]
    out: list[tuple[float, ...]] = []
    for view, line in views:
        for (clicks, gas), temp in setting_temperatures(line).items():
            try:
                a_bc, a_bt = view.areas(clicks, gas_clicks=gas)
            except FitError:
                continue
            out += [(a_bc, a_bt, temp), (a_bc, a_bt, REFERENCE_C)]
    return list(dict.fromkeys(out))


def build(
    result: FitResult, tests: Sequence[TestForces], recorded: Sequence[TestData] = ()
) -> SavedForces:
    """What the report needs of a fit: the characteristic at every area pair the click
    chart asks for, `tests` (the overlays' tests) and, for a thermal fit, the corrected
    chart's model values at the temperatures of the `recorded` tests; not yet bound to a
    FIT.json."""
    car = result.model().vehicle()
    pairs = characteristic_areas(result)
    table: dict[str, FloatArray] = {}
    for name, vs in VELOCITY_SETS.items():
        v = np.asarray(vs, dtype=float)
        zeros = np.zeros_like(v)
        rows = [quasi_static_force(car, zeros, v, zeros, a_bc, a_bt) for a_bc, a_bt in pairs]
        table[name] = np.array(rows, dtype=float).reshape(len(pairs), v.size)
    areas = np.array(pairs, dtype=float).reshape(len(pairs), 2)
    points = thermal_points(result, recorded)
    thermal: dict[str, FloatArray] = {}
    for name, vs in VELOCITY_SETS.items():
        if name == "rest" or not points:
            continue
        v = np.concatenate([[0.0], np.asarray(vs, dtype=float)])
        zeros = np.zeros(v.size)
        thermal[name] = np.array(
            [
                car.force(ModelInputs.points(zeros, v, zeros, np.full(v.size, t)), a_bc, a_bt)
                for a_bc, a_bt, t in points
            ],
            dtype=float,
        ).reshape(len(points), v.size)
    keys = np.array(points, dtype=float).reshape(len(points), 3)
    return SavedForces("", areas, table, {t.index: t for t in tests}, keys, thermal)


def to_bytes(saved: SavedForces, fit_text: str) -> bytes:
    """The .npz of `saved`, bound to the FIT.json whose text is `fit_text`."""
    arrays: dict[str, NDArray[np.generic]] = {
        "format": np.array(FORMAT),
        "fit_sha256": np.array(text_sha256(fit_text)),
        "char_areas": saved.areas_m2,
    }
    for name, forces in saved.characteristic.items():
        arrays[f"char_v_{name}"] = np.asarray(VELOCITY_SETS[name], dtype=float)
        arrays[f"char_f_{name}"] = forces
    arrays["thermal_keys"] = saved.thermal_keys
    for name, forces in saved.thermal.items():
        arrays[f"thermal_f_{name}"] = forces
    arrays["test_index"] = np.array(sorted(saved.tests), dtype=np.int64)
    for i, t in sorted(saved.tests.items()):
        arrays[f"proposed_{i}"] = t.proposed
        arrays[f"talbott_{i}"] = t.talbott
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]
    return buf.getvalue()


def write(path: Path, saved: SavedForces, fit_text: str) -> None:
    """Write the sidecar whole or not at all (the caller checked --force and inputs)."""
    try:
        write_bytes_atomic(path, to_bytes(saved, fit_text))
    except OSError as exc:
        raise ConfigError(f"cannot write {path} ({exc.strerror})") from None


def _check_shapes(
    areas: FloatArray,
    table: dict[str, FloatArray],
    tests: dict[int, TestForces],
    keys: FloatArray,
    thermal: dict[str, FloatArray],
) -> None:
    """A file whose arrays do not fit together (written by something else, or damaged
    in a way its checksums missed) is not readable: a report would index past them."""
    for name, forces in table.items():
        if forces.shape != (len(areas), len(VELOCITY_SETS[name])):
            raise ValueError(f"char_f_{name} is {forces.shape}, not {len(areas)} rows")
    for name, forces in thermal.items():
        if forces.shape != (len(keys), 1 + len(VELOCITY_SETS[name])):
            raise ValueError(f"thermal_f_{name} is {forces.shape}, not {len(keys)} rows")
    for t in tests.values():
        if t.proposed.ndim != 1 or t.proposed.shape != t.talbott.shape:
            raise ValueError(f"test {t.index}'s forces differ in length")


def read(fit_json: str | os.PathLike[str]) -> tuple[SavedForces | None, str]:
    """The sidecar of the FIT.json at `fit_json`, or None with one line saying why (a
    fit from before `fit` saved it, a stale or damaged file): the caller computes."""
    path = sidecar_path(fit_json)
    fallback = "; the model's forces are computed from the fit instead"
    if not path.is_file():
        return (
            None,
            f"{path.name} not found beside {Path(fit_json).name} (a fit written before "
            f"fit saved it, or with --json -){fallback}",
        )
    try:
        text = Path(fit_json).read_text(encoding="utf-8")
        if path.stat().st_size > MAX_BYTES:
            raise ValueError("too large")
        if not zipfile.is_zipfile(path):  # np.load would try it as a pickle, and say so
            raise ValueError("not a .npz file")
        with np.load(path, allow_pickle=False) as z:
            if str(z["format"]) != FORMAT:
                raise ValueError(f"format {str(z['format'])!r}")
            if str(z["fit_sha256"]) != text_sha256(text):
                return None, (
                    f"{path.name} belongs to another version of {Path(fit_json).name} "
                    f"(stale: the JSON was edited, or written again without it){fallback}"
                )
            names = [k[len("char_f_") :] for k in z.files if k.startswith("char_f_")]
            table = {n: np.asarray(z[f"char_f_{n}"], dtype=float) for n in names}
            for n in names:
                if n not in VELOCITY_SETS or not np.array_equal(
                    z[f"char_v_{n}"], np.asarray(VELOCITY_SETS[n], dtype=float)
                ):
                    table.pop(n)  # velocities this version does not ask for
            tests = {
                int(i): TestForces(
                    int(i),
                    np.asarray(z[f"proposed_{int(i)}"], dtype=float),
                    np.asarray(z[f"talbott_{int(i)}"], dtype=float),
                )
                for i in z["test_index"]
            }
            areas = np.asarray(z["char_areas"], dtype=float).reshape(-1, 2)
            keys = np.asarray(z["thermal_keys"], dtype=float).reshape(-1, 3)
            thermal = {
                k[len("thermal_f_") :]: np.asarray(z[k], dtype=float)
                for k in z.files
                if k.startswith("thermal_f_") and k[len("thermal_f_") :] in VELOCITY_SETS
            }
            _check_shapes(areas, table, tests, keys, thermal)
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, zlib.error, EOFError) as exc:
        return None, f"{path.name} is not readable ({exc}){fallback}"
    return SavedForces(text_sha256(text), areas, table, tests, keys, thermal), ""


def attach(
    fit: FitResult, fit_json: str | os.PathLike[str], recording_sha256: str | None = None
) -> str:
    """Give `fit` (loaded from `fit_json`) its saved forces; "" or the one line saying
    why there are none and what is done instead. `recording_sha256`: the recording the
    page draws. The saved tests' forces are the model on the fit's recording's measured
    motion, so for another recording (--allow-other-recording) they are left out and
    computed on its own (counted: `computed_note`); the characteristic holds for any."""
    fit.saved, note = read(fit_json)
    if (
        fit.saved is not None
        and recording_sha256 is not None
        and fit.info.recording_sha256 != recording_sha256
    ):
        fit.saved.tests = {}
    return note


def computed_note(fit: FitResult, fit_json: str | os.PathLike[str]) -> str:
    """One line for the values a report asked of `fit.saved` that it did not hold ("")."""
    missed = list(dict.fromkeys(fit.saved.computed)) if fit.saved is not None else []
    if not missed:
        return ""
    more = f" and {len(missed) - 1} more" if len(missed) > 1 else ""
    return (
        f"{sidecar_path(fit_json).name} does not hold {missed[0]}{more} (another "
        "--reference-temperature-c, a report of another recording): computed from the fit"
    )
