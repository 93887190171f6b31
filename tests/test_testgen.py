"""`mlca-verify tests`: the MC/DC pairs z3 finds and the reasons it gives against brute force; the suite's
expected values against independent explorers; the written suites against the generated code, mutants of it,
clang's MC/DC, coverage.py and a Cortex-M4 under QEMU."""

from __future__ import annotations

import itertools
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from fractions import Fraction
from pathlib import Path

import jsonschema
import pytest
from hypothesis import HealthCheck, assume, given, settings

from mlca_verify.cli import main
from mlca_verify.model import BinOp, Const, Expr, Machine, Not, Prev, StateIn
from mlca_verify.spec import load_spec
from mlca_verify.testgen.cobertura import cobertura_from_lcov
from mlca_verify.testgen.objectives import Decision, objectives
from mlca_verify.testgen.search import Found, Pair, Search, Unrolling
from mlca_verify.testgen.suite import generate
from mlca_verify.testgen.target import first_difference
from tests import bruteforce, bruteforce_data
from tests.conftest import ROOT
from tests.strategies import machines

SCHEMAS = ROOT / "tests" / "schemas"
BOOLEAN_SPECS = ["spec/mlca.toml", "spec/mlca_r.toml"]

# --- an evaluator of decisions written apart from the engine's --------------------------------------------------


def outcome(expr: Expr, atom: Callable[[Expr], bool], forced: dict[int, bool]) -> bool:
    """The decision's value, its condition occurrences (numbered left to right) read through `atom` unless
    forced."""
    count = itertools.count()

    def walk(e: Expr) -> bool:
        if isinstance(e, Not):
            return not walk(e.arg)
        if isinstance(e, BinOp):
            a, b = walk(e.left), walk(e.right)
            return {"and": a and b, "or": a or b, "->": (not a) or b, "<->": a == b}[e.op]
        if isinstance(e, Const):
            return e.value
        k = next(count)
        return forced[k] if k in forced else atom(e)

    return walk(expr)


def occurrences(expr: Expr) -> list[Expr]:
    if isinstance(expr, Not):
        return occurrences(expr.arg)
    if isinstance(expr, BinOp):
        return occurrences(expr.left) + occurrences(expr.right)
    return [] if isinstance(expr, Const) else [expr]


def at_point(expr: Expr, index: int, atom: Callable[[Expr], bool]) -> tuple[bool, bool, bool, list[bool]]:
    """The condition's value, whether it alone decides the outcome here, the outcome, every condition's value."""
    values = [atom(a) for a in occurrences(expr)]
    high = outcome(expr, atom, {index: True})
    low = outcome(expr, atom, {index: False})
    return values[index], high != low, high if values[index] else low, values


# --- machines without data: brute force over every state and input -----------------------------------------------


def boolean_points(m: Machine, d: Decision) -> Iterator[tuple[str | None, dict[str, bool]]]:
    """Where the code evaluates `d`: a guard in its reachable state under inputs that make a step; an invariant
    over any state (None: a value that names no state) and any inputs."""
    ex = bruteforce.Explicit(m)
    if d.kind == "guard":
        reachable = ex.distances()
        for inputs in ex.vals:
            if d.state in reachable and ex.fired(d.state, inputs):
                yield d.state, inputs
        return
    for state in (*m.states, None):
        for inputs in ex.vals:
            yield state, inputs


def brute_pairs(m: Machine, d: Decision, index: int) -> tuple[bool, bool]:
    """Whether some unique-cause pair exists, and whether some masking pair does."""
    halves: dict[bool, list[tuple[bool, list[bool]]]] = {True: [], False: []}
    for state, inputs in boolean_points(m, d):

        def atom(e: Expr, state: str | None = state, inputs: dict[str, bool] = inputs) -> bool:
            return bruteforce.ev(e, inputs, state)

        if not all(atom(g) for g in d.given):
            continue
        value, decides, result, values = at_point(d.expr, index, atom)
        if decides:
            halves[value].append((result, values))
    unique = any(
        ra != rb and all(x == y for k, (x, y) in enumerate(zip(va, vb, strict=True)) if k != index)
        for (ra, va), (rb, vb) in itertools.product(halves[True], halves[False])
    )
    masking = any(ra != rb for (ra, _), (rb, _) in itertools.product(halves[True], halves[False]))
    return unique, masking


