"""Benchmark `check`: the shipped specs, machines with data, then synthetic machines of growing size.

Run on demand: `.venv/bin/python bench/bench_check.py [--quick] [--reps N] [--t-min-sample N] [--sharing]`.
Prints wall times side by side in one run:
the shipped specs (in process, and as a fresh `mlca-verify` process, interpreter and z3 start-up included),
MLCA-T's parametric proof against one proof per value of T_MIN, a counter of 1,000,000 values proved
symbolically against an explicit BFS of the same machine, a pedestrian crossing with a timer against the same
crossing with the timer expanded into states, timers of growing length, z3's resources per ms, the machine's
shared unrollings against one per query, the time per property and per model on the public models and the
project's corpus, then machines of 10 to 2,000 states and 4 to 12 inputs, with the growth factor between
consecutive sizes. Where two things are compared, the times are medians of interleaved repetitions.
`--sharing` runs only the shared unrollings and the corpora.
"""

from __future__ import annotations

import argparse
import atexit
import random
import statistics
import subprocess
import sys
import tempfile
import time
from collections import deque
from collections.abc import Callable
from functools import partial
from pathlib import Path

import z3

from figures import PERFORMANCE, write_block  # run as a script: bench/ is on the path
from mlca_verify.codegen import generate
from mlca_verify.errors import Loc
from mlca_verify.logic import check_all
from mlca_verify.logic.boolean import Checker
from mlca_verify.logic.datachecks import DataChecker
from mlca_verify.logic.induction import Limits, Unrolling, Unrollings
from mlca_verify.logic.results import Result
from mlca_verify.logic.symbolic import System
from mlca_verify.model import BinOp, Expr, Input, Invariant, Liveness, Machine, Not, StateIn, Transition, Var
from mlca_verify.spec import load_spec, load_text

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = sorted(str(p.relative_to(ROOT)) for p in [*ROOT.glob("spec/*.toml"), *ROOT.glob("spec/paper/*.toml")])
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


def shipped(reps: int) -> None:
    machines = [load_spec(ROOT / p).machine for p in SHIPPED]
    check_all(machines[0])  # warm z3 up
    print("shipped specs                in process (s)")
    total = 0.0
    best = []
    for path, machine in zip(SHIPPED, machines, strict=True):
        seconds = min(timed(lambda m=machine: check_all(m)) for _ in range(reps))
        total += seconds
        best.append((path, seconds))
        print(f"  {path:26} {seconds:8.3f}")
    print(f"  {f'all {len(SHIPPED)}':26} {total:8.3f}")
    rows = [f"| `{path}`, `check_all` in process, best of {reps} | {seconds:.3f} s |" for path, seconds in best]
    walls = [timed(lambda: [check_all(m) for m in machines]) for _ in range(reps)]
    verdict = "met" if statistics.median(walls) < 1.0 else "missed"
    print(
        f"  one Python process, one `check_all` per spec, wall time: median {statistics.median(walls):.3f} s"
        f" of {reps} (best {min(walls):.3f}, worst {max(walls):.3f}); 1 s target {verdict}"
    )
    rows.append(
        f"| all {len(SHIPPED)}, one `check_all` each in one process | median {statistics.median(walls):.3f} s of"
        f" {reps} (best {min(walls):.3f} s, worst {max(walls):.3f} s) |"
    )
    cli = ROOT / ".venv" / "bin" / "mlca-verify"
    command = [str(cli), "check", *SHIPPED, "--quiet"]
    walls = [timed(lambda: subprocess.run(command, cwd=ROOT, capture_output=True, check=True)) for _ in range(reps)]
    print(
        f"  one `mlca-verify check` process on all {len(SHIPPED)}, wall time: best {min(walls):.3f} s,"
        f" worst {max(walls):.3f} s"
    )
    print("  target: under 1 s of wall time\n")
    verdict = "met" if min(walls) < 1.0 else "**missed**"
    rows.append(
        f"| one `mlca-verify check` process on all {len(SHIPPED)} (start-up included) | best {min(walls):.3f} s,"
        f" worst {max(walls):.3f} s of {reps}: the 1 s target is {verdict} |"
    )
    DOCS["check-shipped"] = ["| | wall time |", "|---|---|", *rows]


