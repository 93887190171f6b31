"""The search for MC/DC pairs by z3, over the machine's own step relation (`logic.symbolic`) unrolled from the
initial state.

Each objective asks for two runs from the initial state whose last steps form an independence pair: at the
first (A) the condition is true and alone decides the outcome; at the second (B) it is false, decides the
outcome too, and the outcome differs. B first keeps every other condition at its value in A (unique cause) and
falls back to masking (the others may change, the outcome still follows the condition).

Definitions that read only the step's signals are abstracted in the steps before the last (a fresh boolean a
step), which keeps the unrolling free of the nonlinear gap rules; each such step is then made concrete on its
own (signals that give the booleans chosen), and made concrete in the unrolling when it cannot be.
Comparisons over reals keep a margin at every concrete step, so that binary64 arithmetic in the generated code
decides them as the exact arithmetic of the spec does.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction

import z3

from mlca_verify.logic.symbolic import (
    Frame,
    StepInputs,
    StepTerms,
    System,
    Valuation,
    input_only,
    python_value,
    value_of,
)
from mlca_verify.model import (
    BinOp,
    Cmp,
    Expr,
    Machine,
    Not,
    Var,
    nodes,
    observer_variables,
    own,
    prevs_of,
    show,
    stored_registers,
)
from mlca_verify.testgen.objectives import Decision, Objective, atoms, rule

MARGIN = Fraction(1, 64)  # how far apart the two sides of a real comparison are kept at a concrete step
SHORT = 4  # depths tried one by one before the rest are searched at once
DIGITS = 40  # decimal digits a real of a model is read to

Sample = dict[str, bool | int | float]
# what else the second half of a pair must satisfy, over its conditions and its outcome
Extra = Callable[[list[z3.BoolRef], z3.BoolRef], z3.BoolRef]


@dataclass
class Point:
    """Where a decision is evaluated: the step's valuations, and its index in the run."""

    pre: Valuation
    post: Valuation
    step: int


@dataclass
class Snapshot:
    """A direct call of the monitor: the context before and after a step (any, reachable or not), the inputs."""

    before: dict[str, bool | int | float]
    after: dict[str, bool | int | float]
    inputs: Sample
    outputs: dict[str, bool | int | float]  # the spec's outputs over the context after
    failing: tuple[str, ...]  # the invariants the spec says fail there


@dataclass
class Found:
    """A run that ends at a point of an objective (or a monitor call), with the condition values there."""

    inputs: list[Sample]
    values: list[bool]
    outcome: bool
    snapshot: Snapshot | None = None
    start: dict[str, bool | int | float] | None = None  # the run starts from this context, not the initial one


Finder = Callable[["Objective", bool, Extra], "Found | None"]


@dataclass
class Pair:
    objective: Objective
    a: Found | None = None
    b: Found | None = None
    form: str = ""  # "unique cause", "masking", or why there is no pair
    reason: str = ""


def tree(system: System, expr: Expr, v: Valuation, override: dict[int, z3.BoolRef], at: list[int]) -> z3.BoolRef:
    """The decision's term, with the condition occurrences numbered left to right replaced where overridden."""
    if isinstance(expr, Not):
        return z3.Not(tree(system, expr.arg, v, override, at))
    if isinstance(expr, BinOp):
        left = tree(system, expr.left, v, override, at)
        right = tree(system, expr.right, v, override, at)
        ops: dict[str, Callable[[z3.BoolRef, z3.BoolRef], z3.BoolRef]] = {
            "and": z3.And,
            "or": z3.Or,
            "->": z3.Implies,
            "<->": lambda x, y: x == y,
        }
        return ops[expr.op](left, right)
    if not atoms(expr):
        return system.ev(expr, v)
    k = at[0]
    at[0] += 1
    return override.get(k, system.ev(expr, v))


