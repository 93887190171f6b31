"""A solver `unknown` (a timeout) is its own verdict: never folded into holds or violated."""

from __future__ import annotations

import pytest

from mlca_verify.cli import main
from mlca_verify.logic import check_all
from mlca_verify.logic.solver import Solver
from mlca_verify.spec import load_spec
from tests.conftest import ROOT

# results that need no query: the initial state is reached, and first-match with an `otherwise` is deterministic
# and complete by construction
BY_CONSTRUCTION = {"reach:IDLE", "determinism", "completeness"}


def test_every_query_unknown_gives_unknown_verdicts(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(Solver, "check", lambda self, formula: "unknown")
    results = {r.prop: r for r in check_all(load_spec(ROOT / "spec/mlca.toml").machine)}
    assert results["reach:IDLE"].verdict == "holds"  # the initial state needs no query
    assert results["determinism"].verdict == "holds"  # first-match: by construction
    one_of_each_kind = ("reach:WAITING", "fires:reset", "A2", "gap-taken", "gap-taken-when-urgent")
    assert set(one_of_each_kind) <= set(results), sorted(results)
    for prop in one_of_each_kind:
        assert results[prop].verdict == "unknown", prop
    assert {p for p, r in results.items() if r.verdict != "unknown"} == BY_CONSTRUCTION
    assert all(r.counterexample is None for r in results.values())


def test_every_query_unknown_gives_an_unknown_comparison(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(Solver, "check", lambda self, formula: "unknown")
    results = {r.prop: r for r in check_all(load_spec(ROOT / "spec/mlca_r.toml").machine)}
    assert "equiv:MLCA" in results, sorted(results)  # spec/mlca_r.toml compares itself with spec/mlca.toml
    assert results["equiv:MLCA"].verdict == "unknown"
    assert results["equiv:MLCA"].counterexample is None
    assert {p for p, r in results.items() if r.verdict != "unknown"} == BY_CONSTRUCTION


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


@pytest.mark.usefixtures("at_root")
def test_unknown_is_not_as_expected_so_check_exits_1(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(Solver, "check", lambda self, formula: "unknown")
    assert main(["check", "spec/mlca_r.toml", "--quiet"]) == 1
    assert "unknown" in capsys.readouterr().out
