"""Recording sets: NAME.mcap, then NAME.part2.mcap, NAME.part3.mcap, ... from resumed sweeps."""

from __future__ import annotations

import re
from pathlib import Path


def _stem(path: Path) -> str | None:
    return path.name[: -len(".mcap")] if path.name.endswith(".mcap") else None


def part_paths(path: Path) -> list[Path]:
    """Existing part files (2, 3, ...) of the set whose first file is `path`, in order."""
    stem = _stem(path)
    if stem is None or not path.parent.is_dir():
        return []
    pattern = re.compile(re.escape(stem) + r"\.part(\d+)\.mcap")
    found = []
    for p in path.parent.iterdir():
        m = pattern.fullmatch(p.name)
        if m and int(m.group(1)) >= 2:
            found.append((int(m.group(1)), p))
    return [p for _, p in sorted(found)]


def set_paths(path: Path) -> list[Path]:
    """Every file of the set, first file first (the first file need not exist)."""
    return ([path] if path.exists() else []) + part_paths(path)


def next_part_path(path: Path) -> tuple[Path, int]:
    """Where a resumed sweep writes next, and its part number (1 is the first file)."""
    if not path.exists():
        return path, 1
    parts = part_paths(path)
    stem = _stem(path)
    if stem is None:
        stem = path.name
    last = 1
    if parts:
        m = re.search(r"\.part(\d+)\.mcap$", parts[-1].name)
        last = int(m.group(1)) if m else len(parts) + 1
    return path.with_name(f"{stem}.part{last + 1}.mcap"), last + 1
