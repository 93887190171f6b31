"""The explicit-state engine: timers of hundreds to thousands of steps decided with no unknown, its runs the same
counterexamples the symbolic engine builds, and its verdicts the symbolic engine's where both decide."""

from __future__ import annotations

import functools
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
import z3

from mlca_verify.logic import check_all
from mlca_verify.logic.datachecks import DataChecker
from mlca_verify.logic.explicit import _components, _longest, lasso, restricted_edges, sustained
from mlca_verify.logic.finite import Finite
from mlca_verify.logic.induction import Limits, pdr, stopped
from mlca_verify.logic.results import Result
from mlca_verify.logic.symbolic import Frame, StepInputs, StepTerms, System, python_value
from mlca_verify.model import Var
from mlca_verify.spec import load_spec, load_text

ROOT = Path(__file__).resolve().parent.parent
MACHINES = sorted((ROOT / "tests" / "machines").glob("*.toml"))
DATA = [p for p in MACHINES if load_spec(p).machine.has_data]  # the explicit engine serves machines with data
# machines whose deepest counterexample and witness lie within BMC's default depth of 60 (their timers are short;
# the motor limiter's are 20 to 50 steps, one of them a real timer, which the explicit engine does not enumerate)
SHORT_RUNS = {
    "acc_modes_50hz", "battery_bms_10hz", "bus_door", "flasher_100hz", "motor_limiter_1khz", "two_cars_gap_10hz",
    "watchdog_100hz",
}  # fmt: skip
_DEPTH = re.compile(r"^(?:reached in|fires at step) ([\d,]+)")


def _depth(result: Result) -> int:
    """How deep the run that decided `result` is: its counterexample's length, or its witness's step."""
    if result.counterexample is not None:
        return len(result.counterexample.steps)
    found = _DEPTH.match(result.detail)
    return int(found.group(1).replace(",", "")) if found else 0


@functools.cache
def _decided(path: Path) -> tuple[list[Result], DataChecker | None]:
    """`check`'s verdicts on the machine at `path` with the default limits, and for a machine with data the
    checker that gave them (its counterexamples as the explicit engine built them); computed once a worker."""
    machine = load_spec(path).machine
    if not machine.has_data:
        return check_all(machine), None
    checker = DataChecker(machine, Limits())
    return checker.run_all(), checker


def _by_machine(paths: list[Path]) -> list[object]:
    """The machines as parameters, each machine's tests on one worker, so it is decided once."""
    return [pytest.param(p, id=p.stem, marks=pytest.mark.xdist_group(f"explicit:{p.stem}")) for p in paths]


@pytest.mark.parametrize("path", _by_machine(MACHINES))
def test_long_timers_are_decided_with_no_unknown(path: Path) -> None:
    results, _ = _decided(path)
    assert [r.prop for r in results if r.verdict == "unknown"] == []
    assert [r.prop for r in results if not r.ok] == []
    if path.stem not in SHORT_RUNS:
        assert max(_depth(r) for r in results) > 60


# the 100 Hz crossing's runs are ten times as long as the 10 Hz one's, through the same code; the CAN machine's
# and the charger's time goes to witnesses thousands of steps deep, and their counterexamples are short
QUICK = [p for p in DATA if p.stem not in ("crossing_100hz", "can_fault_confinement", "charger_1hz")]


@pytest.mark.parametrize("path", _by_machine([*QUICK, ROOT / "spec" / "mlca_t.toml"]))
def test_explicit_counterexamples_are_the_symbolic_traces_of_the_same_runs(path: Path) -> None:
    _, checker = _decided(path)
    assert checker is not None
    built = list(checker._traces.values())
    assert built
    for found, explicit in built:
        assert checker.traced(found) == explicit


def test_shortest_counterexamples_of_a_long_debounce() -> None:
    results = {r.prop: r for r in check_all(load_spec(ROOT / "tests" / "machines" / "pump_debounce_1khz.toml").machine)}
    # 1,000 hot samples in a row trip the pump: the claim that it never trips fails at the 1,000th step
    never = results["never-trips"].counterexample
    assert never is not None and len(never.steps) == 1000
    assert never.steps[-1].outcome.transition == "trip"
    assert results["fires:trip"].detail == "fires at step 1000"
    # the loop: tripped, then cool forever with no reset; it starts right after the trip
    loop = results["cool-restarts"].counterexample
    assert loop is not None and loop.loop_start is not None and loop.loop_start >= 1000
    assert results["trips-when-hot"].verdict == "holds" and results["hot-ends-tripped"].verdict == "holds"


