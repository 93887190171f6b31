"""What random machines with data found on the code side, one regression test each: a machine that can reach a
step with no transition enabled refused by `gen` at its line; a mode no run reaches, with no transition, compared
as the code keeps it; a monitor whose invariants read no variable, or no register, built with -Werror; guards
that repeat, decide or imply what earlier ones of their mode tested, and conditions their own text decides, left
out of the code (cppcheck); a range only the runs keep, required by every function the step calls and admitted
after it (WP); an input read only at a param's range end, probed outside 0/1 (sanitizers); and gaps the suite
leaves, each with its reason."""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.codegen import generate, machine_ir, write
from mlca_verify.conformance import conform
from mlca_verify.conformance.outcome import CheckOutcome
from mlca_verify.model import Arith, Call, Cmp, Const, Num, Var, show
from mlca_verify.spec import load_spec
from mlca_verify.testgen.explain import element_of, mode_of, others_than_chain, saturation
from mlca_verify.testgen.objectives import atoms, decisions
from tests.c_text import c_function

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


def _gap_reasons(tmp_path: Path, body: str, capsys: pytest.CaptureFixture[str]) -> list[str]:
    """The reason of every gap `tests` leaves in the machine's code, which must pass every check."""
    path = _spec(tmp_path, body)
    generated, out = tmp_path / "gen", tmp_path / "tests"
    assert main(["gen", "--out", str(generated), str(path)]) == 0
    assert main(["tests", "--no-target", "--generated", str(generated), "--out", str(out), str(path)]) == 0
    assert "every check passed" in capsys.readouterr().out
    coverage = json.loads((out / "r" / "coverage.json").read_text(encoding="utf-8"))["coverage"]
    return [g["reason"] for c in coverage for g in c["gaps"]]


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


def test_a_monitor_whose_invariant_decides_its_own_prev_is_built_with_werror(tmp_path: Path) -> None:
    """`prev(c) > prev(c)` is false as written, so the invariant's code reads no register; the monitor still keeps
    the register for the contract, and once left it unused (gcc -Werror, cppcheck: unreadVariable)."""
    body = """
[[transition]]
from = ["A", "B"]
to = "B"
when = "valid(x)"
do = "c = min(c + 1, 2)"

[[invariant]]
id = "decided"
expr = "(prev(c) > prev(c) and state == A) or c <= 2"
"""
    outcomes = _conform(_spec(tmp_path, body), ["compile", "exhaustive", "sequences", "cppcheck"])
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


def test_a_gap_in_the_c_dispatch_to_a_mode_no_run_is_in_is_traced_to_that_mode() -> None:
    """C's `r_fired` tells the modes apart by `if (c->mode == R_S1)`: a branch to a mode no run of the suite is
    in was left without a reason (a random machine whose S0 and S1 no run reaches)."""
    c = ["static int r_fired(const r_ctx_t *c, const r_inputs_t *i, const r_params_t *p)", "{", "    int fired = -1;"]
    c += ["    if (c->mode == R_S0) {", "        fired = r_fired_S0(c, i, p);", "    } else if (c->mode == R_S1) {"]
    assert mode_of(c, 4, ("S0", "S1")) == "S0" and mode_of(c, 6, ("S0", "S1")) == "S1"
    c += ["        fired = r_fired_S1(c, i, p);", "    } else { /* not a state */", "        fired = -1;"]
    assert mode_of(c, 9, ("S0", "S1")) is None  # the restart's branch is no mode's


