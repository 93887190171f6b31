"""Generated code of machines with data: MLCA-T's Python and C agree bit for bit with each other and with z3's
semantics of the spec, a planted off-by-one in both languages is caught, hostile spec text stays in comments
and strings, and the embedding examples build for the host and the Cortex-M4."""

from __future__ import annotations

import ast
import itertools
import math
import os
import random
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.codegen import generate, machine_ir, write
from mlca_verify.codegen.widths import narrow, output_bounds
from mlca_verify.conformance import conform
from mlca_verify.conformance.c_tools import WP, wp_guard_s
from mlca_verify.conformance.generated_code import WP_FLAGS
from mlca_verify.errors import SpecError
from mlca_verify.layout import Layout
from mlca_verify.loading import (
    FIRED_MASK,
    FIRED_SHIFT,
    PythonMachine,
    build_c,
    flag_definitions,
    import_generated,
)
from mlca_verify.spec import load_spec
from mlca_verify.tools import C_FLAGS
from tests.c_text import c_function
from tests.conftest import ROOT
from tests.test_random_bool_findings import SAME_END

GENERATED = ROOT / "generated"
SPEC = ROOT / "spec" / "mlca_t.toml"


def _module() -> object:
    return import_generated(GENERATED / "python" / "mlca_t_fsm.py", "_test_mlca_t_fsm")


def _inputs(py: object, **changes: object) -> object:
    values = {
        "N": True,
        "U": False,
        "v": 25.0,
        "gap_lead_left": 1000.0,
        "gap_follow_left": 110.0,  # RSS asks for 106.1 m from a follower at 27 m/s behind the AV at 25 m/s
        "v_follow_left": 27.0,
        "v_lead_left": 25.0,
        "gap_lead_right": 1000.0,
        "gap_follow_right": 1000.0,
        "v_follow_right": 0.0,
        "v_lead_right": 0.0,
    }
    values.update(changes)
    return py.Inputs(**values)  # type: ignore[attr-defined]


def test_generated_python_defers_then_moves_and_fails_safe_on_nan() -> None:
    py = _module()
    ctx = py.Context()  # type: ignore[attr-defined]
    modes = []
    for _ in range(22):
        py.step(ctx, _inputs(py))  # type: ignore[attr-defined]
        modes.append(py.State(ctx.mode).name)  # type: ignore[attr-defined]
    t_min = py.DEFAULT_PARAMS.T_MIN  # type: ignore[attr-defined]
    assert modes[:t_min] == ["WAITING"] * t_min  # deferred for T_MIN steps
    assert modes[t_min] == "MOVING_LEFT"
    out = py.step(ctx, _inputs(py, v_follow_left=math.nan))  # type: ignore[attr-defined]
    assert py.State(ctx.mode).name == "IDLE" and out.command == 0  # type: ignore[attr-defined]


def test_a_boolean_machine_gets_the_one_api_with_its_enum_and_inputs_unchanged() -> None:
    """The repair, a machine without data, goes through the one pipeline: a context that is its mode alone,
    empty params and outputs, the step and the monitor over pointers; the enum, its constants and the inputs
    struct are the ones its callers used before (the README's note on what changed)."""
    spec = load_spec(ROOT / "spec" / "mlca_r.toml", compare=False)
    files = generate(spec, GENERATED)
    for rel, text in files.items():
        assert (GENERATED / rel).read_text() == text
    header = files["c/mlca_r_fsm.h"]
    for kept in ("MLCA_R_IDLE = 0,", "#define MLCA_R_INITIAL MLCA_R_IDLE", "    bool N; /*", "} mlca_r_inputs_t;"):
        assert kept in header, kept
    start = header.index("typedef struct {\n    mlca_r_state_t mode;")
    assert header[start : header.index("} mlca_r_ctx_t;")].count(";") == 1  # the mode, and nothing else
    assert (
        "void mlca_r_step(mlca_r_ctx_t *c, const mlca_r_inputs_t *i, const mlca_r_params_t *p, mlca_r_outputs_t *o);"
        in header
    )


