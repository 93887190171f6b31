"""One test per class of bad spec: the exact one-line message, at the right file, line and column."""

from __future__ import annotations

from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.errors import SpecError
from mlca_verify.spec import load_spec, load_text

GOOD = """\
[machine]
name = "Toy"
initial = "A"
states = ["A", "B"]
cite = "toy"

[inputs]
x = { doc = "x", cite = "c" }
y = { doc = "y", cite = "c" }

[[transition]]
from = "A"
to = "B"
when = "x and not y"
cite = "c1"

[[invariant]]
id = "inv"
expr = "state == B -> x"
cite = "c2"

[[liveness]]
id = "live"
assume = "x"
goal = "state == B"
cite = "c3"
"""


def error_of(text: str) -> str:
    with pytest.raises(SpecError) as info:
        load_text(text, "toy.toml")
    message = str(info.value)
    assert "\n" not in message
    return message


def test_good_spec_loads() -> None:
    machine = load_text(GOOD, "toy.toml")
    assert machine.states == ("A", "B")
    assert [t.id for t in machine.transitions] == ["t1"]


CASES = [
    ("invalid TOML", ('when = "x and not y"', 'when = "x and not y'), "toy.toml:14:"),
    (
        "unknown top-level key",
        ("[[transition]]", "[[transitions]]"),
        "toy.toml:11:3: error: unknown top-level key 'transitions' (did you mean 'transition'?)",
    ),
    (
        "unknown key",
        ("when =", "wen ="),
        "toy.toml:14:7: error: unknown key 'wen' in [[transition]] #1 (did you mean 'when'?)",
    ),
    ("missing key", ('to = "B"\n', ""), "toy.toml:11:3: error: missing key 'to' in [[transition]] #1"),
    (
        "wrong type",
        ('states = ["A", "B"]', "states = 3"),
        "toy.toml:4:10: error: 'states' in [machine] must be an array of strings, got integer",
    ),
    ("unknown target", ('to = "B"', 'to = "C"'), "toy.toml:13:6: error: unknown target state 'C' (states: A, B)"),
    (
        "unknown source",
        ('from = "A"', 'from = ["A", "Q"]'),
        "toy.toml:12:8: error: unknown source state 'Q' (states: A, B)",
    ),
    (
        "unknown input in guard",
        ("x and not y", "x and not z"),
        "toy.toml:14:19: error: unknown input 'z' in guard (inputs: x, y)",
    ),
    (
        "state in guard",
        ("x and not y", "x and state == A"),
        "toy.toml:14:15: error: guard may not refer to the state (guards are over inputs only): 'x and state == A'",
    ),
    (
        "unknown state in invariant",
        ("state == B -> x", "state == Z -> x"),
        "toy.toml:19:18: error: unknown state 'Z' in invariant (states: A, B)",
    ),
    (
        "syntax error in guard",
        ("x and not y", "x and and y"),
        "toy.toml:14:15: error: bad guard 'x and and y': expected an input name, 'state', 'true', 'false', 'not' or '(', found 'and'",
    ),
    (
        "unbalanced parenthesis",
        ("x and not y", "(x and y"),
        "toy.toml:14:17: error: bad guard '(x and y': expected ')', found end of expression",
    ),
    ("bad character", ("x and not y", "x && y"), "toy.toml:14:11: error: bad guard 'x && y': unexpected character '&'"),
    ("duplicate state", ('["A", "B"]', '["A", "B", "A"]'), "toy.toml:4:21: error: duplicate state 'A'"),
    (
        "case-folded duplicate",
        ('["A", "B"]', '["A", "B", "b"]'),
        "toy.toml:4:21: error: state 'b' clashes with 'B' (names must differ in more than case)",
    ),
    ("duplicate property", ('id = "live"', 'id = "inv"'), "toy.toml:22:3: error: duplicate property id 'inv'"),
    (
        "not an identifier",
        ('["A", "B"]', '["A", "B-2"]'),
        "toy.toml:4:16: error: state name 'B-2' is not an identifier (a letter, then letters, digits or '_')",
    ),
    ("python keyword", ("y = {", "lambda = {"), "toy.toml:9:1: error: input name 'lambda' is a Python keyword"),
    (
        "C keyword",
        ('["A", "B"]', '["A", "volatile"]'),
        "toy.toml:4:16: error: state name 'volatile' is a C keyword or reserved name",
    ),
    (
        "expression word",
        ("y = {", "state = {"),
        "toy.toml:9:1: error: input name 'state' is a word of the expression language",
    ),
    (
        "initial not a state",
        ('initial = "A"', 'initial = "Start"'),
        "toy.toml:3:11: error: initial state 'Start' is not a state (A, B)",
    ),
    (
        "bad semantics",
        ('cite = "toy"', 'cite = "toy"\nsemantics = "random"'),
        "toy.toml:6:13: error: 'semantics' must be one of first-match, any-enabled, got 'random'",
    ),
    (
        "bad expect",
        ('cite = "c2"', 'cite = "c2"\nexpect = "maybe"'),
        "toy.toml:21:10: error: 'expect' must be one of holds, violated, got 'maybe'",
    ),
    (
        "unknown built-in in [expect]",
        ("[[transition]]", '[expect]\n"fires:t9" = "violated"\n\n[[transition]]'),
        "toy.toml:12:14: error: unknown built-in check 'fires:t9' in [expect] (one of determinism, completeness, reach:<state>, fires:<transition id>)",
    ),
    (
        "non-positive within",
        ('goal = "state == B"', 'goal = "state == B"\nwithin = 0'),
        "toy.toml:26:10: error: 'within' must be a number of steps from 1 to 100000, got 0",
    ),
    (
        "within past its limit",
        ('goal = "state == B"', 'goal = "state == B"\nwithin = 1000000000'),
        "toy.toml:26:10: error: 'within' must be a number of steps from 1 to 100000, got 1000000000",
    ),
    (
        "trailing newline in a state name",
        ('["A", "B"]', '["A", "B\\n"]'),
        "toy.toml:4:10: error: state name 'B\\n' is not an identifier",
    ),
    (
        "trailing newline in a property id",
        ('id = "inv"', 'id = "inv\\n"'),
        "toy.toml:18:6: error: invariant id 'inv\\n' must start with a letter",
    ),
    (
        "state named like the generated INITIAL",
        ('["A", "B"]', '["A", "INITIAL"]'),
        "toy.toml:4:16: error: state name 'INITIAL' clashes with the generated C name <MACHINE>_INITIAL",
    ),
    (
        "state named like the header guard",
        ('["A", "B"]', '["A", "FSM_H"]'),
        "toy.toml:4:16: error: state name 'FSM_H' clashes with the generated C name <MACHINE>_FSM_H",
    ),
    (
        "input named like a Python class attribute",
        ("y = {", "mro = {"),
        "toy.toml:9:1: error: input name 'mro' clashes with an attribute of the generated Inputs class",
    ),
    (
        "state named like an IntEnum attribute",
        ('["A", "B"]', '["A", "value"]'),
        "toy.toml:4:16: error: state name 'value' clashes with an attribute of the generated State enum",
    ),
    (
        "input named like a stdio macro",
        ("y = {", "EOF = {"),
        "toy.toml:9:1: error: input name 'EOF' is a macro of the C standard headers",
    ),
    (
        "input named like an emitted test's macro",
        ("y = {", "STEP_COUNT = {"),
        "toy.toml:9:1: error: input name 'STEP_COUNT' clashes with a macro the emitted C tests define",
    ),
    (
        "double underscore",
        ('["A", "B"]', '["A", "B__1_t"]'),
        "toy.toml:4:16: error: state name 'B__1_t' contains '__'",
    ),
    (
        "machine name too long",
        ('name = "Toy"', f'name = "{"M" * 300}"'),
        "toy.toml:2:8: error: machine name 'MMMMMMMMMMMMMMMMMMMM...' is 300 characters long (at most 32)",
    ),
    (
        "property id that reads as a result prefix",
        ('id = "inv"', 'id = "equiv"'),
        "toy.toml:18:6: error: invariant id 'equiv' is the name of a built-in check",
    ),
    (
        "deep parentheses",
        ("x and not y", "(" * 170 + "x" + ")" * 170),
        "toy.toml:14:109: error: bad guard '(((((((((((((((((((((((((((((((((((((((((((((((((((((((((((('...: expression nested more than 100 deep",
    ),
    (
        "long chain of or",
        ("x and not y", " or ".join(["x"] * 1000)),
        "toy.toml:14:9: error: bad guard 'x or x or x or x or x or x or x or x or x or x or x or x or '...: expression nested more than 100 deep (split a long chain with parentheses)",
    ),
    (
        "long chain of not",
        ("x and not y", "not " * 1000 + "x"),
        "toy.toml:14:409: error: bad guard 'not not not not not not not not not not not not not not not '...: expression nested more than 100 deep",
    ),
    (
        "long chain of implications",
        ("x and not y", " -> ".join(["x"] * 1000)),
        "toy.toml:14:511: error: bad guard 'x -> x -> x -> x -> x -> x -> x -> x -> x -> x -> x -> x -> '...: expression nested more than 100 deep",
    ),
    (
        "deeply nested TOML arrays",
        ('cite = "toy"', 'cite = "toy"\nx = ' + "[" * 1000 + "]" * 1000),
        "toy.toml:1:1: error: invalid TOML: arrays or tables nested too deeply",
    ),
    (
        "state in assumption",
        ('assume = "x"', 'assume = "state == A"'),
        "toy.toml:24:11: error: assumption may not refer to the state (assumptions are over inputs only): 'state == A'",
    ),
    ("no states", ('["A", "B"]', "[]"), "toy.toml:4:10: error: a machine needs at least one state"),
    (
        "missing machine",
        ("[machine]", "[machin]"),
        "toy.toml:1:2: error: unknown top-level key 'machin' (did you mean 'machine'?)",
    ),
    (
        "builtin name as id",
        ('id = "inv"', 'id = "determinism"'),
        "toy.toml:18:6: error: invariant id 'determinism' is the name of a built-in check",
    ),
]


