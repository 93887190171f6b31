"""Diagrams: DOT and SVG through Graphviz, Mermaid, and SCXML run in SCION, a W3C SCXML interpreter."""

from __future__ import annotations

import json
import random
import subprocess
from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.diagram import render
from mlca_verify.spec import load_spec
from tests.bruteforce import Explicit
from tests.conftest import ROOT

REPLAY = ROOT / "tools" / "scxml" / "replay.js"
DETERMINISTIC = ["spec/mlca.toml", "spec/mlca_r.toml", "tests/corpus/counter.toml", "tests/corpus/shadowed.toml"]


def scion(scxml: Path, sequences: list[list[dict[str, bool]]]) -> list[list[list[str]]]:
    done = subprocess.run(
        ["node", str(REPLAY), str(scxml)], input=json.dumps(sequences), capture_output=True, text=True, check=True
    )
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


def test_scxml_refuses_a_machine_with_data_and_names_what_it_cannot_carry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The step event carries booleans only: a param, or a guard that compares a number, is named in one line,
    and the other formats still draw the machine."""
    conveyor = ROOT / "tests" / "fixtures" / "conveyor_stop.toml"
    assert main(["diagram", "--format", "scxml", str(conveyor)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"{conveyor}: error: SCXML is not drawn for machines with data (its param NEAR); use dot, mermaid or svg"
    ]
    assert main(["diagram", "--format", "mermaid", str(conveyor)]) == 0
    counter = tmp_path / "counter.toml"
    counter.write_text(
        "[machine]\nname = 'C'\ninitial = 'A'\nstates = ['A', 'B']\n\n[inputs]\ngo = { doc = 'go', cite = 'x' }\n\n"
        "[variables]\nn = { type = 'int', initial = 0, range = [0, 3], every = 'min(n + 1, 3)', doc = 'n', cite = 'x' }\n\n"
        "[[transition]]\nid = 'ab'\nfrom = 'A'\nto = 'B'\nwhen = 'go and n >= 2'\ncite = 'x'\n",
        encoding="utf-8",
    )
    assert main(["diagram", "--format", "scxml", str(counter)]) == 2
    assert "(its variable n)" in capsys.readouterr().err
    edge = tmp_path / "edge.toml"
    edge.write_text(
        "[machine]\nname = 'E'\ninitial = 'A'\nstates = ['A', 'B']\n\n[inputs]\ngo = { doc = 'go', cite = 'x' }\n\n"
        "[[transition]]\nid = 'rise'\nfrom = 'A'\nto = 'B'\nwhen = 'go and 2 > 1'\ncite = 'x'\n",
        encoding="utf-8",
    )
    assert main(["diagram", "--format", "scxml", str(edge)]) == 2
    assert "(rise's guard computes on numbers)" in capsys.readouterr().err