@pytest.mark.slow
def test_wp_refutes_a_transition_that_fires_in_the_wrong_order(tmp_path: Path) -> None:
    """The behaviours come from the spec, not from the code: a C `fired` that checks wait_right before
    wait_left (both enabled when both gaps are safe) fails the wait_left behaviour."""
    source = (GENERATED / "c" / "mlca_t_fsm.c").read_text()
    left = "        fired = 5;\n"
    right = "        fired = 6;\n"
    assert source.count(left) == 1 and source.count(right) == 1
    mutated = source.replace(left, "@@").replace(right, left).replace("@@", right)
    (tmp_path / "mlca_t_fsm.c").write_text(mutated)
    shutil.copy2(GENERATED / "c" / "mlca_t_fsm.h", tmp_path)
    # as conform runs it (its steps), on the behaviours asked about: the swapped one and the two urgent ones
    behaviours = "WAITING__4_wait_left,WAITING__2_urgent_left,WAITING__3_urgent_right"
    guard = ("-wp-timeout", str(wp_guard_s(WP_FLAGS)))
    flags = [*WP, *guard, *WP_FLAGS, "-wp-par", "2", "-wp-fct", "mlca_t_fired_WAITING", "-wp-bhv", behaviours]
    ran = subprocess.run(
        [*flags, str(tmp_path / "mlca_t_fsm.c")],
        check=False,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    unproved = {
        line.split(" Goal ")[1].split(" ")[0]: line
        for line in ran.stdout.splitlines()
        if " Goal " in line and "Valid" not in line
    }
    assert "typed_mlca_t_fired_WAITING_WAITING_4_wait_left_ensures" in unproved, ran.stdout[-2000:]
    proved = [line for line in ran.stdout.splitlines() if " Goal " in line and "Valid" in line]
    assert sum("urgent" in line for line in proved) == 2, ran.stdout[-2000:]  # both urgent behaviours were asked
    # the urgent behaviours still hold: a budget of steps, not of seconds, decides each goal, so load cannot fail one
    assert not any("urgent" in goal for goal in unproved), unproved


@pytest.mark.slow
def test_an_off_by_one_in_both_languages_is_caught_by_the_spec(tmp_path: Path) -> None:
    """Python and C agree with each other here; only the comparison with z3's semantics can catch it."""
    copy = tmp_path / "generated"
    shutil.copytree(GENERATED, copy)
    for rel, old, new in (
        ("c/mlca_t_fsm.c", "(c->waited < p->T_MIN)", "(c->waited <= p->T_MIN)"),
        ("python/mlca_t_fsm.py", "(c.waited < p.T_MIN)", "(c.waited <= p.T_MIN)"),
    ):
        text = (copy / rel).read_text()
        assert old in text
        (copy / rel).write_text(text.replace(old, new))
    outcomes = conform(load_spec(SPEC, compare=False), copy, ["exhaustive"], lambda _: None).outcomes
    exhaustive = next(o for o in outcomes if o.name == "exhaustive")
    assert not exhaustive.ok and "the spec (z3)" in exhaustive.detail


def test_hostile_text_in_a_data_spec_stays_in_comments_and_strings(tmp_path: Path) -> None:
    text = SPEC.read_text().replace(
        'doc = "the AV\'s speed"', 'doc = "*/ int evil; /* \\"\\"\\" import os #\\n\\u0000 ??="'
    )
    spec_file = tmp_path / "mlca_t.toml"
    spec_file.write_text(text)
    files = generate(load_spec(spec_file, compare=False), tmp_path / "generated")
    ast.parse(files["python/mlca_t_fsm.py"])
    out = tmp_path / "generated"
    for rel, body in files.items():
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text(body)
    done = subprocess.run(
        ["gcc", *C_FLAGS, "-c", "-o", str(tmp_path / "x.o"), str(out / "c" / "mlca_t_fsm.c")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert (
        "int evil"
        not in subprocess.run(
            ["gcc", "-E", "-P", str(out / "c" / "mlca_t_fsm.c")], capture_output=True, text=True, check=True
        ).stdout
    )


def test_embedding_examples_build_and_run(tmp_path: Path) -> None:
    main_c = ROOT / "docs" / "examples" / "mlca_t_main.c"
    fsm_c = GENERATED / "c" / "mlca_t_fsm.c"
    host = tmp_path / "fw"
    cc = ["gcc", *C_FLAGS, f"-I{GENERATED / 'c'}", "-o", str(host), str(main_c), str(fsm_c)]
    subprocess.run(cc, check=True)
    assert subprocess.run([str(host)], check=False).returncode == 0
    arm = ["arm-none-eabi-gcc", *C_FLAGS, "-mcpu=cortex-m4", "-mthumb", "-Os", "--specs=nosys.specs"]
    subprocess.run([*arm, f"-I{GENERATED / 'c'}", "-o", str(tmp_path / "fw.elf"), str(main_c), str(fsm_c)], check=True)
    loop = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "examples" / "mlca_t_loop.py")], capture_output=True, text=True, check=True
    )
    assert "tick 25: MOVING_LEFT  command +1" in loop.stdout
    assert "tick 30: IDLE         command +0" in loop.stdout
    page = (ROOT / "docs" / "reference" / "generated-code.md").read_text(encoding="utf-8")
    assert f"```text\n{loop.stdout}```" in page  # the page shows what it prints, whole


