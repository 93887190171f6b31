"""Conditions as the code writes them: what a condition's own text decides, decided before it reaches C.

A spec may hold a comparison of two constants (`3 <= 1`), a comparison or connective whose two sides are the same
expression (`d == d`, `far -> far`; of ints, also but for a constant added: `c >= c + 1`) or one side's negation
(`a or not a`), one side holding the other (`a or (a and b)`) or repeated in a chain (`a or (a or b)`), a
constant that reaches a connective or a choice, a choice between two equal values, an int minus itself
(`c - c`), or `abs`, `min` or `max` of numbers. The spec
means what it says, and every engine reads it as written; but C that tests a condition whose outcome its text
fixes is refused by gcc (-Wtautological-compare) and by cppcheck (knownConditionTrueFalse, duplicateExpression,
oppositeExpression, redundantCondition, duplicateExpressionTernary). A choice on a negation is written the other
way round (`if not a then x else y` as `if a then y else x`): clang's MC/DC records no test vector of a `?:`
whose condition is a `!`, so a suite that pairs its conditions would show them unpaired.
So the code, and the contracts WP proves it against, are written from the condition with those parts decided:
the same value at every step, in exact arithmetic. Comparisons of reals are kept as written (binary64 compares
a NaN with itself as unequal). Nodes that nothing changes are the spec's own objects, so what is keyed by a
node's identity (a real computation's function, see `rounded`) still finds them.

Within one mode's chain of guards, a conjunct that the earlier guards' being false already makes true is
dropped too (`not b` after a branch on `b`), and a part they decide deeper in the guard is decided (of ints,
also a comparison of the same two sides as a decided one: `c <= d` where `c != d` is false):
`known_false`, `without_known` and `with_known`. Within a condition the same is done to the right side of a
connective, which C reads only where the left side decides it must (`!a || (a && b)` is `!a || b`); that
also writes a side repeated in a chain once (`a or (a or b)` is `a or b`, `(a or b) or a` is `a or b`).
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction

from mlca_verify.codegen.joins import conjoin, conjuncts
from mlca_verify.logic.concrete import COMPARE
from mlca_verify.model import Arith, BinOp, Call, Cmp, Const, Expr, Ite, Not, Num, StateIn, Type, type_of

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


def _modes_of(e: Expr) -> tuple[bool, tuple[str, ...]] | None:
    """A test of the mode, `state in {...}` or its negation: whether it is negated, and its modes."""
    if isinstance(e, StateIn):
        return False, e.states
    if isinstance(e, Not) and isinstance(e.arg, StateIn):
        return True, e.arg.states
    return None


def _mode_test(negated: bool, states: tuple[str, ...]) -> Expr:
    if not states:
        return TRUE if negated else FALSE
    return Not(StateIn(states)) if negated else StateIn(states)


def _modes_joined(op: str, left: Expr, right: Expr) -> Expr | None:
    """Two tests of the mode joined by `and`, `or` or `->`, as one (cppcheck: redundantCondition on
    `!(mode == A) || mode == B`): the modes' sets joined, in the order the spec names them."""
    a, b = _modes_of(left), _modes_of(right)
    if a is None or b is None or op == "<->":
        return None
    if op == "->":
        op, a = "or", (not a[0], a[1])
    (neg_a, xs), (neg_b, ys) = a, b
    if neg_a != neg_b:  # one side negated: not in N, and (or) in P
        (_, n), (_, q) = (a, b) if neg_a else (b, a)
        if op == "or":  # not in N or in Q: not in N but Q
            return _mode_test(True, tuple(s for s in n if s not in q))
        return _mode_test(False, tuple(s for s in q if s not in n))  # in Q and not in N
    union = (*xs, *(s for s in ys if s not in xs))
    common = tuple(s for s in xs if s in ys)
    if neg_a:  # not in X or not in Y: not in both; not in X and not in Y: in neither
        return _mode_test(True, common if op == "or" else union)
    return _mode_test(False, union if op == "or" else common)


def _connective(e: BinOp, left: Expr, right: Expr) -> Expr:
    """`left op right` with what its sides decide taken out."""
    joined = _modes_joined(e.op, left, right)
    if joined is not None:
        return joined
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
    (left, by), (right, to) = _offset(e.left), _offset(e.right)
    if exact and left == right:  # `c >= c + 1` compares 0 with 1 (cppcheck: invalidTestForOverflow)
        return Const(COMPARE[e.op](by, to))
    return e


def _offset(e: Expr) -> tuple[Expr, Fraction]:
    """`e` as an expression plus a constant: `c + 1` is (c, 1), `c - 1` is (c, -1), `c` is (c, 0)."""
    if isinstance(e, Arith) and e.op in ("+", "-") and isinstance(e.right, Num):
        return e.left, e.right.value if e.op == "+" else -e.right.value
    if isinstance(e, Arith) and e.op == "+" and isinstance(e.left, Num):
        return e.right, e.left.value
    return e, Fraction(0)


def _difference(e: Arith, types: Mapping[str, Type]) -> Expr:
    """`x - x` of ints is 0 (cppcheck: duplicateExpression); of reals it is kept (a NaN or an infinity minus
    itself is a NaN)."""
    if e.op == "-" and e.left == e.right and type_of(e, types) == "int":
        return Num(Fraction(0), False)
    return e


def _constant_call(e: Call) -> Expr:
    """`abs`, `min` or `max` of numbers of one kind is a number (`abs(0)`, once `c - c` is 0)."""
    if e.fn == "valid" or not all(isinstance(a, Num) for a in e.args):
        return e
    values = [a.value for a in e.args if isinstance(a, Num)]
    kinds = {a.real for a in e.args if isinstance(a, Num)}
    if len(kinds) != 1:
        return e
    value = abs(values[0]) if e.fn == "abs" else min(values) if e.fn == "min" else max(values)
    return Num(value, kinds.pop())


