"""`mlca-sim replay`: a lemma's counterexample as traffic in SUMO. The old time-gap rule's counterexample ends in a
collision or in braking beyond a declared limit; a gap MLCA-T's L accepts ends in neither. Bad replay files are
one-line errors with exit 2, before SUMO starts."""

from __future__ import annotations

import json
import math
from fractions import Fraction
from pathlib import Path

import pytest

from mlca_verify.cli import main as verify
from mlca_verify.model import Var
from mlca_verify.spec import load_spec
from sim_check.cli import main
from sim_check.replay import AD_RSS_DEFAULTS, Point, front_speed, horizon, load_points, rear_speed, replay
from tests.bruteforce_data import Point as At
from tests.bruteforce_data import ev
from tests.conftest import ROOT
from tests.page_sessions import run_session, sessions

MLCA_T = ROOT / "spec" / "mlca_t.toml"
EDGE = ROOT / "docs" / "lemmas" / "replay_rss_edge.toml"
HIGHWAY = "time-gap-rule-is-rss-safe-on-the-highway"


def _l_accepts(point: Point) -> bool:
    """MLCA-T's L at the point, by the brute-force evaluator (exact arithmetic, no code shared with the engine)."""
    machine = load_spec(MLCA_T).machine
    params = {p.name: Fraction(p.default) for p in machine.params} | {k: Fraction(v) for k, v in point.params.items()}
    signals = {s.name: Fraction(0) for s in machine.signals} | {
        "v": Fraction(point.v),
        "gap_lead_left": Fraction(point.gap_lead),
        "v_lead_left": Fraction(point.v_lead),
        "gap_follow_left": Fraction(point.gap_follow),
        "v_follow_left": Fraction(point.v_follow),
    }
    at = At(machine, "IDLE", {"waited": 0, "need_age": 0}, {**signals, "N": True, "U": False}, params)
    return bool(ev(Var("L"), at))


