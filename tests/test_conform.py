"""conform: the real compilers, prover and checkers on the shipped specs, on broken code, on random specs."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import tempfile
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings

from mlca_verify.cli import main
from mlca_verify.codegen import generate, machine_ir, write
from mlca_verify.codegen.render import TEMPLATE_DIR
from mlca_verify.conformance import conform
from mlca_verify.conformance.c_tools import cppcheck_file, external_calls, library_calls
from mlca_verify.conformance.generated_code import Subject, frama_c
from mlca_verify.conformance.outcome import CheckOutcome
from mlca_verify.layout import Layout
from mlca_verify.logic import check_all
from mlca_verify.model import Machine
from mlca_verify.spec import LoadedSpec, load_spec
from tests.conftest import ROOT
from tests.strategies import machines

FIXTURES = Path(__file__).parent / "fixtures"


def quiet(_: CheckOutcome) -> None:
    pass


@pytest.mark.slow
@pytest.mark.usefixtures("at_root")
def test_shipped_specs_pass_every_check(tmp_path: Path) -> None:
    out = tmp_path / "conform.json"
    assert main(["conform", "spec/mlca.toml", "spec/mlca_r.toml", "--json", str(out), "--sequences", "100"]) == 0
    doc = json.loads(out.read_text())
    assert doc["schema"] == "mlca-verify.conform/1"
    for spec in doc["specs"]:
        checks = {c["name"]: c for c in spec["checks"]}
        assert list(checks) == [
            "up-to-date",
            "compile",
            "exhaustive",
            "sequences",
            "frama-c-wp",
            "cppcheck",
            "cortex-m4",
            "sanitizers",
        ]
        assert all(c["ok"] for c in checks.values()), spec
        wp = checks["frama-c-wp"]["data"]
        # one goal per behaviour of each mode's own function (the modes told apart by an if chain)
        assert wp["proved"] == wp["goals"] > 80
        names = {g["goal"] for g in wp["goal_list"]}
        module = Path(spec["path"]).stem
        assert {f"typed_{module}_to_IDLE_IDLE_2_idle_wait_ensures", f"typed_{module}_restart_ensures"} <= names
        assert not any("_part" in n and "_to_" in n and "ensures" in n for n in names), "per-case split is back"
        machine = load_spec(spec["path"], compare=False).machine
        assert wp["certified"]["stated"] == [i.id for i in machine.invariants if i.expect == "holds"]
        assert checks["exhaustive"]["data"] == {"steps": 4 * 16, "restarts": 16}
        assert checks["cortex-m4"]["data"]["calls"] == []  # the README: no call out of the object
        assert checks["cortex-m4"]["data"]["stack"][f"{module}_step"] == 0


def _subject(c_text: str, build: Path) -> Subject:
    """A subject of Alg. 1 whose C source is `c_text`, the generated header and Python beside it."""
    spec = load_spec(ROOT / "spec/mlca.toml", compare=False)
    layout = Layout(build / "generated", "mlca")
    layout.c_source.parent.mkdir(parents=True)
    layout.python.parent.mkdir(parents=True)
    layout.c_source.write_text(c_text, encoding="utf-8")
    shutil.copy(ROOT / "generated" / "c" / "mlca_fsm.h", layout.c_header)
    shutil.copy(ROOT / "generated" / "python" / "mlca_fsm.py", layout.python)
    return Subject(spec.machine, machine_ir(spec, ROOT / "generated"), layout, build, sequences=100)


@pytest.mark.slow
def test_hand_broken_copy_fails_the_proof(tmp_path: Path) -> None:
    """IDLE's third branch (idle_left) edited to move right: WP finds the behaviour it breaks."""
    text = (ROOT / "generated" / "c" / "mlca_fsm.c").read_text()
    broken = text.replace("next = MLCA_MOVING_LEFT;", "next = MLCA_MOVING_RIGHT;", 1)
    assert broken != text
    outcome = frama_c(_subject(broken, tmp_path))
    assert not outcome.ok
    assert outcome.data["proved"] < outcome.data["goals"]
    assert any("IDLE_3_idle_left" in goal for goal in outcome.data["unproved"]), outcome.data["unproved"]


