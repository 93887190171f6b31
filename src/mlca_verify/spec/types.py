"""Types and units of expressions, checked at load time (pure: no I/O, no solver).

Types are `bool`, `int` and `real`; an `int` meets a `real` as a `real`. Units are products of named base units
with integer exponents (`m/s^2`); `+`, `-`, comparisons, `min`, `max` and the branches of `if` need equal units,
`*` and `/` combine them. A literal number takes the unit its context needs.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

from mlca_verify.model import (
    Arith,
    BinOp,
    Call,
    Cmp,
    Const,
    Expr,
    Ite,
    Neg,
    Not,
    Num,
    Prev,
    StateIn,
    Type,
    Unit,
    Var,
)

Kind = str  # "input", "param", "signal", "variable", "definition", "output"
UNIT_LIMIT = 64  # characters of a unit
_FACTOR = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)(?:\^(-?[0-9]{1,2}))?")


class TypeProblem(Exception):
    """A type or unit error at a 0-based offset of the expression text."""

    def __init__(self, offset: int, message: str) -> None:
        super().__init__(message)
        self.offset = offset
        self.message = message


@dataclass(frozen=True)
class Symbol:
    kind: Kind
    type: Type
    unit: Unit
    tainted: bool = False  # a numeric definition that reads a signal: its value is unspecified when one is invalid


def parse_unit(text: str) -> Unit | None:
    """`m/s^2` as (("m", 1), ("s", -2)); `1` or "" is dimensionless; None when the text is not a unit."""
    text = text.replace(" ", "")
    if text in ("", "1"):
        return ()
    if len(text) > UNIT_LIMIT:
        return None
    powers: dict[str, int] = {}
    sign, pos = 1, 0
    while True:
        m = _FACTOR.match(text, pos)
        if m is None:
            return None
        powers[m.group(1)] = powers.get(m.group(1), 0) + sign * int(m.group(2) or 1)
        pos = m.end()
        if pos == len(text):
            return tuple(sorted((b, e) for b, e in powers.items() if e))
        if text[pos] not in "*/":
            return None
        sign = 1 if text[pos] == "*" else -1
        pos += 1


def show_unit(unit: Unit | None) -> str:
    if not unit:
        return "1"
    up = [b if e == 1 else f"{b}^{e}" for b, e in unit if e > 0]
    down = [b if e == -1 else f"{b}^{-e}" for b, e in unit if e < 0]
    text = "*".join(up) or "1"
    return text + ("/" + "/".join(down) if down else "")


def _combine(a: Unit | None, b: Unit | None, sign: int) -> Unit | None:
    if a is None and b is None:
        return None
    powers = dict(a or ())
    for base, exp in b or ():
        powers[base] = powers.get(base, 0) + sign * exp
    return tuple(sorted((base, e) for base, e in powers.items() if e))


Typed = tuple[Type, Unit | None]


class TypeChecker:
    """Types one expression against a table of symbols; `offsets` maps node ids to their text offsets."""

    def __init__(self, env: Mapping[str, Symbol], offsets: Mapping[int, int]) -> None:
        self.env = env
        self.offsets = offsets

    def at(self, node: Expr) -> int:
        return self.offsets.get(id(node), 0)

    def fail(self, node: Expr, message: str) -> TypeProblem:
        return TypeProblem(self.at(node), message)

    def check(self, expr: Expr) -> Typed:
        if isinstance(expr, Const | StateIn):
            return "bool", ()
        if isinstance(expr, Num):
            return ("real" if expr.real or expr.value.denominator != 1 else "int"), None
        if isinstance(expr, Var):
            symbol = self.env[expr.name]
            return symbol.type, symbol.unit
        if isinstance(expr, Not):
            self.boolean(expr.arg, "'not'")
            return "bool", ()
        if isinstance(expr, BinOp):
            self.boolean(expr.left, f"'{expr.op}'")
            self.boolean(expr.right, f"'{expr.op}'")
            return "bool", ()
        if isinstance(expr, Prev):
            return self.check(expr.arg)
        return self.data(expr)

    def data(self, expr: Expr) -> Typed:
        if isinstance(expr, Neg):
            return self.numeric(expr.arg, "'-'")
        if isinstance(expr, Arith):
            return self.arith(expr)
        if isinstance(expr, Cmp):
            return self.comparison(expr)
        if isinstance(expr, Ite):
            self.boolean(expr.cond, "'if'")
            return self.same(expr, [expr.then, expr.other], "the branches of 'if'", allow_bool=True)
        assert isinstance(expr, Call)
        if expr.fn == "valid":
            return "bool", ()
        if expr.fn == "abs":
            return self.numeric(expr.args[0], "abs()")
        return self.same(expr, list(expr.args), f"the arguments of {expr.fn}()", allow_bool=False)

    def boolean(self, node: Expr, where: str) -> None:
        found, _ = self.check(node)
        if found != "bool":
            raise self.fail(node, f"{where} needs a boolean, got {found}")

    def numeric(self, node: Expr, where: str) -> Typed:
        found, unit = self.check(node)
        if found == "bool":
            raise self.fail(node, f"{where} needs a number, got bool")
        return found, unit

    def arith(self, expr: Arith) -> Typed:
        lt, lu = self.numeric(expr.left, f"'{expr.op}'")
        rt, ru = self.numeric(expr.right, f"'{expr.op}'")
        kind: Type = "real" if "real" in (lt, rt) or expr.op == "/" else "int"
        if expr.op in "+-":
            return kind, self.unify(expr, lu, ru, f"'{expr.op}'")
        return kind, _combine(lu, ru, 1 if expr.op == "*" else -1)

    def comparison(self, expr: Cmp) -> Typed:
        lt, lu = self.check(expr.left)
        rt, ru = self.check(expr.right)
        if "bool" in (lt, rt):
            if lt != rt or expr.op not in ("==", "!="):
                raise self.fail(expr, f"'{expr.op}' cannot compare {lt} with {rt}")
            return "bool", ()
        self.unify(expr, lu, ru, f"'{expr.op}'")
        return "bool", ()

    def same(self, expr: Expr, args: list[Expr], what: str, allow_bool: bool) -> Typed:
        typed = [self.check(a) for a in args]
        kinds = {t for t, _ in typed}
        if "bool" in kinds and (not allow_bool or len(kinds) > 1):
            raise self.fail(expr, f"{what} must be numbers of one unit" + (" or all booleans" if allow_bool else ""))
        unit: Unit | None = None
        for _, u in typed:
            unit = self.unify(expr, unit, u, what)
        kind: Type = "bool" if kinds == {"bool"} else "real" if "real" in kinds else "int"
        return kind, unit

    def unify(self, node: Expr, a: Unit | None, b: Unit | None, where: str) -> Unit | None:
        if a is None:
            return b
        if b is None or a == b:
            return a
        raise self.fail(node, f"{where} mixes units {show_unit(a)} and {show_unit(b)}")


def literal_value(value: int | float) -> Fraction:
    """A TOML number, exact as written: 0.1 is one tenth."""
    return Fraction(value) if isinstance(value, int) else Fraction(repr(value))
