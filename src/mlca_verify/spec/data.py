"""Stage two of loading, for the data of a machine: params, signals, variables, definitions, outputs and
assumptions, and the roles that say what each kind of expression may read."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, cast

from mlca_verify.errors import SpecError
from mlca_verify.model import (
    Assumption,
    BinOp,
    Call,
    Const,
    Definition,
    Expr,
    Ite,
    Num,
    Output,
    Param,
    Range,
    Signal,
    Type,
    Unit,
    Update,
    Var,
    Variable,
    children,
    nodes,
)
from mlca_verify.spec.expr_parser import ParseError, parse_expr
from mlca_verify.spec.locate import KeyPath, Locator
from mlca_verify.spec.types import Symbol, literal_value, parse_unit, show_unit

NUMBER_LIMIT = Fraction(10) ** 15  # the largest magnitude of a param, range end or initial value
MAX_CHAIN = 64  # definitions in a chain, each reading the next
DATA_SECTIONS = ("params", "signals", "variables", "definitions", "outputs", "assume")
_ASSIGNMENT = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*=(?!=)")


@dataclass(frozen=True)
class Role:
    """What one kind of expression may read, and the type it must have (None: a number or a boolean)."""

    label: str
    type: Type | None
    kinds: frozenset[str]
    state: bool
    prev: bool = False
    over: str = "inputs only"  # what it is over, when it may not read the state (for the error message)
    numeric_samples: bool = False  # may read a numeric definition of a signal: it has a value wherever it is read

    def why_not(self, kind: str) -> str:
        if kind == "signal":
            return (
                "a signal is read only by definitions and environment assumptions (a boolean definition says what "
                "it is when the sample is invalid) or through valid()"
            )
        if kind == "output":
            return "an output is the value after the step: only properties read it"
        if kind == "definition":
            return (
                "a numeric definition that reads a signal has no value when the sample is invalid: "
                "only definitions read it"
            )
        return f"{'an' if self.label[0] in 'aeiou' else 'a'} {self.label} reads only {', '.join(sorted(self.kinds))}"


_STEP = frozenset({"input", "param", "variable", "definition"})
ROLES = {
    "guard": Role("guard", "bool", _STEP, state=False),
    "update": Role("update", None, _STEP, state=True),
    "definition": Role("definition", None, _STEP | {"signal"}, state=True, numeric_samples=True),
    "output": Role("output", None, _STEP | {"signal"}, state=True, numeric_samples=True),
    "environment assumption": Role("environment assumption", "bool", _STEP | {"signal"}, state=True),
    "invariant": Role("invariant", "bool", _STEP | {"output"}, state=True, prev=True),
    "assumption": Role("assumption", "bool", _STEP | {"output"}, state=False, prev=True),
    "goal": Role("goal", "bool", _STEP | {"output"}, state=True, prev=True),
    "bound": Role("bound", "int", frozenset({"param"}), state=False),
    "lemma": Role(
        "lemma",
        "bool",
        frozenset({"input", "param", "signal", "definition"}),
        state=False,
        over="signals, inputs, params and definitions",
        numeric_samples=True,  # a lemma is over the signals' ranges, where every sample is valid
    ),
}

ExprOf = Callable[[KeyPath, str, str], tuple[Expr, Type, Unit | None]]


class DataBuilder:
    """Builds the data elements of a machine. `expr` parses, resolves and types one expression in a role."""

    def __init__(self, doc: dict[str, Any], where: Locator, env: dict[str, Symbol], expr: ExprOf) -> None:
        self.doc = doc
        self.where = where
        self.env = env
        self.expr = expr
        self.tainted_by: dict[str, tuple[str, ...]] = {}

    def fail(self, path: KeyPath, message: str) -> SpecError:
        return SpecError(self.where.loc(path), message)

    # --- values --------------------------------------------------------------------------------------

    def number(self, path: KeyPath, value: int | float, kind: Type) -> Fraction:
        if isinstance(value, float) and not math.isfinite(value):
            raise self.fail(path, f"'{path[-1]}' must be a finite number, got {value}")
        exact = literal_value(value)
        if abs(exact) > NUMBER_LIMIT:
            raise self.fail(path, f"'{path[-1]}' is beyond the supported magnitude 1e15")
        if kind == "int" and exact.denominator != 1:
            raise self.fail(path, f"'{path[-1]}' of an int must be a whole number, got {value}")
        return exact

    def type_of(self, path: KeyPath, value: str, allowed: tuple[str, ...] = ("int", "real")) -> Type:
        if value not in allowed:
            raise self.fail(path, f"'type' must be one of {', '.join(allowed)}, got {value[:20]!r}")
        return cast(Type, value)

    def range_of(self, path: KeyPath, item: dict[str, Any], kind: Type) -> Range | None:
        if "range" not in item:
            return None
        low, high = (self.number((*path, "range"), v, kind) for v in item["range"])
        if low > high:
            raise self.fail((*path, "range"), f"'range' is empty: {low} > {high}")
        return low, high

    def unit_of(self, path: KeyPath, item: dict[str, Any]) -> Unit:
        unit = parse_unit(item.get("unit", ""))
        if unit is None:
            raise self.fail((*path, "unit"), f"'unit' {item['unit'][:40]!r} is not a unit (like m, s, m/s^2 or 1)")
        return unit

    def inside(self, path: KeyPath, value: Fraction, bounds: Range | None, what: str) -> None:
        if bounds is not None and not bounds[0] <= value <= bounds[1]:
            raise self.fail(path, f"{what} {value} lies outside its range [{bounds[0]}, {bounds[1]}]")

    # --- sections ------------------------------------------------------------------------------------

    def params(self) -> tuple[Param, ...]:
        result = []
        for name, item in self.doc.get("params", {}).items():
            path: KeyPath = ("params", name)
            kind = self.type_of((*path, "type"), item["type"])
            default = self.number((*path, "default"), item["default"], kind)
            bounds = self.range_of(path, item, kind)
            self.inside((*path, "default"), default, bounds, "default")
            unit = self.unit_of(path, item)
            result.append(
                Param(name, kind, default, bounds, unit, item["doc"], item.get("cite", ""), self.where.loc(path))
            )
            self.env[name] = Symbol("param", kind, unit)
        return tuple(result)

    def signals(self) -> tuple[Signal, ...]:
        result = []
        for name, item in self.doc.get("signals", {}).items():
            path: KeyPath = ("signals", name)
            kind = self.type_of((*path, "type"), item["type"])
            bounds = self.range_of(path, item, kind)
            assert bounds is not None
            unit = self.unit_of(path, item)
            result.append(Signal(name, kind, unit, bounds, item["doc"], item.get("cite", ""), self.where.loc(path)))
            self.env[name] = Symbol("signal", kind, unit)
        return tuple(result)

    def declare_variables(self) -> None:
        for name, item in self.doc.get("variables", {}).items():
            path: KeyPath = ("variables", name)
            self.env[name] = Symbol("variable", self.type_of((*path, "type"), item["type"]), self.unit_of(path, item))

    def variables(self) -> tuple[Variable, ...]:
        result = []
        for name, item in self.doc.get("variables", {}).items():
            path: KeyPath = ("variables", name)
            symbol = self.env[name]
            initial = self.number((*path, "initial"), item["initial"], symbol.type)
            bounds = self.range_of(path, item, symbol.type)
            if symbol.type == "int" and bounds is None:
                raise self.fail(path, f"int variable '{name}' needs a 'range' (its generated type is chosen from it)")
            self.inside((*path, "initial"), initial, bounds, "initial value")
            every = None
            if "every" in item:
                every = self.assigned((*path, "every"), item["every"], name)
            result.append(
                Variable(
                    name,
                    symbol.type,
                    initial,
                    bounds,
                    every,
                    symbol.unit,
                    item["doc"],
                    item.get("cite", ""),
                    self.where.loc(path),
                    item.get("observer", False),
                )
            )
        return tuple(result)

    def assigned(self, path: KeyPath, text: str, variable: str, offset: int = 0) -> Expr:
        """An expression assigned to `variable`: its type and unit must fit the variable's."""
        expr, kind, unit = self.expr(path, text, "update")
        target = self.env[variable]
        if kind == "bool" or (kind == "real" and target.type == "int"):
            raise SpecError(
                self.where.string_loc(path, offset), f"{variable} is {target.type}: it cannot be assigned a {kind}"
            )
        if unit is not None and unit != target.unit:
            raise SpecError(
                self.where.string_loc(path, offset),
                f"{variable} is in {show_unit(target.unit)}: it cannot be assigned a value in {show_unit(unit)}",
            )
        return expr

    def updates(self, path: KeyPath, text: str) -> tuple[Update, ...]:
        """`do = "t = 0; n = n + 1"`: each variable at most once; each value over the step before it."""
        result: list[Update] = []
        offset = 0
        for piece in text.split(";"):
            if not piece.strip():
                offset += len(piece) + 1
                continue
            m = _ASSIGNMENT.match(piece)
            if m is None:
                raise SpecError(
                    self.where.string_loc(path, offset), f"bad update {piece.strip()[:60]!r}: expected 'name = value'"
                )
            name = m.group(1)
            if self.env.get(name, Symbol("", "bool", ())).kind != "variable":
                raise SpecError(self.where.string_loc(path, offset + m.start(1)), f"'{name}' is not a variable")
            if any(u.variable == name for u in result):
                raise SpecError(self.where.string_loc(path, offset + m.start(1)), f"'{name}' is updated twice")
            start = offset + m.end()
            value = " " * start + piece[m.end() :]
            result.append(Update(name, self.assigned(path, value, name, start)))
            offset += len(piece) + 1
        return tuple(result)

    def definitions(self) -> tuple[Definition, ...]:
        items = self.doc.get("definitions", {})
        for name in items:
            self.env[name] = Symbol("pending", "bool", ())
        done: dict[str, Definition] = {}
        ordered, reads = self.order(items)
        self.chain_depth(ordered, reads)
        for name in ordered:
            done[name] = self.definition(name, items[name])
        return tuple(done[name] for name in ordered)  # each after those it reads: the code defines them so

    def chain_depth(self, ordered: list[str], reads: dict[str, set[str]]) -> None:
        """Refuse a chain of definitions, each reading the next, longer than MAX_CHAIN (every engine and the
        generated code would nest that deep)."""
        depth: dict[str, int] = {}
        for name in ordered:
            depth[name] = 1 + max((depth[r] for r in reads[name]), default=0)
            if depth[name] > MAX_CHAIN:
                raise self.fail(
                    ("definitions", name, "expr"),
                    f"definition '{name}' ends a chain of {depth[name]} definitions each reading the next "
                    f"(at most {MAX_CHAIN})",
                )

    def order(self, items: dict[str, Any]) -> tuple[list[str], dict[str, set[str]]]:
        """The definitions, each after those it reads, and what each reads; a cycle is an error at the
        definition that closes it."""
        reads = {name: self.mentions(item["expr"], items) for name, item in items.items()}
        ordered: list[str] = []
        state: dict[str, int] = {}
        for root in items:
            stack = [(root, iter(sorted(reads[root])))]
            if state.get(root):
                continue
            state[root] = 1
            while stack:
                name, todo = stack[-1]
                nxt = next(todo, None)
                if nxt is None:
                    stack.pop()
                    state[name] = 2
                    ordered.append(name)
                elif state.get(nxt) == 1:
                    path: KeyPath = ("definitions", name, "expr")
                    raise self.fail(path, f"definition '{name}' reads '{nxt}', which reads '{name}' back (a cycle)")
                elif not state.get(nxt):
                    state[nxt] = 1
                    stack.append((nxt, iter(sorted(reads[nxt]))))
        return ordered, reads

    def mentions(self, text: str, items: dict[str, Any]) -> set[str]:
        try:
            expr, _ = parse_expr(text)
        except ParseError:
            return set()  # reported with its column when the definition itself is checked
        return {n.name for n in nodes(expr) if isinstance(n, Var) and n.name in items}

    def definition(self, name: str, item: dict[str, Any]) -> Definition:
        path: KeyPath = ("definitions", name)
        expr, kind, unit = self.expr((*path, "expr"), item["expr"], "definition")
        if "unit" in item and unit is not None and self.unit_of(path, item) != unit:
            declared = show_unit(self.unit_of(path, item))
            raise self.fail((*path, "unit"), f"definition '{name}' is in {show_unit(unit)}, not {declared}")
        if unit is None and "unit" in item:
            unit = self.unit_of(path, item)  # only literals: they take the unit the definition declares
        signals = self.signals_read(expr)
        if "if_invalid" in item and (kind != "bool" or not signals):
            raise self.fail((*path, "if_invalid"), "'if_invalid' applies to a boolean definition that reads a signal")
        self.env[name] = Symbol("definition", kind, unit or (), tainted=kind != "bool" and bool(signals))
        if self.env[name].tainted:
            self.tainted_by[name] = signals
        return Definition(
            name,
            kind,
            expr,
            unit or (),
            bool(item.get("if_invalid", False)),
            signals,
            item["doc"],
            item.get("cite", ""),
            self.where.loc(path),
        )

    def signals_read(self, expr: Expr) -> tuple[str, ...]:
        """The signals a definition reads directly or through numeric definitions (not inside valid())."""
        found: set[str] = set()
        todo = [expr]
        while todo:
            node = todo.pop()
            if isinstance(node, Call) and node.fn == "valid":
                continue
            if isinstance(node, Var):
                symbol = self.env[node.name]
                if symbol.kind == "signal":
                    found.add(node.name)
                elif symbol.tainted:
                    found |= set(self.tainted_by[node.name])
            todo.extend(children(node))
        return tuple(sorted(found))

    def outputs(self) -> tuple[Output, ...]:
        result = []
        for name, item in self.doc.get("outputs", {}).items():
            path: KeyPath = ("outputs", name)
            expr, kind, unit = self.expr((*path, "expr"), item["expr"], "output")
            if "type" in item:
                declared = self.type_of((*path, "type"), item["type"], ("bool", "int", "real"))
                if declared != kind and not (declared == "real" and kind == "int"):
                    raise self.fail((*path, "type"), f"output '{name}' is declared {declared} but its value is {kind}")
                kind = declared
            if "range" in item and kind == "bool":
                raise self.fail((*path, "range"), f"output '{name}' is a bool: a 'range' is for an int or a real")
            bounds = self.range_of(path, item, kind)
            signals = self.signals_read(expr)
            expr = self.gated(path, item, expr, kind, bounds)
            loc = self.where.loc(path)
            result.append(Output(name, kind, expr, unit or (), item["doc"], item.get("cite", ""), loc, bounds, signals))
            self.env[name] = Symbol("output", kind, unit or ())
        return tuple(result)

    def gated(self, path: KeyPath, item: dict[str, Any], expr: Expr, kind: Type, bounds: Range | None) -> Expr:
        """An output that reads samples: its rule while they are valid, else its `if_invalid` value."""
        name, signals = path[-1], self.signals_read(expr)
        if not signals:
            if "if_invalid" in item:
                raise self.fail((*path, "if_invalid"), "'if_invalid' applies to an output that reads a signal")
            return expr
        if "if_invalid" not in item:
            raise self.fail(
                (*path, "expr"),
                f"output '{name}' reads {', '.join(signals)}: give 'if_invalid', its value at a step where a "
                "sample is invalid",
            )
        value = item["if_invalid"]
        where = (*path, "if_invalid")
        if isinstance(value, bool) != (kind == "bool"):
            wanted = "true or false" if kind == "bool" else f"a number ({kind})"
            raise self.fail(where, f"'if_invalid' of output '{name}' must be {wanted}")
        fallback: Expr
        if isinstance(value, bool):
            fallback = Const(value)
        else:
            exact = self.number(where, value, kind)
            self.inside(where, exact, bounds, "'if_invalid'")
            fallback = Num(exact, kind == "real")
        checks: Expr = Call("valid", (Var(signals[0]),))
        for s in signals[1:]:
            checks = BinOp("and", checks, Call("valid", (Var(s),)))
        return Ite(checks, expr, fallback)

    def assumptions(self, check_id: Callable[[KeyPath, str, str], None]) -> tuple[Assumption, ...]:
        result = []
        for index, item in enumerate(self.doc.get("assume", [])):
            path: KeyPath = ("assume", index)
            check_id((*path, "id"), item["id"], "assumption id")
            expr, _, _ = self.expr((*path, "expr"), item["expr"], "environment assumption")
            result.append(Assumption(item["id"], expr, item.get("doc", ""), item.get("cite", ""), self.where.loc(path)))
        return tuple(result)


def declared_data(doc: dict[str, Any]) -> bool:
    return any(doc.get(section) for section in DATA_SECTIONS) or any("do" in t for t in doc.get("transition", []))
