"""Benchmark `check`: the shipped specs, then synthetic machines of growing size.

Run on demand: `.venv/bin/python bench/bench_check.py [--quick]`. Prints wall times side by side in one run:
the shipped specs (in process, and as a fresh `mlca-verify` process, interpreter and z3 start-up included),
then machines of 10 to 2,000 states and 4 to 12 inputs, with the growth factor between consecutive sizes.
"""

from __future__ import annotations

import argparse
import random
import subprocess
import sys
import time
from pathlib import Path

from mlca_verify.errors import Loc
from mlca_verify.logic import check_all
from mlca_verify.logic.checks import Checker
from mlca_verify.model import BinOp, Expr, Input, Invariant, Liveness, Machine, Not, StateIn, Transition, Var
from mlca_verify.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = ["spec/mlca.toml", "spec/mlca_r.toml", "spec/paper/figure.toml", "spec/paper/prose.toml"]
HERE = Loc("<bench>", 1, 1)


def synthetic(n_states: int, n_inputs: int, seed: int = 1) -> Machine:
    """A ring of states with forward, skip and back edges over random guards, a global reset, two invariants
    and two liveness properties (one holds, one is violated by a long lasso)."""
    rng = random.Random(seed)
    states = tuple(f"S{i}" for i in range(n_states))
    inputs = tuple(f"i{k}" for k in range(n_inputs))
    data = inputs[1:]

    def guard() -> Expr:
        a, b = rng.sample(data, 2) if len(data) > 1 else (data[0], data[0])
        op = rng.choice(["and", "or", "->"])
        return BinOp(op, Var(a), Not(Var(b)) if rng.random() < 0.5 else Var(b))

    transitions = [Transition("reset", None, "S0", Var(inputs[0]), "bench", HERE)]
    for i, s in enumerate(states):
        for kind, target in (
            ("fwd", (i + 1) % n_states),
            ("skip", (i + 7) % n_states),
            ("back", rng.randrange(n_states)),
        ):
            transitions.append(Transition(f"{kind}{i}", (s,), states[target], guard(), "bench", HERE))
    rst = Var(inputs[0])
    return Machine(
        name="Synthetic",
        initial="S0",
        states=states,
        inputs=tuple(Input(n, "bench", "bench", HERE) for n in inputs),
        transitions=tuple(transitions),
        invariants=(
            Invariant("reset-works", BinOp("->", rst, StateIn(("S0",))), "bench", "holds", HERE),
            Invariant("never-last", Not(StateIn((states[-1],))), "bench", "violated", HERE),
        ),
        liveness=(
            Liveness("reset-returns", rst, StateIn(("S0",)), None, "bench", "holds", HERE),
            Liveness("visits-S0", Not(rst), StateIn(("S0",)), None, "bench", "violated", HERE),
        ),
        cite="bench",
    )


def timed(fn: object) -> float:
    start = time.perf_counter()
    fn()  # type: ignore[operator]
    return time.perf_counter() - start


def shipped() -> None:
    machines = [load_spec(ROOT / p).machine for p in SHIPPED]
    check_all(machines[0])  # warm z3 up
    print("shipped specs                in process (s)")
    total = 0.0
    for path, machine in zip(SHIPPED, machines, strict=True):
        seconds = min(timed(lambda m=machine: check_all(m)) for _ in range(5))
        total += seconds
        print(f"  {path:26} {seconds:8.3f}")
    print(f"  {'all four':26} {total:8.3f}")
    cli = ROOT / ".venv" / "bin" / "mlca-verify"
    command = [str(cli), "check", *SHIPPED, "--quiet"]
    walls = [timed(lambda: subprocess.run(command, cwd=ROOT, capture_output=True, check=True)) for _ in range(5)]
    print(
        f"  one `mlca-verify check` process on all four, wall time: best {min(walls):.3f} s, worst {max(walls):.3f} s"
    )
    print("  target: under 1 s of wall time\n")


def growth(quick: bool) -> None:
    sizes = [10, 50, 100, 250, 500] if quick else [10, 50, 100, 250, 500, 1000, 2000]
    print("synthetic machines  states  inputs  transitions  z3 queries  seconds  x previous size  s per state")
    for n_inputs in (4, 8, 12):
        previous = None
        for n in sizes:
            machine = synthetic(n, n_inputs)
            checker: list[Checker] = []
            start = time.perf_counter()
            checker.append(Checker(machine))
            results = checker[0].run_all()
            seconds = time.perf_counter() - start
            assert all(r.verdict != "unknown" for r in results)
            verdicts = {r.prop: r.verdict for r in results}
            assert verdicts["reset-works"] == "holds" and verdicts["visits-S0"] == "violated"
            ratio = f"{seconds / previous:6.1f}" if previous else "     -"
            print(
                f"{'':19} {n:6}  {n_inputs:6}  {len(machine.transitions):11}  {checker[0].solver.queries:10}"
                f"  {seconds:7.2f}  {ratio:>15}  {seconds / n:11.4f}"
            )
            previous = seconds
            sys.stdout.flush()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="sizes up to 500 states only")
    args = parser.parse_args()
    shipped()
    growth(args.quick)
