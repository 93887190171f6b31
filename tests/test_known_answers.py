"""Known-answer corpus: (spec, property) -> verdict and the length of the shortest counterexample.

Every layer runs against it: the engine here, the brute-force explorer below, the CLI in test_cli."""

from __future__ import annotations

import pytest

from mlca_verify.logic import check_all
from mlca_verify.logic.results import Result
from mlca_verify.model import Invariant, Liveness, Machine
from mlca_verify.spec import load_spec, load_text
from tests.bruteforce import Explicit
from tests.conftest import ROOT

V, H = "violated", "holds"

# spec, property, verdict, counterexample length (None: no trace), loop_start
ANSWERS = [
    ("tests/corpus/shadowed.toml", "fires:t3", V, None, None),
    ("tests/corpus/shadowed.toml", "fires:t4", H, None, None),
    ("tests/corpus/shadowed.toml", "reach:C", H, None, None),
    ("tests/corpus/shadowed.toml", "c-needs-b", V, 3, None),
    ("tests/corpus/shadowed.toml", "not-a-means-A", H, None, None),
    ("tests/corpus/nondeterministic.toml", "determinism", V, 1, None),
    ("tests/corpus/nondeterministic.toml", "completeness", V, 1, None),
    ("tests/corpus/nondeterministic.toml", "reach:D", V, None, None),
    ("tests/corpus/counter.toml", "below-four", V, 4, None),
    ("tests/corpus/counter.toml", "clear-resets", H, None, None),
    ("tests/corpus/counter.toml", "counts-to-four", H, None, None),
    ("tests/corpus/counter.toml", "counts-to-four-in-3", V, 3, None),
    ("tests/corpus/counter.toml", "reaches-S2", V, 1, 0),
    ("tests/corpus/pingpong.toml", "completeness", V, 2, None),
    (
        "tests/corpus/pingpong.toml",
        "reaches-C",
        V,
        2,
        0,
    ),  # x: ping and pong forever (stuck in C is no answer: C is the goal)
    ("tests/corpus/pingpong.toml", "equiv:PingPongTwin", H, None, None),
    ("tests/corpus/pingpong.toml", "equiv:PingPongLate", V, 2, None),
    ("spec/mlca.toml", "A2", H, None, None),
    ("spec/mlca.toml", "gap-taken", V, 2, 0),
    ("spec/mlca.toml", "gap-taken-when-urgent", H, None, None),
    ("spec/mlca_r.toml", "gap-taken", H, None, None),
    ("spec/mlca_r.toml", "gap-taken-within-3", H, None, None),
    ("spec/mlca_r.toml", "gap-taken-within-2-fails", V, 3, None),
    ("spec/mlca_r.toml", "equiv:MLCA", V, 2, None),
    ("spec/paper/figure.toml", "determinism", V, 1, None),
    ("spec/paper/figure.toml", "completeness", V, 1, None),
    ("spec/paper/figure.toml", "settles-when-not-needed", V, 2, None),
    ("spec/paper/prose.toml", "gap-taken", V, 2, None),
    ("spec/paper/prose.toml", "equiv:MLCA", V, 1, None),
]


@pytest.fixture(scope="module")
def results() -> dict[str, dict[str, Result]]:
    table: dict[str, dict[str, Result]] = {}
    for spec in sorted({a[0] for a in ANSWERS}):
        table[spec] = {r.prop: r for r in check_all(load_spec(ROOT / spec).machine)}
    return table


@pytest.mark.parametrize(
    ("spec", "prop", "verdict", "length", "loop"), ANSWERS, ids=[f"{a[0]}:{a[1]}" for a in ANSWERS]
)
def test_known_answer(
    results: dict[str, dict[str, Result]], spec: str, prop: str, verdict: str, length: int | None, loop: int | None
) -> None:
    result = results[spec][prop]
    assert result.verdict == verdict
    cx = result.counterexample
    assert (None if cx is None else len(cx.steps)) == length
    assert (None if cx is None else cx.loop_start) == loop


