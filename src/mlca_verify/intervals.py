"""Interval arithmetic over the model's numeric expressions: a sound enclosure of every value an expression can
take when each name lies in its interval. Exact (fractions); an end of None is unbounded. Pure: no I/O."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from fractions import Fraction

from mlca_verify.model import Arith, Call, Expr, Ite, Machine, Neg, Num, Var, bodies, name_types, type_of


@dataclass(frozen=True)
class Interval:
    low: Fraction | None  # None: no lower bound
    high: Fraction | None  # None: no upper bound

    @staticmethod
    def point(value: Fraction) -> Interval:
        return Interval(value, value)

    def bounded(self) -> bool:
        return self.low is not None and self.high is not None

    def magnitude(self) -> Fraction | None:
        """The largest absolute value in the interval; None when unbounded."""
        if self.low is None or self.high is None:
            return None
        return max(abs(self.low), abs(self.high))

    def within(self, low: Fraction, high: Fraction) -> bool:
        return self.low is not None and self.high is not None and low <= self.low and self.high <= high

    def hull(self, other: Interval) -> Interval:
        low = None if self.low is None or other.low is None else min(self.low, other.low)
        high = None if self.high is None or other.high is None else max(self.high, other.high)
        return Interval(low, high)

    def __str__(self) -> str:
        low = "-inf" if self.low is None else str(self.low)
        high = "inf" if self.high is None else str(self.high)
        return f"[{low}, {high}]"


UNBOUNDED = Interval(None, None)


def _add(a: Interval, b: Interval) -> Interval:
    low = None if a.low is None or b.low is None else a.low + b.low
    high = None if a.high is None or b.high is None else a.high + b.high
    return Interval(low, high)


def _neg(a: Interval) -> Interval:
    return Interval(None if a.high is None else -a.high, None if a.low is None else -a.low)


def _mul(a: Interval, b: Interval) -> Interval:
    if not (a.bounded() and b.bounded()):
        zero = Interval.point(Fraction(0))
        return zero if zero in (a, b) else UNBOUNDED
    assert a.low is not None and a.high is not None and b.low is not None and b.high is not None
    products = [a.low * b.low, a.low * b.high, a.high * b.low, a.high * b.high]
    return Interval(min(products), max(products))


def _div(a: Interval, b: Interval) -> Interval:
    if b.low is None or b.high is None or b.low <= 0 <= b.high:
        return UNBOUNDED
    return _mul(a, Interval(1 / b.high, 1 / b.low))


def _abs(a: Interval) -> Interval:
    if a.low is not None and a.low >= 0:
        return a
    if a.high is not None and a.high <= 0:
        return _neg(a)
    top = a.magnitude()
    return Interval(Fraction(0), top)


def _min(a: Interval, b: Interval) -> Interval:
    low = None if a.low is None or b.low is None else min(a.low, b.low)
    high = b.high if a.high is None else a.high if b.high is None else min(a.high, b.high)
    return Interval(low, high)


def _max(a: Interval, b: Interval) -> Interval:
    return _neg(_min(_neg(a), _neg(b)))


_ARITH: dict[str, Callable[[Interval, Interval], Interval]] = {
    "+": _add,
    "-": lambda a, b: _add(a, _neg(b)),
    "*": _mul,
    "/": _div,
}


def enclose(expr: Expr, names: Mapping[str, Interval]) -> Interval:
    """An interval holding every value of the numeric `expr` when each name lies in `names[name]` (a name not
    given is unbounded)."""
    if isinstance(expr, Num):
        return Interval.point(expr.value)
    if isinstance(expr, Var):
        return names.get(expr.name, UNBOUNDED)
    if isinstance(expr, Neg):
        return _neg(enclose(expr.arg, names))
    if isinstance(expr, Arith):
        return _ARITH[expr.op](enclose(expr.left, names), enclose(expr.right, names))
    if isinstance(expr, Ite):
        return enclose(expr.then, names).hull(enclose(expr.other, names))
    if isinstance(expr, Call) and expr.fn in ("min", "max", "abs"):
        parts = [enclose(a, names) for a in expr.args]
        if expr.fn == "abs":
            return _abs(parts[0])
        result = parts[0]
        for part in parts[1:]:
            result = _min(result, part) if expr.fn == "min" else _max(result, part)
        return result
    return UNBOUNDED


INT64 = Interval(Fraction(-(2**63)), Fraction(2**63 - 1))  # the generated code's ints


def machine_intervals(m: Machine, at_defaults: bool) -> dict[str, Interval]:
    """Each numeric name's values as far as ranges tell: params by their ranges (or, `at_defaults`, their
    defaults), variables by their ranges (the `range:` checks show that every step keeps them), int signals
    anywhere in 64 bits and real ones anywhere (an invalid sample reaches the code too), definitions and outputs
    by their expressions."""
    found: dict[str, Interval] = {}
    for p in m.params:
        found[p.name] = Interval(*p.range) if p.range is not None and not at_defaults else Interval.point(p.default)
    for v in m.variables:
        found[v.name] = Interval(*v.range) if v.range is not None else UNBOUNDED
    for s in m.signals:
        found[s.name] = INT64 if s.type == "int" else UNBOUNDED
    kinds = name_types(m)
    for name, body in bodies(m).items():  # definitions in dependency order, then outputs
        found[name] = enclose(body, found) if type_of(body, kinds) != "bool" else UNBOUNDED
    return found
