"""The shipped specs: traceability, the paper's findings on record, and the repaired machine's guarantees."""

from __future__ import annotations

import pytest

from mlca_verify.logic import check_all
from mlca_verify.model import Machine
from mlca_verify.spec import load_spec
from tests.conftest import ROOT

SHIPPED = sorted(
    str(p.relative_to(ROOT)) for p in ROOT.glob("spec/**/*.toml") if "[network]" not in p.read_text(encoding="utf-8")
)  # the machine specs (the networks of spec/v2v: tests/test_v2v.py)
DECIDED_HERE = [p for p in SHIPPED if not p.startswith("spec/v2v/")]  # spec/v2v's: tests/test_v2v.py


def load(path: str) -> Machine:
    return load_spec(ROOT / path).machine


@pytest.mark.parametrize("path", SHIPPED)
def test_every_element_cites_the_paper(path: str) -> None:
    m = load(path)
    elements = [m, *m.inputs, *m.transitions, *m.invariants, *m.liveness, *m.comparisons]
    for element in elements:
        assert element.cite.strip(), element


@pytest.mark.parametrize("path", DECIDED_HERE)
def test_every_verdict_is_as_expected(path: str) -> None:
    bad = [r.prop for r in check_all(load(path)) if not r.ok]
    assert bad == []


def test_the_three_readings_share_states_inputs_and_asserts() -> None:
    readings = [load("spec/mlca.toml"), load("spec/paper/figure.toml"), load("spec/paper/prose.toml")]
    assert len({m.states for m in readings}) == 1
    assert len({m.input_names for m in readings}) == 1
    asserts = [{i.id: i.expr for i in m.invariants if i.id.startswith("A")} for m in readings]
    assert asserts[0] == asserts[1] == asserts[2]
    assert set(asserts[0]) == {"A1", "A2", "A3", "A4"}


def test_waiting_exit_contradiction_is_on_record() -> None:
    alg = {t.id: t for t in load("spec/mlca.toml").transitions}
    prose = {t.id: t for t in load("spec/paper/prose.toml").transitions}
    from mlca_verify.model import show

    assert show(alg["wait_exit"].guard) == "N and (L or R)"
    assert show(prose["wait_exit"].guard) == "not N and (L or R)"


def test_repaired_machine_meets_every_property_the_paper_fails() -> None:
    paper = {r.prop: r.verdict for r in check_all(load("spec/mlca.toml"))}
    repaired = {r.prop: r.verdict for r in check_all(load("spec/mlca_r.toml"))}
    failed_in_paper = {p for p, v in paper.items() if v == "violated" and not p.startswith("equiv:")}
    assert failed_in_paper == {"gap-taken", "left-gap-taken-left"}
    assert all(repaired[p] == "holds" for p in failed_in_paper)
    assert all(v == "holds" for p, v in repaired.items() if p.startswith(("A", "reach:", "fires:", "no-move")))
