"""The closed loop since the need moved to SUMO's own model and MLCA-T's whole decision into generated code: the
need source, MLCA-T's generated C adapter against its Python, the counting of lane changes against SUMO's own
lane-change output (a change in the step an edge is entered included), the controller's reason in that output,
the transition coverage, the shadow mode, the RSS check of each change and the SSM device."""

from __future__ import annotations

import dataclasses
import itertools
import math
import random
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from mlca_verify.evidence.adrss import ad_rss_gap, available
from mlca_verify.model import evaluate
from sim_check import need, rss, ssm
from sim_check.controllers import load_controller, setup_of
from sim_check.runner import ClosedLoop, run_once
from sim_check.scenario import load_scenario
from sim_check.signals import SENSED
from tests.sim_helpers import SHORT, in_mode

NAN = math.nan


class FakeReads:
    """The two getters sumo_wish reads, answering fixed lane-change states (left, right)."""

    def __init__(self, left: int, right: int) -> None:
        self.states = {1: (left, 0), -1: (right, 0)}

    def lane_change_state(self, av: str, side: int) -> tuple[int, int]:
        return self.states[side]


@pytest.mark.parametrize(
    ("left", "right", "urgent_end", "expected"),
    [
        (0, 0, False, need.NO_NEED),
        (0, 0, True, need.NO_NEED),  # the lane's end alone is no need: SUMO's model says where to go
        (need.LCA_LEFT | need.LCA_SPEEDGAIN, 0, False, need.Need(1, "speedGain", False)),
        (need.LCA_SPEEDGAIN, 0, False, need.NO_NEED),  # a reason without a direction that way is no wish
        (0, need.LCA_RIGHT | need.LCA_KEEPRIGHT, True, need.Need(-1, "keepRight", True)),
        (need.LCA_LEFT | need.LCA_STRATEGIC | need.LCA_URGENT, 0, False, need.Need(1, "strategic", True)),
        (  # both sides: the more pressing reason wins
            need.LCA_LEFT | need.LCA_SPEEDGAIN,
            need.LCA_RIGHT | need.LCA_STRATEGIC,
            False,
            need.Need(-1, "strategic", False),
        ),
        (
            need.LCA_LEFT | need.LCA_KEEPRIGHT,
            need.LCA_RIGHT | need.LCA_KEEPRIGHT,
            False,
            need.Need(1, "keepRight", False),
        ),
        (need.LCA_LEFT | need.LCA_COOPERATIVE, 0, False, need.Need(1, "cooperative", False)),
    ],
)
def test_the_need_is_sumos_wish_with_its_reason_and_urgency(
    left: int, right: int, urgent_end: bool, expected: need.Need
) -> None:
    assert need.sumo_wish(FakeReads(left, right), "av0", urgent_end) == expected  # type: ignore[arg-type]


def test_the_lca_bits_are_libsumos() -> None:
    import libsumo

    c = libsumo.constants
    assert (need.LCA_LEFT, need.LCA_RIGHT, need.LCA_URGENT) == (c.LCA_LEFT, c.LCA_RIGHT, c.LCA_URGENT)
    assert [bit for bit, _ in need.REASONS] == [c.LCA_STRATEGIC, c.LCA_COOPERATIVE, c.LCA_SPEEDGAIN, c.LCA_KEEPRIGHT]


def _random_values(rng: random.Random) -> list[Any]:
    def signal() -> float:
        return rng.choice([rng.uniform(0.0, 80.0), rng.uniform(-5.0, 1200.0), NAN, math.inf, 1000.0, 0.0])

    needed = rng.random() < 0.97  # needs that hold long enough for the waiting timeout to run out
    return [needed, needed and rng.random() < 0.1, *(signal() for _ in SENSED)]


