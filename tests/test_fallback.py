"""The fallback state: where the generated code restarts a context whose state value names no state (a corrupted
context). A spec names it (`fallback`, default the initial state); the Python, the C, its ACSL contract, conform's
checks and the generated test suites all restart there, with the rest of the context as initially."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest

from mlca_verify.cli import main
from mlca_verify.conformance import conform
from mlca_verify.conformance.outcome import CHECKS, CheckOutcome
from mlca_verify.diagram import FORMATS, render
from mlca_verify.errors import SpecError
from mlca_verify.evidence.collect import Evidence, document
from mlca_verify.evidence.page import render_page
from mlca_verify.loading import import_generated
from mlca_verify.logic import check_all
from mlca_verify.spec import load_spec, load_text
from tests.conftest import ROOT

DOOR = """\
[machine]
name = "Door"
initial = "SHUT"
fallback = "LOCKED"
states = ["SHUT", "OPEN", "LOCKED"]

[inputs]
open = { doc = "open it" }
lock = { doc = "lock it" }
reset = { doc = "back to shut, from anywhere" }

[[transition]]
from = "*"
to = "SHUT"
when = "reset"

[[transition]]
from = "SHUT"
to = "OPEN"
when = "open and not lock"

[[transition]]
from = "SHUT"
to = "LOCKED"
when = "lock"

[[invariant]]
id = "shut-on-reset"
expr = "reset -> state == SHUT"
"""


def _error(text: str) -> str:
    with pytest.raises(SpecError) as info:
        load_text(text, "door.toml")
    assert "\n" not in str(info.value)
    return str(info.value)


def test_the_fallback_is_a_state_and_defaults_to_the_initial_one() -> None:
    assert load_text(DOOR, "door.toml").fallback_state == "LOCKED"
    assert load_text(DOOR.replace('fallback = "LOCKED"\n', ""), "door.toml").fallback_state == "SHUT"
    message = _error(DOOR.replace('fallback = "LOCKED"', 'fallback = "AJAR"'))
    assert message == "door.toml:4:12: error: fallback state 'AJAR' is not a state (SHUT, OPEN, LOCKED)"


@pytest.mark.parametrize(
    ("old", "new", "clash"),
    [
        ('"LOCKED"]', '"FALLBACK"]', "state name 'FALLBACK' clashes with the generated C name <MACHINE>_FALLBACK"),
        ('"LOCKED"]', '"FAILING"]', "state name 'FAILING' clashes with the generated C name <MACHINE>_FAILING"),
        ("[inputs]", '[params]\nDOOR_INITIAL = { type = "int", default = 1, doc = "d" }\n[inputs]', "DOOR_INITIAL"),
        ("[inputs]", '[params]\nDOOR_FALLBACK = { type = "int", default = 1, doc = "d" }\n[inputs]', "DOOR_FALLBACK"),
    ],
)
def test_a_name_the_generated_header_defines_is_refused(old: str, new: str, clash: str) -> None:
    text = DOOR.replace('fallback = "LOCKED"\n', "").replace(old, new)
    message = _error(text)
    assert clash in message
    if "param" in new:
        assert f"param name '{clash}' clashes with the macro {clash} of the generated C header" in message


def test_a_boolean_machine_restarts_in_its_fallback_even_where_a_transition_from_every_state_is_enabled(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The `from = "*"` reset leads to the initial state; the generated code tests such transitions once before
    it tells the states apart, which was right while the initial state was where a bad state value went too."""
    spec = tmp_path / "door.toml"
    spec.write_text(DOOR, encoding="utf-8")
    generated = tmp_path / "gen"
    assert main(["gen", "--out", str(generated), str(spec)]) == 0
    door = import_generated(generated / "python" / "door_fsm.py", "door_fsm_fallback")
    assert door.FALLBACK == door.State.LOCKED and door.INITIAL == door.State.SHUT

    def step(mode: int, **inputs: bool) -> int:
        ctx = door.Context(mode=mode)
        door.step(ctx, door.Inputs(**inputs))
        return int(ctx.mode)

    for reset in (False, True):
        assert step(7, open=True, lock=False, reset=reset) == door.State.LOCKED
    assert step(door.State.OPEN, open=False, lock=False, reset=True) == door.State.SHUT
    header = (generated / "c" / "door_fsm.h").read_text(encoding="utf-8")
    assert "#define DOOR_FALLBACK DOOR_LOCKED" in header
    checks = "compile,exhaustive,sequences,sanitizers,frama-c-wp,cppcheck"
    assert main(["conform", "--only", checks, "--generated", str(generated), str(spec)]) == 0
    said = capsys.readouterr().out
    assert "from a mode that names no state: both restart in LOCKED" in said and "frama-c-wp  pass" in said