def _red_then_green(tmp_path: Path, buggy: Path, test_py: Path, test_c: Path) -> None:
    """The emitted tests fail on the code generated from the buggy spec and pass on MLCA-T's."""
    pytest_cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(test_py)]
    assert subprocess.run(pytest_cmd, capture_output=True, check=False).returncode == 1
    env = {**os.environ, "MLCA_T_FSM": str(GENERATED / "python" / "mlca_t_fsm.py")}
    assert subprocess.run(pytest_cmd, capture_output=True, check=False, env=env).returncode == 0
    for folder, expected in ((buggy / "c", 1), (GENERATED / "c", 0)):
        exe = tmp_path / f"{test_c.stem}{expected}"
        subprocess.run(["gcc", *C_FLAGS, "-ffp-contract=off", f"-I{folder}", "-o", str(exe), str(test_c)], check=True)
        assert subprocess.run([str(exe)], capture_output=True, check=False).returncode == expected


def test_emitted_tests_are_red_on_the_buggy_code_and_green_on_the_repaired(tmp_path: Path) -> None:
    """The planted fast timer: its counterexample (with its signals and T_MIN = 3) becomes a pytest and a C test
    that fail on the code generated from the buggy spec and pass on MLCA-T's."""
    fixture = ROOT / "tests" / "fixtures" / "mlca_t_fast_timer.toml"
    buggy, out = tmp_path / "buggy", tmp_path / "emitted"
    assert main(["gen", str(fixture), "--out", str(buggy)]) == 0
    assert main(["check", str(fixture), "--quiet", "--emit-tests", str(out), "--generated", str(buggy)]) == 1
    _red_then_green(tmp_path, buggy, out / "test_mlca_t_deferral.py", out / "test_mlca_t_deferral.c")


def test_an_emitted_liveness_test_catches_a_livelock(tmp_path: Path) -> None:
    """Without Alg. 1's repair (no move out of WAITING once the timer has run out) a need with a safe gap waits
    forever: the bounded response `no-livelock` (within T_MIN + 2) fails, and its counterexample, replayed with
    the response counted as the engine counts it, is red on that code and green on MLCA-T's."""
    text = SPEC.read_text()
    for tid in ("wait_left", "wait_right"):
        start = text.index(f'[[transition]]\nid = "{tid}"')
        text = text[:start] + text[text.index("[[transition]]", start + 1) :]
    spec = tmp_path / "mlca_t.toml"
    spec.write_text(text)
    buggy, out = tmp_path / "buggy", tmp_path / "emitted"
    assert main(["gen", str(spec), "--out", str(buggy)]) == 0
    assert main(["check", str(spec), "--quiet", "--emit-tests", str(out), "--generated", str(buggy)]) == 1
    test_py = out / "test_mlca_t_no_livelock.py"
    assert "BOUND = " in test_py.read_text()
    _red_then_green(tmp_path, buggy, test_py, out / "test_mlca_t_no_livelock.c")


def test_one_rule_over_different_signals_is_generated_once() -> None:
    from mlca_verify.codegen.shapes import shared_shapes

    machine = load_spec(SPEC, compare=False).machine
    shapes, uses = shared_shapes(machine)
    assert len(shapes) == 4
    assert {name: use.shape for name, use in uses.items()} == {
        "reach_av": 0,
        "reach_follow_left": 0,
        "reach_follow_right": 0,
        "stop_av": 1,
        "stop_lead_left": 1,
        "stop_lead_right": 1,
        "L": 2,
        "R": 2,
        "rss_lead_left": 3,
        "rss_follow_left": 3,
        "rss_lead_right": 3,
        "rss_follow_right": 3,
    }
    assert uses["L"].signals == ("gap_lead_left", "v", "v_lead_left", "gap_follow_left", "v_follow_left")
    assert "W" not in uses  # it reads a variable and an input: not a rule over samples
    c = (GENERATED / "c" / "mlca_t_fsm.c").read_text()
    assert c.count("static bool mlca_t_shape2(") == 1
    assert "mlca_t_shape2(i->gap_lead_right, i->v, i->v_lead_right, i->gap_follow_right, i->v_follow_right, p)" in c
    assert "mlca_t_shape3" not in c  # the lemmas' rule is not code: no transition reads it


SMALL = """
[machine]
name = "Pump"
initial = "OFF"
states = ["OFF", "ON"]

[inputs]
start = { doc = "start pressed" }

[signals]
level = { type = "int", unit = "cm", range = [0, 50], doc = "water level" }

[variables]
run = { type = "int", initial = 0, range = [0, 9], unit = "step", every = "min(run + 1, 9)", doc = "steps on" }

[definitions]
dry = { expr = "level < 5", if_invalid = true, doc = "too little water to pump" }

[[transition]]
from = "OFF"
to = "ON"
when = "start and not dry"
do = "run = 0"

[[transition]]
from = "ON"
to = "OFF"
when = "dry or run >= 9"
"""


