"""Benchmark the generated C step against hand-written references of the same machine (Alg. 1).

Run on demand: `.venv/bin/python bench/bench_codegen.py [--steps N]`. Prints, side by side in one run:
- instructions per step on x86-64 (gcc -O2), counted by `valgrind --tool=callgrind` inside the step function
  only, over the same fixed input sequence for every candidate (instruction counts are repeatable, unlike time);
- Cortex-M4 .text bytes of the step function (arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -Os);
and the ratio generated / best hand-written reference. Target: both ratios at most 1.0.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GENERATED = ROOT / "generated" / "c"
REFERENCE = ROOT / "bench" / "reference"
CANDIDATES = {
    "generated mlca_step": ("mlca_step", GENERATED / "mlca_fsm.c"),
    "hand-written, early returns": ("mlca_hand_return", REFERENCE / "mlca_hand.c"),
    "hand-written, single exit": ("mlca_hand_switch", REFERENCE / "mlca_hand.c"),
}


def sh(*args: str, cwd: Path | None = None) -> str:
    done = subprocess.run(args, cwd=cwd, capture_output=True, text=True, check=True)
    return done.stdout + done.stderr


def instructions(function: str, source: Path, steps: int, work: Path) -> tuple[float, str]:
    exe = work / f"drive_{function}"
    sh("gcc", "-std=c99", "-O2", f"-I{GENERATED}", f"-DSTEP_FN={function}", f"-DSTEPS={steps}u",
       "-o", str(exe), str(REFERENCE / "driver.c"), str(source))  # fmt: skip
    out_file = work / f"callgrind.{function}"
    log = sh(
        "valgrind", "--tool=callgrind", f"--callgrind-out-file={out_file}", f"--toggle-collect={function}", str(exe)
    )
    visits = sh(str(exe)).strip()
    total = int(re.search(r"Collected : (\d+)", log).group(1))  # type: ignore[union-attr]
    return total / steps, visits


def text_bytes(function: str, source: Path, work: Path) -> int:
    obj = work / f"{function}.arm.o"
    sh(
        "arm-none-eabi-gcc",
        "-std=c99",
        "-mcpu=cortex-m4",
        "-mthumb",
        "-Os",
        f"-I{GENERATED}",
        "-c",
        "-o",
        str(obj),
        str(source),
    )
    symbols = sh("arm-none-eabi-nm", "-S", str(obj))
    return int(re.search(rf"^[0-9a-f]+ ([0-9a-f]+) T {function}$", symbols, re.MULTILINE).group(1), 16)  # type: ignore[union-attr]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=1_000_000, help="steps of the fixed input sequence")
    args = parser.parse_args()
    rows = {}
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        for label, (function, source) in CANDIDATES.items():
            per_step, visits = instructions(function, source, args.steps, work)
            rows[label] = (per_step, text_bytes(function, source, work), visits)
    visits = {v[2] for v in rows.values()}
    assert len(visits) == 1, f"the candidates disagree on the trajectory: {rows}"
    print(f"{args.steps} steps, same trajectory for every candidate (state visits {visits.pop()})\n")
    print(f"{'candidate':30} {'instructions/step':>18} {'Cortex-M4 .text B':>18}")
    for label, (per_step, size, _) in rows.items():
        print(f"{label:30} {per_step:18.2f} {size:18d}")
    gen = rows["generated mlca_step"]
    best_ins = min(v[0] for k, v in rows.items() if k.startswith("hand"))
    best_text = min(v[1] for k, v in rows.items() if k.startswith("hand"))
    print(
        f"\nratio generated / best hand-written: instructions {gen[0] / best_ins:.3f}, .text {gen[1] / best_text:.3f}"
    )
    print("target: both at most 1.0")


if __name__ == "__main__":
    main()