def test_cppcheck_runs_its_misra_addon(tmp_path: Path) -> None:
    outcome = cppcheck_file(FIXTURES / "misra_violation.c", tmp_path)
    assert not outcome.ok
    assert any("misra-c2012-15.1" in f for f in outcome.data["findings"]), outcome.data["findings"]


def _conform_with_templates(templates: Path, tmp_path: Path, checks: list[str]) -> dict[str, CheckOutcome]:
    spec = load_spec(ROOT / "spec/mlca.toml", compare=False)
    out = tmp_path / "generated"
    write(generate(spec, out, templates), out)
    result = conform(spec, out, checks, quiet, sequences=50, template_dir=templates)
    return {o.name: o for o in result.outcomes}


@pytest.mark.parametrize(
    ("template", "old", "new", "caught_by"),
    [
        ("c_fsm.c.j2", "        next = {{ M }}_{{ b.target }};\n{% endif %}\n{% endfor %}\n{% if case.code and not case.closes %}",
         "        next = {{ M }}_{{ b.target if not loop.last else m.initial }};\n{% endif %}\n{% endfor %}\n{% if case.code and not case.closes %}",
         "exhaustive"),
        ("python_fsm.py.j2", "nxt.mode = _TARGETS.get(fired, c.mode)", "nxt.mode = c.mode", "exhaustive"),
        ("c_fsm.c.j2", "    c->mode = {{ M }}_FALLBACK;", "    c->mode = {{ M }}_{{ m.states[-1] }};", "exhaustive"),
    ],
    ids=["C: last branch of each mode to the initial mode", "Python: every branch stays", "C: out-of-range to the wrong mode"],
)  # fmt: skip
def test_template_bug_is_caught_by_conform(template: str, old: str, new: str, caught_by: str, tmp_path: Path) -> None:
    templates = tmp_path / "codegen"
    shutil.copytree(TEMPLATE_DIR, templates)
    path = templates / template
    assert old in path.read_text()
    path.write_text(path.read_text().replace(old, new))
    outcomes = _conform_with_templates(templates, tmp_path, ["compile", "exhaustive", "sequences", "sanitizers"])
    assert outcomes["compile"].ok
    assert not outcomes[caught_by].ok, outcomes[caught_by].detail


@pytest.mark.slow
def test_template_bug_in_c_fails_the_proof_too(tmp_path: Path) -> None:
    templates = tmp_path / "codegen"
    shutil.copytree(TEMPLATE_DIR, templates)
    path = templates / "c_fsm.c.j2"
    path.write_text(
        path.read_text().replace("    c->mode = {{ M }}_FALLBACK;", "    c->mode = {{ M }}_{{ m.states[-1] }};")
    )
    outcomes = _conform_with_templates(templates, tmp_path, ["frama-c-wp"])
    assert not outcomes["frama-c-wp"].ok
    assert any("restart" in g for g in outcomes["frama-c-wp"].data["unproved"]), outcomes["frama-c-wp"].data


def _random_spec(machine: Machine) -> LoadedSpec:
    """A random first-match machine whose invariants expect what the engine proves of them."""
    machine = replace(machine, semantics="first-match", otherwise="stay")
    verdicts = {r.prop: r.verdict for r in check_all(machine)}
    invariants = tuple(replace(i, expect=verdicts[i.id]) for i in machine.invariants)
    return LoadedSpec("random.toml", "0" * 64, replace(machine, invariants=invariants))


@settings(max_examples=20, deadline=None, suppress_health_check=list(HealthCheck))
@given(machines(max_states=6, max_inputs=4))
def test_random_specs_generate_compile_and_agree(machine: Machine) -> None:
    spec = _random_spec(machine)
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "generated"
        write(generate(spec, out), out)
        result = conform(spec, out, ["compile", "exhaustive", "sequences"], quiet, sequences=20)
        assert result.ok, [(o.name, o.detail) for o in result.outcomes if not o.ok]