def test_a_machine_with_data_restarts_in_its_fallback_with_its_initial_values(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The 10 Hz crossing restarts a corrupted context with all red before the cars' green, not with the cars'
    green (its initial state); conform steps such contexts in Python and C from every boundary input."""
    spec = ROOT / "tests" / "machines" / "crossing_10hz.toml"
    assert load_spec(spec).machine.fallback_state == "ALL_RED_OUT"
    generated = tmp_path / "gen"
    assert main(["gen", "--out", str(generated), str(spec)]) == 0
    crossing = import_generated(generated / "python" / "crossing10hz_fsm.py", "crossing_fallback")
    ctx = crossing.Context()
    ctx.mode = 99
    if hasattr(ctx, "first"):  # kept only where a register reads an input (see model.stored_registers)
        ctx.first = False
    for name, value in vars(crossing.Context()).items():
        if name not in ("mode", "first"):
            setattr(ctx, name, value + 1 if isinstance(value, int) and not isinstance(value, bool) else value)
    crossing.step(ctx, crossing.Inputs(button=True))
    assert vars(ctx) == vars(crossing.Context(mode=crossing.State.ALL_RED_OUT))
    c_source = (generated / "c" / "crossing10hz_fsm.c").read_text(encoding="utf-8")
    assert "crossing10hz_restart(&next);" in c_source
    assert "k < 0 ? (n.mode == CROSSING10HZ_FALLBACK && crossing10hz_fresh(n))" in c_source
    assert main(["conform", "--only", "exhaustive,cppcheck", "--generated", str(generated), str(spec)]) == 0
    said = capsys.readouterr().out
    assert "steps from a mode that names no state: both restart in ALL_RED_OUT with the initial values" in said


@pytest.mark.parametrize("planted", ["c", "both"])
def test_a_restart_in_the_initial_state_is_caught(tmp_path: Path, planted: str) -> None:
    """Code that restarts a corrupted crossing with the cars' green: in C alone Python and C differ; in both, only
    the spec's fallback tells that they are wrong."""
    spec = ROOT / "tests" / "machines" / "crossing_10hz.toml"
    generated = tmp_path / "gen"
    assert main(["gen", "--out", str(generated), str(spec)]) == 0
    plants = [("c/crossing10hz_fsm.c", "c->mode = CROSSING10HZ_FALLBACK;", "c->mode = CROSSING10HZ_INITIAL;")]
    if planted == "both":
        plants.append(("python/crossing10hz_fsm.py", "Context(mode=FALLBACK)", "Context(mode=INITIAL)"))
    for rel, old, new in plants:
        text = (generated / rel).read_text(encoding="utf-8")
        assert old in text
        (generated / rel).write_text(text.replace(old, new), encoding="utf-8")
    outcomes = conform(load_spec(spec, compare=False), generated, ["exhaustive"], lambda _: None).outcomes
    exhaustive = next(o for o in outcomes if o.name == "exhaustive")
    assert not exhaustive.ok
    if planted == "c":
        assert exhaustive.detail.startswith("Python and C differ from (6, ")
    else:
        assert exhaustive.detail.endswith("no state) the code restarted as (0, 0, 0, 0), not as (5, 0, 0, 0)")


def test_diff_names_a_changed_fallback(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    old, new = tmp_path / "old.toml", tmp_path / "new.toml"
    old.write_text(DOOR.replace('fallback = "LOCKED"\n', ""), encoding="utf-8")
    new.write_text(DOOR, encoding="utf-8")
    assert main(["diff", str(old), str(new)]) == 0
    assert "fallback: a context whose state names no state now restarts in LOCKED (was SHUT)" in capsys.readouterr().out
    assert main(["diff", str(new), str(new)]) == 0
    assert "fallback:" not in capsys.readouterr().out


def test_the_diagrams_mark_the_fallback_and_say_nothing_of_a_default_one() -> None:
    door = load_text(DOOR, "door.toml")
    said = "a corrupted state restarts in LOCKED"
    assert said in render(door, "dot") and '  LOCKED [xlabel="fallback"];' in render(door, "dot")
    assert "    note right of LOCKED: fallback, a corrupted state restarts here" in render(door, "mermaid")
    assert said in render(door, "scxml")
    plain = load_text(DOOR.replace('fallback = "LOCKED"\n', ""), "door.toml")
    assert all("fallback" not in render(plain, fmt) and "restarts" not in render(plain, fmt) for fmt in FORMATS)


def test_the_evidence_names_the_states_the_initial_one_and_the_fallback(tmp_path: Path) -> None:
    path = ROOT / "tests" / "machines" / "crossing_10hz.toml"
    assert main(["gen", "--out", str(tmp_path), str(path)]) == 0
    spec = load_spec(path)
    passed = [CheckOutcome(n, True, "passed") for n in ("up-to-date", *CHECKS)]
    loop = {"status": "undeveloped", "detail": "no closed-loop runs"}
    doc = document(Evidence(spec, check_all(spec.machine), passed, tmp_path, [], "now", loop=loop))
    schema = json.loads((ROOT / "src/mlca_verify/schemas/evidence-1.schema.json").read_text())
    jsonschema.validate(doc["spec"], schema["properties"]["spec"])
    assert doc["spec"]["states"] == list(spec.machine.states) and doc["spec"]["initial"] == "CARS_GREEN"
    assert doc["spec"]["fallback"] == "ALL_RED_OUT" and 'ALL_RED_OUT [xlabel="fallback"]' in doc["spec"]["dot"]
    page = render_page(doc)
    assert (
        "It starts in <code>CARS_GREEN</code>; generated code restarts a context whose state names no state "
        "(a corrupted context) in\n<code>ALL_RED_OUT</code> (the spec&#39;s fallback)." in page
    )
    drawn = page[page.index('<div class="drawn">') :]
    assert drawn.startswith('<div class="drawn"><svg') and ">fallback</text>" in drawn[: drawn.index("</svg>")]
