"""Branch conditions for code: each guard with the conjuncts dropped that the earlier branches already imply.

Under first-match semantics a branch is only reached when every earlier guard was false, so in Alg. 1 the
`N and W` of IDLE's second branch is `W` in code (the first branch took `not N`). Checkers rightly flag the
redundant test otherwise (cppcheck: knownConditionTrueFalse). Only conjuncts are dropped, and only when z3
proves them implied, so the code condition is equivalent to the spec's in its context; Frama-C WP then proves
the code against contracts written with the spec's full guards.
"""

from __future__ import annotations

import z3

from mlca_verify.logic.solver import Solver, encode
from mlca_verify.model import BinOp, Const, Expr, Not, mentions_state


def conjuncts(expr: Expr) -> list[Expr]:
    if isinstance(expr, BinOp) and expr.op == "and":
        return conjuncts(expr.left) + conjuncts(expr.right)
    return [expr]


def conjoin(parts: list[Expr]) -> Expr:
    if not parts:
        return Const(True)
    result = parts[0]
    for part in parts[1:]:
        result = BinOp("and", result, part)
    return result


def fold(expr: Expr, solver: Solver) -> Expr:
    """Replace every state-free subexpression that z3 proves constant by that constant, then tidy up.

    Compilers reject some tautologies outright (`x == x` under -Werror), and a constant is what the code means."""
    if isinstance(expr, Not):
        expr = Not(fold(expr.arg, solver))
    elif isinstance(expr, BinOp):
        expr = BinOp(expr.op, fold(expr.left, solver), fold(expr.right, solver))
    if isinstance(expr, Const) or mentions_state(expr):
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
        return Const({"and": a.value and b.value, "or": a.value or b.value,
                      "->": (not a.value) or b.value, "<->": a.value == b.value}[expr.op])  # fmt: skip
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


def in_context(guards: list[Expr], solver: Solver) -> list[Expr]:
    """The code condition of each guard of one state's first-match chain."""
    result = []
    for index, guard in enumerate(guards):
        context = [z3.Not(encode(g, solver.vars)) for g in guards[:index]]
        kept = conjuncts(fold(guard, solver))
        for part in list(kept):
            rest = [encode(p, solver.vars) for p in kept if p is not part]
            if solver.check(z3.And(*context, *rest, z3.Not(encode(part, solver.vars)))) == "unsat":
                kept = [p for p in kept if p is not part]
        result.append(fold(conjoin(kept), solver))
    return result
