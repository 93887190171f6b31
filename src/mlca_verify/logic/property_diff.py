"""Compare two versions of a property by meaning, not by id: the new one implies the old (strengthened), the
old implies the new (weakened), both (equivalent), or neither; and the environment assumptions together, which
every guarantee rests on. Each expression is read over one valuation
shared by both machines: the same inputs, state, variables, signals, params and previous values, with each
machine's own definitions expanded."""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Literal

import z3

from mlca_verify.logic.solver import budget
from mlca_verify.logic.symbolic import StepInputs, System, Valuation, sort_of
from mlca_verify.model import Expr, Invariant, Liveness, Machine, Num, own, prevs_of, show

Relation = Literal["equivalent", "strengthened", "weakened", "incomparable", "unknown"]


@dataclass(frozen=True)
class PropertyChange:
    prop: str
    kind: Literal["invariant", "liveness", "assumption"]
    old: str
    new: str
    relation: Relation

    @property
    def regression(self) -> bool:
        """The new property no longer guarantees all that the old one did."""
        return self.relation in ("weakened", "incomparable")


class SharedValuation:
    """One valuation of every name of two machines, and each machine's view of it."""

    def __init__(self, old: Machine, new: Machine) -> None:
        states = sorted(set(old.states) | set(new.states))
        self.index = {s: k for k, s in enumerate(states)}
        self.mode = z3.Int(own("mode"))
        self.systems = {id(m): self.system(m) for m in (old, new)}

    def system(self, m: Machine) -> System:
        prevs = prevs_of(*_expressions(m))
        system = System(m, prevs, parametric=True)
        system.states = self.index
        return system

    def of(self, m: Machine) -> tuple[System, Valuation]:
        system = self.systems[id(m)]
        inputs = StepInputs(
            {i.name: z3.Bool(i.name) for i in m.inputs},
            {s.name: z3.Const(s.name, sort_of(s.type)) for s in m.signals},
            {},
        )
        variables = {v.name: z3.Const(v.name, sort_of(v.type)) for v in m.variables}
        previous = {
            k: z3.Const(own(f"prev:{show(p.arg)}"), sort_of(system.prev_types[k])) for k, p in enumerate(system.prevs)
        }
        return system, Valuation(self.mode, variables, inputs, system.shared_params, previous)

    def formula(self, m: Machine, expr: Expr) -> z3.ExprRef:
        system, valuation = self.of(m)
        return system.ev(expr, valuation)


def _expressions(m: Machine) -> list[Expr]:
    return [i.expr for i in m.invariants] + [e for lv in m.liveness for e in (lv.assume, lv.goal)]


def implies(a: z3.ExprRef, b: z3.ExprRef, timeout_ms: int) -> bool | None:
    solver = z3.Solver()
    budget(solver, timeout_ms)
    answer = solver.check(z3.And(a, z3.Not(b)))
    return None if answer == z3.unknown else answer == z3.unsat


def _relation(forward: bool | None, backward: bool | None) -> Relation:
    """`forward`: new implies old; `backward`: old implies new."""
    if forward is None or backward is None:
        return "unknown"
    if forward and backward:
        return "equivalent"
    return "strengthened" if forward else "weakened" if backward else "incomparable"


def _bound(live: Liveness) -> Expr | None:
    if live.bound is not None:
        return live.bound
    return None if live.within is None else Num(Fraction(live.within), False)


def property_changes(old: Machine, new: Machine, timeout_ms: int, *, assumptions: bool = True) -> list[PropertyChange]:
    """Each declared property present in both whose text changed, with how its meaning changed; and, with
    `assumptions`, the `[[assume]]`s together (a network's are its channels', which `network_diff` compares)."""
    shared = SharedValuation(old, new)
    after_inv = {p.id: p for p in new.invariants}
    after_live = {p.id: p for p in new.liveness}
    changes = []
    for inv in old.invariants:
        other = after_inv.get(inv.id)
        if other is not None and show(inv.expr) != show(other.expr):
            changes.append(_invariant_change(shared, (old, new), inv, other, timeout_ms))
    for live in old.liveness:
        lv = after_live.get(live.id)
        if lv is not None and _text(live) != _text(lv):
            changes.append(_liveness_change(shared, (old, new), live, lv, timeout_ms))
    assumed = _assumption_change(shared, (old, new), timeout_ms) if assumptions else None
    return changes if assumed is None else [*changes, assumed]