@pytest.mark.slow
def test_a_machine_without_params_outputs_or_invariants_generates_clean_code(tmp_path: Path) -> None:
    """No params, no outputs, no invariants, an int signal: the code still compiles without a warning, passes
    cppcheck's MISRA addon, and agrees with the spec."""
    spec = tmp_path / "pump.toml"
    spec.write_text(SMALL)
    assert main(["gen", str(spec), "--out", str(tmp_path / "generated")]) == 0
    checks = ["compile", "exhaustive", "sequences", "sanitizers", "cppcheck", "cortex-m4"]
    outcomes = conform(load_spec(spec, compare=False), tmp_path / "generated", checks, lambda _: None).outcomes
    assert all(o.ok for o in outcomes), [(o.name, o.detail[:300]) for o in outcomes if not o.ok]


LASSO = """[machine]
name = "LOOPY"
initial = "A"
states = ["A", "B"]
[inputs]
go = {{ doc = "go" }}
[variables]
t = {{ type = "int", initial = 0, range = [0, 3], every = "0", doc = "always 0" }}
[[transition]]
id = "leave"
from = "A"
to = "B"
when = "{when}"
[[liveness]]
id = "leaves"
assume = "go"
goal = "state == B"
"""


def test_an_emitted_lasso_test_catches_a_response_that_never_comes(tmp_path: Path) -> None:
    """An unbounded response violated by a lasso (the loop repeated three times in the replay): red on the code
    whose guard can never hold, green on the code whose guard is the assumption."""
    emitted = tmp_path / "emitted"
    for name, when in (("buggy", "go and t > 2"), ("fixed", "go")):
        spec = tmp_path / f"{name}.toml"
        spec.write_text(LASSO.format(when=when))
        assert main(["gen", str(spec), "--out", str(tmp_path / name)]) == 0
        if name == "buggy":
            assert (
                main(["check", str(spec), "--quiet", "--emit-tests", str(emitted), "--generated", str(tmp_path / name)])
                == 1
            )
    test_py, test_c = emitted / "test_loopy_leaves.py", emitted / "test_loopy_leaves.c"
    assert "CHECK_FROM = " in test_py.read_text() and "BOUND" not in test_py.read_text()
    pytest_cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(test_py)]
    assert subprocess.run(pytest_cmd, capture_output=True, check=False).returncode == 1
    env = {**os.environ, "LOOPY_FSM": str(tmp_path / "fixed" / "python" / "loopy_fsm.py")}
    assert subprocess.run(pytest_cmd, capture_output=True, check=False, env=env).returncode == 0
    for name, expected in (("buggy", 1), ("fixed", 0)):
        exe = tmp_path / f"lasso_{name}"
        cc = ["gcc", *C_FLAGS, "-ffp-contract=off", f"-I{tmp_path / name / 'c'}", "-o", str(exe), str(test_c)]
        subprocess.run(cc, check=True)
        assert subprocess.run([str(exe)], capture_output=True, check=False).returncode == expected


def test_prev_of_an_output_is_generated_and_agrees_with_the_spec(tmp_path: Path) -> None:
    """`check` accepts prev() of an output, so `gen` does too: the register keeps what the output computes, and the
    generated monitor agrees with z3's semantics on every mode, input and first-step flag."""
    text = (ROOT / "tests" / "fixtures" / "boolean_terms.toml").read_text()
    spec_path = tmp_path / "bt.toml"
    spec_path.write_text(
        text + '[[invariant]]\nid = "agree-kept"\nexpr = "prev(agree) -> agree"\nexpect = "violated"\n'
    )
    spec = load_spec(spec_path, compare=False)
    assert main(["gen", str(spec_path), "--out", str(tmp_path / "gen")]) == 0
    assert main(["gen", "--check", str(spec_path), "--out", str(tmp_path / "gen")]) == 0
    outcomes = conform(spec, tmp_path / "gen", ["exhaustive", "sequences"], lambda _: None).outcomes
    assert all(o.ok for o in outcomes), [o.detail for o in outcomes if not o.ok]
    assert "agree-kept (not proved (violated)) fails" in next(o for o in outcomes if o.name == "sequences").detail


CONVEYOR = ROOT / "tests" / "fixtures" / "conveyor_stop.toml"


