"""Expressions of a machine with data compiled to Python closures over exact values (ints and Fractions), for
the explicit-state engine (`explicit`).

A step's signals are real numbers, so a machine's configurations cannot be enumerated over them. But most
machines read signals only through boolean tests that read nothing of the frame (`gap >= MIN_GAP`, a gap rule
over several signals, `valid(v)`): such a test is an *atom*, and a step depends on its signals only through the
truth of its atoms. The compiler replaces each atom by a look-up in the step's atom values; anything else that
reads a signal (a variable set to a signal, a comparison of a signal with a variable) cannot be compiled
(`NotFinite`), and the symbolic engine decides what needs it.

The semantics is the symbolic engine's (`symbolic.System`): ints unbounded, reals exact, `x / y` over the reals;
a division by zero, to which z3 gives any value, stops the explicit engine (`Undecidable`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from fractions import Fraction

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
    name_types,
    nodes,
    type_of,
)

Value = bool | int | Fraction


class NotFinite(Exception):
    """An expression reads a signal other than through an atom: its steps cannot be enumerated."""


class Undecidable(Exception):
    """A value the engine's arithmetic leaves open (a division by zero) was met during the search."""


@dataclass(slots=True)
class Env:
    """Where an expression is evaluated: a frame's mode and variables, a step's boolean inputs and atom values,
    and (after a step) the values prev() reads. `cache` keeps each definition's value once computed."""

    mode: int
    variables: tuple[Value, ...]
    inputs: tuple[bool, ...]
    atoms: tuple[bool, ...]
    previous: tuple[Value, ...] = ()
    cache: dict[str, Value] = field(default_factory=dict)


Eval = Callable[[Env], Value]


def _real(x: Value) -> Value:
    return Fraction(x) if isinstance(x, int) and not isinstance(x, bool) else x


def _divide(a: Value, b: Value) -> Value:
    if b == 0:
        raise Undecidable("a divisor is zero")
    return Fraction(a) / Fraction(b)


COMPARE: dict[str, Callable[[Value, Value], bool]] = {  # each comparison of the spec, exactly
    "<": lambda a, b: a < b,
    "<=": lambda a, b: a <= b,
    ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b,
    "==": lambda a, b: a == b,
    "!=": lambda a, b: a != b,
}
_ARITH: dict[str, Callable[[Value, Value], Value]] = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": _divide,
}


