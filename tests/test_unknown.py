"""A solver `unknown` (a timeout) is its own verdict: never folded into holds or violated."""

from __future__ import annotations

from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.logic import check_all
from mlca_verify.logic.solver import Solver
from mlca_verify.spec import load_spec

ROOT = Path(__file__).parent.parent


def test_every_query_unknown_gives_unknown_verdicts(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(Solver, "check", lambda self, formula: "unknown")
    results = {r.prop: r for r in check_all(load_spec(ROOT / "spec/mlca.toml").machine)}
    assert results["reach:IDLE"].verdict == "holds"  # the initial state needs no query
    assert results["determinism"].verdict == "holds"  # first-match: by construction
    for prop in ("reach:WAITING", "fires:reset", "A2", "gap-taken", "gap-taken-when-urgent", "equiv:MLCA_R"):
        if prop in results:
            assert results[prop].verdict == "unknown", prop
    assert all(r.counterexample is None for r in results.values())


def test_unknown_after_exploration_keeps_violations_found_and_degrades_proofs(monkeypatch: pytest.MonkeyPatch) -> None:
    real = Solver.check
    state = {"calls": 0}

    def flaky(self: Solver, formula: object) -> str:
        state["calls"] += 1
        answer = real(self, formula)  # type: ignore[arg-type]
        return "unknown" if answer == "unsat" and state["calls"] > 40 else answer

    monkeypatch.setattr(Solver, "check", flaky)
    results = {r.prop: r for r in check_all(load_spec(ROOT / "spec/mlca.toml").machine)}
    assert results["A2"].verdict == "unknown"
    assert results["gap-taken"].verdict == "violated"  # a lasso found with sat answers stands


def test_unknown_is_not_as_expected_so_check_exits_1(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(Solver, "check", lambda self, formula: "unknown")
    monkeypatch.chdir(ROOT)
    assert main(["check", "spec/mlca_r.toml", "--quiet"]) == 1
    assert "unknown" in capsys.readouterr().out
