"""The corpus of machines unlike MLCA (tests/machines/) through the code-side commands: diagrams in every format a
machine with data is drawn in, the regression gate against a weakened copy, the generated test suites (every gap
in the code's coverage with its reason), and Frama-C WP on a machine whose timers count to thousands."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from xml.etree import ElementTree

import pytest
from bench.bench_corpus import weakened

from mlca_verify.cli import main
from mlca_verify.conformance.outcome import CHECKS, CheckOutcome
from mlca_verify.evidence.collect import Evidence, argument
from mlca_verify.logic import check_all
from mlca_verify.spec import load_spec
from tests.bruteforce_data import DataExplorer
from tests.conftest import ROOT
from tests.test_data_vs_bruteforce import check_replay

SCXML_NS = "{http://www.w3.org/2005/07/scxml}"
CORPUS = sorted((ROOT / "tests" / "machines").glob("*.toml"))


def test_the_corpus_holds_the_machines() -> None:
    assert [p.stem for p in CORPUS] == [
        "acc_modes_50hz",
        "battery_bms_10hz",
        "bus_door",
        "can_fault_confinement",
        "charger_1hz",
        "crossing_100hz",
        "crossing_10hz",
        "elevator_3floor_10hz",
        "flasher_100hz",
        "garage_door_10hz",
        "handshake_1khz",
        "infusion_1hz",
        "level_crossing_10hz",
        "motor_limiter_1khz",
        "pump_debounce_1khz",
        "seatbelt_10hz",
        "tank_fill_1hz",
        "thermostat_1hz",
        "two_cars_gap_10hz",
        "washer_10hz",
        "watchdog_100hz",
    ]


@pytest.mark.parametrize("spec", CORPUS, ids=[p.stem for p in CORPUS])
def test_every_diagram_format_of_a_corpus_machine(
    spec: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for fmt in ("dot", "mermaid", "svg"):
        out = tmp_path / f"d.{fmt}"
        assert main(["diagram", "--format", fmt, "--out", str(out), str(spec)]) == 0
        assert out.stat().st_size > 0
    assert (tmp_path / "d.svg").read_text(encoding="utf-8").lstrip().startswith(("<?xml", "<svg"))
    capsys.readouterr()
    assert main(["diagram", "--format", "scxml", str(spec)]) == 0
    scxml = capsys.readouterr().out
    assert scxml.startswith('<?xml version="1.0" encoding="UTF-8"?>')
    states = [s.get("id") for s in ElementTree.fromstring(scxml.split("\n", 1)[1]).iter(f"{SCXML_NS}state")]
    assert states == list(load_spec(spec).machine.states)


def test_diff_against_a_weakened_copy_is_a_regression(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = ROOT / "tests" / "machines" / "pump_debounce_1khz.toml"
    text = spec.read_text(encoding="utf-8")
    assert text.count("within = 1000") == 1
    weaker = tmp_path / "pump.toml"
    weaker.write_text(text.replace("within = 1000", "within = 2000"), encoding="utf-8")
    assert main(["diff", str(spec), str(weaker)]) == 1
    out = capsys.readouterr().out
    assert "1 weakened: trips-when-hot now guarantees less than before (a regression)" in out
    assert main(["diff", str(spec), str(spec)]) == 0


@pytest.mark.parametrize("name", ["flasher_100hz", "infusion_1hz", "seatbelt_10hz", "tank_fill_1hz"])
def test_diff_against_a_copy_with_an_added_assumption_is_a_regression(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A weaker copy of each machine: one more `[[assume]]`, on its first boolean input or its first signal's
    validity, narrows the environments every guarantee covers."""
    spec = ROOT / "tests" / "machines" / f"{name}.toml"
    assert main(["diff", str(spec), str(weakened(spec, tmp_path))]) == 1
    out = capsys.readouterr().out
    assert "assumptions narrowed: weaker allow fewer environments, so every guarantee is weaker (a regression)" in out


SUITES = [
    "acc_modes_50hz",
    "bus_door",
    "can_fault_confinement",
    "charger_1hz",
    "elevator_3floor_10hz",
    "flasher_100hz",
    "garage_door_10hz",
    "infusion_1hz",
    "seatbelt_10hz",
    "tank_fill_1hz",
    "thermostat_1hz",
]  # the pump's helper gap: test_testgen.py
NEVER_FAILS = {  # an invariant no context breaks
    "elevator_3floor_10hz": "no-move-with-doors-open",
    "acc_modes_50hz": "decel-only-when-active",
    "charger_1hz": "current-limited",
    "flasher_100hz": "one-side-from-the-stalk",
    "garage_door_10hz": "lamp-while-moving",
}


@pytest.mark.slow
@pytest.mark.parametrize("name", SUITES)
def test_the_suite_of_a_corpus_machine_leaves_no_gap_without_a_reason(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Each of these once failed `tests`: the cruise control's suite never stepped from ACTIVE (a realized signal
    broke the run the search had found), gaps in a definition's function or the shared min helper had no
    reason, a CAN counter's choice nested in an `if` was paired where the C never evaluates it, and a charger's
    real output, rounded by binary64, failed the suite's exact comparison."""
    spec = ROOT / "tests" / "machines" / f"{name}.toml"
    generated, out = tmp_path / "gen", tmp_path / "tests"
    assert main(["gen", "--out", str(generated), str(spec)]) == 0
    assert main(["tests", "--no-target", "--generated", str(generated), "--out", str(out), str(spec)]) == 0
    said = capsys.readouterr().out
    assert "every check passed" in said
    (report,) = out.glob("*/coverage.json")
    coverage = json.loads(report.read_text(encoding="utf-8"))["coverage"]
    python = next(c for c in coverage if c["file"].endswith(".py"))
    if name in NEVER_FAILS:  # over outputs that are functions of the state: its failing branch is never run
        assert python["gaps"] and all(f"in inv:{NEVER_FAILS[name]}: no context" in g["reason"] for g in python["gaps"])
    else:
        assert python["statements"]["percent"] == 100.0 and python["branches"]["percent"] == 100.0
    assert all(g["reason"] for c in coverage for g in c["gaps"])