class Compiler:
    """Compiles the expressions of `machine` with its params fixed to `params`; collects the atoms and the prev()
    nodes met, each given an index (the position of its value in `Env.atoms` and `Env.previous`)."""

    def __init__(self, machine: Machine, params: Mapping[str, Value]) -> None:
        self.m = machine
        self.params = dict(params)
        self.kinds: dict[str, Type] = name_types(machine)
        self.inputs = {i.name: k for k, i in enumerate(machine.inputs)}
        self.variables = {v.name: k for k, v in enumerate(machine.variables)}
        self.states = {s: k for k, s in enumerate(machine.states)}
        self.signals = {s.name for s in machine.signals}
        self.defs: dict[str, Definition] = {d.name: d for d in machine.definitions}
        self.outputs = {o.name: o.expr for o in machine.outputs}
        self.atoms: dict[Expr, int] = {}
        self.prevs: dict[Prev, int] = {}
        self._frame: dict[str, bool] = {}
        self._signal: dict[str, bool] = {}

    # --- what an expression reads --------------------------------------------------------------------

    def reads_frame(self, expr: Expr) -> bool:
        """Does `expr` read the mode, a variable or a register (directly or through definitions and outputs)?"""
        for n in nodes(expr):
            if isinstance(n, StateIn | Prev):
                return True
            if isinstance(n, Var) and self._name_reads(n.name, self._frame, self.reads_frame, self.variables):
                return True
        return False

    def reads_signal(self, expr: Expr) -> bool:
        for n in nodes(expr):
            if isinstance(n, Var) and self._name_reads(n.name, self._signal, self.reads_signal, self.signals):
                return True
        return False

    def _name_reads(
        self, name: str, memo: dict[str, bool], test: Callable[[Expr], bool], direct: Mapping[str, object] | set[str]
    ) -> bool:
        if name in direct:
            return True
        body = self.defs[name].expr if name in self.defs else self.outputs.get(name)
        if body is None:
            return False
        if name not in memo:
            memo[name] = False  # the loader rejects cycles; this only stops a second visit
            memo[name] = test(body)
        return memo[name]

    def is_atom(self, expr: Expr) -> bool:
        """A boolean test of the step's signals that reads nothing of the frame, and is not a connective (whose
        parts are compiled on their own)."""
        if isinstance(expr, Not | BinOp | Const):
            return False
        return type_of(expr, self.kinds) == "bool" and self.reads_signal(expr) and not self.reads_frame(expr)

    # --- compilation ---------------------------------------------------------------------------------

    def compile(self, expr: Expr) -> Eval:
        if self.is_atom(expr):
            k = self.atoms.setdefault(expr, len(self.atoms))
            return lambda e: e.atoms[k]
        if isinstance(expr, Const):
            value = expr.value
            return lambda e: value
        if isinstance(expr, Num):
            number: Value = expr.value if expr.real or expr.value.denominator != 1 else int(expr.value)
            return lambda e: number
        if isinstance(expr, Var):
            return self.name(expr.name)
        if isinstance(expr, StateIn):
            modes = frozenset(self.states[s] for s in expr.states)
            return lambda e: e.mode in modes
        if isinstance(expr, Prev):
            k = self.prevs.setdefault(expr, len(self.prevs))
            return lambda e: e.previous[k]
        if isinstance(expr, Not):
            arg = self.compile(expr.arg)
            return lambda e: not arg(e)
        if isinstance(expr, BinOp):
            return self.connective(expr)
        return self.data(expr)

    def connective(self, expr: BinOp) -> Eval:
        a, b = self.compile(expr.left), self.compile(expr.right)
        if expr.op == "and":
            return lambda e: bool(a(e)) and bool(b(e))
        if expr.op == "or":
            return lambda e: bool(a(e)) or bool(b(e))
        if expr.op == "->":
            return lambda e: (not a(e)) or bool(b(e))
        return lambda e: bool(a(e)) == bool(b(e))

    def data(self, expr: Expr) -> Eval:
        kind = type_of(expr, self.kinds)
        if isinstance(expr, Neg):
            arg = self.compile(expr.arg)
            return lambda e: -arg(e)
        if isinstance(expr, Ite):
            cond, then, other = self.compile(expr.cond), self.coerced(expr.then, kind), self.coerced(expr.other, kind)
            return lambda e: then(e) if cond(e) else other(e)
        if isinstance(expr, Cmp):
            left, right, test = self.compile(expr.left), self.compile(expr.right), COMPARE[expr.op]
            return lambda e: test(left(e), right(e))
        if isinstance(expr, Call):
            return self.call(expr, kind)
        if isinstance(expr, Arith):
            left, right, op = self.compile(expr.left), self.compile(expr.right), _ARITH[expr.op]
            return lambda e: op(left(e), right(e))
        raise NotFinite(f"{type(expr).__name__} cannot be evaluated here")

    def call(self, expr: Call, kind: Type) -> Eval:
        if expr.fn == "valid":  # a sample's validity reads a signal: always an atom, never here
            raise NotFinite("valid() of a signal outside an atom")
        args = [self.coerced(a, kind) for a in expr.args]
        if expr.fn == "abs":
            return _absolute(args[0])
        return _extreme(args, expr.fn == "min")

    def coerced(self, expr: Expr, kind: Type) -> Eval:
        """`expr`, as a real when `kind` is real (z3's ToReal): equal values, so only the type changes."""
        inner = self.compile(expr)
        if kind == "real" and type_of(expr, self.kinds) == "int":
            return lambda e: _real(inner(e))
        return inner

    def name(self, name: str) -> Eval:
        if name in self.inputs:
            k = self.inputs[name]
            return lambda e: e.inputs[k]
        if name in self.params:
            value = self.params[name]
            return lambda e: value
        if name in self.variables:
            k = self.variables[name]
            return lambda e: e.variables[k]
        if name in self.signals:
            raise NotFinite(f"the signal {name} is read other than through a boolean test")
        if name in self.defs:
            return self.memo(name, self.definition(self.defs[name]))
        return self.memo(name, self.compile(self.outputs[name]))

    def definition(self, d: Definition) -> Eval:
        value = self.coerced(d.expr, d.type)
        if d.type != "bool" or not d.signals:
            return value
        checks = [self.compile(Call("valid", (Var(s),))) for s in d.signals]
        fallback = d.if_invalid
        return lambda e: value(e) if all(c(e) for c in checks) else fallback

    @staticmethod
    def memo(name: str, inner: Eval) -> Eval:
        def cached(e: Env) -> Value:
            found = e.cache.get(name)
            if found is None:
                found = e.cache[name] = inner(e)
            return found

        return cached


def _absolute(arg: Eval) -> Eval:
    def run(e: Env) -> Value:
        x = arg(e)
        return -x if x < 0 else x

    return run


def _extreme(args: list[Eval], least: bool) -> Eval:
    """min or max as z3 builds it (a later argument replaces the result only when strictly beyond it)."""

    def run(e: Env) -> Value:
        result = args[0](e)
        for f in args[1:]:
            x = f(e)
            if (x < result) if least else (x > result):
                result = x
        return result

    return run


class Sampled(Compiler):
    """The compiler with each signal fixed to one sample (an input class's witness): an expression that reads
    both the frame and a signal's value, as an output computed from samples does, evaluates over the frame alone.
    It makes no atoms: every test of the samples is a constant."""

    def __init__(self, machine: Machine, params: Mapping[str, Value], samples: Mapping[str, Value]) -> None:
        super().__init__(machine, params)
        self.samples = dict(samples)
        self.ranges = {s.name: s.range for s in machine.signals}

    def is_atom(self, expr: Expr) -> bool:
        return False

    def name(self, name: str) -> Eval:
        if name in self.samples:
            value = self.samples[name]
            return lambda e: value
        return super().name(name)

    def call(self, expr: Call, kind: Type) -> Eval:
        if expr.fn == "valid" and isinstance(expr.args[0], Var):
            low, high = self.ranges[expr.args[0].name]
            ok = low <= self.samples[expr.args[0].name] <= high
            return lambda e: ok
        return super().call(expr, kind)


def param_values(machine: Machine) -> dict[str, Value]:
    """Each param at its default, as an exact value of its type."""
    return {p.name: (int(p.default) if p.type == "int" else p.default) for p in machine.params}
