"""Lemmas: statements over the spec's definitions that must hold for every value of the signals in their declared
ranges (and of the params in theirs when the lemma is parametric, else at their defaults), decided over the reals
by z3's nonlinear arithmetic. The query of each lemma is also written as an SMT-LIB 2 script (`smt2`), so that a
second solver can decide it again: unsat means the lemma holds, sat that it is violated.

Definitions are evaluated as the engine evaluates them everywhere else (`System.ev`), with the same validity
gating; within the declared ranges every sample is valid, so a gated definition is its rule.
"""

from __future__ import annotations

from dataclasses import dataclass

import z3

from mlca_verify.escape import c_form
from mlca_verify.logic.results import Counterexample, Number, Outcome, Step
from mlca_verify.logic.solver import budget
from mlca_verify.logic.symbolic import StepInputs, System, Valuation, python_value, sort_of, value_of
from mlca_verify.model import Expr, Lemma, Machine, Var, Verdict, nodes

Decision = tuple[Verdict, str, Counterexample | None]


@dataclass(frozen=True)
class LemmaQuery:
    """The negation of a lemma with the ranges it is stated over: satisfiable exactly when the lemma fails."""

    solver: z3.Solver
    bools: dict[str, z3.BoolRef]
    signals: dict[str, z3.ExprRef]
    params: dict[str, z3.ExprRef]
    definitions: dict[str, z3.ExprRef]

    def smt2(self, lemma: Lemma) -> str:
        """The query as an SMT-LIB 2 script: `unsat` means the lemma holds."""
        head = f"; lemma {lemma.id}: unsat means it holds for every value in the ranges, sat that it fails\n"
        return head + "(set-logic ALL)\n" + str(self.solver.to_smt2())


def query(machine: Machine, lemma: Lemma, parametric: bool, timeout_ms: int) -> LemmaQuery:
    system = System(machine, parametric=parametric)
    bools = {i.name: z3.Bool(f"input!{i.name}") for i in machine.inputs}
    signals = {s.name: z3.Const(f"signal!{s.name}", sort_of(s.type)) for s in machine.signals}
    solver = z3.Solver()
    budget(solver, timeout_ms)
    for s in machine.signals:
        low, high = (value_of(v, s.type) for v in s.range)
        solver.add(signals[s.name] >= low, signals[s.name] <= high)
    params: dict[str, z3.ExprRef] = {}
    for p in machine.params:
        if parametric and p.range is not None:
            params[p.name] = z3.Const(f"param!{p.name}", sort_of(p.type))
            low, high = (value_of(v, p.type) for v in p.range)
            solver.add(params[p.name] >= low, params[p.name] <= high)
        else:
            params[p.name] = value_of(p.default, p.type)
    v = Valuation(z3.IntVal(machine.states.index(machine.initial)), {}, StepInputs(bools, signals, {}), params)
    solver.add(z3.Not(system.ev(lemma.expr, v)))
    definitions = {d.name: system.ev(d.expr, v) for d in machine.definitions if d.name in _read_by(machine, lemma)}
    return LemmaQuery(solver, bools, signals, params, definitions)


def _read_by(machine: Machine, lemma: Lemma) -> set[str]:
    """The definitions a lemma reads, directly or through others."""
    names = {d.name for d in machine.definitions}
    return reads(machine, lemma.expr) & names


def reads(machine: Machine, expr: Expr) -> set[str]:
    """Every name an expression reads, directly or through the definitions it reads (theirs included)."""
    by_name = {d.name: d for d in machine.definitions}
    seen: set[str] = set()
    todo = list(named(expr))
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            if name in by_name:
                todo += named(by_name[name].expr)
    return seen


def named(expr: Expr) -> set[str]:
    """The names an expression reads itself (not through definitions)."""
    return {x.name for x in nodes(expr) if isinstance(x, Var)}


def decide(machine: Machine, lemma: Lemma, parametric: bool, timeout_ms: int) -> Decision:
    q = query(machine, lemma, parametric, timeout_ms)
    answer = q.solver.check()
    if answer == z3.unsat:
        where = "every param value in range" if parametric else "the params' defaults"
        return "holds", f"holds for every signal value in range, at {where} (nonlinear real arithmetic)", None
    if answer == z3.unknown:
        return "unknown", f"z3 could not decide it: {q.solver.reason_unknown()}", None
    model = q.solver.model()

    def val(term: z3.ExprRef) -> Number:
        return python_value(model.eval(term, model_completion=True))

    step = Step(
        machine.initial,
        {k: bool(val(b)) for k, b in q.bools.items()},
        Outcome(None, None, None),
        signals={k: val(s) for k, s in q.signals.items()},
        definitions={k: val(d) for k, d in q.definitions.items()},
    )
    params = {k: val(p) for k, p in q.params.items()}
    shown = ", ".join(f"{k} = {v}" for k, v in {**step.signals, **params}.items())
    return "violated", f"fails at {shown}", Counterexample((step,), None, params, point=True)


def lemma_scripts(machine: Machine, parametric: bool, timeout_ms: int) -> dict[str, str]:
    """File name -> SMT-LIB 2 script of each lemma's query (`<machine>_<lemma id>.smt2`)."""
    scripts = {}
    for lemma in machine.lemmas:
        q = query(machine, lemma, parametric or lemma.parametric, timeout_ms)
        scripts[f"{machine.name.lower()}_{c_form(lemma.id)}.smt2"] = q.smt2(lemma)
    return scripts
