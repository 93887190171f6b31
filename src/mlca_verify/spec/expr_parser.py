"""Recursive-descent parser for guard and property expressions (never `eval`).

Grammar, loosest binding first:

    expr    := implies ('<->' implies)*
    implies := disj ('->' implies)?          right-associative
    disj    := conj ('or' conj)*
    conj    := unary ('and' unary)*
    unary   := 'not' unary | atom
    atom    := '(' expr ')' | 'true' | 'false' | NAME
             | 'state' ('==' | '!=') NAME | 'state' 'in' '{' NAME (',' NAME)* '}'

Names are resolved later, against the machine; this module only knows the syntax.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mlca_verify.model import BinOp, Const, Expr, Not, StateIn, Var


class ParseError(Exception):
    """A syntax error at a 0-based character offset of the expression text."""

    def __init__(self, offset: int, message: str) -> None:
        super().__init__(message)
        self.offset = offset
        self.message = message


@dataclass(frozen=True)
class Token:
    kind: str  # NAME, OP, END
    text: str
    offset: int


@dataclass(frozen=True)
class NameRef:
    """Where a name was used, so that an unknown one can be reported at its column."""

    name: str
    offset: int
    is_state: bool
    state_offset: int = 0  # for a state name: where its 'state' keyword stands


_TOKEN = re.compile(r"\s*(?:(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<op><->|->|==|!=|[(){},]))")
_KEYWORDS = {"and", "or", "not", "true", "false", "state", "in"}


def tokenize(text: str) -> list[Token]:
    tokens: list[Token] = []
    pos = 0
    while pos < len(text):
        if text[pos:].strip() == "":
            break
        m = _TOKEN.match(text, pos)
        if m is None:
            bad = len(text[pos:]) - len(text[pos:].lstrip()) + pos
            raise ParseError(bad, f"unexpected character {text[bad]!r}")
        kind = "NAME" if m.group("name") else "OP"
        tokens.append(Token(kind, m.group(kind.lower()), m.start(kind.lower())))
        pos = m.end()
    tokens.append(Token("END", "", len(text)))
    return tokens


class _Parser:
    def __init__(self, text: str) -> None:
        self.tokens = tokenize(text)
        self.pos = 0
        self.refs: list[NameRef] = []

    @property
    def tok(self) -> Token:
        return self.tokens[self.pos]

    def accept(self, text: str) -> bool:
        if self.tok.text == text and self.tok.kind != "END":
            self.pos += 1
            return True
        return False

    def expect(self, text: str, what: str) -> Token:
        if self.tok.text != text or self.tok.kind == "END":
            raise ParseError(self.tok.offset, f"expected {what}, found {self.describe()}")
        self.pos += 1
        return self.tokens[self.pos - 1]

    def describe(self) -> str:
        return "end of expression" if self.tok.kind == "END" else repr(self.tok.text)

    def parse(self) -> Expr:
        if self.tok.kind == "END":
            raise ParseError(0, "empty expression")
        expr = self.iff()
        if self.tok.kind != "END":
            raise ParseError(self.tok.offset, f"unexpected {self.describe()} after a complete expression")
        return expr

    def iff(self) -> Expr:
        left = self.implies()
        while self.accept("<->"):
            left = BinOp("<->", left, self.implies())
        return left

    def implies(self) -> Expr:
        left = self.disj()
        if self.accept("->"):
            return BinOp("->", left, self.implies())
        return left

    def disj(self) -> Expr:
        left = self.conj()
        while self.accept("or"):
            left = BinOp("or", left, self.conj())
        return left

    def conj(self) -> Expr:
        left = self.unary()
        while self.accept("and"):
            left = BinOp("and", left, self.unary())
        return left

    def unary(self) -> Expr:
        if self.accept("not"):
            return Not(self.unary())
        return self.atom()

    def atom(self) -> Expr:
        tok = self.tok
        if self.accept("("):
            inner = self.iff()
            self.expect(")", "')'")
            return inner
        if tok.kind != "NAME" or tok.text in _KEYWORDS - {"true", "false", "state"}:
            raise ParseError(
                tok.offset, f"expected an input name, 'state', 'true', 'false', 'not' or '(', found {self.describe()}"
            )
        self.pos += 1
        if tok.text in ("true", "false"):
            return Const(tok.text == "true")
        if tok.text == "state":
            return self.state_comparison(tok.offset)
        self.refs.append(NameRef(tok.text, tok.offset, is_state=False))
        return Var(tok.text)

    def state_comparison(self, at: int) -> Expr:
        if self.accept("=="):
            return StateIn((self.state_name(at),))
        if self.accept("!="):
            return Not(StateIn((self.state_name(at),)))
        if self.accept("in"):
            self.expect("{", "'{' after 'state in'")
            names = [self.state_name(at)]
            while self.accept(","):
                names.append(self.state_name(at))
            self.expect("}", "',' or '}'")
            return StateIn(tuple(names))
        raise ParseError(self.tok.offset, f"expected '==', '!=' or 'in' after 'state', found {self.describe()}")

    def state_name(self, at: int) -> str:
        tok = self.tok
        if tok.kind != "NAME" or tok.text in _KEYWORDS:
            raise ParseError(tok.offset, f"expected a state name, found {self.describe()}")
        self.pos += 1
        self.refs.append(NameRef(tok.text, tok.offset, is_state=True, state_offset=at))
        return tok.text


def parse_expr(text: str) -> tuple[Expr, list[NameRef]]:
    """Parse `text`; return the AST and every name it uses with its offset."""
    parser = _Parser(text)
    expr = parser.parse()
    return expr, parser.refs
