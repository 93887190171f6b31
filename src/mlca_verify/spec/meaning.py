"""Stage two of loading: names, references and expressions, turned into a `Machine`."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any, cast

from mlca_verify.errors import Loc, SpecError
from mlca_verify.model import (
    ANY_STATE,
    Comparison,
    Expr,
    Input,
    Invariant,
    Liveness,
    Machine,
    Otherwise,
    Semantics,
    Transition,
    Verdict,
)
from mlca_verify.spec.expr_parser import ParseError, parse_expr
from mlca_verify.spec.locate import KeyPath, Locator
from mlca_verify.spec.names import (
    IDENTIFIER,
    MACHINE_NAME_LIMIT,
    MAX_INPUTS,
    MAX_STATES,
    NAME_LIMIT,
    PROPERTY_ID,
    c_form,
    clash,
)

BUILTIN_PROPERTIES = frozenset({"determinism", "completeness"})
# Prefixes of the built-in checks' results (`fires:t1`, `reach:IDLE`, `equiv:OTHER`): ids that would be read as one.
RESULT_PREFIXES = frozenset({"fires", "reach", "equiv"})
WITHIN_LIMIT = 1000  # steps of a bounded response: its counterexample and its search grow with the bound
SEMANTICS = ("first-match", "any-enabled")
OTHERWISE = ("stay", "undefined")
VERDICTS = ("holds", "violated")

LoadOther = Callable[[str, Loc], Machine]


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
        if m["initial"] not in self.states:
            raise self.fail(
                ("machine", "initial"),
                f"initial state {_quoted(m['initial'])} is not a state ({', '.join(self.states)})",
            )
        inputs = self.inputs()
        transitions = self.transitions()
        invariants = self.invariants()
        liveness = self.liveness_list()
        self.unique_properties(invariants, liveness)
        return Machine(
            name=m["name"],
            initial=m["initial"],
            states=self.states,
            inputs=inputs,
            transitions=transitions,
            semantics=cast(
                Semantics, self.choice(("machine", "semantics"), m.get("semantics", "first-match"), SEMANTICS)
            ),
            otherwise=cast(Otherwise, self.choice(("machine", "otherwise"), m.get("otherwise", "stay"), OTHERWISE)),
            cite=m["cite"],
            doc=m.get("doc", ""),
            invariants=invariants,
            liveness=liveness,
            comparisons=self.comparisons(),
            expect=self.expect_table(transitions),
            loc=self.where.loc(("machine",)),
        )

    def choice(self, path: KeyPath, value: str, allowed: tuple[str, ...]) -> str:
        if value not in allowed:
            raise self.fail(path, f"'{path[-1]}' must be one of {', '.join(allowed)}, got {_quoted(value)}")
        return value

    def inputs(self) -> tuple[Input, ...]:
        items = self.doc["inputs"]
        if not items:
            raise self.fail(("inputs",), "a machine needs at least one input")
        self.bounded(("inputs",), len(items), MAX_INPUTS, "inputs")
        result = []
        for name, item in items.items():
            self.identifier(("inputs", name), name, "input name", self.where.key_loc(("inputs", name)))
            result.append(Input(name, item["doc"], item["cite"], self.where.loc(("inputs", name))))
        self.distinct(("inputs",), [(i.name, i.loc) for i in result], "input")
        self.input_names = frozenset(items)
        return tuple(result)

    # --- expressions ---------------------------------------------------------------------------------

    def expr(self, path: KeyPath, text: str, allow_state: bool, role: str) -> Expr:
        try:
            expr, refs = parse_expr(text)
        except ParseError as err:
            raise SpecError(
                self.where.string_loc(path, err.offset), f"bad {role} {_quoted(text)}: {err.message}"
            ) from None
        for ref in refs:
            loc = self.where.string_loc(path, ref.offset)
            if ref.is_state and not allow_state:
                where = self.where.string_loc(path, ref.state_offset)
                raise SpecError(
                    where, f"{role} may not refer to the state ({role}s are over inputs only): {_quoted(text)}"
                )
            if ref.is_state and ref.name not in self.states:
                raise SpecError(loc, f"unknown state '{ref.name}' in {role} (states: {', '.join(self.states)})")
            if not ref.is_state and ref.name not in self.input_names:
                raise SpecError(
                    loc, f"unknown input '{ref.name}' in {role} (inputs: {', '.join(sorted(self.input_names))})"
                )
        return expr

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
                    cite=item["cite"],
                    loc=self.where.loc(path),
                    doc=item.get("doc", ""),
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
            result.append(Invariant(item["id"], expr, item["cite"], self.verdict(path, item), loc, item.get("doc", "")))
        return tuple(result)

    def liveness_list(self) -> tuple[Liveness, ...]:
        result = []
        for index, item in enumerate(self.doc.get("liveness", [])):
            path: KeyPath = ("liveness", index)
            self.property_id((*path, "id"), item["id"], "liveness id")
            within = item.get("within")
            if within is not None and not 1 <= within <= WITHIN_LIMIT:
                raise self.fail(
                    (*path, "within"), f"'within' must be a number of steps from 1 to {WITHIN_LIMIT}, got {within}"
                )
            result.append(
                Liveness(
                    id=item["id"],
                    assume=self.expr((*path, "assume"), item["assume"], allow_state=False, role="assumption"),
                    goal=self.expr((*path, "goal"), item["goal"], allow_state=True, role="goal"),
                    within=within,
                    cite=item["cite"],
                    expect=self.verdict(path, item),
                    loc=self.where.loc(path),
                    doc=item.get("doc", ""),
                )
            )
        return tuple(result)

    def unique_properties(self, invariants: tuple[Invariant, ...], liveness: tuple[Liveness, ...]) -> None:
        named = [(p.id, p.loc) for p in invariants] + [(p.id, p.loc) for p in liveness]
        self.distinct((), named, "property id")

    def comparisons(self) -> tuple[Comparison, ...]:
        result = []
        for index, item in enumerate(self.doc.get("compare", [])):
            path: KeyPath = ("compare", index)
            if self.load_other is None:
                continue
            other = self.load_other(item["with"], self.where.loc((*path, "with")))
            result.append(Comparison(other, self.verdict(path, item), item["cite"], self.where.loc(path)))
        return tuple(result)

    def expect_table(self, transitions: tuple[Transition, ...]) -> dict[str, Verdict]:
        known = set(BUILTIN_PROPERTIES) | {f"reach:{s}" for s in self.states} | {f"fires:{t.id}" for t in transitions}
        table: dict[str, Verdict] = {}
        for key, value in self.doc.get("expect", {}).items():
            path: KeyPath = ("expect", key)
            if key not in known:
                hint = "determinism, completeness, reach:<state>, fires:<transition id>"
                raise self.fail(path, f"unknown built-in check {_quoted(key)} in [expect] (one of {hint})")
            table[key] = cast(Verdict, self.choice(path, value, VERDICTS))
        return table
