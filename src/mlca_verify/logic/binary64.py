"""Does a verdict decided over the reals hold for the generated code, which computes in IEEE 754 binary64 (or
binary32, where the spec says `machine.reals = "binary32"`; below, binary64 with p = 53 stands for either, p = 24
for binary32: see `floats`)?

The method (a forward rounding-error bound, then one query per comparison):
- Each numeric expression gets a bound on |binary64 value - real value|, from interval enclosures of its operands
  (`mlca_verify.intervals`) and the standard model of floating point: each +, -, *, / of binary64 operands is
  the exact result times (1 + d) with |d| <= 2^-p, plus, for * and /, half the smallest subnormal (underflow);
  a result whose enclosure reaches beyond the largest finite value may overflow, and has no bound.
  An operation is exact (bound 0) where its operands are exact multiples of a power of two g (their grain) and
  the result's magnitude is at most 2^p g: such a result is itself a binary64. So a timer counting 0.125 a
  step within [0, 10] is exact; one counting 0.1 is not.
  A literal's error is its distance to the nearest binary64; signals, and params in a parametric proof, are
  binary64 values the proof quantifies over, so their error is 0; ints are exact (their `ovf:` checks keep them
  within 64 bits) and below 2^p they convert to binary64 exactly. A real variable is exact when its initial
  value and every value assigned to it are; otherwise its error grows with the steps and is unbounded.
- A comparison of two operands whose bounds are both 0 is decided alike in both arithmetics. Otherwise it is
  robust when no valuation within the ranges brings its operands closer than the sum of their bounds (z3, with a
  resource budget); such a comparison cannot change its outcome under rounding.
- If every comparison that the verdict depends on is exact or robust, every step takes the same transition and
  every property the same truth value in both arithmetics, so the verdict carries over. The comparisons a
  verdict depends on are those of the step (guards, updates, `every`) and of the property, with the definitions
  and outputs they read; a definition the proof abstracted (a fresh value each step) is left out, since the
  proof holds for any value it takes, the code's included.
The bound is sound but not tight: a comparison it cannot show robust may still agree; the verdict then says that
it holds over the reals and was not shown for binary64, naming the comparison.
"""

from __future__ import annotations

from collections.abc import Iterable
from fractions import Fraction

import z3

from mlca_verify.floats import FORMATS
from mlca_verify.intervals import Interval, enclose, machine_intervals
from mlca_verify.logic.symbolic import StepInputs, System, Valuation, sort_of, value_of, variable_bounds
from mlca_verify.model import (
    Arith,
    Call,
    Cmp,
    Expr,
    Ite,
    Machine,
    Neg,
    Num,
    Prev,
    Var,
    bodies,
    name_types,
    nodes,
    own,
    show,
    type_of,
)

RLIMIT = 2_000_000  # z3's resource budget for one robustness query

Error = Fraction | None  # None: no bound
Grain = Fraction | None  # every value is an integer multiple of it (a power of two); None: not known
GRAIN_ROUNDS = 8  # rounds of the variables' grain fixpoint before a variable's grain is taken as unknown


def grain_of(value: Fraction) -> Grain:
    """The largest power of two (at most 1) that `value` is an integer multiple of; None unless it is dyadic."""
    if value.denominator & (value.denominator - 1):
        return None
    return Fraction(1, value.denominator)


def _finer(*grains: Grain) -> Grain:
    return None if any(g is None for g in grains) else min(g for g in grains if g is not None)


def _worse(*errors: Error) -> Error:
    return None if any(e is None for e in errors) else max(e for e in errors if e is not None)