def boolean_half(m: Machine, p: Pair, found: Found) -> tuple[bool, bool, bool, list[bool]]:
    d = p.objective.decision
    if found.snapshot is not None:
        mode = int(found.snapshot.after["mode"])
        state: str | None = m.states[mode] if mode < len(m.states) else None
        inputs = {k: bool(v) for k, v in found.snapshot.inputs.items()}
    else:
        ex, state = bruteforce.Explicit(m), m.initial
        for sample in found.inputs[:-1]:
            state = ex.fired(state, {k: bool(v) for k, v in sample.items()})[0][1]
        inputs = {k: bool(v) for k, v in found.inputs[-1].items()}
        assert state == d.state or d.state is None, (p.objective.id, state)
    assert all(bruteforce.ev(g, inputs, state) for g in d.given), p.objective.id
    return at_point(d.expr, p.objective.index, lambda e: bruteforce.ev(e, inputs, state))


def check_against_brute_force(m: Machine, depth: int) -> None:
    search = Search(Unrolling(m, depth))
    for o in objectives(m):
        p = search.pair(o)
        unique, masking = brute_pairs(m, o.decision, o.index)
        if p.a is None or p.b is None:
            assert not masking, f"{o.id}: z3 found no pair, brute force finds one ({p.reason})"
            assert p.reason
            continue
        a, b = boolean_half(m, p, p.a), boolean_half(m, p, p.b)
        assert a[0] and not b[0], o.id
        assert a[1] and b[1], f"{o.id}: the condition does not decide the outcome"
        assert a[2] != b[2], f"{o.id}: the outcomes are the same"
        if p.form == "unique cause":
            assert all(x == y for k, (x, y) in enumerate(zip(a[3], b[3], strict=True)) if k != o.index), o.id
        else:
            assert not unique or p.form == "masking", o.id


@pytest.mark.parametrize("path", BOOLEAN_SPECS)
def test_pairs_and_reasons_of_the_shipped_machines_against_brute_force(path: str) -> None:
    check_against_brute_force(load_spec(ROOT / path).machine, depth=8)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(machines(max_states=5, max_inputs=3))
def test_pairs_and_reasons_of_random_machines_against_brute_force(machine: Machine) -> None:
    assume(machine.semantics == "first-match")
    check_against_brute_force(machine, depth=len(machine.states) + 1)


@pytest.mark.parametrize("path", BOOLEAN_SPECS)
def test_expected_states_and_verdicts_agree_with_the_explicit_explorer(path: str) -> None:
    m = load_spec(ROOT / path).machine
    suite = generate(m)
    ex = bruteforce.Explicit(m)
    assert suite.cases
    for case in suite.cases:
        state = m.initial
        for sample, want in zip(case.inputs, case.expected, strict=True):
            inputs = {k: bool(v) for k, v in sample.items()}
            state = ex.fired(state, inputs)[0][1]
            failing = [i.id for i in m.invariants if not bruteforce.ev(i.expr, inputs, state)]
            assert (want.state, list(want.failing)) == (state, failing), case.name
    for call in suite.monitor:
        mode = int(call.snapshot.after["mode"])
        state = m.states[mode] if mode < len(m.states) else None
        inputs = {k: bool(v) for k, v in call.snapshot.inputs.items()}
        failing = [i.id for i in m.invariants if not bruteforce.ev(i.expr, inputs, state)]
        assert list(call.snapshot.failing) == failing, call.name


# --- MLCA-T: exact arithmetic, apart from z3 ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def mlca_t() -> tuple[Machine, object]:
    m = load_spec(ROOT / "spec/mlca_t.toml").machine
    return m, generate(m)