@pytest.mark.slow
def test_a_number_computed_only_where_a_guard_never_reads_it_has_the_reason_of_its_reader(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`gap` has no conditions of its own, and `far` computes it only where x is valid, which A's chain never
    is where it reads `far`: the line of gap's function was a gap without a reason (a random machine)."""
    body = """
[definitions]
gap = { expr = "x * 2", doc = "twice the sample" }
far = { expr = "gap == c", if_invalid = false, doc = "the sample twice the counter" }

[[transition]]
id = "sampled"
from = "A"
to = "B"
when = "valid(x)"

[[transition]]
id = "far_off"
from = "A"
to = "C"
when = "far or go"

[[transition]]
id = "back"
from = ["B", "C"]
to = "A"
when = "true"
"""
    reasons = _gap_reasons(tmp_path, body, capsys)
    assert any(r.startswith("gap is computed only where far reads it") for r in reasons)


def test_a_guard_s_valid_is_two_conditions_as_the_code_tests_it(tmp_path: Path) -> None:
    """The code tests `valid(x)` one end at a time (`0 <= x && x <= 3`), and gcc's MC/DC counts two conditions;
    the suite paired `valid(x)` as one, with a sample below the range only, so `x <= 3` was never false and
    left without a reason (a random machine). A real signal's check is one call of the code (a rounded part)."""
    real = '[signals.r]\ntype = "real"\nunit = "m"\nrange = [0.0, 10.0]\ndoc = "a distance"\n'
    body = real + '[[transition]]\nid = "t"\nfrom = "A"\nto = "B"\nwhen = "valid(x) or valid(r) or go"\n'
    machine = load_spec(_spec(tmp_path, body)).machine
    (guard,) = [d for d in decisions(machine) if d.id == "guard:A:t"]
    assert [show(a) for a in atoms(guard.expr)] == ["0 <= x", "x <= 3", "valid(r)", "go"]


def test_only_a_number_read_by_definitions_and_transitions_alone_takes_its_readers_reasons(tmp_path: Path) -> None:
    """A number an output reads is computed whatever fires: its readers' reasons would not explain its gap."""
    from mlca_verify.testgen.explain import _readers

    head = '[definitions]\ngap = { expr = "x * 2", doc = "d" }\nfar = { expr = "gap == c", if_invalid = false, doc = "d" }\n'
    body = head + '[[transition]]\nid = "t"\nfrom = "A"\nto = "B"\nwhen = "far"\n'
    assert _readers("gap", load_spec(_spec(tmp_path, body)).machine) == ["far"]
    output = '[outputs]\no = { expr = "gap + 1", if_invalid = 0, doc = "d" }\n'
    assert _readers("gap", load_spec(_spec(tmp_path, output + body)).machine) is None


@pytest.mark.slow
def test_a_definition_read_only_by_one_nothing_reads_is_paired_where_the_code_reads_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`ready` is read by nothing, so the code never computes it; through it the suite took `near` as read at
    every step and paired its `go` there, while the code reads `near` only where `go` is false (after `stop`):
    the gaps in near's function had no reason (three random machines)."""
    body = """
[definitions]
near = { expr = "x == 3 or go", if_invalid = true, doc = "a high sample, or go" }
ready = { expr = "near and c > 0", doc = "read by nothing" }

[[transition]]
id = "stop"
from = "A"
to = "B"
when = "go"

[[transition]]
id = "near_by"
from = "A"
to = "C"
when = "near"

[[transition]]
id = "back"
from = ["B", "C"]
to = "A"
when = "true"
"""
    reasons = _gap_reasons(tmp_path, body, capsys)
    assert reasons and all(reasons)
    assert any("go in def:near" in r for r in reasons)


def test_the_last_branch_of_an_update_is_traced_to_the_transitions_that_take_it() -> None:
    """A step that fires t1 or t4 takes their branches of d's update: its `else` is taken when t2 or t3 fires
    (a random machine whose t1 fires from every mode at every step left that line without a reason)."""
    python = [
        "        if fired == 1:  # d = max(d, c)",
        "            nxt.d = _max(c.d, c.c)",
        "        elif fired == 4:  # d = d + 1",
        "            nxt.d = c.d + 1",
        "        else:",
        "            nxt.d = c.d",
    ]
    numbered = ["t1", "t2", "t3", "t4"]
    assert others_than_chain(python, 6, numbered) == ["t2", "t3"]
    assert others_than_chain(python, 4, numbered) is None  # a transition's own branch
    c = [
        "        if (fired == 2) { /* d = 0 */",
        "            next.d = 0;",
        "        } else {",
        "            next.d = c->d;",
    ]
    assert others_than_chain(c, 4, numbered) == ["t1", "t3", "t4"]
    restart = ["    if (fired < 0) {", "        r_restart(&next);", "    } else {", "        next.mode = c->mode;"]
    assert others_than_chain(restart, 4, numbered) is None


def _every_transition_sets_c(first: str, second: str) -> str:
    """Two transitions from every mode, each setting c: t1 on `first`, then t2 on `second`."""
    return "".join(
        f'\n[[transition]]\nid = "t{k}"\nfrom = ["A", "B", "C"]\nto = "{to}"\nwhen = "{when}"\ndo = "c = {value}"\n'
        for k, (when, to, value) in enumerate(((first, "B", 1), (second, "C", 0)), 1)
    )


@pytest.mark.slow
def test_the_last_branch_of_an_update_no_step_of_the_code_takes_has_its_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every transition sets c and every mode's chain ends in `else` (`valid(x)` after `not (valid(x) and go)`),
    so the code always fires one and the Python's `else: nxt.c = c.c` is never run; it was left without a
    reason (a random machine of seed 11)."""
    from mlca_verify.testgen.explain import NO_TRANSITION

    body = _every_transition_sets_c("not (valid(x) and go)", "valid(x)")
    reasons = _gap_reasons(tmp_path, body, capsys)
    assert NO_TRANSITION in reasons and all(reasons), reasons


@pytest.mark.slow
def test_the_last_branch_of_an_update_only_an_unreached_otherwise_takes_has_its_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every transition sets c, and `not ready` holds wherever `go` does not (`ready` needs `go`), so no step fires
    none; the code's chains still end in `otherwise` (it does not look into `ready`), and the Python's
    `else: nxt.c = c.c` had no reason (a random machine of seed 17). It takes the reasons of each mode's last
    guard, as the `otherwise` branches do."""
    from mlca_verify.testgen.explain import OTHERWISE_ONLY

    ready = '[definitions]\nready = { expr = "valid(x) and go", doc = "a valid sample while go" }\n'
    body = ready + _every_transition_sets_c("go", "not ready")
    reasons = _gap_reasons(tmp_path, body, capsys)
    assert any(r.startswith(OTHERWISE_ONLY + " | ") for r in reasons) and all(reasons), reasons


def test_the_shared_abs_helper_of_an_invariant_has_its_reason(tmp_path: Path) -> None:
    """The monitor's check of `abs(c - prev(c)) <= 1` calls the shared abs helper: a gap in it is traced to that
    invariant's abs (a random machine left it without a reason)."""
    body = '[[transition]]\nfrom = "A"\nto = "B"\nwhen = "go"\n'
    body += '[[invariant]]\nid = "slow"\nexpr = "abs(c - prev(c)) <= 1"\n'
    machine = load_spec(_spec(tmp_path, body)).machine
    assert "(abs(c - prev(c)))" in saturation(machine, "abs_i", 30)


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
    reasons = _gap_reasons(tmp_path, body, capsys)
    assert reasons and all(reasons)
    assert any("shared abs helper" in r for r in reasons)


def test_what_a_condition_s_own_text_decides_is_decided_before_the_code() -> None:
    from mlca_verify.codegen.tidy import known_false, tidy, without_known
    from mlca_verify.model import BinOp, Const, Ite, Not

    types = {"a": "bool", "d": "int", "r": "real"}
    a, d, r = Var("a"), Var("d"), Var("r")
    three, one = Num(Fraction(3), False), Num(Fraction(1), False)
    assert tidy(Cmp("<=", three, one), types) == Const(False)
    assert tidy(Cmp("==", d, d), types) == Const(True) and tidy(Cmp("<", d, d), types) == Const(False)
    assert tidy(Cmp("==", r, r), types) == Cmp("==", r, r)  # binary64: a NaN is not equal to itself
    assert tidy(BinOp("->", a, a), types) == Const(True) and tidy(BinOp("or", a, Not(a)), types) == Const(True)
    assert tidy(BinOp("->", Not(a), a), types) == a and tidy(BinOp("and", a, Not(a)), types) == Const(False)
    implies = BinOp("->", Cmp("<=", three, one), a)  # 3 <= 1 -> a
    assert tidy(implies, types) == Const(True) and tidy(BinOp("and", implies, a), types) == a
    assert tidy(Ite(Cmp("!=", d, d), three, one), types) == one
    assert tidy(Arith("-", d, d), types) == Num(Fraction(0), False)  # cppcheck: duplicateExpression
    assert tidy(Arith("-", r, r), types) == Arith("-", r, r)  # a NaN minus itself is a NaN
    assert tidy(Arith("+", d, d), types) == Arith("+", d, d)
    assert tidy(Call("abs", (Arith("-", d, d),)), types) == Num(Fraction(0), False)  # not abs(0)
    assert tidy(Call("max", (three, one)), types) == three and tidy(Call("min", (three, one)), types) == one
    half = Num(Fraction(1, 2), True)
    assert tidy(Call("min", (three, half)), types) == Call("min", (three, half))  # an int and a real: kept
    kept = BinOp("and", a, Cmp("<", d, three))
    assert tidy(kept, types) is kept  # nothing to decide: the spec's own node
    assert without_known(BinOp("and", Not(a), Cmp("<", d, three)), known_false(a)) == Cmp("<", d, three)
    assert without_known(Not(a), known_false(BinOp("or", a, Cmp("<", d, three)))) == Const(True)


def test_what_the_left_side_decides_where_the_right_is_read_is_decided() -> None:
    """C reads `b` in `a && b` and `a -> b` only where `a` holds, in `a || b` only where it does not:
    `!a || (a && d < 3)` was redundantCondition for cppcheck (a random machine of seed 11)."""
    from mlca_verify.codegen.tidy import tidy
    from mlca_verify.model import BinOp, Not

    types = {"a": "bool", "b": "bool", "d": "int"}
    a, b, less = Var("a"), Var("b"), Cmp("<", Var("d"), Num(Fraction(3), False))
    assert tidy(BinOp("->", a, BinOp("and", a, less)), types) == BinOp("->", a, less)
    assert tidy(BinOp("or", a, BinOp("and", Not(a), less)), types) == BinOp("or", a, less)
    assert tidy(BinOp("and", BinOp("and", a, b), BinOp("or", Not(b), less)), types) == BinOp(
        "and", BinOp("and", a, b), less
    )
    kept = BinOp("or", a, BinOp("and", b, less))
    assert tidy(kept, types) is kept


def test_an_int_compared_with_itself_plus_a_constant_is_decided() -> None:
    """`c >= c + 1` was written as is: cppcheck's invalidTestForOverflow (two random machines of seed 11)."""
    from mlca_verify.codegen.tidy import tidy

    types = {"c": "int", "r": "real"}
    c, r, one = Var("c"), Var("r"), Num(Fraction(1), False)
    assert tidy(Cmp(">=", c, Arith("+", c, one)), types) == Const(False)
    assert tidy(Cmp("!=", c, Arith("-", c, one)), types) == Const(True)
    assert tidy(Cmp("<", Arith("-", c, one), Arith("+", one, c)), types) == Const(True)
    assert tidy(Cmp(">=", r, Arith("+", r, one)), types) == Cmp(">=", r, Arith("+", r, one))  # NaN, infinity


@pytest.mark.slow
def test_conditions_decided_by_their_own_text_build_and_pass_cppcheck(tmp_path: Path) -> None:
    """Once `c == c` in an update failed gcc (-Wtautological-compare), `(3 <= 1) -> go` and `not go` after a
    branch on `go` failed cppcheck (knownConditionTrueFalse), `abs(c - c)` failed it too (duplicateExpression),
    so did `go -> (go and c == 1)` (redundantCondition), `go` after it (knownConditionTrueFalse) and
    `c >= c + 1` (invalidTestForOverflow), and a definition read only by a branch the code
    leaves out was a C function never called (-Wunused-function)."""
    body = """
[definitions]
high = { expr = "x >= 2", if_invalid = false, doc = "a high sample" }

[[transition]]
id = "on"
from = "A"
to = "B"
when = "go"
do = "c = if c == c then 1 else 0"

[[transition]]
id = "off"
from = "A"
to = "C"
when = "not go and c > 0"

[[transition]]
id = "settled"
from = "B"
to = "A"
when = "go -> (go and c == 1)"

[[transition]]
id = "then_on"
from = "B"
to = "C"
when = "go and c > 0"

[[transition]]
id = "always"
from = "B"
to = "A"
when = "(3 <= 1) -> go"

[[transition]]
id = "shadowed"
from = "B"
to = "C"
when = "high"

[[transition]]
id = "never_on"
from = "C"
to = "B"
when = "not go -> c >= c + 1"

[[transition]]
id = "back"
from = "C"
to = "A"
when = "go or not go"
do = "c = abs(c - c)"
"""
    outcomes = _conform(_spec(tmp_path, body), ["compile", "exhaustive", "sequences", "cppcheck"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items()}
    source = (tmp_path / "gen" / "c" / "r_fsm.c").read_text(encoding="utf-8")
    assert "r_def_high(" not in source and "r_l_high(" in source  # the contracts keep every branch
    assert "(c->c == c->c)" not in source and "(!i->go) &&" not in source
    assert "(c->c - c->c)" not in source  # cppcheck: duplicateExpression
    assert "(i->go && " not in source  # cppcheck: redundantCondition
    assert "(c->c + 1)" not in source  # cppcheck: invalidTestForOverflow


def test_a_part_of_a_guard_the_earlier_guards_decide_is_decided() -> None:
    from mlca_verify.codegen.tidy import known_false, tidy, with_known
    from mlca_verify.model import BinOp, Const, Not

    a, b = Var("a"), Var("b")
    assert with_known(BinOp("and", a, b), known_false(BinOp("->", a, b))) == BinOp("and", Const(True), Const(False))
    valid, go = Call("valid", (Var("x"),)), Var("go")
    known = known_false(tidy(BinOp("->", valid, Not(valid)), {}))  # `not valid(x)` was false: valid(x) holds
    assert with_known(BinOp("or", go, Not(valid)), known) == BinOp("or", go, Const(False))
    assert tidy(with_known(BinOp("or", go, Not(valid)), known), {}) == go
    assert with_known(BinOp("and", go, go), known) == BinOp("and", go, go)  # nothing known: the same node


@pytest.mark.slow
def test_a_guard_that_reads_what_an_earlier_guard_decided_passes_cppcheck(tmp_path: Path) -> None:
    """`valid(x) -> not valid(x)` is `not valid(x)`: after its branch, `go or not valid(x)` was written with a
    test of `!valid(x)` that cppcheck knows is false (knownConditionTrueFalse, from a random machine); and
    `not valid(x) and go` is false there, so it is left out of the code."""
    body = """
[[transition]]
id = "never"
from = "A"
to = "B"
when = "valid(x) -> not valid(x)"

[[transition]]
id = "late"
from = "A"
to = "C"
when = "not valid(x) and go"

[[transition]]
id = "then"
from = "A"
to = "C"
when = "go or not valid(x)"

[[transition]]
id = "back"
from = ["B", "C"]
to = "A"
when = "go"
"""
    outcomes = _conform(_spec(tmp_path, body), ["compile", "exhaustive", "cppcheck"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:300] for n, o in outcomes.items() if not o.ok}
    source = (tmp_path / "gen" / "c" / "r_fsm.c").read_text(encoding="utf-8")
    assert "/* late: never taken in A: its guard is false where the earlier ones are */" in source


def test_two_tests_of_the_mode_joined_are_one() -> None:
    """`state == S2 -> state == S1` was written `!(mode == S2) || mode == S1` (cppcheck: redundantCondition)."""
    from mlca_verify.codegen.tidy import tidy
    from mlca_verify.model import BinOp, Const, Not, StateIn

    a, b, ab = StateIn(("A",)), StateIn(("B",)), StateIn(("A", "B"))
    assert tidy(BinOp("->", a, b), {}) == Not(a) and tidy(BinOp("->", a, ab), {}) == Const(True)
    assert tidy(BinOp("or", a, b), {}) == ab and tidy(BinOp("and", ab, Not(a)), {}) == b
    assert tidy(BinOp("and", a, b), {}) == Const(False) and tidy(BinOp("or", Not(a), Not(b)), {}) == Const(True)
    assert tidy(BinOp("and", Not(a), Not(b)), {}) == Not(ab) and tidy(BinOp("<->", a, b), {}) == BinOp("<->", a, b)


@pytest.mark.slow
def test_an_input_read_only_at_a_param_s_end_is_probed_outside_0_1(tmp_path: Path) -> None:
    """A reads `go` only when `c == Q`, which no boundary step meets at the default Q = 3 (c is at most 2): the
    sanitizers' probe of inputs outside 0/1 found nothing to report and failed; it now takes the steps at the
    params' ends too. The invariant's `state == B -> state == C` is `state != B` in C (cppcheck)."""
    body = """
[params]
Q = { type = "int", default = 3, range = [2, 3], doc = "a limit" }

[[transition]]
id = "skip"
from = "A"
to = "B"
when = "c != Q"

[[transition]]
id = "on"
from = "A"
to = "C"
when = "go"

[[transition]]
id = "back"
from = ["B", "C"]
to = "A"
when = "true"

[[invariant]]
id = "odd"
expr = "state == B -> state == C"
"""
    outcomes = _conform(_spec(tmp_path, body), ["compile", "cppcheck", "sanitizers"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:300] for n, o in outcomes.items() if not o.ok}
    assert "inputs outside 0/1 reported" in outcomes["sanitizers"].detail


def test_a_choice_between_equal_values_is_that_value() -> None:
    from mlca_verify.codegen.tidy import tidy
    from mlca_verify.model import Ite

    d, one = Var("d"), Num(Fraction(1), False)
    assert tidy(Ite(Cmp("<", d, one), d, d), {"d": "int"}) == d  # cppcheck: duplicateExpressionTernary


def test_a_choice_on_a_negation_is_written_the_other_way_round() -> None:
    from mlca_verify.codegen.tidy import tidy
    from mlca_verify.model import Ite, Not

    d, zero, valid = Var("d"), Num(Fraction(0), False), Call("valid", (Var("x"),))
    assert tidy(Ite(Not(valid), d, zero), {"d": "int"}) == Ite(valid, zero, d)


@pytest.mark.slow
def test_a_choice_on_a_negated_valid_has_its_c_mcdc_pairs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`d = if not valid(x) then d else 0` was `(!((0 <= x) && (x <= 3))) ? d : 0`, whose two conditions clang's
    MC/DC never saw paired (it records no test vector of a `?:` on a `!`) though the suite paired them: two
    gaps without a reason (a random machine of seed 11)."""
    body = """
[[transition]]
id = "t"
from = "A"
to = "B"
when = "go"
do = "c = if not valid(x) then c else 1"

[[transition]]
id = "back"
from = "B"
to = "A"
when = "true"
do = "c = 0"
"""
    reasons = _gap_reasons(tmp_path, body, capsys)
    assert all(reasons) and not [r for r in reasons if "valid" in r], reasons


@pytest.mark.slow
@pytest.mark.parametrize("every", ["2", "if c < c then c else 2"])
def test_an_update_that_is_the_every_rule_and_a_helper_only_a_left_out_branch_calls(tmp_path: Path, every: str) -> None:
    """`c = 2` where c's every is 2 once wrote the same assignment in the `if` and the `else` (cppcheck:
    duplicateBranch), and so did an every the code writes as 2 (`if c < c then c else 2`, five random machines
    of seed 17); a `max` only in a guard the code leaves out once left the max helper defined and never called
    (gcc: -Wunused-function)."""
    body = """
[[transition]]
id = "on"
from = "A"
to = "B"
when = "go"
do = "c = 2"

[[transition]]
id = "again"
from = "A"
to = "C"
when = "go"

[[transition]]
id = "never"
from = "B"
to = "C"
when = "max(c, 1) > 5 and (3 <= 1)"
"""
    path = _spec(tmp_path, body.replace("[[transition]]", "[[transition]]", 1))
    text = path.read_text(encoding="utf-8").replace('doc = "a counter" }', f'every = "{every}", doc = "a counter" }}')
    path.write_text(text, encoding="utf-8")
    outcomes = _conform(path, ["compile", "exhaustive", "cppcheck"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items()}
    source = (tmp_path / "gen" / "c" / "r_fsm.c").read_text(encoding="utf-8")
    assert "r_max_i(" not in source and "never taken in B: its guard is false as written" in source


# c = c + d from B would leave c's range from contexts in range, but no run reaches B with d > 0: d is 0 there
REACHED_ONLY = """
[variables.d]
type = "int"
initial = 0
range = [0, 2]
doc = "zero in B"

[[transition]]
id = "on"
from = "A"
to = "B"
when = "go"
do = "d = 0; c = 1"

[[transition]]
id = "add"
from = "B"
to = "A"
when = "go"
do = "c = c + d"

[[transition]]
id = "rest"
from = "A"
to = "A"
when = "not go"
do = "d = 2; c = 0"

[[invariant]]
id = "stays"
expr = "prev(go) or not go"
"""


@pytest.mark.slow
def test_wp_proves_a_step_whose_range_only_the_runs_keep(tmp_path: Path) -> None:
    """From B, `c = c + d` would take c past 2 from some contexts in range, but no run reaches B with such a d
    (d is 0 there): the step requires c's range (in_reach) without ensuring it, and WP proves the rest; the
    range itself is range:c's, which holds. It once failed WP (the call of prev()'s register on the next
    context)."""
    path = _spec(tmp_path, REACHED_ONLY)
    outcomes = _conform(path, ["compile", "frama-c-wp"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail for n, o in outcomes.items()}
    wp = outcomes["frama-c-wp"]
    assert wp.data["certified"]["in_reach"] == ["c"] and "leaves it to the engine's range:c" in wp.detail
    source = (tmp_path / "gen" / "c" / "r_fsm.c").read_text(encoding="utf-8")
    assert "@ requires in_reach: 0 <= c->c <= 2" in source


def test_the_ranges_one_step_keeps_from_every_context_in_range(tmp_path: Path) -> None:
    """c's range is kept only because no run reaches B with d > 0 (one step from B with d = 2 and c = 2 leaves
    it); d's and the counter's own are kept by every step. The independent check: every context in range and
    every input, stepped by the explicit replay of the spec."""
    from itertools import product

    from mlca_verify.logic.kept import kept_ranges
    from mlca_verify.logic.replay64 import Binary64

    machine = load_spec(_spec(tmp_path, REACHED_ONLY)).machine
    kept = kept_ranges(machine)
    assert kept == frozenset({"d"})
    replay = Binary64(machine)
    leaves = set()
    for mode, c, d, go, x in product(machine.states, range(3), range(3), (False, True), range(-1, 5)):
        _, _, after = replay.step(mode, {"c": c, "d": d, "go": go, "x": x})
        leaves |= {n for n in ("c", "d") if not 0 <= after[n] <= 2}
    assert leaves == {"c"}


def test_a_side_that_holds_the_other_absorbs_it() -> None:
    from mlca_verify.codegen.tidy import tidy
    from mlca_verify.model import BinOp

    a, b = Var("a"), Var("b")
    types = {"a": "bool", "b": "bool"}
    assert tidy(BinOp("or", a, BinOp("and", a, b)), types) == a  # cppcheck: redundantCondition
    assert tidy(BinOp("and", BinOp("or", b, a), a), types) == a
    assert tidy(BinOp("or", a, BinOp("and", b, b)), types) == BinOp("or", a, b)


def test_a_side_repeated_in_a_chain_is_written_once() -> None:
    """`(valid(x) -> 1 <= c) or not valid(x)` was written `(!valid || 1 <= c) || !valid` (cppcheck:
    duplicateExpression, from a random machine of seed 11)."""
    from mlca_verify.codegen.tidy import tidy
    from mlca_verify.model import BinOp, Not

    a, b = Var("a"), Var("b")
    assert tidy(BinOp("or", BinOp("->", a, b), Not(a)), {}) == BinOp("->", a, b)
    assert tidy(BinOp("or", BinOp("->", a, b), b), {}) == BinOp("->", a, b)
    assert tidy(BinOp("and", a, BinOp("and", b, a)), {}) == BinOp("and", a, b)  # b where a holds
    assert tidy(BinOp("or", a, BinOp("and", b, a)), {}) == a  # absorbed
    assert tidy(BinOp("and", BinOp("->", a, b), Not(a)), {}) == BinOp("and", BinOp("->", a, b), Not(a))


def test_a_direct_step_that_keeps_a_variable_restarts_a_mode_that_names_no_state(tmp_path: Path) -> None:
    """`c` is updated by no transition, so the step is direct; a `from = "*"` transition to the fallback mode,
    tested before the modes, would leave `c` as it was in a context whose mode names no state, where the restart
    resets it. The step tests such a transition in each mode when the context keeps a variable."""
    body = """
