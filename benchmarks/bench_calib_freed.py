"""A held spec value freed in the final refit, on sim-rig recordings that vary from run to
run (issue 44): test_calibration's held-value case, diagnosed by each checkout.

The sim rig runs in real time, so two sweeps with one seed are two recordings; made under
load (`--burn N`: N busy processes beside the rig while it sweeps, stopped after), the
held search of some of them took a bleed land beside a Coulomb friction held at 2x, and
the final refit left the friction there. Each recording (clicks 0 and 14, seed 31, speed
50, as the test's fixture) is diagnosed with a spec giving a third of the rig damper's
Coulomb friction and `candidates=("friction",)`, by each Python given (each venv runs its
own checkout's code), and the fitted and asked friction are printed as multiples of the
spec's. The recordings are kept in --work and reused.

    .venv/bin/python benchmarks/bench_calib_freed.py --python /work/main/.venv/bin/python \\
        --python .venv/bin/python --make 4 [--burn 3] [--work DIR]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
from diag_equal import child  # noqa: E402  (benchmarks/ is not a package)

SPEC = REPO / "sim" / "ohlins-s46.toml"
RIG_FRICTION_N = 35.0

# Run in the child: the test's diagnosis of one recording; friction's row and the land.
CHILD = """
import json, sys
from shockdyno.diagnose.engine import diagnose
from shockdyno.diagnose.settings import Settings
from shockdyno.diagnose.verdict import to_json
from shockdyno.record import open_recording
tests = open_recording(sys.argv[1]).load_all()
s = Settings(n_boot=199, candidates=("friction",))
d = to_json(diagnose(tests, settings=s, spec_path=sys.argv[2]))
rows = {r["parameter"]: r for r in d["verdict"]["calibration"]}
print(json.dumps({"fitted": rows["friction_n"]["fitted"], "asked": rows["friction_n"].get("asked"),
                  "land_m": rows.get("bleed_land_m", {}).get("fitted", 0.0),
                  "physics": d["verdict"]["physics"]}))
"""


def make(rec: Path, burn: int) -> None:
    """One sweep of the sim rig as the test's fixture makes it, with `burn` busy processes."""
    burners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(burn)]
    try:
        cmd = [
            sys.executable,
            "-m",
            "shockdyno.cli",
            "sweep",
            "--rig",
            str(REPO / "rigs" / "sim.toml"),
        ]
        cmd += ["--start-sim", "--speed", "50", "--clicks", "0,14", "-o", str(rec), "--seed", "31"]
        subprocess.run(cmd, check=True, capture_output=True, timeout=600, cwd=REPO)
    finally:
        for b in burners:
            b.kill()
            b.wait()


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--python", action="append", required=True, help="a checkout's Python")
    ap.add_argument("--make", type=int, default=0, help="recordings to make first")
    ap.add_argument("--burn", type=int, default=0, help="busy processes while recording")
    ap.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "calib_freed")
    args = ap.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    tag = f"burn{args.burn}"
    for _ in range(args.make):
        n = len(list(args.work.glob(f"{tag}-*.mcap")))
        make(args.work / f"{tag}-{n + 1}.mcap", args.burn)
    spec_n = RIG_FRICTION_N / 3
    spec = args.work / "friction-a-third.toml"
    text = "".join(
        f"friction_n = {spec_n!r}\n" if line.startswith("friction_n = ") else line
        for line in SPEC.read_text().splitlines(keepends=True)
    )
    spec.write_text(text)
    for rec in sorted(args.work.glob("*.mcap")):
        for py in args.python:
            r = child(py, CHILD, rec, str(spec))
            asked = r["asked"] / spec_n if r["asked"] is not None else float("nan")
            print(
                f"{rec.name:14s} {py:40s} friction {r['fitted'] / spec_n:.4f}x (asked "
                f"{asked:.4f}x)  land {1e3 * r['land_m']:.1f} mm  physics {r['physics']}",
                flush=True,
            )


if __name__ == "__main__":
    main()
