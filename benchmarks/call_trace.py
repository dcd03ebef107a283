"""How far a reader walks following the calls of `diagnose_file`: modules entered and
comebacks (issue 48).

Runs `diagnose_file` on a recording under a profile hook that records, for every function
of shockdyno that runs, the functions it calls in the order they are first called. Then it
walks that call tree as a reader would: from `diagnose_file`, into each callee in turn
(each function read once, where it is first called) and back out. Printed: the modules the
walk visits, how many times it steps into another module (a call or a return that crosses
a module boundary), and how many of those steps come back to a module it had already
left. Fewer steps and comebacks: the search reads in fewer jumps.

    .venv/bin/python benchmarks/call_trace.py [REC.mcap] [--fit FIT.json] [--top 10]
        [--skip-imports]

The default recording is recordings/examples/example.mcap with the whole library.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import threading
from collections import Counter
from pathlib import Path
from types import FrameType
from typing import Any

REPO = Path(__file__).resolve().parents[1]
Key = tuple[str, str]  # (module, qualified function name)


def _key(frame: FrameType) -> Key | None:
    module = frame.f_globals.get("__name__", "")
    if not isinstance(module, str) or not module.startswith("shockdyno"):
        return None
    return module, frame.f_code.co_qualname


def trace_calls(run: Any, skip_imports: bool = False) -> tuple[Key, dict[Key, list[Key]]]:
    """(the root, each function's callees in first-call order) of shockdyno's calls made
    by `run()`, skipping frames outside the package (a callee reached through numpy or
    a thread pool is tied to the nearest shockdyno caller on the stack). `skip_imports`:
    leave out what runs while a module is imported (its body, and what that calls), so
    an import inside a function does not add the imported module's definitions to the
    walk."""
    callees: dict[Key, list[Key]] = {}
    seen: dict[Key, set[Key]] = {}
    root: list[Key] = []
    importing = [0]  # module bodies running (the profile hook is per thread: imports
    # inside the diagnosis run on the calling thread)

    def caller_of(frame: FrameType) -> Key | None:
        f = frame.f_back
        while f is not None:
            k = _key(f)
            if k is not None:
                return k
            f = f.f_back
        return None

    def hook(frame: FrameType, event: str, _arg: object) -> None:
        if skip_imports and frame.f_code.co_name == "<module>":
            importing[0] += {"call": 1, "return": -1}.get(event, 0)
            return
        if event != "call" or importing[0]:
            return
        k = _key(frame)
        if k is None:
            return
        parent = caller_of(frame)
        if parent is None:
            if not root:
                root.append(k)
            return
        if k not in seen.setdefault(parent, set()):
            seen[parent].add(k)
            callees.setdefault(parent, []).append(k)

    sys.setprofile(hook)
    threading.setprofile(hook)
    try:
        run()
    finally:
        sys.setprofile(None)
        threading.setprofile(None)  # type: ignore[arg-type]
    return root[0], callees


def walk(root: Key, callees: dict[Key, list[Key]]) -> list[str]:
    """The modules a reader is in, step by step, reading each function once."""
    out: list[str] = []
    read: set[Key] = set()

    def visit(k: Key) -> None:
        read.add(k)
        out.append(k[0])
        for c in callees.get(k, []):
            if c not in read:
                visit(c)
                out.append(k[0])  # back in the caller

    sys.setrecursionlimit(20000)
    visit(root)
    return out


def count(steps: list[str]) -> tuple[int, int, Counter[str]]:
    """(steps into another module, comebacks to a module left before, comebacks by module)."""
    crossings = comebacks = 0
    left: set[str] = set()
    by_module: Counter[str] = Counter()
    for prev, cur in itertools.pairwise(steps):
        if prev == cur:
            continue
        crossings += 1
        left.add(prev)
        if cur in left:
            comebacks += 1
            by_module[cur] += 1
    return crossings, comebacks, by_module


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "recording", nargs="?", type=Path, default=REPO / "recordings" / "examples" / "example.mcap"
    )
    ap.add_argument("--fit", default=None, help="FIT.json to start from (diagnose --fit)")
    ap.add_argument("--top", type=int, default=10, help="modules listed by comebacks")
    ap.add_argument(
        "--skip-imports",
        action="store_true",
        help="leave out module bodies run by imports inside functions (and what they call)",
    )
    args = ap.parse_args(argv)

    from shockdyno.diagnose.file import diagnose_file

    root, callees = trace_calls(
        lambda: diagnose_file(args.recording, fit_path=args.fit), args.skip_imports
    )
    steps = walk(root, callees)
    crossings, comebacks, by_module = count(steps)
    functions = {k for k in callees} | {c for cs in callees.values() for c in cs}
    print(
        f"diagnose_file({args.recording.name}{', --fit' if args.fit else ''}): "
        f"{len(functions)} functions in {len(set(steps))} modules; the reader's walk steps "
        f"into another module {crossings} times and comes back to one it had left "
        f"{comebacks} times" + (" (imports left out)" if args.skip_imports else "")
    )
    for module, n in by_module.most_common(args.top):
        print(f"  {n:4d} comebacks to {module}")


if __name__ == "__main__":
    main()
