"""What random machines without data found on the code side (`bench/bench_random.py --kind bool`), one regression
test each: an invariant the spec claims but the engine shows violated was stated as a contract of the step (WP
failed on it, and conform's runs blamed the code for breaking it); a guard that never holds where its chain
reaches it, or one that always does, was written as `if (true)` and `else if (true)` (cppcheck: multiCondition,
knownConditionTrueFalse), as were `a and a`, and a last branch that goes where its chain ends anyway
(duplicateExpression, duplicateBranch); a step that then tests no input failed -Werror; and `tests` left without
a reason the lines of a state no run is in, of a state only a run's start is in, and of an invariant that only an
out-of-range state breaks."""

from __future__ import annotations

from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.codegen import generate, write
from mlca_verify.conformance import conform
from mlca_verify.conformance.outcome import CheckOutcome
from mlca_verify.spec import load_spec

CHECKS = ["compile", "exhaustive", "sequences", "frama-c-wp", "cppcheck"]


def _spec(tmp_path: Path, text: str) -> Path:
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / "b.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _quiet(_: CheckOutcome) -> None:
    pass


def _generated(path: Path) -> tuple[str, str, dict[str, CheckOutcome]]:
    """The generated C and Python of the spec at `path`, and conform's outcomes on them."""
    spec = load_spec(path)
    out = path.parent / "gen"
    write(generate(spec, out), out)
    outcomes = {o.name: o for o in conform(spec, out, CHECKS, _quiet, sequences=50).outcomes}
    return (out / "c" / "b_fsm.c").read_text(), (out / "python" / "b_fsm.py").read_text(), outcomes


TOGGLE = """
[machine]
name = "B"
initial = "S0"
states = ["S0", "S1"]

[inputs]
a = { doc = "a" }

[[transition]]
id = "up"
from = "S0"
to = "S1"
when = "a"

[[transition]]
id = "down"
from = "S1"
to = "S0"
when = "not a"

[[invariant]]
id = "follows"
expr = "a -> state == S1"

[[invariant]]
id = "stays-low"
expr = "state == S0"
"""


@pytest.mark.slow
def test_an_invariant_the_engine_shows_violated_is_no_contract_of_the_step(tmp_path: Path) -> None:
    c, py, outcomes = _generated(_spec(tmp_path, TOGGLE))
    assert "stays-low" in c and "stays-low" in py  # monitored in both languages
    assert outcomes["frama-c-wp"].data["certified"]["stated"] == ["follows"]  # the one proved: a contract
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items() if not o.ok}
    assert main(["check", str(tmp_path / "b.toml"), "--quiet"]) == 1  # the claim is the spec's fault, told by check


CONSTANT = """
[machine]
name = "B"
initial = "S0"
states = ["S0", "S1", "S2"]

[inputs]
a = { doc = "a" }
b = { doc = "b" }

[[transition]]
id = "never"
from = "S0"
to = "S2"
when = "false and a"

[[transition]]
id = "on-a"
from = "S0"
to = "S1"
when = "not not a"

[[transition]]
id = "always"
from = ["S0", "S1"]
to = "S2"
when = "true <-> true"

[[transition]]
id = "after-always"
from = ["S0", "S1"]
to = "S0"
when = "b"

[[transition]]
id = "back"
from = "S2"
to = "S0"
when = "b"
"""


@pytest.mark.slow
def test_a_guard_that_always_holds_ends_the_chain_and_one_that_never_does_is_left_out(tmp_path: Path) -> None:
    c, py, outcomes = _generated(_spec(tmp_path, CONSTANT))
    assert "(true)" not in c and "(false" not in c
    # S0: the guard that never holds is left out; `always` is the chain's else, with no otherwise after it
    s0 = _function(c, "b_to_S0")
    assert "if (i->a) { /* on-a: not not a */" in s0
    assert "} else { /* always: true <-> true: enabled whenever the ones before it are not */" in s0
    assert "/* never: never taken in S0: its guard is false as written */" in s0 and s0.count("if (") == 1
    assert "after-always" not in s0 and "otherwise" not in s0
    # S1: `always` is its first branch, so the mode's code is that one assignment
    s1 = _function(c, "b_to_S1")
    assert "next = B_S2; /* always: true <-> true: always enabled */" in s1 and "if (" not in s1
    assert "fired = 3  # always: true <-> true: always enabled" in py
    assert "behavior S0__1_never:" in c  # the contracts still state every transition
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items() if not o.ok}


