"""Conjunctions and disjunctions of expressions: split into their parts, and joined back."""

from __future__ import annotations

from typing import Literal

from mlca_verify.model import BinOp, Const, Expr


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
