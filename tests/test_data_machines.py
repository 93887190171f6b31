"""Machines with data: MLCA-T proved with certificates, a planted timer bug caught, the loader's type and unit
errors at their columns, and the symbolic engine agreeing with the explicit one on the boolean machines."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import jsonschema
import pytest

from mlca_verify.cli import main
from mlca_verify.errors import SpecError
from mlca_verify.logic import check_all
from mlca_verify.spec import load_spec, load_text
from tests.conftest import ROOT

MLCA_T = ROOT / "spec" / "mlca_t.toml"
FAST_TIMER = ROOT / "tests" / "fixtures" / "mlca_t_fast_timer.toml"


@pytest.fixture(scope="module")
def mlca_t_results() -> dict[str, object]:
    results = check_all(load_spec(MLCA_T).machine)
    return {r.prop: r for r in results}


def test_mlca_t_proves_every_property_for_every_param_value(mlca_t_results: dict[str, object]) -> None:
    machine = load_spec(MLCA_T).machine
    declared = [p.id for p in machine.invariants] + [p.id for p in machine.liveness]
    assert all(p.parametric for p in machine.invariants) and all(p.parametric for p in machine.liveness)
    for prop in declared:
        r = mlca_t_results[prop]
        assert r.verdict == "holds", (prop, r.detail)  # type: ignore[attr-defined]
        proof = r.proof  # type: ignore[attr-defined]
        assert proof is not None and proof.parametric
        assert proof.certificate, prop
        assert proof.certificate_checked, prop


def test_mlca_t_builtins_reach_every_state_and_fire_every_transition(mlca_t_results: dict[str, object]) -> None:
    bad = [p for p, r in mlca_t_results.items() if r.verdict != r.expected]  # type: ignore[attr-defined]
    assert bad == []
    assert any(p.startswith("range:") for p in mlca_t_results)


def test_planted_timer_bug_gives_a_concrete_shortest_counterexample() -> None:
    machine = load_spec(FAST_TIMER).machine
    (deferral,) = [r for r in check_all(machine) if r.prop == "deferral"]
    assert deferral.verdict == "violated"
    cx = deferral.counterexample
    assert cx is not None
    assert cx.params["T_MIN"] == 3  # the smallest deferral the doubled timer can undercut
    assert len(cx.steps) == 3
    last = cx.steps[-1]
    assert last.outcome.next in ("MOVING_LEFT", "MOVING_RIGHT") and not last.inputs["U"]
    assert last.variables["need_age"] <= cx.params["T_MIN"]
    assert [s.variables["waited"] for s in cx.steps] == [1, 3, 5]  # the timer counts two per step
    assert set(last.signals) == {s.name for s in machine.signals}


def test_fixture_differs_from_mlca_t_only_in_the_timer() -> None:
    ours = MLCA_T.read_text().splitlines()
    planted = [line for line in FAST_TIMER.read_text().splitlines() if not line.startswith("# ")]
    changed = [(a, b) for a, b in zip(ours[-len(planted) :], planted, strict=False) if a != b]
    assert len(changed) == 1 and "waited + 2" in changed[0][1]


def test_json_schema_2_carries_proofs_and_values(tmp_path: Path) -> None:
    out = tmp_path / "check.json"
    assert main(["check", str(FAST_TIMER), "--only", "deferral,A3", "--quiet", "--json", str(out)]) == 1
    doc = json.loads(out.read_text())
    jsonschema.validate(doc, json.loads((ROOT / "src" / "mlca_verify" / "schemas" / "check-3.schema.json").read_text()))
    assert doc["schema"] == "mlca-verify.check/3"
    results = {r["property"]: r for r in doc["specs"][0]["results"]}
    assert results["A3"]["proof"]["engine"] == "k-induction"
    step = results["deferral"]["counterexample"]["steps"][-1]
    assert {"signals", "definitions", "variables", "outputs"} <= set(step)
    assert results["deferral"]["counterexample"]["params"]["T_MIN"] == 3


@pytest.mark.parametrize("spec", ["mlca.toml", "mlca_r.toml"])
def test_symbolic_engine_agrees_with_the_explicit_one(spec: str) -> None:
    machine = load_spec(ROOT / "spec" / spec, compare=False).machine
    explicit = {r.prop: r for r in check_all(machine)}
    symbolic = {r.prop: r for r in check_all(replace(machine, data=True))}
    compared = sorted(p for p, r in explicit.items() if r.kind != "liveness")
    assert compared and set(compared) <= set(symbolic)  # every safety verdict of the explicit engine is compared
    for prop in compared:
        r = symbolic[prop]
        assert r.verdict == explicit[prop].verdict, prop
        if r.verdict == "violated" and r.counterexample is not None:
            assert explicit[prop].counterexample is not None
            assert len(r.counterexample.steps) == len(explicit[prop].counterexample.steps), prop
    bounded = [live.id for live in machine.liveness if live.within is not None]
    assert bounded and any(live.within is None for live in machine.liveness)
    for live in machine.liveness:  # bounded, and without a bound (decided by the explicit-state engine's loops)
        assert symbolic[live.id].verdict == explicit[live.id].verdict, live.id


HEAD = """
[machine]
name = "M"
initial = "A"
states = ["A", "B"]
[inputs]
go = { doc = "go" }
[signals]
d = { type = "real", unit = "m", range = [0.0, 10.0], doc = "a distance" }
t = { type = "real", unit = "s", range = [0.0, 10.0], doc = "a time" }
[params]
K = { type = "int", default = 2, range = [1, 5], doc = "a bound" }
"""


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            '[definitions]\nX = { expr = "d + t > 1", doc = "x" }',
            "x.toml:14:17: error: definition: '+' mixes units m and s",
        ),
        ('[definitions]\nX = { expr = "d > 1 + go", doc = "x" }', "'+' needs a number, got bool"),
        (
            '[[transition]]\nfrom = "A"\nto = "B"\nwhen = "d > 1"',
            "guard cannot read 'd': a signal is read only by definitions",
        ),
        ('[[transition]]\nfrom = "A"\nto = "B"\nwhen = "prev(go)"', "prev() is for properties"),
        ('[definitions]\nX = { expr = "Y", doc = "x" }\nY = { expr = "X", doc = "y" }', "a cycle"),
        ('[variables]\nc = { type = "int", initial = 9, range = [0, 4], doc = "c" }', "lies outside its range"),
        ('[variables]\nc = { type = "int", initial = 0, doc = "c" }', "needs a 'range'"),
        ('[[transition]]\nfrom = "A"\nto = "B"\nwhen = "go"\ndo = "go = 1"', "'go' is not a variable"),
        ('[params]\nP = { type = "int", default = 1.5, doc = "p" }', "whole number"),
    ],
)
def test_loader_reports_data_mistakes_at_their_place(extra: str, message: str) -> None:
    text = HEAD + extra + "\n"
    if "[params]" in extra:
        text = text.replace('[params]\nK = { type = "int", default = 2, range = [1, 5], doc = "a bound" }\n', "")
    with pytest.raises(SpecError) as info:
        load_text(text, "x.toml")
    assert message in str(info.value)


def test_require_cites_lists_each_uncited_element(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    spec = tmp_path / "u.toml"
    spec.write_text(HEAD + '[[transition]]\nfrom = "A"\nto = "B"\nwhen = "go"\n')
    assert main(["check", str(spec), "--quiet"]) == 0
    assert main(["check", str(spec), "--quiet", "--require-cites"]) == 1
    out = capsys.readouterr().out
    for what in ("machine 'M'", "input 'go'", "signal 'd'", "param 'K'", "transition 't1'"):
        assert f"uncited {what}" in out


def test_require_cites_locates_each_element_in_sarif(tmp_path: Path) -> None:
    spec = tmp_path / "u.toml"
    spec.write_text(HEAD + '[definitions]\nnear = { expr = "d < 2.0", doc = "close" }\n')
    out = tmp_path / "c.sarif"
    assert main(["check", str(spec), "--quiet", "--require-cites", "--sarif", str(out)]) == 1
    results = json.loads(out.read_text())["runs"][0]["results"]
    where = {
        r["message"]["text"]: r["locations"][0]["physicalLocation"]["region"]["startLine"]
        for r in results
        if r["ruleId"] == "citation"
    }
    lines = spec.read_text().splitlines()
    assert lines[where["uncited definition 'near'"] - 1].startswith("near =")
    assert lines[where["uncited param 'K'"] - 1].startswith("K =")


def _reworded(tmp_path: Path, old: str, new: str) -> Path:
    text = MLCA_T.read_text()
    assert old in text
    path = tmp_path / "mlca_t.toml"
    path.write_text(text.replace(old, new))
    return path


@pytest.mark.parametrize(
    ("old", "new", "label", "code"),
    [
        ('"not N -> state == IDLE"', '"not (state != IDLE and not N)"', "equivalent (reworded)", 0),
        ('"state == MOVING_LEFT -> N and L"', '"state == MOVING_LEFT -> N"', "WEAKENED (REGRESSION)", 1),
        ('within = "T_MIN + 2"', 'within = "T_MIN + 3"', "WEAKENED (REGRESSION)", 1),
        ('within = "T_MIN + 2"', 'within = "T_MIN + 2"\nwithin_s = 1.0', None, 2),
        ('assume = "N and L"', 'assume = "N"', "strengthened", 1),
    ],
)
def test_diff_compares_properties_by_meaning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, label: str | None, code: int
) -> None:
    changed = _reworded(tmp_path, old, new)
    assert main(["diff", str(MLCA_T), str(changed)]) == code
    out = capsys.readouterr().out
    if label is not None:
        assert label in out


ADDED = """
[[assume]]
id = "no-cut-in"
expr = "v_follow_left <= v + 5.0"
doc = "the follower on the left is at most 5 m/s faster"
cite = "a narrower environment"
"""


@pytest.mark.parametrize(
    ("change", "label", "code"),
    [
        ((None, ADDED), "WEAKENED (REGRESSION)", 1),  # one more assumption: every guarantee rests on more
        (('expr = "U -> N"', 'expr = "U -> N and v <= 60.0"'), "WEAKENED (REGRESSION)", 1),  # narrowed
        (('expr = "U -> N"', 'expr = "not (U and not N)"'), "equivalent (reworded)", 0),
        (('expr = "U -> N"', 'expr = "U -> N or v > 1000.0"'), "strengthened", 0),  # an invalid sample may read so
    ],
)
def test_diff_counts_narrower_assumptions_as_a_weakening(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: tuple[str | None, str], label: str, code: int
) -> None:
    old, new = change
    changed = tmp_path / "mlca_t.toml"
    text = MLCA_T.read_text()
    if old is None:
        changed.write_text(text + new)
    else:
        assert old in text
        changed.write_text(text.replace(old, new))
    assert main(["diff", str(MLCA_T), str(changed)]) == code
    out = capsys.readouterr().out
    assert label in out
    assert "    old: (U -> N)" in out  # each side's assumptions shown whole
    if code == 1:
        named = "no-cut-in" if old is None else "urgent-is-needed"
        assert f"assumptions narrowed: {named} allow fewer environments" in out


def test_a_divisor_that_can_be_zero_is_a_finding_not_a_crash() -> None:
    machine = load_spec(ROOT / "tests" / "fixtures" / "division.toml").machine
    results = {r.prop: r for r in check_all(machine)}
    assert results["div:ttc"].verdict == "violated"
    cx = results["div:ttc"].counterexample
    assert cx is not None and cx.steps[-1].signals["v"] == 0
    assert results["div:safe_ttc"].verdict == "holds"