UNREACHED = """
[machine]
name = "B"
initial = "S1"
states = ["S0", "S1", "S2"]

[inputs]
a = { doc = "a" }

[[transition]]
id = "stay"
from = "*"
to = "S1"
when = "true or a"

[[transition]]
id = "leave"
from = ["S0", "S2"]
to = "S0"
when = "a"

[[invariant]]
id = "settled"
expr = "state == S1"
"""

INITIAL_ONLY = """
[machine]
name = "B"
initial = "S2"
states = ["S0", "S1", "S2"]

[inputs]
a = { doc = "a" }

[[transition]]
id = "settle"
from = "*"
to = "S0"
when = "not (true and false)"

[[invariant]]
id = "settled"
expr = "state == S0 or a"
"""

ONE_STATE = """
[machine]
name = "B"
initial = "S0"
states = ["S0"]

[inputs]
a = { doc = "a" }

[[invariant]]
id = "only"
expr = "not not state == S0"
"""


@pytest.mark.slow
@pytest.mark.parametrize(
    "text", [UNREACHED, INITIAL_ONLY, ONE_STATE], ids=["unreached-states", "initial-only", "one-state"]
)
def test_the_suite_gives_every_gap_of_a_machine_without_data_its_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    """The lines of states no run is in (their checks in `state_valid` and the monitor included), a state only
    the run's start is in (the suite calls the monitor on it), and an invariant that holds of every state (only
    an out-of-range state, which the monitor names alone, breaks it)."""
    path = _spec(tmp_path, text)
    generated = tmp_path / "gen"
    assert main(["gen", "--out", str(generated), str(path)]) == 0
    assert main(["tests", str(path), "--generated", str(generated), "--out", str(tmp_path / "tests")]) == 0
    said = capsys.readouterr().out
    assert "without a reason" not in said.replace(", 0 without a reason", ""), said


SAME_END = """
[machine]
name = "B"
initial = "S0"
states = ["S0", "S1"]

[inputs]
a = { doc = "a" }
b = { doc = "b" }

[[transition]]
id = "go"
from = "S0"
to = "S1"
when = "a and a"

[[transition]]
id = "hold"
from = "S0"
to = "S0"
when = "not (b or b)"

[[transition]]
id = "back-on-a"
from = "S1"
to = "S0"
when = "a"

[[transition]]
id = "back"
from = "S1"
to = "S0"
when = "true"
"""

NO_INPUT_READ = """
[machine]
name = "B"
initial = "S0"
states = ["S0", "S1"]

[inputs]
a = { doc = "a" }

[[transition]]
id = "go"
from = "S0"
to = "S1"
when = "a or true"

[[transition]]
id = "stay-on-a"
from = "S1"
to = "S1"
when = "a"
"""


@pytest.mark.slow
def test_a_branch_that_goes_where_the_chain_ends_is_left_out_and_a_or_a_is_a(tmp_path: Path) -> None:
    """`a and a` was written `in.a && in.a` (cppcheck: duplicateExpression); a last branch that goes where its
    chain ends anyway, by the `otherwise` or by a branch that always fires, was written too (duplicateBranch); and
    a step whose code then tests no input must still build under -Werror."""
    c, _, outcomes = _generated(_spec(tmp_path / "same", SAME_END))
    s0, s1 = _function(c, "b_to_S0"), _function(c, "b_to_S1")
    assert "i->a && i->a" not in c and "i->b || i->b" not in c
    assert "/* hold:" not in s0 and "/* back-on-a:" not in s1  # each goes where its chain ends
    assert "if (i->a) { /* go: a and a */" in s0 and "} else { /* otherwise: the mode is kept */" in s0
    assert "next = B_S0; /* back: true: always enabled */" in s1
    assert "behavior S0__2_hold:" in c and "behavior S1__1_back_on_a:" in c  # the contracts keep them
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items() if not o.ok}
    c, _, outcomes = _generated(_spec(tmp_path / "none", NO_INPUT_READ))
    assert "stay-on-a" not in _function(c, "b_to_S1")
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items() if not o.ok}


def _function(c: str, name: str) -> str:
    """The C function `name`, from its header to its closing brace."""
    start = c.index(f" {name}(")
    return c[start : c.index("\n}\n", start)]
