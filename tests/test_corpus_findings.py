"""What the seven newer machines of the corpus (tests/machines/) found when taken through every command, one
regression test each: a definition of literals only takes the unit it declares; two booleans compared in C pass
cppcheck's MISRA addon however each side is built; a choice nested in an `if then else` is a decision only where
the code reaches it; a real output the code computes in binary64 passes its generated suite; the evidence of a
machine without params or assumptions claims nothing about them; and an invariant whose proof needs the
arithmetic of a definition over reals is not stated to WP, which sees that definition as a function without a
body."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.codegen import generate, write
from mlca_verify.codegen.acsl import AcslLowering
from mlca_verify.codegen.certified import COMPARES_BINARY64, as_wp_sees, needs_arithmetic
from mlca_verify.conformance import conform
from mlca_verify.conformance.outcome import CHECKS, CheckOutcome
from mlca_verify.evidence.collect import Evidence, argument
from mlca_verify.loading import import_generated
from mlca_verify.logic import check_all
from mlca_verify.logic.datachecks import check_data_machine, check_invariants
from mlca_verify.logic.induction import Limits
from mlca_verify.model import Machine, Not, Var, nodes, show
from mlca_verify.spec import load_spec
from mlca_verify.testgen.objectives import atoms, decisions
from mlca_verify.testgen.suite import replay
from tests.conftest import ROOT

HEAD = """
[machine]
name = "K"
initial = "A"
states = ["A", "B"]
"""


def _spec(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "k.toml"
    path.write_text(HEAD + body, encoding="utf-8")
    return path


def _quiet(_: CheckOutcome) -> None:
    pass


def test_a_definition_of_literals_only_takes_the_unit_it_declares(tmp_path: Path) -> None:
    """A flasher's stride (`if bulb_out then 2 else 1`, in steps) was read as dimensionless, so `phase + stride`
    was refused as mixing step and 1."""
    body = """
[inputs]
fast = { doc = "count twice as fast" }
[definitions]
stride = { expr = "if fast then 2 else 1", unit = "step", doc = "how far a step advances" }
[variables]
phase = { type = "int", initial = 0, range = [0, 10], unit = "step", every = "if phase + stride >= 10 then 0 else phase + stride", doc = "into the period" }
[[transition]]
from = "A"
to = "B"
when = "phase >= 5"
"""
    spec = load_spec(_spec(tmp_path, body))
    (stride,) = spec.machine.definitions
    assert stride.unit == (("step", 1),)
    unitless = _spec(tmp_path, body.replace('unit = "step", doc = "how far', 'doc = "how far'))
    with pytest.raises(Exception, match="'\\+' mixes units step and 1"):
        load_spec(unitless)


def test_two_booleans_compared_in_c_pass_misra_however_each_side_is_built(tmp_path: Path) -> None:
    """CAN fault confinement's `state == ERROR_PASSIVE <-> (tec >= 128 or rec >= 128)` was C's `(mode == X) ==
    (a || b)`, which cppcheck's MISRA addon reads as two essential types (rule 10.4); each side is now negated."""
    body = """
[inputs]
go = { doc = "go" }
[variables]
n = { type = "int", initial = 0, range = [0, 9], every = "min(n + 1, 9)", doc = "a count" }
[outputs]
busy = { type = "bool", expr = "(state == B) == (n >= 3 or go)", doc = "a comparison of booleans" }
[[transition]]
from = "A"
to = "B"
when = "go"
[[invariant]]
id = "iff"
expr = "state == B <-> (n >= 3 and go or prev(state) == B)"
expect = "violated"
"""
    spec = load_spec(_spec(tmp_path, body))
    out = tmp_path / "gen"
    write(generate(spec, out), out)
    source = (out / "c" / "k_fsm.c").read_text(encoding="utf-8")
    assert "((!(c->mode == K_B)) == (!(" in source
    result = conform(spec, out, ["compile", "exhaustive", "cppcheck"], _quiet)
    assert all(o.ok for o in result.outcomes), {o.name: o.detail for o in result.outcomes}


NESTED = """
[inputs]
err = { doc = "an error" }
ok = { doc = "a success" }
[variables]
rec = { type = "int", initial = 0, range = [0, 135], every = "if err then min(rec + 1, 135) else if ok then (if rec > 127 then 127 else max(rec - 1, 0)) else rec", doc = "an error counter" }
[[transition]]
from = "A"
to = "B"
when = "rec >= 128"
[[transition]]
from = "B"
to = "A"
when = "rec < 128"
"""