@pytest.mark.parametrize(("label", "edit", "expected"), CASES, ids=[c[0] for c in CASES])
def test_bad_spec_message(label: str, edit: tuple[str, str], expected: str) -> None:
    old, new = edit
    assert old in GOOD, label
    message = error_of(GOOD.replace(old, new, 1))
    assert message.startswith(expected), message


def test_property_ids_that_are_one_c_name_clash() -> None:
    text = GOOD.replace('id = "inv"', 'id = "a.b"').replace('id = "live"', 'id = "a-b"')
    assert error_of(text) == (
        "toy.toml:22:3: error: property id 'a-b' clashes with 'a.b' (names must differ in more than case, '-' and '.')"
    )


def test_missing_compared_spec(tmp_path: Path) -> None:
    spec = tmp_path / "toy.toml"
    spec.write_text(GOOD + '\n[[compare]]\nwith = "nowhere.toml"\ncite = "c"\n')
    with pytest.raises(SpecError, match=r"toy.toml:29:8: error: compared spec 'nowhere.toml' not found"):
        load_spec(spec)


def test_not_utf8(tmp_path: Path) -> None:
    spec = tmp_path / "bad.toml"
    spec.write_bytes(GOOD.encode().replace(b'cite = "c1"', b'cite = "c\xff"'))
    with pytest.raises(SpecError, match=r"bad.toml:15:10: error: spec is not UTF-8 text \(byte 0xff\)"):
        load_spec(spec)


