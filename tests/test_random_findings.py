"""What random machines with data found on the code side, one regression test each: a machine that can reach a
step with no transition enabled refused by `gen` at its line; a mode no run reaches, with no transition, compared
as the code keeps it; a monitor whose invariants read no variable built with -Werror; a guard that repeats an
earlier one of its mode left out of the code (cppcheck: multiCondition); and gaps the suite leaves in a
transition's update, the shared abs helper, a mode's `otherwise` and a mode no run is in, each with its reason."""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.codegen import generate, write
from mlca_verify.conform import conform
from mlca_verify.conform.checks import CheckOutcome
from mlca_verify.model import Arith, Cmp, Num, Var
from mlca_verify.spec import load_spec
from mlca_verify.testgen.explain import element_of, mode_of
from mlca_verify.testgen.objectives import decisions

HEAD = """
[machine]
name = "R"
initial = "A"
states = ["A", "B", "C"]
otherwise = "{otherwise}"

[inputs]
go = {{ doc = "go" }}

[signals]
x = {{ type = "int", unit = "1", range = [0, 3], doc = "a sample" }}

[variables]
c = {{ type = "int", initial = 0, range = [0, 2], doc = "a counter" }}
"""


def _spec(tmp_path: Path, body: str, otherwise: str = "stay") -> Path:
    path = tmp_path / "r.toml"
    path.write_text(HEAD.format(otherwise=otherwise) + body, encoding="utf-8")
    return path


def _quiet(_: CheckOutcome) -> None:
    pass


def _conform(path: Path, checks: list[str]) -> dict[str, CheckOutcome]:
    spec = load_spec(path)
    out = path.parent / "gen"
    write(generate(spec, out), out)
    result = conform(spec, out, checks, _quiet, sequences=20)
    return {o.name: o for o in result.outcomes}


def test_a_reachable_step_with_no_transition_is_refused_by_gen(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _spec(tmp_path, '[[transition]]\nfrom = "A"\nto = "B"\nwhen = "go"\n', otherwise="undefined")
    assert main(["gen", "--out", str(tmp_path / "gen"), str(path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"{path}:") and "may reach a step with no transition enabled" in line


@pytest.mark.slow
def test_a_mode_no_run_reaches_is_compared_as_the_code_keeps_it(tmp_path: Path) -> None:
    """C has no transition and no run reaches it: completeness holds, generation goes ahead, and the boundary
    rows from C (where the spec's step is undefined) compare with the code keeping the mode. A monitor whose
    invariant reads no variable once left its context alias unused (gcc -Werror)."""
    body = """
[[transition]]
from = ["A", "B"]
to = "B"
when = "true"
do = "c = min(c + 1, 2)"

[[invariant]]
id = "never-c"
expr = "state != C"
"""
    outcomes = _conform(_spec(tmp_path, body, otherwise="undefined"), ["compile", "exhaustive", "sequences"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items()}


@pytest.mark.slow
def test_a_guard_that_repeats_an_earlier_one_is_left_out_of_the_code(tmp_path: Path) -> None:
    body = """
[[transition]]
id = "first"
from = "A"
to = "B"
when = "go"

[[transition]]
id = "again"
from = "*"
to = "C"
when = "go"
"""
    path = _spec(tmp_path, body)
    outcomes = _conform(path, ["compile", "exhaustive", "cppcheck"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items()}
    source = (tmp_path / "gen" / "c" / "r_fsm.c").read_text(encoding="utf-8")
    assert "/* again: never taken in A: its guard repeats first's */" in source
    python = (tmp_path / "gen" / "python" / "r_fsm.py").read_text(encoding="utf-8")
    assert "# again: never taken in A: its guard repeats first's" in python
    assert python.count("fired = 2") == 2  # in B and C, not in A


def test_an_update_choice_is_a_decision_read_where_its_transition_fires(tmp_path: Path) -> None:
    body = '[[transition]]\nid = "t"\nfrom = "B"\nto = "A"\nwhen = "go"\ndo = "c = abs(c - 2)"\n'
    machine = load_spec(_spec(tmp_path, body)).machine
    (choice,) = [d for d in decisions(machine) if d.id.startswith("choice:")]
    assert (
        choice.id == "choice:t#1"
        and choice.where == "pre"
        and choice.expr == Cmp(">=", Arith("-", Var("c"), Num(Fraction(2), False)), Num(Fraction(0), False))
    )


def test_gaps_are_traced_to_the_transition_whose_branch_holds_them() -> None:
    c_lines = ["        if (fired == 3) { /* c = abs(c - d) */", "            next.c = (int32_t)(r_abs_i(c->c));"]
    assert element_of(c_lines, 2, set(), ["t1", "t2", "t3"]) == "t3"
    assert element_of(["    } else if (fired == 2) { /* t2 */"], 1, {"t2"}) == "t2"
    python = ["def _fired(c, i, p):", "    if c.mode == State.GO:", "        if i.a:  # t: a", "            fired = 1"]
    assert mode_of(python, 4, ("GO",)) == "GO" and mode_of(python, 4, ("STOP",)) is None
    assert mode_of(["static int r_fired_GO(const r_ctx_t *c)", "{", "    int fired = 0;"], 3, ("GO",)) == "GO"


@pytest.mark.slow
def test_the_suite_gives_a_reason_for_gaps_of_dead_transitions_and_their_updates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`late` never fires (`soon` takes every step it could), so its branch of the step, its update's `abs` and
    the shared abs helper are never run, and A's chain never ends in `otherwise` (`not go` closes it only as z3
    sees it): every such gap gets its reason."""
    body = """
[[transition]]
id = "soon"
from = "A"
to = "B"
when = "go"
do = "c = 1"

[[transition]]
id = "late"
from = "A"
to = "C"
when = "go and c > 0"
do = "c = abs(c - 2)"

[[transition]]
id = "idle"
from = "A"
to = "A"
when = "not go or c > 5"

[[transition]]
id = "back"
from = ["B", "C"]
to = "A"
when = "go"
do = "c = 0"
"""
    path = _spec(tmp_path, body)
    generated, out = tmp_path / "gen", tmp_path / "tests"
    assert main(["gen", "--out", str(generated), str(path)]) == 0
    assert main(["tests", "--no-target", "--generated", str(generated), "--out", str(out), str(path)]) == 0
    assert "every check passed" in capsys.readouterr().out
    coverage = json.loads((out / "r" / "coverage.json").read_text(encoding="utf-8"))["coverage"]
    reasons = [g["reason"] for c in coverage for g in c["gaps"]]
    assert reasons and all(reasons)
    assert any("shared abs helper" in r for r in reasons)
