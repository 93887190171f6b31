"""The V2V protocols in the closed loop: each AV's own generated controller, its claims carried to the others by a
seeded radio that loses, delays and repeats messages (sim_check.radio), and no claim rule in the harness."""

from __future__ import annotations

import json
import sqlite3
from collections import Counter
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mlca_verify.cli import main as verify
from mlca_verify.conformance import conform
from mlca_verify.conformance.outcome import CheckOutcome
from mlca_verify.errors import SpecError, ToolError
from mlca_verify.spec import load_spec
from sim_check import channels
from sim_check.cli import main as sim_main
from sim_check.controllers import load_controller
from sim_check.db import ResultsDB
from sim_check.network_replay import load_scenes
from sim_check.radio import V2V, Claim, Moves, Radio, Traffic, heard
from sim_check.runner import run_once
from sim_check.scenario import load_scenario
from tests.conftest import ROOT
from tests.page_sessions import run_session, sessions
from tests.sim_helpers import SHORT

AVS = ["av0", "av1", "av2"]


def _claim(sender: str, lane: int = 2, pos: float = 100.0) -> Claim:
    return Claim(sender, "highway", lane, pos)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    loss=st.sampled_from([0.0, 0.3, 0.9, 1.0]),
    lost_in_row=st.integers(0, 3),
    delay=st.integers(1, 3),
    spread=st.integers(0, 2),
    duplicate=st.sampled_from([0.0, 0.5]),
    sends=st.lists(st.booleans(), min_size=1, max_size=40),
    seed=st.integers(0, 5),
)
def test_the_radio_keeps_to_its_channel_model(
    loss: float, lost_in_row: int, delay: int, spread: int, duplicate: float, sends: list[bool], seed: int
) -> None:
    """On every channel (sender, receiver): never more than `lost_in_row` lost in a row, each message read once
    (twice where repeated) between `delay` and `max_delay` steps after it was sent (the step after for the
    repeat), and the counts are what happened. Checked against a log kept beside the radio."""
    model = V2V(loss=loss, lost_in_row=lost_in_row, delay=delay, max_delay=delay + spread, duplicate=duplicate)
    radio = Radio.seeded(model, seed)
    reads: Counter[tuple[str, int]] = Counter()
    for step, send in enumerate(sends):
        if send:
            radio.send(step, _claim("av0", pos=float(step)), AVS)
        for receiver in AVS:
            for claim in radio.read(step, receiver):
                age = step - int(claim.pos)
                assert receiver != "av0" and delay <= age <= delay + spread + (duplicate > 0)
                reads[receiver, int(claim.pos)] += 1
    for step in range(len(sends), len(sends) + delay + spread + 2):  # what is still in flight arrives
        for receiver in AVS:
            for claim in radio.read(step, receiver):
                reads[receiver, int(claim.pos)] += 1
    sent = [step for step, send in enumerate(sends) if send]
    t = radio.traffic
    assert t.sent == 2 * len(sent) and t.lost + len(reads) == t.sent
    assert sum(reads.values()) == len(reads) + t.duplicated and max(reads.values(), default=1) <= 2
    for receiver in ("av1", "av2"):
        run = 0
        for step in sent:  # lost: never read
            run = run + 1 if (receiver, step) not in reads else 0
            assert run <= lost_in_row
    if loss == 0.0:
        assert t.lost == 0
    if lost_in_row == 0:
        assert t.lost == 0


def test_the_radio_is_the_same_for_the_same_seed() -> None:
    model = V2V(loss=0.5, delay=1, max_delay=3, duplicate=0.2)

    def log(seed: int) -> list[tuple[int, str, float]]:
        radio, out = Radio.seeded(model, seed), []
        for step in range(50):
            radio.send(step, _claim(AVS[step % 3], pos=float(step)), AVS)
            out += [(step, r, c.pos) for r in AVS for c in radio.read(step, r)]
        return out

    assert log(7) == log(7) != log(8)


def test_a_message_due_while_the_receiver_does_not_listen_is_gone() -> None:
    radio = Radio.seeded(V2V(), 0)
    radio.send(0, _claim("av0"), AVS)
    assert radio.read(2, "av1") == []  # due at step 1, read at 2: never read
    assert radio.read(1, "av1") == []
    assert radio.read(1, "av2") == [_claim("av0")]


