"""Register values <-> 16-bit Modbus words, as the rig file's register map says. No I/O."""

from __future__ import annotations

import struct
from collections.abc import Iterable

from shockdyno.errors import ConfigError
from shockdyno.rig.config import Register, RegisterMap

_FMT = {"int32": ">i", "float32": ">f"}


def encode(reg: Register, value: float, word_order: str = "big") -> list[int]:
    """Engineering value (SI, or a count) -> the register's words."""
    if reg.type == "float32":
        raw = struct.pack(">f", value / reg.scale)
    else:
        counts = round(value / reg.scale)
        if reg.type == "uint16":
            if not 0 <= counts <= 0xFFFF:
                raise ConfigError(f"register {reg.name}: {value} does not fit a uint16")
            return [counts]
        if not -(2**31) <= counts < 2**31:
            raise ConfigError(f"register {reg.name}: {value} does not fit an int32")
        raw = struct.pack(">i", counts)
    hi, lo = struct.unpack(">HH", raw)
    return [hi, lo] if word_order == "big" else [lo, hi]


def decode(reg: Register, words: list[int], word_order: str = "big") -> float:
    """The register's words -> engineering value."""
    if reg.type == "uint16":
        return words[0] * reg.scale if reg.scale != 1.0 else words[0]
    hi, lo = (words[0], words[1]) if word_order == "big" else (words[1], words[0])
    value = struct.unpack(_FMT[reg.type], struct.pack(">HH", hi, lo))[0]
    return float(value) * reg.scale if reg.scale != 1.0 else value


def decode_span(
    rm: RegisterMap, start: int, words: list[int], names: Iterable[str]
) -> dict[str, float]:
    """Values of `names` from a block of words read from address `start`."""
    out: dict[str, float] = {}
    for name in names:
        reg = rm[name]
        off = reg.address - start
        out[name] = decode(reg, words[off : off + reg.width], rm.word_order)
    return out


def span_of(rm: RegisterMap, names: Iterable[str]) -> tuple[int, int]:
    """(first address, number of registers) of the smallest block covering the named registers."""
    regs = [rm[n] for n in names]
    lo = min(r.address for r in regs)
    hi = max(r.address + r.width for r in regs)
    return lo, hi - lo