class Unrolling:
    """Frames f0..f(depth+1) from the initial state, each step behind an activation literal."""

    def __init__(self, machine: Machine, depth: int, timeout_ms: int = 20_000) -> None:
        self.m = machine
        self.depth = depth
        prevs = prevs_of(*(i.expr for i in machine.invariants), *(o.expr for o in machine.outputs))
        self.abstracted = sorted(d for d in input_only(machine) if _bool_def(machine, d))
        self.system = System(machine, prevs, abstract=self.abstracted)
        self.concrete = System(machine, prevs)
        self.stored = stored_registers(machine, prevs)
        self.def_exprs = {d: rule(machine, d) for d in self.abstracted}
        self.solver = z3.Solver()
        self.solver.set("timeout", timeout_ms)
        self.frames: list[Frame] = [self.system.frame("0")]
        self.inputs: list[StepInputs] = []
        self.terms: list[StepTerms] = []
        self.active: list[z3.BoolRef] = []
        self.solver.add(self.system.init(self.frames[0]))
        self.concrete_steps: set[int] = set()
        self.concrete_terms: dict[int, z3.BoolRef] = {}
        self.realized: dict[tuple[bool | str, ...], Sample | None] = {}
        for _ in range(depth + 1):
            self._add_step()

    def _add_step(self) -> None:
        k = len(self.inputs)
        i, post = self.system.inputs(str(k)), self.system.frame(str(k + 1))
        link, terms = self.system.step(self.frames[k], i, post)
        act = z3.Bool(own(f"act@{k}"))
        bounds = signal_bounds(self.system, i)
        self.solver.add(z3.Implies(act, z3.And(link, self.system.assumptions(self.frames[k], i), *bounds)))
        self.frames.append(post)
        self.inputs.append(i)
        self.terms.append(terms)
        self.active.append(act)

    def point(self, k: int) -> Point:
        return Point(self.terms[k].pre, self.terms[k].post, k)

    def make_concrete(self, k: int) -> z3.BoolRef:
        """The abstracted definitions equal to their rules at step k, with the margins of its comparisons."""
        if k not in self.concrete_terms:
            pre = self.terms[k].pre
            parts = [self.inputs[k].abstract[d] == self.system.ev(self.def_exprs[d], pre) for d in self.abstracted]
            parts += margins(self.system, [self.def_exprs[d] for d in self.abstracted], pre)
            self.concrete_terms[k] = z3.And(*parts)
        return self.concrete_terms[k]

    def check(self, k: int, goal: z3.BoolRef) -> z3.ModelRef | None:
        fixed = [self.make_concrete(j) for j in sorted(self.concrete_steps) if j < k]
        answer = self.solver.check(*self.active[: k + 1], z3.And(goal, self.make_concrete(k), *fixed))
        return self.solver.model() if answer == z3.sat else None

    def run_to(self, k: int, goal: z3.BoolRef) -> tuple[list[Sample], z3.ModelRef] | None:
        """A run of k + 1 steps that meets `goal`, every step made concrete, with its model."""
        for _ in range(k + 2):
            model = self.check(k, goal)
            if model is None:
                return None
            run = self.run_inputs(model, k)
            if not isinstance(run, int):
                return run, model
            self.concrete_steps.add(run)
        return None

    def run_inputs(self, model: z3.ModelRef, k: int) -> list[Sample] | int:
        """The inputs of steps 0..k with every abstracted step made concrete, or the first step that cannot be."""
        result: list[Sample] = []
        for j in range(k + 1):
            sample = self.sample(model, j)
            if j < k and self.abstracted and j not in self.concrete_steps:
                realized = self.realize(model, j)
                if realized is None:
                    return j
                sample.update(realized)
            result.append(sample)
        return result

    def sample(self, model: z3.ModelRef, j: int) -> Sample:
        return self.sample_of(model, self.inputs[j])

    def sample_of(self, model: z3.ModelRef, i: StepInputs) -> Sample:
        values: Sample = {n: bool(z3.is_true(model.eval(t, model_completion=True))) for n, t in i.bools.items()}
        for n, t in i.signals.items():
            values[n] = _number(model.eval(t, model_completion=True), self.m, n)
        return values

    def realize(self, model: z3.ModelRef, j: int) -> Sample | None:
        """Signals at step j that give each abstracted definition the value the model chose, and with the step's
        booleans as the model has them, take the spec's step from the model's context before it to its context
        after it (so every other test of the signals comes out as the model has it); a choice met once is
        reused."""
        chosen = [z3.is_true(model.eval(self.inputs[j].abstract[d], model_completion=True)) for d in self.abstracted]
        bools = [z3.is_true(model.eval(b, model_completion=True)) for b in self.inputs[j].bools.values()]
        around = [model.eval(t, model_completion=True) for t in (*self.frames[j].terms(), *self.frames[j + 1].terms())]
        key = (*chosen, *bools, *(t.sexpr() for t in around))
        if key not in self.realized:
            self.realized[key] = self._realize(chosen, bools, around)
        return self.realized[key]

    @functools.cached_property
    def _one_step(self) -> _OneStep:
        """The spec's concrete step between two fresh frames, within its assumptions and the signals' bounds,
        built once and asserted into each realization's own solver."""
        s = self.concrete
        pre, i, post = s.frame("rz0"), s.inputs("rz0"), s.frame("rz1")
        link, terms = s.step(pre, i, post)
        rules = [self.def_exprs[d] for d in self.abstracted]
        base = [link, s.assumptions(pre, i), *signal_bounds(s, i), *margins(s, rules, terms.pre)]
        return _OneStep(base, [*pre.terms(), *post.terms()], i, [s.ev(r, terms.pre) for r in rules])

    def _realize(self, chosen: list[bool], bools: list[bool], around: list[z3.ExprRef]) -> Sample | None:
        one = self._one_step
        solver = z3.Solver()
        solver.set("timeout", 20_000)
        solver.add(*one.base)
        solver.add(*[t == value for t, value in zip(one.frames, around, strict=True)])
        solver.add(*[t == value for t, value in zip(one.definitions, chosen, strict=True)])
        solver.add(*[b == value for b, value in zip(one.inputs.bools.values(), bools, strict=True)])
        if solver.check() != z3.sat:
            return None
        found = solver.model()
        return {n: _number(found.eval(t, model_completion=True), self.m, n) for n, t in one.inputs.signals.items()}


