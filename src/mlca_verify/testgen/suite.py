"""A requirements-based test suite: the runs of the MC/DC pairs, each with what the spec says happens at every
step (the mode, the variables, the outputs, the invariants that fail), answered by z3 on the spec's own step
relation with every input fixed, never by the generated code."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

import z3

from mlca_verify.floats import FORMATS, Format
from mlca_verify.logic.symbolic import Frame, StepInputs, StepTerms, System, value_of
from mlca_verify.model import Machine, prevs_of, stored_registers
from mlca_verify.testgen import DEPTH
from mlca_verify.testgen.objectives import objectives
from mlca_verify.testgen.search import Found, Pair, Sample, Search, Snapshot, Unrolling, frame_values, unkept, value_at


@dataclass(frozen=True)
class Expected:
    state: str
    variables: tuple[int | float, ...]
    outputs: tuple[int | float | bool, ...]
    failing: tuple[str, ...]


@dataclass(frozen=True)
class Case:
    name: str
    inputs: tuple[Sample, ...]
    expected: tuple[Expected, ...]
    covers: tuple[str, ...]  # "objective-id:A" or ":B"
    start: dict[str, bool | int | float] | None = None  # the context the run starts from (None: the initial one)


@dataclass(frozen=True)
class MonitorCase:
    """A direct call of the monitor on a context the machine need not reach (an invariant at its boundary)."""

    name: str
    snapshot: Snapshot
    covers: tuple[str, ...]


@dataclass(frozen=True)
class ParamCase:
    """Params with one value outside its range (or every default), and whether the code must call them valid."""

    name: str
    values: dict[str, int | float]
    valid: bool


@dataclass
class Suite:
    machine: Machine
    cases: list[Case]
    monitor: list[MonitorCase]
    pairs: list[Pair]
    params: list[ParamCase]
    depth: int
    unvisited: list[str] = field(default_factory=list)  # states no run of `depth` steps steps from

    @property
    def uncovered(self) -> list[Pair]:
        return [p for p in self.pairs if p.a is None or p.b is None]


Start = dict[str, bool | int | float] | None
Run = tuple[Start, list[Sample]]


def replay(machine: Machine, runs: Sequence[Run]) -> list[list[Expected]]:
    """What the spec says of each run (from its start, or from the initial state), step by step: one step of
    the spec's step relation at a time, with the context before it and its inputs fixed. The context a step
    leaves is carried to the next as the code holds it: each real variable the value of the machine's format
    (binary64 or binary32) nearest z3's exact one, which is the code's own result where the update is one
    operation. The spec's real constants (literals, params' defaults, initial values, signals' bounds) are the
    format's too, as the code's constants hold them. So each step's expectation is the spec's from the context
    and with the constants the code has, and rounding does not pile up between the two over a run: a timer
    counting 0.001 a step holds what the code holds (the format's 0.001 added and rounded), and reaches a
    threshold of 0.02 at the step the code does, in binary64 as in binary32."""
    prevs = prevs_of(*(i.expr for i in machine.invariants), *(o.expr for o in machine.outputs))
    fmt = FORMATS[machine.reals]
    system = System(machine, prevs, held=fmt)
    stored = stored_registers(machine, prevs)
    pre, i, post = system.frame("r0"), system.inputs("r0"), system.frame("r1")
    link, terms = system.step(pre, i, post)
    solver = z3.Solver()
    solver.add(link)
    initial = z3.Solver()
    initial.add(system.init(pre))
    initial.check()
    first = frame_values(initial.model(), pre, stored)
    answers = []
    for start, run in runs:
        context = first if start is None else dict(start)
        held: dict[str, z3.ExprRef] = {}
        steps = []
        for sample in run:
            fixed = (_start(system, pre, context, held, fmt), *unkept(system, pre, i, stored))
            fixed += (_fix(system, i, sample, fmt),)
            if solver.check(*fixed) != z3.sat:
                raise AssertionError(f"the spec has no step from {context} under {sample}")
            model = solver.model()
            steps.append(_expected(system, model, post, terms))
            context = frame_values(model, post, stored)
            held = {n: _held(model.eval(t, model_completion=True), fmt) for n, t in post.variables.items()}
        answers.append(steps)
    return answers


def _held(value: z3.ExprRef, fmt: Format) -> z3.ExprRef:
    """A variable's value as the code's field holds it: a real rounded to the format, an int or a bool as is."""
    if not z3.is_rational_value(value) or z3.is_int_value(value):
        return value
    return z3.RealVal(_rounded(value.as_fraction(), fmt))


def _rounded(value: Fraction, fmt: Format) -> Fraction:
    """A real as a field of the format holds it (the loader keeps every number far from overflow)."""
    rounded = fmt.nearest(value)
    return value if rounded is None else rounded


def _start(
    system: System, f: Frame, start: dict[str, bool | int | float], held: dict[str, z3.ExprRef], fmt: Format
) -> z3.BoolRef:
    """The context before a step: `start`, each variable as the code holds it (`held`, after a step)."""
    parts = [f.mode == int(start["mode"]), f.first == bool(start.get("first", False))]  # none: after a step
    for v in system.m.variables:
        given = Fraction(start[v.name])
        value = held.get(v.name, value_of(_rounded(given, fmt) if v.type == "real" else given, v.type))
        parts.append(f.variables[v.name] == value)
    parts += [reg == start[f"prev{k}"] for k, reg in f.registers.items() if f"prev{k}" in start]
    return z3.And(*parts)


def _fix(system: System, i: StepInputs, sample: Sample, fmt: Format) -> z3.BoolRef:
    parts = []
    for name, value in sample.items():
        if isinstance(value, bool):
            parts.append(i.bools[name] == value)
        else:
            parts.append(i.signals[name] == _exact(system, name, value, fmt))
    return z3.And(*parts)


def _exact(system: System, name: str, value: int | float, fmt: Format) -> z3.ExprRef:
    """A sample as the code reads it: a real one rounded to the format (an infinity or NaN as out of range)."""
    signal = system.signals[name]
    if isinstance(value, float) and not math.isfinite(value):
        return value_of(signal.range[1] + 1, signal.type)
    exact = Fraction(value)
    return value_of(_rounded(exact, fmt) if signal.type == "real" else exact, signal.type)


def _expected(system: System, model: z3.ModelRef, post: Frame, terms: StepTerms) -> Expected:
    m = system.m
    mode = int(value_at(model, post.mode))
    variables = tuple(value_at(model, post.variables[v.name]) for v in m.variables)
    outputs = tuple(value_at(model, t) for t in system.outputs_at(terms.post).values())
    failing = tuple(inv.id for inv in m.invariants if not value_at(model, system.ev(inv.expr, terms.post)))
    return Expected(m.states[mode], variables, outputs, failing)


def param_cases(machine: Machine) -> list[ParamCase]:
    """The defaults, then each param just below and just above its range."""
    defaults = {p.name: _param_value(p.default, p.type) for p in machine.params}
    cases = [ParamCase("defaults", defaults, True)]
    for p in machine.params:
        if p.range is None:
            continue
        step = Fraction(1) if p.type == "int" else Fraction(1, 2)
        for end, value in (("below", p.range[0] - step), ("above", p.range[1] + step)):
            cases.append(ParamCase(f"{p.name}_{end}", {**defaults, p.name: _param_value(value, p.type)}, False))
    return cases


def _param_value(value: Fraction, kind: str) -> int | float:
    return int(value) if kind == "int" else float(value)


def generate(machine: Machine, depth: int = DEPTH) -> Suite:
    """Search a pair for every objective, keep each distinct run once, and replay the runs on the spec."""
    search = Search(Unrolling(machine, depth))
    pairs = [search.pair(o) for o in objectives(machine)]
    visits, unvisited = visit_states(machine, search, pairs)
    cases = cases_of(machine, pairs, visits)
    monitor = monitor_cases(pairs)
    return Suite(machine, cases, monitor, pairs, param_cases(machine), depth, unvisited)


def visit_states(machine: Machine, search: Search, pairs: Sequence[Pair]) -> tuple[dict[str, Found], list[str]]:
    """A run stepping from each state no pair's run steps from already (a state without decisions)."""
    stepped = {p.objective.decision.state for p in pairs if p.a is not None and p.a.snapshot is None}
    visits: dict[str, Found] = {}
    unvisited: list[str] = []
    for state in machine.states:
        if state in stepped:
            continue
        found = search.visit(state)
        if found is None:
            unvisited.append(state)
        else:
            visits[state] = found
    return visits, unvisited


def monitor_cases(pairs: Sequence[Pair]) -> list[MonitorCase]:
    shots: dict[str, tuple[Snapshot, list[str]]] = {}
    for p in pairs:
        for half, found in (("A", p.a), ("B", p.b)):
            if found is not None and found.snapshot is not None:
                shots.setdefault(repr(found.snapshot), (found.snapshot, []))[1].append(f"{p.objective.id}:{half}")
    return [MonitorCase(f"m{n + 1:03d}", s, tuple(c)) for n, (s, c) in enumerate(shots.values())]


def cases_of(machine: Machine, pairs: Sequence[Pair], visits: Mapping[str, Found]) -> list[Case]:
    found_runs = [(f"{p.objective.id}:{half}", f) for p in pairs for half, f in (("A", p.a), ("B", p.b))]
    found_runs += [(f"state:{state}", f) for state, f in visits.items()]
    runs: dict[str, tuple[Start, list[Sample], list[str]]] = {}
    for cover, found in found_runs:
        if found is None or found.snapshot is not None:
            continue
        key = repr((found.start, found.inputs))
        runs.setdefault(key, (found.start, found.inputs, []))[2].append(cover)
    ordered = _without_prefixes(list(runs.values()))
    expected = replay(machine, [(s, r) for s, r, _ in ordered])
    return [
        Case(f"t{n + 1:03d}", tuple(r), tuple(e), tuple(covers), s)
        for n, ((s, r, covers), e) in enumerate(zip(ordered, expected, strict=True))
    ]


def _without_prefixes(runs: list[tuple[Start, list[Sample], list[str]]]) -> list[tuple[Start, list[Sample], list[str]]]:
    """A run that begins another from the same start keeps no test of its own: the longer run passes the same
    steps (its objectives move there)."""
    runs = sorted(runs, key=lambda r: -len(r[1]))
    kept: list[tuple[Start, list[Sample], list[str]]] = []
    for start, inputs, covers in runs:
        host = next((k for k in kept if k[0] == start and k[1][: len(inputs)] == inputs), None)
        if host is None:
            kept.append((start, inputs, list(covers)))
        else:
            host[2].extend(covers)
    kept.sort(key=lambda r: (r[0] is not None, len(r[1]), repr(r[1])))
    return kept
