"""Lemmas: statements over the definitions for every signal value in range, decided by z3 over the reals. Each
counterexample is re-evaluated exactly by the brute-force evaluator (no code shared with the engine), and each
query's SMT-LIB 2 file is decided again by a second solver, cvc5, with the same answers."""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import cvc5
import jsonschema
import pytest

from mlca_verify.cli import main
from mlca_verify.logic import check_all
from mlca_verify.logic.lemmas import lemma_scripts
from mlca_verify.spec import load_spec
from tests.bruteforce_data import Point, ev
from tests.conftest import ROOT

FIXTURE = ROOT / "tests" / "fixtures" / "lemmas.toml"
EXPECTED = {"braking": "violated", "same-gap": "violated", "same-gap-default": "holds", "double-gap": "holds"}


def _lemmas() -> dict[str, object]:
    machine = load_spec(FIXTURE).machine
    return {r.prop: r for r in check_all(machine) if r.kind == "lemma"}


def test_lemmas_are_decided_over_the_reals() -> None:
    results = _lemmas()
    assert {k: r.verdict for k, r in results.items()} == EXPECTED  # type: ignore[attr-defined]
    assert "at the params' defaults" in results["same-gap-default"].detail  # type: ignore[attr-defined]
    assert "every param value in range" in results["double-gap"].detail  # type: ignore[attr-defined]


def test_every_counterexample_fails_the_lemma_when_evaluated_exactly() -> None:
    machine = load_spec(FIXTURE).machine
    for prop, r in _lemmas().items():
        cx = r.counterexample  # type: ignore[attr-defined]
        if EXPECTED[prop] != "violated":
            assert cx is None
            continue
        step = cx.steps[0]
        assert cx.point and step.signals and cx.params
        inputs = {k: Fraction(v) for k, v in step.signals.items()} | dict(step.inputs)
        point = Point(machine, machine.initial, {}, inputs, {k: Fraction(v) for k, v in cx.params.items()})
        lemma = next(x for x in machine.lemmas if x.id == prop)
        assert ev(lemma.expr, point) is False, prop
        assert all(ev(d.expr, point) == step.definitions[d.name] for d in machine.definitions), prop


def _cvc5(text: str, tmp: Path) -> str:
    path = tmp / "query.smt2"
    path.write_text(text)
    tm = cvc5.TermManager()
    solver = cvc5.Solver(tm)
    solver.setOption("nl-cov", "true")  # cylindrical algebraic coverings: complete for nonlinear real arithmetic
    symbols = cvc5.SymbolManager(tm)
    parser = cvc5.InputParser(solver, symbols)
    parser.setFileInput(cvc5.InputLanguage.SMT_LIB_2_6, str(path))
    answers = []
    while True:
        command = parser.nextCommand()
        if command.isNull():
            break
        answers.append(command.invoke(solver, symbols).strip())
    return " ".join(a for a in answers if a)


def test_a_second_solver_replays_every_smt2_file_with_the_same_answer(tmp_path: Path) -> None:
    machine = load_spec(FIXTURE).machine
    scripts = lemma_scripts(machine, parametric=False, timeout_ms=10_000)
    assert sorted(scripts) == sorted(f"gaps_{k.replace('-', '_')}.smt2" for k in EXPECTED)
    for lemma in machine.lemmas:
        text = scripts[f"gaps_{lemma.id.replace('-', '_')}.smt2"]
        assert text.startswith(f"; lemma {lemma.id}:") and "(check-sat)" in text
        assert _cvc5(text, tmp_path) == {"holds": "unsat", "violated": "sat"}[EXPECTED[lemma.id]], lemma.id


@pytest.mark.parametrize("spec", ["spec/mlca_t.toml", "docs/lemmas/rss_longitudinal.toml"])
def test_a_second_solver_agrees_on_every_shipped_lemma(tmp_path: Path, spec: str) -> None:
    """The queries the evidence bundles for the shipped lemmas (MLCA-T's gap rule, the RSS template's motion
    lemma over time included) get cvc5's answer equal to z3's verdict."""
    machine = load_spec(ROOT / spec).machine
    verdicts = {r.prop: r.verdict for r in check_all(machine) if r.kind == "lemma"}
    scripts = lemma_scripts(machine, parametric=False, timeout_ms=10_000)
    assert len(scripts) == len(machine.lemmas) >= 3
    for lemma in machine.lemmas:
        text = scripts[f"{machine.name.lower()}_{lemma.id.replace('-', '_')}.smt2"]
        assert _cvc5(text, tmp_path) == {"holds": "unsat", "violated": "sat"}[verdicts[lemma.id]], lemma.id


def test_check_writes_the_smt2_files_and_the_json_holds_the_point(tmp_path: Path) -> None:
    out, report = tmp_path / "smt2", tmp_path / "check.json"
    assert main(["check", str(FIXTURE), "--quiet", "--smt2", str(out), "--json", str(report)]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(f"gaps_{k.replace('-', '_')}.smt2" for k in EXPECTED)
    doc = json.loads(report.read_text())
    schema = json.loads((ROOT / "src" / "mlca_verify" / "schemas" / "check-3.schema.json").read_text())
    jsonschema.validate(doc, schema)
    braking = next(r for r in doc["specs"][0]["results"] if r["property"] == "braking")
    assert braking["kind"] == "lemma" and braking["counterexample"]["point"] is True
    # SARIF points at the lemma itself
    sarif = tmp_path / "check.sarif"
    main(["check", str(FIXTURE), "--quiet", "--sarif", str(sarif)])
    results = json.loads(sarif.read_text())["runs"][0]["results"]
    lines = [r["locations"][0]["physicalLocation"]["region"]["startLine"] for r in results if r["ruleId"] == "lemma"]
    text = FIXTURE.read_text().splitlines()
    assert lines and all(text[n - 1] == "[[lemma]]" for n in lines)


@pytest.mark.parametrize(
    ("expr", "message"),
    [
        ('"state == FOLLOW"', "lemma"),
        ('"ok and w > 0"', "a lemma reads"),
        ('"gap >= v"', "mixes units m and m/s"),
        ('"near"', "definition near"),
    ],
)
def test_lemma_mistakes_are_one_line_at_their_place(tmp_path: Path, expr: str, message: str, capsys) -> None:  # type: ignore[no-untyped-def]
    text = FIXTURE.read_text().replace(
        "[definitions]\n",
        '[variables]\nw = { type = "int", initial = 0, range = [0, 5], doc = "a counter", cite = "t" }\n'
        "[definitions]\n"
        'near = { expr = "w > 2", doc = "reads a variable", cite = "t" }\n',
    )
    text += f'\n[[lemma]]\nid = "bad"\nexpr = {expr}\ncite = "t"\n'
    spec = tmp_path / "bad.toml"
    spec.write_text(text)
    assert main(["check", str(spec), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"{spec}:") and message in err, err
