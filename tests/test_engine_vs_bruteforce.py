"""The z3 engine against an independent brute-force explorer on random machines.

Every verdict must agree; every counterexample must replay on the machine and be as short as the shortest the
brute-force search finds."""

from __future__ import annotations

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from mlca_verify.logic.boolean import Checker
from mlca_verify.logic.equiv import compare
from mlca_verify.logic.results import Result
from mlca_verify.model import Machine
from tests.bruteforce import Explicit, differ_length, ev
from tests.replay import check_lasso_or_gap, replay
from tests.strategies import machines, machines_over

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _by_name(results: list[Result]) -> dict[str, Result]:
    return {r.prop: r for r in results}


def _length(result: Result) -> int | None:
    if result.verdict == "holds":
        return None
    assert result.verdict == "violated", result
    assert result.counterexample is not None
    return len(result.counterexample.steps)


@SETTINGS
@given(machines())
def test_builtin_checks_agree(machine: Machine) -> None:
    results = _by_name(Checker(machine).run_all())
    ex = Explicit(machine)
    dist = ex.distances()
    assert _length(results["determinism"]) == (None if machine.semantics == "first-match" else ex.nondeterminism())
    assert _length(results["completeness"]) == (None if machine.otherwise == "stay" else ex.gap())
    for state in machine.states:
        assert results[f"reach:{state}"].verdict == ("holds" if state in dist else "violated")
    for t in machine.transitions:
        assert results[f"fires:{t.id}"].verdict == ("holds" if ex.fires(t.id) else "violated")
    for prop in ("determinism", "completeness"):
        cx = results[prop].counterexample
        if cx is not None:
            replay(machine, cx)


@SETTINGS
@given(machines())
def test_invariants_agree_and_replay(machine: Machine) -> None:
    assume(machine.invariants)  # never vacuous: hypothesis reports it when too few examples have one
    results = _by_name(Checker(machine).run_all())
    ex = Explicit(machine)
    for inv in machine.invariants:
        result = results[inv.id]
        assert _length(result) == ex.invariant(inv.expr)
        if result.counterexample is not None:
            replay(machine, result.counterexample)
            last = result.counterexample.steps[-1]
            assert not ev(inv.expr, last.inputs, last.outcome.next)


@SETTINGS
@given(machines())
def test_liveness_agrees_and_replays(machine: Machine) -> None:
    assume(machine.liveness)
    results = _by_name(Checker(machine).run_all())
    ex = Explicit(machine)
    for live in machine.liveness:
        result = results[live.id]
        if live.within is None:
            assert _length(result) == ex.liveness(live)
        else:
            assert (result.verdict == "violated") == ex.bounded_violated(live)
        if result.counterexample is not None:
            check_lasso_or_gap(machine, result.counterexample, live)


@SETTINGS
@given(st.data())
def test_equivalence_agrees(data: st.DataObject) -> None:
    states = tuple(f"S{i}" for i in range(data.draw(st.integers(1, 5))))
    inputs = tuple(f"I{i}" for i in range(data.draw(st.integers(1, 4))))
    left = data.draw(machines_over(states, inputs, "A"))
    right = data.draw(machines_over(states, inputs, "B"))
    found = compare(left, right)
    expected = differ_length(left, right)
    assert (found.verdict == "violated") == (expected is not None)
    if found.counterexample is not None:
        assert len(found.counterexample.steps) == expected
        if expected:
            replay(left, found.counterexample)
            replay(right, found.counterexample)


@SETTINGS
@given(machines())
def test_machine_is_equivalent_to_itself_with_rewritten_guards(machine: Machine) -> None:
    from dataclasses import replace

    from mlca_verify.model import Not

    twin = replace(
        machine,
        name="twin",
        transitions=tuple(replace(t, guard=Not(Not(t.guard))) for t in machine.transitions),
    )
    assert compare(machine, twin).verdict == "holds"
