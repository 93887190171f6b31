"""The machine model: frozen dataclasses, no I/O, no solver, no file format.

A `Machine` is what every consumer (the z3 engine, the code generators, the simulator) reads.
Expressions are a small AST over boolean inputs and the machine's state.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal, TypeAlias

from mlca_verify.errors import Loc

Semantics = Literal["first-match", "any-enabled"]
Otherwise = Literal["stay", "undefined"]
Verdict = Literal["holds", "violated", "unknown"]
ANY_STATE = "*"
OTHERWISE_ID = "otherwise"
IN_MEMORY = Loc("<memory>", 1, 1)


# --- expressions -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Const:
    value: bool


@dataclass(frozen=True)
class Var:
    """A boolean input, by name."""

    name: str


@dataclass(frozen=True)
class StateIn:
    """`state == X` (one name), `state in {X, Y}` or, negated, `state != X`."""

    states: tuple[str, ...]


@dataclass(frozen=True)
class Not:
    arg: Expr


@dataclass(frozen=True)
class BinOp:
    """`and`, `or`, `->` (implies), `<->` (iff)."""

    op: Literal["and", "or", "->", "<->"]
    left: Expr
    right: Expr


Expr: TypeAlias = Const | Var | StateIn | Not | BinOp


def inputs_of(expr: Expr) -> frozenset[str]:
    """The input names an expression mentions."""
    if isinstance(expr, Var):
        return frozenset([expr.name])
    if isinstance(expr, Not):
        return inputs_of(expr.arg)
    if isinstance(expr, BinOp):
        return inputs_of(expr.left) | inputs_of(expr.right)
    return frozenset()


def mentions_state(expr: Expr) -> bool:
    """True when the expression compares the machine's state."""
    if isinstance(expr, StateIn):
        return True
    if isinstance(expr, Not):
        return mentions_state(expr.arg)
    if isinstance(expr, BinOp):
        return mentions_state(expr.left) or mentions_state(expr.right)
    return False


def evaluate(expr: Expr, inputs: Mapping[str, bool], state: str | None = None) -> bool:
    """Evaluate an expression on concrete inputs and (when it mentions it) a concrete state."""
    if isinstance(expr, Const):
        return expr.value
    if isinstance(expr, Var):
        return inputs[expr.name]
    if isinstance(expr, StateIn):
        return state in expr.states
    if isinstance(expr, Not):
        return not evaluate(expr.arg, inputs, state)
    a = evaluate(expr.left, inputs, state)
    b = evaluate(expr.right, inputs, state)
    return {"and": a and b, "or": a or b, "->": (not a) or b, "<->": a == b}[expr.op]


_PRECEDENCE = {"<->": 1, "->": 2, "or": 3, "and": 4}


def show(expr: Expr, parent: int = 0) -> str:
    """Render an expression in the spec's own syntax, with only the parentheses it needs."""
    if isinstance(expr, Const):
        return "true" if expr.value else "false"
    if isinstance(expr, Var):
        return expr.name
    if isinstance(expr, StateIn):
        if len(expr.states) == 1:
            return f"state == {expr.states[0]}"
        return "state in {" + ", ".join(expr.states) + "}"
    if isinstance(expr, Not):
        return "not " + show(expr.arg, 5)
    prec = _PRECEDENCE[expr.op]
    text = f"{show(expr.left, prec)} {expr.op} {show(expr.right, prec)}"
    return f"({text})" if prec <= parent and not (prec == parent and expr.op in ("and", "or")) else text


# --- machine elements ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Input:
    name: str
    doc: str
    cite: str
    loc: Loc


@dataclass(frozen=True)
class Transition:
    """A guarded edge. `sources` is `None` for `from = "*"` (every state)."""

    id: str
    sources: tuple[str, ...] | None
    target: str
    guard: Expr
    cite: str
    loc: Loc
    doc: str = ""

    def applies_to(self, state: str) -> bool:
        return self.sources is None or state in self.sources


@dataclass(frozen=True)
class Invariant:
    """Must hold after every step, over that step's inputs and the state it led to."""

    id: str
    expr: Expr
    cite: str
    expect: Verdict
    loc: Loc
    doc: str = ""


@dataclass(frozen=True)
class Liveness:
    """Response under persistence: if `assume` holds at every step from some step on,
    `goal` holds at some step from then on (within `within` steps when given)."""

    id: str
    assume: Expr
    goal: Expr
    within: int | None
    cite: str
    expect: Verdict
    loc: Loc
    doc: str = ""


@dataclass(frozen=True)
class Comparison:
    """A declared equivalence check against another machine."""

    other: Machine
    expect: Verdict
    cite: str
    loc: Loc


@dataclass(frozen=True)
class Machine:
    name: str
    initial: str
    states: tuple[str, ...]
    inputs: tuple[Input, ...]
    transitions: tuple[Transition, ...]
    semantics: Semantics = "first-match"
    otherwise: Otherwise = "stay"
    cite: str = ""
    doc: str = ""
    invariants: tuple[Invariant, ...] = ()
    liveness: tuple[Liveness, ...] = ()
    comparisons: tuple[Comparison, ...] = ()
    expect: Mapping[str, Verdict] = field(default_factory=dict)
    loc: Loc = IN_MEMORY

    @property
    def input_names(self) -> tuple[str, ...]:
        return tuple(i.name for i in self.inputs)

    def outgoing(self, state: str) -> tuple[Transition, ...]:
        """Transitions that apply in `state`, in priority (file) order."""
        return tuple(t for t in self.transitions if t.applies_to(state))

    def expected(self, prop: str) -> Verdict:
        """The declared expectation for a built-in check (default: holds)."""
        return self.expect.get(prop, "holds")