def interleaved(reps: int, *fns: Callable[[], object]) -> list[float]:
    """The median wall time of each function, run in turn `reps` times (a, b, a, b, ...)."""
    times: list[list[float]] = [[] for _ in fns]
    for _ in range(reps):
        for i, fn in enumerate(fns):
            times[i].append(timed(fn))
    return [statistics.median(t) for t in times]


def declared(results: list[Result], machine: Machine) -> list[Result]:
    names = {p.id for p in machine.invariants} | {p.id for p in machine.liveness}
    return [r for r in results if r.prop in names]


def mlca_t_sweep(reps: int, sample: int) -> None:
    """MLCA-T's properties proved once for every T_MIN in [1, 100] against one proof per value of T_MIN."""
    text = (ROOT / "spec" / "mlca_t.toml").read_text()
    shipped_machine = load_text(text, "spec/mlca_t.toml")
    assert all(p.parametric for p in (*shipped_machine.invariants, *shipped_machine.liveness))
    default = 'T_MIN = { type = "int", default = 20, range = [1, 100]'
    assert text.count(default) == 1 and "parametric = true" in text
    low, high = 1, 100
    values = sorted({round(low + (high - low) * i / max(sample - 1, 1)) for i in range(sample)})
    per_value: dict[int, Machine] = {}
    for value in values:
        one = text.replace("parametric = true", "parametric = false").replace(
            default, default.replace("default = 20", f"default = {value}")
        )
        per_value[value] = load_text(one, f"mlca_t(T_MIN={value})")
    last: dict[str, list[Result]] = {}
    props: dict[int, float] = {}

    def parametric() -> None:
        last["parametric"] = check_all(shipped_machine)

    def one_by_one() -> None:
        for value, machine in per_value.items():
            results = check_all(machine)
            last[str(value)] = results
            props[value] = sum(r.seconds for r in declared(results, machine))

    para, sweep = interleaved(reps, parametric, one_by_one)
    para_props = declared(last["parametric"], shipped_machine)
    assert all(r.ok and r.proof is not None and r.proof.parametric for r in para_props)
    para_prop_s = sum(r.seconds for r in para_props)
    print(
        f"MLCA-T, {len(para_props)} properties, T_MIN in [{low}, {high}]      whole check_all (s)  properties only (s)"
    )
    print(f"  parametric (as shipped), every T_MIN at once   {para:19.3f}  {para_prop_s:19.3f}")
    print(f"  one T_MIN at a time, parametric = false, {len(values)} of {high - low + 1} values sampled: {values}")
    for value in values:
        results = last[str(value)]
        off = [f"{r.prop} {r.verdict}" for r in results if not r.ok]
        note = f"  not as expected: {', '.join(off)}" if off else ""
        total = sum(r.seconds for r in results)
        print(f"    T_MIN = {value:3}                              {total:19.3f}  {props[value]:19.3f}{note}")
    print(f"  the {len(values)} sampled values, wall time (median of {reps}) {sweep:12.3f}")
    every = high - low + 1
    if len(values) == every:
        print(f"  all {every} values, measured                     {sweep:19.3f}")
        estimate = sweep
    else:
        estimate = sweep / len(values) * every
        estimate_props = sum(props.values()) / len(values) * every
        print(
            f"  all {every} values, EXTRAPOLATED (mean of the sample x {every}) {estimate:10.1f}"
            f"  {estimate_props:19.1f}"
        )
    print(
        f"  one value at a time / parametric: {estimate / para:.1f}x"
        f" ({'measured' if len(values) == every else 'extrapolated'}); one value alone costs"
        f" {sweep / len(values) / para:.2f}x the parametric proof on average\n"
    )
    unknown = [f"{r.prop} at T_MIN = {v}" for v in values for r in last[str(v)] if r.verdict == "unknown"]
    how = "measured" if len(values) == every else "extrapolated"
    DOCS.setdefault("check-data", DATA_HEAD.copy()).extend([
        f"| MLCA-T, its {len(para_props)} properties for every T_MIN in {low}..{high} | one parametric proof |"
        f" {para_prop_s:.2f} s ({para:.2f} s with the built-in checks and the lemmas) |",
        f"| | one proof per value, {len(values)} values of {every} timed ({', '.join(map(str, values))}), the mean"
        f" times {every} | {estimate:.0f} s {how}, about {estimate / para:,.0f} times the parametric proof;"
        f" unknown: {', '.join(unknown) or 'none'} |",
    ])  # fmt: skip


