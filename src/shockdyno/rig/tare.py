"""`rig tare`: the load cell's zero, measured with the drive disabled and the ram at rest.

Why disabled rather than held at centre: the zero of an unloaded load cell does not depend
on where the ram is, a holding servo adds its own dither to the reading, and a tare that
never enables the drive can be the first thing done on a new rig. The load cell must
carry nothing: a mounted damper pushes with its gas force, which is a force the sweep
measures, not an offset (unbolt the upper eye, or tare before mounting).

A load is told from a zero by its size: a zero error left after commissioning is a few
newtons, a mounted damper's gas force 100-2000 N. A reading
beyond `LOADED_MIN_N`, or `LOADED_SHARE` of the rig's force limit if more, is refused as a
load, with how to tare (unbolt the upper eye, or tare before mounting); an operator whose
load cell really is free and this far off zero says so with `--unloaded` (a tare taken
under a mounted damper would cancel its gas force from every later reading).

The zero goes where the DAQ's calibration already reads it, `[daq.calibration]
force_offset_n` (force = counts × force_n_per_count + force_offset_n): the new offset is
the old one minus the mean the load cell reads now.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from shockdyno.errors import ConfigError, RigFault
from shockdyno.rig.check import listen, open_links
from shockdyno.rig.config import RigConfig, parse_rig

AT_REST_SD_M = 1e-4  # LVDT sd beyond which the ram is not at rest (as rig check)
KEY = "force_offset_n"
LOADED_MIN_N = 25.0  # a reading beyond this (or LOADED_SHARE of the force limit) is a load
LOADED_SHARE = 0.005


@dataclass(frozen=True)
class Tare:
    """One tare reading with the drive disabled: the load cell's mean (N, with the rig file's
    calibration) and its sample-to-sample sd, the samples read, the offset the rig file has now,
    the ram's sd (m) over the reading, and the reading beyond which it is a load, not a zero."""

    mean_n: float  # what the load cell reads now, with the rig file's calibration
    sd_n: float  # sample-to-sample noise
    samples: int
    old_offset_n: float
    ram_sd_m: float
    loaded_above_n: float = math.inf  # a reading beyond this is a load, not a zero

    @property
    def loaded(self) -> bool:
        """Whether the reading is too large to be a zero error (a mounted damper or a hanging
        load)."""
        return abs(self.mean_n) > self.loaded_above_n

    def load_text(self) -> str:
        """Why a loaded reading is no zero, and how to tare."""
        pushed = (
            "pushing like a mounted damper's gas force (the rod pushed out against the load cell)"
            if self.mean_n > 0
            else "pulling on it: something hangs from or is clamped to the load cell"
        )
        return (
            f"the load cell reads {self.mean_n:+.1f} N with the drive disabled and the ram at "
            f"rest, over the {self.loaded_above_n:.0f} N a zero error can be: a load {pushed}. "
            "A tare needs the load cell free: unbolt the damper's upper eye (or tare before "
            "mounting it), run rig tare again, then mount the damper; if nothing is mounted "
            "and the zero really is this far off, run again with --unloaded"
        )

    @property
    def standard_error_n(self) -> float:
        """The uncertainty of the mean (white noise assumed)."""
        return self.sd_n / math.sqrt(max(1, self.samples))

    @property
    def new_offset_n(self) -> float:
        """The `force_offset_n` that reads the load cell's zero as 0 N: the old offset less the
        mean."""
        return self.old_offset_n - self.mean_n

    def line(self) -> str:
        """The rig file's line with the new offset (`force_offset_n = ...`, N)."""
        return f"{KEY} = {self.new_offset_n:.3f}"


def measure_tare(rig: RigConfig, seconds: float = 2.0) -> Tare:
    """Read the load cell for `seconds`; refused if the drive is enabled or the ram moves."""
    if not (math.isfinite(seconds) and seconds > 0):
        raise ConfigError(f"--seconds must be > 0, got {seconds:g}")
    act, daq = open_links(rig)
    try:
        st = act.status()
        if st.enabled or st.running:
            raise RigFault(
                "the drive is enabled or running: a tare needs it disabled and the ram at rest "
                "(nothing is written to the drive; disable it at its panel or stop the sweep)"
            )
        got = listen(daq, seconds)
    finally:
        act.close()
        daq.close()
    s = got.samples
    if len(s) < 10:
        raise RigFault(f"DAQ {rig.daq.url}: only {len(s)} valid frames in {seconds:g} s")
    ram_sd = float(np.std(s.displacement_m))
    if ram_sd > AT_REST_SD_M:
        raise RigFault(
            f"the ram moved during the tare (LVDT sd {ram_sd * 1e3:.3f} mm): not at rest"
        )
    return Tare(
        mean_n=float(np.mean(s.force_n)),
        sd_n=float(np.std(s.force_n)),
        samples=len(s),
        old_offset_n=rig.daq.calibration.force_offset_n,
        ram_sd_m=ram_sd,
        loaded_above_n=max(LOADED_MIN_N, LOADED_SHARE * rig.limits.force_n),
    )


_TABLE = re.compile(r"^\s*\[\s*([^\]]+?)\s*\]\s*(#.*)?$")
_KEY = re.compile(rf"^(\s*){KEY}\s*=\s*[^#\n]*?(\s*#.*)?$")


def with_offset(text: str, offset_n: float, source: str = "<rig>") -> str:
    """The rig file's text with `[daq.calibration] force_offset_n` set (comments kept): the
    key's line replaced, or added after the table's header."""
    lines = text.splitlines(keepends=True)
    table = ""
    header: int | None = None
    for i, raw in enumerate(lines):
        line = raw.rstrip("\n")
        m = _TABLE.match(line)
        if m:
            table = m.group(1)
            if table == "daq.calibration":
                header = i
            continue
        k = _KEY.match(line)
        if table == "daq.calibration" and k:
            comment = k.group(2) or ""
            lines[i] = f"{k.group(1)}{KEY} = {offset_n:.3f}{comment}\n"
            break
    else:
        if header is None:
            raise ConfigError(f"{source}: no [daq.calibration] table to put {KEY} in")
        lines.insert(header + 1, f"{KEY} = {offset_n:.3f}  # rig tare\n")
    out = "".join(lines)
    got = parse_rig(out, source).daq.calibration.force_offset_n  # the edit must read back
    if not math.isclose(got, round(offset_n, 3), abs_tol=1e-9):
        raise ConfigError(f"{source}: could not set daq.calibration.{KEY} (reads {got:g})")
    return out
