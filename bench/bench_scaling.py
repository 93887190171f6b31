"""Benchmark many transitions out of one state: `check` and codegen's IR at 250, 500, 1,000 and 2,000 transitions.

Run on demand: `.venv/bin/python bench/bench_scaling.py`. Two machines per size: guards `x and y{k % 5}` (five
fire, the rest are shadowed) and pairwise disjoint cubes over 12 inputs (every one fires). Prints wall times,
solver queries, and the growth factor from the previous size (about 2 when the work is linear)."""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import z3

from mlca_verify.codegen import machine_ir
from mlca_verify.logic import check_all
from mlca_verify.logic.solver import Answer, Solver
from mlca_verify.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench.wide import wide_spec  # noqa: E402

SIZES = (250, 500, 1000, 2000)
QUERIES = [0]
STYLES = (("shadowed", 5), ("cubes", 11))


def measure(spec: Path, out: Path) -> tuple[float, float, int]:
    """Seconds for check, seconds for the IR, and solver queries for both."""
    before = QUERIES[0]
    loaded = load_spec(spec, compare=False)
    start = time.perf_counter()
    check_all(loaded.machine)
    middle = time.perf_counter()
    machine_ir(loaded, out)
    return middle - start, time.perf_counter() - middle, QUERIES[0] - before


def main() -> None:
    ask = Solver.check

    def counted(self: Solver, formula: z3.BoolRef) -> Answer:
        QUERIES[0] += 1
        return ask(self, formula)

    Solver.check = counted
    print(f"{'guards':<10} {'n':>5} {'check s':>8} {'ir s':>8} {'queries':>8} {'growth':>7}")
    with tempfile.TemporaryDirectory() as tmp:
        for style, n_inputs in STYLES:
            previous = None
            for n in SIZES:
                spec = Path(tmp) / f"{style}{n}.toml"
                spec.write_text(wide_spec(n, style, n_inputs=n_inputs), encoding="utf-8")
                check_s, ir_s, queries = measure(spec, Path(tmp) / "generated")
                growth = f"{(check_s + ir_s) / previous:.2f}" if previous else ""
                print(f"{style:<10} {n:>5} {check_s:>8.2f} {ir_s:>8.2f} {queries:>8} {growth:>7}", flush=True)
                previous = check_s + ir_s


if __name__ == "__main__":
    main()