[[transition]]
id = "stop"
from = "*"
to = "A"
when = "go"

[[transition]]
id = "on"
from = "A"
to = "B"
when = "big"
"""
    path = _spec(tmp_path, '[definitions]\nbig = { expr = "x > 1", if_invalid = false, doc = "d" }\n' + body)
    step = c_function(generate(load_spec(path), tmp_path / "g")["c/r_fsm.c"], "void r_step(")
    assert "fired" not in step and "if (mode == R_A) {" in step  # direct, the modes told apart first
    outcomes = _conform(path, ["compile", "exhaustive"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:300] for n, o in outcomes.items() if not o.ok}


COMMON_ONCE = """
[machine]
name = "R"
initial = "A"
states = ["A", "B"]
otherwise = "stay"

[inputs]
go = { doc = "go" }

[params]
STEP = { type = "int", default = 1, range = [0, 2], doc = "the counter's step" }

[signals]
x = { type = "int", unit = "1", range = [0, 3], doc = "a sample" }

[definitions]
k = { expr = "c + STEP", doc = "the counter moved on" }
low = { expr = "x < 1", if_invalid = false, doc = "a low sample" }

[variables]
c = { type = "int", initial = 0, range = [0, 5], every = "min(k + 1, 5)", doc = "a counter" }

