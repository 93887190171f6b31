"""The closed loop in SUMO, for real: controllers, determinism, the results database, kill and resume."""

from __future__ import annotations

import itertools
import math
import os
import signal
import sqlite3
import subprocess
import sys
import sysconfig
import tempfile
import time
import types
from pathlib import Path

import pytest

from mlca_verify.errors import SpecError, ToolError
from sim_check.cli import main
from sim_check.controllers import load_controller, python_headers, setup_of
from sim_check.reads import Reads
from sim_check.runner import TRACE_STEPS, ClosedLoop, run_once, run_plain, sumo_args
from sim_check.scenario import build, load_scenario
from sim_check.sensing import Network

ROOT = Path(__file__).parent.parent
SHORT = ROOT / "sim_check" / "scenarios" / "short.toml"


def rows(db: Path, table: str, skip: tuple[str, ...] = ("wall_s",)) -> list[tuple[object, ...]]:
    with sqlite3.connect(db) as conn:
        cursor = conn.execute(f"SELECT * FROM {table} ORDER BY 1, 2, 3, 4")
        keep = [k for k, d in enumerate(cursor.description) if d[0] not in skip]
        return [tuple(r[k] for k in keep) for r in cursor.fetchall()]


def stored(db: Path) -> int:
    """Runs a sweep running in another process has stored so far (none while it is still creating the file)."""
    try:
        return len(rows(db, "runs")) if db.exists() else 0
    except sqlite3.OperationalError:  # the file exists, its tables not yet
        return 0


@pytest.mark.slow
@pytest.mark.parametrize("machine", ["mlca", "mlca_r"])
def test_python_and_c_controllers_drive_identically(machine: str, tmp_path: Path) -> None:
    scenario = load_scenario(SHORT).with_avs(3)
    py = run_once(scenario, f"{machine}-py", 4, tmp_path)
    c = run_once(scenario, f"{machine}-c", 4, tmp_path)
    assert py.status == c.status == "done"
    assert py.trajectory_sha256 == c.trajectory_sha256
    assert [m.row() for m in py.metrics] == [m.row() for m in c.metrics]
    assert py.violations == c.violations == []
    assert all(m.row()["arrived"] and m.row()["lc_5km"] >= 1 for m in py.metrics)  # every AV merged


@pytest.mark.slow
def test_same_seed_twice_gives_the_same_rows(tmp_path: Path) -> None:
    for name in ("a", "b"):
        argv = ["sweep", "--controller", "mlca-c", "--avs", "1,3", "--runs", "2", "--jobs", "2"]
        assert main([*argv, "--db", str(tmp_path / f"{name}.sqlite"), "--scenario", str(SHORT)]) == 0
    for table in ("runs", "av_metrics", "violations"):
        assert rows(tmp_path / "a.sqlite", table) == rows(tmp_path / "b.sqlite", table)
    assert len(rows(tmp_path / "a.sqlite", "runs")) == 4
    assert len(rows(tmp_path / "a.sqlite", "av_metrics")) == 2 * (1 + 3)


