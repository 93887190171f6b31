"""Recursive-descent parser for guard and property expressions (never `eval`).

Grammar, loosest binding first:

    expr    := implies ('<->' implies)*
    implies := disj ('->' implies)?          right-associative
    disj    := conj ('or' conj)*
    conj    := unary ('and' unary)*
    unary   := 'not' unary | atom
    atom    := '(' expr ')' | 'true' | 'false' | NAME
             | 'state' ('==' | '!=') NAME | 'state' 'in' '{' NAME (',' NAME)* '}'

Names are resolved later, against the machine; this module only knows the syntax. Work is bounded: the text is
at most `MAX_LENGTH` characters and tokenized in one pass, and no expression nests deeper than `MAX_DEPTH`
(parentheses, `not`, `->` and the operands of chained operators alike), so no later recursive walk over it
can exhaust the stack.
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


MAX_LENGTH = 10_000  # characters in one expression
MAX_DEPTH = 100  # nesting of one expression

_SPACE = re.compile(r"\s*")
_TOKEN = re.compile(r"(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<op><->|->|==|!=|[(){},])")
_KEYWORDS = {"and", "or", "not", "true", "false", "state", "in"}


def tokenize(text: str) -> list[Token]:
    if len(text) > MAX_LENGTH:
        raise ParseError(MAX_LENGTH, f"expression longer than {MAX_LENGTH} characters ({len(text)})")
    tokens: list[Token] = []
    pos = _skip_space(text, 0)
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise ParseError(pos, f"unexpected character {text[pos]!r}")
        kind = "NAME" if m.group("name") else "OP"
        tokens.append(Token(kind, m.group(), pos))
        pos = _skip_space(text, m.end())
    tokens.append(Token("END", "", len(text)))
    return tokens


def _skip_space(text: str, pos: int) -> int:
    m = _SPACE.match(text, pos)
    return m.end() if m else pos


class _Parser:
    def __init__(self, text: str) -> None:
        self.tokens = tokenize(text)
        self.pos = 0
        self.refs: list[NameRef] = []
        self.depth = 0

    def nest(self, offset: int) -> None:
        """One level deeper (a parenthesis, a `not`, the right side of `->`); refused past `MAX_DEPTH`."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise ParseError(offset, f"expression nested more than {MAX_DEPTH} deep")

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
        if self.tok.text == "->" and self.tok.kind == "OP":
            self.nest(self.tok.offset)
            self.pos += 1
            right = self.implies()
            self.depth -= 1
            return BinOp("->", left, right)
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
        if self.tok.text == "not" and self.tok.kind == "NAME":
            self.nest(self.tok.offset)
            self.pos += 1
            inner = self.unary()
            self.depth -= 1
            return Not(inner)
        return self.atom()

    def atom(self) -> Expr:
        tok = self.tok
        if self.accept("("):
            self.nest(tok.offset)
            inner = self.iff()
            self.expect(")", "')'")
            self.depth -= 1
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
    if depth(expr) > MAX_DEPTH:
        raise ParseError(0, f"expression nested more than {MAX_DEPTH} deep (split a long chain with parentheses)")
    return expr, parser.refs


def depth(expr: Expr) -> int:
    """The height of the tree, counted without recursion."""
    deepest, todo = 0, [(expr, 1)]
    while todo:
        node, level = todo.pop()
        deepest = max(deepest, level)
        if isinstance(node, BinOp):
            todo += [(node.left, level + 1), (node.right, level + 1)]
        elif isinstance(node, Not):
            todo.append((node.arg, level + 1))
    return deepest