def _exact_inputs(sample: dict[str, bool | int | float]) -> dict[str, bruteforce_data.Value]:
    return {k: v if isinstance(v, bool) else Fraction(v) for k, v in sample.items()}


def _prevs(m: Machine) -> tuple[Prev, ...]:
    return bruteforce_data._prevs(*(i.expr for i in m.invariants), *(o.expr for o in m.outputs))


def test_mlca_t_runs_replay_exactly_on_the_data_explorer(mlca_t: tuple[Machine, object]) -> None:
    m, suite = mlca_t
    ex = bruteforce_data.DataExplorer(m, enumerate_inputs=False)
    params = ex.defaults()
    prevs = _prevs(m)
    from_context = 0
    for case in suite.cases:  # type: ignore[attr-defined]
        if case.start is None:
            mode, variables = ex.initial()
            registers: dict[int, object] | None = None
        else:
            from_context += 1
            mode = m.states[int(case.start["mode"])]
            variables = tuple(Fraction(case.start[v.name]) for v in m.variables)
            # a register the code does not keep is not in the context: it is its expression over the context
            kept = {k: case.start[f"prev{k}"] for k in range(len(prevs)) if f"prev{k}" in case.start}
            registers = None if case.start.get("first", False) else kept
        for sample, want in zip(case.inputs, case.expected, strict=True):
            inputs = _exact_inputs(sample)
            before = ex.point(mode, variables, inputs, params)
            move = ex.step(params, mode, variables, inputs)
            assert move is not None, case.name
            previous = {p: ev_prev(p, before, registers, k) for k, p in enumerate(prevs)}
            post = ex.point(move.mode, move.variables, inputs, params, previous)
            failing = [i.id for i in m.invariants if not bruteforce_data.ev(i.expr, post)]
            outputs = tuple(bruteforce_data.ev(o.expr, post) for o in m.outputs)
            assert want.state == move.mode, case.name
            assert tuple(Fraction(x) for x in want.variables) == move.variables, case.name
            assert tuple(Fraction(x) for x in want.outputs) == tuple(Fraction(x) for x in outputs), case.name
            assert list(want.failing) == failing, case.name
            mode, variables = move.mode, move.variables
            registers = {k: bruteforce_data.ev(p.arg, post) for k, p in enumerate(prevs)}
    assert from_context >= 1  # the saturating counters are reached from a context


def test_every_run_the_search_finds_passes_its_decision_state_on_the_data_explorer() -> None:
    """The runs found for each pair, replayed on the independent explorer from the initial state, step from the
    decision's state at their last step: the signals chosen to realize an abstracted definition at an earlier
    step keep the step the search's model took (a chosen `speed` outside its range once sent a cruise control
    to its fault mode, so no run ever stepped from ACTIVE, whose guards the suite claimed to pair)."""
    m = load_spec(ROOT / "tests/machines/acc_modes_50hz.toml").machine
    search = Search(Unrolling(m, 30))
    ex = bruteforce_data.DataExplorer(m, enumerate_inputs=False)
    checked: set[str] = set()
    for o in objectives(m):
        if o.decision.kind != "guard" or o.decision.state is None:
            continue
        pair = search.pair(o)
        for found in (pair.a, pair.b):
            assert found is not None, o.id
            if found.start is not None:  # one step from a context in range (a hold counted past the depth)
                continue
            mode, variables = ex.initial()
            for sample in found.inputs[:-1]:
                move = ex.step(ex.defaults(), mode, variables, _exact_inputs(sample))
                assert move is not None, o.id
                mode, variables = move.mode, move.variables
            assert mode == o.decision.state, o.id
            checked.add(mode)
    assert checked == set(m.states)


def ev_prev(p: Prev, before: bruteforce_data.Point, registers: dict[int, object] | None, k: int) -> object:
    return registers[k] if registers is not None and k in registers else bruteforce_data.ev(p.arg, before)