def _assumptions_text(m: Machine) -> str:
    return " and ".join(f"({show(a.expr)})" for a in m.assumptions) or "true"


def _assumption_change(
    shared: SharedValuation, pair: tuple[Machine, Machine], timeout_ms: int
) -> PropertyChange | None:
    """The environment assumptions together, compared by meaning. Every guarantee of a machine is claimed only
    where its assumptions hold, so assumptions that allow fewer environments weaken every guarantee, whatever
    the verdicts say; its name lists the new assumptions the old ones do not imply (those that narrow)."""
    old, new = pair
    if sorted(show(a.expr) for a in old.assumptions) == sorted(show(a.expr) for a in new.assumptions):
        return None
    fa = z3.And(z3.BoolVal(True), *[shared.formula(old, a.expr) for a in old.assumptions])
    parts = {a.id: shared.formula(new, a.expr) for a in new.assumptions}
    fb = z3.And(z3.BoolVal(True), *parts.values())
    relation = _relation(implies(fa, fb, timeout_ms), implies(fb, fa, timeout_ms))
    narrowing = [name for name, part in parts.items() if implies(fa, part, timeout_ms) is not True]
    name = "[[assume]]" + (f" {', '.join(narrowing)}" if narrowing else "")
    return PropertyChange(name, "assumption", _assumptions_text(old), _assumptions_text(new), relation)


def _invariant_change(
    shared: SharedValuation, pair: tuple[Machine, Machine], a: Invariant, b: Invariant, timeout_ms: int
) -> PropertyChange:
    old, new = pair
    fa, fb = shared.formula(old, a.expr), shared.formula(new, b.expr)
    relation = _relation(implies(fb, fa, timeout_ms), implies(fa, fb, timeout_ms))
    return PropertyChange(a.id, "invariant", show(a.expr), show(b.expr), relation)


def _text(live: Liveness) -> str:
    bound = _bound(live)
    return f"{show(live.assume)} ~> {show(live.goal)}" + ("" if bound is None else f" within {show(bound)}")


def _liveness_change(
    shared: SharedValuation, pair: tuple[Machine, Machine], a: Liveness, b: Liveness, timeout_ms: int
) -> PropertyChange:
    """Response "if assume persists, goal within the bound": stronger with a weaker assumption, a stronger goal
    and a smaller bound."""
    old, new = pair
    aa, ab = shared.formula(old, a.assume), shared.formula(new, b.assume)
    ga, gb = shared.formula(old, a.goal), shared.formula(new, b.goal)
    ba, bb = _bound(a), _bound(b)
    bounds_forward: bool | None
    bounds_backward: bool | None
    if ba is None or bb is None:
        bounds_forward = bb is not None or ba is None  # a bound is stronger than none
        bounds_backward = ba is not None or bb is None
    else:
        va, vb = shared.formula(old, ba), shared.formula(new, bb)
        bounds_forward = implies(z3.BoolVal(True), vb <= va, 1000)
        bounds_backward = implies(z3.BoolVal(True), va <= vb, 1000)
    forward = _all(implies(aa, ab, timeout_ms), implies(gb, ga, timeout_ms), bounds_forward)
    backward = _all(implies(ab, aa, timeout_ms), implies(ga, gb, timeout_ms), bounds_backward)
    return PropertyChange(a.id, "liveness", _text(a), _text(b), _relation(forward, backward))


def _all(*answers: bool | None) -> bool | None:
    if any(a is False for a in answers):
        return False
    return None if any(a is None for a in answers) else True