@pytest.mark.slow
def test_killed_sweep_resumes_without_losing_or_repeating_a_run(tmp_path: Path) -> None:
    db = tmp_path / "r.sqlite"
    argv = [sys.executable, "-m", "sim_check", "sweep", "--controller", "mlca-c", "--avs", "1", "--runs", "6",
            "--jobs", "1", "--db", str(db), "--scenario", str(SHORT)]  # fmt: skip
    scratch = tmp_path / "tmp"  # a killed sweep cannot remove its temporary files: keep them out of /tmp
    scratch.mkdir()
    sweep = subprocess.Popen(
        argv,
        cwd=ROOT,
        env={**os.environ, "TMPDIR": str(scratch)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if stored(db) >= 2:
            break
        time.sleep(0.2)
    os.killpg(sweep.pid, signal.SIGKILL)
    sweep.wait()
    before = rows(db, "runs")
    assert 2 <= len(before) < 6, "the sweep should be killed halfway"
    for run in before:  # every committed run is whole
        assert len([r for r in rows(db, "av_metrics") if r[:3] == run[:3]]) == 1
    assert (
        main(
            ["sweep", "--controller", "mlca-c", "--avs", "1", "--runs", "6", "--db", str(db), "--scenario", str(SHORT)]
        )
        == 2
    )
    assert subprocess.run([*argv, "--resume"], cwd=ROOT, capture_output=True, check=False).returncode == 0
    after = rows(db, "runs")
    assert sorted(r[2] for r in after) == list(range(6))
    assert after[: len(before)] == before or set(before) <= set(after)


@pytest.mark.slow
def test_ctrl_c_stops_a_sweep_with_a_message_and_keeps_its_runs(tmp_path: Path) -> None:
    db, scratch = tmp_path / "r.sqlite", tmp_path / "tmp"
    scratch.mkdir()
    argv = [sys.executable, "-m", "sim_check", "sweep", "--controller", "mlca-c", "--avs", "1", "--runs", "8",
            "--jobs", "2", "--db", str(db), "--scenario", str(SHORT)]  # fmt: skip
    env = {**os.environ, "TMPDIR": str(scratch)}
    sweep = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             start_new_session=True)  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not stored(db):
        time.sleep(0.1)
    os.killpg(sweep.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: the whole process group
    _, err = sweep.communicate(timeout=60)
    kept = len(rows(db, "runs"))
    assert sweep.returncode == 130 and 1 <= kept < 8
    assert "Traceback" not in err
    assert f"interrupted: {kept} of the 8 runs wanted are stored in {db}; run the same command with --resume" in err
    assert list(scratch.iterdir()) == []  # the workers are gone and their files with them
    assert subprocess.run([*argv, "--resume"], cwd=ROOT, capture_output=True, check=False).returncode == 0
    assert sorted(r[2] for r in rows(db, "runs")) == list(range(8))


@pytest.mark.slow
def test_hung_runs_fail_with_a_reason_and_the_sweep_goes_on(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "r.sqlite"
    argv = ["sweep", "--controller", "mlca-c", "--avs", "1", "--runs", "2", "--jobs", "1", "--timeout", "0.01"]
    assert main([*argv, "--db", str(db), "--scenario", str(SHORT)]) == 1
    failed = rows(db, "runs")
    assert len(failed) == 2 and all(r[3] == "failed" and "hung" in str(r[4]) for r in failed)
    assert "0 runs done, 2 failed" in capsys.readouterr().out


def test_scenario_errors_name_the_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[road]\nlanes = 5\nlenght_m = 3\n")
    with pytest.raises(SpecError, match=r"bad.toml:3:12: error: unknown key 'lenght_m' in \[road\]"):
        load_scenario(bad)
    bad.write_text("[traffic]\ncars = -4\n")
    with pytest.raises(SpecError, match=r"bad.toml:2:8: error: 'cars' in \[traffic\] must be positive"):
        load_scenario(bad)


def test_paper_defaults() -> None:
    s = load_scenario()
    assert (s.road.lanes, s.road.highway_speed_kmh, s.traffic.cars, s.target_lane) == (5, 80, 100, 2)


@pytest.fixture(scope="module")
def ray_cluster() -> str:
    """A local Ray cluster, started for these tests and stopped after them."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    ray = str(Path(sys.executable).with_name("ray"))
    # Ray's default temp dir: a pytest tmp path is too long for the Unix sockets Ray creates under it
    start = [
        ray,
        "start",
        "--head",
        f"--port={port}",
        "--num-cpus=2",
        "--include-dashboard=false",
        "--disable-usage-stats",
    ]
    subprocess.run(start, check=True, capture_output=True, cwd=ROOT)
    yield f"127.0.0.1:{port}"  # type: ignore[misc]
    subprocess.run([ray, "stop", "--force"], check=False, capture_output=True)


@pytest.mark.slow
def test_sweep_on_a_ray_cluster_gives_the_local_rows(ray_cluster: str, tmp_path: Path) -> None:
    argv = ["sweep", "--controller", "mlca-c,mlca_r-py", "--avs", "1,3", "--runs", "1", "--scenario", str(SHORT)]
    assert main([*argv, "--db", str(tmp_path / "ray.sqlite"), "--ray", ray_cluster]) == 0
    assert main([*argv, "--db", str(tmp_path / "local.sqlite")]) == 0
    for table in ("runs", "av_metrics"):
        assert rows(tmp_path / "ray.sqlite", table) == rows(tmp_path / "local.sqlite", table)
    assert len(rows(tmp_path / "ray.sqlite", "runs")) == 4


def test_unreachable_ray_cluster_is_a_usage_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["sweep", "--runs", "1", "--avs", "1", "--db", str(tmp_path / "r.sqlite"), "--ray", "127.0.0.1:9"]
    assert main([*argv, "--scenario", str(SHORT)]) == 2
    assert "cannot connect to the Ray cluster at 127.0.0.1:9" in capsys.readouterr().err


def test_openstreetmap_road_is_imported_and_driven(tmp_path: Path) -> None:
    scenario_file = tmp_path / "osm.toml"
    osm = ROOT / "tests" / "fixtures" / "small.osm"
    scenario_file.write_text(
        f'[road]\nosm = "{osm}"\nroute = "100 101"\nlanes = 3\n\n[traffic]\ncars = 10\navs = 1\ndepart_window_s = 20\n'
    )
    result = run_once(load_scenario(scenario_file), "mlca_r-c", 3, tmp_path / "work")
    assert result.status == "done" and result.violations == []
    av = result.metrics[0].row()
    assert av["arrived"] and av["lc_5km"] == 1  # from lane 0 into the middle lane of the three
    assert 1900 < result.metrics[0].distance_m < 2100


def test_openstreetmap_road_needs_a_route(tmp_path: Path) -> None:
    scenario_file = tmp_path / "osm.toml"
    scenario_file.write_text(f'[road]\nosm = "{ROOT / "tests" / "fixtures" / "small.osm"}"\n')
    with pytest.raises(SpecError, match=r"osm\.toml:2:7: error: an OpenStreetMap road needs 'route'"):
        load_scenario(scenario_file)


def test_observing_an_av_does_not_change_the_simulation(tmp_path: Path) -> None:
    """With SUMO's own model driving, the closed loop only reads: its run is step for step the plain run."""
    scenario = load_scenario(SHORT)
    _, steps, vehicle_steps = run_plain(scenario, 2, tmp_path)
    observed = run_once(scenario, "lc2013", 2, tmp_path)
    assert observed.status == "done"
    assert (observed.sim_steps, observed.vehicle_steps) == (steps, vehicle_steps)
    assert run_plain(scenario, 2, tmp_path, limit_s=5.0)[1] == 51  # a limit stops it: steps up to 5.1 s


def test_the_loops_bound_reads_give_what_libsumos_methods_give(tmp_path: Path) -> None:
    """The loop reads libsumo's compiled functions directly (and caches the network's lane counts and lengths):
    every value, step by step, is the one libsumo's own methods return."""
    import libsumo

    scenario = load_scenario(SHORT).with_avs(3)
    built = build(scenario, 1, tmp_path, "")
    libsumo.start(sumo_args(scenario, built.net, built.routes, 1))
    try:
        read, network, v, seen = Reads(libsumo), Network(libsumo), libsumo.vehicle, set()
        assert read.road is libsumo._libsumo.vehicle_getRoadID  # bound past libsumo's Python methods
        while len(seen) < 3 or libsumo.simulation.getMinExpectedNumber() > 0:
            libsumo.simulationStep()
            assert read.departed() == libsumo.simulation.getDepartedIDList()
            assert read.arrived() == libsumo.simulation.getArrivedIDList()
            for av in set(built.av_ids) & set(v.getIDList()):
                seen.add(av)
                edge, lane = read.road(av), read.lane(av)
                assert (edge, lane) == (v.getRoadID(av), v.getLaneIndex(av))
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
                    assert network.lanes[edge] == libsumo.edge.getLaneNumber(edge)
                    end = libsumo.lane.getLength(f"{edge}_{lane}") - read.position(av)
                    assert network.lane_end(edge, lane, read.position(av)) == (
                        end if (edge, lane) == ("acc", 0) else math.inf
                    )
        assert seen == set(built.av_ids)
    finally:
        libsumo.close()


def test_a_monitor_violation_is_stored_with_the_steps_that_led_to_it() -> None:
    import libsumo  # not started: the machine's steps read nothing from SUMO

    loop = ClosedLoop(libsumo, setup_of("mlca-py"), load_scenario(SHORT), ("av0",))
    ctrl = load_controller("mlca-py")
    av = loop.enter("av0", 0.0)
    state = ctrl.initial
    inputs = [{"N": k % 3 != 0, "W": k % 2 == 0, "L": k % 5 == 1, "R": k % 7 == 2} for k in range(TRACE_STEPS + 5)]
    expected = []
    for k, given in enumerate(inputs):
        loop.machine(av, k / 10, given)
        after, _ = ctrl.advance(state, given)
        expected.append(
            {"t": round(k / 10, 3), "state": ctrl.states[state], "inputs": given, "next": ctrl.states[after]}
        )
        state = after
    assert av.state == state and loop.violations == []  # the shipped machine keeps its invariants
    loop.violation(av, 2.4, ["I9"])
    (stored,) = loop.violations
    assert stored == {"av": "av0", "time_s": 2.4, "invariants": ["I9"], "trace": expected[-TRACE_STEPS:]}
    assert loop.metrics["av0"].monitor_violations == 1


def test_a_sweep_leaves_no_files_behind(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))  # the workers' temporary files
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))  # this process's
    argv = ["sweep", "--controller", "mlca-c,lc2013", "--avs", "1", "--runs", "1", "--jobs", "2"]
    assert main([*argv, "--db", str(tmp_path / "r.sqlite"), "--scenario", str(SHORT)]) == 0
    assert len(rows(tmp_path / "r.sqlite", "runs")) == 2
    assert list(scratch.iterdir()) == []


