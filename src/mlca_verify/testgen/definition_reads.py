"""Where the generated code reads a definition: the code evaluates a definition lazily, inside the guards (and the
other definitions) that name it, and C and Python stop evaluating `a and b` once `a` is false. A decision inside
a definition is covered only at a step where the code reaches it; this module writes that condition as an
expression over the step, from the spec alone."""

from __future__ import annotations

from collections.abc import Callable

from mlca_verify.codegen.joins import conjoin, disjoin
from mlca_verify.model import (
    BinOp,
    Const,
    Expr,
    Ite,
    Machine,
    Not,
    Prev,
    StateIn,
    Transition,
    Var,
    children,
    names_of,
    nodes,
)

Path = tuple[Expr, ...]  # conditions that hold wherever an occurrence is evaluated


def paths(expr: Expr, name: str) -> list[Path]:
    """For each occurrence of `name` in `expr`, what must hold for the code to evaluate it (short circuits and
    the branches of `if then else`)."""
    return _paths(expr, lambda e: isinstance(e, Var) and e.name == name, ())


def paths_to(expr: Expr, node: Expr) -> list[Path]:
    """For each place `node` (this very node of `expr`'s tree) holds in `expr`, what must hold for the code to
    evaluate it there."""
    return _paths(expr, lambda e: e is node, ())


def _paths(expr: Expr, hit: Callable[[Expr], bool], along: Path) -> list[Path]:
    if hit(expr):
        return [along]
    if isinstance(expr, (Var, Prev)):
        return []  # a register is the value of an earlier step, not a read now
    if isinstance(expr, BinOp):
        return _paths(expr.left, hit, along) + _paths(expr.right, hit, along + _right_gate(expr))
    if isinstance(expr, Ite):
        found = _paths(expr.cond, hit, along)
        found += _paths(expr.then, hit, (*along, expr.cond))
        return found + _paths(expr.other, hit, (*along, Not(expr.cond)))
    return [p for child in children(expr) for p in _paths(child, hit, along)]


def _right_gate(expr: BinOp) -> Path:
    """What must hold for the code to evaluate the right side of `expr` (the short circuits of C and Python)."""
    return {"and": (expr.left,), "or": (Not(expr.left),), "->": (expr.left,), "<->": ()}[expr.op]


def condition_paths(expr: Expr, along: Path = ()) -> list[Path]:
    """For each condition of a decision (the atom occurrences, left to right, as `objectives.atoms` lists them),
    what must hold for the code to evaluate it."""
    if isinstance(expr, Not):
        return condition_paths(expr.arg, along)
    if isinstance(expr, BinOp):
        return condition_paths(expr.left, along) + condition_paths(expr.right, along + _right_gate(expr))
    if isinstance(expr, Const):
        return []
    return [along]


def _reads(expr: Expr | None, name: str) -> bool:
    return expr is not None and any(isinstance(n, Var) and n.name == name for n in nodes(expr))


def read_context(machine: Machine, name: str, checks: dict[str, Expr | None]) -> Expr | None:
    """Where the step code reads definition `name` (None: at every step, or only in the monitor, which the
    suite calls at every step). `checks` gives each boolean definition's range checks. A variable's `every` is
    read only where no transition that updates the variable is enabled, an update only where its transition
    fires."""
    if any(_reads(o.expr, name) for o in machine.outputs):
        return None
    parts: list[Expr] = []
    for v in machine.variables:
        if v.every is not None:
            parts += [conjoin([*no_update(machine, v.name), *p]) for p in paths(v.every, name)]
    for t in machine.transitions:
        parts += [conjoin([fires(machine, t), *p]) for u in t.updates for p in paths(u.expr, name)]
    for state in machine.states:
        earlier: list[Expr] = []
        for t in machine.outgoing(state):
            parts += [conjoin([StateIn((state,)), *earlier, *p]) for p in paths(t.guard, name)]
            earlier.append(Not(t.guard))
    parts += _through_definitions(machine, name, checks, read_context)
    return disjoin(parts) if parts else None


Context = Callable[[Machine, str, dict[str, Expr | None]], Expr | None]


def _through_definitions(machine: Machine, name: str, checks: dict[str, Expr | None], outer_of: Context) -> list[Expr]:
    """Where `name` is read inside the definitions that read it: each one's own read context (`outer_of`), its
    samples valid, and the short circuits inside it."""
    parts: list[Expr] = []
    for d in machine.definitions:
        if d.name != name and _reads(d.expr, name) and read_anywhere(machine, d.name):
            gate = [g for g in (outer_of(machine, d.name, checks), checks.get(d.name)) if g is not None]
            parts += [conjoin([*gate, *p]) for p in paths(d.expr, name)]
    return parts


def read_anywhere(machine: Machine, name: str) -> bool:
    """Does anything read definition `name`: the step, the outputs, the monitor's invariants, or a definition read
    so? One nothing reads has no read site (the code never computes it), which `read_context`'s None (every
    step) must not stand for."""
    after = [o.expr for o in machine.outputs] + [i.expr for i in machine.invariants]
    return name in read_through(machine, [*_before_step(machine), *after])


def read_before(machine: Machine, name: str) -> bool:
    """Does the step read definition `name` over the context before it (a guard, an update, an `every`, an
    environment assumption, or a definition read so)? If not, only the outputs and the monitor read it, after
    the step."""
    return name in read_through(machine, _before_step(machine))


def _before_step(machine: Machine) -> list[Expr]:
    exprs = [t.guard for t in machine.transitions] + [u.expr for t in machine.transitions for u in t.updates]
    exprs += [v.every for v in machine.variables if v.every is not None]
    return exprs + [a.expr for a in machine.assumptions]


def read_through(machine: Machine, exprs: list[Expr]) -> set[str]:
    """The definitions `exprs` read, directly or through the definitions they read."""
    defined = {d.name: d.expr for d in machine.definitions}
    todo = [n for e in exprs for n in names_of(e) if n in defined]
    found: set[str] = set()
    while todo:
        name = todo.pop()
        if name not in found:
            found.add(name)
            todo += [n for n in names_of(defined[name]) if n in defined]
    return found


def read_after_context(machine: Machine, name: str, checks: dict[str, Expr | None]) -> Expr | None:
    """Where the monitor reads definition `name` after the step: inside its invariants (and the definitions they
    read), as the short circuits allow; None where an output reads it (every step) or nothing says where."""
    if any(_reads(o.expr, name) for o in machine.outputs):
        return None
    parts = [conjoin(list(p)) for inv in machine.invariants for p in paths(inv.expr, name)]
    parts += _through_definitions(machine, name, checks, read_after_context)
    return disjoin(parts) if parts else None


def fires(machine: Machine, t: Transition) -> Expr:
    """`t` fires: in a mode it leaves, its guard holds and the earlier guards of that mode do not."""
    ways: list[Expr] = []
    for state in machine.states:
        if t.applies_to(state):
            out = machine.outgoing(state)
            ways.append(conjoin([StateIn((state,)), *(Not(e.guard) for e in out[: out.index(t)]), t.guard]))
    return disjoin(ways)


def no_update(machine: Machine, variable: str) -> tuple[Expr, ...]:
    """No transition that updates `variable` is enabled."""
    given: list[Expr] = []
    for t in machine.transitions:
        if any(u.variable == variable for u in t.updates):
            enabled = t.guard if t.sources is None else BinOp("and", StateIn(t.sources), t.guard)
            given.append(Not(enabled))
    return tuple(given)
