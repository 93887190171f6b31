"""Expressions of a machine lowered to C99 and to Python with the same operations in the same order.

Both languages read one view of the machine: the context `c` (mode and variables, before or after the step), the
inputs `i` (booleans and signals) and the params `p`. A definition is a function of that view, so a guard reads
it over the context before the step and a property over the context after it. Reals are IEEE 754 binary64 in
both languages, or binary32 where the spec says so (C's `float`; in Python each operation's binary64 result, and
each real input, rounded to binary32 by `_f32`, which gives binary32's own result: 53 >= 2 * 24 + 2); `min`,
`max` and `/` go through small helpers that behave alike (Python's `/` would raise where C gives an infinity or
a NaN). A signal's validity is `lo <= x && x <= hi`, false for NaN and the infinities
without any library call.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

from mlca_verify.codegen.tidy import tidy
from mlca_verify.floats import BY_CTYPE, FORMATS, Format, shortest_single
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
    type_of,
)

INT_LIMIT = 2**31 - 1
BINARY64 = FORMATS["binary64"]
REAL_CTYPES = frozenset(BY_CTYPE)  # a field of one of these C types holds a real


def c_type(
    kind: Type, bounds: tuple[Fraction, Fraction] | None = None, ints: str = "int64_t", real: str = "double"
) -> str:
    """A value's C type: an int field whose range fits 32 bits is an `int32_t`, any other int the type the code's
    arithmetic computes in (`ints`, see `widths`); a real the format's type (`real`)."""
    if kind == "bool":
        return "bool"
    if kind == "real":
        return real
    if bounds is not None and bounds[0] >= -INT_LIMIT - 1 and bounds[1] <= INT_LIMIT:
        return "int32_t"
    return ints


def without_double_negation(e: BinOp) -> BinOp:
    """`not a -> b` as `a or b`: the code writes `a -> b` as `!a || b`, which on a negated premise reads `!!a`."""
    if e.op == "->" and isinstance(e.left, Not):
        return BinOp("or", e.left.arg, e.right)
    return e


def real_literal(value: Fraction, fmt: Format = BINARY64, lang: str = "c") -> str:
    """The value of the format nearest to `value`, written so that C and Python read the same one: in binary64
    the same text; in binary32 a C `float` constant (suffix `f`), and in Python that float's exact binary64."""
    rounded = fmt.nearest(value)
    assert rounded is not None  # the loader keeps every number within 1e15 in magnitude: no format overflows
    if fmt.name == "binary32" and lang == "c":
        return shortest_single(float(rounded)) + "f"
    text = repr(float(rounded))
    return text if any(ch in text for ch in ".en") else text + ".0"


WIDTHS = ((8, "int8_t"), (16, "int16_t"), (32, "int32_t"))


def output_type(kind: Type, bounds: tuple[Fraction, Fraction] | None, real: str = "double") -> str:
    """An output's C type: an int with a range takes the narrowest signed type that holds it."""
    if kind != "int" or bounds is None:
        return c_type(kind, real=real)
    for bits, name in WIDTHS:
        if -(2 ** (bits - 1)) <= bounds[0] and bounds[1] <= 2 ** (bits - 1) - 1:
            return name
    return "int64_t"


@dataclass(frozen=True)
class Names:
    """How each name of the machine is read: its kind and type."""

    kinds: Mapping[str, str]  # input, signal, param, variable, definition, output
    types: Mapping[str, Type]
    states: Mapping[str, int]
    prefix: str  # C prefix of the machine's functions and types
    macro: str
    ranges: Mapping[str, tuple[Fraction, Fraction]]  # of each signal
    ints: str = "int64_t"  # the type every int expression computes in (see `widths`)
    fmt: Format = BINARY64  # the format every real expression computes in

    @property
    def real(self) -> str:
        """The C type of a real."""
        return self.fmt.ctype


def names_of(m: Machine, prefix: str, macro: str, observers: frozenset[str] = frozenset()) -> Names:
    """How the code reads each name of `m`; the variables in `observers` are the monitor's (see `ir.observers`)."""
    kinds: dict[str, str] = {i.name: "input" for i in m.inputs}
    types: dict[str, Type] = {i.name: "bool" for i in m.inputs}
    for group, kind in (
        (m.signals, "signal"),
        (m.params, "param"),
        (m.variables, "variable"),
        (m.definitions, "definition"),
        (m.outputs, "output"),
    ):
        for item in group:
            kinds[item.name] = kind
            types[item.name] = item.type
    kinds.update({name: "observer" for name in observers})
    ranges = {s.name: s.range for s in m.signals}
    return Names(kinds, types, {s: k for k, s in enumerate(m.states)}, prefix, macro, ranges, fmt=FORMATS[m.reals])


