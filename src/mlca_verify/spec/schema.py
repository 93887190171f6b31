"""The spec format as a JSON Schema (draft-07, which Taplo and the Even Better TOML editor extension read), built
from the shape stage's own tables (`shape`): an editor that validates a spec against it refuses what the loader's
first stage refuses (an unknown or missing key, a value of the wrong type, too many entries), and completes keys
with their descriptions. What the later stages check (names, types of expressions, ranges) is the loader's."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping

from mlca_verify.json_types import Json, JsonObject
from mlca_verify.spec import network
from mlca_verify.spec.names import MAX_ELEMENTS
from mlca_verify.spec.shape import ARRAYS, INPUT, MACHINE, TABLES, Field, FieldKind

SCHEMA_NAME = "spec.schema.json"
DRAFT = "http://json-schema.org/draft-07/schema#"

_STRINGS: JsonObject = {"type": "array", "items": {"type": "string"}}
_KINDS: dict[FieldKind, JsonObject] = {
    "str": {"type": "string"},
    "str-or-list": {"anyOf": [{"type": "string"}, _STRINGS]},
    "list-of-str": _STRINGS,
    "int": {"type": "integer"},
    "table-of-str": {"type": "object", "additionalProperties": {"type": "string"}},
    "bool": {"type": "boolean"},
    "number": {"type": "number"},
    "range": {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2},
    "int-or-str": {"anyOf": [{"type": "integer"}, {"type": "string"}]},
    "bool-or-number": {"anyOf": [{"type": "boolean"}, {"type": "number"}]},
}

# What each key means, where it means the same in every table that has it ...
_KEYS = {
    "doc": "What it is, in the spec's own words (reports and generated code carry it).",
    "cite": "Where it comes from (a paper's section, a requirement's id); reports and generated code carry it.",
    "unit": "Its unit (m, m/s, s, ...): a comparison or a sum of different units is refused.",
    "range": "[low, high]: the values it may take, both included.",
    "id": "Its name in reports, counterexamples and generated tests.",
    "expect": "The verdict the spec expects: holds (the default) or violated.",
    "parametric": "Prove it for every param value in its range, not only for the defaults.",
}
# ... and where a table gives it a meaning of its own.
_SECTION_KEYS = {
    ("machine", "name"): "The machine's name (its generated code's module is made from it).",
    ("machine", "initial"): "The state the machine starts in.",
    ("machine", "fallback"): "The state a context whose mode names no state restarts in (default: initial).",
    ("machine", "states"): "The machine's states, each a name.",
    ("machine", "semantics"): "How transitions are chosen: first-match (in the order written) or any-enabled.",
    ("machine", "otherwise"): "When no transition is enabled: stay in the state, or undefined (a finding).",
    ("machine", "reals"): "The IEEE 754 format the generated code computes reals in: binary64 (double, the "
    "default) or binary32 (float, for a single-precision FPU).",
    ("machine", "step_s"): "The seconds of one step (the sample rate's period): within_s and timers read it.",
    ("transition", "from"): 'The state or states it leaves, or "*" for every state.',
    ("transition", "to"): "The state it enters.",
    ("transition", "when"): "Its guard: an expression over inputs, signals, params, variables and definitions.",
    ("transition", "do"): 'Updates of variables when it fires: "x = expr; y = expr".',
    ("invariant", "expr"): "What must hold after every step (prev(e) reads e before the step).",
    ("lemma", "expr"): "A statement over the definitions alone, proved for every value of what it reads.",
    ("assume", "expr"): "What the environment guarantees at every step: every proof assumes it.",
    ("liveness", "assume"): "When the goal is owed (a request).",
    ("liveness", "goal"): "What must follow (the response).",
    ("liveness", "within"): "Steps within which the goal must hold, an int or a param's name (none: eventually).",
    ("liveness", "within_s"): "Seconds within which the goal must hold (with machine.step_s).",
    ("compare", "with"): "Another spec (a path) whose verdicts this one is compared with.",
    ("params", "type"): "int or real.",
    ("params", "default"): "The value the code uses unless the caller passes its own.",
    ("signals", "type"): "int or real.",
    ("variables", "type"): "int or real.",
    ("variables", "initial"): "Its value before the first step.",
    ("variables", "every"): "Its value after every step in which no transition updates it (default: kept).",
    ("variables", "observer"): (
        "true: only invariants read it (an observer for a property); the generated monitor keeps it, not the step."
    ),
    ("definitions", "expr"): "Its value, over inputs, signals, params, variables and earlier definitions.",
    ("definitions", "if_invalid"): "Its value when a signal it reads is invalid (outside its range, NaN, infinite).",
    ("outputs", "expr"): "Its value after each step, over the context after it, the inputs and the params.",
    ("outputs", "type"): "bool, int or real (default: the expression's).",
    ("outputs", "if_invalid"): "Its value when a signal it reads is invalid.",
}
_SECTIONS = {
    "machine": "The machine: its name, states, initial state and how it steps.",
    "inputs": "The boolean inputs, each sampled at every step.",
    "params": "Constants the caller may set within their ranges; proofs hold for the defaults or every value.",
    "signals": "Numeric inputs sampled at every step; a sample outside its range, NaN or infinite is invalid.",
    "variables": "Numbers the machine keeps between steps (timers, counters, observers).",
    "definitions": "Named expressions, read by guards, updates, outputs and properties.",
    "outputs": "What the machine computes after each step.",
    "transition": "A transition: from, to, and its guard.",
    "invariant": "A property that must hold after every step.",
    "liveness": "A response: whenever assume holds, goal follows (within a bound, or eventually).",
    "lemma": "A fact about the definitions, proved on its own (RSS's rules, for instance).",
    "compare": "Another reading of the same machine, compared verdict by verdict.",
    "assume": "An environment assumption, which every proof takes as given.",
    "expect": "Verdicts expected of the built-in checks, by check name.",
}


# A network spec's tables and keys (spec/network.py), where they mean something of their own.
_NETWORK_SECTIONS = {
    "network": "A network of machines: its name and how its instances step.",
    "instances": "The instances, each a machine spec (by path) with its params overridden.",
    "channel": "A channel: an output of one instance read by an input or a signal of another.",
    "invariant": "A property over several instances that must hold after every step.",
    "liveness": "A response over several instances: whenever assume holds, goal follows.",
}
_NETWORK_KEYS = {
    ("network", "name"): "The network's name (an identifier, as a machine's name).",
    ("network", "schedule"): "synchronous (every instance steps at once, the default) or interleaved (one at a time).",
    ("network", "fairness"): "Interleaved only: each instance steps at least once in every this many steps.",
    ("network", "timeout_ms"): "The solver budget its proofs need (check takes the larger of this and --timeout-ms).",
    ("instances", "spec"): "The instance's machine spec, a path relative to this file.",
    ("instances", "params"): "Param overrides: each a param of that machine, within its range.",
    ("channel", "from"): "The sending end: an instance's output, as A.name.",
    ("channel", "to"): "The receiving end: an instance's input or signal, as B.name.",
    ("channel", "delay"): "Steps from sending to reading (0 to 100; default 1; 0: immediate).",
    ("channel", "max_delay"): "Read from delay to max_delay steps after it was sent.",
    ("channel", "order"): 'With max_delay: "fifo" (in order) or "any" (reordered).',
    ("channel", "duplicate"): "fifo with max_delay: a late step may read the message before again (false: nothing).",
    ("channel", "lost"): "At most this many messages lost in a row (0 to 100; default 0).",
    ("liveness", "within"): "Steps within which the goal must hold (none: eventually).",
}
_NETWORK_KINDS: dict[network.KeyKind, JsonObject] = {
    "table": {"type": "object"},
    "int": _KINDS["int"],
    "bool": _KINDS["bool"],
    "str": _KINDS["str"],
}


def _describe(section: str, key: str) -> str:
    return _SECTION_KEYS.get((section, key)) or _KEYS.get(key, "")


def _table(keys: Iterable[tuple[str, JsonObject, str]], required: list[Json]) -> JsonObject:
    """A table of the spec with exactly these keys, each (name, its kind's schema, its description)."""
    properties: JsonObject = {key: {**kind, **({"description": text} if text else {})} for key, kind, text in keys}
    return {"type": "object", "properties": properties, "required": required, "additionalProperties": False}


def _item(section: str, fields: Mapping[str, Field]) -> JsonObject:
    """One table of the spec (a state machine's [machine], an input, a [[transition]], ...)."""
    keys = [(key, _KINDS[field.kind], _describe(section, key)) for key, field in fields.items()]
    return _table(keys, [key for key, field in fields.items() if field.required])


def _network_item(section: str) -> JsonObject:
    """One table of a network spec ([network], an instance, a [[channel]], a property)."""
    keys = [
        (key, _NETWORK_KINDS[network.key_kind(key)], _NETWORK_KEYS.get((section, key)) or _KEYS.get(key, ""))
        for key in sorted(network.TABLES[section])
    ]
    return _table(keys, list(network.REQUIRED[section]))


def _network_schema() -> tuple[JsonObject, JsonObject]:
    """What a network spec (one with a [network] table) must be, as the shape stage of spec/network.py sees it,
    and its tables' schemas by name."""
    arrays = {"channel": network.MAX_CHANNELS, "invariant": network.MAX_PROPERTIES, "liveness": network.MAX_PROPERTIES}
    properties: JsonObject = {
        "network": {**_network_item("network"), "description": _NETWORK_SECTIONS["network"]},
        "instances": {
            "type": "object",
            "additionalProperties": _network_item("instances"),
            "minProperties": 1,
            "maxProperties": network.MAX_INSTANCES,
            "description": _NETWORK_SECTIONS["instances"],
        },
    }
    for name, limit in arrays.items():
        entry: JsonObject = {"type": "array", "items": _network_item(name), "maxItems": limit}
        properties[name] = {**entry, "description": _NETWORK_SECTIONS[name]}
    names: list[Json] = list(network.TABLES)
    required: list[Json] = ["network", "instances"]
    whole: JsonObject = {"properties": properties, "required": required, "propertyNames": {"enum": names}}
    return whole, properties


def spec_schema() -> JsonObject:
    """The JSON Schema of a spec file: a machine, or a network of machines (a spec with a [network] table)."""
    properties: JsonObject = {
        "machine": {**_item("machine", MACHINE), "description": _SECTIONS["machine"]},
        "inputs": {
            "type": "object",
            "additionalProperties": _item("inputs", INPUT),
            "description": _SECTIONS["inputs"],
        },
    }
    for name, fields in TABLES.items():
        entry: JsonObject = {
            "type": "object",
            "additionalProperties": _item(name, fields),
            "maxProperties": MAX_ELEMENTS,
        }
        properties[name] = {**entry, "description": _SECTIONS[name]}
    for name, fields in ARRAYS.items():
        entry = {"type": "array", "items": _item(name, fields), "maxItems": MAX_ELEMENTS}
        properties[name] = {**entry, "description": _SECTIONS[name]}
    properties["expect"] = {**_KINDS["table-of-str"], "description": _SECTIONS["expect"]}
    nets, network_tables = _network_schema()
    for name in ("network", "instances", "channel"):  # a network's own tables, offered beside a machine's
        properties[name] = network_tables[name]
    # [inputs] may be left out only by a machine that reads signals or definitions
    inputs_or_signals: list[Json] = [{"required": [k]} for k in ("inputs", "signals", "definitions")]
    machine: JsonObject = {
        "required": ["machine"],
        "anyOf": inputs_or_signals,
        "not": {"anyOf": [{"required": ["instances"]}, {"required": ["channel"]}]},
    }
    return {
        "$schema": DRAFT,
        "title": "mlca-verify spec",
        "description": "A state machine for mlca-verify: its inputs, signals, params, variables, definitions, "
        "outputs, transitions and properties; or a network of such machines, with its instances and channels "
        "(see docs/reference/spec-schema.md).",
        "type": "object",
        "properties": properties,
        "additionalProperties": False,
        "if": {"required": ["network"]},
        "then": nets,
        "else": machine,
    }


def schema_text() -> str:
    """The schema as the package ships it (`spec.schema.json` beside this module)."""
    return json.dumps(spec_schema(), indent=2, ensure_ascii=True) + "\n"