class Rounding:
    """The rounding-error bounds of one machine's expressions, and the comparisons they can make go either way."""

    def __init__(self, machine: Machine, parametric: bool) -> None:
        self.m = machine
        self.parametric = parametric
        self.fmt = FORMATS[machine.reals]
        self.kinds = name_types(machine)
        self.bodies = bodies(machine)
        self.intervals = machine_intervals(machine, at_defaults=not parametric)
        self.grains = self._variable_grains()
        self.exact_variables = self._exact_variables()
        self._robust: dict[tuple[Cmp, bool], bool] = {}
        self._step: dict[frozenset[str], list[Cmp]] = {}  # the step's comparisons, by the definitions left out

    # --- bounds ---------------------------------------------------------------------------------------

    def _variable_grains(self) -> dict[str, Grain]:
        """Each real variable's grain: the finest of its initial value's and of every value assigned to it."""
        grains: dict[str, Grain] = {v.name: grain_of(v.initial) for v in self.m.variables if v.type == "real"}
        for _ in range(GRAIN_ROUNDS):
            before = dict(grains)
            for v in self.m.variables:
                if v.type == "real" and grains[v.name] is not None:
                    values = [v.every] if v.every is not None else []
                    values += [u.expr for t in self.m.transitions for u in t.updates if u.variable == v.name]
                    grains[v.name] = _finer(grains[v.name], *(self.grain(e, grains) for e in values))
            if grains == before:
                return grains
        return {name: None for name in grains}

    def grain(self, expr: Expr, grains: dict[str, Grain] | None = None) -> Grain:
        """A power of two every value of `expr` is an integer multiple of, in both arithmetics; None if unknown."""
        grains = self.grains if grains is None else grains
        if type_of(expr, self.kinds) == "int":
            return Fraction(1)
        if isinstance(expr, Num):
            return grain_of(expr.value)
        if isinstance(expr, Var):
            if expr.name in self.bodies:
                return self.grain(self.bodies[expr.name], grains)
            param = next((p for p in self.m.params if p.name == expr.name), None)
            if param is not None and not self.parametric:
                return grain_of(param.default)
            return grains.get(expr.name)
        if isinstance(expr, Neg | Prev):
            return self.grain(expr.arg, grains)
        if isinstance(expr, Ite):
            return _finer(self.grain(expr.then, grains), self.grain(expr.other, grains))
        if isinstance(expr, Call):
            return _finer(*(self.grain(a, grains) for a in expr.args))
        assert isinstance(expr, Arith)
        a, b = self.grain(expr.left, grains), self.grain(expr.right, grains)
        if a is None or b is None or expr.op == "/":
            return None
        return a * b if expr.op == "*" else min(a, b)

    def _exact_variables(self) -> frozenset[str]:
        """The real variables whose every value is a binary64 equal to the real one (a greatest fixpoint)."""
        exact = {v.name for v in self.m.variables}
        changed = True
        while changed:
            changed = False
            for v in self.m.variables:
                if v.name in exact and not self._assigned_exactly(v.name, exact):
                    exact.discard(v.name)
                    changed = True
        return frozenset(exact)

    def _assigned_exactly(self, name: str, exact: set[str]) -> bool:
        variable = next(v for v in self.m.variables if v.name == name)
        if variable.type == "int":
            return True
        values = [variable.every] if variable.every is not None else []
        values += [u.expr for t in self.m.transitions for u in t.updates if u.variable == name]
        return self.fmt.nearest(variable.initial) == variable.initial and all(self.error(e, exact) == 0 for e in values)

    def error(self, expr: Expr, exact: Iterable[str] | None = None) -> Error:
        """A bound on |binary64 value - real value| of a numeric expression."""
        exact = self.exact_variables if exact is None else frozenset(exact)
        if type_of(expr, self.kinds) == "int":
            limit = self.fmt.exact_int
            return Fraction(0) if enclose(expr, self.intervals).within(-limit, limit) else None
        if isinstance(expr, Num):
            return self._literal_error(expr.value)
        if isinstance(expr, Var):
            return self._name_error(expr.name, exact)
        if isinstance(expr, Neg | Prev):
            return self.error(expr.arg, exact)
        if isinstance(expr, Ite):
            return _worse(self.error(expr.then, exact), self.error(expr.other, exact))
        if isinstance(expr, Call):
            return _worse(*(self.error(a, exact) for a in expr.args))
        assert isinstance(expr, Arith)
        return self._arith_error(expr, exact)

    def _name_error(self, name: str, exact: frozenset[str]) -> Error:
        if name in self.bodies:
            return self.error(self.bodies[name], exact)
        if name in {v.name for v in self.m.variables}:
            return Fraction(0) if name in exact else None
        param = next((p for p in self.m.params if p.name == name), None)
        if param is not None and not self.parametric:
            return self._literal_error(param.default)
        return Fraction(0)

    def _literal_error(self, value: Fraction) -> Error:
        rounded = self.fmt.nearest(value)
        return None if rounded is None else abs(value - rounded)

    def _arith_error(self, expr: Arith, exact: frozenset[str]) -> Error:
        ea, eb = self.error(expr.left, exact), self.error(expr.right, exact)
        a, b = enclose(expr.left, self.intervals).magnitude(), enclose(expr.right, self.intervals).magnitude()
        top = enclose(expr, self.intervals).magnitude()
        if ea is None or eb is None or a is None or b is None or top is None or top > self.fmt.largest:
            return None
        grain = self.grain(expr)
        if ea == eb == 0 and grain is not None and top <= self.fmt.exact_int * grain:
            return Fraction(0)  # a multiple of the grain within 2^53 grains: a binary64, so no rounding
        if expr.op in ("+", "-"):
            carried = ea + eb
        elif expr.op == "*":
            carried = a * eb + b * ea + ea * eb
        else:
            low = _smallest_magnitude(enclose(expr.right, self.intervals))
            if low is None or low <= eb:
                return None
            carried = (a * eb + b * ea) / (low * (low - eb))
        tiny = self.fmt.underflow if expr.op in ("*", "/") else Fraction(0)  # a sum of subnormals is exact
        return carried + self.fmt.unit * (top + carried) + tiny

    # --- comparisons ----------------------------------------------------------------------------------

    def at_fault(self, exprs: Iterable[Expr], abstracted: frozenset[str], step: bool = True) -> str | None:
        """The first comparison of the cone of `exprs` (with the step's when `step`) that is not shown to be
        decided alike in binary64, as text; None when every one is."""
        for cmp in self.comparisons(exprs, abstracted, step):
            if not self.robust(cmp):
                return show(cmp)
        return None

    def comparisons(self, exprs: Iterable[Expr], abstracted: frozenset[str], step: bool) -> list[Cmp]:
        """The real comparisons `exprs` read (through definitions and outputs, but not the abstracted ones),
        sorted, then those of the step that are not among them."""
        own = self._read(list(exprs), abstracted)
        if not step:
            return own
        if abstracted not in self._step:
            todo = [t.guard for t in self.m.transitions] + [u.expr for t in self.m.transitions for u in t.updates]
            todo += [v.every for v in self.m.variables if v.every is not None]
            self._step[abstracted] = self._read(todo, abstracted)
        return own + [c for c in self._step[abstracted] if c not in own]

    def _read(self, todo: list[Expr], abstracted: frozenset[str]) -> list[Cmp]:
        seen: set[str] = set()
        found: dict[str, Cmp] = {}
        while todo:
            for node in nodes(todo.pop()):
                if isinstance(node, Var) and node.name in self.bodies and node.name not in seen | abstracted:
                    seen.add(node.name)
                    todo.append(self.bodies[node.name])
                if isinstance(node, Cmp) and "real" in (
                    type_of(node.left, self.kinds),
                    type_of(node.right, self.kinds),
                ):
                    found.setdefault(show(node), node)
        return [found[k] for k in sorted(found)]

    def robust(self, cmp: Cmp) -> bool:
        key = (cmp, self.parametric)
        if key not in self._robust:
            self._robust[key] = self._decide_robust(cmp)
        return self._robust[key]

    def _decide_robust(self, cmp: Cmp) -> bool:
        ea, eb = self.error(cmp.left), self.error(cmp.right)
        if ea is None or eb is None:
            return False
        if ea + eb == 0:
            return True
        return _apart(self.m, cmp, ea + eb, self.parametric)


