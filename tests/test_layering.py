"""No arrow runs up: every import in src/shockdyno (at module level or inside a function)
stays within the layers docs/architecture.md draws. The table below is that picture;
a change to the layering changes both."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "shockdyno"

# Small modules every layer may use; they use only each other.
UTILITY = {
    "errors",
    "units",
    "lists",
    "progress",
    "outputs",
    "result_files",
    "atomic",
    "schema",
    "priority",
    "samples",
    "figures",
}
# Package -> the project packages it may import (utilities aside). `commands` is the
# command-line glue (each subcommand's arguments, progress and files) and may use any;
# `cli` names the command modules as strings and imports none of them by name.
LAYERS: dict[str, set[str]] = {
    "model": set(),
    "rig": set(),
    "record": set(),
    "simrig": {"model", "rig", "record"},
    "fit": {"model", "record"},
    "report": {"model", "record", "fit"},
    "diagnose": {"model", "record", "fit", "report"},
    "ride": {"model", "record", "fit", "report"},
    "run": {"model", "rig", "record", "report"},
    "live": {"rig", "record"},
    "compare": {"record", "fit", "report"},
    "history": {"record", "fit", "report"},
    "batch": {"record", "fit", "report", "diagnose", "history"},
    "commands": {
        "model", "rig", "record", "simrig", "fit", "report", "diagnose", "ride", "run",
        "compare", "batch", "history", "live",
    },
    "cli": set(),
}  # fmt: skip


def _package(path: Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, first name under shockdyno) of every import of the project in a file."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "shockdyno":
                names = [f"shockdyno.{a.name}" for a in node.names]
            else:
                names = [node.module]
        for name in names:
            parts = name.split(".")
            if parts[0] == "shockdyno" and len(parts) > 1:
                found.append((node.lineno, parts[1]))
    return found


def violations() -> list[str]:
    bad = []
    for path in sorted(SRC.rglob("*.py")):
        pkg = _package(path)
        if pkg == "__init__":
            continue
        allowed = UTILITY if pkg in UTILITY else UTILITY | LAYERS[pkg]
        for line, target in imports(path):
            if target not in allowed | {pkg, "__version__"}:
                bad.append(f"{path.relative_to(SRC)}:{line}: {pkg} imports {target}")
    return bad


def test_every_package_has_a_place_in_the_layers() -> None:
    packages = {_package(p) for p in SRC.rglob("*.py")} - {"__init__"}
    assert packages <= UTILITY | set(LAYERS), packages - UTILITY - set(LAYERS)


def test_no_module_imports_a_layer_above_it() -> None:
    assert violations() == []


def test_the_walk_sees_an_import_inside_a_function(tmp_path: Path) -> None:
    # The check would pass vacuously if it missed function-level imports, which is
    # where an upward arrow hides.
    f = tmp_path / "m.py"
    f.write_text("def f():\n    from shockdyno.report.build import build_report\n")
    assert imports(f) == [(2, "report")]


@pytest.mark.parametrize("pkg", sorted(LAYERS))
def test_no_layer_reaches_itself_through_another(pkg: str) -> None:
    # The table is a partial order: no package may be reachable from itself.
    seen, todo = set(), list(LAYERS[pkg])
    while todo:
        p = todo.pop()
        if p not in seen:
            seen.add(p)
            todo += LAYERS.get(p, set())
    assert pkg not in seen