@pytest.mark.slow
def test_wp_proves_the_step_and_the_certified_invariants_of_a_timer_machine(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The 10 Hz crossing's step (proved against the spec's first enabled transition, a logic function) and its
    request-kept invariant with its certificate (which holds on contexts whose mode is a state, not after a
    reset)."""
    spec = ROOT / "tests" / "machines" / "crossing_10hz.toml"
    generated = tmp_path / "gen"
    assert main(["gen", "--out", str(generated), str(spec)]) == 0
    assert main(["conform", "--only", "frama-c-wp", "--generated", str(generated), str(spec)]) == 0
    said = capsys.readouterr().out
    assert "not proved" not in said.replace("crossing10hz_monitor is not proved", "")
    assert "3 invariant(s) proved on the step with their certificates" in said


BRUTE = [
    "crossing_10hz",
    "elevator_3floor_10hz",
    "level_crossing_10hz",
    "watchdog_100hz",
]  # the explorer enumerates int and bool inputs


@pytest.mark.slow
@pytest.mark.parametrize("name", BRUTE)
def test_the_engine_agrees_with_brute_force_on_a_corpus_machine(name: str) -> None:
    """Every verdict `check` gives, and the length of every counterexample (the shortest), against the
    independent explorer's enumeration of the machine's configurations; each counterexample replays there."""
    machine = load_spec(ROOT / "tests" / "machines" / f"{name}.toml").machine
    ex = DataExplorer(machine)
    brute = ex.verdicts()
    engine = {r.prop: r for r in check_all(machine) if r.kind != "overflow"}  # 64-bit carries: test_carry.py
    assert set(brute) == set(engine)
    for prop, expected in brute.items():
        result = engine[prop]
        assert result.verdict == expected.verdict, prop
        if expected.length is not None:
            assert result.counterexample is not None, prop
            assert len(result.counterexample.steps) == expected.length, prop
            check_replay(ex, prop, result.counterexample, False)


def test_the_evidence_of_a_corpus_machine_claims_what_its_proofs_give(tmp_path: Path) -> None:
    """A pump debounce proved at its calibrated params: its argument claims the properties at the params'
    defaults (none is declared parametric) and every claim its proofs back is supported; it once claimed every
    param value in range and failed for want of parametric proofs the spec never asked for. Declared
    parametric, a property whose proof is not parametric fails the goal."""
    spec = load_spec(ROOT / "tests" / "machines" / "pump_debounce_1khz.toml")
    passed = [CheckOutcome(n, True, "passed") for n in ("up-to-date", *CHECKS)]  # the argument is the subject
    ev = Evidence(spec, check_all(spec.machine), passed, tmp_path, [], "now", loop={"status": "undeveloped"})
    nodes = {n["id"]: n for n in argument(ev)}
    assert ev.ok and nodes["G1"]["ok"] is True and "at the params' defaults" in nodes["G1"]["text"]
    assert nodes["G3"]["type"] == "context" and "parametric = true" in nodes["G3"]["text"]
    assert [n["id"] for n in nodes.values() if n["ok"] is False] == []
    claimed = spec.machine.invariants[0]
    asked = replace(spec, machine=replace(spec.machine, invariants=(replace(claimed, parametric=True),)))
    ev = Evidence(asked, check_all(asked.machine), passed, tmp_path, [], "now", loop={"status": "undeveloped"})
    nodes = {n["id"]: n for n in argument(ev)}
    proof = next(r.proof for r in ev.results if r.prop == claimed.id)
    assert proof is not None and proof.parametric  # k-induction over DEBOUNCE's whole range
    assert nodes["G3"]["type"] == "goal" and nodes["G3"]["ok"] is True and ev.ok
    assert [n["text"].split(" ")[0] for n in nodes.values() if n["parent"] == "G3"] == [claimed.id]
    unproved = replace(
        ev,
        results=[replace(r, proof=replace(proof, parametric=False)) if r.prop == claimed.id else r for r in ev.results],
    )
    assert not unproved.ok and {n["id"]: n for n in argument(unproved)}["G3"]["ok"] is False


@pytest.mark.slow
def test_random_runs_of_a_machine_with_an_assumption_keep_to_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The washer's spin-ends-done-or-drained rests on lock-holds (the door stays shut while the drum turns):
    random runs that opened the door in a spin once reported it as a proved invariant failing. Each step's
    inputs are now drawn within the assumptions, and the certified wrapper WP proves requires them."""
    spec = ROOT / "tests" / "machines" / "washer_10hz.toml"
    generated = tmp_path / "gen"
    assert main(["gen", "--out", str(generated), str(spec)]) == 0
    assert main(["conform", "--only", "sequences", "--generated", str(generated), str(spec)]) == 0
    said = capsys.readouterr().out
    assert "no proved invariant fails" in said and "outside them" not in said
    from mlca_verify.codegen.acsl import AcslLowering
    from mlca_verify.codegen.certified import assumed_text

    machine = load_spec(spec).machine
    text = assumed_text(machine, AcslLowering.of(machine, "washer", "WASHER"))
    assert "WASHER_WASH" in text and "WASHER_SPIN" in text and "door_closed" in text
