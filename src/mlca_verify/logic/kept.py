"""Which int variables' ranges one step keeps from every context in range, whether or not a run reaches it.

The generated step's contract requires the context in range and, for such a variable, ensures it after the step,
so WP proves the range is kept. A range that holds only because no run reaches the contexts that would break it
(proved by `range:<name>` with k-induction or a strengthening) cannot be proved that way; its contract requires
it and leaves the keeping to the engine's proof. The question is asked of the spec's step with the params free in
their ranges, any inputs and samples, and the mode kept where no transition is enabled (as the code keeps it).
"""

from __future__ import annotations

from dataclasses import replace

import z3

from mlca_verify.logic.solver import budget
from mlca_verify.logic.symbolic import System, variable_bounds
from mlca_verify.model import Machine

KEPT_BUDGET_MS = 2_000  # in z3's resource units (see `solver.budget`): an answer not found within it is "not kept"


def kept_ranges(machine: Machine) -> frozenset[str]:
    """The int variables with a range that every step from a context with every such variable in range keeps."""
    ranged = [v.name for v in machine.variables if v.range is not None and v.type == "int"]
    if not ranged:
        return frozenset()
    system = System(replace(machine, otherwise="stay"), parametric=True)
    pre, inputs, post = system.frame("k0"), system.inputs("k0"), system.frame("k1")
    link, _ = system.step(pre, inputs, post)
    solver = z3.Solver()
    budget(solver, KEPT_BUDGET_MS)
    solver.add(link, system.well_formed(pre), *variable_bounds(machine, pre.variables, ranged))
    kept = (
        n for n in ranged if solver.check(z3.Not(z3.And(*variable_bounds(machine, post.variables, [n])))) == z3.unsat
    )
    return frozenset(kept)