class Lowering:
    """One language's text of expressions. `lang` is "c" or "py". `calls` gives, for a node of the spec (by its
    identity), the text that reads it instead: a call of the function that computes it (see `rounded`). In C, a
    definition in `once` is read from the field the step computed it into (see `codegen.once`)."""

    def __init__(
        self, names: Names, lang: str, calls: Mapping[int, str] | None = None, once: frozenset[str] = frozenset()
    ) -> None:
        self.n = names
        self.lang = lang
        self.calls = calls or {}
        self.once = once  # the definitions read from the step's fields `d->...`, computed once (see `once`)

    def type_of(self, e: Expr) -> Type:
        return type_of(e, self.n.types)

    # --- text ----------------------------------------------------------------------------------------

    def go(self, e: Expr, prevs: Mapping[Prev, str] | None = None) -> str:
        """The expression, fully parenthesised (no precedence to get wrong in either language): read through
        the function that computes it where `calls` has one, and written from what its conditions leave
        undecided (see `tidy`; the contracts too, so that WP meets the code's own terms)."""
        if self.calls and id(e) in self.calls:
            return self.calls[id(e)]
        tidied = tidy(e, self.n.types)
        return self.go(tidied, prevs) if tidied is not e else self.text(e, prevs)

    def text(self, e: Expr, prevs: Mapping[Prev, str] | None) -> str:
        """`e`'s own node in the language, its parts through `go`."""
        c = self.lang == "c"
        if isinstance(e, Const):
            return ("true" if e.value else "false") if c else ("True" if e.value else "False")
        if isinstance(e, Num):
            return self.number(e)
        if isinstance(e, Var):
            return self.name(e.name)
        if isinstance(e, StateIn):
            mode = "c->mode" if c else "c.mode"
            tests = [f"({mode} == {self.state(s)})" for s in e.states]
            return tests[0] if len(tests) == 1 else "(" + (" || " if c else " or ").join(tests) + ")"
        if isinstance(e, Not):
            return f"(!{self.go(e.arg, prevs)})" if c else f"(not {self.go(e.arg, prevs)})"
        if isinstance(e, BinOp):
            e = without_double_negation(e)
            a, b = self.go(e.left, prevs), self.go(e.right, prevs)
            if e.op == "->":
                return f"((!{a}) || {b})" if c else f"((not {a}) or {b})"
            if c and e.op == "<->":
                return self.booleans_compared(a, "==", b)
            op = {"and": "&&", "or": "||", "<->": "=="}[e.op] if c else {"and": "and", "or": "or", "<->": "=="}[e.op]
            return f"({a} {op} {b})"
        if isinstance(e, Prev):
            if prevs is None:
                raise ValueError("prev() outside a property")
            return prevs[e]
        return self.data(e, prevs)

    def data(self, e: Expr, prevs: Mapping[Prev, str] | None) -> str:
        c = self.lang == "c"
        if isinstance(e, Neg):
            if isinstance(e.arg, Num):
                return self.number(e.arg, negative=True)
            arg = self.go(e.arg, prevs)
            return f"(-{self.widened(e.arg, arg) if c and self.type_of(e) == 'int' else arg})"
        if isinstance(e, Ite):
            kind = self.type_of(e)
            cond, a, b = self.go(e.cond, prevs), self.as_type(e.then, kind, prevs), self.as_type(e.other, kind, prevs)
            if c and kind == "int":  # both sides int64_t: no int32_t field meets an int64_t (MISRA C:2012 10.8)
                a, b = self.widened(e.then, a), self.widened(e.other, b)
            return f"({cond} ? {a} : {b})" if c else f"({a} if {cond} else {b})"
        if isinstance(e, Cmp):
            both: Type | None = "real" if "real" in (self.type_of(e.left), self.type_of(e.right)) else None
            a = self.as_type(e.left, both, prevs)
            b = self.as_type(e.right, both, prevs)
            if c and self.type_of(e.left) == "bool":
                return self.booleans_compared(a, e.op, b)
            return f"({a} {e.op} {b})"
        if isinstance(e, Call):
            return self.call(e, prevs)
        assert isinstance(e, Arith)
        kind = self.type_of(e)
        a, b = self.as_type(e.left, kind, prevs), self.as_type(e.right, kind, prevs)
        if c and kind == "int" and all(isinstance(x, (Var, Prev)) for x in (e.left, e.right)):
            a = self.widened(e.left, a)  # two int32_t fields: the sum is computed in int64_t, as every int is
        if e.op == "/":
            if c:
                return f"{self.n.prefix}_div({a}, {b})"
            return f"_f32(_div({a}, {b}))" if self.single else f"_div({a}, {b})"
        if not c and kind == "real" and self.single:
            return f"_f32({a} {e.op} {b})"
        return f"({a} {e.op} {b})"

    @staticmethod
    def booleans_compared(a: str, op: str, b: str) -> str:
        """Two booleans compared in C, each side negated: cppcheck's MISRA addon reads a comparison and an `&&` or
        `||` as different essential types (rule 10.4), and two negations as one."""
        return f"((!{a}) {op} (!{b}))"

    def as_type(self, e: Expr, kind: Type | None, prevs: Mapping[Prev, str] | None) -> str:
        """`e`, converted to a double where an int meets a real (as z3's ToReal does)."""
        text = self.go(e, prevs)
        if kind == "real" and self.type_of(e) == "int":
            if isinstance(e, Num):
                return real_literal(e.value, self.n.fmt, self.lang)
            if self.lang == "c":
                return f"(({self.n.real}){text})"
            return f"_f32_int({text})" if self.single else f"float({text})"
        return text

    @property
    def single(self) -> bool:
        """Whether reals are binary32: Python then rounds each real operation's result (`_f32`)."""
        return self.n.fmt.name == "binary32"

    def widened(self, e: Expr, text: str) -> str:
        """A bare read of an int field (a variable, a param, a signal, a register: stored as int32_t where its
        range allows) as an int64_t, the type every int expression computes in."""
        if self.n.ints == "int32_t":  # every int field is an int32_t too
            return text
        return f"((int64_t){text})" if isinstance(e, (Var, Prev)) else text

    def call(self, e: Call, prevs: Mapping[Prev, str] | None) -> str:
        c = self.lang == "c"
        if e.fn == "valid":
            arg = e.args[0]
            assert isinstance(arg, Var)
            return self.valid(arg.name)
        kind = self.type_of(e)
        args = [self.as_type(a, kind, prevs) for a in e.args]
        suffix = "d" if kind == "real" else "i"
        if e.fn == "abs":
            helper = f"{self.n.prefix}_abs_{suffix}" if c else "_abs"
            return f"{helper}({args[0]})"
        helper = f"{self.n.prefix}_{e.fn}_{suffix}" if c else f"_{e.fn}"
        text = args[0]
        for a in args[1:]:
            text = f"{helper}({text}, {a})"  # as z3: the running result, then the next argument
        return text

    def valid(self, signal: str) -> str:
        """In range: false for NaN and the infinities (every comparison with NaN is false), no library call."""
        low, high = self.n.ranges[signal]
        kind = self.n.types[signal]
        fmt, lang = self.n.fmt, self.lang
        lo, hi = (real_literal(v, fmt, lang) if kind == "real" else self.number(Num(v, False)) for v in (low, high))
        x = self.name(signal)
        return f"(({lo} <= {x}) && ({x} <= {hi}))" if self.lang == "c" else f"(({lo} <= {x}) and ({x} <= {hi}))"

    def number(self, e: Num, negative: bool = False) -> str:
        """A literal; in C an int is an int64_t constant, the type of every int computation (MISRA C:2012
        rule 10.4: both operands of one essential type category; 10.6: no narrower composite assigned)."""
        value = -e.value if negative else e.value
        if e.real or value.denominator != 1:
            return real_literal(value, self.n.fmt, self.lang)
        if self.lang != "c" or self.n.ints == "int32_t":  # an int constant: 32 bits wide on both targets
            return str(int(value))
        return f"INT64_C({int(value)})"

    def state(self, s: str) -> str:
        return f"{self.n.macro}_{s}" if self.lang == "c" else f"State.{s}"

    def name(self, name: str) -> str:
        kind = self.n.kinds[name]
        c = self.lang == "c"
        if kind in ("input", "signal"):
            return f"i->{name}" if c else f"i.{name}"
        if kind == "param":
            return f"p->{name}" if c else f"p.{name}"
        if kind == "variable":
            return f"c->{name}" if c else f"c.{name}"
        if kind == "observer":  # kept by the monitor, beside the context
            return f"g->{name}" if c else f"g.{name}"
        if kind == "arg":  # an argument of a shared shape (see `shapes`)
            return name
        if kind == "definition":
            if c and name in self.once:
                return f"d->{name}"
            return f"{self.n.prefix}_def_{name}(c, i, p)" if c else f"_def_{name}(c, i, p)"
        return f"o->{name}" if c else f"o.{name}"
