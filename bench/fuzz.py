"""Fuzz the command line with mutated and adversarial specs, and count every break of the error contract.

The contract: a mistake in a spec or on the command line ends in exactly one line on stderr and exit 2; never a
traceback, never another exit code for bad input, never a hang, never unbounded memory; and a spec that `gen`
accepts yields Python that imports and C that compiles warning-free.

Run on demand (not part of the test suite):

    .venv/bin/python bench/fuzz.py --cases 5000 --seed 1 --workers 2 --save out/fuzz

Each case is one spec file (sometimes with a sibling it compares with), made from the shipped specs and the
test corpus by textual mutations (lines deleted, duplicated, swapped; characters flipped; values of another
type) or by adversarial edits (deep expressions and arrays, hostile names and texts, huge numbers and
strings, thousands of transitions, non-UTF-8 and enormous files). Every case runs
`mlca-verify check SPEC --json/--junit/--sarif` and `mlca-verify gen SPEC --out DIR`, each in its own process
with a time limit and an address-space limit; generated code is then imported (Python) and compiled
(`gcc -std=c99 -Wall -Wextra -Werror -c`). A command that ends in an internal error (exit 3) runs again with
`--debug` for the traceback it hides. A case is a pure function of (seed, index): `--case I` runs one case
again and prints everything about it. `--mode fork` forks every command from a process that has already
imported the toolkit (same limits, same exit codes, no interpreter start-up), several times faster than the
default `--mode exec`, which starts `python -m mlca_verify` for every command.

Failing inputs are written under `--save DIR`, one folder per failure kind and case, with the command, the exit
code and the output; inputs larger than 1 MB are not written, only the command that regenerates them.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import multiprocessing
import multiprocessing.connection
import os
import random
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
import traceback
from collections import Counter
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
BASE_FILES = sorted(
    [*ROOT.glob("spec/*.toml"), *ROOT.glob("spec/paper/*.toml"), *ROOT.glob("tests/corpus/*.toml")],
    key=lambda p: p.relative_to(ROOT).as_posix(),
)
SPEC = "spec.toml"
OTHER = "other.toml"
SAVE_LIMIT = 1 << 20  # inputs larger than this are described, not saved
DEFAULT_TIMEOUT_S = 10.0
DEFAULT_MEMORY_MB = 1024
QUERY_TIMEOUT_MS = "2000"  # the solver's own per-query budget, well inside the process time limit
INTERNAL_ERROR = 3  # the exit code of a bug caught at the top level; `--debug` prints its traceback
DEBUG_FLAG = "--debug"

# --- failure kinds ---------------------------------------------------------------------------------------------

TRACEBACK = "traceback"
BAD_EXIT = "exit code not 0/1/2"
HANG = "hang (timeout)"
MEMORY = "memory failure"
MULTILINE = "exit 2, stderr not one line"
WRONGLY_ACCEPTED = "wrongly accepted names"
KINDS = (TRACEBACK, BAD_EXIT, HANG, MEMORY, MULTILINE, WRONGLY_ACCEPTED)
SLUG = {
    TRACEBACK: "traceback",
    BAD_EXIT: "bad-exit",
    HANG: "hang",
    MEMORY: "memory",
    MULTILINE: "multiline",
    WRONGLY_ACCEPTED: "wrongly-accepted",
}
_MEMORY_SIGNS = ("MemoryError", "std::bad_alloc", "out of memory", "Cannot allocate memory", "cannot allocate memory")


# --- a small TOML writer, enough for the spec format and for verbatim adversarial values -----------------------


@dataclass(frozen=True)
class Raw:
    """A value written verbatim (deep arrays, malformed values)."""

    text: str


_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def toml_str(text: str) -> str:
    out = []
    for ch in text:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        elif 0xD800 <= ord(ch) <= 0xDFFF:
            out.append("?")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(key: str) -> str:
    return key if _BARE_KEY.match(key) else toml_str(key)


def toml_value(value: object) -> str:
    if isinstance(value, Raw):
        return value.text
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return toml_str(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + " }"
    return toml_str(str(value))


def toml_dump(doc: dict[str, Any]) -> str:
    """Top-level scalars, then tables (`[name]`) and arrays of tables (`[[name]]`); deeper tables inline."""
    head: list[str] = []
    body: list[str] = []
    for key, value in doc.items():
        if isinstance(value, dict):
            body.append(f"\n[{toml_key(key)}]")
            body.extend(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items())
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for item in value:
                body.append(f"\n[[{toml_key(key)}]]")
                body.extend(f"{toml_key(k)} = {toml_value(v)}" for k, v in item.items())
        else:
            head.append(f"{toml_key(key)} = {toml_value(value)}")
    return "\n".join(head + body).lstrip("\n") + "\n"


# --- the seed specs --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Base:
    name: str
    text: str
    doc: dict[str, Any]
    siblings: dict[str, bytes]  # the specs it compares with, copied beside every case made from it


def load_bases() -> list[Base]:
    bases = []
    for path in BASE_FILES:
        text = path.read_text(encoding="utf-8")
        doc = tomllib.loads(text)
        siblings = {}
        for item in doc.get("compare", []):
            other = path.parent / item["with"]
            if "/" not in item["with"] and other.is_file() and item["with"] != SPEC:
                siblings[item["with"]] = other.read_bytes()
        bases.append(Base(path.relative_to(ROOT).as_posix(), text, doc, siblings))
    if not bases:
        raise SystemExit("fuzz: no seed specs found under spec/ and tests/corpus/")
    return bases


# --- adversarial material --------------------------------------------------------------------------------------

# Names that the generated Python or C also defines, or that the languages and headers reserve.
GENERATED_CLASHES = (
    "INITIAL", "FSM_H", "mro", "State", "Inputs", "step", "state_valid", "check_invariants", "GENERATOR",
    "SPEC_PATH", "SPEC_SHA256", "IntEnum", "dataclass", "annotations", "name", "value", "inputs", "state",
    "failed", "next", "hold", "valid", "s", "bool", "true", "false", "NULL", "EOF", "errno", "stdin", "assert",
    "printf", "exit", "size_t", "int8_t", "INT_MAX", "main", "self", "cls", "print", "object", "PyObject",
    "from_bytes", "bit_length", "real", "conjugate", "replace", "fields", "STATE", "FSM", "CAT",
)  # fmt: skip
CONTROL_SUFFIXES = ("\n", "\r", "\t", "\x00", "\x1b", " ", "\x0c", "\x7f", "\u2028", "\u00a0")
HOSTILE_TEXTS = (
    "line one\nline two",
    "*/ int injected; /*",
    "/* nested",
    '"',
    '"""',
    "'''",
    "\\",
    "ends with a backslash \\",
    "\\N{oops}",
    "\\x",
    "\\u12",
    "\r",
    "\x00",
    "\x0c",
    "??/",
    "{{ m.name }}",
    "{% if %}",
    "\u2028",
    "#",
    "\n    __import__('sys').exit(97)\n    #",
    '"""\n__import__("sys").exit(97)\n"""',
    "\nimport sys; sys.exit(97)\n",
    "\n#error injected\n",
    "*/\n#error injected\n/*",
    "</script><script>alert(1)</script>",
    "\t",
    "é ü ß",
    "\U0001f600",
    "\\\n",
    "' or '",
    "$(touch pwned)",
)
WITHIN_VALUES = (10**9, 10**12, 2**63 - 1, 10**6, 10**5, 0, -1, -(2**63))
COMPARE_TARGETS = (
    "../outside.toml",
    "/etc/passwd",
    "/dev/zero",
    "/dev/null",
    "/proc/self/status",
    "",
    ".",
    "..",
    SPEC,
    "\x00",
    "a\nb.toml",
    "~/spec.toml",
    "spec/../spec.toml",
)
PROPERTY_IDS = (
    "equiv",
    "fires",
    "reach",
    "state-range",
    "equiv:X",
    "fires:t1",
    "determinism",
    "completeness",
    "A.B",
    "a-b",
    "x" * 300,
    "A1\n",
)
EXPRESSION_KEYS = {"transition": ("when",), "invariant": ("expr",), "liveness": ("assume", "goal")}
TEXT_KEYS = ("doc", "cite")