def test_mlca_t_pairs_hold_in_exact_arithmetic(mlca_t: tuple[Machine, object]) -> None:
    """Each pair's last steps, evaluated exactly: the condition differs, decides the outcome, and the outcomes
    differ (the margins keep binary64 and exact arithmetic on the same side of every comparison)."""
    m, suite = mlca_t
    ex = bruteforce_data.DataExplorer(m, enumerate_inputs=False)
    params, prevs = ex.defaults(), _prevs(m)
    checked = 0
    for p in suite.pairs:  # type: ignore[attr-defined]
        if p.a is None or p.b is None:
            continue
        halves = [_data_half(m, ex, params, prevs, p, f) for f in (p.a, p.b)]
        (va, da, ra, _), (vb, db, rb, _) = halves
        assert va and not vb and da and db and ra != rb, p.objective.id
        checked += 1
    assert checked >= 80


def _data_half(
    m: Machine, ex: bruteforce_data.DataExplorer, params: dict, prevs: tuple[Prev, ...], p: Pair, found: Found
):  # type: ignore[no-untyped-def]
    d = p.objective.decision
    if found.snapshot is not None:
        s = found.snapshot
        inputs = _exact_inputs(s.inputs)
        before = ex.point(
            m.states[int(s.before["mode"])], tuple(Fraction(s.before[v.name]) for v in m.variables), inputs, params
        )
        kept = (
            None
            if s.before.get("first", False)
            else {k: s.before[f"prev{k}"] for k in range(len(prevs)) if f"prev{k}" in s.before}
        )
        previous = {q: ev_prev(q, before, kept, k) for k, q in enumerate(prevs)}
        mode = int(s.after["mode"])
        point = ex.point(
            m.states[mode] if mode < len(m.states) else "<none>",
            tuple(Fraction(s.after[v.name]) for v in m.variables),
            inputs,
            params,
            previous,
        )
    else:
        mode_name, variables = ex.initial()
        if found.start is not None:
            mode_name = m.states[int(found.start["mode"])]
            variables = tuple(Fraction(found.start[v.name]) for v in m.variables)
        for sample in found.inputs[:-1]:
            move = ex.step(params, mode_name, variables, _exact_inputs(sample))
            assert move is not None
            mode_name, variables = move.mode, move.variables
        inputs = _exact_inputs(found.inputs[-1])
        before = ex.point(mode_name, variables, inputs, params)
        point = before
        if d.where == "post":
            move = ex.step(params, mode_name, variables, inputs)
            assert move is not None
            point = ex.point(move.mode, move.variables, inputs, params, {})
        if d.state is not None:
            assert mode_name == d.state, p.objective.id
    assert all(bruteforce_data.ev(g, point) for g in d.given), p.objective.id
    return at_point(d.expr, p.objective.index, lambda e: bool(bruteforce_data.ev(e, point)))


# --- the written suites, run --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tests")
    code = main(["tests", "spec/mlca.toml", "spec/mlca_t.toml", "--out", str(out)])
    assert code == 0
    return out


@pytest.mark.slow
def test_the_suites_cover_the_generated_code_and_agree_on_the_target(written: Path) -> None:
    # MLCA-T's C: every condition paired but L and R in the fail-safe invariants, which hold at every step (a
    # valid sample with L true and alone deciding would break fail-safe-left)
    for module, mcdc in (("mlca", None), ("mlca_t", (83, 85))):
        doc = json.loads((written / module / "coverage.json").read_text(encoding="utf-8"))
        assert doc["host"]["passed"] and doc["target"]["agrees"], module
        assert doc["target"]["lines"] == doc["target"]["host_lines"] > 50
        python, c = doc["coverage"]
        assert python["passed"] and c["passed"]
        assert all(g["reason"] for g in python["gaps"] + c["gaps"]), module  # every gap traced to z3's reason
        assert c["statements"]["percent"] == 100.0
        if mcdc is not None:
            assert (c["mcdc"]["covered"], c["mcdc"]["total"]) == mcdc  # clang's own MC/DC measurement
        assert all(e["reason"] for e in doc["exceptions"])
    boolean = json.loads((written / "mlca" / "coverage.json").read_text(encoding="utf-8"))
    assert boolean["coverage"][0]["statements"]["percent"] == boolean["coverage"][0]["branches"]["percent"] == 100.0


