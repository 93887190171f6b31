"""z3 glue: expressions to formulas, and a solver whose every query has a timeout and a three-way answer."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Literal

import z3

from mlca_verify.model import Const, Expr, Not, StateIn, Var, as_binop

Answer = Literal["sat", "unsat", "unknown"]
DEFAULT_TIMEOUT_MS = 10_000
# A query's budget is counted in z3's resource units (rlimit), not in time, so that a loaded machine gives the same
# verdicts as an idle one: RESOURCE_PER_MS units for each millisecond of `--timeout-ms`, about what z3 spends in
# a millisecond on the reference machine (bench/bench_check.py measures it). The clock stops a query only at GUARD
# times its budget (and never before GUARD_MIN_MS), against a prover that hangs.
RESOURCE_PER_MS = 3_000  # PDR on an idle 2-core machine: 2,900 per ms (bench_check.py, "z3 resources")
GUARD = 10
GUARD_MIN_MS = 60_000
RLIMIT_MAX = 4_000_000_000  # z3 keeps the limit in 32 bits


def budget(query: z3.Solver, timeout_ms: int) -> None:
    """Give a solver the budget of `timeout_ms`: its resource limit, and the guard's clock."""
    query.set("rlimit", min(timeout_ms * RESOURCE_PER_MS, RLIMIT_MAX))
    query.set("timeout", max(timeout_ms * GUARD, GUARD_MIN_MS))


def encode(expr: Expr, inputs: Mapping[str, z3.BoolRef], state: str | None = None) -> z3.BoolRef:
    """The z3 formula of `expr` over input variables, with `state` (when given) a known constant."""
    if isinstance(expr, Const):
        return z3.BoolVal(expr.value)
    if isinstance(expr, Var):
        return inputs[expr.name]
    if isinstance(expr, StateIn):
        return z3.BoolVal(state in expr.states)
    if isinstance(expr, Not):
        return z3.Not(encode(expr.arg, inputs, state))
    expr = as_binop(expr)
    a, b = encode(expr.left, inputs, state), encode(expr.right, inputs, state)
    ops = {"and": z3.And, "or": z3.Or, "->": z3.Implies, "<->": lambda x, y: x == y}
    result: z3.BoolRef = ops[expr.op](a, b)
    return result


class Solver:
    """One z3 solver over a fixed set of boolean inputs. Queries are pushed and popped, never accumulated."""

    def __init__(self, input_names: Sequence[str], timeout_ms: int = DEFAULT_TIMEOUT_MS) -> None:
        self.names = tuple(input_names)
        self.vars = {name: z3.Bool(name) for name in self.names}
        self._z3 = z3.Solver()
        budget(self._z3, timeout_ms)
        self.queries = 0
        self.unknowns = 0

    def check(self, formula: z3.BoolRef) -> Answer:
        """Is `formula` satisfiable? `unknown` (a timeout, say) is kept distinct."""
        self.queries += 1
        answer = self._z3.check(formula)
        if answer == z3.sat:
            return "sat"
        if answer == z3.unsat:
            return "unsat"
        self.unknowns += 1
        return "unknown"

    def point(self, values: dict[str, bool]) -> z3.BoolRef:
        """The conjunction of input literals fixing each input in `values` to its value."""
        return z3.And(*[self.vars[n] if v else z3.Not(self.vars[n]) for n, v in values.items()])

    def witness(self, formula: z3.BoolRef) -> dict[str, bool] | None:
        """A satisfying input valuation, made canonical: each input false where it can be, in declaration order.

        Canonical witnesses keep counterexamples short to read and identical across z3 versions."""
        if self.check(formula) != "sat":
            return None
        model = self._z3.model()
        fixed: list[z3.BoolRef] = []
        values: dict[str, bool] = {}
        for name in self.names:
            literal = z3.Not(self.vars[name])
            answer = self.check(z3.And(formula, *fixed, literal))
            if answer == "unknown":
                return {n: z3.is_true(model.eval(self.vars[n], model_completion=True)) for n in self.names}
            value = answer == "unsat"
            values[name] = value
            fixed.append(self.vars[name] if value else literal)
        return values