def deep_expression(rng: random.Random, atom: str, depth: int) -> str:
    shape = rng.choice(["parens", "not", "or", "and", "implies", "iff", "mixed", "not-parens"])
    if shape == "parens":
        return "(" * depth + atom + ")" * depth
    if shape == "not":
        return "not " * depth + atom
    if shape == "not-parens":
        return "not (" * depth + atom + ")" * depth
    if shape == "mixed":
        ops = ["and", "or", "->", "<->"]
        text = atom
        for _ in range(depth):
            text = f"({atom} {rng.choice(ops)} {text})"
        return text
    op = {"or": "or", "and": "and", "implies": "->", "iff": "<->"}[shape]
    return f" {op} ".join([atom] * depth)


def deep_array(rng: random.Random, depth: int) -> Raw:
    if rng.random() < 0.5:
        return Raw("[" * depth + '"A"' + "]" * depth)
    return Raw("{ a = " * depth + "1" + " }" * depth)


def odd_value(rng: random.Random) -> object:
    return rng.choice(
        [
            1,
            -1,
            0,
            10**30,
            1.5,
            Raw("nan"),
            Raw("inf"),
            True,
            False,
            [],
            [1, 2],
            ["a", 1],
            [[]],
            {},
            {"a": "b"},
            "",
            Raw("1979-05-27T07:32:00Z"),
            Raw("07:32:00"),
            Raw("1979-05-27"),
            Raw("'literal'"),
            Raw("'''multi\nline'''"),
            Raw('"""multi\nline"""'),
            "x" * 5000,
        ]
    )


def hostile_name(rng: random.Random, old: str, machine: str) -> str:
    pick = rng.random()
    if pick < 0.3:
        return old + rng.choice(CONTROL_SUFFIXES)
    if pick < 0.45:
        return rng.choice(GENERATED_CLASHES)
    if pick < 0.6:
        upper, lower = machine.upper(), machine.lower()
        return rng.choice([f"{upper}_FSM_H", f"{upper}_INITIAL", f"{lower}_step", f"{lower}_state_t", f"{upper}_{old}"])
    if pick < 0.75:
        return "N" + "x" * rng.choice([63, 64, 255, 299, 300, 5000])
    if pick < 0.85:
        return rng.choice(["É", "Ω", "a b", "a-b", "1a", "_a", "a__b", "a.b", "", " ", "\x00", "🙂"])
    return rng.choice(CONTROL_SUFFIXES) + old


# --- structured edits on a parsed spec -------------------------------------------------------------------------


def _tables(doc: dict[str, Any], key: str) -> list[dict[str, Any]]:
    value = doc.get(key)
    return [v for v in value if isinstance(v, dict)] if isinstance(value, list) else []


def _rename_word(text: str, old: str, new: str) -> str:
    return re.sub(rf"(?<![A-Za-z0-9_]){re.escape(old)}(?![A-Za-z0-9_])", lambda _: new, text)


def _expressions(doc: dict[str, Any]) -> Iterator[tuple[dict[str, Any], str]]:
    for table, keys in EXPRESSION_KEYS.items():
        for item in _tables(doc, table):
            for key in keys:
                if isinstance(item.get(key), str):
                    yield item, key


def rename_state(doc: dict[str, Any], old: str, new: str) -> None:
    m = doc["machine"]
    m["states"] = [new if s == old else s for s in m["states"]]
    if m.get("initial") == old:
        m["initial"] = new
    for t in _tables(doc, "transition"):
        if t.get("to") == old:
            t["to"] = new
        if t.get("from") == old:
            t["from"] = new
        elif isinstance(t.get("from"), list):
            t["from"] = [new if s == old else s for s in t["from"]]
    for item, key in _expressions(doc):
        item[key] = _rename_word(item[key], old, new)
    if isinstance(doc.get("expect"), dict):
        doc["expect"] = {(f"reach:{new}" if k == f"reach:{old}" else k): v for k, v in doc["expect"].items()}


