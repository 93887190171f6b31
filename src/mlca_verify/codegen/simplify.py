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
from mlca_verify.model import BinOp, Const, Expr


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


def in_context(guards: list[Expr], solver: Solver) -> list[Expr]:
    """The code condition of each guard of one state's first-match chain."""
    result = []
    for index, guard in enumerate(guards):
        context = [z3.Not(encode(g, solver.vars)) for g in guards[:index]]
        kept = conjuncts(guard)
        for part in list(kept):
            rest = [encode(p, solver.vars) for p in kept if p is not part]
            if solver.check(z3.And(*context, *rest, z3.Not(encode(part, solver.vars)))) == "unsat":
                kept = [p for p in kept if p is not part]
        result.append(conjoin(kept))
    return result