def test_a_context_that_is_its_mode_alone_is_stepped_directly(tmp_path: Path) -> None:
    """The conveyor keeps no variable and no prev(): its context is the mode, with no first-step flag; its step
    tests the emergency stop (from every mode to the fallback one) once, before the modes, and writes the next
    mode itself. MLCA-T, with timers and prev(), keeps both the flag and the transition's number."""
    files = generate(load_spec(CONVEYOR), tmp_path / "generated")
    header, source = files["c/conveyor_fsm.h"], files["c/conveyor_fsm.c"]
    context = header[header.index("typedef struct {\n    conveyor_state_t mode;") :]
    assert "bool first;" not in context[: context.index("} conveyor_ctx_t;")]
    step = c_function(source, "void conveyor_step(")
    assert step.index("if (i->stop) {") < step.index("(mode == CONVEYOR_HALTED)")
    assert "fired" not in step and "next.mode = conveyor_to_RUNNING(c, i, p);" in step
    creeping = c_function(source, "static conveyor_state_t conveyor_to_CREEPING(")
    assert "i->stop" not in creeping  # the hoisted test is not repeated in the mode's chain
    # its contract states the relation mode by mode (WP's goals then hold one mode each), not through the
    # function over every mode
    contract = source[source.rindex("/*@ requires", 0, source.index("\nvoid conveyor_step(")) :]
    contract = contract[: contract.index("@*/")]
    machine = load_spec(CONVEYOR).machine
    for state in machine.states:
        assert f"@ behavior in_{state}:\n  @   assumes c->mode == CONVEYOR_{state};" in contract
        assert f"conveyor_first_{state}(\\old(*c), *i, *p), *c);" in contract
    assert "conveyor_first(" not in contract and "@ complete behaviors;\n  @ disjoint behaviors;" in contract
    kept = generate(load_spec(SPEC), tmp_path / "generated")
    assert "const int fired = mlca_t_fired(c, i, p);" in c_function(kept["c/mlca_t_fsm.c"], "void mlca_t_step(")


PUMP = ROOT / "tests" / "machines" / "pump_debounce_1khz.toml"


def test_a_machine_whose_transitions_change_the_mode_alone_is_stepped_directly(tmp_path: Path) -> None:
    """The pump's counter follows its `every` rule whatever fires: the step makes that update once, before the
    modes are told apart, and each mode's chain yields the next mode, reading `hot` as computed once. A
    transition that also resets the counter needs the transition's number again."""
    files = generate(load_spec(PUMP), tmp_path / "pump")
    step = c_function(files["c/pumpdebounce_fsm.c"], "void pumpdebounce_step(")
    assert "fired" not in step and "pumpdebounce_once(c, i, p, &once);" in step
    assert step.index("next.count = ") < step.index("(mode == PUMPDEBOUNCE_RUNNING)")
    assert "next.mode = pumpdebounce_to_RUNNING(c, i, p, d);" in step
    running = c_function(files["c/pumpdebounce_fsm.c"], "static pumpdebounce_state_t pumpdebounce_to_RUNNING(")
    assert "d->hot" in running and "pumpdebounce_def_hot(" not in running
    text = PUMP.read_text(encoding="utf-8").replace('to = "TRIPPED"\n', 'to = "TRIPPED"\ndo = "count = 0"\n')
    (tmp_path / "reset.toml").write_text(text, encoding="utf-8")
    numbered = generate(load_spec(tmp_path / "reset.toml", compare=False), tmp_path / "reset")
    assert "const int fired = pumpdebounce_fired(c, i, p, d);" in c_function(
        numbered["c/pumpdebounce_fsm.c"], "void pumpdebounce_step("
    )


def test_the_c_adapter_of_a_direct_step_with_variables_reports_what_the_python_one_does(tmp_path: Path) -> None:
    """The pump's direct step computes `hot` once for its chains; the C adapter, which finds the transition by
    the step's own tests, computes it too. Both answers agree over runs that trip the pump, reset it and feed it
    invalid samples, and every transition is seen."""
    spec = load_spec(PUMP)
    out = tmp_path / "generated"
    write(generate(spec, out), out)
    ir = machine_ir(spec, out)
    layout = Layout(out, ir.module)
    py = PythonMachine(import_generated(layout.python, "_test_pump_direct"), flag_definitions(ir))
    c = build_c(layout, ir, tmp_path, "_test_pump_direct_c")
    py_ctx, c_ctx = py.context(), c.context()
    rng = random.Random(11)
    fired = set()
    for _ in range(3):
        run = [(False, 100.0)] * 1001 + [(rng.random() < 0.5, rng.choice([20.0, 96.0, math.nan, 151.0]))
                                         for _ in range(40)] + [(True, 20.0)]  # fmt: skip
        for values in run:
            py_answer, c_answer = py.advance(py_ctx, *values), c.advance(c_ctx, *values)
            assert py_answer == c_answer, values
            fired.add((py_answer[0] >> FIRED_SHIFT) & FIRED_MASK)
    assert fired == {1, 2, 3}  # none (numbered 0, plus one), trip and reset_trip