def rename_input(doc: dict[str, Any], old: str, new: str) -> None:
    doc["inputs"] = {(new if k == old else k): v for k, v in doc["inputs"].items()}
    for item, key in _expressions(doc):
        item[key] = _rename_word(item[key], old, new)


def edit_names(rng: random.Random, doc: dict[str, Any]) -> str:
    m = doc["machine"]
    target = rng.choice(["state", "state", "input", "input", "machine", "transition-id", "initial-only"])
    if target == "state" and m["states"]:
        old = rng.choice(m["states"])
        rename_state(doc, old, hostile_name(rng, old, m["name"]))
    elif target == "input" and doc["inputs"]:
        old = rng.choice(list(doc["inputs"]))
        rename_input(doc, old, hostile_name(rng, old, m["name"]))
    elif target == "machine":
        m["name"] = hostile_name(rng, m["name"], m["name"])
    elif target == "transition-id" and _tables(doc, "transition"):
        t = rng.choice(_tables(doc, "transition"))
        t["id"] = hostile_name(rng, str(t.get("id", "t")), m["name"])
    else:
        m["initial"] = hostile_name(rng, m["initial"], m["name"])
    return f"names:{target}"


def edit_clash_pair(rng: random.Random, doc: dict[str, Any]) -> str:
    """Two names that differ only where generated code cannot tell them apart."""
    m = doc["machine"]
    pair = rng.choice([("a_b", "a-b"), ("A.B", "A_B"), ("equiv", "fires"), ("x1", "X1")])
    items = _tables(doc, "invariant") + _tables(doc, "liveness")
    if len(items) >= 2:
        items[0]["id"], items[1]["id"] = pair
    else:
        m["states"] = [*m["states"], "Extra"]
        rename_state(doc, "Extra", f"{m['initial']}_" if rng.random() < 0.5 else m["initial"].lower())
    return "names:clash-pair"


def edit_text(rng: random.Random, doc: dict[str, Any]) -> str:
    places: list[dict[str, Any]] = [doc["machine"]]
    places += [v for v in doc["inputs"].values() if isinstance(v, dict)]
    for key in ("transition", "invariant", "liveness", "compare"):
        places += _tables(doc, key)
    place = rng.choice(places)
    key = rng.choice(TEXT_KEYS)
    if rng.random() < 0.1:
        place[key] = "x" * rng.choice([10**5, 10**6, 8 * 10**6])
        return f"text:huge-{key}"
    place[key] = rng.choice(HOSTILE_TEXTS) + (rng.choice(HOSTILE_TEXTS) if rng.random() < 0.3 else "")
    return f"text:{key}"


def edit_deep_expression(rng: random.Random, doc: dict[str, Any]) -> str:
    found = list(_expressions(doc))
    if not found:
        return "deep:none"
    item, key = rng.choice(found)
    atom = next(iter(doc["inputs"]), "x") if key in ("when", "assume") else f"state == {doc['machine']['initial']}"
    if key in ("expr", "goal") and rng.random() < 0.3:
        states = ", ".join([doc["machine"]["initial"]] * rng.choice([1000, 5000]))
        item[key] = f"state in {{{states}}}"
        return f"deep:state-set-{key}"
    depth = rng.choice([100, 300, 500, 800, 1000, 1000, 1500, 3000, 10000, 50000])
    item[key] = deep_expression(rng, atom, depth)
    return f"deep:{key}-{depth}"


def edit_deep_array(rng: random.Random, doc: dict[str, Any]) -> str:
    depth = rng.choice([100, 500, 1000, 1000, 3000, 10000])
    place = rng.choice(["states", "from", "doc", "top", "expect"])
    if place == "states":
        doc["machine"]["states"] = deep_array(rng, depth)
    elif place == "from" and _tables(doc, "transition"):
        rng.choice(_tables(doc, "transition"))["from"] = deep_array(rng, depth)
    elif place == "doc":
        doc["machine"]["doc"] = deep_array(rng, depth)
    elif place == "expect":
        doc["expect"] = {"determinism": deep_array(rng, depth)}
    else:
        doc["machine"]["cite"] = deep_array(rng, depth)
    return f"deep-array:{place}-{depth}"


def edit_within(rng: random.Random, doc: dict[str, Any]) -> str:
    value = rng.choice(WITHIN_VALUES)
    items = _tables(doc, "liveness")
    if items:
        rng.choice(items)["within"] = value
    else:
        atom = next(iter(doc["inputs"]))
        doc["liveness"] = [
            {
                "id": "huge",
                "assume": atom,
                "goal": f"state == {doc['machine']['initial']}",
                "within": value,
                "cite": "c",
            }
        ]
    return f"within:{value}"


def edit_many_transitions(rng: random.Random, doc: dict[str, Any]) -> str:
    m = doc["machine"]
    count = rng.choice([500, 2000, 2000, 5000])
    inputs = list(doc["inputs"]) or ["x"]
    source = m["initial"]
    added = []
    for k in range(count):
        a, b = rng.choice(inputs), rng.choice(inputs)
        added.append(
            {
                "id": f"bulk{k}",
                "from": source,
                "to": rng.choice(m["states"]),
                "when": f"{a} and not {b}" if k % 3 else f"{a} or {b}",
                "cite": f"bulk {k}",
            }
        )
    doc["transition"] = _tables(doc, "transition") + added
    return f"bulk:transitions-{count}"


def edit_many_states(rng: random.Random, doc: dict[str, Any]) -> str:
    m = doc["machine"]
    count = rng.choice([1000, 3000, 10000])
    extra = [f"Q{k}" for k in range(count)]
    m["states"] = [*m["states"], *extra]
    atom = next(iter(doc["inputs"]))
    doc["transition"] = [
        *_tables(doc, "transition"),
        *({"from": extra[k], "to": extra[(k + 1) % count], "when": atom, "cite": "ring"} for k in range(count)),
        {"from": m["initial"], "to": extra[0], "when": atom, "cite": "enter"},
    ]
    return f"bulk:states-{count}"