def test_a_bound_one_step_short_is_violated_and_the_exact_one_holds() -> None:
    text = (ROOT / "tests" / "machines" / "crossing_10hz.toml").read_text()
    served = {}
    for bound in (199, 200, 201):
        machine = load_text(text.replace("within = 205", f"within = {bound}"), "crossing.toml")
        served[bound] = next(r for r in check_all(machine) if r.prop == "served")
    # a press at the step that leaves the walk waits with the request latched and no walk shown through 50 steps
    # of flashing, 10 of all red, 100 of minimum green, 30 of yellow and 10 of all red: 200 steps in a row, so a
    # bound of 200 is met (violated) and 201 is not
    assert [served[b].verdict for b in (199, 200, 201)] == ["violated", "violated", "holds"]
    for bound in (199, 200):
        cx = served[bound].counterexample
        assert cx is not None and sum(1 for s in cx.steps if s.state == "WALK") >= 1
    assert served[201].proof is not None and served[201].proof.engine == "explicit"


@pytest.mark.parametrize("path", _by_machine([*QUICK, ROOT / "spec" / "mlca_t.toml"]))
def test_the_symbolic_engine_agrees_where_it_decides(path: Path) -> None:
    machine = load_spec(path).machine
    explicit = {r.prop: r for r in _decided(path)[0]}
    # the symbolic engines alone, on a small budget: what they leave unknown is not compared (what they decide
    # here takes well under 0.1 s a query; the deep witnesses they cannot find within 10 steps end at the timeout)
    alone = Limits(induction=2, depth=10, lasso=4, timeout_ms=400, steps=0)
    symbolic = {r.prop: r for r in check_all(machine, limits=alone)}
    decided = [p for p, r in symbolic.items() if r.verdict != "unknown"]
    assert decided
    for prop in decided:
        assert symbolic[prop].verdict == explicit[prop].verdict, prop
        cx = symbolic[prop].counterexample
        if cx is not None:
            found = explicit[prop].counterexample
            assert found is not None and len(found.steps) == len(cx.steps), prop


def test_a_machine_that_compares_a_signal_with_a_variable_is_left_to_the_symbolic_engine() -> None:
    spec = """
[machine]
name = "Keep"
initial = "A"
states = ["A", "B"]
[signals]
x = { type = "int", unit = "m", range = [0, 10], doc = "a reading" }
[variables]
level = { type = "int", initial = 0, range = [0, 10], unit = "m", every = "min(level + 1, 10)", doc = "a level" }
[definitions]
above = { expr = "x > level", if_invalid = false, doc = "the reading is above the level" }
[[transition]]
id = "go"
from = "A"
to = "B"
when = "above"
"""
    machine = load_text(spec, "keep.toml")
    finite = Finite(machine, Limits().timeout_ms)
    assert not finite.usable and "x" in finite.reason
    results = {r.prop: r for r in check_all(machine)}
    assert results["fires:go"].verdict == "holds" and results["fires:go"].proof is not None
    assert results["fires:go"].proof.engine != "explicit"


def test_graph_searches_on_small_graphs() -> None:
    # 0 -> 1 -> 2 -> 1 (a loop of two), 2 -> 3, 3 -> 4 (a path of two at the end)
    edges = [[(1, 0)], [(2, 0)], [(1, 1), (3, 0)], [(4, 0)], []]
    order = _components(edges)
    assert sorted(map(sorted, order)) == [[0], [1, 2], [3], [4]]
    assert order.index([4]) < order.index([3]) < order.index(next(c for c in order if 1 in c))  # closed after
    longest = _longest(edges)
    assert longest[4] == 0 and longest[3] == 1 and longest[1] == float("inf") and longest[0] == float("inf")
    assert _longest([[(1, 0)], [(2, 0)], []]) == [2.0, 1.0, 0.0]


