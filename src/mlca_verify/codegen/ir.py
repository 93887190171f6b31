"""A language-neutral intermediate form of a deterministic machine, ready for any renderer.

Per state, the branches that apply there in priority order (global `from = "*"` transitions included), then
the default (`otherwise = "stay"`). Renderers never re-derive semantics from the spec; they print this.
"""

from __future__ import annotations

from dataclasses import dataclass

from mlca_verify.codegen.simplify import fold, in_context
from mlca_verify.errors import CodegenError
from mlca_verify.logic.solver import Solver
from mlca_verify.model import Expr, Invariant, Machine, StateIn, inputs_of

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
    branches: tuple[Branch, ...]


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
    proved: bool  # expected to hold: stated as a contract on the step function, not only monitored
    implied: bool = False  # `state in {every state}`: the monitor's state check already decides it


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


def build_ir(machine: Machine, spec_path: str, spec_sha256: str, version: str, reachable: tuple[str, ...]) -> MachineIR:
    """The IR of a first-match, gap-free machine; anything else is refused with a `CodegenError`."""
    require_first_match(machine)
    cases = []
    solver = Solver(machine.input_names)
    for index, state in enumerate(machine.states):
        out = [t for t in machine.transitions if t.applies_to(state)]
        codes = in_context([t.guard for t in out], solver, machine, state)
        branches = tuple(Branch(t.id, t.guard, c, t.target, t.cite) for t, c in zip(out, codes, strict=True))
        cases.append(StateCase(state, index, machine.cite, branches))
    module = machine.name.lower()
    hoisted = 0
    for t in machine.transitions:
        if t.sources is not None or t.target != machine.fallback_state:
            break
        hoisted += 1
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
        step_reads_inputs=any(inputs_of(b.code) for case in cases for b in case.branches),
        invariants_read_inputs=any(inputs_of(fold(i.expr, solver)) for i in machine.invariants),
        otherwise_cite=machine.cite,
        invariants=tuple(_invariant(i, fold(i.expr, solver), machine.states) for i in machine.invariants),
        reachable=reachable,
    )


def _invariant(inv: Invariant, code: Expr, states: tuple[str, ...]) -> InvariantIR:
    implied = isinstance(code, StateIn) and set(code.states) == set(states)
    return InvariantIR(inv.id, inv.expr, inv.cite, code, inv.expect == "holds", implied)
