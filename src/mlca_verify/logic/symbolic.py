"""A machine with data as a symbolic transition system over z3 terms.

A frame is the machine between two steps: its mode (an integer, the index of its state), its variables, the
registers that `prev()` reads, the counters of bounded responses, and whether no step has been taken yet. A step
reads fresh inputs (booleans and signals), fires the first enabled transition (or none), and yields the next
frame. Guards, updates and environment assumptions are evaluated over the inputs and the frame before the step;
properties and outputs over the inputs and the frame after it.

Definitions that read only the step's inputs and params (no variable, no state) can be *abstracted*: replaced by a
fresh value at each step. The abstract system has more behaviours than the real one, so a property proved on it
holds; a counterexample found on it is only a candidate, replayed on the real system before it is reported.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from fractions import Fraction

import z3
from z3.z3 import _to_expr_ref

from mlca_verify.floats import Format
from mlca_verify.model import (
    Arith,
    BinOp,
    Call,
    Cmp,
    Const,
    Definition,
    Expr,
    Ite,
    Machine,
    Neg,
    Not,
    Num,
    Prev,
    StateIn,
    Type,
    Var,
    nodes,
    own,
    type_of,
)


def python_value(term: z3.ExprRef) -> bool | int | float:
    """A value of a z3 model as Python holds it: a bool, an int, or a float (the nearest binary64)."""
    if z3.is_true(term) or z3.is_false(term):
        return bool(z3.is_true(term))
    if z3.is_int_value(term):
        return int(str(term))
    if z3.is_rational_value(term):
        value = Fraction(term.numerator_as_long(), term.denominator_as_long())
        return int(value) if value.denominator == 1 else float(value)
    if z3.is_algebraic_value(term):
        return float(term.approx(20).as_fraction())
    return 0


def sort_of(kind: Type) -> z3.SortRef:
    return {"bool": z3.BoolSort(), "int": z3.IntSort(), "real": z3.RealSort()}[kind]


def value_of(value: Fraction, kind: Type) -> z3.ExprRef:
    if kind == "int":
        return z3.IntVal(int(value))
    return z3.RealVal(value)


@dataclass(frozen=True)
class Monitor:
    """A bounded response as a counter: consecutive steps with `assume and not goal`, saturating at `bound`."""

    name: str
    assume: Expr
    goal: Expr
    bound: Expr


@dataclass
class Frame:
    mode: z3.ArithRef
    variables: dict[str, z3.ExprRef]
    registers: dict[int, z3.ExprRef]
    counters: dict[str, z3.ArithRef]
    first: z3.BoolRef
    params: dict[str, z3.ExprRef]

    def terms(self) -> list[z3.ExprRef]:
        """Every constant of the frame, in a fixed order (the arguments of an invariant)."""
        return [
            self.mode,
            *self.variables.values(),
            *self.registers.values(),
            *self.counters.values(),
            self.first,
            *self.params.values(),
        ]

    def looped(self) -> list[z3.ExprRef]:
        """The constants a run that comes back to this frame must match: all but `first`, where no register
        reads it (a step from the first frame is then a step from any frame with its mode and values)."""
        return [t for t in self.terms() if self.registers or t is not self.first]


@dataclass
class StepInputs:
    bools: dict[str, z3.BoolRef]
    signals: dict[str, z3.ExprRef]
    abstract: dict[str, z3.ExprRef]

    def terms(self) -> list[z3.ExprRef]:
        return [*self.bools.values(), *self.signals.values(), *self.abstract.values()]


@dataclass
class Valuation:
    """A point at which expressions are evaluated: a frame's mode and variables, a step's inputs, the params;
    `previous` answers prev()."""

    mode: z3.ArithRef
    variables: Mapping[str, z3.ExprRef]
    inputs: StepInputs
    params: Mapping[str, z3.ExprRef]
    previous: Mapping[int, z3.ExprRef] = field(default_factory=dict)
    cache: dict[str, z3.ExprRef] = field(default_factory=dict)


@dataclass
class StepTerms:
    """What one step yields: the next frame's values, which transition fired, and the step's constraints."""

    fired: dict[str, z3.BoolRef]
    enabled_any: z3.BoolRef
    next_mode: z3.ArithRef
    next_variables: dict[str, z3.ExprRef]
    pre: Valuation
    post: Valuation


def variable_bounds(
    machine: Machine, variables: Mapping[str, z3.ExprRef], names: Iterable[str] | None = None
) -> list[z3.BoolRef]:
    """Each variable with a declared range (of `names`, when given) within it (the range checks prove that of
    every reachable context)."""
    bounds: list[z3.BoolRef] = []
    chosen = None if names is None else set(names)
    for v in machine.variables:
        if v.range is not None and (chosen is None or v.name in chosen):
            term = variables[v.name]
            bounds += [term >= value_of(v.range[0], v.type), term <= value_of(v.range[1], v.type)]
    return bounds


class System:
    """The transition system of `machine` for one query: the `prev()` nodes and monitors it needs, the
    definitions it abstracts, and whether params are fixed to their defaults or free within their ranges."""

    def __init__(
        self,
        machine: Machine,
        prevs: Iterable[Prev] = (),
        monitors: Iterable[Monitor] = (),
        abstract: Iterable[str] = (),
        *,
        parametric: bool = False,
        held: Format | None = None,
    ) -> None:
        self.m = machine
        self.held = held
        self.prevs = list(dict.fromkeys(prevs))
        self.prev_index = {p: i for i, p in enumerate(self.prevs)}
        self.monitors = list(monitors)
        self.abstract = [d for d in machine.definitions if d.name in set(abstract)]
        self.parametric = parametric
        self.states = {s: i for i, s in enumerate(machine.states)}
        self.defs = {d.name: d for d in machine.definitions}
        self.signals = {s.name: s for s in machine.signals}
        self.kinds: dict[str, Type] = {p.name: p.type for p in machine.params}
        self.kinds.update({v.name: v.type for v in machine.variables})
        self.kinds.update({s.name: s.type for s in machine.signals})
        self.kinds.update({d.name: d.type for d in machine.definitions})
        self.outputs = {o.name: o for o in machine.outputs}
        self.kinds.update({o.name: o.type for o in machine.outputs})
        self.shared_params = {p.name: z3.Const(f"param!{p.name}", sort_of(p.type)) for p in machine.params}
        self.prev_types = [self.type_of(p.arg) for p in self.prevs]
        self._template: tuple[Frame, StepInputs, Frame, z3.BoolRef, StepTerms] | None = None
        self._transitions: dict[str, tuple[Frame, StepInputs, Frame, z3.BoolRef, StepTerms]] = {}
        self._defaults: dict[str, z3.ExprRef] | None = None
        variables = {v.name for v in machine.variables}
        self.assumptions_read_frame = any(
            isinstance(n, StateIn) or (isinstance(n, Var) and n.name in variables)
            for a in machine.assumptions
            for n in nodes(a.expr)
        )

    # --- constants -----------------------------------------------------------------------------------

    def constant(self, value: Fraction, kind: Type) -> z3.ExprRef:
        """A literal, a param's default, an initial value or a signal's bound: exact, or (`held`) a real as a
        field or constant of the code's format holds it."""
        rounded = self.held.nearest(value) if kind == "real" and self.held is not None else None
        return value_of(value if rounded is None else rounded, kind)  # None: exact, or past the largest

    def frame(self, tag: str) -> Frame:
        m = self.m
        params: dict[str, z3.ExprRef] = {}
        if self.parametric:
            params = dict(self.shared_params)
        return Frame(
            mode=z3.Int(own(f"mode@{tag}")),
            variables={v.name: z3.Const(f"{v.name}@{tag}", sort_of(v.type)) for v in m.variables},
            registers={i: z3.Const(own(f"prev{i}@{tag}"), sort_of(t)) for i, t in enumerate(self.prev_types)},
            counters={c.name: z3.Int(own(f"{c.name}@{tag}")) for c in self.monitors},
            first=z3.Bool(own(f"first@{tag}")),
            params=params,
        )

    def inputs(self, tag: str) -> StepInputs:
        m = self.m
        return StepInputs(
            bools={i.name: z3.Bool(f"{i.name}@{tag}") for i in m.inputs},
            signals={s.name: z3.Const(f"{s.name}@{tag}", sort_of(s.type)) for s in m.signals},
            abstract={d.name: z3.Const(f"{d.name}~@{tag}", sort_of(d.type)) for d in self.abstract},
        )

    def param_values(self, frame: Frame) -> dict[str, z3.ExprRef]:
        if self.parametric:
            return frame.params
        if self._defaults is None:
            self._defaults = {p.name: self.constant(p.default, p.type) for p in self.m.params}
        return dict(self._defaults)

    def param_ranges(self, params: Mapping[str, z3.ExprRef]) -> z3.BoolRef:
        """Each param within its range (in a parametric query)."""
        parts = []
        for p in self.m.params:
            if self.parametric and p.range is not None:
                parts += [
                    params[p.name] >= value_of(p.range[0], p.type),
                    params[p.name] <= value_of(p.range[1], p.type),
                ]
        return z3.And(*parts) if parts else z3.BoolVal(True)

    # --- frames and steps ----------------------------------------------------------------------------

    def init(self, f: Frame) -> z3.BoolRef:
        parts = [f.mode == self.states[self.m.initial], f.first]
        parts += [f.variables[v.name] == self.constant(v.initial, v.type) for v in self.m.variables]
        parts += [c == 0 for c in f.counters.values()]
        parts.append(self.param_ranges(self.param_values(f)))
        return z3.And(*parts)

    def well_formed(self, f: Frame) -> z3.BoolRef:
        """What every frame satisfies by construction: a mode that names a state, params in their ranges."""
        parts = [f.mode >= 0, f.mode < len(self.m.states), self.param_ranges(self.param_values(f))]
        return z3.And(*parts)

    def valuation(self, f: Frame, i: StepInputs, previous: Mapping[int, z3.ExprRef] | None = None) -> Valuation:
        return Valuation(f.mode, f.variables, i, self.param_values(f), previous or {})

    def step(self, pre: Frame, i: StepInputs, post: Frame) -> tuple[z3.BoolRef, StepTerms]:
        """The constraint linking `pre` to `post` under inputs `i`, with the step's terms: built once over
        placeholder constants, then instantiated by substitution (z3 does that far faster than rebuilding)."""
        if self._template is None:
            slots = (self.frame("T!0"), self.inputs("T!0"), self.frame("T!1"))
            self._template = (*slots, *self.build_step(*slots))
        t_pre, t_in, t_post, link, terms = self._template
        pairs: dict[int, tuple[z3.ExprRef, z3.ExprRef]] = {}
        for old, new in zip(
            [*t_pre.terms(), *t_in.terms(), *t_post.terms()], [*pre.terms(), *i.terms(), *post.terms()], strict=True
        ):
            pairs.setdefault(old.get_id(), (old, new))
        sub = substitution(list(pairs.values()))

        def moved(v: Valuation, frame: Frame) -> Valuation:
            previous = {k: sub(x) for k, x in v.previous.items()}
            cache = {k: sub(x) for k, x in v.cache.items()}
            return Valuation(frame.mode, frame.variables, i, self.param_values(frame), previous, cache)

        return sub(link), StepTerms(
            {k: sub(x) for k, x in terms.fired.items()},
            sub(terms.enabled_any),
            sub(terms.next_mode),
            {k: sub(x) for k, x in terms.next_variables.items()},
            moved(terms.pre, pre),
            moved(terms.post, post),
        )

    def transition(self, tag: str) -> tuple[Frame, StepInputs, Frame, z3.BoolRef, StepTerms]:
        """Frames `{tag}0` and `{tag}1`, the inputs between them and the step that links them, made once per tag
        (the one-step queries of proofs and certificates ask for the same tags again and again)."""
        if tag not in self._transitions:
            pre, i, post = self.frame(f"{tag}0"), self.inputs(f"{tag}0"), self.frame(f"{tag}1")
            self._transitions[tag] = (pre, i, post, *self.step(pre, i, post))
        return self._transitions[tag]

    def build_step(self, pre: Frame, i: StepInputs, post: Frame) -> tuple[z3.BoolRef, StepTerms]:
        before = self.valuation(pre, i)
        fired, enabled_any = self.fire(before)
        next_mode: z3.ArithRef = z3.IntVal(0) + pre.mode
        for t in reversed(self.m.transitions):
            next_mode = z3.If(fired[t.id], z3.IntVal(self.states[t.target]), next_mode)
        next_vars = {v.name: self.next_value(v.name, before, fired) for v in self.m.variables}
        parts = [post.mode == next_mode, z3.Not(post.first)]
        parts += [post.variables[n] == value for n, value in next_vars.items()]
        if self.m.otherwise == "undefined":
            parts.append(enabled_any)
        previous = {k: z3.If(pre.first, self.ev(p.arg, before), pre.registers[k]) for k, p in enumerate(self.prevs)}
        after = Valuation(post.mode, post.variables, i, self.param_values(post), previous)
        parts += [post.registers[k] == self.ev(p.arg, after) for k, p in enumerate(self.prevs)]
        for c in self.monitors:
            bound = self.ev(c.bound, after)
            waiting = z3.And(self.ev(c.assume, after), z3.Not(self.ev(c.goal, after)))
            count = z3.If(pre.counters[c.name] + 1 > bound, bound, pre.counters[c.name] + 1)
            parts.append(post.counters[c.name] == z3.If(waiting, count, 0))
        if self.parametric:
            parts += [post.params[n] == pre.params[n] for n in pre.params]
        return z3.And(*parts), StepTerms(fired, enabled_any, next_mode, next_vars, before, after)

    def fire(self, before: Valuation) -> tuple[dict[str, z3.BoolRef], z3.BoolRef]:
        """First match: a transition fires when it applies to the mode, its guard holds, and no earlier one fired."""
        fired: dict[str, z3.BoolRef] = {}
        taken: z3.BoolRef = z3.BoolVal(False)
        for t in self.m.transitions:
            where = z3.BoolVal(True) if t.sources is None else self.in_states(before.mode, t.sources)
            enabled = z3.And(where, self.ev(t.guard, before))
            fired[t.id] = z3.And(enabled, z3.Not(taken))
            taken = z3.Or(taken, enabled)
        return fired, taken

    def next_value(self, name: str, before: Valuation, fired: Mapping[str, z3.BoolRef]) -> z3.ExprRef:
        variable = next(v for v in self.m.variables if v.name == name)
        value = self.ev(variable.every, before) if variable.every is not None else before.variables[name]
        for t in reversed(self.m.transitions):
            for u in t.updates:
                if u.variable == name:
                    value = z3.If(fired[t.id], self.ev(u.expr, before), value)
        return self.coerce(value, variable.type)

    def assumptions(self, pre: Frame, i: StepInputs) -> z3.BoolRef:
        before = self.valuation(pre, i)
        return z3.And(*[self.ev(a.expr, before) for a in self.m.assumptions])

    def in_states(self, mode: z3.ArithRef, states: Iterable[str]) -> z3.BoolRef:
        return z3.Or(*[mode == self.states[s] for s in states])

    def outputs_at(self, post: Valuation) -> dict[str, z3.ExprRef]:
        return {o.name: self.ev(o.expr, post) for o in self.m.outputs}

    # --- expressions ---------------------------------------------------------------------------------

    def coerce(self, term: z3.ExprRef, kind: Type) -> z3.ExprRef:
        if kind == "real" and z3.is_int(term):
            return z3.ToReal(term)
        return term

    def type_of(self, expr: Expr) -> Type:
        return type_of(expr, self.kinds)

    def valid(self, name: str, v: Valuation) -> z3.BoolRef:
        low, high = self.signals[name].range
        kind = self.signals[name].type
        x = v.inputs.signals[name]
        return z3.And(x >= self.constant(low, kind), x <= self.constant(high, kind))

    def ev(self, expr: Expr, v: Valuation) -> z3.ExprRef:
        """The z3 term of `expr` at valuation `v`."""
        if isinstance(expr, Const):
            return z3.BoolVal(expr.value)
        if isinstance(expr, Num):
            return self.constant(expr.value, "real" if expr.real or expr.value.denominator != 1 else "int")
        if isinstance(expr, Var):
            return self.name(expr.name, v)
        if isinstance(expr, StateIn):
            return self.in_states(v.mode, expr.states)
        if isinstance(expr, Not):
            return z3.Not(self.ev(expr.arg, v))
        if isinstance(expr, BinOp):
            a, b = self.ev(expr.left, v), self.ev(expr.right, v)
            return {"and": z3.And, "or": z3.Or, "->": z3.Implies, "<->": lambda x, y: x == y}[expr.op](a, b)
        if isinstance(expr, Prev):
            return v.previous[self.prev_index[expr]]
        return self.ev_data(expr, v)

    def ev_data(self, expr: Expr, v: Valuation) -> z3.ExprRef:
        if isinstance(expr, Neg):
            return -self.ev(expr.arg, v)
        if isinstance(expr, Ite):
            kind = self.type_of(expr)
            then, other = (self.coerce(self.ev(e, v), kind) for e in (expr.then, expr.other))
            return z3.If(self.ev(expr.cond, v), then, other)
        if isinstance(expr, Call):
            return self.call(expr, v)
        if isinstance(expr, Cmp):
            a, b = self.ev(expr.left, v), self.ev(expr.right, v)
            return compare(expr.op, *self.unify(a, b))
        assert isinstance(expr, Arith)
        a, b = self.unify(self.ev(expr.left, v), self.ev(expr.right, v))
        if expr.op == "/":
            return z3.ToReal(a) / z3.ToReal(b) if z3.is_int(a) else a / b
        return {"+": a + b, "-": a - b, "*": a * b}[expr.op]

    def unify(self, a: z3.ExprRef, b: z3.ExprRef) -> tuple[z3.ExprRef, z3.ExprRef]:
        if z3.is_bool(a) or z3.is_bool(b):
            return a, b
        if z3.is_real(a) and z3.is_int(b):
            return a, z3.ToReal(b)
        if z3.is_int(a) and z3.is_real(b):
            return z3.ToReal(a), b
        return a, b

    def call(self, expr: Call, v: Valuation) -> z3.ExprRef:
        if expr.fn == "valid":
            arg = expr.args[0]
            assert isinstance(arg, Var)
            return self.valid(arg.name, v)
        kind = self.type_of(expr)
        args = [self.coerce(self.ev(a, v), kind) for a in expr.args]
        if expr.fn == "abs":
            return z3.If(args[0] >= 0, args[0], -args[0])
        result = args[0]
        for a in args[1:]:
            result = z3.If(a < result, a, result) if expr.fn == "min" else z3.If(a > result, a, result)
        return result

    def name(self, name: str, v: Valuation) -> z3.ExprRef:
        if name in v.inputs.bools:
            return v.inputs.bools[name]
        if name in v.inputs.signals:
            return v.inputs.signals[name]
        if name in v.params:
            return v.params[name]
        if name in v.variables:
            return v.variables[name]
        if name in v.cache:
            return v.cache[name]
        d = self.defs.get(name)
        value = self.definition(d, v) if d is not None else self.ev(self.outputs[name].expr, v)
        v.cache[name] = value
        return value

    def definition(self, d: Definition, v: Valuation) -> z3.ExprRef:
        if d.name in v.inputs.abstract:
            return v.inputs.abstract[d.name]
        value = self.coerce(self.ev(d.expr, v), d.type)
        if d.type == "bool" and d.signals:
            return z3.If(z3.And(*[self.valid(s, v) for s in d.signals]), value, z3.BoolVal(d.if_invalid))
        return value