@pytest.mark.slow
@settings(max_examples=2, deadline=None, suppress_health_check=list(HealthCheck))
@given(machines(max_states=5, max_inputs=3))
def test_random_specs_pass_the_proof_and_the_sanitizers(machine: Machine) -> None:
    spec = _random_spec(machine)
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "generated"
        write(generate(spec, out), out)
        result = conform(spec, out, ["compile", "frama-c-wp", "sanitizers"], quiet)
        assert result.ok, [(o.name, o.detail) for o in result.outcomes if not o.ok]


def test_missing_generated_code_is_a_usage_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["conform", str(ROOT / "spec/mlca.toml"), "--generated", str(tmp_path)]) == 2
    assert "generated file not found; run `mlca-verify gen" in capsys.readouterr().err


def test_unknown_check_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["conform", str(ROOT / "spec/mlca.toml"), "--only", "lint"]) == 2
    assert "unknown checks: lint" in capsys.readouterr().err


def test_hand_edit_of_generated_code_makes_conform_exit_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "generated"
    shutil.copytree(ROOT / "generated", out)
    c_file = out / "c" / "mlca_fsm.c"
    c_file.write_text(
        c_file.read_text().replace("next = MLCA_MOVING_LEFT;", "next = MLCA_MOVING_RIGHT;", 1)
    )  # idle_left
    shutil.copytree(ROOT / "spec", tmp_path / "spec")
    spec = str(tmp_path / "spec" / "mlca.toml")
    assert main(["conform", spec, "--generated", str(out), "--only", "compile,exhaustive"]) == 1
    printed = capsys.readouterr().out
    assert "up-to-date  FAIL  c/mlca_fsm.c differs from what the spec and templates produce: run" in printed
    assert "exhaustive  FAIL" in printed


def test_input_names_that_are_macros_of_pythons_headers_still_build(tmp_path: Path) -> None:
    text = (ROOT / "spec" / "mlca.toml").read_text()
    for old, new in (("N", "EINVAL"), ("W", "INT_MAX")):
        text = re.sub(rf"\b{old}\b", new, text)
    spec_file = tmp_path / "macro.toml"
    spec_file.write_text(text)
    spec = load_spec(spec_file, compare=False)
    out = tmp_path / "generated"
    write(generate(spec, out), out)
    result = conform(spec, out, ["compile", "exhaustive"], quiet, sequences=10)
    assert result.ok, [o.detail for o in result.outcomes]


def test_sequences_blame_only_an_invariant_the_engine_proves(tmp_path: Path) -> None:
    """An invariant declared to hold that the engine finds violated fails in the random runs: that is news about
    the spec, reported with what the engine says, not "a proved invariant failed" (the code is not at fault)."""
    text = (FIXTURES / "real_state.toml").read_text()
    spec_path = tmp_path / "ra.toml"
    spec_path.write_text(text + '\n[[invariant]]\nid = "n-small"\nexpr = "n <= 3"\n')
    spec = load_spec(spec_path, compare=False)
    assert {r.prop: r.verdict for r in check_all(spec.machine)}["n-small"] == "violated"
    write(generate(spec, tmp_path / "gen"), tmp_path / "gen")
    outcomes = {o.name: o for o in conform(spec, tmp_path / "gen", ["sequences"], quiet).outcomes}
    sequences = outcomes["sequences"]
    assert sequences.ok, sequences.detail
    assert "n-small (not proved (violated)) fails at seed 0, step " in sequences.detail
    assert "a proved invariant failed" not in sequences.detail and sequences.data["unproved_failing"] == ["n-small"]


