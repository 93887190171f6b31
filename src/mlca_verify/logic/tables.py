"""Conditions over many guards of one state, kept small: "no earlier guard holds" and "some later guard holds".

Written out, the first-match condition of the i-th transition conjoins the negations of all i earlier guards, so
a state with n transitions gives formulas of total size n^2 and every query on them grows with n. Over the few
inputs its guards read, any such condition is one boolean function, whatever n: here it is computed as a truth
table (a Python int, one bit per input valuation) and written back as a z3 term by Shannon expansion (a reduced
decision diagram), which depends on the function only and whose shared nodes are built once. The terms are
exactly equivalent to the conjunctions they replace, so every answer and every witness stays the same.

Above `MAX_TABLE_INPUTS` inputs a truth table is too large: the conditions are then written out, which is only
done for states with at most `MAX_WRITTEN_OUT` transitions.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import z3

from mlca_verify.errors import SpecError
from mlca_verify.model import BinOp, Const, Expr, Machine, Not, Transition, Var, inputs_of

MAX_TABLE_INPUTS = 16  # 2^16 bits (8 KiB) per table
MAX_WRITTEN_OUT = 100  # transitions of one state whose guards read more than MAX_TABLE_INPUTS inputs


class Tables:
    """Truth tables of expressions over `names`: bit `a` of a table is the value under valuation `a`, in which
    input `names[i]` is bit `i` of `a`. Inputs outside `names` must not occur; state tests are false, as in
    `encode` without a state."""

    def __init__(self, names: Sequence[str], vars_: Mapping[str, z3.BoolRef]) -> None:
        self.names = tuple(names)
        self.vars = [vars_[n] for n in self.names]
        self.size = 1 << len(self.names)
        self.full = (1 << self.size) - 1
        self.masks = {name: self._mask(i) for i, name in enumerate(self.names)}
        self.ones = [(1 << (1 << level)) - 1 for level in range(len(self.names) + 1)]
        self.memo: dict[tuple[int, int], z3.BoolRef] = {}

    def _mask(self, i: int) -> int:
        """The valuations in which input i is true: blocks of 2^i ones after 2^i zeros, repeated."""
        width = 1 << i
        block = ((1 << width) - 1) << width
        return self.full // ((1 << (2 * width)) - 1) * block

    def table(self, expr: Expr) -> int:
        if isinstance(expr, Const):
            return self.full if expr.value else 0
        if isinstance(expr, Var):
            return self.masks[expr.name]
        if isinstance(expr, Not):
            return self.full ^ self.table(expr.arg)
        if isinstance(expr, BinOp):
            a, b = self.table(expr.left), self.table(expr.right)
            ops = {"and": a & b, "or": a | b, "->": (self.full ^ a) | b, "<->": self.full ^ (a ^ b)}
            return ops[expr.op]
        return 0  # a state test: false, as `encode` has it without a state

    def formula(self, table: int) -> z3.BoolRef:
        return self._expand(table, len(self.names))

    def _expand(self, table: int, level: int) -> z3.BoolRef:
        """The term of a table over the first `level` inputs, splitting on the last of them."""
        if table == 0:
            return z3.BoolVal(False)
        if table == self.ones[level]:
            return z3.BoolVal(True)
        key = (level, table)
        if key not in self.memo:
            half = 1 << (level - 1)
            high, low = table >> half, table & ((1 << half) - 1)
            if high == low:
                self.memo[key] = self._expand(low, level - 1)
            else:
                var = self.vars[level - 1]
                self.memo[key] = z3.If(var, self._expand(high, level - 1), self._expand(low, level - 1))
        return self.memo[key]


def _read_names(machine: Machine, guards: Sequence[Expr]) -> list[str]:
    used = frozenset().union(*[inputs_of(g) for g in guards])
    return [n for n in machine.input_names if n in used]


def check_size(machine: Machine, state: str, guards: Sequence[Expr]) -> None:
    """Refuse a state whose conditions can be neither tabulated nor written out in bounded time."""
    read = _read_names(machine, guards)
    if len(read) > MAX_TABLE_INPUTS and len(guards) > MAX_WRITTEN_OUT:
        raise SpecError(
            machine.loc,
            f"state {state} has {len(guards)} transitions whose guards read {len(read)} inputs; at most "
            f"{MAX_WRITTEN_OUT} transitions are supported in a state whose guards read more than "
            f"{MAX_TABLE_INPUTS} inputs",
        )


def tables_for(machine: Machine, guards: Sequence[Expr], vars_: Mapping[str, z3.BoolRef]) -> Tables | None:
    """Truth tables over the inputs `guards` read, or None when they read more than `MAX_TABLE_INPUTS`."""
    read = _read_names(machine, guards)
    return Tables(read, vars_) if len(read) <= MAX_TABLE_INPUTS else None


def remaining(tables: Tables, guards: Sequence[Expr]) -> list[int]:
    """For i = 0..n, the table of the valuations under which none of the first i guards holds."""
    result = [tables.full]
    for guard in guards:
        result.append(result[-1] & (tables.full ^ tables.table(guard)))
    return result


def firing(tables: Tables, guards: Sequence[Expr]) -> list[int]:
    """The table of the valuations under which each guard is the first that holds."""
    return [tables.table(g) & r for g, r in zip(guards, remaining(tables, guards), strict=False)]


def none_before(
    machine: Machine, state: str, guards: Sequence[Expr], encoded: Sequence[z3.BoolRef], vars_: Mapping[str, z3.BoolRef]
) -> list[z3.BoolRef]:
    """For i = 0..n, the condition that none of the first i guards holds (the last: none holds at all)."""
    check_size(machine, state, guards)
    tables = tables_for(machine, guards, vars_)
    if tables is None:
        return [z3.And(*[z3.Not(e) for e in encoded[:i]]) if i else z3.BoolVal(True) for i in range(len(encoded) + 1)]
    return [tables.formula(table) for table in remaining(tables, guards)]


def later_elsewhere(
    machine: Machine,
    state: str,
    out: Sequence[Transition],
    encoded: Sequence[z3.BoolRef],
    vars_: Mapping[str, z3.BoolRef],
) -> list[z3.BoolRef]:
    """For each transition, the condition that some later one with another target is enabled."""
    guards = [t.guard for t in out]
    check_size(machine, state, guards)
    tables = tables_for(machine, guards, vars_)
    if tables is None:
        return [
            _any([e for u, e in zip(out[i + 1 :], encoded[i + 1 :], strict=True) if u.target != t.target])
            for i, t in enumerate(out)
        ]
    later: dict[str, int] = {}
    result = []
    for t in reversed(out):
        result.append(tables.formula(_union(v for target, v in later.items() if target != t.target)))
        later[t.target] = later.get(t.target, 0) | tables.table(t.guard)
    return result[::-1]


def _union(tables: Iterable[int]) -> int:
    result = 0
    for table in tables:
        result |= table
    return result


def _any(formulas: list[z3.BoolRef]) -> z3.BoolRef:
    return z3.Or(*formulas) if formulas else z3.BoolVal(False)