def test_mlca_ts_c_adapter_answers_as_its_python_step_by_step() -> None:
    """The closed loop's one call a step into MLCA-T's generated C (mode, monitor, the transition fired, L, R and W
    as the step saw them, the command) equals the generated Python's, over random sequences with invalid samples."""
    c, py = load_controller("mlca_t-c"), load_controller("mlca_t-py")
    assert c.command_at is not None and py.command_at is not None  # it decides on the raw signals
    assert (c.states, c.inputs, c.signals, c.transitions, c.flags) == (
        py.states,
        py.inputs,
        py.signals,
        py.transitions,
        py.flags,
    )
    assert c.signals == SENSED and c.flags == ("L", "R", "W")
    rng = random.Random(7)
    fired = Counter()
    for _ in range(40):
        c_ctx, py_ctx = c.context(), py.context()
        for _ in range(100):
            values = _random_values(rng)
            answer = c.advance(c_ctx, *values)
            assert answer == py.advance(py_ctx, *values), values
            fired[(answer[0] >> 20) & 0xFFF] += 1
    assert set(fired) == set(range(1, len(c.transitions) + 2))  # every transition fired, and "none"


def test_mlca_ts_c_adapter_checks_its_arguments() -> None:
    c = load_controller("mlca_t-c")
    with pytest.raises(TypeError, match="advance takes the context and 11 inputs"):
        c.advance(c.context(), True)
    with pytest.raises(TypeError, match="a context made by context"):
        c.advance(bytearray(3), *_random_values(random.Random(1)))
    with pytest.raises(TypeError):
        c.advance(c.context(), True, False, "fast", *[0.0] * 8)


@pytest.mark.parametrize("machine", ["mlca", "mlca_r"])
def test_the_transition_a_boolean_machine_fires_leads_where_its_generated_code_goes(machine: str) -> None:
    """The answer of a machine on the sensed booleans names the transition the spec's own semantics fires
    (mlca_verify.model.evaluate, first match), and the mode reached is that transition's target, in the Python
    and in the C alike."""
    spec = load_spec_machine(machine)
    for ctrl in (load_controller(f"{machine}-py"), load_controller(f"{machine}-c")):
        assert ctrl.command_at is None and not ctrl.signals  # the loop reads the side from the mode
        for state in range(len(ctrl.states)):
            for values in itertools.product((False, True), repeat=len(ctrl.inputs)):
                given = dict(zip(ctrl.inputs, values, strict=True))
                name = ctrl.states[state]
                enabled = [t for t in spec.outgoing(name) if evaluate(t.guard, given, name)]
                ctx = in_mode(ctrl, state)
                packed, *_ = ctrl.advance(ctx, *values)
                fired = ((packed >> 20) & 0xFFF) - 1
                expected = spec.transitions.index(enabled[0]) + 1 if enabled else 0
                assert fired == expected, (name, values)
                reached = enabled[0].target if enabled else name
                assert ctrl.states[packed & 0xFFFF] == reached, (name, values)


def load_spec_machine(machine: str) -> Any:
    from mlca_verify.spec import load_spec
    from tests.conftest import ROOT

    return load_spec(ROOT / "spec" / f"{machine}.toml", compare=False).machine


def _run_with_outputs(controller: str, seed: int, work: Path) -> tuple[Any, ET.Element]:
    setup = setup_of(controller)
    changes = work / "changes.xml"
    options = (*setup.options, "--lanechange-output", str(changes))
    result = run_once(
        load_scenario(SHORT).with_avs(3), controller, seed, work, setup=dataclasses.replace(setup, options=options)
    )
    assert result.status == "done"
    return result, ET.parse(changes).getroot()


