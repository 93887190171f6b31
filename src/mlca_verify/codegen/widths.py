"""How wide the generated code's integers are: 32-bit arithmetic where the ranges show that every value fits.

The generated C computes every int expression in one type, so that no operation mixes widths (MISRA C:2012 rules
10.4, 10.6 to 10.8). That type is `int32_t` when every field the code reads (int variables, params, signals and
outputs) is at most 32 bits wide and interval arithmetic over the declared ranges shows that every int value the
code computes (each literal, sum, product, `min`, `max`, `abs` and `if then else`, in guards, updates, definitions,
outputs and invariants) lies within 32 bits; otherwise `int64_t`. On a 32-bit core (the Cortex-M4) a 64-bit sum is
several instructions and a register pair; a timer counting to 1,000 needs neither.

An int output declared without a range takes the narrowest type that holds every value its expression can take,
when the ranges bound it (a relay's `if state == RUNNING then 1 else 0` is an `int8_t`); one they do not bound
(it reads an int signal, whose invalid samples reach the code too) stays `int64_t`.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from fractions import Fraction

from mlca_verify.intervals import Interval, enclose, machine_intervals
from mlca_verify.model import Arith, Call, Expr, Ite, Machine, Neg, Num, name_types, nodes, type_of, without_prev

INT32 = (Fraction(-(2**31)), Fraction(2**31 - 1))


def _fits(bounds: tuple[Fraction, Fraction] | None) -> bool:
    return bounds is not None and INT32[0] <= bounds[0] and bounds[1] <= INT32[1]


def code_exprs(m: Machine) -> Iterator[Expr]:
    """Every expression the generated code computes."""
    for t in m.transitions:
        yield t.guard
        yield from (u.expr for u in t.updates)
    yield from (v.every for v in m.variables if v.every is not None)
    yield from (d.expr for d in m.definitions)
    yield from (o.expr for o in m.outputs)
    yield from (i.expr for i in m.invariants)


Bounds = dict[str, tuple[Fraction, Fraction] | None]


def widths(m: Machine) -> tuple[str, Bounds]:
    """The type the code's ints compute in, and each int output's bounds, from one interval analysis."""
    names = machine_intervals(m, at_defaults=False)
    return ("int32_t" if narrow(m, names) else "int64_t"), output_bounds(m, names)


def output_bounds(m: Machine, names: Mapping[str, Interval] | None = None) -> Bounds:
    """Each int output's bounds: its declared range, else those of its expression when the ranges give them
    (`names`: `machine_intervals` of the machine, when already computed)."""
    names = machine_intervals(m, at_defaults=False) if names is None else names
    found: dict[str, tuple[Fraction, Fraction] | None] = {}
    for o in m.outputs:
        if o.type != "int":
            continue
        interval = names[o.name]
        found[o.name] = o.range or ((interval.low, interval.high) if interval.bounded() else None)  # type: ignore[assignment]
    return found


def narrow(m: Machine, names: Mapping[str, Interval] | None = None) -> bool:
    """Whether the code's int arithmetic fits `int32_t` (see the module's text)."""
    ranges = [x.range for group in (m.variables, m.params, m.signals) for x in group if x.type == "int"]
    if not all(_fits(r) for r in ranges):
        return False
    names = machine_intervals(m, at_defaults=False) if names is None else names
    if not all(_fits(b) for b in output_bounds(m, names).values()):
        return False
    kinds = name_types(m)
    computed = (Num, Arith, Neg, Call, Ite)
    for expr in code_exprs(m):
        for node in nodes(without_prev(expr)):
            is_int = isinstance(node, computed) and type_of(node, kinds) == "int"
            if is_int and not enclose(node, names).within(*INT32):
                return False
    return True