DATA_HEAD = ["| | | time |", "|---|---|---|"]


COUNTER = 999_999
COUNTER_SPEC = f"""
[machine]
name = "Counter"
initial = "A"
states = ["A", "B"]
semantics = "first-match"
otherwise = "stay"
cite = "bench"

[inputs]
tick = {{ doc = "count one step", cite = "bench" }}

[variables]
c = {{ type = "int", initial = 0, range = [0, {COUNTER}], every = "if tick then min(c + 1, {COUNTER}) else c", \
doc = "ticks seen", cite = "bench" }}

[[transition]]
id = "go"
from = "A"
to = "B"
when = "tick"
cite = "bench"

[[transition]]
id = "back"
from = "B"
to = "A"
when = "not tick"
cite = "bench"

[[invariant]]
id = "bounded"
expr = "c <= {COUNTER}"
cite = "bench"

[[invariant]]
id = "B-counted"
expr = "state == B -> c >= 1"
cite = "bench"
"""


def counter_bfs(limit_s: float) -> tuple[int, float | None]:
    """Explicit BFS over (state, c) of COUNTER_SPEC, both invariants checked in every state reached; the
    number of states reached and the seconds taken (None: over `limit_s`)."""
    start = time.perf_counter()
    seen = {("A", 0)}
    queue = deque(seen)
    while queue:
        if len(seen) % 4096 == 0 and time.perf_counter() - start > limit_s:
            return len(seen), None
        state, c = queue.popleft()
        assert c <= COUNTER and (state != "B" or c >= 1)
        for tick in (False, True):
            # go: A -tick-> B, back: B -not tick-> A, otherwise stay: the next state is B exactly on a tick
            after = ("B" if tick else "A", min(c + 1, COUNTER) if tick else c)
            if after not in seen:
                seen.add(after)
                queue.append(after)
    return len(seen), time.perf_counter() - start


def counter(reps: int) -> None:
    machine = load_text(COUNTER_SPEC, "<bench counter>")
    results: list[list[Result]] = []
    bfs: list[tuple[int, float | None]] = []
    symbolic, explicit = interleaved(
        reps, lambda: results.append(check_all(machine)), lambda: bfs.append(counter_bfs(60.0))
    )
    assert all(r.ok for r in results[-1])
    engines = ", ".join(f"{r.prop} {r.proof.engine}" for r in declared(results[-1], machine) if r.proof)
    reached, seconds = bfs[-1]
    print(f"counter of {COUNTER + 1:,} values, states A/B        seconds (median of {reps})")
    print(f"  symbolic `check_all` (all checks)             {symbolic:8.3f}  ({engines})")
    if seconds is None:
        print(f"  explicit BFS over (state, c), 60 s limit      over 60 s ({reached:,} states reached)")
    else:
        print(
            f"  explicit BFS over (state, c), 60 s limit      {explicit:8.3f}  ({reached:,} states reached;"
            f" {explicit / symbolic:.0f}x the symbolic proof)"
        )
    print()
    bare = "over 60 s" if seconds is None else f"{explicit:.2f} s"
    DOCS.setdefault("check-data", DATA_HEAD.copy()).extend([
        f"| a counter of {COUNTER + 1:,} values (two states, a tick input, two invariants) | symbolic, every check |"
        f" {symbolic:.2f} s |",
        f"| | explicit breadth-first search of its {reached:,} states, in plain Python in the benchmark | {bare} |",
    ])  # fmt: skip