@pytest.mark.slow
def test_the_written_files_are_valid_and_byte_stable(written: Path, tmp_path: Path) -> None:
    assert main(["tests", "spec/mlca_t.toml", "--out", str(tmp_path), "--no-coverage", "--no-target"]) == 0
    for name in ("test_mlca_t_mcdc.py", "mlca_t_mcdc.c", "objectives.json"):
        assert (tmp_path / "mlca_t" / name).read_bytes() == (written / "mlca_t" / name).read_bytes(), name
    log = json.loads((written / "mlca_t" / "uncovered.sarif").read_text(encoding="utf-8"))
    jsonschema.validate(log, json.loads((SCHEMAS / "sarif-2.1.0-core.schema.json").read_text(encoding="utf-8")))
    assert {r["ruleId"] for r in log["runs"][0]["results"]} == {"mcdc-no-pair", "code-gap"}
    assert (written / "mlca_t" / "cobertura-c.xml").read_text(encoding="utf-8").count("<line ") > 150
    assert 'filename="mlca_t_fsm.py"' in (written / "mlca_t" / "cobertura-python.xml").read_text(encoding="utf-8") or (
        "mlca_t_fsm.py" in (written / "mlca_t" / "cobertura-python.xml").read_text(encoding="utf-8")
    )


MUTANTS = {  # a slip the suite must catch, in each language
    "mlca_t_fsm.py": ("elif (i.U and _def_L(c, i, p)):", "elif (i.U or _def_L(c, i, p)):"),
    "mlca_t_fsm.c": ("} else if ((i->U && mlca_t_def_L(c, i, p))) {", "} else if ((i->U || mlca_t_def_L(c, i, p))) {"),
}


@pytest.mark.slow
def test_the_python_suite_fails_on_a_mutant(written: Path, tmp_path: Path) -> None:
    test = written / "mlca_t" / "test_mlca_t_mcdc.py"
    ok = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(test)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert ok.returncode == 0, ok.stdout[-2000:]
    source = (ROOT / "generated/python/mlca_t_fsm.py").read_text(encoding="utf-8")
    old, new = MUTANTS["mlca_t_fsm.py"]
    assert old in source
    mutant = tmp_path / "mutant_fsm.py"
    mutant.write_text(source.replace(old, new), encoding="utf-8")
    env = {**os.environ, "MLCA_T_FSM": str(mutant)}
    bad = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(test)],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    assert bad.returncode == 1 and " failed" in bad.stdout