def compare(op: str, a: z3.ExprRef, b: z3.ExprRef) -> z3.ExprRef:
    """`a op b`, built for that operator alone (booleans have `==` and `!=` but no order)."""
    if op == "==":
        return a == b
    if op == "!=":
        return a != b
    ops: dict[str, Callable[[z3.ExprRef, z3.ExprRef], z3.ExprRef]] = {
        "<": lambda x, y: x < y,
        "<=": lambda x, y: x <= y,
        ">": lambda x, y: x > y,
        ">=": lambda x, y: x >= y,
    }
    return ops[op](a, b)


def substitution(pairs: list[tuple[z3.ExprRef, z3.ExprRef]]) -> Callable[[z3.ExprRef], z3.ExprRef]:
    """A function replacing each `old` by its `new` in a term; the pair arrays are built once for every call
    (z3.substitute rebuilds them each time, which dominates when a step has many terms)."""
    count = len(pairs)
    sources = (z3.Ast * count)()
    targets = (z3.Ast * count)()
    for k, (old, new) in enumerate(pairs):
        sources[k], targets[k] = old.as_ast(), new.as_ast()

    def apply(term: z3.ExprRef) -> z3.ExprRef:
        ctx = term.ctx
        return _to_expr_ref(z3.z3core.Z3_substitute(ctx.ref(), term.as_ast(), count, sources, targets), ctx)

    return apply


def input_only(machine: Machine) -> frozenset[str]:
    """Definitions whose value depends only on the step's inputs, signals and params: they may be abstracted."""
    state_bound = {v.name for v in machine.variables}
    result: set[str] = set()
    changed = True
    candidates = {d.name: d for d in machine.definitions}
    while changed:
        changed = False
        for name, d in candidates.items():
            if name in result:
                continue
            reads = {n.name for n in nodes(d.expr) if isinstance(n, Var)}
            if any(isinstance(n, StateIn) for n in nodes(d.expr)) or reads & state_bound:
                continue
            if all(r not in candidates or r in result for r in reads):
                result.add(name)
                changed = True
    return frozenset(result)