@pytest.mark.parametrize("spec", ["tests/machines/level_crossing_10hz.toml", "tests/machines/bus_door.toml"])
def test_the_checks_asked_run_in_the_order_they_build_on_each_other(
    spec: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--only` names a set: asked in any order, the checks run compile first (the exhaustive check of a machine
    with data once reported "not run: the code did not compile" when compile was named after it)."""
    assert main(["gen", "--out", str(tmp_path), str(ROOT / spec)]) == 0
    capsys.readouterr()
    args = ["conform", "--generated", str(tmp_path), "--only", "sequences,exhaustive,compile", "--sequences", "5"]
    assert main([*args, str(ROOT / spec)]) == 0
    rows = [line.split()[0] for line in capsys.readouterr().out.splitlines() if line.startswith("  ")]
    assert rows == ["up-to-date", "compile", "exhaustive", "sequences"]


def test_inputs_outside_0_1_are_reported_when_only_a_later_state_reads_them(tmp_path: Path) -> None:
    """The initial state reads no input; the sanitizer check once stepped from it alone and saw nothing."""
    spec = tmp_path / "late.toml"
    spec.write_text(
        '[machine]\nname = "Late"\ninitial = "S1"\nstates = ["S0", "S1"]\n[inputs]\ni0 = { doc = "i0" }\n'
        '[[transition]]\nfrom = "S0"\nto = "S1"\nwhen = "i0"\n',
        encoding="utf-8",
    )
    out = tmp_path / "generated"
    loaded = load_spec(spec)
    write(generate(loaded, out), out)
    outcomes = conform(loaded, out, ["compile", "sanitizers"], quiet).outcomes
    sanitizers = next(o for o in outcomes if o.name == "sanitizers")
    assert sanitizers.ok and sanitizers.detail.endswith("inputs outside 0/1 reported"), sanitizers.detail


def test_the_cortex_m4_build_tells_soft_float_helpers_from_library_calls(tmp_path: Path) -> None:
    """binary64 on a core without a double-precision FPU is calls to the compiler's helpers; a call into the C
    library (a struct copy gcc makes a memcpy, a sqrt) is what the README says the generated code never makes."""
    source = tmp_path / "calls.c"
    source.write_text(
        "#include <math.h>\n#include <string.h>\n"
        "double f(double a, double b) { return a * b + a / b; }\n"
        "void g(char *d, const char *s, size_t n) { memcpy(d, s, n); }\n"
        "double h(double a) { return sqrt(a); }\n"
    )
    obj = tmp_path / "calls.o"
    ran = subprocess.run(["arm-none-eabi-gcc", "-mcpu=cortex-m4", "-mthumb", "-Os", "-fno-builtin", "-c", "-o",
                          str(obj), str(source)], capture_output=True, text=True, check=False)  # fmt: skip
    assert ran.returncode == 0, ran.stderr
    calls = external_calls(obj)
    assert {"__aeabi_dmul", "__aeabi_ddiv", "__aeabi_dadd", "memcpy", "sqrt"} <= set(calls)
    assert library_calls(calls) == ["memcpy", "sqrt"]


@pytest.mark.parametrize("name", ["pump_debounce_1khz", "watchdog_100hz"])
def test_generated_code_of_a_data_machine_calls_no_library(name: str, tmp_path: Path) -> None:
    path = ROOT / "tests" / "machines" / f"{name}.toml"
    assert main(["gen", "--out", str(tmp_path), str(path)]) == 0
    spec = load_spec(path, compare=False)
    outcome = next(o for o in conform(spec, tmp_path, ["cortex-m4"], quiet).outcomes if o.name == "cortex-m4")
    assert outcome.ok, outcome.detail
    calls = outcome.data["calls"]
    assert all(c.startswith("__aeabi_d") for c in calls) and bool(calls) == (name == "pump_debounce_1khz")
    assert ("no library call (binary64 through" in outcome.detail) == bool(calls)


def test_the_clock_guards_a_goal_at_ten_times_what_its_budget_takes() -> None:
    """WP's budget of steps decides a goal; the clock only guards against a hung prover, and grows with the budget
    (the last -wp-steps given wins), so that a loaded machine cannot turn a goal the budget decides into a timeout."""
    from mlca_verify.conformance.c_tools import SECONDS_PER_MILLION_STEPS, WP_GUARD_S, wp_guard_s
    from mlca_verify.conformance.generated_code import WP_FLAGS, WP_STEPS

    assert wp_guard_s(()) == WP_GUARD_S == 60
    assert wp_guard_s(WP_FLAGS) == round(10 * SECONDS_PER_MILLION_STEPS * WP_STEPS / 1e6) > 5 * WP_GUARD_S
    assert wp_guard_s((*WP_FLAGS, "-wp-steps", "1000")) == WP_GUARD_S