@pytest.mark.slow
def test_the_c_suite_fails_on_a_mutant(written: Path, tmp_path: Path) -> None:
    source = (ROOT / "generated/c/mlca_t_fsm.c").read_text(encoding="utf-8")
    old, new = MUTANTS["mlca_t_fsm.c"]
    assert old in source
    (tmp_path / "mlca_t_fsm.c").write_text(source.replace(old, new), encoding="utf-8")
    shutil.copy(ROOT / "generated/c/mlca_t_fsm.h", tmp_path)
    exe = tmp_path / "runner"
    built = subprocess.run(
        [
            "gcc",
            "-std=c99",
            f"-I{tmp_path}",
            "-o",
            str(exe),
            str(written / "mlca_t" / "mlca_t_mcdc.c"),
            str(tmp_path / "mlca_t_fsm.c"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert built.returncode == 0, built.stderr
    ran = subprocess.run([str(exe)], capture_output=True, text=True, check=False)
    assert ran.returncode == 1
    assert "FAIL" in ran.stdout and not ran.stdout.splitlines()[-1].endswith(" 0 failed")


# --- units and errors ---------------------------------------------------------------------------------------------


def test_first_difference_names_the_line() -> None:
    assert first_difference(["a 1", "b 2"], ["a 1", "b 2"]) == ""
    assert first_difference(["a 1", "b 2"], ["a 1", "b 3"]) == "line 2: host 'b 2', target 'b 3'"
    assert first_difference(["a"], ["a", "b"]) == "host printed 1 lines, target 2"


def test_cobertura_counts_lines_and_branches() -> None:
    lcov = "SF:x.c\nDA:1,3\nDA:2,0\nBRDA:1,0,0,2\nBRDA:1,0,1,-\nend_of_record\n"
    xml = cobertura_from_lcov(lcov, "x.c")
    assert 'lines-covered="1"' in xml and 'lines-valid="2"' in xml
    assert 'condition-coverage="50% (1/2)"' in xml and 'branch-rate="0.5000"' in xml


def test_a_depth_out_of_range_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tests", "spec/mlca.toml", "--out", str(tmp_path), "--depth", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["mlca-verify tests: error: argument --depth: must be from 1 to 1000, got 0"]


def test_a_machine_of_other_semantics_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "any.toml"
    text = (
        (ROOT / "spec/mlca.toml")
        .read_text(encoding="utf-8")
        .replace('semantics = "first-match"', 'semantics = "any-enabled"')
    )
    spec.write_text(text, encoding="utf-8")
    assert main(["tests", str(spec), "--out", str(tmp_path / "out"), "--generated", str(tmp_path)]) == 2
    assert "first-match" in capsys.readouterr().err


def test_missing_generated_code_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tests", "spec/mlca.toml", "--out", str(tmp_path), "--generated", str(tmp_path / "none")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "generated code not found" in err[0]


def test_decisions_follow_the_code() -> None:
    m = load_spec(ROOT / "spec/mlca_t.toml").machine
    ids = {o.decision.id for o in objectives(m)}
    assert {"guard:IDLE:urgent_left", "valid:L", "def:L", "def:W", "inv:deferral", "choice:every:waited#1"} <= ids
    assert not any(i.startswith("chain:") for i in ids)  # the monitor checks each invariant apart
    boolean = load_spec(ROOT / "spec/mlca.toml").machine
    found = {o.decision.id: o.decision for o in objectives(boolean)}
    assert {"inv:A1", "inv:A2", "guard:IDLE:idle_wait"} <= set(found)  # the same code: the same decisions
    assert found["inv:A2"].given == () and not any(i.startswith("chain:") for i in found)


SMALL = """[machine]
name = "H"
initial = "A"
states = ["A", "B"]
cite = "test"
[inputs]
go = { doc = "go", cite = "test" }
[params]
P = { type = "real", default = 1.5, range = [0.25, 2.0], unit = "m", doc = "p", cite = "test" }
[signals]
d = { type = "real", unit = "m", range = [0.0, 10.0], doc = "a distance", cite = "test" }
[definitions]
near = { expr = "d < P", doc = "near", cite = "test" }
[[transition]]
id = "t"
from = "A"
to = "B"
when = "go and near"
cite = "test"
"""


@pytest.mark.slow
def test_a_machine_without_invariants_or_outputs_and_a_state_without_decisions(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Empty parts (no monitor call, no output, a state no guard is read in) still make valid suites, and the
    state is stepped from, which statement coverage asks."""
    spec = tmp_path / "h.toml"
    spec.write_text(SMALL, encoding="utf-8")
    assert main(["gen", str(spec), "--out", str(tmp_path / "gen")]) == 0
    assert main(["tests", str(spec), "--generated", str(tmp_path / "gen"), "--out", str(tmp_path / "t")]) == 0
    out = capsys.readouterr().out
    assert "python pass  h_fsm.py: statements 100.0% (58/58), branches 100.0% (10/10)" in out
    assert "MC/DC 100.0% (6/6)" in out and "every line as on the host" in out


def test_a_definition_is_read_where_the_short_circuit_reaches_it() -> None:
    from mlca_verify.model import Var, nodes
    from mlca_verify.testgen.definition_reads import paths

    a, b, c = Var("a"), Var("L"), Var("c")
    assert paths(BinOp("and", a, b), "L") == [(a,)]
    assert paths(BinOp("or", a, b), "L") == [(Not(a),)]
    assert paths(BinOp("and", b, c), "L") == [()]
    assert paths(Not(BinOp("->", a, BinOp("and", c, b))), "L") == [(a, c)]
    m = load_spec(ROOT / "spec/mlca_t.toml").machine
    given = {o.decision.id: o.decision.given for o in objectives(m)}
    read, checks = given["def:L"]  # L is read where a guard reaches it, its rule once its samples are valid
    assert StateIn(("MOVING_LEFT",)) in set(nodes(read)) and Var("U") in set(nodes(read))
    assert given["valid:L"] == (read,) and Var("v") in set(nodes(checks))


ACC_C = """/* fast_enough: speed >= V_MIN (corpus) */
/*@ requires \\valid_read(c);
  @ assigns \\nothing;
  @*/
static bool accmodes_def_fast_enough(const accmodes_ctx_t *c, const accmodes_inputs_t *i, const accmodes_params_t *p)
{
    (void)c;
    (void)i;
    (void)p;
    return ((((0.0 <= i->speed) && (i->speed <= 70.0))) ? (i->speed >= p->V_MIN) : false);
}
static int64_t accmodes_min_i(int64_t r, int64_t a) { return (a < r) ? a : r; }
static int64_t accmodes_max_i(int64_t r, int64_t a) { return (a > r) ? a : r; }
"""


def test_a_gap_in_a_definition_or_a_shared_helper_has_its_reason() -> None:
    """A gap deep in a definition's function takes the reasons of that definition's conditions without a pair
    (its validity gate is decided earlier in the chain); a saturation branch of the shared min helper names the
    spec's calls of min; a helper the spec never calls gets no reason."""
    from mlca_verify.testgen.explain import Reach, explain
    from mlca_verify.testgen.measure import Gap

    m = load_spec(ROOT / "tests/machines/acc_modes_50hz.toml").machine
    valid = next(o for o in objectives(m) if o.id == "valid:fast_enough#1")
    pairs = [Pair(valid, form="none", reason="no step in any state has it")]
    gaps = [Gap(10, "branch at column 15 never false"), Gap(12, "branch never true"), Gap(13, "branch never true")]
    reasons = explain(gaps, ACC_C, m, pairs, reach=Reach(30))
    assert reasons[0] == "0.0 <= speed in valid:fast_enough: no step in any state has it"
    assert reasons[1].startswith("the shared min helper takes this branch only where one of the spec's min(...)")
    assert "min(hold + 1, 1000)" in reasons[1] and "(at most 30 steps)" in reasons[1]
    assert reasons[2] == ""


def test_what_clang_leaves_out_of_mcdc_is_noted_at_its_line() -> None:
    """clang 19 warns, and measures nothing, where a boolean expression nests one inside an operator (the monitor's
    `!(a && b) || c`): the report counts them, each at its place, instead of one note for all."""
    from mlca_verify.testgen.measure import mcdc_notes

    said = (
        "gen/c/r_fsm.c:580:25: warning: unsupported MC/DC boolean expression; contains an operation with a nested "
        "boolean expression. Expression will not be covered\n"
        "  580 |     const bool holds4 = ((!(a && b)) || c);\n"
        "gen/c/r_fsm.c:581:25: warning: unsupported MC/DC boolean expression; contains an operation with a nested "
        "boolean expression. Expression will not be covered\n"
        "runner.c:12:3: warning: unsupported MC/DC boolean expression; contains an operation with a nested "
        "boolean expression. Expression will not be covered\n"
        "gen/c/r_fsm.c:9:1: warning: unused variable 'x'\n"
    )
    notes = mcdc_notes(said, Path("gen/c/r_fsm.c"))
    assert [n.split(": ")[0] for n in notes] == ["r_fsm.c:580:25", "r_fsm.c:581:25"]
    assert all("Expression will not be covered" in n for n in notes)
