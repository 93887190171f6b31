"""A regression gate on public models with published verdicts (tests/public/: Lustre benchmarks of Kind 2, JKind and
the CoCo team, translated by hand, each file citing its source and where its verdict is published).

A verdict that flips between holds and violated fails; so does a new unknown. Each counterexample must be as long
as the published one (or, where none is published, as the shortest one an independent transcription of the Lustre
text finds, tests/public/lustre_oracle.py). The oracle itself is checked against the published verdicts, and
the symbolic engines alone (no explicit-state search) must give the same answers."""

from __future__ import annotations

from dataclasses import dataclass, replace

import pytest

from mlca_verify.logic import check_all
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.results import Result
from mlca_verify.spec import load_spec
from tests.conftest import ROOT
from tests.public.lustre_oracle import MODELS, explore

PUBLIC = ROOT / "tests" / "public"


@dataclass(frozen=True)
class Published:
    prop: str
    verdict: str  # holds (valid) or violated (invalid, falsifiable)
    length: int | None  # the published counterexample's instants, where the source gives them
    where: str  # where the verdict is recorded


KIND2 = "kind2-mc/kind2 tests/regression"
COCO = "coco-team/benchmarks horn_regression"
JKIND = "loonwerks/jkind testing"
FMCAD08 = "kind2-mc/kind2-benchmarks FMCAD08"

PUBLISHED: dict[str, list[Published]] = {
    "two_counters": [Published("OK", "holds", None, f"{COCO}/safe")],
    "speed2": [Published("OK", "holds", None, f"{COCO}/safe")],
    "traffic": [Published("OK", "holds", None, f"{COCO}/safe")],
    "reset_counters_success": [Published("OK", "holds", None, f"{KIND2}/success")],
    "cex_test": [Published("OK", "violated", None, f"{COCO}/cex")],
    "reset_counters_falsifiable": [Published("OK", "violated", None, f"{KIND2}/falsifiable")],
    "jkind_pre": [
        Published("ok1", "holds", None, f"{JKIND}/pre.lus: VALID PROPERTIES"),
        Published("cex1", "violated", None, f"{JKIND}/pre.lus: INVALID PROPERTIES"),
    ],
    "stopwatch": [Published("time_is_less_than_three", "violated", None, f"{KIND2}/falsifiable, {COCO}/cex")],
    "bridge_and_torch": [
        Published("prop1", "holds", None, f"{JKIND}/bridge_and_torch.lus: VALID PROPERTIES"),
        Published("prop2", "violated", 6, f"{JKIND}/bridge_and_torch.lus: INVALID PROPERTIES (k = 6)"),
    ],
    "ex8": [Published("OK", "violated", None, f"{FMCAD08}/Int/misc/ex8.lus: comment 'incorrect'")],
    "six_counter": [Published("OK", "violated", None, f"{FMCAD08}/Bool/misc/_6counter2.lus: comment 'invalid'")],
    "farmer": [Published("prop", "violated", 8, f"{JKIND}/farmer.lus: 'false at K = 8'")],
    # the two below carry no verdict of their own: their headers imply one ("requires the invariant", "requires
    # subnode properties in order to prove")
    "inv_gen": [Published("ok", "holds", None, f"{JKIND}/inv_gen.lus (implied)")],
    "subnode_properties": [
        Published(p, "holds", None, f"{JKIND}/subnode-properties.lus (implied)")
        for p in ("prop", "counter.lemma", "counter2.lemma")
    ],
}


def test_every_translation_is_gated_and_has_its_oracle() -> None:
    stems = sorted(p.stem for p in PUBLIC.glob("*.toml"))
    assert stems == sorted(PUBLISHED) == sorted(MODELS)
    assert sum(p.verdict == "holds" for ps in PUBLISHED.values() for p in ps) == 10
    assert sum(p.verdict == "violated" for ps in PUBLISHED.values() for p in ps) == 8


def _oracle_length(stem: str, prop: str) -> int | None:
    return explore(MODELS[stem]).shortest[prop]


def _gate(stem: str, results: list[Result]) -> list[str]:
    """What breaks the gate: a published property whose verdict flipped or is unknown, or whose counterexample is
    not as long as the published (or the oracle's) one."""
    found = {r.prop: r for r in results}
    problems = []
    for p in PUBLISHED[stem]:
        r = found[p.prop]
        if r.verdict == "unknown":
            problems.append(f"{stem}: {p.prop} is now unknown ({r.detail}); published {p.verdict} ({p.where})")
        elif r.verdict != p.verdict:
            problems.append(f"{stem}: {p.prop} flipped to {r.verdict}; published {p.verdict} ({p.where})")
        elif p.verdict == "violated":
            wanted = p.length if p.length is not None else _oracle_length(stem, p.prop)
            steps = None if r.counterexample is None else len(r.counterexample.steps)
            if steps != wanted:
                problems.append(f"{stem}: {p.prop}'s counterexample has {steps} steps, the shortest has {wanted}")
    return problems


@pytest.mark.parametrize("stem", sorted(PUBLISHED))
def test_published_verdicts_hold_and_counterexamples_are_shortest(stem: str) -> None:
    results = check_all(load_spec(PUBLIC / f"{stem}.toml").machine)
    assert _gate(stem, results) == []
    assert [r.prop for r in results if not r.ok] == []  # the translation's other checks are as it expects


@pytest.mark.parametrize("stem", sorted(PUBLISHED))
def test_the_symbolic_engines_alone_agree(stem: str) -> None:
    results = check_all(load_spec(PUBLIC / f"{stem}.toml").machine, limits=Limits(steps=0))
    assert _gate(stem, results) == []


@pytest.mark.parametrize("stem", sorted(PUBLISHED))
def test_the_oracle_gives_the_published_verdicts(stem: str) -> None:
    explored = explore(MODELS[stem])
    for p in PUBLISHED[stem]:
        length = explored.shortest[p.prop]
        if p.verdict == "violated":
            assert length is not None and (p.length is None or length == p.length), p
        else:
            assert length is None, p
            assert explored.complete or stem == "jkind_pre", p  # pre.lus's delays are searched to 12 instants only


def test_the_gate_fails_on_a_flipped_verdict_and_on_a_longer_counterexample() -> None:
    results = check_all(load_spec(PUBLIC / "farmer.toml").machine)
    flipped = [r if r.prop != "prop" else replace(r, verdict="holds") for r in results]
    assert _gate("farmer", flipped) == [
        "farmer: prop flipped to holds; published violated (loonwerks/jkind testing/farmer.lus: 'false at K = 8')"
    ]
    cx = next(r.counterexample for r in results if r.prop == "prop")
    assert cx is not None
    longer_cx = replace(cx, steps=(*cx.steps, cx.steps[-1]))
    longer = [r if r.prop != "prop" else replace(r, counterexample=longer_cx) for r in results]
    assert _gate("farmer", longer) == ["farmer: prop's counterexample has 9 steps, the shortest has 8"]
