"""`mlca-verify diff OLD NEW` as a regression gate: what changed between two versions of a machine.

Verdicts that changed (a property that held and no longer does is a regression, and so is a declared
invariant or liveness property that held and is gone; a built-in check of a removed state or transition
simply goes with it), transitions
added, removed or changed (matched by id), and the behaviour that changed, each difference with a witness."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mlca_verify.logic.results import Kind, Result
from mlca_verify.model import Machine, Transition, Verdict, show


@dataclass(frozen=True)
class VerdictChange:
    prop: str
    kind: Kind
    old: Verdict | None  # None: the property does not exist on that side
    new: Verdict | None

    @property
    def regression(self) -> bool:
        if self.new is None:
            return self.old == "holds" and self.kind in DECLARED
        return self.old == "holds" and self.new != "holds"

    @property
    def label(self) -> str:
        if self.regression:
            return "REGRESSION" if self.new is not None else "REGRESSION (removed)"
        if self.old is None:
            return "new"
        if self.new is None:
            return "removed"
        return "fixed" if self.new == "holds" else "changed"


@dataclass(frozen=True)
class TransitionChange:
    id: str
    change: str  # added, removed, changed
    old: str | None
    new: str | None


DECLARED = ("invariant", "liveness", "equivalence")


def verdict_changes(old: Sequence[Result], new: Sequence[Result]) -> list[VerdictChange]:
    before = {r.prop: r for r in old}
    after = {r.prop: r for r in new}
    changes = []
    for prop in list(before) + [p for p in after if p not in before]:
        b, a = before.get(prop), after.get(prop)
        kind = (b or a).kind  # type: ignore[union-attr]
        if (b and b.verdict) != (a and a.verdict):
            changes.append(VerdictChange(prop, kind, b.verdict if b else None, a.verdict if a else None))
    return changes


def describe(t: Transition) -> str:
    source = "*" if t.sources is None else ", ".join(t.sources)
    return f"{source} -> {t.target} when {show(t.guard)}"


def transition_changes(old: Machine, new: Machine) -> list[TransitionChange]:
    before = {t.id: t for t in old.transitions}
    after = {t.id: t for t in new.transitions}
    order_before = [tid for tid in before if tid in after]
    order_after = [tid for tid in after if tid in before]
    changes = []
    for tid, t in before.items():
        if tid not in after:
            changes.append(TransitionChange(tid, "removed", describe(t), None))
        elif describe(t) != describe(after[tid]):
            changes.append(TransitionChange(tid, "changed", describe(t), describe(after[tid])))
        elif order_before.index(tid) != order_after.index(tid):
            changes.append(
                TransitionChange(
                    tid,
                    "changed",
                    f"{describe(t)} (priority {order_before.index(tid) + 1})",
                    f"{describe(t)} (priority {order_after.index(tid) + 1})",
                )
            )
    changes += [TransitionChange(tid, "added", None, describe(t)) for tid, t in after.items() if tid not in before]
    return changes
