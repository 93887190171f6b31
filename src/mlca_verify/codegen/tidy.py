"""Conditions as the code writes them: what a condition's own text decides, decided before it reaches C.

A spec may hold a comparison of two constants (`3 <= 1`), a comparison or connective whose two sides are the same
expression (`d == d`, `far -> far`) or one side's negation (`a or not a`), one side holding the other
(`a or (a and b)`), a constant that reaches a connective or a choice, or a choice between two equal values. The
spec means what it says, and every engine reads it as written; but C that tests a condition whose outcome its
text fixes is refused by gcc (-Wtautological-compare) and by cppcheck (knownConditionTrueFalse,
duplicateExpression, oppositeExpression, redundantCondition, duplicateExpressionTernary).
So the code, and the contracts WP proves it against, are written from the condition with those parts decided:
the same value at every step, in exact arithmetic. Comparisons of reals are kept as written (binary64 compares
a NaN with itself as unequal). Nodes that nothing changes are the spec's own objects, so what is keyed by a
node's identity (a real computation's function, see `rounded`) still finds them.

Within one mode's chain of guards, a conjunct that the earlier guards' being false already makes true is
dropped too (`not b` after a branch on `b`): `known_false` and `without_known`.
"""

from __future__ import annotations

from collections.abc import Mapping

from mlca_verify.codegen.joins import conjoin, conjuncts
from mlca_verify.logic.concrete import COMPARE
from mlca_verify.model import BinOp, Cmp, Const, Expr, Ite, Not, Num, Type, type_of

TRUE, FALSE = Const(True), Const(False)


def _opposite(a: Expr, b: Expr) -> bool:
    return a == Not(b) or Not(a) == b


def _negated(e: Expr) -> Expr:
    if isinstance(e, Const):
        return Const(not e.value)
    return e.arg if isinstance(e, Not) else Not(e)


def _absorbs(op: str, this: Expr, other: Expr) -> bool:
    """`this op other` is `this`: `other` is a conjunction (for `or`; a disjunction for `and`) holding `this`."""
    inner = "and" if op == "or" else "or"
    return isinstance(other, BinOp) and other.op == inner and this in (other.left, other.right)


def _connective(e: BinOp, left: Expr, right: Expr) -> Expr:
    """`left op right` with what its sides decide taken out."""
    if left == right or _opposite(left, right):
        same = left == right
        return {
            "and": left if same else FALSE,
            "or": left if same else TRUE,
            "->": TRUE if same else right,
            "<->": TRUE if same else FALSE,
        }[e.op]
    for this, other, this_left in ((left, right, True), (right, left, False)):
        if e.op in ("and", "or") and _absorbs(e.op, this, other):  # a or (a and b) is a; a and (a or b) is a
            return this
        if isinstance(this, Const):
            if e.op == "and":
                return other if this.value else FALSE
            if e.op == "or":
                return TRUE if this.value else other
            if e.op == "<->":
                return other if this.value else _negated(other)
            if this_left:  # a constant premise
                return other if this.value else TRUE
            return TRUE if this.value else _negated(other)  # a constant conclusion
    if left is e.left and right is e.right:
        return e
    return BinOp(e.op, left, right)


def _comparison(e: Cmp, types: Mapping[str, Type]) -> Expr:
    if isinstance(e.left, Num) and isinstance(e.right, Num):
        return Const(COMPARE[e.op](e.left.value, e.right.value))
    exact = "real" not in (type_of(e.left, types), type_of(e.right, types))
    if exact and e.left == e.right:
        return Const(e.op in ("==", "<=", ">="))
    return e


def tidy(e: Expr, types: Mapping[str, Type]) -> Expr:
    """`e` with what its own text decides decided (see the module's docstring)."""
    if isinstance(e, Not):
        arg = tidy(e.arg, types)
        if isinstance(arg, Not):  # not not a is a
            return arg.arg
        return Const(not arg.value) if isinstance(arg, Const) else e if arg is e.arg else Not(arg)
    if isinstance(e, BinOp):
        return _connective(e, tidy(e.left, types), tidy(e.right, types))
    if isinstance(e, Cmp):
        return _comparison(e, types)
    if isinstance(e, Ite):
        cond = tidy(e.cond, types)
        if isinstance(cond, Const):
            return tidy(e.then if cond.value else e.other, types)
        if e.then == e.other:  # the same value either way
            return tidy(e.then, types)
        return e if cond is e.cond else Ite(cond, e.then, e.other)
    return e


def known_false(guard: Expr) -> list[Expr]:
    """What holds once `guard` is false: its negation, and each disjunct's (a false `a or b` is `not a`,
    `not b`; a false `not (a and b)` makes `a` and `b` true)."""
    if isinstance(guard, BinOp) and guard.op == "or":
        return [_negated(guard), *known_false(guard.left), *known_false(guard.right)]
    if isinstance(guard, Not):
        return [guard.arg, *conjuncts(guard.arg)]
    return [_negated(guard)]


def without_known(guard: Expr, known: list[Expr]) -> Expr:
    """`guard` without the conjuncts `known` holds (true if none is left)."""
    parts = conjuncts(guard)
    kept = [c for c in parts if c not in known]
    return guard if len(kept) == len(parts) else conjoin(kept)
