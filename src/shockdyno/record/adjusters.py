"""A sweep over several adjusters seen one adjuster at a time (docs/adjusters.md).

Each test of a damper with several adjusters carries every adjuster's clicks
(TestMeta.adjusters). The click chart, the loops, `compare` and the damper tables are
per click of one adjuster; an adjuster's *line* is the tests whose other adjusters sit at
the sweep's base, with `clicks` set to that adjuster's. The base is each adjuster's most
frequent setting (on a tie the middle of the tied ones, the lower middle of an even
count): the held value of a one-at-a-time sweep (run/plan.py's base: the middle of each
list), and the middle of a factorial sweep's lists.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace

from shockdyno.record.types import TestData, TestMeta


def names(settings: Iterable[Mapping[str, int]]) -> list[str]:
    """Every adjuster named, in the order first seen (the spec's, as the sweep wrote it)."""
    out: dict[str, None] = {}
    for s in settings:
        out.update(dict.fromkeys(s))
    return list(out)


def base(settings: Sequence[Mapping[str, int]]) -> dict[str, int]:
    """Each adjuster's most frequent clicks among these settings; on a tie the middle of
    the tied values (the lower middle of an even count)."""
    out: dict[str, int] = {}
    for name in names(settings):
        counts = Counter(s[name] for s in settings if name in s)
        top = max(counts.values())
        tied = sorted(v for v, n in counts.items() if n == top)
        out[name] = tied[(len(tied) - 1) // 2]
    return out


def on_line(setting: Mapping[str, int], name: str, at: Mapping[str, int]) -> bool:
    """The other adjusters at the base: this setting belongs to `name`'s line."""
    return name in setting and all(v == at.get(n) for n, v in setting.items() if n != name)


def held(name: str, at: Mapping[str, int]) -> str:
    """'rebound at 10' for the line of `name`: what the others were held at."""
    return ", ".join(f"{n} at {v}" for n, v in at.items() if n != name)


def line_meta(meta: TestMeta, name: str) -> TestMeta:
    """The test's metadata with `clicks` set to adjuster `name`'s clicks, as a line of that
    adjuster reads it."""
    return replace(meta, clicks=meta.adjusters[name])


def lines(tests: Sequence[TestData]) -> dict[str, list[TestData]]:
    """{adjuster: its line's tests with `clicks` the adjuster's}, {} for the one rod."""
    settings = [t.meta.adjusters for t in tests if t.meta.adjusters]
    at = base(settings)
    return {
        name: [
            replace(t, meta=line_meta(t.meta, name))
            for t in tests
            if on_line(t.meta.adjusters, name, at)
        ]
        for name in names(settings)
    }
