"""z3 glue: expressions to formulas, and a solver whose every query has a timeout and a three-way answer."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Literal

import z3

from mlca_verify.model import Const, Expr, Not, StateIn, Var, as_binop

Answer = Literal["sat", "unsat", "unknown"]
DEFAULT_TIMEOUT_MS = 10_000


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
        self._z3.set("timeout", timeout_ms)
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
