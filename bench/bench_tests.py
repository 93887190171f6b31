"""Benchmark `mlca-verify tests`: how long z3 takes to generate each shipped spec's MC/DC suite, and how long the
suite runs on the Cortex-M4 under QEMU, against the targets (under 5 s per spec, under 30 s on QEMU).

Run on demand: `.venv/bin/python bench/bench_tests.py [--repeat N]`. Each repeat generates every spec once in a
new interpreter (as the command does, so that the suite does not depend on what ran before) and once in this
one, interleaved; the median of each is printed with the spawn's share. The QEMU figure is the median wall time
of the emulator run alone (the build is not counted), beside the host run of the same program.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from mlca_verify.layout import Layout
from mlca_verify.spec import load_spec
from mlca_verify.testgen import DEPTH, target
from mlca_verify.testgen.command import generate_fresh, host_run, write_suite
from mlca_verify.testgen.suite import generate

ROOT = Path(__file__).resolve().parent.parent
SPECS = ["spec/mlca.toml", "spec/mlca_r.toml", "spec/mlca_t.toml"]
GENERATION_TARGET_S = 5.0
QEMU_TARGET_S = 30.0


def timed(function: object, *args: object) -> float:
    start = time.perf_counter()
    function(*args)  # type: ignore[operator]
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    head = f"{'spec':<18} {'fresh (s)':>10} {'in-process (s)':>15} {'target':>8}"
    print(f"{head}  {'QEMU (s)':>9} {'host build+run (s)':>19} {'target':>8}")
    for path in SPECS:
        spec = load_spec(ROOT / path)
        fresh, inside = [], []
        for _ in range(args.repeat):
            fresh.append(timed(generate_fresh, spec.machine, DEPTH))
            inside.append(timed(generate, spec.machine, DEPTH))
        emulated, host = qemu_times(spec, args.repeat)
        worst = statistics.median(fresh)
        print(
            f"{path:<18} {worst:>10.2f} {statistics.median(inside):>15.2f} "
            f"{'met' if worst < GENERATION_TARGET_S else 'MISSED':>8}  {emulated:>9.3f} {host:>19.3f} "
            f"{'met' if emulated < QEMU_TARGET_S else 'MISSED':>8}"
        )


def qemu_times(spec: object, repeat: int) -> tuple[float, float]:
    machine = spec.machine  # type: ignore[attr-defined]
    layout = Layout(ROOT / "generated", machine.name.lower())
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        files = write_suite(spec, generate(machine, DEPTH), folder, ROOT / "generated")  # type: ignore[arg-type]
        emulated, host = [], []
        for _ in range(repeat):
            start = time.perf_counter()
            _, lines = host_run(files["c"], layout.c_source, folder)
            host.append(time.perf_counter() - start)
            emulated.append(target.run_on_target(files["c"], layout.c_source, folder, lines).seconds)
    return statistics.median(emulated), statistics.median(host)


if __name__ == "__main__":
    main()
