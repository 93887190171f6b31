"""Recursive-descent parser for guard, definition and property expressions (never `eval`).

Grammar, loosest binding first:

    expr    := implies ('<->' implies)*
    implies := disj ('->' implies)?          right-associative
    disj    := conj ('or' conj)*
    conj    := unary ('and' unary)*
    unary   := 'not' unary | cmp
    cmp     := sum (('<' | '<=' | '>' | '>=' | '==' | '!=') sum)?
    sum     := prod (('+' | '-') prod)*
    prod    := neg (('*' | '/') neg)*
    neg     := '-' neg | atom
    atom    := '(' expr ')' | 'true' | 'false' | NUMBER | NAME
             | 'state' ('==' | '!=') NAME | 'state' 'in' '{' NAME (',' NAME)* '}'
             | 'if' expr 'then' expr 'else' expr
             | ('min' | 'max') '(' expr (',' expr)+ ')' | 'abs' '(' expr ')' | 'valid' '(' NAME ')'
             | 'prev' '(' expr ')' | 'prev' '(' 'state' ')' ('==' | '!=' | 'in') ...

Names are resolved later, against the machine; this module only knows the syntax. Work is bounded: the text is
at most `MAX_LENGTH` characters and tokenized in one pass, and no expression nests deeper than `MAX_DEPTH`
(parentheses, `not`, `->` and the operands of chained operators alike), so no later recursive walk over it
can exhaust the stack.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from fractions import Fraction
from typing import Literal

from mlca_verify.model import Arith, BinOp, Call, Cmp, Const, Expr, Ite, Neg, Not, Num, Prev, StateIn, Var, children


class ParseError(Exception):
    """A syntax error at a 0-based character offset of the expression text."""

    def __init__(self, offset: int, message: str) -> None:
        super().__init__(message)
        self.offset = offset
        self.message = message


TokenKind = Literal["NAME", "NUM", "OP", "END"]


@dataclass(frozen=True)
class Token:
    kind: TokenKind
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
_TOKEN = re.compile(
    r"(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<num>[0-9]+(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?)"
    r"|(?P<op><->|->|==|!=|<=|>=|[-+*/<>(){},])"
)
# In a network's properties a name may be qualified by an instance: `A.gap`, and `A.state == X`.
_QUALIFIED = re.compile(
    r"(?P<name>[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)?)|(?P<num>[0-9]+(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?)"
    r"|(?P<op><->|->|==|!=|<=|>=|[-+*/<>(){},])"
)
_KEYWORDS = {"and", "or", "not", "true", "false", "state", "in", "if", "then", "else", "prev"}
_FUNCTIONS = {"min", "max", "abs", "valid"}
_COMPARISONS = ("<", "<=", ">", ">=", "==", "!=")
MAX_EXPONENT = 300  # a literal's exponent: keeps exact arithmetic on it small
MAX_DIGITS = 40  # a literal's digits: more than binary64 (17) or a 64-bit integer (19) can tell apart


def tokenize(text: str, qualified: bool = False) -> list[Token]:
    pattern = _QUALIFIED if qualified else _TOKEN
    if len(text) > MAX_LENGTH:
        raise ParseError(MAX_LENGTH, f"expression longer than {MAX_LENGTH} characters ({len(text)})")
    tokens: list[Token] = []
    pos = _skip_space(text, 0)
    while pos < len(text):
        m = pattern.match(text, pos)
        if m is None:
            raise ParseError(pos, f"unexpected character {text[pos]!r}")
        kind: TokenKind = "NAME" if m.group("name") else "NUM" if m.group("num") else "OP"
        tokens.append(Token(kind, m.group(), pos))
        pos = _skip_space(text, m.end())
    tokens.append(Token("END", "", len(text)))
    return tokens


def _skip_space(text: str, pos: int) -> int:
    m = _SPACE.match(text, pos)
    return m.end() if m else pos


class _Parser:
    def __init__(self, text: str, qualified: bool = False) -> None:
        self.tokens = tokenize(text, qualified)
        self.pos = 0
        self.refs: list[NameRef] = []
        self.depth = 0
        self.offsets: dict[int, int] = {}

    def mark(self, node: Expr, offset: int) -> Expr:
        """Remember where `node` was written, for type errors at its column."""
        self.offsets[id(node)] = offset
        return node

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
        rest = self.tok  # the token after the expression (read again: iff() moved on)
        if rest.kind != "END":
            raise ParseError(rest.offset, f"unexpected {self.describe()} after a complete expression")
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
        return self.comparison()

    def is_op(self, *texts: str) -> bool:
        return self.tok.kind == "OP" and self.tok.text in texts

    def comparison(self) -> Expr:
        left = self.sum()
        if self.is_op(*_COMPARISONS):
            op, at = self.tok.text, self.tok.offset
            self.pos += 1
            left = self.mark(Cmp(op, left, self.sum()), at)  # type: ignore[arg-type]
            if self.is_op(*_COMPARISONS):
                raise ParseError(self.tok.offset, "comparisons do not chain: join them with 'and'")
        return left

    def sum(self) -> Expr:
        left = self.product()
        while self.is_op("+", "-"):
            op, at = self.tok.text, self.tok.offset
            self.pos += 1
            left = self.mark(Arith(op, left, self.product()), at)  # type: ignore[arg-type]
        return left

    def product(self) -> Expr:
        left = self.negation()
        while self.is_op("*", "/"):
            op, at = self.tok.text, self.tok.offset
            self.pos += 1
            left = self.mark(Arith(op, left, self.negation()), at)  # type: ignore[arg-type]
        return left

    def negation(self) -> Expr:
        if self.is_op("-"):
            at = self.tok.offset
            self.nest(at)
            self.pos += 1
            inner = self.negation()
            self.depth -= 1
            return self.mark(Neg(inner), at)
        return self.atom()

    def atom(self) -> Expr:
        tok = self.tok
        if self.accept("("):
            self.nest(tok.offset)
            inner = self.iff()
            self.expect(")", "')'")
            self.depth -= 1
            return inner
        if tok.kind == "NUM":
            self.pos += 1
            return self.mark(number(tok), tok.offset)
        if tok.kind == "NAME" and tok.text == "if":
            return self.conditional()
        if tok.kind == "NAME" and (tok.text in _FUNCTIONS or tok.text == "prev") and self.peek("("):
            return self.call()
        if tok.kind != "NAME" or tok.text in _KEYWORDS - {"true", "false", "state"}:
            raise ParseError(
                tok.offset, f"expected an input name, 'state', 'true', 'false', 'not' or '(', found {self.describe()}"
            )
        self.pos += 1
        if tok.text in ("true", "false"):
            return Const(tok.text == "true")
        if tok.text == "state":
            return self.state_comparison(tok.offset)
        if tok.text.endswith(".state"):
            return self.state_comparison(tok.offset, tok.text[: -len("state")])
        self.refs.append(NameRef(tok.text, tok.offset, is_state=False))
        return self.mark(Var(tok.text), tok.offset)

    def peek(self, text: str) -> bool:
        after = self.tokens[self.pos + 1] if self.pos + 1 < len(self.tokens) else self.tokens[-1]
        return after.kind == "OP" and after.text == text

    def conditional(self) -> Expr:
        at = self.tok.offset
        self.nest(at)
        self.pos += 1
        cond = self.iff()
        self.expect("then", "'then'")
        then = self.iff()
        self.expect("else", "'else'")
        other = self.iff()
        self.depth -= 1
        return self.mark(Ite(cond, then, other), at)

    def call(self) -> Expr:
        name = self.tok
        ahead = self.tokens[self.pos + 2 : self.pos + 4]
        if name.text == "prev" and [t.text for t in ahead] == ["state", ")"] and ahead[0].kind == "NAME":
            self.pos += 4  # prev(state) ==, != or in: the state before the step
            return self.mark(Prev(self.state_comparison(ahead[0].offset)), name.offset)
        self.nest(name.offset)
        self.pos += 2
        if name.text == "valid":
            arg = self.tok
            if arg.kind != "NAME" or arg.text in _KEYWORDS or arg.text in _FUNCTIONS:
                raise ParseError(arg.offset, f"valid() takes a signal's name, found {self.describe()}")
            self.pos += 1
            self.refs.append(NameRef(arg.text, arg.offset, is_state=False))
            args: list[Expr] = [self.mark(Var(arg.text), arg.offset)]
        else:
            args = [self.iff()]
            while self.accept(","):
                args.append(self.iff())
        self.expect(")", "')'" if name.text in ("abs", "valid", "prev") else "',' or ')'")
        self.depth -= 1
        wanted = {"min": "at least 2", "max": "at least 2", "abs": "1", "valid": "1", "prev": "1"}[name.text]
        if (len(args) < 2) if wanted == "at least 2" else len(args) != 1:
            raise ParseError(name.offset, f"{name.text}() takes {wanted} arguments, got {len(args)}")
        if name.text == "prev":
            return self.mark(Prev(args[0]), name.offset)
        return self.mark(Call(name.text, tuple(args)), name.offset)  # type: ignore[arg-type]

    def state_comparison(self, at: int, instance: str = "") -> Expr:
        """`state == X`, `!=` or `in {...}`; `A.state ...` in a network, its states named `A.X`."""
        if self.accept("=="):
            return StateIn((self.state_name(at, instance),))
        if self.accept("!="):
            return Not(StateIn((self.state_name(at, instance),)))
        if self.accept("in"):
            self.expect("{", "'{' after 'state in'")
            names = [self.state_name(at, instance)]
            while self.accept(","):
                names.append(self.state_name(at, instance))
            self.expect("}", "',' or '}'")
            return StateIn(tuple(names))
        raise ParseError(self.tok.offset, f"expected '==', '!=' or 'in' after 'state', found {self.describe()}")

    def state_name(self, at: int, instance: str = "") -> str:
        tok = self.tok
        if tok.kind != "NAME" or tok.text in _KEYWORDS or "." in tok.text:
            raise ParseError(tok.offset, f"expected a state name, found {self.describe()}")
        self.pos += 1
        self.refs.append(NameRef(instance + tok.text, tok.offset, is_state=True, state_offset=at))
        return instance + tok.text


@dataclass(frozen=True)
class Parsed:
    expr: Expr
    refs: list[NameRef]
    offsets: dict[int, int]  # id of a node -> its offset in the text (names, numbers, operators, calls)


def parse_expr(text: str) -> tuple[Expr, list[NameRef]]:
    """Parse `text`; return the AST and every name it uses with its offset."""
    parsed = parse_full(text)
    return parsed.expr, parsed.refs


def parse_full(text: str, qualified: bool = False) -> Parsed:
    """Parse `text`, keeping where each node was written; with `qualified`, names may be qualified by an
    instance (`A.gap`, `A.state == X`, whose state is then `A.X`), as a network's properties are."""
    parser = _Parser(text, qualified)
    # Each nesting level passes through about a dozen grammar functions: leave room for MAX_DEPTH of them.
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 20 * MAX_DEPTH + 1000))
    try:
        expr = parser.parse()
    finally:
        sys.setrecursionlimit(limit)
    if depth(expr) > MAX_DEPTH:
        raise ParseError(0, f"expression nested more than {MAX_DEPTH} deep (split a long chain with parentheses)")
    return Parsed(expr, parser.refs, parser.offsets)


def number(tok: Token) -> Num:
    """A literal, exact: `0.1` is one tenth."""
    mantissa, _, exponent = tok.text.lower().partition("e")
    if sum(ch.isdigit() for ch in mantissa) > MAX_DIGITS or len(exponent) > 5:
        raise ParseError(tok.offset, f"number {tok.text[:30]!r}... has more than {MAX_DIGITS} digits")
    if exponent and abs(int(exponent)) > MAX_EXPONENT:
        raise ParseError(tok.offset, f"number {tok.text[:30]!r} has an exponent beyond {MAX_EXPONENT}")
    return Num(Fraction(mantissa) * Fraction(10) ** int(exponent or 0), real="." in tok.text or bool(exponent))


def depth(expr: Expr) -> int:
    """The height of the tree, counted without recursion."""
    deepest, todo = 0, [(expr, 1)]
    while todo:
        node, level = todo.pop()
        deepest = max(deepest, level)
        todo += [(child, level + 1) for child in children(node)]
    return deepest