GREEN = 50  # steps of minimum green: 5 s at 10 Hz


def crossing_timed(n: int) -> str:
    return f"""
[machine]
name = "CrossingTimed"
initial = "CARS_GREEN"
states = ["CARS_GREEN", "CARS_YELLOW", "WALK", "CLEAR"]
semantics = "first-match"
otherwise = "stay"
step_s = 0.1
cite = "bench"

[inputs]
button = {{ doc = "a pedestrian asks to cross", cite = "bench" }}

[params]
MIN_GREEN = {{ type = "int", default = {n}, range = [2, 1000], unit = "step", doc = "minimum green", cite = "bench" }}

[variables]
green = {{ type = "int", initial = 0, range = [0, 1000], unit = "step", every = "min(green + 1, 1000)", \
doc = "steps of green shown before this one", cite = "bench" }}
green_age = {{ type = "int", initial = 0, range = [0, 1001], unit = "step", \
every = "if state == CARS_GREEN then min(green_age + 1, 1001) else 0", \
doc = "observer: steps of green shown in a row, kept apart from the timer", cite = "bench" }}

[outputs]
cars = {{ expr = "if state == CARS_GREEN then 2 else if state == CARS_YELLOW then 1 else 0", \
doc = "car light: 2 green, 1 yellow, 0 red", cite = "bench" }}
walk = {{ expr = "if state == WALK then 1 else 0", doc = "walk light: 1 walk shown", cite = "bench" }}

[[transition]]
id = "yellow"
from = "CARS_GREEN"
to = "CARS_YELLOW"
when = "button and green >= MIN_GREEN - 1"
cite = "bench"

[[transition]]
id = "walk"
from = "CARS_YELLOW"
to = "WALK"
when = "true"
cite = "bench"

[[transition]]
id = "clear"
from = "WALK"
to = "CLEAR"
when = "true"
cite = "bench"

[[transition]]
id = "green"
from = "CLEAR"
to = "CARS_GREEN"
when = "true"
do = "green = 0"
cite = "bench"

[[invariant]]
id = "no-green-while-walk"
expr = "not (cars == 2 and walk == 1)"
cite = "bench"

[[invariant]]
id = "minimum-green"
expr = "prev(state) == CARS_GREEN and state == CARS_YELLOW -> green_age >= MIN_GREEN"
cite = "bench"
"""


def crossing_expanded(n: int) -> str:
    greens = [f"G{k}" for k in range(1, n + 1)]
    states = ", ".join(f'"{s}"' for s in [*greens, "CARS_YELLOW", "WALK", "CLEAR"])
    lines = [
        "[machine]",
        'name = "CrossingExpanded"',
        'initial = "G1"',
        f"states = [{states}]",
        'semantics = "first-match"',
        'otherwise = "stay"',
        'cite = "bench"',
        "",
        "[inputs]",
        'button = { doc = "a pedestrian asks to cross", cite = "bench" }',
    ]

    def transition(tid: str, source: str, target: str, when: str) -> None:
        lines.extend(["", "[[transition]]", f'id = "{tid}"', f'from = "{source}"', f'to = "{target}"'])
        lines.extend([f'when = "{when}"', 'cite = "bench"'])

    for k in range(1, n):
        transition(f"count{k}", f"G{k}", f"G{k + 1}", "true")
    transition("yellow", f"G{n}", "CARS_YELLOW", "button")
    transition("walk", "CARS_YELLOW", "WALK", "true")
    transition("clear", "WALK", "CLEAR", "true")
    transition("green", "CLEAR", "G1", "true")
    green_set = "{" + ", ".join(greens) + "}"
    lines.extend(["", "[[invariant]]", 'id = "no-green-while-walk"'])
    lines.extend([f'expr = "state == WALK -> not (state in {green_set})"', 'cite = "bench"'])
    # minimum-green needs prev() or a counter, which make a machine with data: here it holds by construction
    # (CARS_YELLOW is entered only from G{n}, the end of the chain G1 -> ... -> G{n} that has no other exit).
    return "\n".join(lines) + "\n"


