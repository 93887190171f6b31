"""Diagrams: DOT and SVG through Graphviz, Mermaid, and SCXML run in SCION, a W3C SCXML interpreter."""

from __future__ import annotations

import itertools
import json
import random
import subprocess
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import pytest

from mlca_verify.cli import main
from mlca_verify.codegen import generate, write
from mlca_verify.diagram import render
from mlca_verify.loading import import_generated
from mlca_verify.spec import load_spec
from tests.bruteforce import Explicit
from tests.conftest import ROOT

REPLAY = ROOT / "tools" / "scxml" / "replay.js"
_COUNT = itertools.count()
DETERMINISTIC = ["spec/mlca.toml", "spec/mlca_r.toml", "tests/corpus/counter.toml", "tests/corpus/shadowed.toml"]


def scion(scxml: Path, sequences: list[list[dict[str, Any]]], data: bool = False) -> list[list[Any]]:
    command = ["node", str(REPLAY), str(scxml), *(["data"] if data else [])]
    done = subprocess.run(command, input=json.dumps(sequences), capture_output=True, text=True, check=True)
    return [json.loads(line) for line in done.stdout.splitlines()]


@pytest.mark.parametrize("spec", DETERMINISTIC)
def test_scxml_runs_in_a_w3c_interpreter_exactly_like_the_spec(spec: str, tmp_path: Path) -> None:
    machine = load_spec(ROOT / spec, compare=False).machine
    path = tmp_path / "machine.scxml"
    assert main(["diagram", str(ROOT / spec), "--format", "scxml", "--out", str(path)]) == 0
    rng = random.Random(7)
    names = machine.input_names
    sequences = [[{n: rng.random() < 0.6 for n in names} for _ in range(25)] for _ in range(40)]
    ex = Explicit(machine)
    for sequence, configurations in zip(sequences, scion(path, sequences), strict=True):
        state = machine.initial
        assert configurations[0] == [state]
        for inputs, configuration in zip(sequence, configurations[1:], strict=True):
            state = ex.fired(state, inputs)[0][1]
            assert configuration == [state], (inputs, configuration, state)


def test_scxml_is_rejected_by_scion_when_broken(tmp_path: Path) -> None:
    text = render(load_spec(ROOT / "spec/mlca.toml", compare=False).machine, "scxml")
    path = tmp_path / "broken.scxml"
    path.write_text(text.replace("</scxml>", ""))
    done = subprocess.run(["node", str(REPLAY), str(path)], input="[]", capture_output=True, text=True, check=False)
    assert done.returncode != 0


def test_dot_becomes_svg_through_graphviz(tmp_path: Path) -> None:
    out = tmp_path / "mlca.svg"
    assert main(["diagram", str(ROOT / "spec/paper/figure.toml"), "--format", "svg", "--out", str(out)]) == 0
    svg = out.read_text()
    assert svg.lstrip().startswith("<?xml") and "<svg" in svg
    for label in ("N and W", "idle_wait", "MOVING_RIGHT", "no priority"):
        assert label in svg


def test_dot_and_mermaid_draw_every_transition(capsys: pytest.CaptureFixture[str]) -> None:
    machine = load_spec(ROOT / "spec/mlca.toml", compare=False).machine
    assert main(["diagram", str(ROOT / "spec/mlca.toml"), "--format", "dot"]) == 0
    dot = capsys.readouterr().out
    mermaid = render(machine, "mermaid")
    for t in machine.transitions:
        assert f"[{t.id}]" in dot
    assert mermaid.startswith("stateDiagram-v2\n") and "[*] --> IDLE" in mermaid
    assert "    WAITING --> IDLE: 2. N and (L or R)" in mermaid
    assert dot.count(" -> ") == 1 + sum(len(machine.outgoing(s)) for s in machine.states)


DATA_MACHINES = [
    "spec/mlca_t.toml",
    "tests/machines/acc_modes_50hz.toml",
    "tests/machines/watchdog_100hz.toml",
    "tests/machines/thermostat_1hz.toml",
    "tests/machines/charger_1hz.toml",
    "tests/machines/motor_limiter_1khz.toml",
    "tests/fixtures/conveyor_stop.toml",
]


def _sample(rng: random.Random, low: float, high: float, integral: bool) -> float:
    """A sample in range most of the time, else just outside it (invalid)."""
    roll = rng.random()
    if roll < 0.08:
        return low - 1
    if roll < 0.16:
        return high + 1
    value = rng.uniform(low, high)
    return float(round(value)) if integral else value


@pytest.mark.parametrize("spec", DATA_MACHINES)
def test_scxml_of_a_machine_with_data_runs_in_scion_like_the_generated_code(spec: str, tmp_path: Path) -> None:
    """The datamodel's variables and outputs after every step, and the state, are the generated Python's, on
    random inputs and samples (some outside their ranges), in a W3C SCXML interpreter."""
    loaded = load_spec(ROOT / spec, compare=False)
    m = loaded.machine
    path = tmp_path / "machine.scxml"
    assert main(["diagram", str(ROOT / spec), "--format", "scxml", "--out", str(path)]) == 0
    write(generate(loaded, tmp_path / "gen"), tmp_path / "gen")
    module_file = next((tmp_path / "gen" / "python").glob("*_fsm.py"))
    code = import_generated(module_file, f"scxml_{module_file.stem}_{next(_COUNT)}")
    rng = random.Random(11)
    sequences = [
        [
            {
                **{i.name: rng.random() < 0.6 for i in m.inputs},
                **{s.name: _sample(rng, float(s.range[0]), float(s.range[1]), s.type == "int") for s in m.signals},
            }
            for _ in range(30)
        ]
        for _ in range(25)
    ]
    for sequence, steps in zip(sequences, scion(path, sequences, data=True), strict=True):
        c = code.Context()
        kept = (code.Observers(),) if hasattr(code, "Observers") else ()  # an observer: the monitor keeps it
        assert steps[0]["state"] == [m.initial] and steps[0]["v"] == {v.name: int(v.initial) for v in m.variables}
        for inputs, seen in zip(sequence, steps[1:], strict=True):
            before, i = code.Context(**vars(c)), code.Inputs(**inputs)
            out = code.step(c, i)
            code.monitor(before, c, i, code.DEFAULT_PARAMS, out, *kept)
            holder = {v.name: kept[0] if v.observer else c for v in m.variables}
            assert seen["state"] == [code.State(c.mode).name], (inputs, seen)
            assert seen["v"] == {v.name: getattr(holder[v.name], v.name) for v in m.variables}, (inputs, seen)
            assert seen["o"] == {o.name: getattr(out, o.name) for o in m.outputs}, (inputs, seen)


def test_scxml_of_a_machine_with_data_parses_with_its_datamodel() -> None:
    """The document parses, names each state once, and carries the params, variables, outputs and one function
    per definition."""
    text = render(load_spec(ROOT / "tests/machines/acc_modes_50hz.toml", compare=False).machine, "scxml")
    root = ElementTree.fromstring(text)
    ns = "{http://www.w3.org/2005/07/scxml}"
    assert [s.get("id") for s in root.iter(f"{ns}state")] == ["OFF", "STANDBY", "ACTIVE", "FAULT"]
    assert [d.get("id") for d in root.iter(f"{ns}data")] == ["p", "v", "o"]
    assert "function d0(st, v, e, p)" in text and "function d2(st, v, e, p)" in text
