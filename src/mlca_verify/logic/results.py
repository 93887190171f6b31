"""Verdicts and counterexample traces: plain data, shared by the engine, the reports and the CLI."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from mlca_verify.json_types import JsonObject
from mlca_verify.model import Verdict

# the engine that decided a property ("" where none did): the explicit-state search, BMC, k-induction, PDR, both
# (k-induction then PDR), the abstraction's refinement, the lasso search of a response without a bound
Engine = Literal["", "explicit", "bmc", "k-induction", "pdr", "k-induction+pdr", "abstraction", "lasso"]
Kind = Literal[
    "determinism",
    "completeness",
    "reachability",
    "dead-transition",
    "invariant",
    "liveness",
    "equivalence",
    "range",
    "division",
    "overflow",
    "lemma",
]
Number = bool | int | float


@dataclass(frozen=True)
class Outcome:
    """One possible result of a step: the transition that fires (None: no transition) and the next state."""

    transition: str | None
    cite: str | None
    next: str | None
    machine: str | None = None

    def to_json(self) -> JsonObject:
        data: JsonObject = {"transition": self.transition, "cite": self.cite, "next": self.next}
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
    # In a machine with data: the step's signals and the definitions as its guards saw them, and the
    # variables and outputs after it.
    signals: dict[str, Number] = field(default_factory=dict)
    definitions: dict[str, Number] = field(default_factory=dict)
    variables: dict[str, Number] = field(default_factory=dict)
    outputs: dict[str, Number] = field(default_factory=dict)

    def to_json(self) -> JsonObject:
        data: JsonObject = {"state": self.state, "inputs": dict(self.inputs), **self.outcome.to_json()}
        if self.alternatives:
            data["alternatives"] = [a.to_json() for a in self.alternatives]
        for key in ("signals", "definitions", "variables", "outputs"):
            if getattr(self, key):
                data[key] = dict(getattr(self, key))
        return data


@dataclass(frozen=True)
class Counterexample:
    """A finite trace from the initial state; with `loop_start`, steps[loop_start:] repeat forever (a lasso)."""

    steps: tuple[Step, ...]
    loop_start: int | None = None
    params: dict[str, Number] = field(default_factory=dict)  # in a machine with data: the params of the run
    point: bool = False  # one valuation, not a run: a lemma's counterexample (its one step holds the values)

    def to_json(self) -> JsonObject:
        data: JsonObject = {"steps": [s.to_json() for s in self.steps], "loop_start": self.loop_start}
        if self.params:
            data["params"] = dict(self.params)
        if self.point:
            data["point"] = True
        return data


@dataclass(frozen=True)
class Proof:
    """How a machine with data was decided: the engine, the k of k-induction, the certificate of PDR (an
    inductive invariant in SMT-LIB, over the frame's constants) and whether a separate query confirmed it."""

    engine: Engine
    parametric: bool
    k: int | None = None
    certificate: str | None = None
    certificate_checked: bool = False
    assumptions: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    def to_json(self) -> JsonObject:
        return {
            "engine": self.engine,
            "parametric": self.parametric,
            "k": self.k,
            "certificate": self.certificate,
            "certificate_checked": self.certificate_checked,
            "assumptions": list(self.assumptions),
            "notes": list(self.notes),
        }


@dataclass(frozen=True)
class Result:
    """The verdict on one property (`prop`, of `kind`), the one the spec expects, and what shows it: a
    counterexample, a proof's certificate, or the reason it is unknown (`detail`)."""

    prop: str
    kind: Kind
    verdict: Verdict
    expected: Verdict
    cite: str
    seconds: float = 0.0
    counterexample: Counterexample | None = None
    detail: str = ""
    proof: Proof | None = None
    # Where a verdict decided over the reals is not shown to carry over to the code's binary64 arithmetic: why.
    caveat: str = ""

    @property
    def ok(self) -> bool:
        """Whether the verdict is the one the spec expects."""
        return self.verdict == self.expected

    def to_json(self) -> JsonObject:
        """The result as `check --json` writes it (schema mlca-verify.check/3)."""
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
            **({} if self.proof is None else {"proof": self.proof.to_json()}),
            **({"caveat": self.caveat} if self.caveat else {}),
        }
