"""Benchmark a machine's generated step in binary32 on a Cortex-M4F's FPU against the same machine in binary64.

Run on demand: `.venv/bin/python bench/bench_formats.py [--write-docs]`. The corpus's motor limiter
(tests/machines/motor_limiter_1khz.toml, `reals = "binary32"`) is generated as it is and as a copy that says
`reals = "binary64"`. Each step is built as `conform`'s cortex-m4 check builds it (binary32 for the
single-precision FPU, binary64 in software) and linked from the step with --gc-sections against libgcc, so that
the compiler's soft-float helpers a binary64 step calls count in its `.text`, as they do in the firmware. It
prints, side by side from one run, each build's `.text` (the step and everything it calls), the helpers it
calls, and the ratio binary32 / binary64.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

from figures import write_block

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "tests" / "machines" / "motor_limiter_1khz.toml"
GUIDE = ROOT / "docs" / "guides" / "ecu.md"
COMMON = ("-std=c99", "-mcpu=cortex-m4", "-mthumb", "-Os", "-ffp-contract=off", "-ffunction-sections")
BUILDS = {
    "binary32": ("-mfpu=fpv4-sp-d16", "-mfloat-abi=hard"),
    "binary64": ("-mfloat-abi=soft",),
}


def sh(*argv: str) -> str:
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed:\n{done.stdout}{done.stderr}")
    return done.stdout


def measure(reals: str, work: Path) -> tuple[int, list[str]]:
    """The linked `.text` of the step built for `reals`, and the helpers its object calls."""
    spec = work / f"motor_{reals}.toml"
    text = SPEC.read_text(encoding="utf-8").replace('reals = "binary32"', f'reals = "{reals}"')
    spec.write_text(text, encoding="utf-8")
    out = work / reals
    sh(sys.executable, "-m", "mlca_verify", "gen", "--out", str(out), str(spec))
    source = next((out / "c").glob("*_fsm.c"))
    step = source.name.removesuffix("_fsm.c") + "_step"
    obj, elf = work / f"{reals}.o", work / f"{reals}.elf"
    sh("arm-none-eabi-gcc", *COMMON, *BUILDS[reals], "-c", "-o", str(obj), str(source))
    calls = sorted(set(sh("arm-none-eabi-nm", "-u", str(obj)).split()) - {"U"})
    sh("arm-none-eabi-gcc", *COMMON[1:3], *BUILDS[reals], "-nostdlib", "-Wl,--gc-sections", f"-Wl,-e,{step}",
       "-o", str(elf), str(obj), "-lgcc")  # fmt: skip
    size = sh("arm-none-eabi-size", str(elf)).splitlines()[-1].split()
    return int(size[0]), calls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/guides/ecu.md")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        rows = {reals: measure(reals, Path(folder)) for reals in BUILDS}
    single, double = rows["binary32"][0], rows["binary64"][0]
    print(f"{'format':10} {'build':36} {'.text B':>8}  helpers called")
    for reals, (size, calls) in rows.items():
        print(f"{reals:10} {' '.join(BUILDS[reals]):36} {size:8d}  {', '.join(calls) or 'none'}")
    print(f"binary32 / binary64: {single / double:.3f}")
    if args.write_docs:
        table = ["| format | build | `.text` of the step and its callees | helpers called |", "|---|---|---|---|"]
        for reals, (size, calls) in rows.items():
            called = ", ".join(f"`{c}`" for c in calls) or "none"
            table.append(f"| {reals} | `{' '.join(BUILDS[reals])}` | {size:,} B | {called} |")
        table += ["", f"binary32 / binary64: **{single / double:.3f}**"]
        write_block("formats", table, "bench/bench_formats.py --write-docs", GUIDE)


if __name__ == "__main__":
    main()