def edit_property_id(rng: random.Random, doc: dict[str, Any]) -> str:
    pid = rng.choice(PROPERTY_IDS)
    items = _tables(doc, "invariant") + _tables(doc, "liveness")
    if items:
        rng.choice(items)["id"] = pid
    else:
        doc["invariant"] = [{"id": pid, "expr": "true", "cite": "c"}]
    if rng.random() < 0.3 and _tables(doc, "transition"):
        rng.choice(_tables(doc, "transition"))["id"] = rng.choice(PROPERTY_IDS)
    return f"property-id:{pid[:20]!r}"


def edit_compare(rng: random.Random, doc: dict[str, Any], files: dict[str, bytes], bases: list[Base]) -> str:
    pick = rng.random()
    if pick < 0.25:
        target = "x" * rng.choice([255, 256, 4096, 5000])
        label = f"long-{len(target)}"
    elif pick < 0.35:
        target = "../" * 40 + "etc/passwd"
        label = "outside"
    elif pick < 0.55:
        target = rng.choice(COMPARE_TARGETS)
        label = repr(target)[:24]
    elif pick < 0.65:
        target = str(ROOT / "spec" / "mlca.toml")
        label = "absolute-shipped"
    else:
        other = copy.deepcopy(rng.choice(bases).doc)
        mutate_doc(rng, other, {}, bases, depth=1)
        files[OTHER] = toml_dump(other).encode("utf-8", "surrogatepass")
        target = OTHER
        label = "adversarial-sibling"
    doc["compare"] = [{"with": target, "cite": rng.choice(["c", *HOSTILE_TEXTS]), "expect": "violated"}]
    return f"compare:{label}"


def edit_type(rng: random.Random, doc: dict[str, Any]) -> str:
    holders: list[tuple[dict[str, Any], str]] = [(doc, k) for k in doc]
    holders += [(doc["machine"], k) for k in doc["machine"]] if isinstance(doc.get("machine"), dict) else []
    for key in ("transition", "invariant", "liveness", "compare"):
        for item in _tables(doc, key):
            holders += [(item, k) for k in item]
    if isinstance(doc.get("inputs"), dict):
        holders += [(doc["inputs"], k) for k in doc["inputs"]]
    holder, key = rng.choice(holders)
    holder[key] = odd_value(rng)
    return f"type:{key}"


def edit_keys(rng: random.Random, doc: dict[str, Any]) -> str:
    pick = rng.choice(["drop", "unknown", "empty-table", "drop-top"])
    if pick == "drop-top":
        doc.pop(rng.choice(list(doc)), None)
    elif pick == "empty-table":
        doc[rng.choice(["machine", "inputs", "expect"])] = {}
    else:
        tables = [doc["machine"], *_tables(doc, "transition"), *_tables(doc, "liveness"), *_tables(doc, "invariant")]
        table = rng.choice(tables)
        if pick == "drop" and table:
            table.pop(rng.choice(list(table)))
        else:
            table[rng.choice(["whn", "From", "id ", "expect", "within", "semantics", "otherwise"])] = "x"
    return f"keys:{pick}"


def edit_semantics(rng: random.Random, doc: dict[str, Any]) -> str:
    doc["machine"]["semantics"] = rng.choice(["first-match", "any-enabled"])
    doc["machine"]["otherwise"] = rng.choice(["stay", "undefined"])
    return "semantics"


EDITS: list[tuple[float, Callable[[random.Random, dict[str, Any]], str]]] = [
    (3, edit_names),
    (1, edit_clash_pair),
    (3, edit_text),
    (2, edit_deep_expression),
    (1, edit_deep_array),
    (0.6, edit_within),
    (0.12, edit_many_transitions),
    (0.06, edit_many_states),
    (1.5, edit_property_id),
    (2, edit_type),
    (1.5, edit_keys),
    (1, edit_semantics),
]


def mutate_doc(rng: random.Random, doc: dict[str, Any], files: dict[str, bytes], bases: list[Base], depth: int) -> str:
    labels = []
    for _ in range(1 if depth else rng.choice([1, 1, 1, 2, 3])):
        if depth == 0 and rng.random() < 0.1:
            labels.append(edit_compare(rng, doc, files, bases))
            continue
        weights = [w for w, _ in EDITS]
        edit = rng.choices([e for _, e in EDITS], weights)[0]
        try:
            labels.append(edit(rng, doc))
        except (KeyError, TypeError, AttributeError, IndexError, ValueError):
            labels.append("edit-skipped")  # an earlier edit changed a type the next one relied on
    return "+".join(labels)


# --- textual mutations -----------------------------------------------------------------------------------------

FLIP_ALPHABET = "\"'=[]{}(),.#\\\n\r\t\x00\x7f *-<>!:;x1é€\u2028\ufeff"


def mutate_text(rng: random.Random, text: str) -> tuple[str, str]:
    labels = []
    for _ in range(rng.choice([1, 1, 2, 3, 5])):
        lines = text.splitlines(keepends=True) or [""]
        kind = rng.choice(["delete", "dup", "swap", "flip", "flip", "insert", "truncate", "retype", "repeat"])
        k = rng.randrange(len(lines))
        if kind == "delete":
            del lines[k]
        elif kind == "dup":
            lines.insert(k, lines[k])
        elif kind == "swap":
            j = rng.randrange(len(lines))
            lines[k], lines[j] = lines[j], lines[k]
        elif kind == "repeat":
            lines[k] = lines[k] * rng.choice([2, 100, 2000])
        elif kind == "retype":
            lines[k] = re.sub(r"=\s*(.*)$", lambda _: "= " + toml_value(odd_value(rng)), lines[k].rstrip("\n")) + "\n"
        text = "".join(lines)
        if kind in ("flip", "insert") and text:
            at = rng.randrange(len(text))
            ch = rng.choice(FLIP_ALPHABET)
            text = text[:at] + ch + text[at + (kind == "flip") :]
        elif kind == "truncate" and text:
            text = text[: rng.randrange(len(text))]
        labels.append(kind)
    return text, "text:" + "+".join(labels)


