"""`mlca-verify evidence NETWORK.toml`: the network's goals, each vehicle's, the channel assumptions, each
machine's code, the closed loop and the replays, in evidence.json and a page that escapes the spec's text."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from mlca_verify.cli import main
from mlca_verify.evidence.network import judged_scenes, v2v_loop
from mlca_verify.evidence.physics import check_replay
from mlca_verify.evidence.runs import ClosedLoopRuns
from mlca_verify.network_report import network_assumptions
from mlca_verify.report_schemas import report_schema
from mlca_verify.spec import load_spec
from sim_check.network_replay import Scene, SceneRun, as_json
from sim_check.radio import V2V, Traffic
from tests.conftest import ROOT

NETWORKS = ROOT / "tests" / "networks"


def _evidence(tmp_path: Path, network: Path, *extra: str) -> tuple[int, dict[str, Any], str]:
    generated = tmp_path / "generated"
    assert main(["gen", "--out", str(generated), str(network)]) == 0
    code = main(["evidence", str(network), "--generated", str(generated), "--out", str(tmp_path / "ev"), *extra])
    doc = json.loads((tmp_path / "ev" / "evidence.json").read_text())
    return code, doc, (tmp_path / "ev" / "index.html").read_text()


def test_a_networks_evidence_holds_its_goals_each_vehicles_its_channels_and_its_code(tmp_path: Path) -> None:
    """ClaimPair's one property is violated as expected (two claims lost at once): the network's goal is
    supported by that verdict, each vehicle's goals by its own proofs, the code by its checks; the channels are
    the assumptions, in the words `check` uses; without --db and --replay those goals are undeveloped."""
    network = NETWORKS / "claim_pair.toml"
    code, doc, page = _evidence(tmp_path, network)
    spec = load_spec(network, network=True)
    assert spec.network is not None
    nodes = {n["id"]: n for n in doc["argument"]}
    assert doc["schema"] == "mlca-verify.network-evidence/1" and code == 0 and doc["ok"] is True
    jsonschema.validate(doc, report_schema("network-evidence"))
    assumptions = [n["text"] for n in doc["argument"] if n["type"] == "assumption"]
    assert assumptions == network_assumptions(spec.network)
    assert [p["property"] for p in doc["proofs"]] == [r["property"] for r in doc["proofs"]]
    assert nodes["G2"]["ok"] is True and len([n for n in nodes if n.startswith("Sn2.")]) == len(doc["proofs"])
    (vehicle,) = doc["vehicles"]  # A and B run one machine with the same params: proved once
    assert vehicle["instances"] == ["A", "B"] and all(p["ok"] for p in vehicle["proofs"])
    machine, frames = doc["code"]
    assert [c["name"] for c in machine["checks"]] == ["up-to-date", "compile", "sequences", "cppcheck", "cortex-m4"]
    assert all(c["ok"] for c in machine["checks"]) and len(machine["files"]) == 3
    assert frames["machine"] == "ClaimPair" and [c["name"] for c in frames["checks"]] == ["up-to-date"]
    assert [f["path"].rsplit("/", 1)[1] for f in frames["files"]] == [
        "claimpair_frames.py",
        "claimpair_frames.h",
        "claimpair_frames.c",
    ]
    assert nodes["G5"]["type"] == nodes["G6"]["type"] == "undeveloped"
    assert doc["closed_loop"] == [] and doc["replays"] is None
    assert "ClaimPair" in page and assumptions[0].split(": ", 1)[1] in page


def test_a_networks_evidence_fails_where_a_vehicles_code_is_stale(tmp_path: Path) -> None:
    """The code of one machine no longer the spec's: the code goal fails, and so the top goal (exit 1)."""
    network = NETWORKS / "claim_pair.toml"
    generated = tmp_path / "generated"
    assert main(["gen", "--out", str(generated), str(network)]) == 0
    for stale in (generated / "c" / "car_fsm.c", generated / "c" / "claimpair_frames.c"):
        kept = stale.read_text()
        stale.write_text(kept + "\n/* edited */\n")
        assert main(["evidence", str(network), "--generated", str(generated), "--out", str(tmp_path / "ev")]) == 1
        doc = json.loads((tmp_path / "ev" / "evidence.json").read_text())
        nodes = {n["id"]: n for n in doc["argument"]}
        assert nodes["G4"]["ok"] is False and nodes["G1"]["ok"] is False and nodes["G2"]["ok"] is True
        failed = [c["detail"] for entry in doc["code"] for c in entry["checks"] if not c["ok"]]
        assert len(failed) == 1 and stale.name in failed[0], failed
        stale.write_text(kept)


