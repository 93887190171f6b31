"""The closed loop in SUMO, for real: the controllers drive it, it reads SUMO as libsumo's methods do, and its
monitor stores what led to a violation."""

from __future__ import annotations

import itertools
import math
import sys
import sysconfig
from pathlib import Path

import pytest

from mlca_verify.errors import ToolError
from mlca_verify.loading import python_headers
from mlca_verify.model import evaluate
from mlca_verify.spec import load_spec
from sim_check.controllers import load_controller, setup_of
from sim_check.reads import Reads
from sim_check.run_results import Violation
from sim_check.runner import TRACE_STEPS, ClosedLoop, run_once, run_plain, sumo_args
from sim_check.scenario import build, load_scenario
from sim_check.sensing import Network
from tests.conftest import ROOT
from tests.sim_helpers import SHORT, in_mode


@pytest.mark.slow
@pytest.mark.parametrize("machine", ["mlca", "mlca_r", "mlca_t"])
def test_python_and_c_controllers_drive_identically(machine: str, tmp_path: Path) -> None:
    scenario = load_scenario(SHORT).with_avs(3)
    py = run_once(scenario, f"{machine}-py", 4, tmp_path)
    c = run_once(scenario, f"{machine}-c", 4, tmp_path)
    assert py.status == c.status == "done"
    assert py.trajectory_sha256 == c.trajectory_sha256
    assert [m.row() for m in py.metrics] == [m.row() for m in c.metrics]
    assert [m.transitions for m in py.metrics] == [m.transitions for m in c.metrics]
    assert [m.episodes for m in py.metrics] == [m.episodes for m in c.metrics]
    assert py.violations == c.violations == []
    assert all(m.row()["arrived"] and m.row()["lc_5km"] >= 1 for m in py.metrics)  # every AV merged


def test_observing_an_av_does_not_change_the_simulation(tmp_path: Path) -> None:
    """With SUMO's own model driving, the closed loop only reads: its run is step for step the plain run."""
    scenario = load_scenario(SHORT)
    _, steps, vehicle_steps = run_plain(scenario, 2, tmp_path)
    observed = run_once(scenario, "lc2013", 2, tmp_path)
    assert observed.status == "done"
    assert (observed.sim_steps, observed.vehicle_steps) == (steps, vehicle_steps)
    assert run_plain(scenario, 2, tmp_path, limit_s=5.0)[1] == 51  # a limit stops it: steps up to 5.1 s


def test_the_loops_bound_reads_give_what_libsumos_methods_give(tmp_path: Path) -> None:
    """The loop's reads of SUMO (and the network's cached lane counts and lengths) give, step by step, every value
    libsumo's own public methods return."""
    import libsumo

    scenario = load_scenario(SHORT).with_avs(3)
    built = build(scenario, 1, tmp_path, "")
    libsumo.start(sumo_args(scenario, built.net, built.routes, 1))
    try:
        read, network, v, seen = Reads(libsumo), Network(libsumo), libsumo.vehicle, set()
        while len(seen) < 3 or libsumo.simulation.getMinExpectedNumber() > 0:
            libsumo.simulationStep()
            assert read.departed() == libsumo.simulation.getDepartedIDList()
            assert read.arrived() == libsumo.simulation.getArrivedIDList()
            assert read.time() == libsumo.simulation.getTime() and read.vehicle_count() == v.getIDCount()
            for av in set(built.av_ids) & set(v.getIDList()):
                seen.add(av)
                edge, lane = read.road(av), read.lane(av)
                assert (edge, lane) == (v.getRoadID(av), v.getLaneIndex(av))
                assert f"{edge}_{lane}" == v.getLaneID(av)  # the loop's lane id, made from these two
                assert read.position(av) == v.getLanePosition(av) and read.distance(av) == v.getDistance(av)
                assert read.speed(av) == v.getSpeed(av) and read.acceleration(av) == v.getAcceleration(av)
                assert read.leader(av, 250.0) == (v.getLeader(av, 250.0) or ("", -1.0))
                assert read.follower(av, 50.0) == v.getFollower(av, 50.0)
                assert read.allowed_speed(av) == v.getAllowedSpeed(av) and read.length(av) == v.getLength(av)
                for side, leaders, named in (
                    (+1, True, v.getLeftLeaders),
                    (+1, False, v.getLeftFollowers),
                    (-1, True, v.getRightLeaders),
                    (-1, False, v.getRightFollowers),
                ):
                    assert read.neighbours(av, side, leaders) == named(av)
                if not edge.startswith(":"):
                    assert read.edge_vehicles(edge) == libsumo.edge.getLastStepVehicleNumber(edge)
                    assert read.edge_speed(edge) == libsumo.edge.getLastStepMeanSpeed(edge)
                    assert network.lanes[edge] == libsumo.edge.getLaneNumber(edge)
                    end = libsumo.lane.getLength(f"{edge}_{lane}") - read.position(av)
                    assert network.lane_end(edge, lane, read.position(av)) == (
                        end if (edge, lane) == ("acc", 0) else math.inf
                    )
        assert seen == set(built.av_ids)
    finally:
        libsumo.close()