def _smallest_magnitude(interval: Interval) -> Fraction | None:
    if interval.low is None or interval.high is None or interval.low <= 0 <= interval.high:
        return None
    return min(abs(interval.low), abs(interval.high))


def _apart(machine: Machine, cmp: Cmp, margin: Fraction, parametric: bool) -> bool:
    """Do the operands of `cmp` stay more than `margin` apart for every valuation within the ranges?"""
    if any(isinstance(n, Prev) for n in nodes(cmp)):
        return False
    system = System(machine, parametric=parametric)
    bools = {i.name: z3.Bool(own(f"in:{i.name}")) for i in machine.inputs}
    signals = {s.name: z3.Const(own(f"sig:{s.name}"), sort_of(s.type)) for s in machine.signals}
    variables = {v.name: z3.Const(own(f"var:{v.name}"), sort_of(v.type)) for v in machine.variables}
    solver = z3.Solver()
    solver.set("rlimit", RLIMIT)
    solver.add(*variable_bounds(machine, variables))
    params: dict[str, z3.ExprRef] = {}
    for p in machine.params:
        if parametric and p.range is not None:
            params[p.name] = z3.Const(own(f"param:{p.name}"), sort_of(p.type))
            solver.add(params[p.name] >= value_of(p.range[0], p.type), params[p.name] <= value_of(p.range[1], p.type))
        else:
            params[p.name] = value_of(p.default, p.type)
    mode = z3.Int(own("mode"))
    solver.add(mode >= 0, mode < len(machine.states))
    at = Valuation(mode, variables, StepInputs(bools, signals, {}), params)
    left, right = system.unify(system.ev(cmp.left, at), system.ev(cmp.right, at))
    gap = left - right
    solver.add(z3.If(gap >= 0, gap, -gap) <= z3.RealVal(margin))
    return bool(solver.check() == z3.unsat)