def test_a_register_that_reads_the_context_alone_lives_in_the_monitor(tmp_path: Path) -> None:
    """MLCA-T's prev(state in {IDLE, WAITING}) is the mode before the step: the step neither keeps nor writes it
    (nor a first-step flag), and the monitor computes it from the context before the step, in C and in Python. A
    register of an input (boolean_terms' prev(hot)) must be kept: the context holds it and the step writes it."""
    files = generate(load_spec(SPEC), tmp_path / "mlca_t")
    header, source = files["c/mlca_t_fsm.h"], files["c/mlca_t_fsm.c"]
    context = header[header.index("typedef struct {\n    mlca_t_state_t mode;") : header.index("} mlca_t_ctx_t;")]
    assert "prev0" not in context and "first" not in context
    assert "prev0" not in c_function(source, "void mlca_t_step(") and "prev0" not in c_function(
        source, "void mlca_t_init("
    )
    assert "const bool prev0 = mlca_t_reg0(before, i, p);" in c_function(source, "void mlca_t_monitor(")
    assert "prev0 = _reg0(before, i, p)  #" in files["python/mlca_t_fsm.py"]
    kept = generate(load_spec(ROOT / "tests" / "fixtures" / "boolean_terms.toml"), tmp_path / "bt")
    header, source = kept["c/bt_fsm.h"], kept["c/bt_fsm.c"]
    assert "    bool prev0;" in header and "    bool first;" in header
    assert "next.prev0 = bt_reg0(&next, i, p);" in c_function(source, "void bt_step(")
    assert "before->first ? bt_reg0(before, i, p) : before->prev0" in c_function(source, "void bt_monitor(")


@pytest.mark.slow
def test_a_direct_step_passes_every_conform_check(tmp_path: Path) -> None:
    """The direct step, its hoisted stop and its context without a flag pass every check: WP proves the step
    against the same contract as the numbered one, and the extension still reports the transition that fired."""
    spec = tmp_path / "conveyor_stop.toml"
    shutil.copy(CONVEYOR, spec)
    assert main(["gen", str(spec), "--out", str(tmp_path / "generated")]) == 0
    checks = ["compile", "exhaustive", "sequences", "frama-c-wp", "cppcheck", "cortex-m4", "sanitizers"]
    outcomes = conform(load_spec(spec, compare=False), tmp_path / "generated", checks, lambda _: None).outcomes
    assert [o.name for o in outcomes if not o.ok] == [], [(o.name, o.detail[:300]) for o in outcomes if not o.ok]


def test_the_c_adapter_of_a_direct_step_reports_what_the_python_one_does(tmp_path: Path) -> None:
    """The closed loop reads the mode, the transition that fired and the boolean definitions from one packed
    answer; the direct step has no numbered transition, so its C adapter finds it by the step's own tests. Both
    answers agree at every step of a seeded run over every input and a spread of samples (NaN included)."""
    spec = load_spec(CONVEYOR)
    out = tmp_path / "generated"
    write(generate(spec, out), out)
    ir = machine_ir(spec, out)
    layout = Layout(out, ir.module)
    flags = flag_definitions(ir)
    py = PythonMachine(import_generated(layout.python, "_test_conveyor_direct"), flags)
    c = build_c(layout, ir, tmp_path, "_test_conveyor_direct_c")
    rng = random.Random(7)
    samples = [0.0, 0.1, 0.39, 0.4, 0.41, 2.5, 10.0, 11.0, -1.0, math.nan]
    py_ctx, c_ctx = py.context(), c.context()
    fired = set()
    for _ in range(400):
        values = (rng.random() < 0.1, rng.random() < 0.6, rng.choice(samples))
        py_answer, c_answer = py.advance(py_ctx, *values), c.advance(c_ctx, *values)
        assert py_answer == c_answer, values
        fired.add((py_answer[0] >> FIRED_SHIFT) & FIRED_MASK)
    assert fired == {1, 2, 3, 4, 5, 6}  # none (1: numbered 0, plus one) and each of the five transitions


def test_a_branch_the_step_leaves_out_is_still_reported_as_fired(tmp_path: Path) -> None:
    """`hold` and `back-on-a` go where their chains end anyway, so the C step leaves them out (cppcheck's
    duplicateBranch); the closed loop still counts them: the C adapter reports them as the Python does."""
    spec_path = tmp_path / "b.toml"
    spec_path.write_text(SAME_END, encoding="utf-8")  # `a and a`, `not (b or b)`: what tidy folds too
    spec, out = load_spec(spec_path), tmp_path / "generated"
    write(generate(spec, out), out)
    assert "/* hold:" not in generate(spec, out)["c/b_fsm.c"].split("b_to_S0(")[-1].split("\n}\n")[0]
    ir = machine_ir(spec, out)
    layout = Layout(out, ir.module)
    py = PythonMachine(import_generated(layout.python, "_test_b_dropped"), ())
    c = build_c(layout, ir, tmp_path, "_test_b_dropped_c")
    fired = set()
    for mode in (0, 1):
        for a, b in itertools.product((False, True), repeat=2):
            py_ctx, c_ctx = py.context(), c.context()
            py_ctx.mode = mode
            c_ctx[0:4] = mode.to_bytes(4, sys.byteorder)
            answer = py.advance(py_ctx, a, b)
            assert answer == c.advance(c_ctx, a, b), (mode, a, b)
            fired.add(((answer[0] >> FIRED_SHIFT) & FIRED_MASK) - 1)
    assert fired == {0, 1, 2, 3, 4}  # none, go, hold, back-on-a and back


