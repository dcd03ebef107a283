"""The one list syntax of every command-line flag that takes several values.

Items are comma-separated; each item is a value or an inclusive range with an optional step:

    clicks       0-21:3   0,5,10   0-4,10,15-21:2     (integers)
    frequencies  0.5,1,1.5         0.5-2:0.5          (numbers; a range needs its step)
    roads        A-E      A,C,E                       (letters)

Values come back in the order written, duplicates dropped. Every mistake is a ConfigError naming
the flag and the item, one line, so the CLI prints it without a traceback.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from typing import TypeVar

from shockdyno.errors import ConfigError

T = TypeVar("T")

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_ITEM = re.compile(rf"^(?P<lo>{_NUM})(?:-(?P<hi>{_NUM})(?::(?P<step>{_NUM}))?)?$")
_LETTERS = re.compile(r"^(?P<lo>[A-Za-z])(?:-(?P<hi>[A-Za-z]))?$")
EXAMPLES = {int: "0-21:3 or 0,5,10", float: "0.5,1,1.5 or 0.5-2:0.5"}


def _items(text: str, what: str) -> list[str]:
    items = [s.strip() for s in text.split(",")]
    if not text.strip() or any(not s for s in items):
        raise ConfigError(f"{what}: empty item in {text!r}")
    return items


def _dedupe(values: list[T]) -> list[T]:
    return list(dict.fromkeys(values))


def parse_ints(text: str, what: str) -> list[int]:
    """'0-21:3' (every third), '0,5,10', or a mix such as '0-4,10,15-21:2'."""
    out: list[int] = []
    for item in _items(text, what):
        m = _ITEM.match(item)
        try:
            lo = int(m["lo"]) if m else None
            hi = int(m["hi"]) if m and m["hi"] else lo
            step = int(m["step"]) if m and m["step"] else 1
        except ValueError:
            lo = None  # a number with a decimal point where a whole number is needed
        if lo is None or hi is None:
            raise ConfigError(f"{what}: cannot read {item!r}: use e.g. {EXAMPLES[int]}")
        if step < 1 or lo > hi:
            raise ConfigError(f"{what}: range {item!r} needs LOW <= HIGH and a step >= 1")
        out.extend(range(lo, hi + 1, step))
    return _dedupe(out)


def parse_floats(text: str, what: str) -> list[float]:
    """'0.5,1,1.5' or '0.5-2:0.5' (a range of numbers needs its step)."""
    out: list[float] = []
    for item in _items(text, what):
        m = _ITEM.match(item)
        if not m:
            raise ConfigError(f"{what}: cannot read {item!r}: use e.g. {EXAMPLES[float]}")
        lo = float(m["lo"])
        if not m["hi"]:
            out.append(lo)
            continue
        if not m["step"]:
            raise ConfigError(f"{what}: range {item!r} needs a step, e.g. {item}:0.5")
        hi, step = float(m["hi"]), float(m["step"])
        if not step > 0 or lo > hi:
            raise ConfigError(f"{what}: range {item!r} needs LOW <= HIGH and a step > 0")
        n = math.floor((hi - lo) / step + 1e-9)
        if n > 10_000:
            raise ConfigError(f"{what}: range {item!r} has more than 10000 values")
        # Round away the binary drift of lo + k * step (0.1 + 0.2 ...) to the step's digits
        digits = max(0, -math.floor(math.log10(step))) + 6
        out.extend(round(lo + k * step, digits) for k in range(n + 1))
    if any(not math.isfinite(v) for v in out):
        raise ConfigError(f"{what}: values must be finite, got {text!r}")
    return _dedupe(out)


def parse_letters(text: str, what: str) -> list[str]:
    """'A-E' or 'A,C,E' (upper-cased)."""
    out: list[str] = []
    for item in _items(text, what):
        m = _LETTERS.match(item)
        if not m:
            raise ConfigError(f"{what}: cannot read {item!r}: use e.g. A-E or A,C,E")
        lo, hi = m["lo"].upper(), (m["hi"] or m["lo"]).upper()
        if lo > hi:
            raise ConfigError(f"{what}: range {item!r} needs FIRST <= LAST")
        out.extend(chr(c) for c in range(ord(lo), ord(hi) + 1))
    return _dedupe(out)


def in_range(values: list[T], what: str, ok: Callable[[T], bool], allowed: str) -> list[T]:
    """values, or a ConfigError naming the first value outside `allowed`."""
    for v in values:
        if not ok(v):
            raise ConfigError(f"{what}: {v} is outside {allowed}")
    return values


def parse_clicks(text: str, max_clicks: int = 21, what: str = "--clicks") -> list[int]:
    """Click settings 0..max_clicks, sorted (the sweep order)."""
    clicks = parse_ints(text, what)
    in_range(clicks, what, lambda c: 0 <= c <= max_clicks, f"0-{max_clicks}")
    return sorted(clicks)


def parse_frequencies(text: str, what: str = "--freq") -> list[float]:
    """Test frequencies in (0, 50] Hz, in the order given."""
    freqs = parse_floats(text, what)
    return in_range(freqs, what, lambda f: 0 < f <= 50, "(0, 50] Hz")


MAX_SEED = 2**32 - 1


def seed_arg(text: str) -> int:
    """argparse type of every --seed: a whole number 0..2³²-1 (NumPy's seeds)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a seed is a whole number, not {text!r}") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"a seed is from 0 to {MAX_SEED}, not {value}")
    return value
