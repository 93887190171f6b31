"""A language-neutral intermediate form of a deterministic machine, ready for any renderer.

Per state, the branches that apply there in priority order (global `from = "*"` transitions included), then
the default (`otherwise = "stay"`). Renderers never re-derive semantics from the spec; they print this.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from mlca_verify.codegen.simplify import fold, in_context
from mlca_verify.errors import CodegenError
from mlca_verify.logic.solver import Solver
from mlca_verify.model import Const, Expr, Invariant, Machine, StateIn, inputs_of

GENERATOR_NAME = "mlca-verify"


@dataclass(frozen=True)
class Branch:
    transition: str
    guard: Expr  # the spec's guard (contracts)
    code: Expr  # the same condition in its first-match context (code)
    target: str
    cite: str


@dataclass(frozen=True)
class StateCase:
    state: str
    index: int
    cite: str
    branches: tuple[Branch, ...]  # every transition that leaves the state, in priority order (the contracts)
    tested: tuple[Branch, ...] = ()  # those the code tests after the hoisted ones (see `_tested`)
    closed: bool = False  # the last of `tested` always fires: no `otherwise`


@dataclass(frozen=True)
class InputIR:
    name: str
    doc: str
    cite: str


@dataclass(frozen=True)
class InvariantIR:
    id: str
    expr: Expr
    cite: str
    code: Expr  # the same expression with constant parts folded
    proved: bool  # expected to hold and proved: stated as a contract on the step function, not only monitored
    implied: bool = False  # `state in {every state}`: the monitor's state check already decides it
    expected: bool = True  # the spec expects it to hold


@dataclass(frozen=True)
class MachineIR:
    name: str
    module: str  # lower-case stem: <module>_fsm.py, <module>_fsm.h, C function prefix
    macro: str  # upper-case prefix of C constants and the header guard
    doc: str
    cite: str
    spec_path: str
    spec_sha256: str
    generator: str
    initial: str
    fallback: str  # the state a state value that names no state goes to
    states: tuple[str, ...]
    inputs: tuple[InputIR, ...]
    cases: tuple[StateCase, ...]
    # how many leading branches every state shares (`from = "*"` transitions to the fallback state): the code
    # tests them once, before the switch; out-of-range states still end in the fallback state
    hoisted: int
    step_reads_inputs: bool  # C needs `(void)in;` where no condition reads an input
    invariants_read_inputs: bool
    otherwise_cite: str
    invariants: tuple[InvariantIR, ...]
    reachable: tuple[str, ...]


def require_first_match(machine: Machine) -> None:
    """Refuse a nondeterministic machine (before any work on it): code needs one next state."""
    if machine.semantics != "first-match":
        raise CodegenError.at(
            machine.loc,
            f"machine '{machine.name}' is nondeterministic (semantics = \"any-enabled\"); "
            "code is generated only for first-match machines",
        )


def build_ir(
    machine: Machine,
    spec_path: str,
    spec_sha256: str,
    version: str,
    reachable: tuple[str, ...],
    *,
    proved: frozenset[str] | None = None,
) -> MachineIR:
    """The IR of a first-match, gap-free machine (anything else is refused with a `CodegenError`); `proved` names
    the invariants the engine proves (None: every one the spec expects to hold), the only ones the step's contract
    states."""
    require_first_match(machine)
    solver = Solver(machine.input_names)
    chains = []
    for state in machine.states:
        out = [t for t in machine.transitions if t.applies_to(state)]
        codes = in_context([t.guard for t in out], solver, machine, state)
        chains.append(tuple(Branch(t.id, t.guard, c, t.target, t.cite) for t, c in zip(out, codes, strict=True)))
    hoisted = _hoisted(machine, chains[0])
    cases = [
        StateCase(state, index, machine.cite, branches, *_tested(branches[hoisted:], state))
        for index, (state, branches) in enumerate(zip(machine.states, chains, strict=True))
    ]
    module = machine.name.lower()
    return MachineIR(
        name=machine.name,
        module=module,
        macro=machine.name.upper(),
        doc=machine.doc,
        cite=machine.cite,
        spec_path=spec_path,
        spec_sha256=spec_sha256,
        generator=f"{GENERATOR_NAME} {version}",
        initial=machine.initial,
        fallback=machine.fallback_state,
        states=machine.states,
        inputs=tuple(InputIR(i.name, i.doc, i.cite) for i in machine.inputs),
        cases=tuple(cases),
        hoisted=hoisted,
        step_reads_inputs=any(inputs_of(c) for c in _conditions(cases, hoisted)),
        invariants_read_inputs=any(inputs_of(fold(i.expr, solver)) for i in machine.invariants),
        otherwise_cite=machine.cite,
        invariants=tuple(_invariant(i, fold(i.expr, solver), machine.states, proved) for i in machine.invariants),
        reachable=reachable,
    )


def _hoisted(machine: Machine, first: tuple[Branch, ...]) -> int:
    """How many leading `from = "*"` transitions to the fallback state the code tests once, before telling the
    states apart (each with a condition that is not constant)."""
    hoisted = 0
    for t, branch in zip(machine.transitions, first, strict=False):
        if t.sources is not None or t.target != machine.fallback_state or isinstance(branch.code, Const):
            break
        hoisted += 1
    return hoisted


def _conditions(cases: list[StateCase], hoisted: int) -> Iterator[Expr]:
    """Every condition the step's code tests (a branch that always fires where reached is tested by none)."""
    yield from (b.code for b in cases[0].branches[:hoisted]) if cases else ()
    for case in cases:
        yield from (b.code for b in case.tested[: len(case.tested) - 1 if case.closed else None])


def _tested(branches: tuple[Branch, ...], state: str) -> tuple[tuple[Branch, ...], bool]:
    """The branches the code tests, in order: none that never fires where the chain reaches it, none after one
    that always fires there, and none just before the chain's end that goes where the end goes (the `otherwise`,
    which stays in `state`, or the last branch when it always fires: cppcheck's duplicateBranch); and whether the
    last always fires (the chain then has no `otherwise`)."""
    tested: list[Branch] = []
    closed = False
    for b in branches:
        if b.code == Const(False):
            continue
        tested.append(b)
        if b.code == Const(True):
            closed = True
            break
    end = tested[-1].target if closed else state
    kept = len(tested) - 1 if closed else len(tested)
    while kept > 0 and tested[kept - 1].target == end:
        kept -= 1
    return (*tested[:kept], *tested[len(tested) - 1 :]) if closed else tuple(tested[:kept]), closed


def _invariant(inv: Invariant, code: Expr, states: tuple[str, ...], proved: frozenset[str] | None) -> InvariantIR:
    implied = isinstance(code, StateIn) and set(code.states) == set(states)
    holds = inv.expect == "holds" and (proved is None or inv.id in proved)
    return InvariantIR(inv.id, inv.expr, inv.cite, code, holds, implied, inv.expect == "holds")
