"""PDR in a z3 process of its own (logic/spacer.py): its answer does not depend on what the calling process ran
before, its budget is z3's resource limit, its invariant is read back from the text z3 prints, and a missing
solver is one clear line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import z3

from mlca_verify.errors import ToolError
from mlca_verify.logic import spacer
from mlca_verify.logic.datachecks import DataChecker
from mlca_verify.logic.induction import Limits, pdr
from mlca_verify.logic.symbolic import Frame, StepInputs, StepTerms, System
from mlca_verify.spec import load_spec
from tests.conftest import ROOT

HISTORY = """
import sys
from mlca_verify.logic import check_all
from mlca_verify.spec import load_spec
for path in sys.argv[1:]:
    results = check_all(load_spec(path).machine)
print("\\n".join(f"{r.prop} {r.proof.engine} {r.proof.certificate}" for r in results if r.proof and r.proof.engine == "pdr"))
"""


def test_pdr_proves_the_same_way_whatever_the_process_ran_before() -> None:
    """MLCA-T's `no-livelock` took 0.3 s alone and 2.3 s after Alg. 1 and its repair when Spacer ran in the
    checking process (the same clauses, from the same text, in a fresh context); now its answer and certificate
    are the same after any history."""
    runs = [
        subprocess.run(
            [sys.executable, "-c", HISTORY, *before, "spec/mlca_t.toml"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for before in ([], ["spec/mlca.toml", "spec/mlca_r.toml"], ["spec/paper/prose.toml"])
    ]
    assert "no-livelock pdr" in runs[0]
    assert runs[1] == runs[0] and runs[2] == runs[0]


def _counter_system() -> tuple[System, z3.BoolRef]:
    machine = load_spec(ROOT / "tests" / "machines" / "watchdog_100hz.toml").machine
    invariant = next(i for i in machine.invariants if i.id == "window-bounded")
    system, _ = DataChecker(machine, Limits(steps=0)).systems((invariant.expr,), False)
    return system, invariant.expr  # type: ignore[return-value]


def test_a_budget_too_small_is_unknown_with_its_reason() -> None:
    system, expr = _counter_system()

    def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
        return z3.Not(s.ev(expr, t.post))

    found = pdr(system, bad, 1)  # 3,000 of z3's resource units
    assert found.answer == "unknown"
    assert "ran out of its budget" in found.reason and "--timeout-ms" in found.reason
    proved = pdr(system, bad, 10_000)
    assert proved.answer == "unreachable" and proved.certificate_checked


def test_the_invariant_is_read_back_in_every_form_z3_prints_it() -> None:
    ctx = z3.Context()
    x, y = z3.Int("x", ctx), z3.Bool("y", ctx)
    inv = z3.Function("Inv", z3.IntSort(ctx), z3.BoolSort(ctx), z3.BoolSort(ctx))
    forms = {
        "(and (= Err false) (forall ((A Int) (B Bool)) (! (= (Inv A B) (and B (>= A 0))) :weight 0)))": "And(y, x >= 0)",
        "(forall ((A Int) (B Bool)) (= (Inv A B) (<= A 3)))": "x <= 3",
        "(forall ((A Int) (B Bool)) (Inv A B))": "True",
        "(forall ((A Int) (B Bool)) (not (Inv A B)))": "False",
    }
    for printed, wanted in forms.items():
        found = spacer.invariant(printed, inv, [x, y])
        assert str(found) == wanted, printed
    assert spacer.invariant("(this is not SMT-LIB", inv, [x, y]) is None
    assert spacer.invariant("(forall ((A Int) (B Bool)) (= (Other A) true))", inv, [x, y]) is None


def test_a_missing_solver_is_one_line(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    spacer.binary.cache_clear()
    monkeypatch.setattr(sys, "executable", str(tmp_path / "python"))
    try:
        with pytest.raises(ToolError) as err:
            spacer.binary()
        assert "z3's command-line solver not found" in str(err.value) and "\n" not in str(err.value)
    finally:
        spacer.binary.cache_clear()


def test_an_error_in_the_clauses_is_unknown_never_a_proof() -> None:
    """z3 reports a clause it cannot read and goes on without it: Err is then underivable, and it answers unsat.
    That answer is not taken: any error makes the query unknown, with z3's words on one line."""
    answer, reason = spacer.solve("(declare-rel Err ())\n(rule (=> undeclared_constant Err))", "Err", 1000)
    assert answer == "unknown" and "\n" not in reason and "undeclared_constant" in reason
