"""A run of a machine replayed in the generated code's arithmetic: ints exact (they fit 64 bits where every `ovf:`
check holds), reals in the machine's IEEE 754 format (binary64, or binary32: `floats`) with the code's operations
in the code's order (`min`/`max` keep the running result unless the next argument is smaller/larger, division is
IEEE's), each literal, param, signal and result rounded to the format as the code rounds it.

It confirms a witness or a counterexample the engine found over the reals: when the same inputs, given to the
code in its format, fire the same transitions, the run is one the code takes too, whatever rounding does to the
comparisons along it."""

from __future__ import annotations

import math
from collections.abc import Mapping
from fractions import Fraction

from mlca_verify.floats import FORMATS
from mlca_verify.logic.results import Counterexample
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
    StateIn,
    Var,
)

Value = bool | int | float


def _divide(a: float, b: float) -> float:
    if b != 0:
        return a / b
    if math.isnan(a) or a == 0:
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)


def _fold(fn: str, args: list[Value]) -> Value:
    result = args[0]
    for a in args[1:]:
        if (fn == "min" and a < result) or (fn == "max" and a > result):
            result = a
    return result


class Binary64:
    """The machine evaluated as its generated code evaluates it, at one step's inputs and context."""

    def __init__(self, machine: Machine) -> None:
        self.m = machine
        self.defs = {d.name: d for d in machine.definitions}
        self.signals = {s.name: s for s in machine.signals}
        self.fmt = FORMATS[machine.reals]

    def number(self, value: Fraction, real: bool) -> Value:
        return self.real(value) if real else int(value)

    def real(self, x: Value | Fraction) -> float:
        """`x` as the code holds it in its format: a float rounded, an int or a literal rounded once."""
        return self.fmt.round(x) if isinstance(x, float) else self.fmt.of(x)

    def ev(self, e: Expr, env: Mapping[str, Value], mode: str) -> Value:
        if isinstance(e, Const):
            return e.value
        if isinstance(e, Num):
            return self.number(e.value, e.real or e.value.denominator != 1)
        if isinstance(e, Var):
            return self.name(e.name, env, mode)
        if isinstance(e, StateIn):
            return mode in e.states
        if isinstance(e, Not):
            return not self.ev(e.arg, env, mode)
        if isinstance(e, BinOp):
            return self.logic(e, env, mode)
        if isinstance(e, Neg):
            return -self.ev(e.arg, env, mode)
        if isinstance(e, Ite):
            return self.ev(e.then if self.ev(e.cond, env, mode) else e.other, env, mode)
        if isinstance(e, Cmp):
            return self.compare(e, env, mode)
        if isinstance(e, Call):
            return self.call(e, env, mode)
        assert isinstance(e, Arith)
        return self.arith(e, env, mode)

    def logic(self, e: BinOp, env: Mapping[str, Value], mode: str) -> bool:
        a = bool(self.ev(e.left, env, mode))
        if e.op == "and":
            return a and bool(self.ev(e.right, env, mode))
        if e.op == "or":
            return a or bool(self.ev(e.right, env, mode))
        b = bool(self.ev(e.right, env, mode))
        return (not a or b) if e.op == "->" else a == b

    def compare(self, e: Cmp, env: Mapping[str, Value], mode: str) -> bool:
        a, b = self.ev(e.left, env, mode), self.ev(e.right, env, mode)
        if isinstance(a, float) or isinstance(b, float):
            a, b = self.real(a), self.real(b)  # the code converts an int operand to its format
        ops = {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b, "==": a == b, "!=": a != b}
        return ops[e.op]

    def arith(self, e: Arith, env: Mapping[str, Value], mode: str) -> Value:
        a, b = self.ev(e.left, env, mode), self.ev(e.right, env, mode)
        if e.op == "/":
            return self.fmt.round(_divide(self.real(a), self.real(b)))
        if isinstance(a, float) or isinstance(b, float):
            x, y = self.real(a), self.real(b)
            return self.fmt.round({"+": x + y, "-": x - y, "*": x * y}[e.op])  # binary64 then rounded once more:
        return {"+": a + b, "-": a - b, "*": a * b}[e.op]  # binary32's result, as 53 >= 2 * 24 + 2

    def call(self, e: Call, env: Mapping[str, Value], mode: str) -> Value:
        if e.fn == "valid":
            arg = e.args[0]
            assert isinstance(arg, Var)
            return self.valid(arg.name, env)
        args = [self.ev(a, env, mode) for a in e.args]
        if any(isinstance(a, float) for a in args):
            args = [self.real(a) for a in args]
        if e.fn == "abs":
            return args[0] if args[0] >= 0 else -args[0]
        return _fold(e.fn, args)

    def valid(self, name: str, env: Mapping[str, Value]) -> bool:
        s = self.signals[name]
        real = s.type == "real"
        x = env[name]
        return bool(self.number(s.range[0], real) <= x <= self.number(s.range[1], real))

    def name(self, name: str, env: Mapping[str, Value], mode: str) -> Value:
        if name in env:
            return env[name]
        return self.definition(self.defs[name], env, mode)

    def definition(self, d: Definition, env: Mapping[str, Value], mode: str) -> Value:
        if d.type == "bool" and d.signals and not all(self.valid(s, env) for s in d.signals):
            return d.if_invalid
        value = self.ev(d.expr, env, mode)
        return self.real(value) if d.type == "real" else value

    def step(self, mode: str, env: dict[str, Value]) -> tuple[str, str | None, dict[str, Value]]:
        """One step from `mode` with `env` (variables, params, the step's inputs): the next mode, the transition
        that fired (None: none), the variables after it."""
        fired = next(
            (
                t
                for t in self.m.transitions
                if (t.sources is None or mode in t.sources) and bool(self.ev(t.guard, env, mode))
            ),
            None,
        )
        after = {}
        for v in self.m.variables:
            expr = next((u.expr for u in (fired.updates if fired else ()) if u.variable == v.name), v.every)
            value = env[v.name] if expr is None else self.ev(expr, env, mode)
            after[v.name] = self.real(value) if v.type == "real" else value
        return (fired.target if fired else mode), (fired.id if fired else None), after


def follows(machine: Machine, trace: Counterexample) -> bool:
    """Does the code, given the trace's params and inputs in its format, fire the trace's transitions at every
    step?"""
    sim = Binary64(machine)
    params: dict[str, Value] = {}
    for p in machine.params:
        value = trace.params.get(p.name)
        params[p.name] = sim.number(p.default, p.type == "real") if value is None else value
        params[p.name] = sim.real(params[p.name]) if p.type == "real" else params[p.name]
    variables: dict[str, Value] = {v.name: sim.number(v.initial, v.type == "real") for v in machine.variables}
    mode = machine.initial
    for step in trace.steps:
        if step.state != mode:
            return False
        env: dict[str, Value] = {**params, **variables, **step.inputs, **_signals(sim, step.signals)}
        mode, fired, variables = sim.step(mode, env)
        if fired != step.outcome.transition or mode != step.outcome.next:
            return False
    return True


def _signals(sim: Binary64, values: Mapping[str, Value]) -> dict[str, Value]:
    kinds = {s.name: s.type for s in sim.m.signals}
    return {k: sim.real(v) if kinds.get(k) == "real" else v for k, v in values.items()}