@pytest.mark.parametrize("machine", ["mlca", "mlca_r"])
def test_the_c_controllers_one_call_a_step_agrees_with_the_python_machine(machine: str) -> None:
    c, py = load_controller(f"{machine}-c"), load_controller(f"{machine}-py")
    assert c.inputs == py.inputs and c.states == py.states
    for state in range(len(c.states)):
        for values in itertools.product((False, True), repeat=len(c.inputs)):
            inputs = dict(zip(c.inputs, values, strict=True))
            assert c.advance(state, inputs) == py.advance(state, inputs), (state, inputs)


def test_the_c_controllers_step_is_an_extension_function_that_checks_its_arguments() -> None:
    c = load_controller("mlca-c")
    assert isinstance(c.packed, types.BuiltinFunctionType)  # imported from the built library, no ctypes between
    n = len(c.inputs)
    with pytest.raises(TypeError, match=f"advance takes the state and {n} inputs"):
        c.packed(0, True)
    with pytest.raises(TypeError):
        c.packed("IDLE", *[True] * n)
    for state in range(len(c.states)):
        for values in itertools.product((0, 1), repeat=n):  # any truthy value is true
            assert c.packed(state, *values) == c.packed(state, *map(bool, values))


def test_building_the_c_controller_without_pythons_headers_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(sysconfig, "get_paths", lambda: {"include": str(tmp_path)})
    with pytest.raises(ToolError, match=r"no Python\.h in .*python3-dev"):
        python_headers()