@pytest.mark.slow
@pytest.mark.parametrize(("controller", "seed"), [("lc2013", 1), ("mlca_t-c", 1), ("without", 2)])
def test_every_lane_change_sumo_writes_is_counted_once(controller: str, seed: int, tmp_path: Path) -> None:
    """SUMO's own lane-change output, the independent count: the loop counts exactly its changes of each AV. With
    LC2013 at seed 1, av2 changes lane in the step it enters the acceleration edge (from the junction's internal
    lane straight into lane 1), which the loop once missed."""
    crossings: list[tuple[str, str, str]] = []
    original = ClosedLoop.moved_on

    def moved_on(loop: ClosedLoop, av: Any, t: float, lane_id: str, edge: str, lane: int) -> None:
        if av.lane_id and loop.network.change(av.lane_id, lane_id) and not lane_id.startswith(f"{av.edge}_"):
            crossings.append((av.id, av.lane_id, lane_id))
        original(loop, av, t, lane_id, edge, lane)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ClosedLoop, "moved_on", moved_on)
        result, changes = _run_with_outputs(controller, seed, tmp_path)
    sumo = Counter(c.get("id") for c in changes if c.get("id", "").startswith("av"))
    assert {m.av: len(m.lane_changes) for m in result.metrics} == {m.av: sumo[m.av] for m in result.metrics}
    assert sum(sumo.values()) >= 5
    if controller == "lc2013":
        assert ("av2", ":merge_start_0_0", "acc_1") in crossings
    else:  # the controller's reason is in SUMO's own file, after SUMO's own reasons
        reasons = [c.get("reason", "") for c in changes if c.get("id", "").startswith("av")]
        assert all(f"|{controller}" in r for r in reasons), reasons
        assert result.metrics[0].commands >= len(result.metrics[0].lane_changes)


@pytest.mark.slow
def test_mlca_t_in_traffic_reports_transitions_episodes_and_safety(tmp_path: Path) -> None:
    result, _ = _run_with_outputs("mlca_t-c", 3, tmp_path)
    for m in result.metrics:
        assert set(m.transitions) == set(load_controller("mlca_t-c").transitions)
        assert m.transitions["urgent_left"] == 1  # the merge: an urgent strategic need to the left, once
        shadow = m.shadow()
        assert shadow["wishes"] == len(m.episodes) >= 1
        assert shadow["wishes_at_once"] + shadow["wishes_deferred"] + shadow["wishes_refused"] == shadow["wishes"]
        followed = [e for e in m.episodes if e.outcome != "refused"]
        assert len(followed) <= len(m.lane_changes)
        assert all(e.delay_s >= 0 and (e.outcome == "deferred") == (e.delay_s > 0) for e in followed)
        assert m.episodes[0].reason == "strategic" and m.episodes[0].urgent and m.episodes[0].side == 1
        assert m.lc_rss_unsafe == 0  # MLCA-T moves only into gaps that are safe by RSS
        assert m.ssm_conflicts >= 0 and m.row()["commands"] == m.commands
    assert result.density_veh_km_lane is not None and result.density_veh_km_lane > 0


@pytest.mark.skipif(not available(), reason="ad-rss-lib is not installed")
def test_the_loops_rss_distance_is_ad_rss_libs() -> None:
    params = rss.spec_params()
    assert (params.rho, params.accel_max, params.brake_min, params.brake_max) == (1.0, 3.5, 4.0, 8.0)
    for v_rear, v_front in itertools.product((0.0, 5.0, 13.9, 22.2, 30.0, 40.0), repeat=2):
        expected = ad_rss_gap(v_rear, v_front, (1.0, 3.5, 4.0, 8.0))
        assert rss.safe_distance(v_rear, v_front, params) == pytest.approx(expected, abs=1e-3)


def test_a_change_is_rss_safe_only_with_both_gaps() -> None:
    p = rss.spec_params()
    needed = rss.safe_distance(20.0, 20.0, p)
    assert rss.change_is_safe(20.0, None, None, p)
    assert rss.change_is_safe(20.0, (needed, 20.0), (needed, 20.0), p)
    assert not rss.change_is_safe(20.0, (needed - 0.01, 20.0), None, p)
    assert not rss.change_is_safe(20.0, None, (needed - 0.01, 20.0), p)


def test_the_ssm_file_is_read_per_av(tmp_path: Path) -> None:
    output = tmp_path / "ssm.xml"
    output.write_text(
        "<SSMLog>\n"
        '<conflict begin="1" end="2" ego="av0" foe="car3"><minTTC time="1.5" value="2.10"/>'
        '<maxDRAC time="1.5" value="3.50"/><PET time="NA" value="NA"/></conflict>\n'
        '<conflict begin="5" end="6" ego="av0" foe="car4"><minTTC time="5.5" value="1.20"/>'
        '<maxDRAC time="5.5" value="1.00"/><PET time="6" value="1.5"/></conflict>\n'
        '<conflict begin="5" end="6" ego="car9" foe="av0"><minTTC time="5.5" value="0.2"/></conflict>\n'
        "</SSMLog>\n"
    )
    found = ssm.read(output, ("av0", "av1"))
    assert found["av0"] == ssm.Conflicts(2, 1.2, 3.5, 1.5)
    assert found["av1"] == ssm.Conflicts()
    assert ssm.read(tmp_path / "none.xml", ("av0",))["av0"] == ssm.Conflicts()