[[transition]]
id = "up"
from = "A"
to = "B"
when = "low and k > 4"

[[transition]]
id = "again"
from = "A"
to = "B"
when = "low or go"

[[transition]]
id = "down"
from = "B"
to = "A"
when = "k > 3"
"""


@pytest.mark.slow
def test_a_definition_every_mode_computes_once_is_computed_whatever_the_mode(tmp_path: Path) -> None:
    """Both modes compute `k` once, A also `low`: `k` is computed whatever the mode, so the direct step's
    `every` update, made before it knows whether the mode is a state, reads a `k` WP knows (it found `k + 1`
    overflowing when `k` was computed mode by mode). `go` is read only when `low` is false, which the boundary
    steps reach with their bools 0xFF: the sanitizers see it (a step from each mode on zero samples did not)."""
    path = tmp_path / "r.toml"
    path.write_text(COMMON_ONCE, encoding="utf-8")
    once = generate(load_spec(path), tmp_path / "g")["c/r_fsm.c"].split("static void r_once(")[1].split("\n}\n")[0]
    assert once.index("d->k = r_def_k(c, i, p);") < once.index("if ((c->mode == R_A)) {")
    outcomes = _conform(path, ["compile", "exhaustive", "frama-c-wp", "sanitizers"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:300] for n, o in outcomes.items() if not o.ok}


KEEPS_A_CALL = """
[machine]
name = "R"
initial = "S1"
states = ["S0", "S1"]
otherwise = "stay"