def test_a_choice_inside_an_if_is_a_decision_where_the_code_reaches_it(tmp_path: Path) -> None:
    """The counter's `rec > 127` is evaluated only when `err` is false and `ok` true; the suite once paired it
    on a step with neither, which the C never evaluates it on, and left its branch without a reason."""
    machine = load_spec(_spec(tmp_path, NESTED)).machine
    found = {d.id: d for d in decisions(machine)}
    inner = next(d for d in found.values() if show(d.expr) == "rec > 127")
    read = set().union(*(set(nodes(g)) for g in inner.given))
    assert Not(Var("err")) in read and Var("ok") in read
    first = next(d for d in found.values() if d.id.endswith("#1") and d.id.startswith("output:"))
    assert Var("ok") not in set().union(*(set(nodes(g)) for g in first.given))  # the outer if: every step


@pytest.mark.slow
def test_every_gap_of_a_nested_choice_has_its_reason_or_is_closed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _spec(tmp_path, NESTED)
    assert main(["gen", "--out", str(tmp_path / "gen"), str(spec)]) == 0
    argv = ["tests", "--no-target", "--generated", str(tmp_path / "gen"), "--out", str(tmp_path / "t"), str(spec)]
    assert main(argv) == 0, capsys.readouterr().out
    (report,) = (tmp_path / "t").glob("*/coverage.json")
    assert all(g["reason"] for c in json.loads(report.read_text())["coverage"] for g in c["gaps"])