def test_a_schema_2_database_is_still_reported_without_the_new_sections(tmp_path: Path) -> None:
    """A results database from before the shadow mode (schema 2: the old columns, no transitions, no episodes)
    is read by `mlca-sim report`, which leaves out what it does not record."""
    import sqlite3

    from sim_check import schema
    from sim_check.db import ResultsDB
    from sim_check.report import write_report

    path = tmp_path / "old.sqlite"
    conn = sqlite3.connect(path)
    for table, columns in schema.COLUMNS_2.items():
        conn.execute(f"CREATE TABLE {table} ({', '.join(columns)})")
    conn.execute("CREATE TABLE violations (controller, avs, seed, av, time_s, invariants, trace_json)")
    conn.execute(f"PRAGMA application_id = {schema.APPLICATION_ID}")
    conn.execute("PRAGMA user_version = 2")
    run = {"controller": "mlca_r-c", "avs": 1, "seed": 0, "status": "done", "reason": "", "collisions": 0}
    conn.execute(
        f"INSERT INTO runs VALUES ({', '.join('?' for _ in schema.COLUMNS_2['runs'])})",
        [run.get(c, 0) for c in schema.COLUMNS_2["runs"]],
    )
    metrics = {
        "controller": "mlca_r-c",
        "avs": 1,
        "seed": 0,
        "av": "av0",
        "lc_20km": 3,
        "needs": 2,
        "travel_time_s": 900.0,
    }
    conn.execute(
        f"INSERT INTO av_metrics VALUES ({', '.join('?' for _ in schema.COLUMNS_2['av_metrics'])})",
        [metrics.get(c, 0) for c in schema.COLUMNS_2["av_metrics"]],
    )
    conn.commit()
    conn.close()
    write_report(path, tmp_path / "out")
    report = (tmp_path / "out" / "report.md").read_text()
    assert "1 finished runs" in report and "## Mechanism" in report
    assert "## Transition coverage" not in report and "## Shadow mode" not in report and "## Safety" not in report
    with pytest.raises(Exception, match="written by an older mlca-sim"):
        ResultsDB.open_for_writing(path)


class Recorder:
    """Stands in for libsumo's vehicle domain where the loop commands: records changeLane and lcReason."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, Any]] = []
        self.vehicle = self

    def changeLane(self, av: str, lane: int, duration: float) -> None:
        self.calls.append(("changeLane", lane))

    def setParameter(self, av: str, key: str, value: str) -> None:
        self.calls.append((key, value))


def test_a_move_is_commanded_when_it_begins_and_a_repeat_is_counted_apart() -> None:
    import libsumo  # not started: the commands go to the recorder

    loop = ClosedLoop(libsumo, setup_of("mlca_t-py"), load_scenario(SHORT), ("av0",))
    av = loop.enter("av0", 0.0)
    loop.sumo = recorder = Recorder()
    where = ("hw", 1, 100.0)
    for t, side in ((0.0, 1), (0.1, 1), (2.9, 1), (3.0, 1), (3.1, 0), (3.2, -1), (6.2, -1), (6.3, 0), (9.3, 1)):
        loop.move(av, t, where, side)
    lanes = [lane for name, lane in recorder.calls if name == "changeLane"]
    assert lanes == [2, 2, 0, 2]  # at 0.0 (begins), 3.0 (a repeat), 6.2 (held back until 3 s passed), 9.3
    assert (av.m.commands, av.m.repeats) == (4, 1)  # the right move, held back, is still its first command
    assert all(value.startswith("|mlca_t-py") for name, value in recorder.calls if name == "lcReason")