def test_a_monitor_violation_is_stored_with_the_steps_that_led_to_it() -> None:
    """The ledger keeps the last TRACE_STEPS steps of each AV; the steps are the spec's own (first match, by
    mlca_verify.model.evaluate), not the generated code's."""
    import libsumo  # not started: the machine's steps read nothing from SUMO

    loop = ClosedLoop(libsumo, setup_of("mlca-py"), load_scenario(SHORT), ("av0",))
    machine = load_spec(ROOT / "spec" / "mlca.toml", compare=False).machine
    av = loop.enter("av0", 0.0)
    state = machine.initial
    inputs = [{"N": k % 3 != 0, "W": k % 2 == 0, "L": k % 5 == 1, "R": k % 7 == 2} for k in range(TRACE_STEPS + 5)]
    expected = []
    for k, given in enumerate(inputs):
        loop.machine(av, k / 10, given)
        enabled = [t for t in machine.outgoing(state) if evaluate(t.guard, given, state)]
        after = enabled[0].target if enabled else state
        expected.append({"t": round(k / 10, 3), "state": state, "inputs": given, "next": after})
        state = after
    assert machine.states[av.state] == state and loop.ledger.violations == []  # the machine keeps its invariants
    loop.ledger.violation(av, 2.4, ["I9"])
    (stored,) = loop.ledger.violations
    assert stored == Violation("av0", 2.4, ["I9"], expected[-TRACE_STEPS:])
    assert loop.metrics["av0"].monitor_violations == 1


@pytest.mark.parametrize("machine", ["mlca", "mlca_r"])
def test_the_c_controllers_one_call_a_step_agrees_with_the_python_machine(machine: str) -> None:
    c, py = load_controller(f"{machine}-c"), load_controller(f"{machine}-py")
    assert (c.inputs, c.states, c.transitions, c.flags) == (py.inputs, py.states, py.transitions, py.flags)
    for state in range(len(c.states) + 2):  # two modes that name no state too
        for values in itertools.product((False, True), repeat=len(c.inputs)):
            c_ctx, py_ctx = in_mode(c, state), in_mode(py, state)
            assert c.advance(c_ctx, *values) == py.advance(py_ctx, *values), (state, values)
            assert bytes(c_ctx[0:4]) == int(py_ctx.mode).to_bytes(4, sys.byteorder)


def test_the_c_controllers_step_checks_its_arguments_and_answers_as_the_python_machine() -> None:
    c, py = load_controller("mlca-c"), load_controller("mlca-py")
    n = len(c.inputs)
    with pytest.raises(TypeError, match=f"advance takes the context and {n} inputs"):
        c.advance(c.context(), True)
    with pytest.raises(TypeError, match="a context made by context"):
        c.advance(bytearray(1), *[True] * n)
    for state in range(len(c.states)):
        for values in itertools.product((0, 1), repeat=n):  # any truthy value is true
            answer = py.advance(in_mode(py, state), *map(bool, values))
            assert c.advance(in_mode(c, state), *values) == c.advance(in_mode(c, state), *map(bool, values)) == answer


def test_building_the_c_controller_without_pythons_headers_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(sysconfig, "get_paths", lambda: {"include": str(tmp_path)})
    with pytest.raises(ToolError, match=r"no Python\.h in .*python3-dev"):
        python_headers()