def test_lasso_and_sustained_runs_are_the_shortest() -> None:
    machine = load_spec(ROOT / "tests" / "machines" / "pump_debounce_1khz.toml").machine
    finite = Finite(machine, Limits().timeout_ms)
    assert finite.base is not None
    finite.base.run(finite.budget)
    assert finite.base.complete
    search = finite.base
    # every configuration's stem is as long as its depth
    for at in (0, 1, len(search.configs) // 2, len(search.configs) - 1):
        assert len(search.stem(at)) == search.depth[at]
    edges = [[(to, c) for c in range(len(search.classes))] for to in range(1, 3)] + [[] for _ in range(search.done - 2)]
    run = sustained(search, edges, 2)
    assert run is not None and len(run) == 2
    assert sustained(search, edges, 3) is None
    assert lasso(search, edges) is None


@pytest.mark.parametrize("name", ["bus_door", "crossing_10hz", "level_crossing_10hz"])
def test_the_labelled_steps_kept_are_the_steps_taken_again(name: str) -> None:
    """Each response's waiting steps, kept as the search takes them, against every step taken again from every
    configuration expanded and tested with the response's own assumption and goal."""
    finite = Finite(load_spec(ROOT / "tests" / "machines" / f"{name}.toml").machine, Limits().timeout_ms)
    search = finite.base
    assert search is not None and finite.labelled
    search.run(finite.budget)
    assert search.complete
    for k, live_id in enumerate(finite.labelled):
        waiting = finite._waiting(live_id)
        again: list[list[tuple[int, int]]] = [[] for _ in range(search.done)]
        for at in range(search.done):
            for c, cls in enumerate(search.classes):
                taken = search.take(search.configs[at], cls)
                if taken is None or taken[1] is None or taken[3] is None:
                    continue
                if waiting(taken[1]):
                    again[at].append((search.index[taken[3]], c))
        kept = restricted_edges(search, k)
        assert kept == again and any(kept), live_id


def test_an_unknown_says_why_in_words_and_what_to_try() -> None:
    machine = load_spec(ROOT / "tests" / "machines" / "pump_debounce_1khz.toml").machine
    results = check_all(machine, limits=Limits(steps=0, depth=5, induction=1, lasso=2, timeout_ms=50))
    unknown = [r for r in results if r.verdict == "unknown"]
    assert unknown
    for r in unknown:
        assert "canceled" not in r.detail and r.detail, (r.prop, r.detail)
    assert any("ran out of its budget (" in r.detail and "try a larger --timeout-ms" in r.detail for r in unknown)


def test_verdicts_do_not_depend_on_the_machines_load(tmp_path: Path) -> None:
    """z3's resource limit, not the clock, decides when a query gives up: a fresh `check` process gives the same
    verdicts (and the same reasons) while two other processes keep every core busy. Parametric, so that the
    symbolic engines decide, on a budget small enough to leave some properties unknown."""
    spec = ROOT / "tests" / "machines" / "crossing_10hz.toml"

    def verdicts(name: str) -> list[tuple[str, str, str]]:
        out = tmp_path / f"{name}.json"
        command = [sys.executable, "-m", "mlca_verify", "check", str(spec), "--parametric", "--depth", "8"]
        subprocess.run([*command, "--timeout-ms", "300", "--json", str(out), "--quiet"], check=False, timeout=600)
        results = json.loads(out.read_text())["specs"][0]["results"]
        return [(r["property"], r["verdict"], r["detail"]) for r in results]

    idle = verdicts("idle")
    assert any(v == "unknown" for _, v, _ in idle) and any(v == "holds" for _, v, _ in idle)
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        loaded = verdicts("loaded")
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    assert loaded == idle


def test_pdr_answers_the_same_query_the_same_way_in_every_call() -> None:
    """Spacer runs in a z3 process of its own: what ran before a call (other checks, other specs) does not
    change its search, so a query on a tight budget comes out the same in every call (in one shared context
    this one came out proved, proved, proved and unknown in four calls), with the same certificate."""
    machine = load_spec(ROOT / "tests" / "machines" / "crossing_10hz.toml").machine
    invariant = next(i for i in machine.invariants if i.id == "minimum-green")

    def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
        return z3.Not(s.ev(invariant.expr, t.post))

    answers = []
    for _ in range(6):
        system, _real = DataChecker(machine, Limits(steps=0)).systems((invariant.expr,), False)
        found = pdr(system, bad, 300)
        answers.append((found.answer, found.reason, found.certificate_checked, found.certificate))
    assert len(set(answers)) == 1


def test_input_classes_are_every_feasible_combination_with_a_witness() -> None:
    spec = """
[machine]
name = "Classes"
initial = "A"
states = ["A", "B"]
[inputs]
b = { doc = "a free input" }
c = { doc = "an input an assumption ties to the signal" }
[signals]
x = { type = "real", unit = "m", range = [0.0, 10.0], doc = "a reading" }
[definitions]
high = { expr = "x > 5.0", if_invalid = false, doc = "above 5" }
top = { expr = "x > 8.0", if_invalid = false, doc = "above 8" }
[[assume]]
id = "c-when-top"
expr = "top -> c"
[[transition]]
id = "go"
from = "A"
to = "B"
when = "b and high and not top"
"""
    machine = load_text(spec, "classes.toml")
    finite = Finite(machine, Limits().timeout_ms)
    assert finite.usable
    names = [a.name for a in finite.compiler.atoms if isinstance(a, Var)]
    assert sorted(names) == ["high", "top"]
    atoms = [dict(zip(names, cls.atoms, strict=True)) for cls in finite.classes]
    found = {(cls.bools, a["high"], a["top"]) for cls, a in zip(finite.classes, atoms, strict=True)}
    # high and top: (no, no), (yes, no), (yes, yes); top needs c; b is free
    expected = {
        ((b, c), high, top)
        for b in (False, True)
        for c in (False, True)
        for high, top in [(False, False), (True, False), (True, True)]
        if c or not top
    }
    assert found == expected
    for cls in finite.classes:  # each witness realises its class (an invalid sample reads neither high nor top)
        x = python_value(cls.signals[0])
        values = dict(zip(names, cls.atoms, strict=True))
        valid = 0.0 <= x <= 10.0
        assert values["high"] == (valid and x > 5.0) and values["top"] == (valid and x > 8.0)


@pytest.mark.parametrize(
    "raw", ["canceled", "push canceled", "timeout", "max. resource limit exceeded", "resource limits reached"]
)
def test_every_way_z3_says_it_ran_out_is_put_in_words(raw: str) -> None:
    said = stopped(raw, 300)
    assert "canceled" not in said and "ran out of its budget (z3's resources for 300 ms" in said
    assert stopped("smt tactic failed to show goal to be sat/unsat (incomplete quantifiers)", 300).startswith("smt")


def test_a_loop_through_the_initial_state_is_the_shortest_lasso_where_no_register_reads_the_first_step() -> None:
    """Where no prev() register reads whether a step is the first, the configuration before the first step and
    one after a step that differ in that flag alone step alike: they are one, so a lasso may come back to the
    start. Alg. 1's livelock (`gap-taken`) is then the boolean engine's two-step loop through IDLE, not a
    three-step run with a stem, and the search keeps one configuration per state."""
    machine = load_spec(ROOT / "spec" / "mlca.toml").machine
    data = {r.prop: r for r in DataChecker(machine, Limits()).run_all()}
    boolean = {r.prop: r for r in check_all(machine)}
    for prop in ("gap-taken", "left-gap-taken-left"):
        ours, theirs = data[prop].counterexample, boolean[prop].counterexample
        assert ours is not None and theirs is not None
        assert (ours.loop_start, len(ours.steps)) == (theirs.loop_start, len(theirs.steps)) == (0, 2)
        assert [(s.state, s.inputs, s.outcome.transition) for s in ours.steps] == [
            (s.state, s.inputs, s.outcome.transition) for s in theirs.steps
        ]
        assert data[prop].detail.endswith("the run loops through IDLE")
    assert "4 configurations" in data["A1"].detail
    assert data["reach:IDLE"].detail.startswith("the initial state, entered again in 1 step")


def test_a_lasso_still_needs_a_step_where_a_register_reads_the_first_one() -> None:
    """With a prev() register the flag is kept: the first step reads the register's start, later ones its
    value, so the configuration before the first step is not one a loop can come back to."""
    text = (ROOT / "spec" / "mlca.toml").read_text(encoding="utf-8")
    text = text.replace(
        '[[liveness]]\nid = "gap-taken"',
        '[[invariant]]\nid = "prev-read"\nexpr = "prev(N) or not prev(N)"\ncite = "t"\n\n[[liveness]]\nid = "gap-taken"',
        1,
    )
    machine = load_text(text, "prev.toml")
    results = {r.prop: r for r in DataChecker(machine, Limits()).run_all()}
    found = results["gap-taken"].counterexample
    assert found is not None and found.loop_start is not None and found.loop_start >= 1


STALL = """
[machine]
name = "Tank"
initial = "FILL"
states = ["FILL", "FULL"]
otherwise = "undefined"
[inputs]
pump = { doc = "the pump runs" }
[variables]
level = { type = "int", initial = 0, range = [0, 3], every = "min(level + 1, 3)", doc = "the level" }
[[transition]]
from = "FILL"
to = "FILL"
when = "level < 3"
[[transition]]
from = "FILL"
to = "FULL"
when = "level >= 3 and pump"
[[liveness]]
id = "drains"
assume = "pump"
goal = "state == FILL"
[[liveness]]
id = "fills"
assume = "pump"
goal = "state == FULL"
[[liveness]]
id = "drains-within-5"
assume = "pump"
goal = "state == FILL"
within = 5
"""


@pytest.mark.parametrize("limits", [Limits(), Limits(steps=0)], ids=["explicit", "symbolic"])
def test_a_response_is_violated_by_a_machine_stuck_short_of_its_goal(limits: Limits) -> None:
    """Stuck (no transition enabled, otherwise = "undefined") the machine keeps its state: where the assumption
    holds and the goal does not, the goal never comes, however long the bound; stuck where the goal holds, it has
    come. The explicit engine and the symbolic ones (with no configuration to search) say the same."""
    found = {r.prop: r for r in DataChecker(load_text(STALL, "tank.toml"), limits).run_all()}
    for prop in ("drains", "drains-within-5"):
        stuck = found[prop]
        assert stuck.verdict == "violated", (prop, stuck.detail)
        assert stuck.counterexample is not None and stuck.counterexample.steps[-1].outcome.transition is None
        assert stuck.counterexample.steps[-1].state == "FULL" and "gets stuck in FULL" in stuck.detail
    # stuck in FULL, its goal: not violated (the symbolic engines prove no response without a bound: unknown)
    assert found["fills"].verdict == ("holds" if limits.steps else "unknown"), found["fills"].detail


def _first_match_without_data() -> list[Path]:
    paths = [*(ROOT / "spec").rglob("*.toml"), *(ROOT / "tests").rglob("*.toml")]
    found = []
    for path in sorted(paths):
        try:
            machine = load_spec(path, compare=False).machine
        except Exception:  # a spec the loader refuses (the broken fixtures) is not a machine
            continue
        if not machine.has_data and machine.semantics == "first-match":
            found.append(path)
    return found


def test_both_engines_give_every_first_match_machine_without_data_the_same_verdicts() -> None:
    """The engine for machines with data decides a machine without data as the boolean engine does: the same
    verdict on every check and property, and counterexamples as long, looping from the same step (runs stuck
    short of a goal included). This is the step before one engine decides every machine."""
    paths = _first_match_without_data()
    assert len(paths) >= 30
    for path in paths:
        machine = load_spec(path, compare=False).machine
        ours = {r.prop: r for r in DataChecker(machine, Limits()).run_all()}
        theirs = {r.prop: r for r in check_all(machine) if not r.prop.startswith("equiv:")}
        assert ours.keys() == theirs.keys(), path
        for prop, r in theirs.items():
            assert ours[prop].verdict == r.verdict, (path.name, prop, ours[prop].detail, r.detail)
            a, b = ours[prop].counterexample, r.counterexample
            assert (a is None) == (b is None), (path.name, prop)
            if a is not None and b is not None:
                assert (len(a.steps), a.loop_start) == (len(b.steps), b.loop_start), (path.name, prop)
