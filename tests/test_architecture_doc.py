"""docs/modules.md (the module map docs/architecture.md points to) matches the code: its
module tree names every module under src/shockdyno in its own package's section, and
names no module that is not there.

The tree is the fenced block that starts with `src/shockdyno/`. A package's heading is a
line whose first word is `name/`; a module's line starts with `name.py` (or
`a.py, b.py`) one step deeper. Deeper lines continue the entry above them, so a `.py`
name anywhere in a package's lines counts for that package; `other/name.py` names a
file by its path from src/shockdyno, whatever the section.
"""

from __future__ import annotations

import re
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src" / "shockdyno"
DOC = REPO / "docs" / "modules.md"
NOT_MODULES = {"__init__.py", "__main__.py"}

_ENTRY = re.compile(r"^(?P<indent> *)(?P<word>\w+/|\w+\.py,?)(?:\s|$)")
_MENTION = re.compile(r"(?<![\w/.])((?:\w+/)*\w+\.py)\b")


@dataclass
class Tree:
    """What the doc's tree names: module paths (from src/shockdyno) with the doc's line
    numbers, and the package headings."""

    modules: dict[str, list[int]] = field(default_factory=lambda: defaultdict(list))
    packages: dict[str, int] = field(default_factory=dict)


def tree_lines(text: str) -> list[tuple[int, str]]:
    """(line number, line) of the fenced block that starts with `src/shockdyno/`."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.strip() == "src/shockdyno/" and i > 0 and lines[i - 1].startswith("```"):
            block = []
            for j in range(i + 1, len(lines)):
                if lines[j].startswith("```"):
                    return block
                block.append((j + 1, lines[j]))
    raise AssertionError(f"{DOC.name}: no ``` block starting with `src/shockdyno/` (the tree)")


def parse_tree(text: str) -> Tree:
    tree = Tree()
    stack: list[str] = []  # the package path of the section being read
    for number, line in tree_lines(text):
        entry = _ENTRY.match(line)
        if entry:
            level = (len(entry["indent"]) - 2) // 2
            if 0 <= level <= len(stack):  # deeper than that is a continuation line
                del stack[level:]
                if entry["word"].endswith("/"):
                    stack.append(entry["word"][:-1])
                    tree.packages.setdefault("/".join(stack), number)
        for name in _MENTION.findall(line):
            path = name if "/" in name else "/".join([*stack, name])
            tree.modules[path].append(number)
    return tree


def source_modules() -> list[str]:
    return sorted(
        p.relative_to(SRC).as_posix() for p in SRC.rglob("*.py") if p.name not in NOT_MODULES
    )


def missing(tree: Tree, modules: list[str]) -> list[str]:
    """Modules not named in their package's section, one line per package."""
    by_package: dict[str, list[str]] = defaultdict(list)
    for module in modules:
        if module not in tree.modules:
            package, _, name = module.rpartition("/")
            elsewhere = sorted(m for m in tree.modules if m.rpartition("/")[2] == name)
            hint = f" (named only as {', '.join(elsewhere)})" if elsewhere else ""
            by_package[package].append(name + hint)
    out = []
    for package, names in sorted(by_package.items()):
        where = f"{package}/" if package else "src/shockdyno/ (top level)"
        if package and package not in tree.packages:
            where += " [no section yet: add a heading line for it]"
        out.append(f"{where}: {', '.join(names)}")
    return out


def stale(tree: Tree) -> list[str]:
    """Names in the tree that are not files (and headings that are not packages)."""
    out = [
        f"line {lines[0]}: {module}"
        for module, lines in sorted(tree.modules.items())
        if not (SRC / module).is_file()
    ]
    out += [
        f"line {line}: {package}/ (no such package)"
        for package, line in sorted(tree.packages.items())
        if not (SRC / package).is_dir()
    ]
    return out


def test_every_module_is_named_in_its_package_section() -> None:
    tree, modules = parse_tree(DOC.read_text()), source_modules()
    gaps = missing(tree, modules)
    count = sum(m not in tree.modules for m in modules)
    assert not gaps, (
        f"{count} module(s) of src/shockdyno are not named in their package's section of "
        "docs/modules.md's tree; add a line `name.py   what it is for` (or a shared "
        "`a.py, b.py   ...`) under the package's heading:\n  " + "\n  ".join(gaps)
    )


def test_every_module_the_tree_names_exists() -> None:
    gone = stale(parse_tree(DOC.read_text()))
    assert not gone, (
        "docs/modules.md's tree names modules or packages that are not in "
        "src/shockdyno (renamed or removed: fix or delete the line):\n  " + "\n  ".join(gone)
    )


def test_every_path_the_document_names_exists() -> None:
    # Outside the tree too: the diagram, the term how-to and the file table name
    # `package/module.py` paths, from src/shockdyno, src/ or the repository.
    text = DOC.read_text()
    gone = sorted(
        {
            name
            for name in _MENTION.findall(text)
            if "/" in name and not any((base / name).is_file() for base in (SRC, SRC.parent, REPO))
        }
    )
    assert not gone, "docs/modules.md names files that do not exist:\n  " + "\n  ".join(gone)


SAMPLE = """\
```
src/shockdyno/
  errors.py   typed errors; cli.py is named on a continuation
  model/      physics
    spec.py         the spec, and model/extra.py by its path
    terms/          the term library: friction.py
    gas.py, flow.py   two at once, after a subpackage
  rig/        drivers, prose naming config.py and gas.py
```
"""


def test_the_parser_places_each_name_in_its_section() -> None:
    # The checks above pass vacuously if the parser put every name everywhere or nowhere.
    tree = parse_tree(SAMPLE)
    assert set(tree.modules) == {
        "errors.py",
        "cli.py",
        "model/spec.py",
        "model/extra.py",
        "model/terms/friction.py",
        "model/gas.py",
        "model/flow.py",
        "rig/config.py",
        "rig/gas.py",
    }
    assert set(tree.packages) == {"model", "model/terms", "rig"}
    assert tree.modules["rig/gas.py"] == [8]


def test_a_module_named_in_another_section_is_reported_missing() -> None:
    tree = parse_tree(SAMPLE)
    gaps = missing(tree, ["model/spec.py", "rig/spec.py", "live/cycles.py", "units.py"])
    assert gaps == [
        "src/shockdyno/ (top level): units.py",
        "live/ [no section yet: add a heading line for it]: cycles.py",
        "rig/: spec.py (named only as model/spec.py)",
    ]
