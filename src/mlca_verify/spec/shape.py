"""Stage one of loading: the shape of the TOML document (keys, types), nothing about meaning."""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from mlca_verify.errors import SpecError
from mlca_verify.spec.locate import KeyPath, Locator
from mlca_verify.spec.names import MAX_ELEMENTS


@dataclass(frozen=True)
class Field:
    kind: str  # "str", "str-or-list", "list-of-str", "int", "table-of-str"
    required: bool = False


MACHINE = {
    "name": Field("str", True),
    "initial": Field("str", True),
    "states": Field("list-of-str", True),
    "semantics": Field("str"),
    "otherwise": Field("str"),
    "cite": Field("str", True),
    "doc": Field("str"),
}
INPUT = {"doc": Field("str", True), "cite": Field("str", True)}
TRANSITION = {
    "id": Field("str"),
    "from": Field("str-or-list", True),
    "to": Field("str", True),
    "when": Field("str", True),
    "cite": Field("str", True),
    "doc": Field("str"),
}
INVARIANT = {
    "id": Field("str", True),
    "expr": Field("str", True),
    "cite": Field("str", True),
    "expect": Field("str"),
    "doc": Field("str"),
}
LIVENESS = {
    "id": Field("str", True),
    "assume": Field("str", True),
    "goal": Field("str", True),
    "within": Field("int"),
    "cite": Field("str", True),
    "expect": Field("str"),
    "doc": Field("str"),
}
COMPARE = {"with": Field("str", True), "cite": Field("str", True), "expect": Field("str")}
TOP = {"machine", "inputs", "transition", "invariant", "liveness", "compare", "expect"}
ARRAYS = {"transition": TRANSITION, "invariant": INVARIANT, "liveness": LIVENESS, "compare": COMPARE}

_KIND_TEXT = {
    "str": "a string",
    "str-or-list": "a string or an array of strings",
    "list-of-str": "an array of strings",
    "int": "an integer",
    "table-of-str": "a table of strings",
}


def _type_name(value: object) -> str:
    names = {bool: "boolean", int: "integer", float: "float", str: "string", list: "array", dict: "table"}
    return names.get(type(value), type(value).__name__)


def _fits(kind: str, value: object) -> bool:
    is_str_list = isinstance(value, list) and all(isinstance(v, str) for v in value)
    return {
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

    def inputs(self, value: object) -> None:
        if value is None:
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