@dataclass(frozen=True)
class _OneStep:
    """One concrete step: its constraints (the margins of the definitions' comparisons among them), the terms of
    the frames before and after it, its inputs, and the abstracted definitions' rules as terms of the frame before
    it."""

    base: list[z3.BoolRef]
    frames: list[z3.ExprRef]
    inputs: StepInputs
    definitions: list[z3.ExprRef]


def _anything(conditions: list[z3.BoolRef], outcome: z3.BoolRef) -> z3.BoolRef:
    return z3.BoolVal(True)


def _opposite(value: bool) -> Extra:
    def extra(conditions: list[z3.BoolRef], outcome: z3.BoolRef) -> z3.BoolRef:
        return outcome != value

    return extra


def value_at(model: z3.ModelRef, term: z3.ExprRef) -> bool | int | float:
    return plain(model.eval(term, model_completion=True))


def plain(value: z3.ExprRef) -> bool | int | float:
    """A model's value as Python holds it; a real through its decimal expansion (z3 may answer a rational whose
    numerator has thousands of digits, which exact conversion refuses and binary64 does not need)."""
    if z3.is_rational_value(value) and not z3.is_int_value(value):
        return float(value.as_decimal(DIGITS).rstrip("?"))
    return python_value(value)


def signal_bounds(system: System, i: StepInputs) -> list[z3.BoolRef]:
    """Each sample within its range widened by the range's width on either side: outside it, but not absurdly."""
    parts = []
    for name, term in i.signals.items():
        low, high = system.signals[name].range
        kind = system.signals[name].type
        width = high - low
        parts += [term >= value_of(low - width, kind), term <= value_of(high + width, kind)]
    return parts


def frame_values(model: z3.ModelRef, f: Frame, stored: frozenset[int]) -> dict[str, bool | int | float]:
    """A frame as the generated code's context holds it: the mode, the variables, the registers it keeps
    (`stored`, see `model.stored_registers`), and `first` where one of them needs it (`MachineIR.first_flag`)."""
    values: dict[str, bool | int | float] = {"mode": value_at(model, f.mode)}
    values.update({n: value_at(model, t) for n, t in f.variables.items()})
    values.update({f"prev{k}": value_at(model, t) for k, t in f.registers.items() if k in stored})
    if stored:
        values["first"] = value_at(model, f.first)
    return values


def unkept(s: System, f: Frame, i: StepInputs, stored: frozenset[int]) -> list[z3.BoolRef]:
    """Each register the code does not keep equals its expression over the frame it belongs to: the code's
    monitor computes it from that context (a frame a run reaches satisfies this; one a search makes up must)."""
    here = s.valuation(f, i)
    return [f.registers[k] == s.ev(p.arg, here) for k, p in enumerate(s.prevs) if k not in stored]


