"""Which definitions the C step computes once, before it tests a mode's transitions, instead of calling their
functions where they are read.

A definition is read by a mode's guards, by the updates of its transitions and by the `every` rules, directly or
through the rules of other definitions; where the step calls its function at every read, a definition read twice
is computed twice (a debounce's `hot`, read by the trip guard and by the counter's rule). It is computed once, into
a field the step then reads, when on that mode's path:
- it is read at least twice (counted through the definitions that are not computed once themselves), and
- it is evaluated on every path through the mode's step (the first guard of the mode reads it where no `and`,
  `or`, `->` or `if` can skip it, or an `every` rule that no transition overrides does), so computing it first
  never costs a step that would not have computed it anyway; and
- the guards and updates read it themselves, not through the rule of another definition on the path, nor inside
  a part that computes on reals (see `rounded`): those are functions of their own, which call what they read.
The step computes it by calling its function, so its contract is the function's.

A definition read twice only on some paths (MLCA-T's `L` in WAITING, read again by `wait_left` after
`urgent_left` when the need is urgent and no lane is safe) is left to its calls: computing it first would cost
every step of the mode that defers.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

from mlca_verify.model import BinOp, Expr, Ite, Machine, Var, children, nodes


@dataclass(frozen=True)
class ModePath:
    """What one mode's step evaluates: its written guards in order, the updates of its transitions, and the
    `every` rules, those no transition of the machine overrides (`fixed`) apart."""

    state: str
    guards: tuple[Expr, ...]
    updates: tuple[Expr, ...]
    fixed: tuple[Expr, ...]
    overridden: tuple[Expr, ...]


def surely_read(e: Expr) -> Iterator[Expr]:
    """The nodes of `e` that are evaluated whenever `e` is: not the right of `and`, `or` or `->`, nor a branch of
    `if then else` (C's `&&`, `||` and `?:` skip them)."""
    todo = [e]
    while todo:
        node = todo.pop()
        yield node
        if isinstance(node, BinOp) and node.op in ("and", "or", "->"):
            todo.append(node.left)
        elif isinstance(node, Ite):
            todo.append(node.cond)
        else:
            todo.extend(children(node))


def _count(exprs: Iterable[Expr], rules: Mapping[str, Expr]) -> Counter[str]:
    """How many times the step's calls compute each definition over `exprs` (a rule is computed at every read)."""
    counts: Counter[str] = Counter()
    todo = list(exprs)
    while todo:
        for node in nodes(todo.pop()):
            if isinstance(node, Var) and node.name in rules:
                counts[node.name] += 1
                todo.append(rules[node.name])
    return counts


def _always(path: ModePath, rules: Mapping[str, Expr]) -> frozenset[str]:
    """The definitions evaluated on every path through the mode's step, through the rules of those that are."""
    roots = [*path.guards[:1], *path.fixed]
    found: set[str] = set()
    while roots:
        for node in surely_read(roots.pop()):
            if isinstance(node, Var) and node.name in rules and node.name not in found:
                found.add(node.name)
                roots.append(rules[node.name])
    return frozenset(found)


def _readers(rules: Mapping[str, Expr]) -> dict[str, frozenset[str]]:
    """Each definition's readers among the definitions."""
    return {
        name: frozenset(other for other, rule in rules.items() if any(
            isinstance(n, Var) and n.name == name for n in nodes(rule)))
        for name in rules
    }  # fmt: skip


def computed_once(path: ModePath, rules: Mapping[str, Expr], in_parts: frozenset[str]) -> frozenset[str]:
    """The definitions the mode's step computes once (see the module's doc); `in_parts` are those a part that
    computes on reals reads."""
    counts = _count((*path.guards, *path.updates, *path.fixed, *path.overridden), rules)
    always = _always(path, rules)
    readers = _readers(rules)
    return frozenset(
        n
        for n, k in counts.items()
        if k >= 2 and n in always and n not in in_parts and not any(counts[r] for r in readers[n])
    )


def mode_paths(m: Machine, guards: Mapping[str, Sequence[Expr]]) -> tuple[ModePath, ...]:
    """Each mode's path: `guards` as the step writes them for the mode, the spec's updates and rules."""
    assigned = {u.variable for t in m.transitions for u in t.updates}
    fixed = tuple(v.every for v in m.variables if v.every is not None and v.name not in assigned)
    overridden = tuple(v.every for v in m.variables if v.every is not None and v.name in assigned)
    return tuple(
        ModePath(
            state,
            tuple(guards[state]),
            tuple(u.expr for t in m.outgoing(state) for u in t.updates),
            fixed,
            overridden,
        )
        for state in m.states
    )