def test_a_claim_is_heard_on_the_side_of_the_lane_it_names_near_the_receiver() -> None:
    claims = [_claim("av0", lane=2, pos=100.0)]
    assert heard(claims, "highway", 1, 120.0, 30.0) == (True, False)  # lane 2 is this AV's left
    assert heard(claims, "highway", 3, 80.0, 30.0) == (False, True)
    assert heard(claims, "highway", 2, 100.0, 30.0) == (False, False)  # its own lane: not a side
    assert heard(claims, "highway", 1, 131.0, 30.0) == (False, False)  # too far
    assert heard(claims, "acc", 1, 100.0, 30.0) == (False, False)


def test_two_avs_moving_into_one_lane_near_each_other_count_once_per_time_it_begins() -> None:
    moves, traffic = Moves(30.0), Traffic()
    for step in range(6):
        if step in (1, 2, 4):  # two stretches in conflict
            moves.moving(_claim("av0", lane=2, pos=100.0))
            moves.moving(_claim("av1", lane=2, pos=110.0))
        moves.moving(_claim("av2", lane=2, pos=500.0))  # far away: never in conflict
        moves.end_step(traffic)
    assert traffic.conflicts == 2


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("loss = 1.5", "'loss' in [v2v] must be at most 1, got 1.5"),
        ("loss = -0.1", "'loss' in [v2v] must be at least 0, got -0.1"),
        ("delay = 0", "'delay' in [v2v] must be positive, got 0"),
        ("on = 1", "'on' in [v2v] must be true or false, got 1"),
        ("max_delay = 1\ndelay = 2", "'max_delay' in [v2v] is 1, less than 'delay' (2)"),
        ("jitter = 1", "unknown key 'jitter' in [v2v] (known: on, loss, lost_in_row, delay, max_delay, duplicate"),
    ],
)
def test_a_wrong_v2v_section_is_one_line_at_its_key(tmp_path: Path, line: str, message: str) -> None:
    path = tmp_path / "s.toml"
    path.write_text(f"[v2v]\n{line}\n", encoding="utf-8")
    with pytest.raises(SpecError) as err:
        load_scenario(path)
    assert str(err.value).startswith(f"{path}:") and message in str(err.value), str(err.value)
    assert load_scenario(SHORT).v2v == V2V()  # no section: a perfect radio


def test_the_v2v_controllers_are_the_generated_machines_of_spec_v2v() -> None:
    claim = load_controller("mlca_t_claim-py")
    assert claim.inputs == ("N", "heard_left", "heard_right", "U") and len(claim.claims_at) == 2
    assert {"CLAIM_LEFT", "CLAIM_RIGHT"} <= set(claim.states)
    assert load_controller("mlca_t-py").claims_at == ()


LOSSY = V2V(loss=0.3, lost_in_row=1, delay=1, max_delay=2, duplicate=0.1)
LOSSY_SCENARIO = ROOT / "sim_check" / "scenarios" / "v2v_lossy.toml"


def test_the_shipped_lossy_scenario_is_the_proofs_channel() -> None:
    """Three AVs, at most one message lost in a row, each read 1 to 2 steps late: gap_repaired.toml's channels."""
    scenario = load_scenario(LOSSY_SCENARIO)
    assert scenario.v2v == LOSSY and scenario.traffic.avs == 3


@pytest.mark.slow
def test_the_repaired_protocol_drives_three_avs_through_a_lossy_radio(tmp_path: Path) -> None:
    """Three AVs, each its own generated MLCA_T_CLAIM, their claims lost (at most one in a row), late and repeated:
    every AV arrives, no monitor violation, and no two AVs move into one lane near each other; Python and C drive
    identically, and V2V off sends nothing."""
    scenario = load_scenario(LOSSY_SCENARIO)
    py = run_once(scenario, "mlca_t_claim-py", 1, tmp_path)
    c = run_once(scenario, "mlca_t_claim-c", 1, tmp_path)
    assert py.status == c.status == "done" and py.violations == c.violations == []
    assert py.trajectory_sha256 == c.trajectory_sha256 and py.v2v == c.v2v
    assert all(m.row()["arrived"] for m in c.metrics)
    t = c.v2v
    assert t.sent > 20 and 0 < t.lost < t.sent and t.late > 0 and t.conflicts == 0, t
    assert sum(m.row()["claim_left_s"] or 0.0 for m in c.metrics) > 0  # the AVs claimed before they moved
    off = run_once(replace(scenario, v2v=V2V(on=False)), "mlca_t_claim-c", 1, tmp_path)
    assert off.v2v == Traffic() and off.status == "done"