def tidy(e: Expr, types: Mapping[str, Type]) -> Expr:
    """`e` with what its own text decides decided (see the module's docstring)."""
    if isinstance(e, Not):
        arg = tidy(e.arg, types)
        if isinstance(arg, Not):  # not not a is a
            return arg.arg
        return Const(not arg.value) if isinstance(arg, Const) else e if arg is e.arg else Not(arg)
    if isinstance(e, BinOp):
        left, right = tidy(e.left, types), tidy(e.right, types)
        return _connective(e, left, _where_evaluated(e.op, left, right, types))
    if isinstance(e, Cmp):
        return _comparison(e, types)
    if isinstance(e, Arith):
        return _difference(e, types)
    if isinstance(e, Call):
        tidied = _constant_call(Call(e.fn, tuple(tidy(a, types) for a in e.args)))
        return e if isinstance(tidied, Call) and tidied.args == e.args else tidied
    if isinstance(e, Ite):
        cond = tidy(e.cond, types)
        if isinstance(cond, Const):
            return tidy(e.then if cond.value else e.other, types)
        if e.then == e.other:  # the same value either way
            return tidy(e.then, types)
        if isinstance(cond, Not):  # clang records no MC/DC test vector of a `?:` on a negation
            return Ite(cond.arg, e.other, e.then)
        return e if cond is e.cond else Ite(cond, e.then, e.other)
    return e


def _where_evaluated(op: str, left: Expr, right: Expr, types: Mapping[str, Type]) -> Expr:
    """`right` with what `left` decides where `right` is read decided (`!a || (a && b)` is `!a || b`: cppcheck's
    redundantCondition): C reads the right side of `a && b` and of `a -> b` only where `a` holds, of `a || b`
    only where it does not."""
    if op not in ("and", "or", "->"):
        return right
    known = known_false(left) if op == "or" else [left, *conjuncts(left)]
    decided = with_known(right, known, types)
    return right if decided is right else tidy(decided, types)


def known_false(guard: Expr) -> list[Expr]:
    """What holds once `guard` is false: its negation, and each disjunct's (a false `a or b` is `not a`,
    `not b`; a false `not (a and b)` or `a -> b` makes `a` true, and the latter `b` false)."""
    if isinstance(guard, BinOp) and guard.op == "or":
        return [_negated(guard), *known_false(guard.left), *known_false(guard.right)]
    if isinstance(guard, BinOp) and guard.op == "->":  # a false `a -> b` makes `a` true and `b` false
        return [_negated(guard), guard.left, *conjuncts(guard.left), *known_false(guard.right)]
    if isinstance(guard, Not):
        return [guard.arg, *conjuncts(guard.arg)]
    return [_negated(guard)]


def without_known(guard: Expr, known: list[Expr]) -> Expr:
    """`guard` without the conjuncts `known` holds (true if none is left)."""
    parts = conjuncts(guard)
    kept = [c for c in parts if c not in known]
    return guard if len(kept) == len(parts) else conjoin(kept)


def with_known(guard: Expr, known: list[Expr], types: Mapping[str, Type] | None = None) -> Expr:
    """`guard` with each boolean part that `known` holds made true, and each whose negation it holds made false
    (`not valid(x)` inside a guard tested after a branch on `not valid(x)`), for `tidy` to decide; given the
    `types`, also a comparison of two ints that a known comparison of the same two decides (`c <= d` where
    `c != d` is false)."""
    if guard in known:
        return TRUE
    if _negated(guard) in known:
        return FALSE
    if isinstance(guard, Cmp) and types is not None:
        return _ordered(guard, known, types) or guard
    if isinstance(guard, Not):
        arg = with_known(guard.arg, known, types)
        return guard if arg is guard.arg else Not(arg)
    if isinstance(guard, BinOp):
        left, right = with_known(guard.left, known, types), with_known(guard.right, known, types)
        return guard if left is guard.left and right is guard.right else BinOp(guard.op, left, right)
    return guard


_ORDERS = {"==": {"="}, "!=": {"<", ">"}, "<": {"<"}, "<=": {"<", "="}, ">": {">"}, ">=": {"=", ">"}}
_FLIPPED = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "==": "==", "!=": "!="}


def _ordered(cmp: Cmp, known: list[Expr], types: Mapping[str, Type]) -> Const | None:
    """`cmp` of two ints decided by a known comparison (or a known false one) of the same two sides: each
    comparison is the set of orders (less, equal, greater) it allows. Reals are left alone: a NaN is in no
    order, so a false `x < y` does not make `x >= y` true."""
    if "real" in (type_of(cmp.left, types), type_of(cmp.right, types)):
        return None
    asked = _ORDERS[cmp.op]
    for fact in known:
        held = _order_held(fact, cmp.left, cmp.right)
        if held is not None and held <= asked:
            return TRUE
        if held is not None and not held & asked:
            return FALSE
    return None


def _order_held(fact: Expr, left: Expr, right: Expr) -> set[str] | None:
    """The orders of `left` to `right` that `fact` allows, if it compares the two (None if not)."""
    negated = isinstance(fact, Not)
    cmp = fact.arg if isinstance(fact, Not) else fact
    if not isinstance(cmp, Cmp):
        return None
    if (cmp.left, cmp.right) == (left, right):
        allowed = _ORDERS[cmp.op]
    elif (cmp.left, cmp.right) == (right, left):
        allowed = _ORDERS[_FLIPPED[cmp.op]]
    else:
        return None
    return {"<", "=", ">"} - allowed if negated else allowed
