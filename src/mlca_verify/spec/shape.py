"""Stage one of loading: the shape of the TOML document (keys, types), nothing about meaning."""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

from mlca_verify.errors import SpecError
from mlca_verify.spec.locate import KeyPath, Locator
from mlca_verify.spec.names import MAX_ELEMENTS

FieldKind = Literal[
    "str",
    "str-or-list",
    "list-of-str",
    "int",
    "table-of-str",
    "bool",
    "number",
    "range",
    "int-or-str",
    "bool-or-number",
]


@dataclass(frozen=True)
class Field:
    kind: FieldKind
    required: bool = False


MACHINE = {
    "name": Field("str", True),
    "initial": Field("str", True),
    "fallback": Field("str"),
    "states": Field("list-of-str", True),
    "semantics": Field("str"),
    "otherwise": Field("str"),
    "cite": Field("str"),
    "doc": Field("str"),
    "step_s": Field("number"),
    "reals": Field("str"),
}
INPUT = {"doc": Field("str", True), "cite": Field("str")}
TRANSITION = {
    "id": Field("str"),
    "from": Field("str-or-list", True),
    "to": Field("str", True),
    "when": Field("str", True),
    "do": Field("str"),
    "cite": Field("str"),
    "doc": Field("str"),
}
INVARIANT = {
    "id": Field("str", True),
    "expr": Field("str", True),
    "cite": Field("str"),
    "expect": Field("str"),
    "doc": Field("str"),
    "parametric": Field("bool"),
}
LIVENESS = {
    "id": Field("str", True),
    "assume": Field("str", True),
    "goal": Field("str", True),
    "within": Field("int-or-str"),
    "within_s": Field("number"),
    "cite": Field("str"),
    "expect": Field("str"),
    "doc": Field("str"),
    "parametric": Field("bool"),
}
LEMMA = INVARIANT  # the same keys: a statement, its source, its expected verdict, doc and parametric
COMPARE = {"with": Field("str", True), "cite": Field("str"), "expect": Field("str")}
ASSUME = {"id": Field("str", True), "expr": Field("str", True), "cite": Field("str"), "doc": Field("str")}
PARAM = {
    "type": Field("str", True),
    "default": Field("number", True),
    "range": Field("range"),
    "unit": Field("str"),
    "doc": Field("str", True),
    "cite": Field("str"),
}
SIGNAL = {
    "type": Field("str", True),
    "unit": Field("str", True),
    "range": Field("range", True),
    "doc": Field("str", True),
    "cite": Field("str"),
}
VARIABLE = {
    "type": Field("str", True),
    "initial": Field("number", True),
    "range": Field("range"),
    "every": Field("str"),
    "observer": Field("bool"),
    "unit": Field("str"),
    "doc": Field("str", True),
    "cite": Field("str"),
}
DEFINITION = {
    "expr": Field("str", True),
    "if_invalid": Field("bool"),
    "unit": Field("str"),
    "doc": Field("str", True),
    "cite": Field("str"),
}
OUTPUT = {
    "expr": Field("str", True),
    "type": Field("str"),
    "range": Field("range"),
    "if_invalid": Field("bool-or-number"),
    "unit": Field("str"),
    "doc": Field("str", True),
    "cite": Field("str"),
}
TABLES = {"params": PARAM, "signals": SIGNAL, "variables": VARIABLE, "definitions": DEFINITION, "outputs": OUTPUT}
TOP = {"machine", "inputs", "transition", "invariant", "liveness", "lemma", "compare", "expect", "assume", *TABLES}
ARRAYS = {
    "transition": TRANSITION,
    "invariant": INVARIANT,
    "liveness": LIVENESS,
    "compare": COMPARE,
    "assume": ASSUME,
    "lemma": LEMMA,
}

_KIND_TEXT = {
    "str": "a string",
    "str-or-list": "a string or an array of strings",
    "list-of-str": "an array of strings",
    "int": "an integer",
    "table-of-str": "a table of strings",
    "bool": "true or false",
    "number": "a number",
    "range": "an array of two numbers [low, high]",
    "int-or-str": "an integer or a string",
    "bool-or-number": "true, false or a number",
}