@pytest.mark.parametrize("label", ["unknown input in guard", "invalid TOML", "C keyword"])
def test_cli_exits_2_with_one_line_and_no_traceback(
    label: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _, (old, new), expected = next(c for c in CASES if c[0] == label)
    spec = tmp_path / "toy.toml"
    spec.write_text(GOOD.replace(old, new, 1))
    assert main(["check", str(spec)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(str(tmp_path / expected.split(":", 1)[0]) + ":")
    assert "Traceback" not in captured.err


def test_cli_missing_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", "no/such/spec.toml"]) == 2
    assert capsys.readouterr().err.strip() == "no/such/spec.toml: error: cannot read spec: No such file or directory"


def test_cli_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["chek"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("mlca-verify: error: argument command: invalid choice: 'chek'")


def test_a_name_of_the_contract_language_is_refused() -> None:
    assert error_of(GOOD.replace("y = {", "boolean = {")) == (
        "toy.toml:9:1: error: input name 'boolean' is a word of ACSL, the generated C's contract language"
    )


def test_the_python_attribute_names_cover_this_python() -> None:
    from enum import IntEnum

    from mlca_verify.spec.names import PYTHON_ATTRIBUTES

    here = {n for source in (int, type, IntEnum) for n in dir(source) if not n.startswith("_")}
    assert here <= PYTHON_ATTRIBUTES
