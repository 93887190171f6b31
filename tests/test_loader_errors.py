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
        "toy.toml:26:10: error: 'within' must be a positive number of steps, got 0",
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