# --- whole files -----------------------------------------------------------------------------------------------


@dataclass
class Case:
    index: int
    kind: str
    files: dict[str, bytes] = field(default_factory=dict)
    spec_arg: str = SPEC  # relative to the case folder, or an absolute path such as /dev/zero
    check_extra: tuple[str, ...] = ()
    gen_extra: tuple[str, ...] = ()
    big: bool = False  # too big to save: regenerate it with --case

    @property
    def size(self) -> int:
        return sum(len(v) for v in self.files.values())


def raw_file(rng: random.Random, case: Case, bases: list[Base]) -> None:
    pick = rng.choice(RAW_KINDS)
    case.kind = f"file:{pick}"
    if pick in ("devzero", "directory", "missing"):
        case.spec_arg = {"devzero": "/dev/zero", "directory": ".", "missing": "missing.toml"}[pick]
    data = raw_bytes(rng, pick, rng.choice(bases))
    case.files[SPEC] = data
    case.big = len(data) > SAVE_LIMIT


RAW_KINDS = (
    "empty", "blank", "zeros", "big-zeros", "big-comment", "big-string", "latin1", "bad-byte", "bom", "utf16",
    "random", "devzero", "directory", "missing", "big-lines",
)  # fmt: skip


def _bad_bytes(rng: random.Random, text: str) -> bytes:
    raw = bytearray(text.encode())
    for _ in range(rng.choice([1, 3])):
        raw.insert(rng.randrange(len(raw) + 1), rng.choice([0xFF, 0xFE, 0xC0, 0x80, 0xED, 0xF5]))
    return bytes(raw)


def _huge_doc(base: Base) -> bytes:
    doc = copy.deepcopy(base.doc)
    doc["machine"]["doc"] = "y" * (32 << 20)
    return toml_dump(doc).encode()


def raw_bytes(rng: random.Random, pick: str, base: Base) -> bytes:
    makers: dict[str, Callable[[], bytes]] = {
        "empty": lambda: b"",
        "blank": lambda: b" \n\t\n" * rng.choice([1, 1000]),
        "zeros": lambda: b"\x00" * rng.choice([1, 100, 4096]),
        "big-zeros": lambda: b"\x00" * (64 << 20),
        "big-comment": lambda: base.text.encode() + b"#" + b"x" * (64 << 20) + b"\n",
        "big-lines": lambda: base.text.encode() + b"\n" * (32 << 20),
        "big-string": lambda: _huge_doc(base),
        "latin1": lambda: base.text.replace('cite = "', 'cite = "\u00e9', 1).encode("latin-1", "replace"),
        "bad-byte": lambda: _bad_bytes(rng, base.text),
        "bom": lambda: b"\xef\xbb\xbf" + base.text.encode(),
        "utf16": lambda: base.text.encode("utf-16"),
        "random": lambda: rng.randbytes(rng.choice([10, 400, 4000])),
    }
    return makers.get(pick, base.text.encode)()


def argv_edge(rng: random.Random, case: Case) -> None:
    pick = rng.choice(list(ARGV_EDGES))
    case.kind += f"+argv:{pick}"
    case.check_extra, case.gen_extra = ARGV_EDGES[pick]


# Extra arguments of `check` and of `gen`.
ARGV_EDGES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "timeout-0": (("--timeout-ms", "0"), ()),
    "timeout-neg": (("--timeout-ms", "-1"), ()),
    "timeout-huge": (("--timeout-ms", "99999999999999999999"), ()),
    "only-empty": (("--only", ""), ()),
    "only-odd": (("--only", ",,\n,determinism"), ()),
    "json-dir": (("--json", "."), ()),
    "json-long": (("--json", "j" * 300 + ".json"), ()),
    "out-file": ((), ("--out", SPEC)),
    "out-devnull": ((), ("--out", "/dev/null/x")),
    "gen-check-missing": ((), ("--check", "--out", "nowhere")),
    "emit-tests": (("--emit-tests", "emitted", "--generated", "nowhere"), ()),
}


def make_case(seed: int, index: int, bases: list[Base]) -> Case:
    """Case `index` of run `seed`: the same bytes on every machine and every run."""
    rng = random.Random(f"mlca-fuzz/{seed}/{index}")
    case = Case(index, "")
    family = rng.random()
    if family < 0.08:
        raw_file(rng, case, bases)
    else:
        base = rng.choice(bases)
        case.files.update(base.siblings)
        if family < 0.40:
            text, label = mutate_text(rng, base.text)
        else:
            doc = copy.deepcopy(base.doc)
            label = mutate_doc(rng, doc, case.files, bases, depth=0)
            text = toml_dump(doc)
            if rng.random() < 0.15:
                text, more = mutate_text(rng, text)
                label += "+" + more
        case.kind = f"{Path(base.name).stem}:{label}"
        case.files[SPEC] = text.encode("utf-8", "surrogatepass")
        case.big = case.size > SAVE_LIMIT
    if rng.random() < 0.04:
        argv_edge(rng, case)
    return case


# --- running commands ------------------------------------------------------------------------------------------


@dataclass
class Run:
    command: str  # "check", "gen", "python-import", "gcc"
    argv: list[str]
    code: int | None  # None: killed at the time limit
    out: str
    err: str
    seconds: float


def _limits(memory: int) -> Callable[[], None]:
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        os.setsid()  # a timeout kills the whole group (gcc's children included)

    return apply


def _read(path: Path) -> str:
    with open(path, "rb") as f:
        data = f.read(1 << 20)
    return data.decode("utf-8", "replace")


_SPAWN = threading.Lock()


def run_exec(argv: list[str], cwd: Path, timeout: float, memory: int, command: str) -> Run:
    out_path, err_path = cwd / f".{command}.out", cwd / f".{command}.err"
    start = time.perf_counter()
    with open(out_path, "wb") as out, open(err_path, "wb") as err, _SPAWN:
        # the limits are set between fork and exec by system calls only; one spawn at a time
        proc = subprocess.Popen(
            argv,
            cwd=cwd,
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=err,
            preexec_fn=_limits(memory),  # noqa: PLW1509
        )
        try:
            code: int | None = proc.wait(timeout)
        except subprocess.TimeoutExpired:
            kill_group(proc.pid)
            proc.wait()
            code = None
    return Run(command, argv, code, _read(out_path), _read(err_path), time.perf_counter() - start)