def test_int_arithmetic_is_32_bits_wide_where_the_ranges_show_it_fits(tmp_path: Path) -> None:
    """MLCA-T's timers (0..1000) and T_MIN (1..100): its ints compute in int32_t, with plain literals, and its
    command, -1..1 without a declared range, is an int8_t. A sum that may leave 32 bits, or an int read without a
    32-bit range (here an int signal, whose invalid samples reach the code), keeps the whole machine in int64_t."""
    spec = load_spec(SPEC)
    assert narrow(spec.machine) and output_bounds(spec.machine) == {"command": (-1, 1)}
    files = generate(spec, tmp_path / "t")
    source, header = files["c/mlca_t_fsm.c"], files["c/mlca_t_fsm.h"]
    assert "static int32_t mlca_t_min_i(int32_t r, int32_t a)" in source and "INT64_C" not in source
    assert "next.waited = (int32_t)(mlca_t_min_i((c->waited + 1), 1000));" in source
    assert "    int8_t command;" in header
    text = (ROOT / "tests" / "fixtures" / "boolean_terms.toml").read_text(encoding="utf-8")
    wide = text.replace('range = [0, 20], every = "if hot then min(n + 1, 20) else 0"',
                        'range = [0, 2147483647], every = "if hot then min(n + 1, 2147483647) else 0"')  # fmt: skip
    assert wide != text
    (tmp_path / "wide.toml").write_text(wide, encoding="utf-8")
    machine = load_spec(tmp_path / "wide.toml", compare=False).machine
    assert not narrow(machine)  # n + 1 reaches 2**31
    source = generate(load_spec(tmp_path / "wide.toml", compare=False), tmp_path / "w")["c/bt_fsm.c"]
    assert "static int64_t bt_min_i(int64_t r, int64_t a)" in source and "INT64_C(1)" in source
    washer = load_spec(ROOT / "tests" / "machines" / "washer_10hz.toml").machine
    assert not narrow(washer)  # FILL_LEVEL - level, over an int signal


def test_a_definition_read_twice_on_every_path_is_computed_once(tmp_path: Path) -> None:
    """The pump's `hot` is read by the trip guard and by the counter's rule on every step: the step computes it
    once, into a field that both read. MLCA-T's `L` is read twice only when the need is urgent and no lane is safe
    (`urgent_left`, then `wait_left`), so it stays a call: computing it first would cost every deferring step. The
    flasher's `stride` is read twice by an `every` rule that its transitions override, so not on every path; the two
    cars' `a_hears` is read through `a_next`'s rule, whose function computes it."""
    corpus = ROOT / "tests" / "machines"
    pump = load_spec(corpus / "pump_debounce_1khz.toml")
    ir = machine_ir(pump, tmp_path)
    assert [(g.states, g.names, g.every) for g in ir.once] == [(("RUNNING", "TRIPPED"), ("hot",), True)]
    source = generate(pump, tmp_path / "p")["c/pumpdebounce_fsm.c"]
    step = source.split("void pumpdebounce_monitor(")[0]  # the monitor reads it over the context after the step
    assert step.count("pumpdebounce_def_hot(c, i, p)") == 1  # in pumpdebounce_once alone
    assert "if ((d->hot && (c->count >= (p->DEBOUNCE - 1))))" in source
    assert "next.count = (int32_t)((d->hot ? pumpdebounce_min_i((c->count + 1), 10000) : 0));" in source
    assert "ensures (((d->hot != 0) <==> pumpdebounce_l_hot(*i, *p)));" in source
    assert machine_ir(load_spec(SPEC), tmp_path).once == ()
    assert machine_ir(load_spec(corpus / "flasher_100hz.toml"), tmp_path).once == ()
    cars = machine_ir(load_spec(corpus / "two_cars_gap_10hz.toml"), tmp_path)
    assert {n for g in cars.once for n in g.names} == {"a_next", "b_next"}
    battery = machine_ir(load_spec(corpus / "battery_bms_10hz.toml"), tmp_path)
    assert [(g.states, g.every) for g in battery.once] == [(("OPEN", "PRECHARGE"), False)]
    text = generate(load_spec(corpus / "battery_bms_10hz.toml"), tmp_path / "b")["c/batterybms_fsm.c"]
    assert "if ((c->mode == BATTERYBMS_OPEN) || (c->mode == BATTERYBMS_PRECHARGE)) {" in text
    assert "d->in_window = false; /* not read in this mode */" in text