def observed(s: System, pre: Frame, i: StepInputs, post: Frame) -> list[z3.BoolRef]:
    """Each observer after a monitor call is what the step from `pre` makes of it: the code's monitor keeps the
    observers and moves them on itself (see `model.observer_variables`), where a made-up context after the step
    could hold any value."""
    before = s.valuation(pre, i)
    fired, _ = s.fire(before)
    return [post.variables[n] == s.next_value(n, before, fired) for n in sorted(observer_variables(s.m))]


def _bool_def(machine: Machine, name: str) -> bool:
    d = next(d for d in machine.definitions if d.name == name)
    return d.type == "bool" and bool(d.signals)


def _number(term: z3.ExprRef, machine: Machine, name: str) -> int | float:
    value = plain(term)
    kind = next(s.type for s in machine.signals if s.name == name)
    return float(value) if kind == "real" else int(value)


def margins(system: System, exprs: Sequence[Expr], v: Valuation) -> list[z3.BoolRef]:
    """Each ordering comparison over reals in `exprs` kept MARGIN away from equality."""
    parts: list[z3.BoolRef] = []
    seen: set[Expr] = set()
    for e in exprs:
        for n in nodes(e):
            if isinstance(n, Cmp) and n.op in ("<", "<=", ">", ">=") and n not in seen:
                seen.add(n)
                left, right = system.unify(system.ev(n.left, v), system.ev(n.right, v))
                if z3.is_real(left):
                    gap = z3.RealVal(MARGIN)
                    parts.append(z3.Or(left - right >= gap, right - left >= gap))
    return parts