[inputs]
A = { doc = "d" }

[params]
Q = { type = "int", default = 2, range = [1, 3], doc = "d" }

[signals]
x = { type = "int", unit = "1", range = [0, 3], doc = "d" }

[definitions]
gap = { expr = "x - c", doc = "d" }
far = { expr = "gap >= Q", if_invalid = true, doc = "d" }

[variables]
c = { type = "int", initial = 1, range = [0, 2], doc = "d" }

[[transition]]
id = "t1"
from = "*"
to = "S0"
when = "not far"

[[transition]]
id = "t2"
from = "*"
to = "S0"
when = "A"
"""


def test_a_direct_chain_that_must_keep_a_branch_to_its_end_is_numbered(tmp_path: Path) -> None:
    """In S0, `t1` goes where the chain ends (S0) but calls `far`, so the direct step could not leave it out, and
    would write `next = R_S0` in an `if` and its `else` (cppcheck: duplicateBranch). Such a machine gets the
    numbered step, which tells the branches apart."""
    path = tmp_path / "r.toml"
    path.write_text(KEEPS_A_CALL, encoding="utf-8")
    step = c_function(generate(load_spec(path), tmp_path / "g")["c/r_fsm.c"], "void r_step(")
    assert "const int fired = r_fired(c, i, p);" in step
    outcomes = _conform(path, ["compile", "exhaustive", "cppcheck"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:300] for n, o in outcomes.items() if not o.ok}


TWINS = """
[machine]
name = "R"
initial = "A"
states = ["A", "B"]
otherwise = "stay"

