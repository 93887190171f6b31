"""The expression parser: precedence, the state forms, errors with offsets, and show/parse round trips."""

from __future__ import annotations

import pytest
from hypothesis import given, settings

from mlca_verify.model import BinOp, Const, Not, StateIn, Var, show
from mlca_verify.spec.expr_parser import ParseError, parse_expr
from tests.bruteforce import ev, valuations
from tests.strategies import exprs


def parse(text: str) -> object:
    return parse_expr(text)[0]


def test_precedence_not_and_or_implies_iff() -> None:
    a, b, c = Var("a"), Var("b"), Var("c")
    assert parse("not a and b or c") == BinOp("or", BinOp("and", Not(a), b), c)
    assert parse("a or b and c") == BinOp("or", a, BinOp("and", b, c))
    assert parse("a -> b -> c") == BinOp("->", a, BinOp("->", b, c))
    assert parse("a <-> b -> c") == BinOp("<->", a, BinOp("->", b, c))
    assert parse("(a or b) and c") == BinOp("and", BinOp("or", a, b), c)


def test_state_forms() -> None:
    assert parse("state == A") == StateIn(("A",))
    assert parse("state != A") == Not(StateIn(("A",)))
    assert parse("state in {A, B}") == StateIn(("A", "B"))
    assert parse("true and not false") == BinOp("and", Const(True), Not(Const(False)))


def test_refs_carry_offsets() -> None:
    _, refs = parse_expr("x and state == IDLE")
    assert [(r.name, r.offset, r.is_state) for r in refs] == [("x", 0, False), ("IDLE", 15, True)]
    assert refs[1].state_offset == 6


@pytest.mark.parametrize(
    ("text", "offset", "message"),
    [
        ("", 0, "empty expression"),
        ("a and", 5, "expected an input name"),
        ("a b", 2, "unexpected 'b' after a complete expression"),
        ("state = A", 6, "unexpected character '='"),
        ("state in A", 9, "expected '{' after 'state in'"),
        ("state == and", 9, "expected a state name"),
        ("state", 5, "expected '==', '!=' or 'in' after 'state'"),
        ("a @ b", 2, "unexpected character '@'"),
    ],
)
def test_errors_point_at_the_offending_character(text: str, offset: int, message: str) -> None:
    with pytest.raises(ParseError) as info:
        parse_expr(text)
    assert info.value.offset == offset
    assert message in info.value.message


@settings(max_examples=300, deadline=None)
@given(exprs(("a", "b", "c"), ("S0", "S1")))
def test_show_then_parse_keeps_the_meaning(expr: object) -> None:
    again = parse(show(expr))  # type: ignore[arg-type]
    for state in ("S0", "S1"):
        for inputs in valuations(("a", "b", "c")):
            assert ev(again, inputs, state) == ev(expr, inputs, state)  # type: ignore[arg-type]