def _type_name(value: object) -> str:
    names = {bool: "boolean", int: "integer", float: "float", str: "string", list: "array", dict: "table"}
    return names.get(type(value), type(value).__name__)


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _fits(kind: str, value: object) -> bool:
    is_str_list = isinstance(value, list) and all(isinstance(v, str) for v in value)
    return {
        "bool": isinstance(value, bool),
        "number": _is_number(value),
        "bool-or-number": isinstance(value, bool) or _is_number(value),
        "range": isinstance(value, list) and len(value) == 2 and all(_is_number(v) for v in value),
        "int-or-str": isinstance(value, str) or (isinstance(value, int) and not isinstance(value, bool)),
        "str": isinstance(value, str),
        "str-or-list": isinstance(value, str) or is_str_list,
        "list-of-str": is_str_list,
        "int": isinstance(value, int) and not isinstance(value, bool),
        "table-of-str": isinstance(value, dict) and all(isinstance(v, str) for v in value.values()),
    }[kind]


def _suggest(key: str, allowed: set[str] | Mapping[str, object]) -> str:
    close = difflib.get_close_matches(key, sorted(allowed), n=1)
    return f" (did you mean '{close[0]}'?)" if close else f" (allowed: {', '.join(sorted(allowed))})"


class ShapeChecker:
    """Checks a parsed TOML document against the spec format; raises `SpecError` at the first problem."""

    def __init__(self, doc: dict[str, Any], where: Locator) -> None:
        self.doc = doc
        self.where = where

    def fail(self, path: KeyPath, message: str) -> SpecError:
        return SpecError(self.where.loc(path), message)

    def check(self) -> None:
        for key in self.doc:
            if key not in TOP:
                raise self.fail((key,), f"unknown top-level key '{key}'{_suggest(key, TOP)}")
        if "machine" not in self.doc:
            raise self.fail((), "missing table [machine]")
        self.table(("machine",), self.doc["machine"], MACHINE, "[machine]")
        self.inputs(self.doc.get("inputs"))
        for name, fields in TABLES.items():
            self.named_tables(name, self.doc.get(name, {}), fields)
        for name, fields in ARRAYS.items():
            self.array(name, self.doc.get(name, []), fields)
        self.expect_table(self.doc.get("expect", {}))

    def table(self, path: KeyPath, value: object, fields: Mapping[str, Field], label: str) -> None:
        if not isinstance(value, dict):
            raise self.fail(path, f"{label} must be a table, got {_type_name(value)}")
        for key in value:
            if key not in fields:
                raise self.fail((*path, key), f"unknown key '{key}' in {label}{_suggest(key, fields)}")
        for key, spec in fields.items():
            if key not in value:
                if spec.required:
                    raise self.fail(path, f"missing key '{key}' in {label}")
                continue
            if not _fits(spec.kind, value[key]):
                got = _type_name(value[key])
                raise self.fail((*path, key), f"'{key}' in {label} must be {_KIND_TEXT[spec.kind]}, got {got}")

    def named_tables(self, section: str, value: object, fields: Mapping[str, Field]) -> None:
        if not isinstance(value, dict):
            raise self.fail((section,), f"[{section}] must be a table, got {_type_name(value)}")
        if len(value) > MAX_ELEMENTS:
            raise self.fail((section,), f"{len(value)} entries in [{section}]: at most {MAX_ELEMENTS} are supported")
        for name, item in value.items():
            self.table((section, name), item, fields, f"{section[:-1]} '{name}'")

    def inputs(self, value: object) -> None:
        if value is None:
            if any(key in self.doc for key in ("signals", "definitions")):
                return
            raise self.fail((), "missing table [inputs]")
        if not isinstance(value, dict):
            raise self.fail(("inputs",), f"[inputs] must be a table, got {_type_name(value)}")
        for name, item in value.items():
            self.table(("inputs", name), item, INPUT, f"input '{name}'")

    def array(self, name: str, value: object, fields: Mapping[str, Field]) -> None:
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.fail((name,), f"'{name}' must be an array of tables ([[{name}]]), got {_type_name(value)}")
        if len(value) > MAX_ELEMENTS:
            raise self.fail((name,), f"{len(value)} [[{name}]] tables: at most {MAX_ELEMENTS} are supported")
        for index, item in enumerate(value):
            self.table((name, index), item, fields, f"[[{name}]] #{index + 1}")

    def expect_table(self, value: object) -> None:
        if not _fits("table-of-str", value):
            raise self.fail(("expect",), f"[expect] must be {_KIND_TEXT['table-of-str']}")