@pytest.mark.slow
def test_a_real_output_the_code_rounds_passes_its_generated_suite(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A charger's constant-voltage current, `K * (V_MAX - v)`, is 0.3125 in binary64 where the spec's exact
    value is 0.31249999999999645 (V_MAX = 4.2 is not a binary64); the generated suites compared it exactly and
    failed. They now compare a real within the relative tolerance conform's exhaustive check uses."""
    body = """
[params]
V_MAX = { type = "real", default = 4.2, range = [4.0, 4.4], unit = "V", doc = "top voltage" }
K = { type = "real", default = 20.0, range = [1.0, 50.0], unit = "A/V", doc = "gain" }
[signals]
v = { type = "real", unit = "V", range = [0.0, 5.0], doc = "cell voltage" }
[definitions]
full = { expr = "v >= V_MAX", doc = "at the top" }
[outputs]
i_set = { type = "real", unit = "A", range = [0.0, 100.0], if_invalid = 0.0, expr = "if state == B then max(K * (V_MAX - v), 0.0) else 0.0", doc = "current asked for" }
[[transition]]
from = "A"
to = "B"
when = "not full"
"""
    spec = _spec(tmp_path, body)
    assert main(["gen", "--out", str(tmp_path / "gen"), str(spec)]) == 0
    argv = ["tests", "--no-target", "--generated", str(tmp_path / "gen"), "--out", str(tmp_path / "t"), str(spec)]
    assert main(argv) == 0, capsys.readouterr().out
    suite = next((tmp_path / "t").glob("*/test_*_mcdc.py")).read_text(encoding="utf-8")
    assert "within a relative 1e-09" in suite


def test_the_evidence_of_a_machine_without_params_or_assumptions_claims_nothing_of_them(tmp_path: Path) -> None:
    spec = load_spec(_spec(tmp_path, NESTED))
    passed = [CheckOutcome(n, True, "passed") for n in ("up-to-date", *CHECKS)]
    ev = Evidence(spec, check_all(spec.machine), passed, tmp_path, [], "now", loop={"status": "undeveloped"})
    top = next(n for n in argument(ev) if n["id"] == "G1")["text"]
    assert top.endswith("meets its specified properties") and "param" not in top and "assumption" not in top


def test_an_invariant_whose_proof_needs_a_real_definitions_arithmetic_is_not_stated_to_wp() -> None:
    """A tank's `high -> pump == 0` holds because `low` and `high` are never both true, which only their
    arithmetic on the level sample shows; WP sees them as logic functions without a body, and ran into its guard
    on the certified step. As WP sees the machine (those definitions free at every step) it is not proved, so it is
    not stated, with the reason; the invariants that need nothing of them stay stated."""
    machine = load_spec(ROOT / "tests" / "machines" / "tank_fill_1hz.toml").machine
    seen, opaque = as_wp_sees(machine, AcslLowering.of(machine, "tankfill", "TANKFILL").n.types)
    assert opaque == ("low", "high", "no_flow", "level_ok")
    assert {i.name for i in seen.inputs} == set(opaque) and [d.name for d in seen.definitions] == []

    def proved(m: Machine) -> set[str]:  # at the params' defaults (conform asks for every param: slower)
        results = check_data_machine(m, Limits())
        return {r.prop for r in results if r.kind == "invariant" and r.verdict == "holds" and r.proof is not None}

    assert proved(machine) == {"stops-on-a-bad-level", "stops-when-full", "dry-run-bounded"}
    assert proved(seen) == {"dry-run-bounded"}
    ids = ["stops-when-full", "dry-run-bounded"]  # as conform asks: the invariants alone
    assert [(r.prop, r.verdict) for r in check_invariants(seen, Limits(), ids)] == [
        ("stops-when-full", "violated"),
        ("dry-run-bounded", "holds"),
    ]
    why = dict(needs_arithmetic(machine, {"level": "real"}, ["stops-when-full", "stops-on-a-bad-level"], opaque))
    assert why["stops-when-full"].startswith("its proof needs the arithmetic of low, high, no_flow, level_ok")
    assert why["stops-on-a-bad-level"] == COMPARES_BINARY64


def test_a_boolean_output_is_a_decision_and_an_every_is_read_where_no_update_applies() -> None:
    """A flasher's `lamp_l = state in {LEFT, HAZARD} and phase < ON_STEPS` was no decision of the suite, and its
    `bulb_out`, read by the phase's `every`, was paired on steps where a transition set the phase, which the C
    never reads it on: six C gaps without a reason."""
    machine = load_spec(ROOT / "tests" / "machines" / "flasher_100hz.toml").machine
    found = {d.id: d for d in decisions(machine)}
    lamp = found["output:lamp_l"]
    assert lamp.where == "post" and [show(a) for a in atoms(lamp.expr)] == [
        "state == LEFT",
        "state == HAZARD",
        "phase < ON_STEPS",
    ]
    (read, checks) = found["def:bulb_out"].given
    assert {show(n) for n in nodes(read) if isinstance(n, Var)} >= {"hazard", "stalk_left", "stalk_right"}
    assert "valid" not in show(read) and "lamp_current" in show(checks)


def test_each_branch_of_a_boolean_output_written_as_an_if_is_a_decision_where_it_is_taken(tmp_path: Path) -> None:
    body = """
[inputs]
go = { doc = "go" }
[variables]
n = { type = "int", initial = 0, range = [0, 9], every = "min(n + 1, 9)", doc = "a count" }
[outputs]
busy = { type = "bool", expr = "if go then n >= 3 and n < 7 else n < 1 or n > 8", doc = "two rules" }
[[transition]]
from = "A"
to = "B"
when = "go"
"""
    found = {d.id: d for d in decisions(load_spec(_spec(tmp_path, body)).machine)}
    assert [show(found["output:busy#1"].expr), *map(show, found["output:busy#1"].given)] == ["n >= 3 and n < 7", "go"]
    assert [show(found["output:busy#2"].expr), *map(show, found["output:busy#2"].given)] == ["n < 1 or n > 8", "not go"]


@pytest.mark.parametrize("reals", ["binary32", "binary64"])
def test_the_suites_expectations_follow_a_real_timer_as_the_code_holds_it(tmp_path: Path, reals: str) -> None:
    """The motor limiter's hot-winding timer counts 0.001 s a step. The generated suite carried each step's
    context to the next as the nearest binary64, so in binary32 its timer drifted from the float the code holds,
    and after 20 steps it expected an invariant to hold that the code, holding 0.0200000014, says fails. The
    context is now carried as the code's format holds it. In binary64 the suite added the exact 0.001 and
    compared with the exact 0.02 (0.019999999999999997 against the code's 0.02000000000000001 >= 0.02): the
    constants are now the format's too. The suite's verdict at every step is the code's."""
    body = (
        f'reals = "{reals}"'
        + """
[inputs]
go = { doc = "go" }
[params]
LIMIT = { type = "real", default = 0.02, range = [0.001, 1.0], unit = "s", doc = "the limit" }
[variables]
t = { type = "real", initial = 0.0, range = [0.0, 1.0], unit = "s", every = "min(t + 0.001, 1.0)", doc = "time" }
[[transition]]
from = "A"
to = "B"
when = "go"
[[invariant]]
id = "early"
expr = "t < LIMIT"
expect = "violated"
"""
    )
    spec = _spec(tmp_path, body)
    machine = load_spec(spec).machine
    steps = replay(machine, [(None, [{"go": False}] * 25)])[0]
    assert main(["gen", "--out", str(tmp_path / "gen"), str(spec)]) == 0
    code = import_generated(tmp_path / "gen" / "python" / "k_fsm.py", f"k_{reals}_timer")
    ctx, inputs = code.Context(), code.Inputs(go=False)
    for k, expected in enumerate(steps):
        before = code.Context(**vars(ctx))
        out = code.step(ctx, inputs)
        assert code.monitor(before, ctx, inputs, code.DEFAULT_PARAMS, out) == list(expected.failing), k
        assert abs(ctx.t - expected.variables[0]) <= 1e-4 * abs(ctx.t), k
    assert steps[18].failing == () and steps[19].failing == ("early",)