@pytest.fixture(scope="module")
def check_json(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("replay") / "check.json"
    assert verify(["check", str(MLCA_T), "--only", f"{HIGHWAY},L-is-rss-safe", "--quiet", "--json", str(out)]) == 0
    return out


def test_the_old_rules_counterexample_is_unsafe_in_sumo(check_json: Path, tmp_path: Path) -> None:
    (point,) = load_points(check_json, HIGHWAY, "left")
    assert min(point.v, point.v_lead, point.v_follow) >= 25 and point.params == AD_RSS_DEFAULTS
    assert not _l_accepts(point)  # the repaired rule refuses it
    phases = replay(point, tmp_path)
    assert [ph.name for ph in phases] == ["leader brakes", "AV brakes"]
    for ph in phases:
        assert ph.start_gaps == pytest.approx((point.gap_lead, point.gap_follow), abs=1e-6)
        assert ph.unsafe
        assert ph.collisions or any(v.beyond for v in ph.vehicles)
    # the vehicle braking in front keeps to its limit; the one behind is forced beyond its own
    leader, av, _ = phases[0].vehicles
    assert leader.hardest == pytest.approx(point.params["BRAKE_MAX"]) and not leader.beyond
    assert av.beyond


def test_a_gap_the_repaired_rule_accepts_is_safe_in_sumo(tmp_path: Path) -> None:
    (point,) = load_points(EDGE, None, "left")
    assert _l_accepts(point)
    phases = replay(point, tmp_path)
    for ph in phases:
        assert not ph.collisions and not any(v.beyond for v in ph.vehicles), ph
    # what is left of the gap is what L's margin over RSS's distance (94.28125 m) leaves, within a step's motion
    assert phases[0].min_gap_lead == pytest.approx(94.5 - 94.28125, abs=0.05)
    assert phases[1].min_gap_follow == pytest.approx(94.5 - 94.28125, abs=0.05)


def test_a_gap_just_short_of_rss_fails_in_sumo(tmp_path: Path) -> None:
    """The replay is sharp: a metre under RSS's distance, the vehicle behind must brake beyond BRAKE_MIN."""
    (edge,) = load_points(EDGE, None, "left")
    short = Point(26.0, 93.3, 26.0, 93.3, 26.0, dict(AD_RSS_DEFAULTS), "short")
    assert not _l_accepts(short) and _l_accepts(edge)
    phases = replay(short, tmp_path)
    assert all(ph.unsafe for ph in phases)


def test_the_cli_replays_every_violated_lemma_as_expected(
    check_json: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = check_json.parent / "replay.json"
    assert main(["replay", str(check_json), "--json", str(out)]) == 0  # a violated lemma's point is expected unsafe
    printed = capsys.readouterr().out
    assert f"{HIGHWAY} (left)" in printed and "UNSAFE" in printed and "(expected unsafe: as expected)" in printed
    assert printed.rstrip().endswith(
        "1 point(s) replayed: 1 unsafe (a collision, or braking beyond a declared limit); all as expected"
    )
    doc = json.loads(out.read_text())
    (point,) = doc["points"]
    assert doc["schema"] == "mlca-sim.replay/1" and point["outcome"] == "unsafe" == point["expect"]
    assert point["lemma"] == HIGHWAY and point["spec"].endswith("mlca_t.toml") and point["phases"][0]["unsafe"]
    assert main(["replay", str(EDGE)]) == 0
    short = tmp_path / "short.toml"
    short.write_text(EDGE.read_text().replace("94.5", "90.0"))
    assert main(["replay", str(short)]) == 1  # expected safe, and it is not
    assert "NOT AS EXPECTED" in capsys.readouterr().out


def test_unequal_speeds_start_at_the_points_gaps(tmp_path: Path) -> None:
    """The vehicles are placed one step of motion back: SUMO inserts them, then moves them once as the AV changes
    lane (replay raises if the gaps differ from the point's when the worst case begins)."""
    point = Point(20.0, 30.0, 10.0, 40.0, 30.0, dict(AD_RSS_DEFAULTS), "unequal")
    phases = replay(point, tmp_path)
    assert all(ph.start_gaps == pytest.approx((30.0, 40.0), abs=1e-6) for ph in phases)
    assert not _l_accepts(point) and all(ph.unsafe for ph in phases)


def test_a_lemma_is_replayed_on_its_own_side(check_json: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", str(check_json), "--lemma", HIGHWAY, "--side", "right"]) == 2
    assert "reads no definition of the right side" in capsys.readouterr().err
    assert main(["replay", str(check_json), "--side", "right"]) == 2  # no violated lemma there
    assert "no counterexample of a violated lemma about the right side" in capsys.readouterr().err


def test_the_worst_case_profiles() -> None:
    p = dict(AD_RSS_DEFAULTS)
    assert rear_speed(20.0, 0.5, p) == pytest.approx(21.75)
    assert rear_speed(20.0, 1.0 + 23.5 / 4.0, p) == pytest.approx(0.0)
    assert rear_speed(20.0, 100.0, p) == 0.0
    assert front_speed(20.0, 2.0, p) == pytest.approx(4.0) and front_speed(20.0, 3.0, p) == 0.0
    point = Point(20.0, 50.0, 20.0, 50.0, 20.0, p, "x")
    assert horizon(point) >= 1.0 + 23.5 / 4.0


BAD = [
    ("garbage", "{not json", "invalid JSON"),
    ("schema", '{"schema": "other"}', "not a `mlca-verify check --json` document"),
    ("deep", "[" * 100_000, "invalid TOML"),
    ("deep_json", "{" + '"a":[' * 100_000, "invalid JSON"),
    ("nan", "[point]\nv = nan\ngap_lead = 1.0\nv_lead = 0.0\ngap_follow = 1.0\nv_follow = 0.0\n", "outside"),
    ("range", "[point]\nv = 71.0\ngap_lead = 1.0\nv_lead = 0.0\ngap_follow = 1.0\nv_follow = 0.0\n", "outside"),
    ("type", '[point]\nv = "fast"\n', "must be a number"),
    ("missing", "[point]\nv = 1.0\n", "gap_lead is missing"),
    ("unknown", "[point]\nspeed = 1.0\n", "unknown key 'speed'"),
    (
        "param",
        "[point]\nv = 1.0\ngap_lead = 1.0\nv_lead = 0.0\ngap_follow = 1.0\nv_follow = 0.0\n[params]\nRHO = 0.0\n",
        "RHO = 0.0 is outside",
    ),
    ("table", "[other]\n", "a replay file holds a [point] table"),
    ("expect", '[point]\nexpect = "maybe"\n', 'expect must be "safe" or "unsafe"'),
    ("huge", "[point]\nv = 1" + "0" * 400 + "\n", "v = a number that large is outside"),
]


@pytest.mark.parametrize(("name", "text", "message"), BAD, ids=[b[0] for b in BAD])
def test_a_bad_replay_file_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, text: str, message: str
) -> None:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    assert main(["replay", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "Traceback" not in err, err


def test_a_lemma_without_counterexample_or_signals_is_refused(
    check_json: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["replay", str(check_json), "--lemma", "L-is-rss-safe"]) == 2
    assert "has no counterexample to replay" in capsys.readouterr().err
    doc = json.loads(check_json.read_text())
    for result in doc["specs"][0]["results"]:
        if result["counterexample"]:
            result["counterexample"]["steps"][0]["signals"].pop("v_lead_left")
    edited = check_json.parent / "edited.json"
    edited.write_text(json.dumps(doc))
    assert main(["replay", str(edited)]) == 2
    assert "has no signal v_lead_left" in capsys.readouterr().err
    assert math.isfinite(horizon(load_points(EDGE, None, "right")[0]))


def test_the_closed_loop_guide_shows_what_replay_prints(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The guide's session: the old rule's highway counterexample and the edge point, replayed as the page prints."""
    (session,) = sessions(ROOT / "docs" / "guides" / "closed-loop.md", "mlca-verify check spec/mlca_t.toml")
    run_session(session, tmp_path, capsys)