def kill_group(pid: int) -> None:
    """Kill the process group `pid` leads, or the process alone when it has not made its group yet."""
    try:
        os.killpg(pid, signal.SIGKILL)
    except OSError:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _cli_child(argv: list[str], cwd: str, out_path: str, err_path: str, memory: int) -> None:
    """Runs in a process forked from the fork server: behaves as `mlca-verify ARGV` would."""
    _limits(memory)()
    os.chdir(cwd)
    for fd, path in ((1, out_path), (2, err_path)):
        target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(target, fd)
        os.close(target)
    sys.stdout = open(1, "w", encoding="utf-8", errors="backslashreplace", closefd=False)  # noqa: SIM115
    sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False)  # noqa: SIM115
    sys.argv = ["mlca-verify", *argv]
    code = 1
    try:
        from mlca_verify.cli import entry

        entry()
        code = 0
    except SystemExit as done:
        if done.code is None or isinstance(done.code, int):
            code = done.code or 0
        else:
            print(done.code, file=sys.stderr)
    except BaseException:
        traceback.print_exc()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(BaseException):
            stream.flush()
    os._exit(code & 0xFF)


class ForkRunner:
    """Forks every command from a server process that has already imported the toolkit."""

    def __init__(self) -> None:
        self.context = multiprocessing.get_context("forkserver")
        self.context.set_forkserver_preload(["__main__", "mlca_verify.cli"])
        self.lock = threading.Lock()

    def run(self, argv: list[str], cwd: Path, timeout: float, memory: int, command: str) -> Run:
        out_path, err_path = cwd / f".{command}.out", cwd / f".{command}.err"
        start = time.perf_counter()
        proc = self.context.Process(target=_cli_child, args=(argv, str(cwd), str(out_path), str(err_path), memory))
        # start() polls every other child still running, and two threads reading one child's exit status at once
        # make one of them see 255: starting and reaping hold one lock, waiting does not
        with self.lock:
            proc.start()
        finished = bool(multiprocessing.connection.wait([proc.sentinel], timeout))
        if not finished:
            kill_group(proc.pid)
        with self.lock:
            proc.join()
            code = proc.exitcode if finished else None
            proc.close()
        return Run(command, ["mlca-verify", *argv], code, _read(out_path), _read(err_path), time.perf_counter() - start)


# --- classifying -----------------------------------------------------------------------------------------------


@dataclass
class Failure:
    kind: str
    command: str
    signature: str
    detail: str  # the last lines of the traceback or output


@dataclass
class Outcome:
    case: Case
    runs: list[Run]
    failures: list[Failure]
    seconds: float


_NUMBERS = re.compile(r"\d+")
_QUOTED = re.compile(r"'[^']*'|\"[^\"]*\"")
_FRAME = re.compile(r'File "([^"]+)", line \d+, in (\S+)')


def _last_lines(text: str, n: int = 6) -> str:
    return "\n".join(text.rstrip().splitlines()[-n:])


def traceback_signature(err: str) -> str:
    lines = [line for line in err.rstrip().splitlines() if not line.startswith("mlca-verify:")]
    exc_line = next((line for line in reversed(lines) if line and not line.startswith(" ")), "")
    exc = _NUMBERS.sub("N", _QUOTED.sub("'…'", exc_line.split(":", 1)[0] + ":" + exc_line.partition(":")[2]))[:120]
    frames = _FRAME.findall(err)
    ours = [(f, fn) for f, fn in frames if "mlca_verify" in f or "sim_check" in f]
    where = ours[-1] if ours else (frames[-1] if frames else ("?", "?"))
    module = where[0].split("src/", 1)[-1] if "src/" in where[0] else Path(where[0]).name
    return f"{exc} @ {module}:{where[1]}"


def family(kind: str) -> str:
    """A case kind without its seed spec and numbers: what kind of input it was."""
    return _NUMBERS.sub("N", kind.split(":", 1)[1] if ":" in kind else kind)[:80]


def classify(run: Run, case: Case, timeout: float) -> list[Failure]:
    found: list[Failure] = []
    err = run.err
    if run.code is None:
        sig = f"no exit within {timeout:g} s ({family(case.kind)})"
        return [Failure(HANG, run.command, sig, _last_lines(err or run.out))]
    memory = any(sign in err for sign in _MEMORY_SIGNS)
    if memory:
        sig = traceback_signature(err) if "Traceback" in err else _last_lines(err, 1)
        found.append(Failure(MEMORY, run.command, f"{sig} ({family(case.kind)})", _last_lines(err)))
    elif "Traceback" in err:
        found.append(Failure(TRACEBACK, run.command, traceback_signature(err), _last_lines(err)))
    if run.code not in (0, 1, 2):
        what = f"signal {-run.code}" if run.code < 0 else f"exit {run.code}"
        found.append(Failure(BAD_EXIT, run.command, f"{what}: {_NUMBERS.sub('N', _last_lines(err, 1))[:100]}", err))
    elif run.code == 2 and len(err.splitlines()) != 1:
        first = err.splitlines()[0] if err.splitlines() else "(empty stderr)"
        sig = f"{len(err.splitlines())} lines: {_NUMBERS.sub('N', _QUOTED.sub(chr(39) * 2, first))[:100]}"
        found.append(Failure(MULTILINE, run.command, sig, _last_lines(err)))
    return found


IMPORT_SNIPPET = (
    "import importlib.util, sys\n"
    "spec = importlib.util.spec_from_file_location('fuzzed_fsm', sys.argv[1])\n"
    "module = importlib.util.module_from_spec(spec)\n"
    "sys.modules[spec.name] = module\n"
    "spec.loader.exec_module(module)\n"
    "module.step(module.INITIAL, module.Inputs(**{f: False for f in module.Inputs.__dataclass_fields__}))\n"
)


