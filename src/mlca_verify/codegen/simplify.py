"""Branch conditions for code: each guard with the conjuncts dropped that the earlier branches already imply.

Under first-match semantics a branch is only reached when every earlier guard was false, so in Alg. 1 the
`N and W` of IDLE's second branch is `W` in code (the first branch took `not N`). Checkers rightly flag the
redundant test otherwise (cppcheck: knownConditionTrueFalse). Only conjuncts are dropped, and only when z3
proves them implied, so the code condition is equivalent to the spec's in its context; Frama-C WP then proves
the code against contracts written with the spec's full guards.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import z3

from mlca_verify.logic.solver import Solver, encode
from mlca_verify.logic.tables import MAX_TABLE_INPUTS, Tables, none_before, remaining, tables_for
from mlca_verify.model import BinOp, Const, Expr, Machine, Not, inputs_of, mentions_state


def conjuncts(expr: Expr) -> list[Expr]:
    if isinstance(expr, BinOp) and expr.op == "and":
        return conjuncts(expr.left) + conjuncts(expr.right)
    return [expr]


def _joined(op: Literal["and", "or"], parts: list[Expr]) -> Expr:
    """The parts joined by `op`, left to right; with none, its unit (true for `and`, false for `or`)."""
    if not parts:
        return Const(op == "and")
    result = parts[0]
    for part in parts[1:]:
        result = BinOp(op, result, part)
    return result


def conjoin(parts: list[Expr]) -> Expr:
    return _joined("and", parts)


def disjoin(parts: list[Expr]) -> Expr:
    return _joined("or", parts)


def fold(expr: Expr, solver: Solver) -> Expr:
    """Replace every state-free subexpression that z3 proves constant by that constant, then tidy up.

    Compilers reject some tautologies outright (`x == x` under -Werror), and a constant is what the code means.
    A subexpression whose truth table (over few inputs) has both values is not constant: z3 is not asked."""
    names = [n for n in solver.names if n in inputs_of(expr)]
    tables = Tables(names, solver.vars) if len(names) <= MAX_TABLE_INPUTS else None
    return _fold(expr, solver, tables)


def _fold(expr: Expr, solver: Solver, tables: Tables | None) -> Expr:
    if isinstance(expr, Not):
        expr = Not(_fold(expr.arg, solver, tables))
    elif isinstance(expr, BinOp):
        expr = BinOp(expr.op, _fold(expr.left, solver, tables), _fold(expr.right, solver, tables))
    if isinstance(expr, Const) or mentions_state(expr):
        return _tidy(expr)
    if tables is not None and 0 < tables.table(expr) < tables.full:
        return _tidy(expr)
    formula = encode(expr, solver.vars)
    if solver.check(z3.Not(formula)) == "unsat":
        return Const(True)
    if solver.check(formula) == "unsat":
        return Const(False)
    return _tidy(expr)


def _tidy(expr: Expr) -> Expr:
    """Constant folding of one node whose children are already folded."""
    if isinstance(expr, Not) and isinstance(expr.arg, Const):
        return Const(not expr.arg.value)
    if not isinstance(expr, BinOp):
        return expr
    a, b = expr.left, expr.right
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(
            {
                "and": a.value and b.value,
                "or": a.value or b.value,
                "->": (not a.value) or b.value,
                "<->": a.value == b.value,
            }[expr.op]
        )
    if expr.op in ("and", "or") and a == b:  # `x or x`: cppcheck's duplicateExpression
        return a
    for const, other, first in ((a, b, True), (b, a, False)):
        if not isinstance(const, Const):
            continue
        if expr.op == "and":
            return other if const.value else Const(False)
        if expr.op == "or":
            return Const(True) if const.value else other
        if expr.op == "<->":
            return other if const.value else _tidy(Not(other))
        if first:  # const -> other
            return other if const.value else Const(True)
        return Const(True) if const.value else _tidy(Not(other))  # other -> const
    return expr


def in_context(guards: list[Expr], solver: Solver, machine: Machine, state: str) -> list[Expr]:
    """The code condition of each guard of one state's first-match chain: `false` for a guard that never holds
    where the chain reaches it (the code leaves that branch out)."""
    encoded = [encode(g, solver.vars) for g in guards]
    contexts = none_before(machine, state, guards, encoded, solver.vars)
    tables = tables_for(machine, guards, solver.vars)
    known = remaining(tables, guards) if tables is not None else [None] * len(contexts)
    return [
        Const(False)
        if solver.check(z3.And(formula, guard)) == "unsat"
        else _in_context(expr, Context(formula, tables, table), solver)
        for expr, guard, formula, table in zip(guards, encoded, contexts, known, strict=False)
    ]


@dataclass(frozen=True)
class Context:
    """Where a branch is reached: its formula and, over few inputs, its truth table."""

    formula: z3.BoolRef
    tables: Tables | None
    table: int | None

    def may_fail(self, rest: list[Expr], part: Expr) -> bool:
        """True when the truth tables show an input where the context and `rest` hold and `part` does not."""
        if self.tables is None or self.table is None:
            return False
        table = self.table & ~self.tables.table(part)
        for other in rest:
            table &= self.tables.table(other)
        return table != 0


def _in_context(guard: Expr, context: Context, solver: Solver) -> Expr:
    """Drop every conjunct of `guard` that the context and the conjuncts kept so far imply (z3 proves it)."""
    parts = conjuncts(fold(guard, solver))
    formulas = [encode(p, solver.vars) for p in parts]
    kept = list(range(len(parts)))
    for index, part in enumerate(parts):
        others = [k for k in kept if parts[k] is not part]
        if context.may_fail([parts[k] for k in others], part):
            continue
        rest = [formulas[k] for k in others]
        if solver.check(z3.And(context.formula, *rest, z3.Not(formulas[index]))) == "unsat":
            kept = [k for k in kept if parts[k] is not part]
    return fold(conjoin([parts[k] for k in kept]), solver)
