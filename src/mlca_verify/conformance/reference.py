"""The spec's own semantics, answered by z3: the reference the generated code is compared with."""

from __future__ import annotations

import z3

from mlca_verify.logic.graph import Encoding
from mlca_verify.logic.solver import Solver, encode
from mlca_verify.model import Machine


class Reference:
    def __init__(self, machine: Machine) -> None:
        self.machine = machine
        self.solver = Solver(machine.input_names)
        self.enc = Encoding(machine, self.solver)

    def next_state(self, state: str | None, inputs: dict[str, bool]) -> str:
        """The next state; an out-of-range state (None) goes to the fallback state, as the code contract says."""
        if state is None:
            return self.machine.fallback_state
        point = self.solver.point(inputs)
        fired = [m.target for m in self.enc.moves[state] if self.solver.check(z3.And(point, m.cond)) == "sat"]
        if len(fired) != 1:
            raise AssertionError(f"{state} under {inputs}: {len(fired)} moves fire")
        return fired[0]

    def failing_invariants(self, state: str, inputs: dict[str, bool]) -> list[str]:
        point = self.solver.point(inputs)
        failing = []
        for inv in self.machine.invariants:
            formula = z3.And(point, z3.Not(encode(inv.expr, self.solver.vars, state)))
            if self.solver.check(formula) == "sat":
                failing.append(inv.id)
        return failing