def test_the_header_says_where_binary64_becomes_helper_calls() -> None:
    """The header claims no call into a C library, and for a machine with reals it says that a core without a
    double-precision FPU turns binary64 into the compiler's helper calls (conform's cortex-m4 check lists them);
    Alg. 1, without reals, makes no such remark."""
    with_reals = (GENERATED / "c" / "mlca_t_fsm.h").read_text(encoding="utf-8")
    without = (GENERATED / "c" / "mlca_fsm.h").read_text(encoding="utf-8")
    assert "no call into a C library" in with_reals and "no call into a C library" in without
    assert "libgcc's __aeabi_d*" in with_reals and "binary64" not in without


def test_an_observer_lives_in_the_monitor_not_in_the_step(tmp_path: Path) -> None:
    """MLCA-T's need_age, declared `observer = true`, is read by the deferral invariant alone: the context has no
    need_age and the step neither stores nor updates it; `mlca_t_observers_t` holds it, and the monitor moves it
    on (from the context before the step) before it checks the invariants. In Python a run keeps it alike, and the
    deferral invariant fails when the observer says the need is younger than T_MIN."""
    header = (GENERATED / "c" / "mlca_t_fsm.h").read_text(encoding="utf-8")
    source = (GENERATED / "c" / "mlca_t_fsm.c").read_text(encoding="utf-8")
    context = header.split("} mlca_t_ctx_t;")[0].rsplit("typedef struct {", 1)[1]
    assert "waited" in context and "need_age" not in context
    assert "int32_t need_age;" in header.split("} mlca_t_observers_t;")[0].rsplit("typedef struct {", 1)[1]
    assert "mlca_t_observers_t *g,\n    bool failing[MLCA_T_FAILING]);" in header
    step = c_function(source, "void mlca_t_step(")
    assert "need_age" not in step
    monitor = c_function(source, "void mlca_t_monitor(")
    assert "mlca_t_observe(before, i, p, g, " in monitor and "(g->need_age > p->T_MIN)" in monitor
    module = import_generated(GENERATED / "python" / "mlca_t_fsm.py", "mlca_t_observed")
    ctx, seen = module.Context(), module.Observers()
    assert not hasattr(ctx, "need_age")
    calm = {"v": 20.0, "gap_lead_left": 1000.0, "gap_follow_left": 1000.0, "v_follow_left": 0.0, "v_lead_left": 0.0}
    calm |= {k.replace("left", "right"): v for k, v in calm.items()}
    for _ in range(3):  # the need holds: need_age counts the steps
        before = module.Context(**vars(ctx))
        inputs = module.Inputs(N=True, U=False, **calm)
        out = module.step(ctx, inputs)
        assert module.monitor(before, ctx, inputs, module.DEFAULT_PARAMS, out, seen) == []
    assert seen.need_age == 3 and ctx.mode == module.State.WAITING
    young = module.Context(mode=module.State.MOVING_LEFT, waited=ctx.waited)  # moved before T_MIN steps of need
    failing = module.monitor(ctx, young, inputs, module.DEFAULT_PARAMS, module.Outputs(command=1), seen)
    assert "deferral" in failing and seen.need_age == 4


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            ('when = "U and L"', 'when = "U and L and need_age > 0"'),
            "variable 'need_age' is an observer, but the guard of transition 'urgent_left' reads it",
        ),
        (
            ('every = "if N then min(need_age + 1, 1000) else 0"', 'every = "if N and RHO > 1.5 then 1 else 0"'),
            "variable 'need_age' is an observer, but it computes on reals",
        ),
    ],
)
def test_an_observer_that_a_step_reads_is_refused_at_its_key(
    edit: tuple[str, str], message: str, tmp_path: Path
) -> None:
    text = SPEC.read_text(encoding="utf-8")
    assert edit[0] in text
    (tmp_path / "t.toml").write_text(text.replace(edit[0], edit[1], 1), encoding="utf-8")
    with pytest.raises(SpecError) as info:
        load_spec(tmp_path / "t.toml")
    line = next(k for k, t in enumerate(text.splitlines(), 1) if t.startswith("need_age = {"))
    column = text.splitlines()[line - 1].index("observer = true") + len("observer = ") + 1  # at the key's value
    assert str(info.value).startswith(f"{tmp_path / 't.toml'}:{line}:{column}: error: {message}")
    assert "\n" not in str(info.value)
