"""Load a network spec: `[network]`, its `[instances.<NAME>]` (machine specs by path, params overridden), its
`[[channel]]`s and its properties over several instances. Every mistake is a one-line `SpecError` at its line and
column; the result is a `Network` and the one machine `network.flatten` makes of it."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from fractions import Fraction
from typing import Any, Literal, cast

from mlca_verify.errors import Loc, SpecError
from mlca_verify.model import (
    Expr,
    Invariant,
    Liveness,
    Machine,
    Param,
    StateIn,
    Verdict,
    children,
    with_children,
)
from mlca_verify.network import (
    MAX_DELAY,
    MAX_LOST,
    ORDERS,
    SCHEDULES,
    Channel,
    Instance,
    Network,
    Order,
    Schedule,
    flatten,
    in_states,
)
from mlca_verify.spec.expr_parser import ParseError, parse_full
from mlca_verify.spec.locate import Locator
from mlca_verify.spec.names import IDENTIFIER, MACHINE_NAME_LIMIT, NAME_LIMIT, PROPERTY_ID
from mlca_verify.spec.types import Symbol, TypeChecker, TypeProblem

LoadInstance = Callable[[str, Loc], Machine]
KeyPath = tuple[str | int, ...]

MAX_INSTANCES = 8
MAX_CHANNELS = 64
MAX_PROPERTIES = 500
MAX_WITHIN = 10_000
MAX_TIMEOUT_MS = 600_000
VERDICTS = ("holds", "violated", "unknown")
TABLES = {
    "network": {"name", "schedule", "fairness", "timeout_ms", "doc", "cite"},
    "instances": {"spec", "params", "doc", "cite"},
    "channel": {"id", "from", "to", "delay", "max_delay", "order", "duplicate", "lost", "doc", "cite"},
    "invariant": {"id", "expr", "expect", "doc", "cite"},
    "liveness": {"id", "assume", "goal", "within", "expect", "doc", "cite"},
}
REQUIRED = {
    "network": ("name",),
    "instances": ("spec",),
    "channel": ("id", "from", "to"),
    "invariant": ("id", "expr"),
    "liveness": ("id", "assume", "goal"),
}
INTEGERS = ("delay", "max_delay", "lost", "fairness", "timeout_ms", "within")
KeyKind = Literal["table", "int", "bool", "str"]


def key_kind(key: str) -> KeyKind:
    """What a key of a network spec's tables holds (the shape stage's rule, which the JSON Schema shares)."""
    if key == "params":
        return "table"
    if key in INTEGERS:
        return "int"
    return "bool" if key == "duplicate" else "str"


def is_network(doc: Mapping[str, Any]) -> bool:
    return "network" in doc


class NetworkLoader:
    """Builds a `Network` from a parsed TOML document, checking every key, name, reference and expression."""

    def __init__(self, doc: dict[str, Any], where: Locator, load_instance: LoadInstance) -> None:
        self.doc = doc
        self.where = where
        self.load_instance = load_instance
        self.env: dict[str, Symbol] = {}  # the flat machine's names, once the instances are loaded
        self.states: dict[str, tuple[str, tuple[str, ...]]] = {}  # `A.X` -> (A, A's states)

    def fail(self, path: KeyPath, message: str) -> SpecError:
        return SpecError(self.where.loc(path), message)

    # --- shape ---------------------------------------------------------------------------------------

    def shape(self) -> None:
        for key in self.doc:
            if key not in TABLES:
                raise self.fail((key,), f"unknown table '{key[:40]}' in a network spec (allowed: {', '.join(TABLES)})")
        self.table(("network",), self.doc["network"], "network")
        instances = self.doc.get("instances", {})
        if not isinstance(instances, dict) or not instances:
            raise self.fail(("network",), "a network needs at least one instance: [instances.<NAME>] spec = ...")
        if len(instances) > MAX_INSTANCES:
            raise self.fail(("instances",), f"{len(instances)} instances: at most {MAX_INSTANCES} are supported")
        for name, body in instances.items():
            self.table(("instances", name), body, "instances")
        for key, limit in (("channel", MAX_CHANNELS), ("invariant", MAX_PROPERTIES), ("liveness", MAX_PROPERTIES)):
            items = self.doc.get(key, [])
            if not isinstance(items, list):
                raise self.fail((key,), f"'{key}' must be an array of tables: [[{key}]]")
            if len(items) > limit:
                raise self.fail((key,), f"{len(items)} [[{key}]]: at most {limit} are supported")
            for index, item in enumerate(items):
                self.table((key, index), item, key)

    def value(self, path: KeyPath, key: str, value: object) -> None:
        """A key's value has its type: a table of params, an integer, a boolean or a string."""
        kind = key_kind(key)
        integer = isinstance(value, int) and not isinstance(value, bool)
        if kind == "table" and not isinstance(value, dict):
            raise self.fail((*path, key), "'params' must be a table of numbers")
        if kind == "int" and not integer:
            what = "an integer number of steps" if key == "within" else "an integer"
            raise self.fail((*path, key), f"'{key}' must be {what}")
        if kind == "bool" and not isinstance(value, bool):
            raise self.fail((*path, key), f"'{key}' must be true or false")
        if kind == "str" and not isinstance(value, str):
            raise self.fail((*path, key), f"'{key}' must be a string")

    def table(self, path: KeyPath, body: object, kind: str) -> None:
        if not isinstance(body, dict):
            raise self.fail(path, f"'{'.'.join(map(str, path))}' must be a table")
        for key, value in body.items():
            if key not in TABLES[kind]:
                raise self.fail((*path, key), f"unknown key '{key[:40]}' (allowed: {', '.join(sorted(TABLES[kind]))})")
            self.value(path, key, value)
        for key in REQUIRED[kind]:
            if key not in body:
                raise self.fail(path, f"missing '{key}'")

    # --- meaning -------------------------------------------------------------------------------------

    def build(self) -> tuple[Network, Machine]:
        self.shape()
        net = self.doc["network"]
        self.identifier(("network", "name"), net["name"], "network name", MACHINE_NAME_LIMIT)
        instances = tuple(self.instance(name, body) for name, body in self.doc["instances"].items())
        channels = self.channels({i.name: i.machine for i in instances})
        schedule, fairness = self.schedule(len(instances))
        budget = net.get("timeout_ms", 0)
        if not 0 <= budget <= MAX_TIMEOUT_MS:
            raise self.fail(
                ("network", "timeout_ms"), f"'timeout_ms' must be from 0 to {MAX_TIMEOUT_MS:,}, got {budget}"
            )
        skeleton = Network(
            net["name"], instances, channels, loc=self.where.loc(("network",)), schedule=schedule, fairness=fairness,
            timeout_ms=budget,
        )  # fmt: skip
        flat = flatten(skeleton)
        self.env = _symbols(flat)
        self.states = {f"{i.name}.{s}": (i.name, i.machine.states) for i in instances for s in i.machine.states}
        network = replace(
            skeleton,
            invariants=self.invariants(),
            liveness=self.liveness(),
            cite=net.get("cite", ""),
            doc=net.get("doc", ""),
        )
        self.unique((*network.invariants, *network.liveness))
        return network, flatten(network)

    def schedule(self, count: int) -> tuple[Schedule, int]:
        net = self.doc["network"]
        schedule = net.get("schedule", "synchronous")
        if schedule not in SCHEDULES:
            raise self.fail(
                ("network", "schedule"), f"'schedule' must be one of {', '.join(SCHEDULES)}, got {schedule[:40]!r}"
            )
        fairness = net.get("fairness", 0)
        if "fairness" in net and schedule != "interleaved":
            raise self.fail(("network", "fairness"), "'fairness' bounds an interleaved schedule: give schedule too")
        if "fairness" in net and not count <= fairness <= MAX_DELAY:
            raise self.fail(
                ("network", "fairness"),
                f"'fairness' must be from {count} (the instances) to {MAX_DELAY} steps, got {fairness}",
            )
        return cast(Schedule, schedule), fairness

    def identifier(self, path: KeyPath, name: str, what: str, limit: int = NAME_LIMIT) -> None:
        if not IDENTIFIER.fullmatch(name):
            raise self.fail(path, f"{what} {name[:60]!r} is not an identifier (a letter, then letters, digits or '_')")
        if len(name) > limit:
            raise self.fail(path, f"{what} '{name[:20]}...' is {len(name)} characters long (at most {limit})")

    def instance(self, name: str, body: dict[str, Any]) -> Instance:
        path: KeyPath = ("instances", name)
        self.identifier(path, name, "instance name")
        machine = self.load_instance(body["spec"], self.where.loc((*path, "spec")))
        overrides = body.get("params", {})
        params = tuple(self.param(p, overrides.get(p.name), (*path, "params", p.name)) for p in machine.params)
        for key in overrides:
            if key not in {p.name for p in machine.params}:
                known = ", ".join(p.name for p in machine.params) or "none"
                raise self.fail((*path, "params", key), f"'{key[:40]}' is not a param of {machine.name} ({known})")
        return Instance(
            name, replace(machine, params=params), body["spec"], body.get("cite", ""), body.get("doc", ""),
            self.where.loc(path),
        )  # fmt: skip

    def param(self, p: Param, value: object, path: KeyPath) -> Param:
        if value is None:
            return p
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(path, f"param '{p.name}' must be a number")
        number = Fraction(value)
        if p.type == "int" and number.denominator != 1:
            raise self.fail(path, f"param '{p.name}' is an int, got {value}")
        if p.range is not None and not p.range[0] <= number <= p.range[1]:
            low, high = (float(x) for x in p.range)
            raise self.fail(path, f"param '{p.name}' = {value} lies outside its range [{low:g}, {high:g}]")
        return replace(p, default=number)

    def channels(self, machines: dict[str, Machine]) -> tuple[Channel, ...]:
        result: list[Channel] = []
        fed: dict[str, str] = {}
        for index, item in enumerate(self.doc.get("channel", [])):
            path: KeyPath = ("channel", index)
            self.property_id((*path, "id"), item["id"], "channel id")
            sender, output = self.end((*path, "from"), item["from"], machines)
            receiver, port = self.end((*path, "to"), item["to"], machines)
            self.ends(path, (machines[sender], output), (machines[receiver], port), item)
            signal = any(s.name == port for s in machines[receiver].signals)
            if signal and (other := fed.get(item["to"])) is not None:
                raise self.fail((*path, "to"), f"signal '{item['to']}' is fed by channel '{other}' already")
            fed[item["to"]] = item["id"]
            delay, lost = item.get("delay", 1), item.get("lost", 0)
            if not 0 <= delay <= MAX_DELAY:
                raise self.fail((*path, "delay"), f"'delay' must be from 0 to {MAX_DELAY} steps, got {delay}")
            if not 0 <= lost <= MAX_LOST:
                raise self.fail((*path, "lost"), f"'lost' must be from 0 to {MAX_LOST} messages in a row, got {lost}")
            latest = item.get("max_delay", delay)
            if not delay <= latest <= MAX_DELAY:
                raise self.fail(
                    (*path, "max_delay"), f"'max_delay' must be from 'delay' ({delay}) to {MAX_DELAY}, got {latest}"
                )
            order = item.get("order", "fifo")
            if order not in ORDERS:
                raise self.fail((*path, "order"), f"'order' must be one of {', '.join(ORDERS)}, got {order[:40]!r}")
            duplicate = item.get("duplicate", True)
            if not duplicate and order != "fifo":
                raise self.fail((*path, "duplicate"), "'duplicate = false' needs order = \"fifo\"")
            result.append(
                Channel(
                    item["id"], sender, output, receiver, port, delay, lost, item.get("cite", ""),
                    item.get("doc", ""), self.where.loc(path), item.get("max_delay"), cast(Order, order), duplicate,
                )
            )  # fmt: skip
        ids = [c.id for c in result]
        for index, cid in enumerate(ids):
            if cid in ids[:index]:
                raise self.fail(("channel", index, "id"), f"duplicate channel id '{cid}'")
        return tuple(result)

    def end(self, path: KeyPath, text: str, machines: dict[str, Machine]) -> tuple[str, str]:
        instance, dot, name = text.partition(".")
        if not dot or instance not in machines:
            raise self.fail(path, f"{text[:60]!r} must be <instance>.<name> (instances: {', '.join(machines)})")
        return instance, name

    def ends(self, path: KeyPath, source_end: tuple[Machine, str], port_end: tuple[Machine, str], item: Any) -> None:
        """A boolean output feeds a boolean input; an int or real one a signal of its type."""
        (sender, output), (receiver, port) = source_end, port_end
        source = next((o for o in sender.outputs if o.name == output), None)
        if source is None:
            known = ", ".join(o.name for o in sender.outputs) or "none"
            raise self.fail((*path, "from"), f"'{item['from'][:60]}' is not an output ({sender.name}'s: {known})")
        signal = next((s for s in receiver.signals if s.name == port), None)
        if source.type == "bool" and port not in receiver.input_names:
            raise self.fail(
                (*path, "to"), f"'{item['to'][:60]}' must be a boolean input of {receiver.name}, as the output is"
            )
        if source.type != "bool" and (signal is None or signal.type != source.type):
            raise self.fail(
                (*path, "to"),
                f"'{item['to'][:60]}' must be a {source.type} signal of {receiver.name}, as the output is",
            )

    # --- properties ----------------------------------------------------------------------------------

    def property_id(self, path: KeyPath, pid: str, what: str) -> None:
        if not PROPERTY_ID.fullmatch(pid) or len(pid) > NAME_LIMIT:
            raise self.fail(
                path, f"{what} {pid[:60]!r} must start with a letter and use letters, digits, '_', '-', '.' "
                f"(at most {NAME_LIMIT})",
            )  # fmt: skip

    def verdict(self, path: KeyPath, item: dict[str, Any]) -> Verdict:
        value = item.get("expect", "holds")
        if value not in VERDICTS:
            raise self.fail((*path, "expect"), f"'expect' must be one of {', '.join(VERDICTS)}, got {value[:40]!r}")
        return cast(Verdict, value)

    def expr(self, path: KeyPath, text: str, what: str) -> Expr:
        """A boolean expression over the instances' qualified names (`A.gap`, `A.state == X`)."""
        try:
            parsed = parse_full(text, qualified=True)
        except ParseError as err:
            raise SpecError(self.where.string_loc(path, err.offset), f"bad {what}: {err.message}") from None
        for ref in parsed.refs:
            known = self.states if ref.is_state else self.env
            if ref.name not in known or "~" in ref.name:
                kind = "state" if ref.is_state else "name"
                raise SpecError(
                    self.where.string_loc(path, ref.offset),
                    f"unknown {kind} '{ref.name[:60]}' in {what} (write <instance>.<name>; instances: "
                    f"{', '.join(self.doc['instances'])})",
                )
        try:
            kind, _ = TypeChecker(self.env, parsed.offsets).check(parsed.expr)
        except TypeProblem as err:
            raise SpecError(self.where.string_loc(path, err.offset), f"{what}: {err.message}") from None
        if kind != "bool":
            raise SpecError(self.where.string_loc(path, 0), f"{what} must be bool, got {kind}")
        return self.qualified_states(parsed.expr)

    def qualified_states(self, e: Expr) -> Expr:
        if isinstance(e, StateIn):
            instance, states = self.states[e.states[0]]
            return in_states(instance, states, tuple(s.partition(".")[2] for s in e.states))
        return with_children(e, tuple(self.qualified_states(c) for c in children(e)))

    def invariants(self) -> tuple[Invariant, ...]:
        result = []
        for index, item in enumerate(self.doc.get("invariant", [])):
            path: KeyPath = ("invariant", index)
            self.property_id((*path, "id"), item["id"], "invariant id")
            expr = self.expr((*path, "expr"), item["expr"], "invariant")
            verdict = self.verdict(path, item)
            result.append(
                Invariant(item["id"], expr, item.get("cite", ""), verdict, self.where.loc(path), item.get("doc", ""))
            )
        return tuple(result)

    def liveness(self) -> tuple[Liveness, ...]:
        result = []
        for index, item in enumerate(self.doc.get("liveness", [])):
            path: KeyPath = ("liveness", index)
            self.property_id((*path, "id"), item["id"], "liveness id")
            within = item.get("within")
            if within is not None and not 1 <= within <= MAX_WITHIN:
                raise self.fail((*path, "within"), f"'within' must be from 1 to {MAX_WITHIN} steps, got {within}")
            result.append(
                Liveness(
                    id=item["id"],
                    assume=self.expr((*path, "assume"), item["assume"], "liveness assumption"),
                    goal=self.expr((*path, "goal"), item["goal"], "goal"),
                    within=within,
                    cite=item.get("cite", ""),
                    expect=self.verdict(path, item),
                    loc=self.where.loc(path),
                    doc=item.get("doc", ""),
                )
            )
        return tuple(result)

    def unique(self, properties: tuple[Invariant | Liveness, ...]) -> None:
        seen: set[str] = set()
        for p in properties:
            if p.id in seen:
                raise SpecError(p.loc, f"duplicate property id '{p.id}'")
            seen.add(p.id)


def _symbols(flat: Machine) -> dict[str, Symbol]:
    """The flat machine's names, as the type checker reads them."""
    env = {i.name: Symbol("input", "bool", ()) for i in flat.inputs}
    env.update({p.name: Symbol("param", p.type, p.unit) for p in flat.params})
    env.update({s.name: Symbol("signal", s.type, s.unit) for s in flat.signals})
    env.update({v.name: Symbol("variable", v.type, v.unit) for v in flat.variables})
    env.update({d.name: Symbol("definition", d.type, d.unit) for d in flat.definitions})
    env.update({o.name: Symbol("output", o.type, o.unit) for o in flat.outputs})
    return env