def crossing(reps: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for name, text in (("timed", crossing_timed(GREEN)), ("expanded", crossing_expanded(GREEN))):
            paths[name] = Path(tmp) / f"crossing_{name}.toml"
            paths[name].write_text(text)
        specs = {name: load_spec(path) for name, path in paths.items()}
        results: dict[str, list[Result]] = {}

        def run(name: str) -> Callable[[], None]:
            return lambda: results.__setitem__(name, check_all(specs[name].machine))

        seconds = dict(zip(specs, interleaved(reps, *(run(name) for name in specs)), strict=True))
        files = generate(specs["expanded"], Path(tmp) / "out")
        code_lines = sum(text.count("\n") for text in files.values())
        timed_files = generate(specs["timed"], Path(tmp) / "timed")
        timed_lines = sum(text.count("\n") for text in timed_files.values())
    for name, found in results.items():
        bad = [f"{r.prop} {r.verdict}" for r in found if not r.ok]
        assert not bad, (name, bad)
    print(
        f"pedestrian crossing, minimum green {GREEN} steps ({GREEN / 10:g} s at 10 Hz)   states  check_all (s)"
        "  generated code (lines)"
    )
    timed_machine = specs["timed"].machine
    print(
        f"  with a timer (int variable)                      {len(timed_machine.states):6}  {seconds['timed']:13.3f}"
        f"  {timed_lines} in {len(timed_files)} files"
    )
    print(
        f"  timer expanded into states (boolean)             {len(specs['expanded'].machine.states):6}"
        f"  {seconds['expanded']:13.3f}  {code_lines} in {len(files)} files"
    )
    print("  (expanded: minimum green holds by construction, a boolean invariant cannot state it without prev())")
    print()
    expanded = len(specs["expanded"].machine.states)
    DOCS.setdefault("check-data", DATA_HEAD.copy()).extend([
        f"| a pedestrian crossing with a {GREEN / 10:g} s minimum green at 10 Hz | with a timer:"
        f" {len(timed_machine.states)} states, every check | {seconds['timed']:.2f} s |",
        f"| | expanded into states: {expanded} states | {seconds['expanded']:.3f} s; {code_lines:,} generated lines in"
        f" {len(files)} files |",
    ])  # fmt: skip


MACHINES = ROOT / "tests" / "machines"


LONG_TIMERS = {  # the corpus machines with the longest timers, and how the docs name them
    "crossing_10hz": "crossing, 10 Hz",
    "crossing_100hz": "crossing, 100 Hz",
    "pump_debounce_1khz": "pump debounce, 1 kHz",
}


def timers(reps: int) -> None:
    """The corpus's long timers, with the explicit-state engine first (as `check` runs) and with the symbolic
    engines alone, side by side; then the growth of check time with a timer's length."""
    print(
        "corpus machines                   explicit first (s)  unknown   symbolic alone (s)  unknown"
        "   median per property, explicit first (ms)"
    )
    rows = [
        "| machine | explicit first | unknown | symbolic alone (`Limits(steps=0)`) | unknown |",
        "|---|---|---|---|---|",
    ]
    for stem, label in LONG_TIMERS.items():
        machine = load_spec(MACHINES / f"{stem}.toml").machine
        found: dict[str, list[Result]] = {}

        def first_run(m: Machine = machine, into: dict[str, list[Result]] = found) -> None:
            into["explicit"] = check_all(m)

        def alone_run(m: Machine = machine, into: dict[str, list[Result]] = found) -> None:
            into["symbolic"] = check_all(m, limits=Limits(steps=0))

        first, alone = interleaved(reps, first_run, alone_run)
        unknown = {k: sum(r.verdict == "unknown" for r in v) for k, v in found.items()}
        median = statistics.median(r.seconds for r in found["explicit"]) * 1000
        print(
            f"  {stem:30} {first:18.3f}  {unknown['explicit']:7}   {alone:18.3f}  {unknown['symbolic']:7}"
            f"   {median:10.1f}"
        )
        rows.append(f"| {label} | {first:.1f} s | {unknown['explicit']} | {alone:.1f} s | {unknown['symbolic']} |")
    print("\ncrossing, minimum green of N steps: whole check_all (s), explicit first")
    text = (MACHINES / "crossing_10hz.toml").read_text()
    grown = []
    for n in (10, 100, 1000, 10_000):
        one = text.replace('MIN_GREEN = { type = "int", default = 100,', f'MIN_GREEN = {{ type = "int", default = {n},')
        one = one.replace("within = 205", f"within = {n + 105}").replace("within = 120", f"within = {n + 20}")
        machine = load_text(one, f"crossing(MIN_GREEN={n})")
        results: list[list[Result]] = []

        def one_run(m: Machine = machine, into: list[list[Result]] = results) -> None:
            into.append(check_all(m))

        (seconds,) = interleaved(reps, one_run)
        unknown = sum(r.verdict == "unknown" for r in results[-1])
        bad = [r.prop for r in results[-1] if not r.ok]
        print(f"  N = {n:6,}  {seconds:8.3f}  unknown {unknown}  not as expected: {', '.join(bad) or 'none'}")
        grown.append(f"{n:,} steps: {seconds:.1f} s")
    rows += ["", f"The 10 Hz crossing with a minimum green of {'; '.join(grown)} (a whole `check`, explicit first)."]
    DOCS["check-timers"] = rows
    print()


def resources(reps: int) -> None:
    """How long z3 takes to spend a fixed resource budget (rlimit) on a query it cannot finish: PDR on the 10 Hz
    crossing's `reach:WALK`, and a BMC query of 400 steps of it; the engine's RESOURCE_PER_MS should be about
    the budget over these times."""
    from mlca_verify.logic import solver as budgets
    from mlca_verify.logic.datachecks import _reaches
    from mlca_verify.logic.induction import pdr

    machine = load_spec(MACHINES / "crossing_10hz.toml").machine
    system, real = DataChecker(machine, Limits(steps=0)).systems((), False)
    spend_ms = 2000

    def pdr_run() -> None:
        pdr(system, _reaches("WALK"), spend_ms)

    def bmc_run() -> None:
        run = Unrolling(real, True, "b", spend_ms)
        for _ in range(400):
            run.extend()
        run.check(400, z3.Or(*[run.bad(_reaches("WALK"), k) for k in range(0, 400, 7)]))

    units = spend_ms * budgets.RESOURCE_PER_MS
    pdr_s, bmc_s = interleaved(reps, pdr_run, bmc_run)
    print(f"z3 resources: a budget of {units:,} units ({spend_ms} ms at RESOURCE_PER_MS = {budgets.RESOURCE_PER_MS})")
    print(f"  PDR spends it in {pdr_s:.3f} s: {units / pdr_s / 1000:,.0f} units per ms")
    print(f"  BMC of 400 steps answers in {bmc_s:.3f} s (within the budget, or at it)")
    print()
    DOCS["check-resources"] = [
        "| query (the 10 Hz crossing's `reach:WALK`) | budget | seconds | units per ms |",
        "|---|---|---|---|",
        f"| PDR, which cannot finish | {units:,} units | {pdr_s:.3f} | {units / pdr_s / 1000:,.0f} |",
        f"| BMC of 400 steps | {units:,} units | {bmc_s:.3f} | - |",
        "",
        f"The engine takes {budgets.RESOURCE_PER_MS:,} units for a millisecond of `--timeout-ms` (`RESOURCE_PER_MS`).",
    ]


class Unshared(Unrollings):
    """The engine before its queries shared unrollings: every query builds its own."""

    def of(self, system: System, initial: bool) -> Unrolling:
        return Unrolling(system, initial, "b" if initial else "i", self.timeout_ms)


def checked(machine: Machine, shared: bool) -> list[Result]:
    checker = DataChecker(machine, Limits())
    if not shared:
        checker.unrollings = Unshared(checker.limits.timeout_ms)
    return checker.run_all()


SHARING = [
    "spec/mlca_t.toml",
    *(f"tests/machines/{n}.toml" for n in ("crossing_10hz", "watchdog_100hz", "acc_modes_50hz")),
]


def with_invariants(n: int) -> Machine:
    """The window watchdog with `n` more invariants, each a bound on its counter that holds (k-induction)."""
    text = (ROOT / "tests/machines/watchdog_100hz.toml").read_text()
    for j in range(n):
        bound = f"state == WINDOW -> since < TIMEOUT + {j}"
        text += f'\n[[invariant]]\nid = "bound-{j}"\nexpr = "{bound}"\ncite = "bench"\n'
    return load_text(text, "<bench>")


def sharing(reps: int) -> None:
    """One unrolling per system, shared by all of a machine's queries, against one per query."""
    print("shared unrollings: whole check (s), median of interleaved pairs   shared  one per query  ratio")
    rows = ["| spec, whole check | shared | one per query | ratio |", "|---|---|---|---|"]
    for path in SHARING:
        machine = load_spec(ROOT / path).machine
        same = [r.verdict for r in checked(machine, True)] == [r.verdict for r in checked(machine, False)]
        a, b = interleaved(reps, lambda m=machine: checked(m, True), lambda m=machine: checked(m, False))
        print(f"  {path:56} {a:7.3f}  {b:13.3f}  {a / b:5.2f}{'' if same else '  VERDICTS DIFFER'}")
        rows.append(f"| `{path}` | {a:.2f} s | {b:.2f} s | {a / b:.2f} |")
    print("  the watchdog with N more invariants        shared  one per query  per added property (shared, one each)")
    base: tuple[float, float] | None = None
    for n in (0, 10, 20, 40):
        machine = with_invariants(n)
        a, b = interleaved(reps, lambda m=machine: checked(m, True), lambda m=machine: checked(m, False))
        if base is None:
            base = (a, b)
            print(f"  {n:4} more{'':38} {a:7.3f}  {b:13.3f}")
        else:
            print(f"  {n:4} more{'':38} {a:7.3f}  {b:13.3f}  {(a - base[0]) / n:.4f}, {(b - base[1]) / n:.4f}")
            added = ((a - base[0]) / n * 1000, (b - base[1]) / n * 1000)
            rows.append(
                f"| the watchdog with {n} more invariants, each added one | {added[0]:.0f} ms | {added[1]:.0f} ms | |"
            )
    DOCS["check-sharing"] = rows
    print()


SECTIONS: dict[str, Callable[[argparse.Namespace], None]] = {
    "shipped": lambda a: shipped(a.reps),
    "mlca-t": lambda a: mlca_t_sweep(a.reps, a.t_min_sample),
    "counter": lambda a: counter(a.reps),
    "crossing": lambda a: crossing(a.reps),
    "timers": lambda a: timers(a.reps),
    "resources": lambda a: resources(a.reps),
    "sharing": lambda a: sharing(a.reps),
    "corpora": lambda a: corpora(a.reps),
    "growth": lambda a: growth(a.quick),
}
DOCS: dict[str, list[str]] = {}  # the tables measured, by block of performance.md or PAGES (`--write-docs`)


ENGINES = ROOT / "docs" / "explanation" / "engines.md"
PAGES = {"check-timers": ENGINES, "check-resources": ENGINES}  # the blocks not on performance.md


def write_docs(by: str) -> None:
    """Write each table measured into its block (those not measured in this run are left as they are)."""
    for name, lines in DOCS.items():
        write_block(name, lines, by, PAGES.get(name, PERFORMANCE))


KIND2_MEDIAN_S = 0.77  # per model, start-up included, on the FMCAD'08 Lustre set: a quoted figure, not re-measured


def corpora(reps: int) -> None:
    """The public models with published verdicts (tests/public/) and the project's own corpus (tests/machines/):
    the median time per property (in process) and per model (a fresh `mlca-verify check` process)."""
    cli = ROOT / ".venv" / "bin" / "mlca-verify"
    print("corpora                          models  properties  median ms/property  median s/model (process)")
    rows = ["| corpus | models | median per property (every check) | median per model, a fresh `check` process |"]
    rows.append("|---|---|---|---|")
    for name, folder in (("public models (tests/public)", "tests/public"), ("own corpus (tests/machines)", MACHINES)):
        files = sorted((ROOT / folder).glob("*.toml"))
        per_property = [r.seconds for f in files for r in check_all(load_spec(f).machine)]
        runs = [
            partial(subprocess.run, [str(cli), "check", str(f), "--quiet"], check=True, capture_output=True)
            for f in files
        ]
        per_model = [statistics.median(timed(run) for _ in range(reps)) for run in runs]
        print(
            f"  {name:30} {len(files):6} {len(per_property):11} {statistics.median(per_property) * 1000:19.2f}"
            f"  {statistics.median(per_model):8.3f}"
        )
        ms = statistics.median(per_property) * 1000
        shown = Path(folder).relative_to(ROOT) if Path(folder).is_absolute() else folder
        rows.append(f"| `{shown}/` | {len(files)} | {ms:.2f} ms | {statistics.median(per_model):.2f} s |")
    DOCS["check-corpora"] = rows
    print(f"  targets: under 0.1 s per property; per model at most Kind 2's median, {KIND2_MEDIAN_S} s\n")


def growth(quick: bool) -> None:
    sizes = [10, 50, 100, 250, 500] if quick else [10, 50, 100, 250, 500, 1000, 2000]
    print("synthetic machines  states  inputs  transitions  z3 queries  seconds  x previous size  s per state")
    times: dict[tuple[int, int], tuple[int, int, float]] = {}
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
            times[n, n_inputs] = (len(machine.transitions), checker[0].solver.queries, seconds)
            sys.stdout.flush()
    rows = [
        "| states | transitions | z3 queries (4 inputs) | 4 inputs | 8 inputs | 12 inputs |",
        "|---|---|---|---|---|---|",
    ]
    for n in sizes:
        transitions, queries, _ = times[n, 4]
        cells = " | ".join(f"{times[n, k][2]:.2f} s" for k in (4, 8, 12))
        rows.append(f"| {n:,} | {transitions:,} | {queries:,} | {cells} |")
    DOCS["check-growth"] = rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="sizes up to 500 states only")
    parser.add_argument("--reps", type=int, default=3, help="repetitions of each timing (median or best)")
    parser.add_argument("--t-min-sample", type=int, default=4, help="values of T_MIN proved one at a time (<= 100)")
    parser.add_argument(
        "--sharing", action="store_true", help="only the shared unrollings and the corpora's times per property"
    )
    parser.add_argument("--write-docs", action="store_true", help="write the tables measured into their docs page")
    parser.add_argument(
        "--only",
        default=",".join(SECTIONS),
        help=f"comma-separated sections to run (default all: {', '.join(SECTIONS)})",
    )
    args = parser.parse_args()
    if args.write_docs:  # at exit, an interrupted run included: what was measured is written
        atexit.register(write_docs, " ".join(["bench/bench_check.py", *sys.argv[1:]]))
    wanted = ["sharing", "corpora"] if args.sharing else args.only.split(",")
    for name in wanted:
        if name not in SECTIONS:
            sys.exit(f"error: no section {name!r} ({', '.join(SECTIONS)})")
        SECTIONS[name](args)
        sys.stdout.flush()
