"""The decisions of a machine and their conditions: what a requirements-based test suite must cover to MC/DC.

A *decision* is a boolean expression the generated code branches on:
- the guard of a transition in one of its source states, evaluated once the earlier guards of that state are
  false (the code's `if / else if` chain, first match);
- a boolean definition, with the range checks of the samples it reads when it has a fallback value;
- the choice inside `min`, `max` and `abs`, and the condition of an `if then else`;
- an invariant, as the monitor evaluates it after a step.

A *condition* is one occurrence of an atom in a decision: a boolean input or definition, a comparison, a
`state in {...}`, a `prev(...)`. MC/DC asks, for each condition, two test steps in which that condition changes,
the decision's outcome changes, and every other condition either keeps its value (unique cause) or cannot
change the outcome (masking).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Literal

from mlca_verify.codegen.joins import conjoin, disjoin
from mlca_verify.errors import Loc
from mlca_verify.model import (
    IN_MEMORY,
    BinOp,
    Call,
    Cmp,
    Const,
    Expr,
    Ite,
    Machine,
    Not,
    Num,
    StateIn,
    Var,
    children,
    show,
)
from mlca_verify.testgen.definition_reads import (
    fires,
    no_update,
    paths_to,
    read_after_context,
    read_before,
    read_context,
)

Where = Literal["pre", "post"]  # over the frame before the step (guards, definitions) or after it (monitor, outputs)


@dataclass(frozen=True)
class Decision:
    """One decision: `expr` over atoms, evaluated at `where`; `context` must hold for the code to evaluate it."""

    id: str  # e.g. "guard:IDLE:urgent_left", "def:L", "max:reach_av#1", "inv:A3"
    kind: Literal["guard", "definition", "choice", "invariant", "output"]
    expr: Expr
    where: Where
    state: str | None = None  # a guard's source state
    given: tuple[Expr, ...] = ()  # what holds whenever the code evaluates it (earlier guards false, samples valid)
    cite: str = ""
    loc: Loc = IN_MEMORY  # the spec element it comes from


@dataclass(frozen=True)
class Objective:
    """MC/DC of one condition (the `index`-th atom occurrence) of one decision."""

    decision: Decision
    index: int
    atom: Expr

    @property
    def id(self) -> str:
        return f"{self.decision.id}#{self.index + 1}"

    @property
    def label(self) -> str:
        return f"{show(self.atom)} in {self.decision.id}"


def atoms(expr: Expr) -> list[Expr]:
    """The condition occurrences of a decision, left to right; constants are not conditions."""
    if isinstance(expr, Not):
        return atoms(expr.arg)
    if isinstance(expr, BinOp):
        return atoms(expr.left) + atoms(expr.right)
    if isinstance(expr, Const):
        return []
    return [expr]


def validity(machine: Machine, signals: tuple[str, ...]) -> Expr | None:
    """Every sample in its range, one comparison per end (the code checks each end apart)."""
    parts: list[Expr] = []
    by_name = {s.name: s for s in machine.signals}
    for name in signals:
        low, high = by_name[name].range
        real = by_name[name].type == "real"
        parts += [Cmp("<=", Num(low, real), Var(name)), Cmp("<=", Var(name), Num(high, real))]
    return conjoin(parts) if parts else None


def guard_decisions(machine: Machine) -> Iterator[Decision]:
    for state in machine.states:
        earlier: list[Expr] = []
        for t in machine.outgoing(state):
            yield Decision(f"guard:{state}:{t.id}", "guard", t.guard, "pre", state, tuple(earlier), t.cite, t.loc)
            earlier.append(Not(t.guard))


def definition_decisions(machine: Machine) -> Iterator[Decision]:
    """A boolean definition's rule, and before it the range checks of its samples (the code evaluates the rule
    only when they pass), where the step code reads the definition."""
    for d in machine.definitions:
        if d.type != "bool":
            continue
        read, where = _read(machine, d.name), _where(machine, d.name)
        checks = validity(machine, d.signals)
        if checks is not None:
            yield Decision(f"valid:{d.name}", "definition", checks, where, None, read, d.cite, d.loc)
        given = (*read, checks) if checks is not None else read
        yield Decision(f"def:{d.name}", "definition", d.expr, where, None, given, d.cite, d.loc)


def _read(machine: Machine, name: str) -> tuple[Expr, ...]:
    """What holds wherever the code reads definition `name`: before the step, or (read only by the outputs and
    the monitor) after it."""
    checks = {d.name: validity(machine, d.signals) for d in machine.definitions if d.type == "bool"}
    if read_before(machine, name):
        context = read_context(machine, name, checks)
    else:
        context = read_after_context(machine, name, checks)
    return () if context is None else (context,)


def _where(machine: Machine, name: str) -> Where:
    return "pre" if read_before(machine, name) else "post"


def rule(machine: Machine, name: str) -> Expr:
    """A boolean definition's value with its fallback: the rule when the samples are valid, else `if_invalid`."""
    d = next(d for d in machine.definitions if d.name == name)
    checks = validity(machine, d.signals)
    if checks is None:
        return d.expr
    return BinOp("or", Not(checks), d.expr) if d.if_invalid else BinOp("and", checks, d.expr)