def check_generated(out_dir: Path, timeout: float, memory: int) -> tuple[list[Run], list[Failure]]:
    """Import every generated Python file and compile every generated C file."""
    runs: list[Run] = []
    failures: list[Failure] = []
    for py in sorted(out_dir.glob("python/*.py")):
        argv = [sys.executable, "-I", "-c", IMPORT_SNIPPET, str(py)]
        run = run_exec(argv, py.parent, timeout, memory, "python-import")
        runs.append(run)
        if run.code != 0:
            tail = _last_lines(run.err, 1) if run.code is not None else "timeout"
            how = "injected code ran (exit 97)" if run.code == 97 else _NUMBERS.sub("N", tail)[:100]
            failures.append(Failure(WRONGLY_ACCEPTED, "python-import", f"python: {how}", _last_lines(run.err)))
    gcc = shutil.which("gcc")
    for c in sorted(out_dir.glob("c/*.c")) if gcc else []:
        argv = [gcc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-c", c.name, "-o", os.devnull]
        run = run_exec(argv, c.parent, timeout, memory, "gcc")
        runs.append(run)
        if run.code != 0:
            first = next((line for line in run.err.splitlines() if "error" in line), _last_lines(run.err, 1))
            sig = re.sub(r"^\S+:\d+:\d+: ", "", first)
            sig = _NUMBERS.sub("N", _QUOTED.sub("'…'", re.sub(r"‘[^’]*’", "'…'", sig)))[:100]
            failures.append(Failure(WRONGLY_ACCEPTED, "gcc", f"gcc: {sig}", _last_lines(run.err, 8)))
    return runs, failures


@dataclass
class Settings:
    seed: int
    timeout: float
    memory: int
    mode: str
    runner: ForkRunner | None = None


def run_case(case: Case, settings: Settings, work: Path) -> Outcome:
    start = time.perf_counter()
    folder = work / f"case{case.index}"
    folder.mkdir(parents=True)
    try:
        for name, data in case.files.items():
            (folder / name).write_bytes(data)
        reports = folder / "reports"
        reports.mkdir()
        check_argv = ["check", case.spec_arg, "--timeout-ms", QUERY_TIMEOUT_MS]
        check_argv += ["--json", "reports/check.json", "--junit", "reports/check.xml", "--sarif", "reports/check.sarif"]
        check_argv += list(case.check_extra)
        gen_argv = ["gen", case.spec_arg, "--out", "gen", *case.gen_extra]
        runs: list[Run] = []
        failures: list[Failure] = []
        for command, argv in (("check", check_argv), ("gen", gen_argv)):
            run = run_cli(argv, folder, settings, command)
            runs.append(run)
            found = classify(run, case, settings.timeout)
            if run.code == INTERNAL_ERROR:
                explain_internal_error(found, argv, folder, settings, command)
            failures += found
            if command == "gen" and run.code == 0 and "--check" not in argv:
                more_runs, more_failures = check_generated(folder / "gen", settings.timeout, settings.memory)
                runs += more_runs
                failures += more_failures
        return Outcome(case, runs, failures, time.perf_counter() - start)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def explain_internal_error(
    found: list[Failure], argv: list[str], folder: Path, settings: Settings, command: str
) -> None:
    """Run a command that ended in an internal error again with `--debug`, for the traceback it hides."""
    again = run_cli([*argv, DEBUG_FLAG], folder, settings, command)
    if "Traceback" not in again.err:
        return
    for f in found:
        if f.kind == BAD_EXIT:
            f.signature = f"exit {INTERNAL_ERROR}: {traceback_signature(again.err)}"
            f.detail = _last_lines(again.err, 8)


def run_cli(argv: list[str], cwd: Path, settings: Settings, command: str) -> Run:
    if settings.runner is not None:
        return settings.runner.run(argv, cwd, settings.timeout, settings.memory, command)
    full = [sys.executable, "-m", "mlca_verify", *argv]
    run = run_exec(full, cwd, settings.timeout, settings.memory, command)
    run.argv = ["mlca-verify", *argv]
    return run


# --- reporting -------------------------------------------------------------------------------------------------


@dataclass
class Tally:
    cases: int = 0
    failing_cases: int = 0
    by_kind: dict[str, Counter[str]] = field(default_factory=lambda: {k: Counter() for k in KINDS})
    cases_by_kind: Counter[str] = field(default_factory=Counter)
    exit_codes: dict[str, Counter[str]] = field(default_factory=lambda: {"check": Counter(), "gen": Counter()})
    # (kind, signature) -> [count, smallest case, its failure]
    signatures: dict[tuple[str, str], list[Any]] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, outcome: Outcome) -> None:
        with self.lock:
            self.cases += 1
            for run in outcome.runs:
                if run.command in self.exit_codes:
                    self.exit_codes[run.command]["timeout" if run.code is None else str(run.code)] += 1
            kinds = set()
            for f in outcome.failures:
                self.by_kind[f.kind][f.command if f.command in ("check", "gen") else "gen"] += 1
                kinds.add(f.kind)
                key = (f.kind, f.signature)
                entry = self.signatures.setdefault(key, [0, outcome.case, f])
                entry[0] += 1
                if outcome.case.size < entry[1].size:
                    entry[1], entry[2] = outcome.case, f
            for kind in kinds:
                self.cases_by_kind[kind] += 1
            self.failing_cases += bool(kinds)