def test_a_seeded_radio_gives_a_reproducible_run(tmp_path: Path) -> None:
    scenario = replace(load_scenario(SHORT).with_avs(3), v2v=LOSSY)
    runs = [run_once(scenario, "mlca_t_claim-c", 2, tmp_path) for _ in range(2)]
    assert runs[0].trajectory_sha256 == runs[1].trajectory_sha256 and runs[0].v2v == runs[1].v2v


# --- a network counterexample as a scene in SUMO ---------------------------------------------------------------


@pytest.fixture(scope="module")
def delayed_check(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The first protocol's counterexample: two AVs both into the gap, each claim read a step late."""
    out = tmp_path_factory.mktemp("v2v-replay") / "check.json"
    spec = ROOT / "spec" / "v2v" / "gap_delayed.toml"
    assert verify(["check", str(spec), "--only", "one-into-the-gap", "--quiet", "--json", str(out)]) == 0
    return out


def test_a_network_counterexample_is_a_scene_of_its_claiming_avs(delayed_check: Path) -> None:
    (scene,) = load_scenes(delayed_check, delayed_check.read_text(), None)
    assert scene.source.endswith("gap_delayed.toml: one-into-the-gap")
    assert scene.lanes == {"A": 0, "B": 2}  # A claims the lane to its left, B the lane to its right
    assert scene.controllers == {"A": "mlca_t_v2v-c", "B": "mlca_t_v2v-c"} and scene.expect == "conflict"
    assert scene.needs == {"A": (True, True), "B": (True, True)}
    assert scene.radio == V2V(loss=0.0, lost_in_row=0, delay=1, max_delay=1)
    (other,) = load_scenes(delayed_check, delayed_check.read_text(), "mlca_t_claim-c")
    assert set(other.controllers.values()) == {"mlca_t_claim-c"} and other.expect is None
    assert load_scenes(delayed_check, "[point]\nv = 1\n", None) == []  # a point file: no scene


def _channel_from(k: int, port: str) -> Callable[[dict[str, Any]], None]:
    def change(network: dict[str, Any]) -> None:
        network["channels"][k]["from"] = port

    return change


def _machine(name: str) -> Callable[[dict[str, Any]], None]:
    def change(network: dict[str, Any]) -> None:
        network["instances"][0]["machine"] = name

    return change


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_channel_from(0, "A.command"), "channel from A.command: a replay places AVs by their claims_left or"),
        (_channel_from(1, "A.claims_right"), "A claims both sides: no one lane to start it in"),
        (_machine("OTHER"), "instance A's machine 'OTHER' has no V2V controller in the closed loop"),
    ],
)
def test_a_network_that_makes_no_scene_is_refused_in_one_line(
    delayed_check: Path,
    tmp_path: Path,
    change: Callable[[dict[str, Any]], None],
    message: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    doc = json.loads(delayed_check.read_text())
    change(doc["specs"][0]["network"])
    broken = tmp_path / "check.json"
    broken.write_text(json.dumps(doc))
    assert sim_main(["replay", str(broken)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{broken}: error: ") and message in err and len(err.splitlines()) == 1, err


def test_the_first_protocols_counterexample_collides_in_sumo_and_the_repaired_protocol_does_not(
    delayed_check: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Driven by their own generated machines, the two AVs both change into the gap at once and SUMO sees them
    collide; the same scene driven by the repaired protocol (the same radio) has no conflict."""
    first, repaired = tmp_path / "first.json", tmp_path / "repaired.json"
    assert sim_main(["replay", str(delayed_check), "--json", str(first)]) == 0
    said = capsys.readouterr().out
    assert "SUMO collisions: A/B" in said and "each violation driven by its own machines shows in traffic" in said
    (scene,) = json.loads(first.read_text())["networks"]
    assert scene["outcome"] == scene["expected"] == "conflict" and scene["collisions"] == [["A", "B"]]
    assert scene["moved_s"] == {"A": 0.0, "B": 0.0} and scene["conflicts"] == 1
    assert sim_main(["replay", str(delayed_check), "--controller", "mlca_t_claim-c", "--json", str(repaired)]) == 0
    (scene,) = json.loads(repaired.read_text())["networks"]
    assert scene["outcome"] == "none" and scene["expected"] is None and scene["collisions"] == []
    assert scene["messages"]["sent"] > 0  # they claimed, heard each other, and gave the gap up
    assert sim_main(["replay", str(delayed_check), "--controller", "mlca_t-c"]) == 2  # not a V2V controller


@pytest.mark.parametrize("machine", ["mlca_t_claim", "mlca_t_v2v"])
def test_the_v2v_machines_code_that_the_closed_loop_runs_passes_the_quick_conform_checks(machine: str) -> None:
    """The generated code of spec/v2v's machines, checked in and driven in SUMO: up to date, compiled without a
    warning, MISRA-clean, and an ARM object that calls nothing (Python against C: the closed loop's trajectory
    above; WP, the exhaustive boundary set, the sequences and the sanitizers: `conform` in full)."""
    spec = load_spec(ROOT / "spec" / "v2v" / f"{machine}.toml", compare=False)
    seen: list[CheckOutcome] = []
    done = conform(spec, ROOT / "generated", ["compile", "cppcheck", "cortex-m4"], seen.append)
    assert [o.name for o in seen] == ["up-to-date", "compile", "cppcheck", "cortex-m4"]
    assert done.ok, [o.detail for o in seen if not o.ok]


def test_a_context_runs_with_the_params_it_was_given_in_python_and_in_c() -> None:
    """An instance's params (PRIORITY = 1: it keeps its claim when it hears another) in a context of its own, the
    same in the generated Python and C; a value outside its range is refused."""
    py, c = (load_controller(f"mlca_t_claim-{lang}") for lang in ("py", "c"))
    free = (1000.0, 1000.0, 0.0, 0.0, 1000.0, 1000.0, 0.0, 0.0)  # nothing sensed on either side

    def modes(ctrl: Any, params: dict[str, int] | None) -> list[str]:
        ctx, seen = ctrl.context(params), []
        for k in range(12):
            heard = k >= 3  # another AV's claim of the left lane heard from step 3 on
            packed, *_ = ctrl.advance(ctx, True, heard, False, True, 20.0, *free)
            seen.append(ctrl.states[packed & 0xFFFF])
        return seen

    for params in (None, {"PRIORITY": 1}):
        assert modes(py, params) == modes(c, params)
    assert "MOVING_LEFT" in modes(c, {"PRIORITY": 1}) and "MOVING_LEFT" not in modes(c, None)
    for ctrl in (py, c):
        with pytest.raises(ToolError):
            ctrl.context({"PRIORITY": 2})
    with pytest.raises(ToolError):
        c.context({"NO_SUCH": 1})


def test_the_repaired_networks_instances_take_the_gap_one_at_a_time(
    delayed_check: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The first protocol's scene driven as gap_repaired.toml's instances A and B (A with PRIORITY = 1): A claims
    the gap for CLAIM_STEPS steps and moves, B gives it up; no conflict."""
    out = tmp_path / "repaired.json"
    network = ROOT / "spec" / "v2v" / "gap_repaired.toml"
    assert sim_main(["replay", str(delayed_check), "--network", str(network), "--json", str(out)]) == 0
    assert "(A: PRIORITY = 1; B: its machine's params)" in capsys.readouterr().out
    (scene,) = json.loads(out.read_text())["networks"]
    assert scene["outcome"] == "none" and scene["collisions"] == [] and list(scene["moved_s"]) == ["A"]
    assert scene["moved_s"]["A"] == pytest.approx(0.7)  # CLAIM_STEPS = 7 steps of claiming first
    machine = ROOT / "spec" / "v2v" / "mlca_t_claim.toml"
    assert sim_main(["replay", str(delayed_check), "--network", str(machine)]) == 2  # a machine, not a network


# --- the same controllers under several channels -----------------------------------------------------------------


@pytest.mark.slow
def test_channels_compares_v2v_off_perfect_and_lossy_from_their_sweeps(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Three sweeps of the repaired protocol, one per channel (the short road, three AVs): `channels` puts them side
    by side. Off sends nothing; perfect loses nothing and delivers nothing late; lossy loses and delays; the counts
    are the sweeps' own, each a mean per run."""
    radios = {"off": "on = false", "perfect": "loss = 0.0", "lossy": LOSSY_SCENARIO.read_text().split("\n[v2v]\n")[1]}
    dbs = []
    for label, section in radios.items():
        scenario = tmp_path / f"{label}.toml"
        scenario.write_text(LOSSY_SCENARIO.read_text().split("\n[v2v]\n")[0] + f"[v2v]\n{section}\n")
        db = tmp_path / f"{label}.sqlite"
        args = ["sweep", "--controller", "mlca_t_claim-c", "--avs", "3", "--runs", "2", "--jobs", "2"]
        assert sim_main([*args, "--db", str(db), "--scenario", str(scenario)]) == 0
        dbs += ["--db", f"{label}={db}"]
    capsys.readouterr()
    assert sim_main(["channels", *dbs, "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in printed[:4]] == ["channel", "off", "perfect", "lossy"]
    written = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert written == ["channels.md", "channels.png", "channels.svg"]
    page = (tmp_path / "out" / "channels.md").read_text()
    assert "off from `off.sqlite`" in page and "![V2V channels](channels.svg)" in page
    lines = [line for line in page.splitlines() if line.startswith("|")]
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    table = {
        row[0]: dict(zip(header, row, strict=True))
        for row in ([c.strip() for c in line.strip("|").split("|")] for line in lines[2:])
    }
    assert list(table) == ["off", "perfect", "lossy"]
    assert float(table["off"]["messages sent"]) == 0.0
    perfect, lossy = table["perfect"], table["lossy"]
    assert float(perfect["messages sent"]) > 0 and float(perfect["lost"]) == float(perfect["late"]) == 0
    assert float(lossy["lost"]) > 0 and float(lossy["late"]) > 0
    with ResultsDB.open_for_reading(tmp_path / "lossy.sqlite") as results:
        runs = results.v2v_runs()
    assert float(lossy["messages sent"]) == pytest.approx(sum(r[6] for r in runs) / len(runs), abs=0.05)


@pytest.mark.parametrize(
    ("dbs", "message"),
    [
        (["off"], "--db wants LABEL=FILE"),
        (["=x.sqlite"], "a channel's label is 1 to 40"),
        (["a=x.sqlite", "a=y.sqlite"], "the channel label 'a' is given twice"),
        (["a=missing.sqlite"], "missing.sqlite: error: no such results database"),
    ],
)
def test_channels_refuses_a_wrong_db_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], dbs: list[str], message: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    args = [a for d in dbs for a in ("--db", d)]
    assert sim_main(["channels", *args]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err


def test_channels_refuses_a_database_without_v2v_counts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A database of schema 3 (the committed comparison's rows before V2V): one line, exit 2."""
    old = tmp_path / "old.sqlite"
    with sqlite3.connect(old) as conn:
        conn.execute("CREATE TABLE runs (controller TEXT, avs INTEGER, seed INTEGER, status TEXT)")
    assert sim_main(["channels", "--db", f"old={old}"]) == 2
    err = capsys.readouterr().err
    assert "no V2V counts" in err and len(err.strip().splitlines()) == 1, err


def test_channels_rows_group_by_controller_and_keep_the_channels_order() -> None:
    """Rows per (controller, AVs) in the order of the channels given; a value every run shares has no interval; a
    label with Markdown in it is escaped."""
    run = ("mlca_t_claim-c", 3, 0, 4, 0, 1, 10, 3, 2, 1, 0)
    other = ("mlca_t_claim-c", 3, 1, 6, 0, 1, 20, 5, 4, 1, 0)
    table = channels.rows([channels.Channel("b|*x*", [run, other]), channels.Channel("a", [run])])
    assert [(r.channel, r.runs) for r in table] == [("b|*x*", 2), ("a", 1)]
    assert table[0].messages["sent"][0] == 15.0 and table[0].lane_changes[1] < 5.0 < table[0].lane_changes[2]
    assert table[0].ssm_conflicts == (1.0, 1.0, 1.0)
    assert "| b\\|\\*x\\* |" in channels.markdown(table)


def test_the_closed_loop_guide_shows_what_a_network_replay_prints(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The guide's two sessions on the first protocol's counterexample: by its own machines, by the repaired
    controller, and by the repaired network's instances (which reads the first session's check.json)."""
    guide = ROOT / "docs" / "guides" / "closed-loop.md"
    (first,) = sessions(guide, "mlca-verify check spec/v2v/gap_delayed.toml")
    (second,) = sessions(guide, "mlca-sim replay check.json --network")
    run_session(first + second, tmp_path, capsys)
