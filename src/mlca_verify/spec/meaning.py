"""Stage two of loading: names, references and expressions, turned into a `Machine`."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from fractions import Fraction
from typing import Any, cast

from mlca_verify.errors import Loc, SpecError
from mlca_verify.escape import c_form
from mlca_verify.floats import REALS, Reals
from mlca_verify.intervals import Interval, enclose
from mlca_verify.model import (
    ANY_STATE,
    Comparison,
    Definition,
    Expr,
    Input,
    Invariant,
    Lemma,
    Liveness,
    Machine,
    Otherwise,
    Param,
    Prev,
    Semantics,
    Transition,
    Type,
    Unit,
    Var,
    Verdict,
    is_boolean_only,
    nodes,
    observer_readers,
    stateful_definitions,
)
from mlca_verify.model import Call as CallNode
from mlca_verify.spec.data import ROLES, DataBuilder, Role, declared_data
from mlca_verify.spec.expr_parser import ParseError, parse_full
from mlca_verify.spec.locate import KeyPath, Locator
from mlca_verify.spec.names import (
    IDENTIFIER,
    MACHINE_NAME_LIMIT,
    MAX_INPUTS,
    MAX_STATES,
    NAME_LIMIT,
    PROPERTY_ID,
    clash,
)
from mlca_verify.spec.types import Symbol, TypeChecker, TypeProblem

BUILTIN_PROPERTIES = frozenset({"determinism", "completeness"})
# Prefixes of the built-in checks' results (`fires:t1`, `reach:IDLE`, `equiv:OTHER`): ids that would be read as one.
RESULT_PREFIXES = frozenset({"fires", "reach", "equiv"})
WITHIN_LIMIT = 100_000  # steps of a bounded response: its counterexample and its search grow with the bound
SEMANTICS = ("first-match", "any-enabled")
OTHERWISE = ("stay", "undefined")
VERDICTS = ("holds", "violated")

LoadOther = Callable[[str, Loc], Machine]


def param_intervals(params: tuple[Param, ...]) -> dict[str, Interval]:
    """Each param's values in a proof: its range, or its default when it has none."""
    return {p.name: Interval(*p.range) if p.range is not None else Interval.point(p.default) for p in params}


def _quoted(text: str, limit: int = 60) -> str:
    """Spec text quoted for a message: escaped as Python writes it, and cut after `limit` characters."""
    return repr(text) if len(text) <= limit else repr(text[:limit]) + "..."