def summary(tally: Tally, settings: Settings, wall: float) -> str:
    lines = [
        f"fuzz: {tally.cases} cases, seed {settings.seed}, mode {settings.mode}, {wall:.0f} s "
        f"(limits: {settings.timeout:g} s, {settings.memory >> 20} MB per process)",
        "",
        f"  {'failure':<30} {'check':>7} {'gen':>7} {'cases':>7}",
        f"  {'-' * 30} {'-' * 7} {'-' * 7} {'-' * 7}",
    ]
    for kind in KINDS:
        c = tally.by_kind[kind]
        lines.append(f"  {kind:<30} {c['check']:>7} {c['gen']:>7} {tally.cases_by_kind[kind]:>7}")
    lines.append(f"  {'cases with any failure':<30} {'':>7} {'':>7} {tally.failing_cases:>7}")
    for command, codes in tally.exit_codes.items():
        shown = ", ".join(f"{code}: {n}" for code, n in sorted(codes.items()))
        lines.append(f"  exit codes of {command}: {shown}")
    if tally.signatures:
        lines += ["", "distinct failures (count, smallest case):"]
        for (kind, sig), (count, case, _) in sorted(tally.signatures.items(), key=lambda kv: (kv[0][0], -kv[1][0])):
            lines.append(f"  [{kind}] x{count}  case {case.index} ({case.size} bytes, {case.kind[:60]})")
            lines.append(f"      {sig}")
    return "\n".join(lines)


def save_failure(save: Path, outcome: Outcome, settings: Settings) -> None:
    for kind in dict.fromkeys(f.kind for f in outcome.failures):
        folder = save / SLUG[kind] / f"{outcome.case.index:06d}"
        folder.mkdir(parents=True, exist_ok=True)
        case = outcome.case
        for name, data in case.files.items():
            if case.big:
                (folder / f"{name}.txt").write_text(
                    f"{len(data)} bytes, not saved; regenerate: python bench/fuzz.py --seed {settings.seed} "
                    f"--case {case.index} --keep DIR\n"
                )
            else:
                (folder / name).write_bytes(data)
        notes = [f"case {case.index} of seed {settings.seed}: {case.kind}", ""]
        for f in outcome.failures:
            if f.kind == kind:
                notes += [f"[{f.command}] {f.signature}", f.detail, ""]
        for run in outcome.runs:
            code = "timeout" if run.code is None else run.code
            notes += [f"$ {' '.join(run.argv)[:400]}", f"exit {code} after {run.seconds:.1f} s", run.err[-4000:], ""]
        (folder / "README.txt").write_text("\n".join(notes), encoding="utf-8", errors="backslashreplace")


def describe(outcome: Outcome) -> str:
    case = outcome.case
    lines = [f"case {case.index}: {case.kind} ({case.size} bytes, spec argument {case.spec_arg!r})"]
    for run in outcome.runs:
        code = "timeout" if run.code is None else run.code
        lines.append(f"$ {' '.join(run.argv)[:300]}\n  exit {code} after {run.seconds:.2f} s")
        if run.err.strip():
            lines.append("  stderr: " + _last_lines(run.err, 12).replace("\n", "\n          "))
    for f in outcome.failures:
        lines.append(f"FAIL [{f.kind}] {f.command}: {f.signature}")
    if not outcome.failures:
        lines.append("no failure")
    return "\n".join(lines)


# --- main ------------------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=200, help="number of cases (default 200)")
    parser.add_argument("--seed", type=int, default=1, help="seed: the same seed gives the same cases")
    parser.add_argument("--workers", type=int, default=1, help="cases run at once (at most 2 processes each run)")
    parser.add_argument("--save", type=Path, help="write failing inputs here, one folder per failure kind and case")
    parser.add_argument("--mode", choices=["exec", "fork"], default="exec", help="start every command fresh, or fork")
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, help="seconds per command (default 10)")
    parser.add_argument("--memory-mb", type=int, default=DEFAULT_MEMORY_MB, help="address space per command")
    parser.add_argument("--case", type=int, help="run only case I of the seed and print everything about it")
    parser.add_argument("--keep", type=Path, help="with --case: also write the case's files here")
    parser.add_argument("--start", type=int, default=0, help="first case index (default 0)")
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers must be at least 1")

    settings = Settings(args.seed, args.timeout, args.memory_mb << 20, args.mode)
    if args.mode == "fork":
        settings.runner = ForkRunner()
    bases = load_bases()
    with tempfile.TemporaryDirectory(prefix="mlca-fuzz-") as tmp:
        work = Path(tmp)
        if args.case is not None:
            case = make_case(args.seed, args.case, bases)
            if args.keep:
                args.keep.mkdir(parents=True, exist_ok=True)
                for name, data in case.files.items():
                    (args.keep / name).write_bytes(data)
            outcome = run_case(case, settings, work)
            print(describe(outcome))
            return 1 if outcome.failures else 0
        return fuzz(args, settings, bases, work)


def fuzz(args: argparse.Namespace, settings: Settings, bases: list[Base], work: Path) -> int:
    tally = Tally()
    start = time.perf_counter()
    indices = range(args.start, args.start + args.cases)
    step = max(1, args.cases // 100)

    def one(index: int) -> None:
        case = make_case(args.seed, index, bases)
        try:
            outcome = run_case(case, settings, work)
        except Exception as err:  # a problem of the fuzzer itself: say which case, go on
            print(f"fuzz: case {index} ({case.kind}) could not run: {err!r}", file=sys.stderr)
            return
        tally.add(outcome)
        if outcome.failures and args.save:
            save_failure(args.save, outcome, settings)
        done = tally.cases
        if done % step == 0 or done == args.cases:
            rate = done / (time.perf_counter() - start)
            counts = ", ".join(f"{SLUG[k]} {tally.cases_by_kind[k]}" for k in KINDS if tally.cases_by_kind[k])
            print(f"[{done}/{args.cases}] {rate:.1f} cases/s; {counts or 'no failures'}", file=sys.stderr, flush=True)

    with ThreadPoolExecutor(max_workers=args.workers) as pool:
        for _ in pool.map(one, indices):
            pass
    text = summary(tally, settings, time.perf_counter() - start)
    print(text)
    if args.save:
        args.save.mkdir(parents=True, exist_ok=True)
        details = [text, "", "smallest input of each distinct failure:", ""]
        for (kind, sig), (count, case, failure) in sorted(tally.signatures.items()):
            details += [f"## [{kind}] {sig} (x{count})", f"case {case.index}: {case.kind}", failure.detail, ""]
        (args.save / "summary.txt").write_text("\n".join(details), encoding="utf-8", errors="backslashreplace")
    return 1 if tally.signatures else 0


if __name__ == "__main__":
    sys.exit(main())