def test_corpus_covers_every_kind(results: dict[str, dict[str, Result]]) -> None:
    kinds = {results[s][p].kind for s, p, *_ in ANSWERS}
    verdicts = {(results[s][p].kind, v) for s, p, v, *_ in ANSWERS}
    assert kinds == {
        "determinism",
        "completeness",
        "reachability",
        "dead-transition",
        "invariant",
        "liveness",
        "equivalence",
    }
    assert all((k, V) in verdicts for k in kinds)


def _brute(machine: Machine, prop: str) -> tuple[str, int | None]:
    """The verdict and shortest counterexample length of one property, by the brute-force explorer alone (a
    bounded response's length is the engine's own count: the explorer gives only its verdict)."""
    ex = Explicit(machine)
    by_id = {**{i.id: i for i in machine.invariants}, **{p.id: p for p in machine.liveness}}
    item = by_id.get(prop)
    if prop.startswith("reach:"):
        return (H if prop[6:] in ex.distances() else V), None
    if prop.startswith("fires:"):
        return (H if ex.fires(prop[6:]) else V), None
    if prop in ("determinism", "completeness"):
        length = ex.nondeterminism() if prop == "determinism" else ex.gap()
    elif isinstance(item, Invariant):
        length = ex.invariant(item.expr)
    elif isinstance(item, Liveness) and item.within is None:
        length = ex.liveness(item)
    else:
        assert isinstance(item, Liveness), prop
        return (V if ex.bounded_violated(item) else H), None
    return (H if length is None else V), length


SPECS = {spec: load_spec(ROOT / spec).machine for spec in sorted({a[0] for a in ANSWERS})}
SINGLE = [a for a in ANSWERS if not a[1].startswith("equiv:")]


@pytest.mark.parametrize(("spec", "prop", "verdict", "length", "loop"), SINGLE, ids=[f"{a[0]}:{a[1]}" for a in SINGLE])
def test_bruteforce_agrees_with_the_corpus(
    spec: str, prop: str, verdict: str, length: int | None, loop: int | None
) -> None:
    found, shortest = _brute(SPECS[spec], prop)
    assert found == verdict
    bounded = any(p.id == prop and p.within is not None for p in SPECS[spec].liveness)
    if not (bounded or prop.startswith(("reach:", "fires:"))):  # the explorer gives these a verdict only
        assert shortest == length


def test_a_machine_stuck_where_the_goal_holds_has_met_it() -> None:
    """A run that gets stuck (a gap, otherwise = undefined) in a state where the goal holds has met the goal: it
    keeps that state. Before, a response whose goal is the very state the machine gets stuck in was reported
    violated, with a counterexample that reaches the goal. Stuck where the goal does not hold, it is violated."""
    text = (ROOT / "tests" / "corpus" / "pingpong.toml").read_text(encoding="utf-8").split("[[compare]]")[0]
    text += '[[liveness]]\nid = "y-reaches-C"\nassume = "y"\ngoal = "state == C"\ncite = "corpus"\n'
    machine = load_text(text, "pingpong.toml")
    found = {r.prop: r for r in check_all(machine)}
    assert found["y-reaches-C"].verdict == "holds", found["y-reaches-C"].detail
    stuck = found["C-is-stuck"]  # stuck in C, and the goal is A
    assert stuck.verdict == "violated" and stuck.counterexample is not None
    assert stuck.counterexample.steps[-1].state == "C" and stuck.counterexample.steps[-1].outcome.transition is None
    reaches = found["reaches-C"]  # still violated, now by its lasso through A and B (x holds, y does not)
    assert reaches.verdict == "violated" and reaches.counterexample is not None
    assert reaches.counterexample.loop_start is not None
    assert {s.state for s in reaches.counterexample.steps} == {"A", "B"}
    brute = Explicit(machine)
    live = next(lv for lv in machine.liveness if lv.id == "y-reaches-C")
    assert brute.liveness(live) is None