@dataclass
class Search:
    """The pairs of every objective of one machine."""

    unrolling: Unrolling

    def context(self, d: Decision, p: Point, s: System) -> z3.BoolRef:
        parts = [] if d.state is None else [s.in_states(p.pre.mode, (d.state,))]
        parts += [s.ev(e, p.pre if d.where == "pre" else p.post) for e in d.given]
        return z3.And(*parts)

    def terms(self, o: Objective, p: Point, s: System) -> tuple[z3.BoolRef, z3.BoolRef, z3.BoolRef, list[z3.BoolRef]]:
        """The condition, the outcome with it forced true and false, and every condition's value."""
        v = p.pre if o.decision.where == "pre" else p.post
        conditions = [s.ev(a, v) for a in atoms(o.decision.expr)]
        high = tree(s, o.decision.expr, v, {o.index: z3.BoolVal(True)}, [0])
        low = tree(s, o.decision.expr, v, {o.index: z3.BoolVal(False)}, [0])
        return conditions[o.index], high, low, conditions

    def goal(self, o: Objective, k: int, value: bool, extra: Extra) -> tuple[z3.BoolRef, Point]:
        p = self.unrolling.point(k)
        s = self.unrolling.system
        cond, high, low, conditions = self.terms(o, p, s)
        outcome = high if value else low
        sensitive = z3.Xor(high, low)
        return z3.And(self.context(o.decision, p, s), cond == value, sensitive, extra(conditions, outcome)), p

    def find(self, o: Objective, value: bool, extra: Extra) -> Found | None:
        """A run from the initial state, the shortest found; else, for a machine with data, one step from a
        context whose variables lie in their ranges (a counter the search cannot count up to, say)."""
        for k in range(self.unrolling.depth + 1):
            found = self.at(o, k, value, extra)
            if found is not None:
                return found
            if k + 1 == SHORT and not self.any_depth(o, value, extra, k + 1):
                break
        return self.from_context(o, value, extra) if self.unrolling.m.variables else None

    def from_context(self, o: Objective, value: bool, extra: Extra) -> Found | None:
        s = self.unrolling.concrete
        pre, i, post = s.frame("c0"), s.inputs("c0"), s.frame("c1")
        link, t = s.step(pre, i, post)
        p = Point(t.pre, t.post, 0)
        cond, high, low, conditions = self.terms(o, p, s)
        outcome = high if value else low
        solver = z3.Solver()
        solver.set("timeout", 20_000)
        solver.add(link, s.well_formed(pre), z3.Not(pre.first), s.assumptions(pre, i), *self.in_range(pre))
        solver.add(*unkept(s, pre, i, self.unrolling.stored))
        solver.add(*signal_bounds(s, i))
        solver.add(self.context(o.decision, p, s), cond == value, z3.Xor(high, low), extra(conditions, outcome))
        solver.add(*margins(s, self.read_by(o.decision), p.pre))
        if solver.check() != z3.sat:
            return None
        model = solver.model()
        values = [bool(z3.is_true(model.eval(c, model_completion=True))) for c in conditions]
        result = bool(z3.is_true(model.eval(outcome, model_completion=True)))
        start = frame_values(model, pre, self.unrolling.stored)
        return Found([self.unrolling.sample_of(model, i)], values, result, start=start)

    def read_by(self, d: Decision) -> list[Expr]:
        """The decision and every definition it reads, directly or through others."""
        defs = {x.name: x for x in self.unrolling.m.definitions}
        found: list[Expr] = [d.expr, *d.given]
        seen: set[str] = set()
        k = 0
        while k < len(found):
            for n in nodes(found[k]):
                if isinstance(n, Var) and n.name in defs and n.name not in seen:
                    seen.add(n.name)
                    found.append(defs[n.name].expr)
            k += 1
        return found

    def in_range(self, f: Frame) -> list[z3.BoolRef]:
        parts = []
        for v in self.unrolling.m.variables:
            if v.range is not None:
                term = f.variables[v.name]
                parts += [term >= value_of(v.range[0], v.type), term <= value_of(v.range[1], v.type)]
        return parts

    def any_depth(self, o: Objective, value: bool, extra: Extra, low: int) -> bool:
        """Whether some depth from `low` on has the point at all (one query instead of one per depth)."""
        u = self.unrolling
        if low > u.depth:
            return False
        goals = [self.goal(o, k, value, extra)[0] for k in range(low, u.depth + 1)]
        answer = u.solver.check(*u.active, z3.Or(*goals))
        return bool(answer != z3.unsat)

    def at(self, o: Objective, k: int, value: bool, extra: Extra) -> Found | None:
        u = self.unrolling
        goal, p = self.goal(o, k, value, extra)
        found = u.run_to(k, goal)
        if found is None:
            return None
        run, model = found
        _, high, low, conditions = self.terms(o, p, u.system)
        values = [bool(z3.is_true(model.eval(c, model_completion=True))) for c in conditions]
        outcome = bool(z3.is_true(model.eval(high if value else low, model_completion=True)))
        return Found(run, values, outcome)

    def visit(self, state: str) -> Found | None:
        """The shortest run whose last step starts in `state` (a state no decision is evaluated in is stepped
        from too, which statement and branch coverage ask)."""
        u = self.unrolling
        for k in range(u.depth + 1):
            found = u.run_to(k, u.system.in_states(u.point(k).pre.mode, (state,)))
            if found is not None:
                return Found(found[0], [], True)
        return None

    def free_point(self) -> tuple[Frame, StepInputs, Frame, Point, z3.BoolRef]:
        """A monitor call on any context: frames before and after that no step need link."""
        s = self.unrolling.concrete
        pre, i, post = s.frame("m0"), s.inputs("m0"), s.frame("m1")
        before = s.valuation(pre, i)
        previous = {k: z3.If(pre.first, s.ev(p.arg, before), pre.registers[k]) for k, p in enumerate(s.prevs)}
        after = Valuation(post.mode, post.variables, i, s.param_values(post), previous)
        # the context after may hold a mode that names no state (the monitor's A1 and `state_valid` see it)
        sane = [s.well_formed(pre), post.mode >= 0, post.mode <= len(s.m.states), z3.Not(post.first)]
        sane += unkept(s, pre, i, self.unrolling.stored)
        sane += observed(s, pre, i, post)
        sane += signal_bounds(s, i)
        sane += [s.param_ranges(s.param_values(post)), s.assumptions(pre, i), *self.in_range(pre), *self.in_range(post)]
        return pre, i, post, Point(before, after, 0), z3.And(*sane)

    def find_free(self, o: Objective, value: bool, extra: Extra) -> Found | None:
        s = self.unrolling.concrete
        pre, i, post, p, sane = self.free_point()
        cond, high, low, conditions = self.terms(o, p, s)
        outcome = high if value else low
        solver = z3.Solver()
        solver.set("timeout", 20_000)
        solver.add(sane, self.context(o.decision, p, s), cond == value, z3.Xor(high, low), extra(conditions, outcome))
        solver.add(*margins(s, self.read_by(o.decision), p.post))
        if solver.check() != z3.sat:
            return None
        model = solver.model()
        values = [bool(z3.is_true(model.eval(c, model_completion=True))) for c in conditions]
        outputs = {n: value_at(model, x) for n, x in s.outputs_at(p.post).items()}
        failing = tuple(v.id for v in self.unrolling.m.invariants if not value_at(model, s.ev(v.expr, p.post)))
        stored = self.unrolling.stored
        before, after = frame_values(model, pre, stored), frame_values(model, post, stored)
        shot = Snapshot(before, after, self.unrolling.sample_of(model, i), outputs, failing)
        return Found([], values, bool(z3.is_true(model.eval(outcome, model_completion=True))), shot)

    def pair(self, o: Objective) -> Pair:
        """A then B relative to it; where no B fits that A, B first and A relative to it."""
        find = self.find_free if o.decision.kind == "invariant" else self.find
        result = Pair(o)
        first = find(o, True, _anything)
        if first is None:
            result.form, result.reason = "none", self.why(o)
            return result
        result.a = first
        result.b, result.form = self.partner(find, o, first, False)
        if result.b is None:
            other = find(o, False, _anything)
            if other is not None:
                a, form = self.partner(find, o, other, True)
                if a is not None:
                    result.a, result.b, result.form = a, other, form
        if result.b is None:
            result.form, result.reason = "none", self.why(o, "false", _opposite(first.outcome))
        return result

    def partner(self, find: Finder, o: Objective, half: Found, value: bool) -> tuple[Found | None, str]:
        """The other half of a pair with `half`: unique cause first, else masking."""

        def unique(conditions: list[z3.BoolRef], outcome: z3.BoolRef) -> z3.BoolRef:
            same = [c == half.values[k] for k, c in enumerate(conditions) if k != o.index]
            return z3.And(outcome != half.outcome, *same)

        found = find(o, value, unique)
        if found is not None:
            return found, "unique cause"
        return find(o, value, _opposite(half.outcome)), "masking"

    def why(self, o: Objective, half: str = "true", extra: Extra | None = None) -> str:
        """Why a condition has no pair: the decision's form, what holds where the code evaluates it, the
        environment's assumptions, or a run longer than the search."""
        what = f"{_text(o.atom)} {half} and alone deciding {_text(o.decision.expr)}"
        if o.decision.given:
            what += " where " + " and ".join(_given(e) for e in o.decision.given)
        if extra is not None:
            what += ", the outcome opposite to the true half's"
        if self.possible(o, half == "true", True, extra):
            return f"no run of at most {self.unrolling.depth} steps from the initial state has {what}"
        if self.possible(o, half == "true", False, extra):
            names = ", ".join(f"{a.id} ({_text(a.expr)})" for a in self.unrolling.m.assumptions)
            return f"only a step that breaks the assumptions {names} has {what}"
        where = "no context before and after a step" if o.decision.kind == "invariant" else "no step in any state"
        return f"{where} has {what}"

    def possible(self, o: Objective, value: bool, assume: bool, extra: Extra | None) -> bool:
        """Whether one step from any state (a monitor call on any context) has the condition's half."""
        s = self.unrolling.concrete
        if o.decision.kind == "invariant":
            pre, i, post, p, sane = self.free_point()
            if not assume:
                sane = z3.And(s.well_formed(pre), post.mode >= 0, post.mode <= len(s.m.states))
        else:
            pre, i, post = s.frame("w0"), s.inputs("w0"), s.frame("w1")
            link, t = s.step(pre, i, post)
            p = Point(t.pre, t.post, 0)
            sane = z3.And(s.well_formed(pre), link, s.assumptions(pre, i) if assume else z3.BoolVal(True))
        cond, high, low, conditions = self.terms(o, p, s)
        solver = z3.Solver()
        solver.set("timeout", 20_000)
        solver.add(sane, self.context(o.decision, p, s), cond == value, z3.Xor(high, low))
        if extra is not None:
            solver.add(extra(conditions, high if value else low))
        return bool(solver.check() != z3.unsat)


def _text(expr: Expr) -> str:
    return show(expr)


def _given(expr: Expr) -> str:
    return f"not ({show(expr.arg)})" if isinstance(expr, Not) else show(expr)
