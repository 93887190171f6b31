"""Where the generated code's arithmetic can part from the engine's: the elements that divide (`div:`), those
that compute ints which intervals cannot keep within 64 bits (`ovf:`), and the elements a verdict depends on (its
cone), which a division by a divisor that can be zero leaves undecided for the code."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Literal

from mlca_verify.intervals import Interval, enclose, machine_intervals
from mlca_verify.model import Arith, Call, Expr, Machine, Neg, Num, Var, bodies, name_types, nodes, type_of

INT64 = (-(2**63), 2**63 - 1)  # the generated code's ints


def _fits(values: Interval) -> bool:
    return values.within(Fraction(INT64[0]), Fraction(INT64[1]))


def divisions(expr: Expr) -> list[Arith]:
    return [n for n in nodes(expr) if isinstance(n, Arith) and n.op == "/"]


When = Literal["pre", "post", "both"]  # where an element is evaluated: before the step, after it, or both


@dataclass(frozen=True)
class Site:
    """An element that computes: its name, its expressions, and where the code evaluates them."""

    name: str
    exprs: tuple[Expr, ...]
    when: When


def _sites(m: Machine) -> list[Site]:
    sites = [Site(d.name, (d.expr,), "both") for d in m.definitions]
    sites += [Site(v.name, (v.every,), "pre") for v in m.variables if v.every is not None]
    sites += [Site(t.id, (t.guard, *(u.expr for u in t.updates)), "pre") for t in m.transitions]
    sites += [Site(o.name, (o.expr,), "both") for o in m.outputs]
    sites += [Site(i.id, (i.expr,), "post") for i in m.invariants]
    return sites


def division_sites(m: Machine) -> list[Site]:
    """Each element that divides."""
    return [site for site in _sites(m) if any(divisions(e) for e in site.exprs)]


@dataclass(frozen=True)
class OverflowSite:
    site: Site
    nodes: tuple[Expr, ...]  # the int values intervals cannot keep within 64 bits


def overflow_sites(m: Machine) -> list[OverflowSite]:
    """The elements with an int value (an operation's result or a literal) that intervals cannot keep within
    64 bits; each becomes an `ovf:` check. Elsewhere the code cannot overflow."""
    kinds = name_types(m)
    names = machine_intervals(m, at_defaults=False)  # the code may run at any param value in range
    result = []
    for site in _sites(m):
        risky = [
            n
            for e in site.exprs
            for n in nodes(e)
            if isinstance(n, Arith | Neg | Num | Call)
            and (not isinstance(n, Call) or n.fn == "abs")
            and not (isinstance(n, Arith) and n.op == "/")
            and type_of(n, kinds) == "int"
            and not _fits(enclose(n, names))
        ]
        if risky:
            result.append(OverflowSite(site, tuple(dict.fromkeys(risky))))
    return result


def _reads(m: Machine, exprs: Sequence[Expr]) -> set[str]:
    """The names `exprs` read, through definitions and outputs."""
    body = bodies(m)
    seen: set[str] = set()
    todo = list(exprs)
    while todo:
        for node in nodes(todo.pop()):
            if isinstance(node, Var) and node.name not in seen:
                seen.add(node.name)
                if node.name in body:
                    todo.append(body[node.name])
    return seen


def step_cone(m: Machine) -> frozenset[str]:
    """The elements every step depends on, by the names `division_sites` gives them: every transition and
    variable, and what the guards, updates, `every` and assumptions read."""
    step = [t.guard for t in m.transitions] + [u.expr for t in m.transitions for u in t.updates]
    step += [v.every for v in m.variables if v.every is not None] + [a.expr for a in m.assumptions]
    return frozenset(_reads(m, step) | {t.id for t in m.transitions} | {v.name for v in m.variables})


def division_cone(m: Machine, step: frozenset[str], exprs: Sequence[Expr], prop: str) -> frozenset[str]:
    """The elements a verdict depends on: the step's (`step_cone`), what the property's `exprs` read, and
    `prop` itself."""
    return step | _reads(m, exprs) | {prop}
