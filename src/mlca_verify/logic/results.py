"""Verdicts and counterexample traces: plain data, shared by the engine, the reports and the CLI."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from mlca_verify.model import Verdict

Kind = Literal["determinism", "completeness", "reachability", "dead-transition", "invariant", "liveness", "equivalence"]


@dataclass(frozen=True)
class Outcome:
    """One possible result of a step: the transition that fires (None: no transition) and the next state."""

    transition: str | None
    cite: str | None
    next: str | None
    machine: str | None = None

    def to_json(self) -> dict[str, Any]:
        data: dict[str, Any] = {"transition": self.transition, "cite": self.cite, "next": self.next}
        if self.machine is not None:
            data["machine"] = self.machine
        return data


@dataclass(frozen=True)
class Step:
    """A step of a trace. `alternatives` lists other outcomes of the same state and inputs, where the check is
    about them (nondeterminism, two machines that differ)."""

    state: str
    inputs: dict[str, bool]
    outcome: Outcome
    alternatives: tuple[Outcome, ...] = ()

    def to_json(self) -> dict[str, Any]:
        data: dict[str, Any] = {"state": self.state, "inputs": dict(self.inputs), **self.outcome.to_json()}
        if self.alternatives:
            data["alternatives"] = [a.to_json() for a in self.alternatives]
        return data


@dataclass(frozen=True)
class Counterexample:
    """A finite trace from the initial state; with `loop_start`, steps[loop_start:] repeat forever (a lasso)."""

    steps: tuple[Step, ...]
    loop_start: int | None = None

    def to_json(self) -> dict[str, Any]:
        return {"steps": [s.to_json() for s in self.steps], "loop_start": self.loop_start}


@dataclass(frozen=True)
class Result:
    prop: str
    kind: Kind
    verdict: Verdict
    expected: Verdict
    cite: str
    seconds: float = 0.0
    counterexample: Counterexample | None = None
    detail: str = ""

    @property
    def ok(self) -> bool:
        return self.verdict == self.expected

    def to_json(self) -> dict[str, Any]:
        return {
            "property": self.prop,
            "kind": self.kind,
            "verdict": self.verdict,
            "expected": self.expected,
            "ok": self.ok,
            "cite": self.cite,
            "seconds": round(self.seconds, 6),
            "detail": self.detail,
            "counterexample": None if self.counterexample is None else self.counterexample.to_json(),
        }