class MeaningChecker:
    """Builds a `Machine` from a shape-checked document, checking every name and expression."""

    def __init__(self, doc: dict[str, Any], where: Locator, load_other: LoadOther | None) -> None:
        self.doc = doc
        self.where = where
        self.load_other = load_other
        self.states: tuple[str, ...] = ()
        self.input_names: frozenset[str] = frozenset()
        self.env: dict[str, Symbol] = {}
        self.data = declared_data(doc)
        self.builder = DataBuilder(doc, where, self.env, self.typed)

    def fail(self, path: KeyPath, message: str) -> SpecError:
        return SpecError(self.where.loc(path), message)

    # --- names ---------------------------------------------------------------------------------------

    def identifier(self, path: KeyPath, name: str, what: str, loc: Loc | None = None) -> None:
        def error(message: str) -> SpecError:
            return SpecError(loc or self.where.loc(path), message)

        limit = MACHINE_NAME_LIMIT if what == "machine name" else NAME_LIMIT
        if not IDENTIFIER.fullmatch(name):
            raise error(f"{what} {_quoted(name)} is not an identifier (a letter, then letters, digits or '_')")
        if len(name) > limit:
            raise error(f"{what} '{name[:20]}...' is {len(name)} characters long (at most {limit})")
        if (found := clash(name, what.split(maxsplit=1)[0], self.doc["machine"]["name"])) is not None:
            raise error(f"{what} '{name}' {found}")

    def distinct(self, path: KeyPath, names: Iterable[tuple[str, Loc]], what: str) -> None:
        seen: dict[str, str] = {}
        for name, loc in names:
            key = c_form(name).lower()
            if (other := seen.get(key)) is not None:
                if other == name:
                    raise SpecError(loc, f"duplicate {what} '{name}'")
                extra = "" if c_form(name + other) == name + other else ", '-' and '.'"
                raise SpecError(
                    loc, f"{what} '{name}' clashes with '{other}' (names must differ in more than case{extra})"
                )
            seen[key] = name

    def bounded(self, path: KeyPath, count: int, limit: int, what: str) -> None:
        if count > limit:
            raise self.fail(path, f"{count} {what}: at most {limit} are supported")

    # --- machine -------------------------------------------------------------------------------------

    def build(self) -> Machine:
        m = self.doc["machine"]
        self.identifier(("machine", "name"), m["name"], "machine name")
        self.states = tuple(m["states"])
        if not self.states:
            raise self.fail(("machine", "states"), "a machine needs at least one state")
        self.bounded(("machine", "states"), len(self.states), MAX_STATES, "states")
        state_locs = [
            (s, self.where.element_loc(("machine", "states"), s, self.states[:k].count(s)))
            for k, s in enumerate(self.states)
        ]
        for state, loc in state_locs:
            self.identifier(("machine", "states"), state, "state name", loc)
        self.distinct(("machine", "states"), state_locs, "state")
        for key in ("initial", "fallback"):
            if key in m and m[key] not in self.states:
                raise self.fail(
                    ("machine", key),
                    f"{key} state {_quoted(m[key])} is not a state ({', '.join(self.states)})",
                )
        inputs = self.inputs()
        b = self.builder
        params, signals = b.params(), b.signals()
        self.param_ranges = param_intervals(params)
        b.declare_variables()
        definitions = b.definitions()
        variables = b.variables()
        self.unique_names()
        transitions = self.transitions()
        outputs = b.outputs()
        assumptions = b.assumptions(self.property_id)
        invariants = self.invariants()
        liveness = self.liveness_list()
        lemmas = self.lemmas(definitions, variables)
        self.unique_properties(invariants, liveness, lemmas)
        if self.data and m.get("semantics", "first-match") != "first-match":
            raise self.fail(("machine", "semantics"), 'a machine with data needs semantics = "first-match"')
        if self.data and self.doc.get("compare"):
            raise self.fail(("compare", 0), "[[compare]] is not supported for machines with data yet")
        step_s = None
        if "step_s" in m:
            step_s = b.number(("machine", "step_s"), m["step_s"], "real")
            if step_s <= 0:
                raise self.fail(("machine", "step_s"), "'step_s' must be positive")
        return self.observed(Machine(
            name=m["name"],
            initial=m["initial"],
            fallback=m.get("fallback", m["initial"]),
            states=self.states,
            inputs=inputs,
            transitions=transitions,
            semantics=cast(
                Semantics, self.choice(("machine", "semantics"), m.get("semantics", "first-match"), SEMANTICS)
            ),
            otherwise=cast(Otherwise, self.choice(("machine", "otherwise"), m.get("otherwise", "stay"), OTHERWISE)),
            cite=m.get("cite", ""),
            doc=m.get("doc", ""),
            invariants=invariants,
            liveness=liveness,
            comparisons=self.comparisons(),
            expect=self.expect_table(transitions),
            loc=self.where.loc(("machine",)),
            params=params,
            signals=signals,
            variables=variables,
            definitions=definitions,
            outputs=outputs,
            assumptions=assumptions,
            step_s=step_s,
            lemmas=lemmas,
            data=self.data,
            reals=cast(Reals, self.choice(("machine", "reals"), m.get("reals", "binary64"), REALS)),
        ))  # fmt: skip

    def observed(self, machine: Machine) -> Machine:
        """The machine, once no declared observer is read where only invariants may read one."""
        for v, why in observer_readers(machine):
            raise self.fail(("variables", v.name, "observer"), f"variable '{v.name}' is an observer, but {why}")
        return machine

    def choice(self, path: KeyPath, value: str, allowed: tuple[str, ...]) -> str:
        if value not in allowed:
            raise self.fail(path, f"'{path[-1]}' must be one of {', '.join(allowed)}, got {_quoted(value)}")
        return value

    def unique_names(self) -> None:
        """One namespace for inputs, params, signals, variables, definitions and outputs."""
        named: list[tuple[str, Loc]] = []
        for section in ("inputs", "params", "signals", "variables", "definitions", "outputs"):
            for name in self.doc.get(section, {}):
                loc = self.where.key_loc((section, name))
                if section != "inputs":
                    self.identifier((section, name), name, f"{section[:-1]} name", loc)
                named.append((name, loc))
        self.distinct((), named, "name")

    def inputs(self) -> tuple[Input, ...]:
        items = self.doc.get("inputs", {})
        if not items and not (self.doc.get("signals") or self.doc.get("definitions")):
            raise self.fail(("inputs",), "a machine needs at least one input")
        self.bounded(("inputs",), len(items), MAX_INPUTS, "inputs")
        result = []
        for name, item in items.items():
            self.identifier(("inputs", name), name, "input name", self.where.key_loc(("inputs", name)))
            result.append(Input(name, item["doc"], item.get("cite", ""), self.where.loc(("inputs", name))))
            self.env[name] = Symbol("input", "bool", ())
        self.distinct(("inputs",), [(i.name, i.loc) for i in result], "input")
        self.input_names = frozenset(items)
        return tuple(result)

    # --- expressions ---------------------------------------------------------------------------------

    def expr(self, path: KeyPath, text: str, allow_state: bool, role: str) -> Expr:
        del allow_state  # the role says it
        return self.typed(path, text, role)[0]

    def typed(self, path: KeyPath, text: str, role_name: str) -> tuple[Expr, Type, Unit | None]:
        """Parse an expression, resolve its names for `role_name` (a key of ROLES) and check its type."""
        role = ROLES[role_name]
        try:
            parsed = parse_full(text)
        except ParseError as err:
            raise SpecError(
                self.where.string_loc(path, err.offset), f"bad {role.label} {_quoted(text.strip())}: {err.message}"
            ) from None
        self.resolve(path, text, parsed.refs, role)
        self.special_nodes(path, parsed.expr, parsed.offsets, role)
        try:
            kind, unit = TypeChecker(self.env, parsed.offsets).check(parsed.expr)
        except TypeProblem as err:
            raise SpecError(self.where.string_loc(path, err.offset), f"{role.label}: {err.message}") from None
        if role.type is not None and kind != role.type and not (role.type == "real" and kind == "int"):
            raise SpecError(self.where.string_loc(path, 0), f"{role.label} must be {role.type}, got {kind}")
        if not is_boolean_only(parsed.expr):
            self.data = True
        return parsed.expr, kind, unit

    def resolve(self, path: KeyPath, text: str, refs: list[Any], role: Role) -> None:
        for ref in refs:
            loc = self.where.string_loc(path, ref.offset)
            if ref.is_state and not role.state:
                where = self.where.string_loc(path, ref.state_offset)
                raise SpecError(
                    where,
                    f"{role.label} may not refer to the state ({role.label}s are over {role.over}): {_quoted(text)}",
                )
            if ref.is_state and ref.name not in self.states:
                raise SpecError(loc, f"unknown state '{ref.name}' in {role.label} (states: {', '.join(self.states)})")
            if ref.is_state:
                continue
            symbol = self.env.get(ref.name)
            if symbol is None or symbol.kind == "pending":
                raise SpecError(loc, self.unknown(ref.name, role, symbol is not None))

    def unknown(self, name: str, role: Role, pending: bool) -> str:
        if not self.data:
            return f"unknown input '{name}' in {role.label} (inputs: {', '.join(sorted(self.input_names))})"
        if pending:
            return f"'{name}' is a definition that this one reads in a cycle"
        known = sorted(n for n, s in self.env.items() if s.kind in role.kinds)
        listed = ", ".join(known[:12]) + (", ..." if len(known) > 12 else "")
        return f"unknown name '{name}' in {role.label} (it may read: {listed or 'nothing'})"

    def special_nodes(self, path: KeyPath, expr: Expr, offsets: dict[int, int], role: Role) -> None:
        """What a role may read: signals, outputs and prev() only where they have a value."""
        inside_valid = {id(n.args[0]) for n in nodes(expr) if isinstance(n, CallNode) and n.fn == "valid"}
        for node in nodes(expr):
            at = self.where.string_loc(path, offsets.get(id(node), 0))
            if isinstance(node, Prev):
                if not role.prev:
                    raise SpecError(at, f"prev() is for properties: a {role.label} reads the state before the step")
                if any(isinstance(n, Prev) for n in nodes(node.arg)):
                    raise SpecError(at, "prev() inside prev() is not supported")
            if not isinstance(node, Var):
                continue
            symbol = self.env[node.name]
            if id(node) in inside_valid:
                if symbol.kind != "signal":
                    raise SpecError(at, f"valid() takes a signal, and '{node.name}' is a {symbol.kind}")
                if role.label == "bound":
                    raise SpecError(at, "a bound reads only params")
                continue
            tainted = symbol.tainted and not role.numeric_samples
            if symbol.kind not in role.kinds or tainted:
                raise SpecError(at, f"{role.label} cannot read '{node.name}': {role.why_not(symbol.kind)}")

    # --- transitions and properties ------------------------------------------------------------------

    def transitions(self) -> tuple[Transition, ...]:
        result: list[Transition] = []
        for index, item in enumerate(self.doc.get("transition", [])):
            path: KeyPath = ("transition", index)
            tid = item.get("id", f"t{index + 1}")
            self.property_id((*path, "id"), tid, "transition id")
            result.append(
                Transition(
                    id=tid,
                    sources=self.sources((*path, "from"), item["from"]),
                    target=self.state_ref((*path, "to"), item["to"], "target state"),
                    guard=self.expr((*path, "when"), item["when"], allow_state=False, role="guard"),
                    cite=item.get("cite", ""),
                    loc=self.where.loc(path),
                    doc=item.get("doc", ""),
                    updates=self.builder.updates((*path, "do"), item["do"]) if "do" in item else (),
                )
            )
        self.distinct(("transition",), [(t.id, t.loc) for t in result], "transition id")
        return tuple(result)

    def sources(self, path: KeyPath, value: str | list[str]) -> tuple[str, ...] | None:
        if value == ANY_STATE:
            return None
        names = [value] if isinstance(value, str) else value
        if not names:
            raise self.fail(path, "'from' must name at least one state, or be \"*\"")
        return tuple(self.state_ref(path, n, "source state") for n in names)

    def state_ref(self, path: KeyPath, name: str, what: str) -> str:
        if name not in self.states:
            raise self.fail(path, f"unknown {what} {_quoted(name)} (states: {', '.join(self.states)})")
        return name

    def property_id(self, path: KeyPath, pid: str, what: str) -> None:
        if not PROPERTY_ID.fullmatch(pid):
            raise self.fail(
                path, f"{what} {_quoted(pid)} must start with a letter and use letters, digits, '_', '-', '.'"
            )
        if len(pid) > NAME_LIMIT:
            raise self.fail(path, f"{what} '{pid[:20]}...' is {len(pid)} characters long (at most {NAME_LIMIT})")
        if pid in BUILTIN_PROPERTIES or pid in RESULT_PREFIXES:
            raise self.fail(path, f"{what} '{pid}' is the name of a built-in check")
        if "__" in c_form(pid):
            raise self.fail(path, f"{what} '{pid}' clashes with generated names, which join parts with '__'")

    def verdict(self, path: KeyPath, item: dict[str, Any]) -> Verdict:
        return cast(Verdict, self.choice((*path, "expect"), item.get("expect", "holds"), VERDICTS))

    def invariants(self) -> tuple[Invariant, ...]:
        result = []
        for index, item in enumerate(self.doc.get("invariant", [])):
            path: KeyPath = ("invariant", index)
            self.property_id((*path, "id"), item["id"], "invariant id")
            expr = self.expr((*path, "expr"), item["expr"], allow_state=True, role="invariant")
            loc = self.where.loc(path)
            result.append(
                Invariant(
                    item["id"],
                    expr,
                    item.get("cite", ""),
                    self.verdict(path, item),
                    loc,
                    item.get("doc", ""),
                    parametric=item.get("parametric", False),
                )
            )
        return tuple(result)

    def liveness_list(self) -> tuple[Liveness, ...]:
        result = []
        for index, item in enumerate(self.doc.get("liveness", [])):
            path: KeyPath = ("liveness", index)
            self.property_id((*path, "id"), item["id"], "liveness id")
            within, bound = self.within(path, item)
            result.append(
                Liveness(
                    id=item["id"],
                    assume=self.expr((*path, "assume"), item["assume"], allow_state=False, role="assumption"),
                    goal=self.expr((*path, "goal"), item["goal"], allow_state=True, role="goal"),
                    within=within,
                    cite=item.get("cite", ""),
                    expect=self.verdict(path, item),
                    loc=self.where.loc(path),
                    doc=item.get("doc", ""),
                    parametric=item.get("parametric", False),
                    bound=bound,
                )
            )
        return tuple(result)

    def within(self, path: KeyPath, item: dict[str, Any]) -> tuple[int | None, Expr | None]:
        """The bound of a response: `within` steps (a number, or an int expression over params), or `within_s`
        seconds of the machine's `step_s`."""
        within = item.get("within")
        if "within_s" in item:
            if within is not None:
                raise self.fail((*path, "within_s"), "give 'within' or 'within_s', not both")
            step = self.doc["machine"].get("step_s")
            if step is None:
                raise self.fail((*path, "within_s"), "'within_s' needs the step length: 'step_s' in [machine]")
            seconds = self.builder.number((*path, "within_s"), item["within_s"], "real")
            steps = seconds / self.builder.number(("machine", "step_s"), step, "real")
            within = -(-steps.numerator // steps.denominator)
        if isinstance(within, str) and within.strip().isdigit() and len(within) < 10:
            within = int(within)  # a constant: the same bound as the number itself
        if isinstance(within, str):
            self.data = True
            bound = self.typed((*path, "within"), within, "bound")[0]
            values = enclose(bound, self.param_ranges)
            if not values.within(Fraction(1), Fraction(WITHIN_LIMIT)):
                raise self.fail(
                    (*path, "within"),
                    f"'within' must be from 1 to {WITHIN_LIMIT} steps for every param value in range; "
                    f"{_quoted(within.strip()[:40])} may take values in {values}",
                )
            return None, bound
        if within is not None and not 1 <= within <= WITHIN_LIMIT:
            raise self.fail(
                (*path, "within"), f"'within' must be a number of steps from 1 to {WITHIN_LIMIT}, got {within}"
            )
        return within, None

    def lemmas(self, definitions: tuple[Definition, ...], variables: tuple[Any, ...]) -> tuple[Lemma, ...]:
        """Statements over signals, params and the definitions that read only those (no mode, no variable)."""
        result = []
        stateful = stateful_definitions(definitions, (v.name for v in variables))
        for index, item in enumerate(self.doc.get("lemma", [])):
            path: KeyPath = ("lemma", index)
            self.property_id((*path, "id"), item["id"], "lemma id")
            expr = self.expr((*path, "expr"), item["expr"], allow_state=False, role="lemma")
            read = sorted({x.name for x in nodes(expr) if isinstance(x, Var) and x.name in stateful})
            if read:
                raise self.fail(
                    (*path, "expr"), f"a lemma reads no mode and no variable, but definition {read[0]} does"
                )
            self.data = True
            loc = self.where.loc(path)
            doc, cite = item.get("doc", ""), item.get("cite", "")
            parametric = item.get("parametric", False)
            result.append(Lemma(item["id"], expr, cite, self.verdict(path, item), loc, doc, parametric))
        return tuple(result)

    def unique_properties(
        self, invariants: tuple[Invariant, ...], liveness: tuple[Liveness, ...], lemmas: tuple[Lemma, ...] = ()
    ) -> None:
        named: list[tuple[str, Loc]] = [(p.id, p.loc) for p in invariants]
        named += [(p.id, p.loc) for p in liveness] + [(p.id, p.loc) for p in lemmas]
        self.distinct((), named, "property id")

    def comparisons(self) -> tuple[Comparison, ...]:
        result = []
        for index, item in enumerate(self.doc.get("compare", [])):
            path: KeyPath = ("compare", index)
            if self.load_other is None:
                continue
            other = self.load_other(item["with"], self.where.loc((*path, "with")))
            result.append(Comparison(other, self.verdict(path, item), item.get("cite", ""), self.where.loc(path)))
        return tuple(result)

    def expect_table(self, transitions: tuple[Transition, ...]) -> dict[str, Verdict]:
        known = set(BUILTIN_PROPERTIES) | {f"reach:{s}" for s in self.states} | {f"fires:{t.id}" for t in transitions}
        known |= {f"range:{v}" for section in ("variables", "outputs") for v in self.doc.get(section, {})}
        known |= {f"div:{n}" for section in ("definitions", "variables", "outputs") for n in self.doc.get(section, {})}
        known |= {f"div:{t.id}" for t in transitions} | {f"div:{i.get('id')}" for i in self.doc.get("invariant", [])}
        table: dict[str, Verdict] = {}
        for key, value in self.doc.get("expect", {}).items():
            path: KeyPath = ("expect", key)
            if key not in known:
                hint = "determinism, completeness, reach:<state>, fires:<transition id>"
                if self.data:
                    hint += ", range:<variable or output>, div:<name>"
                raise self.fail(path, f"unknown built-in check {_quoted(key)} in [expect] (one of {hint})")
            table[key] = cast(Verdict, self.choice(path, value, VERDICTS))
        return table