def choice_decisions(machine: Machine) -> Iterator[Decision]:
    """The branch inside each `min`/`max` of two arguments, `abs`, and `if then else`: in a definition, read
    where its samples are valid; in a variable's `every`, read where no transition that updates the variable is
    enabled (the code reads `every` only when no update applies); in an output, every step."""
    Root = tuple[str, Expr, Where, Loc, str, tuple[Expr, ...]]
    roots: list[Root] = []
    for d in machine.definitions:
        checks = validity(machine, d.signals)
        given = (*_read(machine, d.name), checks) if checks is not None else _read(machine, d.name)
        roots.append((d.name, d.expr, _where(machine, d.name), d.loc, d.cite, given))
    for v in machine.variables:
        if v.every is not None:
            roots.append((f"every:{v.name}", v.every, "pre", v.loc, v.cite, no_update(machine, v.name)))
    roots += [(f"out:{o.name}", o.expr, "post", o.loc, o.cite, ()) for o in machine.outputs]
    for t in machine.transitions:  # an update: read where its transition fires (one piece of code for every mode)
        roots += [(t.id, u.expr, "pre", t.loc, t.cite, (fires(machine, t),)) for u in t.updates]
    for name, root, where, loc, cite, given in roots:
        for k, node in enumerate(_choices(root)):
            kind: Literal["choice", "output"] = "output" if isinstance(node, Ite) else "choice"
            condition = _choice_condition(node)
            inside = (*given, *_reached(root, node))
            yield Decision(f"{kind}:{name}#{k + 1}", kind, condition, where, None, inside, cite, loc)


def _reached(root: Expr, node: Expr) -> tuple[Expr, ...]:
    """What must hold, inside `root`, for the code to evaluate `node`: the branches of the `if then else` around
    it and the short circuits of `and` and `or` (nothing, where it is evaluated whenever `root` is)."""
    ways = paths_to(root, node)
    if any(not way for way in ways):
        return ()
    return (disjoin([conjoin(list(way)) for way in ways]),)


def _choices(expr: Expr) -> list[Expr]:
    found: list[Expr] = []
    todo = [expr]
    while todo:
        node = todo.pop(0)
        if isinstance(node, Ite) or (isinstance(node, Call) and node.fn in ("min", "max", "abs")):
            found.append(node)
        todo.extend(children(node))
    return found


def _choice_condition(node: Expr) -> Expr:
    if isinstance(node, Ite):
        return node.cond
    assert isinstance(node, Call)
    if node.fn == "abs":
        return Cmp(">=", node.args[0], Num(Fraction(0), False))
    first, second = node.args[0], node.args[1]
    for extra in node.args[2:]:  # the code folds left: only the first choice is a decision of its own here
        first = Call(node.fn, (first, second))
        second = extra
    return Cmp("<" if node.fn == "min" else ">", second, first)


def output_decisions(machine: Machine) -> Iterator[Decision]:
    """Each boolean output's rules, evaluated after every step: its expression, or each branch of an `if then
    else` it is (where the branch is taken; an output that reads samples is `if valid(...) then rule else
    if_invalid`). The `if`'s own condition is a choice (`choice_decisions`)."""
    for o in machine.outputs:
        if o.type != "bool":
            continue
        rules = [(rule, given) for rule, given in _branches(o.expr, ()) if atoms(rule)]
        for k, (rule, given) in enumerate(rules):
            at = f"#{k + 1}" if len(rules) > 1 else ""
            yield Decision(f"output:{o.name}{at}", "output", rule, "post", None, given, o.cite, o.loc)


def _branches(expr: Expr, given: tuple[Expr, ...]) -> Iterator[tuple[Expr, tuple[Expr, ...]]]:
    """The boolean rules of `expr` below its `if then else`s, each with what holds where the code evaluates it."""
    if isinstance(expr, Ite):
        yield from _branches(expr.then, (*given, expr.cond))
        yield from _branches(expr.other, (*given, Not(expr.cond)))
    else:
        yield expr, given


def invariant_decisions(machine: Machine) -> Iterator[Decision]:
    """Each invariant on its own, as the monitor evaluates it."""
    for inv in machine.invariants:
        yield Decision(f"inv:{inv.id}", "invariant", inv.expr, "post", None, (), inv.cite, inv.loc)


def decisions(machine: Machine) -> list[Decision]:
    found = [
        *guard_decisions(machine),
        *definition_decisions(machine),
        *choice_decisions(machine),
        *output_decisions(machine),
        *invariant_decisions(machine),
    ]
    return [replace(d, expr=per_mode(d.expr, machine, reals=d.kind == "invariant")) for d in found]


def per_mode(expr: Expr, machine: Machine, reals: bool = False) -> Expr:
    """`state in {A, B}` as the generated C tests it, one mode at a time (`mode == A || mode == B`), and
    `valid(x)` of an int signal one end of the range at a time (`lo <= x && x <= hi`), so that each test is a
    condition of its own, as gcc's MC/DC counts it. The step tests a real signal's range in one function of
    its own (a rounded part); the monitor tests it inline, one end at a time too (`reals`)."""
    if isinstance(expr, StateIn) and len(expr.states) > 1:
        return disjoin([StateIn((state,)) for state in expr.states])
    inline = {sig.name for sig in machine.signals if sig.type == "int" or reals}
    read = expr.args if isinstance(expr, Call) and expr.fn == "valid" else ()
    if read and all(isinstance(a, Var) and a.name in inline for a in read):
        return validity(machine, tuple(a.name for a in read if isinstance(a, Var))) or expr
    if isinstance(expr, Not):
        arg = per_mode(expr.arg, machine, reals)
        return expr if arg is expr.arg else Not(arg)
    if isinstance(expr, BinOp):
        left, right = per_mode(expr.left, machine, reals), per_mode(expr.right, machine, reals)
        return expr if (left, right) == (expr.left, expr.right) else BinOp(expr.op, left, right)
    return expr


def objectives(machine: Machine) -> list[Objective]:
    return [Objective(d, k, a) for d in decisions(machine) for k, a in enumerate(atoms(d.expr))]
