"""Reports speak of a user's machine in its own words: an element the spec gives no cite shows none (no empty
parentheses in the code, the diagram or the JUnit report), and counts take their noun in the right number."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from mlca_verify.cli import main
from mlca_verify.codegen import generate
from mlca_verify.spec import load_spec
from mlca_verify.words import count
from tests.conftest import ROOT

HEAD = """
[machine]
name = "Lamp"
initial = "OFF"
states = ["OFF", "ON"]
[inputs]
press = { doc = "the button is pressed" }
"""
ON = """
[[transition]]
from = "OFF"
to = "ON"
when = "press"
"""
BOOLEAN = (
    HEAD
    + ON
    + """
[[transition]]
from = "ON"
to = "OFF"
when = "not press"
[[invariant]]
id = "two-states"
expr = "state == ON or state == OFF"
"""
)
DATA = (
    HEAD
    + """
[params]
LIMIT = { type = "int", default = 3, range = [1, 9], doc = "steps on" }
[variables]
n = { type = "int", initial = 0, range = [0, 9], every = "if state == ON then min(n + 1, 9) else 0", doc = "on for" }
"""
    + ON
    + """
[[transition]]
from = "ON"
to = "OFF"
when = "n >= LIMIT"
[[invariant]]
id = "bounded"
expr = "n <= 9"
"""
)


def test_counts_take_their_noun_in_the_right_number() -> None:
    assert [count(n, "step") for n in (0, 1, 2, 1000)] == ["0 steps", "1 step", "2 steps", "1,000 steps"]
    assert count(1, "property", "properties") == "1 property" and count(3, "property", "properties") == "3 properties"


@pytest.mark.parametrize("text", [BOOLEAN, DATA], ids=["boolean", "data"])
def test_an_uncited_machine_shows_no_empty_cite(tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str) -> None:
    spec = tmp_path / "lamp.toml"
    spec.write_text(text)
    junit, report = tmp_path / "junit.xml", tmp_path / "check.json"
    assert main(["check", str(spec), "--junit", str(junit), "--json", str(report)]) == 0
    details = {r["property"]: r["detail"] for r in json.loads(report.read_text())["specs"][0]["results"]}
    assert details["reach:ON"].startswith("reached in 1 step")
    assert not [d for d in details.values() if " 1 steps" in d]
    for rel, generated in generate(load_spec(spec, compare=False), tmp_path).items():
        assert " ()" not in generated, rel
    assert "cite: \n" not in junit.read_text() and "cite:" not in junit.read_text()
    assert main(["diagram", str(spec), "--format", "dot", "--out", str(tmp_path / "d.dot")]) == 0
    assert "Lamp ()" not in (tmp_path / "d.dot").read_text()


WORLD = re.compile(r"\b(traffic|SUMO|lane|lanes|lane-change|ad-rss-lib|RSS|vehicles?|AVs?|MLCA[\w-]*)\b", re.I)


@pytest.mark.slow
def test_the_evidence_of_a_machine_that_is_not_about_lanes_speaks_of_it_alone(tmp_path: Path) -> None:
    """A cruise-control mode manager's bundle has no section or sentence about traffic, SUMO, lanes or RSS."""
    spec = tmp_path / "cm.toml"
    spec.write_text((ROOT / "tests" / "fixtures" / "complement.toml").read_text())
    assert main(["gen", str(spec), "--out", str(tmp_path / "gen")]) == 0
    args = ["evidence", str(spec), "--generated", str(tmp_path / "gen"), "--out", str(tmp_path / "out"), "--no-tests"]
    assert main(args) in (0, 1)
    for name in ("index.html", "evidence.json"):
        text = (tmp_path / "out" / name).read_text().replace("mlca-verify", "")
        assert WORLD.findall(text) == [], name
    assert "Closed-loop runs of the generated code" in (tmp_path / "out" / "index.html").read_text()


PUMP = """
[machine]
name = "Pump"
initial = "IDLE"
states = ["IDLE", "TRIPPED"]
[inputs]
high = { doc = "the temperature sample is high" }
[variables]
n = { type = "int", initial = 0, range = [0, 100], every = "if high then min(n + 1, 100) else 0", doc = "in a row" }
[[transition]]
from = "IDLE"
to = "TRIPPED"
when = "n >= 30"
[[invariant]]
id = "never-trips"
expr = "state == IDLE"
expect = "violated"
"""


def test_a_long_counterexample_is_folded_where_nothing_but_a_count_changes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec, report = tmp_path / "pump.toml", tmp_path / "check.json"
    spec.write_text(PUMP)
    assert main(["check", str(spec), "--json", str(report)]) == 0
    out = capsys.readouterr().out
    assert "steps 2-29: as step 1; n counts 2 to 29" in out
    rows = [line.split()[0] for line in out.splitlines() if line.strip()[:2].isdigit() or line.strip()[:1].isdigit()]
    assert rows[-3:] == ["1", "30", "31"]  # the first step of the run, its last, and the step that trips
    (never,) = [r for r in json.loads(report.read_text())["specs"][0]["results"] if r["property"] == "never-trips"]
    assert len(never["counterexample"]["steps"]) == 31  # the JSON keeps every step
