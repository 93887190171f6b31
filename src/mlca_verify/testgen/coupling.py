"""Conditions no suite can show independent as clang counts MC/DC. The search pairs conditions by masking MC/DC
(the other conditions may change where they cannot affect the outcome); clang's source-based MC/DC asks for
unique cause: two executions that differ in the condition and in the outcome while every other condition that
both evaluate keeps its value (a short-circuited one is free). Coupled conditions (`floor == 0`, `floor == 1`
and `floor == 2` in one decision) can have the first and not the second; z3 tells which, from the spec alone."""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import z3

from mlca_verify.logic.symbolic import System, variable_bounds
from mlca_verify.model import Expr, Machine, Var, nodes, show
from mlca_verify.testgen.definition_reads import condition_paths
from mlca_verify.testgen.objectives import atoms, definition_decisions, guard_decisions

BUDGET = 5_000_000  # z3's resources per query, so that the answer does not depend on the machine's load


@dataclass(frozen=True)
class _Execution:
    """One evaluation of a decision: what its context satisfies, its outcome, and per condition its value and
    whether the code evaluates it."""

    facts: list[z3.BoolRef]
    outcome: z3.BoolRef
    values: list[z3.BoolRef]
    evaluated: list[z3.BoolRef]


def _execution(system: System, expr: Expr, tag: str) -> _Execution:
    """An evaluation of `expr` in a context whose variables are in their ranges, at the params' defaults (where
    the suite runs)."""
    frame = system.frame(tag)
    at = system.valuation(frame, system.inputs(tag))
    facts = [system.well_formed(frame), *variable_bounds(system.m, frame.variables)]
    values = [cast(z3.BoolRef, system.ev(a, at)) for a in atoms(expr)]
    evaluated = [z3.And(True, *[system.ev(g, at) for g in path]) for path in condition_paths(expr)]
    return _Execution(facts, cast(z3.BoolRef, system.ev(expr, at)), values, evaluated)


def unique_cause_impossible(machine: Machine, expr: Expr, k: int) -> bool:
    """Whether no two evaluations of `expr` show its condition k (from 0) alone deciding it, as clang counts."""
    system = System(machine)
    x, y = _execution(system, expr, "ucx"), _execution(system, expr, "ucy")
    solver = z3.Solver()
    solver.set("rlimit", BUDGET)
    solver.add(*x.facts, *y.facts, x.outcome != y.outcome)
    solver.add(x.evaluated[k], y.evaluated[k], x.values[k] != y.values[k])
    for j in range(len(x.values)):
        if j != k:
            both = z3.And(x.evaluated[j], y.evaluated[j])
            solver.add(z3.Implies(both, x.values[j] == y.values[j]))
    return bool(solver.check() == z3.unsat)


def _names(expr: Expr) -> set[str]:
    return {n.name for n in nodes(expr) if isinstance(n, Var)}


def coupling_reason(machine: Machine, element: str, k: int, conditions: int) -> str:
    """Why MC/DC condition k (from 0) of a decision of `conditions` conditions in `element`'s code has no pair
    as clang counts it ("" where a pair may exist, or where the decision is not one of the element's)."""
    candidates = [e for e in _decisions(machine, element) if len(atoms(e)) == conditions]
    if not candidates or not all(unique_cause_impossible(machine, e, k) for e in candidates):
        return ""
    expr = candidates[0]
    cond = atoms(expr)[k]
    coupled = [show(a) for j, a in enumerate(atoms(expr)) if j != k and _names(a) & _names(cond)]
    with_text = f" (coupled with {', '.join(coupled)}: they read the same names)" if coupled else ""
    return (
        f"{show(cond)} in {element}: clang counts MC/DC by unique cause, and no two contexts in their ranges, at "
        f"the params' defaults, show it alone deciding while every other condition both evaluate keeps its "
        f"value{with_text}; the suite pairs it by masking MC/DC"
    )


def _decisions(machine: Machine, element: str) -> list[Expr]:
    """The decisions of a definition (its samples' range checks and its rule) or of a transition's guard."""
    found = (*definition_decisions(machine), *guard_decisions(machine))
    return [d.expr for d in found if d.id.split(":")[-1] == element]