def test_a_networks_text_reaches_its_page_escaped(tmp_path: Path) -> None:
    """The network's name, cite and a channel's cite are spec text: escaped on the page, kept in the JSON."""
    folder = tmp_path / "spec"
    folder.mkdir()
    shutil.copy(NETWORKS / "claim_car.toml", folder / "claim_car.toml")
    text = (NETWORKS / "claim_pair.toml").read_text()
    hostile = text.replace('cite = "corpus: two lane changes into one gap"', 'cite = "<script>alert(1)</script>"')
    hostile = hostile.replace('lost = 1\ncite = "corpus"', 'lost = 1\ncite = "<img src=x onerror=alert(2)>"', 1)
    (folder / "pair.toml").write_text(hostile)
    code, doc, page = _evidence(tmp_path, folder / "pair.toml")
    assert code == 0 and doc["network"]["cite"] == "<script>alert(1)</script>"
    assert "<script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "<img" not in page and "&lt;img src=x onerror=alert(2)&gt;" in page


def test_closed_loop_v2v_runs_with_two_avs_into_one_lane_fail_the_loop_goal(tmp_path: Path) -> None:
    db = tmp_path / "r.sqlite"
    db.write_bytes(b"")
    machine = load_spec(NETWORKS / "claim_car.toml")
    runs = ClosedLoopRuns(db, 4, 0, 0, {}, {"sent": 10, "lost": 2, "late": 1, "conflicts": 1})
    section = v2v_loop(runs, machine)
    assert section["status"] == "failed" and "1 time two AVs moved into one lane" in section["detail"]
    quiet = v2v_loop(ClosedLoopRuns(db, 4, 0, 0, {}, {"sent": 10, "conflicts": 0}), machine)
    assert quiet["status"] == "ok" and "10 sent" in quiet["detail"] and quiet["controllers"] == "car-py, car-c"


def test_a_replayed_scene_is_judged_by_its_own_expectation_or_by_the_networks_verdicts() -> None:
    """A scene its own machines drive wants what it expects; one another protocol drives wants no conflict where
    every property of the network holds, and is not judged where one is violated; other machines' scenes are
    left out."""
    own = {"source": "s", "controllers": {"A": "m-c"}, "outcome": "conflict", "expected": "conflict"}
    other = {"source": "s", "controllers": {"A": "m-c"}, "outcome": "conflict", "expected": None}
    foreign = {"source": "s", "controllers": {"A": "x-c"}, "outcome": "none", "expected": None}
    replay = {"networks": [own, other, foreign]}
    held = judged_scenes(replay, {"m-py", "m-c"}, holds=True)
    assert [(s["wanted"], s["ok"]) for s in held] == [("conflict", True), ("none", False)]
    broken = judged_scenes(replay, {"m-py", "m-c"}, holds=False)
    assert [(s["wanted"], s["ok"]) for s in broken] == [("conflict", True), (None, None)]


def test_readings_are_refused_for_a_network(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    network = NETWORKS / "claim_pair.toml"
    args = ["evidence", str(network), "--out", str(tmp_path / "ev"), "--readings", str(NETWORKS / "claim_car.toml")]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("--readings is for a machine spec; a network's readings are its machines' own"), err


SCENE = {
    "source": "spec/v2v/gap_delayed.toml: one-into-the-gap",
    "lanes": {"A": 0, "B": 2},
    "controllers": {"A": "mlca_t_v2v-c", "B": "mlca_t_v2v-c"},
    "radio": {"lost_in_row": 0, "delay": 1},
    "moved_s": {"A": 0.1, "B": 0.1},
    "conflicts": 1,
    "collisions": [["A", "B"]],
    "messages": {"sent": 4, "lost": 0},
    "outcome": "conflict",
    "expected": "conflict",
}


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"outcome": "none"}, "networks[0].outcome is 'none', but its conflicts and collisions say 'conflict'"),
        ({"conflicts": -1}, "networks[0].conflicts is missing or not of its shape"),
        ({"moved_s": {"A": float("nan")}}, "networks[0].moved_s is missing or not of its shape"),
        ({"expected": "maybe"}, 'networks[0].expected must be "conflict", "none" or null'),
    ],
)
def test_a_replayed_scene_is_checked_and_its_outcome_rebuilt(change: dict[str, Any], message: str) -> None:
    """A replay is data from outside: a scene whose outcome its own counts contradict is refused, never shown."""
    doc = {"schema": "mlca-sim.replay/1", "points": [], "networks": [{**SCENE, **change}]}
    with pytest.raises(ValueError, match="^r.json: " + re.escape(message)):
        check_replay(doc, "r.json")
    assert check_replay({**doc, "networks": [SCENE]}, "r.json")["networks"] == [SCENE]


def test_the_closed_loops_scene_document_is_what_the_evidence_reads() -> None:
    """`mlca-sim replay --json` writes a scene with network_replay.as_json: the evidence's check reads it back."""
    scene = Scene("n.toml: p", {"A": 0, "B": 2}, {"A": (True, True)}, {"A": "m-c", "B": "m-c"}, V2V(delay=2))
    run = SceneRun({"A": 0.7}, [["A", "B"]], Traffic(sent=3, lost=1, conflicts=1))
    doc = {"schema": "mlca-sim.replay/1", "points": [], "networks": [as_json(scene, run)]}
    (checked,) = check_replay(json.loads(json.dumps(doc)), "r.json")["networks"]
    assert checked["outcome"] == "conflict" and checked["controllers"] == {"A": "m-c", "B": "m-c"}
