"""Expressions of a machine as ACSL, the logic the generated C's contracts are written in.

The logic reads the same view as the code (`lower`), but as values: the context `c`, the inputs `i` and the
params `p` are structs, not pointers. Booleans are boolean terms (read as predicates where one is due); ints are
mathematical integers (WP proves that no C operation on them overflows, so the two agree); each operation on
reals is rounded to the code's format (binary64, or binary32) with a cast, as the C computes it. A definition is
a logic function of the context, inputs and params.
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction

from mlca_verify.codegen.lower import BINARY64, Lowering, Names, names_of, real_literal, without_double_negation
from mlca_verify.floats import Format
from mlca_verify.model import (
    Arith,
    BinOp,
    Call,
    Cmp,
    Const,
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
    observer_variables,
    stateful_definitions,
)

# Every boolean is a term (ACSL's `boolean`), so that one text serves as a condition of `? :` inside a term as
# well as in a predicate: implication and equivalence, which ACSL has only between predicates, are written with
# the connectives terms have.
CONNECTIVES = {"and": "&&", "or": "||", "<->": "=="}


def context_free(m: Machine) -> frozenset[str]:
    """The definitions that read neither the mode nor a variable, directly or through other definitions: their
    logic functions take only the inputs and params, so that one value read before and after a step is
    visibly the same term (a prover cannot see it through a function without a body)."""
    stateful = stateful_definitions(m.definitions, (v.name for v in m.variables))
    return frozenset(d.name for d in m.definitions if d.name not in stateful)


class AcslLowering(Lowering):
    """ACSL text of expressions over the logic view `c`, `i`, `p` (and `o` for outputs)."""

    def __init__(
        self, names: Names, free: frozenset[str] = frozenset(), calls: Mapping[int, str] | None = None
    ) -> None:
        super().__init__(names, "acsl", calls)
        self.free = free  # the definitions that take no context (see `context_free`)

    @classmethod
    def of(cls, m: Machine, prefix: str, macro: str) -> AcslLowering:
        """The lowering of a machine's expressions, with its C names (an observer read from `g`)."""
        return cls(names_of(m, prefix, macro, observer_variables(m)), context_free(m))

    def args(self, definition: str, c: str = "c", i: str = "i", p: str = "p") -> str:
        """The arguments of a definition's logic function."""
        return f"{i}, {p}" if definition in self.free else f"{c}, {i}, {p}"

    def text(self, e: Expr, prevs: Mapping[Prev, str] | None) -> str:
        if isinstance(e, Const):
            return "\\true" if e.value else "\\false"
        if isinstance(e, Num):
            return self.number(e)
        if isinstance(e, Var):
            return self.name(e.name)
        if isinstance(e, StateIn):
            tests = [f"(c.mode == {self.state(s)})" for s in e.states]
            return tests[0] if len(tests) == 1 else "(" + " || ".join(tests) + ")"
        if isinstance(e, Not):
            return f"(!{self.go(e.arg, prevs)})"
        if isinstance(e, BinOp):
            e = without_double_negation(e)
            a, b = self.go(e.left, prevs), self.go(e.right, prevs)
            return f"((!{a}) || {b})" if e.op == "->" else f"({a} {CONNECTIVES[e.op]} {b})"
        if isinstance(e, Prev):
            if prevs is None:
                raise ValueError("prev() outside a property")
            return prevs[e]
        return self.data(e, prevs)

    def data(self, e: Expr, prevs: Mapping[Prev, str] | None) -> str:
        if isinstance(e, Neg):
            if isinstance(e.arg, Num):
                return self.number(e.arg, negative=True)
            return f"(-{self.go(e.arg, prevs)})"
        if isinstance(e, Ite):
            kind = self.type_of(e)
            cond, a, b = self.go(e.cond, prevs), self.as_type(e.then, kind, prevs), self.as_type(e.other, kind, prevs)
            return f"({cond} ? {a} : {b})"
        if isinstance(e, Cmp):
            both: Type | None = "real" if "real" in (self.type_of(e.left), self.type_of(e.right)) else None
            return f"({self.as_type(e.left, both, prevs)} {e.op} {self.as_type(e.right, both, prevs)})"
        if isinstance(e, Call):
            return self.call(e, prevs)
        assert isinstance(e, Arith)
        kind = self.type_of(e)
        a, b = self.as_type(e.left, kind, prevs), self.as_type(e.right, kind, prevs)
        return f"({self.n.real})({a} {e.op} {b})" if kind == "real" else f"({a} {e.op} {b})"

    def as_type(self, e: Expr, kind: Type | None, prevs: Mapping[Prev, str] | None) -> str:
        text = self.go(e, prevs)
        if kind == "real" and self.type_of(e) == "int":
            return self.real(Fraction(e.value), self.n.fmt) if isinstance(e, Num) else f"({self.n.real}){text}"
        return text

    def call(self, e: Call, prevs: Mapping[Prev, str] | None) -> str:
        if e.fn == "valid":
            arg = e.args[0]
            assert isinstance(arg, Var)
            return self.valid(arg.name)
        kind = self.type_of(e)
        args = [self.as_type(a, kind, prevs) for a in e.args]
        if e.fn == "abs":
            zero = "0.0" if kind == "real" else "0"
            return f"(({args[0]} >= {zero}) ? {args[0]} : (-{args[0]}))"
        op = "<" if e.fn == "min" else ">"
        text = args[0]
        for a in args[1:]:  # as the C helpers: keep the running result unless the next argument is smaller (larger)
            text = f"(({a} {op} {text}) ? {a} : {text})"
        return text

    def valid(self, signal: str) -> str:
        low, high = self.n.ranges[signal]
        kind = self.n.types[signal]
        lo, hi = (self.real(v, self.n.fmt) if kind == "real" else str(int(v)) for v in (low, high))
        x = self.name(signal)
        return f"(({lo} <= {x}) && ({x} <= {hi}))"

    def number(self, e: Num, negative: bool = False) -> str:
        value = -e.value if negative else e.value
        if e.real or value.denominator != 1:
            return self.real(value, self.n.fmt)
        return str(int(value))

    @staticmethod
    def real(value: Fraction, fmt: Format = BINARY64) -> str:
        """The value of the format the C reads for this constant: written as is when exact, else the decimal the
        C writes rounded with a cast (a binary32 constant's decimal rounds to it as C's `f` suffix does)."""
        if fmt.nearest(value) == value:
            return _decimal(value)  # ACSL reads a decimal as the exact real: this value's own digits
        text = real_literal(value, fmt).removesuffix("f")  # the real the C's decimal denotes; the cast rounds it
        return f"(({fmt.ctype}){text})"

    def state(self, s: str) -> str:
        return f"{self.n.macro}_{s}"

    def name(self, name: str) -> str:
        kind = self.n.kinds[name]
        if kind == "input":
            return f"(i.{name} != 0)"
        if kind == "signal":
            return f"i.{name}"
        if kind == "param":
            return f"p.{name}"
        if kind == "variable":
            return f"c.{name}"
        if kind == "observer":
            return f"g.{name}"
        if kind == "arg":
            return name
        if kind == "definition":
            return f"{self.n.prefix}_l_{name}({self.args(name)})"
        if self.n.types[name] == "bool":
            return f"(o.{name} != 0)"
        return f"o.{name}"


def _decimal(value: Fraction) -> str:
    """A dyadic rational's exact decimal expansion (a value of a binary format has one), with a point."""
    twos = value.denominator.bit_length() - 1  # the denominator is 2^twos
    digits = str(abs(value.numerator) * 5**twos).rjust(twos + 1, "0")
    whole, fraction = digits[: len(digits) - twos], digits[len(digits) - twos :].rstrip("0")
    return ("-" if value < 0 else "") + whole + "." + (fraction or "0")
