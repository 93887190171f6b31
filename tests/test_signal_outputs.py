"""Numeric outputs computed from signals (a heater's power request, an ACC's deceleration): each takes its
`if_invalid` value at a step where a sample it reads is invalid, may declare a `range` that the check
`range:<output>` proves, and is generated with a C type chosen from that range. The engine's verdicts are
compared with the independent explorer, and the generated code goes through every conform check."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.errors import SpecError
from mlca_verify.logic import check_all
from mlca_verify.spec import load_spec, load_text
from tests.bruteforce_data import DataExplorer
from tests.conftest import ROOT

HEATER = ROOT / "tests" / "fixtures" / "heater_power.toml"


def _error(old: str, new: str) -> str:
    text = HEATER.read_text(encoding="utf-8")
    assert text.count(old) == 1
    with pytest.raises(SpecError) as info:
        load_text(text.replace(old, new), "heater.toml")
    message = str(info.value)
    assert "\n" not in message
    return message


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        (
            'if_invalid = 0, expr = "if state',
            'expr = "if state',
            "heater.toml:31:63: error: output 'power' reads temp: give 'if_invalid', its value at a step where a "
            "sample is invalid",
        ),
        (
            'heating = { type = "bool", expr',
            'heating = { type = "bool", if_invalid = false, expr',
            "heater.toml:33:41: error: 'if_invalid' applies to an output that reads a signal",
        ),
        (
            "range = [0, 1000], if_invalid = 0,",
            "range = [0, 1000], if_invalid = true,",
            "heater.toml:31:69: error: 'if_invalid' of output 'power' must be a number (int)",
        ),
        (
            "range = [0, 1000], if_invalid = 0,",
            "range = [0, 1000], if_invalid = 2000,",
            "heater.toml:31:69: error: 'if_invalid' 2000 lies outside its range [0, 1000]",
        ),
        (
            "range = [0, 1000], if_invalid = 0,",
            "range = [0, 1000], if_invalid = 0.5,",
            "heater.toml:31:69: error: 'if_invalid' of an int must be a whole number, got 0.5",
        ),
        (
            'heating = { type = "bool", expr',
            'heating = { type = "bool", range = [0, 1], expr',
            "heater.toml:33:36: error: output 'heating' is a bool: a 'range' is for an int or a real",
        ),
        (
            '"range:demand" = "violated"',
            '"range:demandx" = "violated"',
            "heater.toml:65:19: error: unknown built-in check 'range:demandx' in [expect] (one of determinism, "
            "completeness, reach:<state>, fires:<transition id>, range:<variable or output>, div:<name>)",
        ),
    ],
    ids=[
        "no-if-invalid",
        "if-invalid-without-signal",
        "bool-for-int",
        "outside-range",
        "fraction",
        "bool-range",
        "expect",
    ],
)
def test_a_mistake_in_an_output_is_one_line_at_its_place(old: str, new: str, expected: str) -> None:
    assert _error(old, new) == expected


def test_an_output_of_a_signal_is_its_if_invalid_value_at_an_invalid_sample() -> None:
    """The output's value, as loaded: the rule while the sample is valid, `if_invalid` otherwise."""
    m = load_spec(HEATER).machine
    power = next(o for o in m.outputs if o.name == "power")
    assert power.signals == ("temp",) and power.range == (0, 1000)
    assert next(o for o in m.outputs if o.name == "heating").signals == ()


def test_the_engine_agrees_with_brute_force_on_outputs_of_signals() -> None:
    """Every verdict (the range checks of outputs among them) and the length of the range violation, against the
    explorer's enumeration of every sample of `temp`, valid and invalid; without the `if_invalid` value an invalid
    sample would give power in HEATING, and no-power-on-invalid would fail in both."""
    m = load_spec(HEATER).machine
    brute = DataExplorer(m).verdicts()
    engine = {r.prop: r for r in check_all(m) if r.kind != "overflow"}
    assert set(brute) == set(engine)
    assert {p: v.verdict for p, v in brute.items()} == {p: r.verdict for p, r in engine.items()}
    assert engine["range:power"].verdict == "holds" and engine["no-power-on-invalid"].verdict == "holds"
    assert engine["range:demand"].verdict == "violated"
    cx = engine["range:demand"].counterexample
    assert cx is not None and len(cx.steps) == brute["range:demand"].length == 1
    assert cx.steps[0].outputs["demand"] > 50


def test_a_weakened_output_range_is_found(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`range:power` fails when the cap is raised above the range, with the step that leaves it."""
    text = HEATER.read_text(encoding="utf-8").replace("min(max(GAIN * below, 0), P_MAX)", "max(GAIN * below, 0)")
    spec = tmp_path / "heater.toml"
    spec.write_text(text, encoding="utf-8")
    out = tmp_path / "check.json"
    assert main(["check", "--quiet", "--json", str(out), str(spec)]) == 1
    report = json.loads(out.read_text(encoding="utf-8"))
    power = next(r for r in report["specs"][0]["results"] if r["property"] == "range:power")
    assert power["verdict"] == "violated"
    assert any(s["outputs"]["power"] > 1000 for s in power["counterexample"]["steps"])


@pytest.mark.slow
def test_outputs_of_signals_are_generated_narrow_and_pass_every_code_check(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The C types follow the ranges; conform (WP included) and the generated test suite pass."""
    generated = tmp_path / "gen"
    assert main(["gen", "--out", str(generated), str(HEATER)]) == 0
    header = (generated / "c" / "heaterpower_fsm.h").read_text(encoding="utf-8")
    assert "int16_t power; /* the power requested, in [0, 1000] (fixture) */" in header
    assert "int8_t demand;" in header and "bool heating;" in header
    assert main(["conform", "--generated", str(generated), str(HEATER)]) == 0
    assert main(["tests", "--no-target", "--generated", str(generated), "--out", str(tmp_path / "t"), str(HEATER)]) == 0
    assert "every check passed" in capsys.readouterr().out