[inputs]
go = { doc = "go" }

[variables]
c = { type = "int", initial = 0, range = [0, 2], doc = "a counter" }
d = { type = "int", initial = 0, range = [0, 2], doc = "its twin" }

[outputs]
o = { expr = "OUT", doc = "an output" }

[[transition]]
id = "count"
from = "A"
to = "A"
when = "go and d < 2"
do = "c = c + 1; d = d + 1"

[[transition]]
id = "done"
from = "A"
to = "B"
when = "d >= 2 and c - 1 >= 1"

[[transition]]
id = "again"
from = "B"
to = "A"
when = "go"
do = "c = 0; d = 0"
"""


def _twins(tmp_path: Path, output: str) -> Path:
    path = tmp_path / "r.toml"
    path.write_text(TWINS.replace("OUT", output), encoding="utf-8")
    return path


def test_only_the_variables_whose_range_the_runs_keep_are_admitted_after_the_step(tmp_path: Path) -> None:
    """Only the runs keep c in its range (c equals d on every reachable context, so range:c holds; one step from
    c = 2, d = 0 leaves it): the step requires it of the context before it and admits it of the one after it;
    every function the step calls requires it. d, whose range every step keeps, needs neither."""
    path = _twins(tmp_path, "c + 1")
    assert [f.name for f in machine_ir(load_spec(path), tmp_path / "g").variables if not f.kept] == ["c"]
    source = generate(load_spec(path), tmp_path / "g")["c/r_fsm.c"]
    assert "/*@ admit in_reach: 0 <= next.c <= 2 && \\true; */" in c_function(source, "void r_step(")
    assert "@ requires in_reach: 0 <= c->c <= 2 && \\true;" in source and "next.d <=" not in source
    fired = source.split("static int r_fired_A(")[0].rsplit("/*@ requires", 1)[1]
    assert "0 <= c->c <= 2 && 0 <= c->d <= 2" in fired


@pytest.mark.slow
def test_wp_proves_the_functions_a_step_calls_on_a_variable_whose_range_only_the_runs_keep(tmp_path: Path) -> None:
    """The output `c + 1` was typed int8_t from c's range, but the outputs' function, proved for any context after
    the step, knew nothing of c: WP could not prove its ensures or that `c + 1` does not overflow (a random
    machine's `max(c, P)` failed the same way); nor could it prove that A's chain, proved for any context, does
    not overflow in `c - 1`. Every code-side check passes."""
    path = _twins(tmp_path, "c + 1")
    outcomes = _conform(path, ["compile", "exhaustive", "frama-c-wp", "cppcheck", "sanitizers"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:400] for n, o in outcomes.items() if not o.ok}
    assert "admits it of the one after it" in outcomes["frama-c-wp"].detail
    assert (
        main(["tests", "--no-target", "--generated", str(tmp_path / "gen"), "--out", str(tmp_path / "t"), str(path)])
        == 0
    )


HOISTED = """
[machine]
name = "H"
initial = "A"
states = ["A", "B"]
otherwise = "stay"

[inputs]
a = { doc = "a" }
b = { doc = "b" }
c = { doc = "c" }
go = { doc = "go" }

[[transition]]
id = "t1"
from = "*"
to = "A"
when = "a or b"

[[transition]]
id = "t2"
from = "*"
to = "A"
when = "a and c"

[[transition]]
id = "t3"
from = "A"
to = "B"
when = "go"

[[transition]]
id = "t4"
from = "B"
to = "A"
when = "go"
"""


@pytest.mark.slow
def test_a_hoisted_guard_the_earlier_ones_decide_is_not_hoisted(tmp_path: Path) -> None:
    """The step tests the leading `from = "*"` transitions before the modes; `a and c` after `a or b` is false
    there, so each mode's chain left it out, and the step, counting it hoisted, dropped A's first transition
    instead (`go`). Only t1 is hoisted now, and t2 is left out of each chain with its comment."""
    path = tmp_path / "h.toml"
    path.write_text(HOISTED, encoding="utf-8")
    ir = machine_ir(load_spec(path), tmp_path / "g")
    assert ir.direct and ir.hoisted == 1
    outcomes = _conform(path, ["compile", "exhaustive", "cppcheck", "frama-c-wp"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:300] for n, o in outcomes.items() if not o.ok}
    to_a = c_function((tmp_path / "gen" / "c" / "h_fsm.c").read_text(encoding="utf-8"), "static h_state_t h_to_A(")
    assert "if (i->go) { /* t3: go */" in to_a and "t2: never taken in A" in to_a


def test_a_negated_premise_and_a_negated_invariant_are_written_without_a_double_negation(tmp_path: Path) -> None:
    """`not go -> c == 0` was written `(!(!i->go)) || ...` in C and `(not (not i.go)) or ...` in Python, and the
    Python monitor tested an invariant `not e` as `if not (not e)`: the code now says `go || ...` and `if e`."""
    body = """
[[transition]]
id = "t"
from = "A"
to = "B"
when = "not go -> c == 0"

[[transition]]
id = "back"
from = "B"
to = "A"
when = "go"

[[invariant]]
id = "never"
expr = "not (state == C and c == 2)"
"""
    path = _spec(tmp_path, body)
    files = generate(load_spec(path), tmp_path / "g")
    c, py = files["c/r_fsm.c"], files["python/r_fsm.py"]
    assert "(!(!" not in c and "not (not" not in py
    assert "(i->go || (c->c == 0))" in c and "(i.go or (c.c == 0))" in py
    assert "if ((c.mode == State.C) and (c.c == 2)):" in py
    outcomes = _conform(path, ["compile", "exhaustive", "sequences"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:300] for n, o in outcomes.items() if not o.ok}


def test_the_monitors_inline_range_test_of_a_real_is_two_conditions(tmp_path: Path) -> None:
    """The monitor tests `valid(s)` of a real signal inline, one end at a time, where the step calls one function
    for it. Its MC/DC decision held `valid(s)` as one condition, so the C's two had no pair of their own and
    took the reason of another condition of the invariant (MLCA-T's fail-safe-left, once clang measured it)."""
    body = """
[[transition]]
id = "t"
from = "A"
to = "B"
when = "go and valid(s)"

[[invariant]]
id = "safe"
expr = "not valid(s) -> state != B"
"""
    real = '[signals.s]\ntype = "real"\nunit = "m"\nrange = [0.0, 5.0]\ndoc = "a distance"\n'
    path = _spec(tmp_path, real + body)
    found = {d.id: d.expr for d in decisions(load_spec(path).machine)}
    low, high = Cmp("<=", Num(Fraction(0), True), Var("s")), Cmp("<=", Var("s"), Num(Fraction(5), True))
    assert low in atoms(found["inv:safe"]) and high in atoms(found["inv:safe"])
    assert Call("valid", (Var("s"),)) in atoms(found["guard:A:t"])  # the step's one rounded call


def test_an_int_comparison_a_known_one_of_the_same_sides_decides_is_decided() -> None:
    """After `valid(x) -> c != d` is false, `c == d` holds, so `c <= d` is true (a random machine of seed 29:
    cppcheck's knownConditionTrueFalse); a false comparison of reals decides nothing (NaN)."""
    from mlca_verify.codegen.tidy import known_false, with_known
    from mlca_verify.model import BinOp, Const, Not

    c, d, valid = Var("c"), Var("d"), Call("valid", (Var("x"),))
    ints = {"c": "int", "d": "int"}
    known = known_false(BinOp("->", valid, Cmp("!=", c, d)))
    assert with_known(Cmp("<=", c, d), known, ints) == Const(True)
    assert with_known(Cmp(">", d, c), known, ints) == Const(False)  # the sides the other way round
    assert with_known(Cmp("<", c, d), [Cmp("<=", c, d)], ints) is not Const(True)  # not decided
    assert with_known(Cmp("!=", c, d), [Not(Cmp(">=", d, c))], ints) == Const(True)  # d < c
    reals = {"c": "real", "d": "real"}
    assert with_known(Cmp(">=", c, d), [Not(Cmp("<", c, d))], reals) == Cmp(">=", c, d)  # c or d may be NaN
    assert with_known(Cmp("<=", c, d), known, None) == Cmp("<=", c, d)  # without types, as before


@pytest.mark.slow
def test_a_guard_an_earlier_comparison_of_the_same_ints_decides_passes_cppcheck(tmp_path: Path) -> None:
    """`c <= d` after a branch on `valid(x) -> c != d` was tested though `c == d` held there (a random machine of
    seed 29: cppcheck's knownConditionTrueFalse); it is now the chain's `else`."""
    body = """
[[transition]]
id = "t1"
from = "*"
to = "B"
when = "valid(x) -> c != 2"

[[transition]]
id = "t2"
from = ["A", "B"]
to = "A"
when = "go"

[[transition]]
id = "t3"
from = ["A", "B"]
to = "C"
when = "c >= 2"
do = "c = 0"
"""
    outcomes = _conform(_spec(tmp_path, body), ["compile", "exhaustive", "sequences", "cppcheck"])
    assert all(o.ok for o in outcomes.values()), {n: o.detail[:300] for n, o in outcomes.items() if not o.ok}
    source = (tmp_path / "gen" / "c" / "r_fsm.c").read_text(encoding="utf-8")
    assert "/* t3: c >= 2: enabled whenever the ones before it are not */" in source
