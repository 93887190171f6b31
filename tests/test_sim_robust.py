"""mlca-sim on bad input and in bad weather: every mistake one line and exit 2; a results database shared by
several writers, refused when it is not one; sweeps that leave nothing behind when they are killed."""

from __future__ import annotations

import ctypes
import hashlib
import os
import signal
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from mlca_verify.errors import SpecError, UsageError
from sim_check import schema, transactions
from sim_check.cli import main
from sim_check.db import MonitorSummary, ResultsDB
from sim_check.leases import Owner, started_time
from sim_check.run_results import AvMetrics, RunResult, Violation
from sim_check.scenario import load_scenario
from tests.conftest import ROOT
from tests.sim_helpers import SHORT

TINY = "[road]\nlength_m = 1000\n\n[traffic]\ncars = 5\ndepart_window_s = 10\nav_depart_s = 2\n"


def result(seed: int, status: str = "done", controller: str = "mlca-c") -> RunResult:
    """A run's result as a worker returns it, without SUMO."""
    reason = "" if status == "done" else "the simulator process died (exit code -9)"
    return RunResult(controller, 1, seed, status=status, reason=reason, metrics=[AvMetrics("av0")])


def count(path: Path, table: str) -> int:
    """Rows in `table`; none while the file or its tables do not exist yet."""
    if not path.exists():
        return 0
    try:
        with ResultsDB.open_for_reading(path) as results:
            return len(results.table_rows(table).rows)
    except UsageError:
        return 0


def column(path: Path, table: str, name: str) -> list[Any]:
    """The values of one column of `table`, in the table's order."""
    with ResultsDB.open_for_reading(path) as results:
        rows = results.table_rows(table)
    k = rows.columns.index(name)
    return [row[k] for row in rows.rows]


def store(path: Path, *runs: RunResult) -> None:
    """Store `runs` as a sweep does."""
    with ResultsDB.open_for_writing(path) as results:
        for run in runs:
            assert results.store(run)


def sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    """The short scenario cut down further: 1 km, 5 cars, a run in about half a second."""
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


# --- 6. the results database


def test_a_run_stored_twice_is_stored_once_and_the_second_writer_is_told(tmp_path: Path) -> None:
    path = tmp_path / "r.sqlite"
    with ResultsDB.open_for_writing(path) as first, ResultsDB.open_for_writing(path) as second:
        assert first.store(result(0)) is True
        assert second.store(result(0)) is False  # no IntegrityError: the second writer skips it
    assert (count(path, "runs"), count(path, "av_metrics")) == (1, 1)


def test_a_results_database_is_closed_after_its_with_block(tmp_path: Path) -> None:
    path = tmp_path / "r.sqlite"
    with ResultsDB.open_for_writing(path) as results:
        assert results.store(result(0)) and not results.closed
    assert results.closed
    with pytest.raises(UsageError, match=r"r\.sqlite: error: cannot read: Cannot operate on a closed database"):
        results.stored_keys()
    with pytest.raises(RuntimeError), ResultsDB.open_for_reading(path) as reading:
        raise RuntimeError("a failure inside the block")
    assert reading.closed


def test_the_api_reads_what_was_stored(tmp_path: Path) -> None:
    path = tmp_path / "r.sqlite"
    violation = Violation("av0", 1.0, ["no_collision"], [])
    runs = [result(0), result(1, "failed"), result(0, controller="mlca-py"), result(2, controller="lc2013")]
    runs[2].violations.append(violation)
    store(path, *runs)
    with ResultsDB.open_for_reading(path) as results:
        assert results.stored_keys() == {("mlca-c", 1, 0), ("mlca-c", 1, 1), ("mlca-py", 1, 0), ("lc2013", 1, 2)}
        assert results.monitor_summary(["mlca-py", "mlca-c"]) == MonitorSummary(runs=3, failed_runs=1,
                                                                                monitor_violations=1)  # fmt: skip
        assert results.monitor_summary([]) == MonitorSummary(0, 0, 0)
        rows = results.report_rows()
    assert [(s.controller, s.status) for s in rows.statuses] == [("lc2013", "done"), ("mlca-c", "done"),
                                                                 ("mlca-c", "failed"), ("mlca-py", "done")]  # fmt: skip
    assert [(r.controller, r.seed, r.lane_changes) for r in rows.finished] == [
        ("lc2013", 2, (0, 0, 0, 0)), ("mlca-c", 0, (0, 0, 0, 0)), ("mlca-py", 0, (0, 0, 0, 0))]  # fmt: skip


def test_reading_refuses_a_file_that_is_not_a_results_database_untouched(tmp_path: Path) -> None:
    path = tmp_path / "notes.sqlite"
    _foreign(path)
    before = sha(path)
    with pytest.raises(UsageError, match=r"notes\.sqlite: error: not a results database of mlca-sim$"):
        ResultsDB.open_for_reading(path)
    assert sha(path) == before


def test_a_sweep_opens_its_database_once_and_closes_it(
    tmp_path: Path, tiny: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "r.sqlite"
    store(path, result(0))
    opened: list[ResultsDB] = []
    open_for_writing = ResultsDB.open_for_writing

    def spy(db_path: Path) -> ResultsDB:
        opened.append(open_for_writing(db_path))
        return opened[-1]

    monkeypatch.setattr(ResultsDB, "open_for_writing", spy)
    argv = ["sweep", "--avs", "1", "--runs", "1", "--db", str(path), "--scenario", str(tiny), "--resume"]
    assert main(argv) == 0  # nothing left to run: no SUMO started
    assert len(opened) == 1 and opened[0].closed


def test_a_write_waits_and_retries_while_another_process_holds_the_lock(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(transactions, "BUSY_TIMEOUT_S", 0.1)
    monkeypatch.setattr(transactions, "WRITE_ATTEMPTS", 30)
    path = tmp_path / "r.sqlite"
    results = ResultsDB.open_for_writing(path)
    holder = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    holder.execute("BEGIN EXCLUSIVE")
    threading.Timer(0.8, lambda: holder.execute("COMMIT")).start()  # longer than one busy timeout
    start = time.monotonic()
    with results:
        assert results.store(result(0)) is True
    assert time.monotonic() - start >= 0.7
    assert count(path, "runs") == 1


def test_a_lock_held_through_every_retry_is_one_clear_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(transactions, "BUSY_TIMEOUT_S", 0.05)
    monkeypatch.setattr(transactions, "WRITE_ATTEMPTS", 3)
    path = tmp_path / "r.sqlite"
    results = ResultsDB.open_for_writing(path)
    holder = sqlite3.connect(path, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")
    with results, pytest.raises(UsageError, match=r"cannot store run mlca-c, 1 AVs, seed 0: another process kept"):
        results.store(result(0))
    holder.execute("ROLLBACK")
    holder.close()


@pytest.mark.slow
def test_names_with_hash_and_question_mark_are_plain_file_names(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "res#1?x=%41.sqlite"
    store(path, result(0))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res#1?x=%41.sqlite"]
    assert main(["report", "--db", str(path), "--out", str(tmp_path / "report")]) == 0  # it opens file:PATH?mode=ro
    assert "wrote 11 files" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report", "res#1?x=%41.sqlite"]  # no file `res` made


def test_report_refuses_a_database_that_is_not_one(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "notes.sqlite"
    _foreign(path)
    assert main(["report", "--db", str(path), "--out", str(tmp_path / "report")]) == 2
    assert one_line_error(capsys) == f"{path}: error: not a results database of mlca-sim\n"


def _foreign(path: Path) -> None:
    with sqlite3.connect(path) as conn:
        conn.execute("CREATE TABLE notes (text TEXT)")


def _older(path: Path) -> None:
    """A database as mlca-sim wrote it before the schema had a version: the same three tables, unmarked."""
    with sqlite3.connect(path) as conn:
        for name in ("runs", "av_metrics", "violations"):
            conn.execute(f"CREATE TABLE {name} ({', '.join(schema.TABLES[name].names(1))})")


def _newer(path: Path) -> None:
    ResultsDB.open_for_writing(path).close()
    with sqlite3.connect(path) as conn:
        conn.execute(f"PRAGMA user_version = {schema.SCHEMA_VERSION + 1}")


def _text(path: Path) -> None:
    path.write_text("runs,avs,seed\n")


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (_foreign, "not a results database of mlca-sim (its tables: notes)"),
        (_older, "written by an older mlca-sim (results schema 1, this one writes 4); use a new database file"),
        (_newer, "written by a newer mlca-sim (results schema 5, this one writes 4)"),
        (_text, "cannot write to the results database: file is not a database"),
    ],
)
def test_a_database_this_version_does_not_write_is_refused_untouched(
    make: Callable[[Path], None], message: str, tmp_path: Path, tiny: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "other.sqlite"
    make(path)
    before = sha(path)
    argv = ["sweep", "--avs", "1", "--runs", "1", "--db", str(path), "--scenario", str(tiny)]
    assert main(argv) == 2
    assert message in one_line_error(capsys)
    assert sha(path) == before  # no table added, nothing written


def _without_dac_override() -> None:
    """Run as a root that file permissions apply to (CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH dropped)."""
    libc = ctypes.CDLL(None, use_errno=True)
    for cap in (1, 2):
        if libc.prctl(24, cap, 0, 0, 0) != 0:  # PR_CAPBSET_DROP
            raise OSError(ctypes.get_errno(), "PR_CAPBSET_DROP")


def test_a_read_only_database_is_refused_before_the_run(tmp_path: Path, tiny: Path) -> None:
    path = tmp_path / "ro.sqlite"
    store(path, result(0))
    path.chmod(0o444)
    argv = [sys.executable, "-m", "sim_check", "run", "--seed", "1", "--db", str(path), "--scenario", str(tiny)]
    drop = _without_dac_override if os.geteuid() == 0 else None
    try:
        done = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, preexec_fn=drop, check=False)
    except subprocess.SubprocessError as err:
        pytest.skip(f"cannot drop root's capabilities here: {err}")
    assert done.returncode == 2, done.stderr
    assert done.stdout == ""  # refused before SUMO ran: no run to lose
    assert done.stderr == f"{path}: error: cannot write to the results database: attempt to write a readonly database\n"


def _sleeper() -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])


def _lease(path: Path, seeds: range, pid: int) -> None:
    owner = Owner.me()
    started = started_time(pid)
    with sqlite3.connect(path) as conn:
        conn.executemany("INSERT INTO leases VALUES ('mlca-c', 1, ?, ?, ?, ?)",
                         [(seed, owner.host, pid, started) for seed in seeds])  # fmt: skip


def test_resume_leaves_the_runs_a_live_sweep_holds_and_reclaims_a_dead_ones(
    tmp_path: Path, tiny: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "r.sqlite"
    store(path, result(0))
    other = _sleeper()
    try:
        _lease(path, range(1, 3), other.pid)  # another sweep, alive, runs seeds 1 and 2
        argv = ["sweep", "--avs", "1", "--runs", "3", "--db", str(path), "--scenario", str(tiny)]
        assert main(argv) == 2
        message = f"already holds 1 of these runs; 2 of these runs are being run by another sweep (pid {other.pid})"
        assert message in one_line_error(capsys)
        assert main([*argv, "--resume"]) == 0  # nothing left to do: no SUMO started
        out = capsys.readouterr().out
        assert f"3 runs wanted, 1 already in {path}, 0 to run on 2 workers; 2 left to the sweep running as pid" in out
        assert count(path, "leases") == 2
    finally:
        other.kill()
        other.wait()
    with ResultsDB.open_for_writing(path) as results:
        plan = results.lease([("mlca-c", 1, s) for s in range(3)], resume=True, retry_failed=False)
    assert (plan.todo, plan.held) == ([("mlca-c", 1, 1), ("mlca-c", 1, 2)], {})  # the dead sweep's leases reclaimed
    assert set(column(path, "leases", "pid")) == {os.getpid()}


@pytest.mark.slow
def test_resume_during_a_sweep_leaves_its_runs_to_it(tmp_path: Path, tiny: Path) -> None:
    path = tmp_path / "r.sqlite"
    args = ["sweep", "--avs", "1", "--runs", "6", "--jobs", "1", "--db", str(path), "--scenario", str(tiny)]
    first = subprocess.Popen([sys.executable, "-m", "sim_check", *args], cwd=ROOT, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)  # fmt: skip
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not count(path, "runs"):
        time.sleep(0.05)
    started = time.monotonic()
    assert main([*args, "--resume"]) == 0
    assert time.monotonic() - started < 5  # it ran nothing: every run is stored or held by the first sweep
    _, err = first.communicate(timeout=60)
    assert first.returncode == 0 and "Traceback" not in err
    assert column(path, "runs", "seed") == list(range(6))
    assert count(path, "av_metrics") == 6 and count(path, "leases") == 0


def test_a_lease_whose_pid_was_reused_is_reclaimed(tmp_path: Path) -> None:
    path = tmp_path / "r.sqlite"
    with ResultsDB.open_for_writing(path) as results:
        with sqlite3.connect(path) as other:  # another process's lease, written as that process would
            other.execute("INSERT INTO leases VALUES ('mlca-c', 1, 0, ?, ?, '1')", (Owner.me().host, os.getppid()))
        other.close()
        plan = results.lease([("mlca-c", 1, 0)], resume=True, retry_failed=False)
    assert plan.todo == [("mlca-c", 1, 0)]  # the parent lives, but was not started at clock tick 1


def test_failed_runs_are_retried_only_with_retry_failed(tmp_path: Path) -> None:
    path = tmp_path / "r.sqlite"
    wanted = [("mlca-c", 1, 0), ("mlca-c", 1, 1)]
    with ResultsDB.open_for_writing(path) as results:
        results.store(result(0, "failed"))
        results.store(result(1))
        assert results.lease(wanted, resume=True, retry_failed=False).todo == []
        results.release()
        plan = results.lease(wanted, resume=True, retry_failed=True)
        assert (plan.todo, plan.stored, plan.retried) == ([("mlca-c", 1, 0)], 1, 1)
        assert count(path, "runs") == count(path, "av_metrics") == 1  # the failed run's rows are gone
        assert results.store(result(0)) is True


def test_retry_failed_needs_resume(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sweep", "--retry-failed", "--db", str(tmp_path / "r.sqlite")]) == 2
    assert "--retry-failed goes with --resume" in one_line_error(capsys)
    assert not (tmp_path / "r.sqlite").exists()


@pytest.mark.slow
def test_resume_retry_failed_runs_a_failed_run_again(tmp_path: Path, tiny: Path) -> None:
    path = tmp_path / "r.sqlite"
    store(path, result(0, "failed"))
    argv = ["sweep", "--avs", "1", "--runs", "1", "--jobs", "1", "--db", str(path), "--scenario", str(tiny)]
    assert main([*argv, "--resume"]) == 0
    assert column(path, "runs", "status") == ["failed"]
    assert main([*argv, "--resume", "--retry-failed"]) == 0
    assert column(path, "runs", "status") == ["done"]
    assert [steps > 0 for steps in column(path, "runs", "sim_steps")] == [True]


def test_run_refuses_a_run_the_database_holds(tmp_path: Path, tiny: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "r.sqlite"
    store(path, result(0))
    assert main(["run", "--db", str(path), "--scenario", str(tiny)]) == 2
    assert "already holds this run (mlca-c, 1 AVs, seed 0)" in one_line_error(capsys)


# --- 7. killed sweeps


def _children(pid: int) -> set[int]:
    found = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == pid:
            found.add(int(stat.parent.name))
    return found


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in "ZX"


def _read_to_end(fd: int, seconds: float) -> bool:
    """Whether the pipe reaches its end (every writer gone) within `seconds`."""
    os.set_blocking(fd, False)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            if os.read(fd, 65536) == b"":
                return True
        except BlockingIOError:
            time.sleep(0.1)
    return False


@pytest.mark.slow
def test_a_sweep_killed_with_sigkill_takes_its_workers_along_and_the_next_one_cleans_up(
    tmp_path: Path, tiny: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path, scratch = tmp_path / "r.sqlite", tmp_path / "tmp"
    scratch.mkdir()
    argv = [sys.executable, "-m", "sim_check", "sweep", "--avs", "1", "--runs", "200", "--jobs", "1",
            "--db", str(path), "--scenario", str(tiny)]  # fmt: skip
    env = {**os.environ, "TMPDIR": str(scratch)}
    sweep = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not count(path, "runs"):
        time.sleep(0.1)
    children = _children(sweep.pid)
    assert len(children) >= 2  # the worker and multiprocessing's resource tracker
    sweep.send_signal(signal.SIGKILL)  # the sweep alone, as the OOM killer or `kill -9 PID` would
    sweep.wait()
    assert sweep.stdout is not None
    assert _read_to_end(sweep.stdout.fileno(), 10), "a child of the killed sweep still holds its output"
    assert not [pid for pid in children if _running(pid)]
    (stale,) = scratch.iterdir()
    assert stale.name.startswith(f"mlca-sim-work-{sweep.pid}-")
    assert count(path, "leases") > 0  # the dead sweep's

    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    assert main(["sweep", "--avs", "1", "--runs", "1", "--db", str(path), "--scenario", str(tiny), "--resume"]) == 0
    assert list(scratch.iterdir()) == []
    assert count(path, "leases") == 0


def test_a_live_sweeps_folder_is_left_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    other = _sleeper()
    try:
        live = tmp_path / f"mlca-sim-work-{other.pid}-{started_time(other.pid)}-abc"
        dead = tmp_path / f"mlca-sim-work-{other.pid}-1-abc"  # the same pid, another process: gone
        live.mkdir()
        dead.mkdir()
        from sim_check.sweep import work_folder

        mine = work_folder()
        assert sorted(tmp_path.iterdir()) == sorted([live, mine])
        assert mine.name.startswith(f"mlca-sim-work-{os.getpid()}-{started_time(os.getpid())}-")
    finally:
        other.kill()
        other.wait()


# --- 8. scenario and command-line values


def _scenario(tmp_path: Path, text: str | bytes) -> Path:
    path = tmp_path / "s.toml"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def test_ints_and_floats_where_the_unit_is_continuous(tmp_path: Path) -> None:
    s = load_scenario(
        _scenario(tmp_path, "[road]\nhighway_speed_kmh = 80.5\nlength_m = 3000.0\n[traffic]\nstep_s = 1\n")
    )
    assert (s.road.highway_speed_kmh, s.road.length_m, s.traffic.step_s) == (80.5, 3000.0, 1.0)
    assert isinstance(s.traffic.step_s, float)
    paper = load_scenario()
    assert (paper.road.length_m, paper.traffic.depart_window_s) == (20500, 300)
    assert isinstance(paper.road.length_m, int)  # as written: the network files stay byte for byte the same


def test_target_lane_is_middle_or_an_index_of_the_road(tmp_path: Path) -> None:
    assert load_scenario(_scenario(tmp_path, "[traffic]\ntarget_lane = 4\n")).target_lane == 4
    assert load_scenario(_scenario(tmp_path, '[traffic]\ntarget_lane = "1"\n')).target_lane == 1


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[traffic]\ntarget_lane = "abc"\n', r':2:15: error: .target_lane. in \[traffic\] must be "middle" or a lane'),
        ("[traffic]\ntarget_lane = -1\n", r':2:15: error: .target_lane. .* "middle" or a lane index .* got -1'),
        ("[road]\nlanes = 3\n[traffic]\ntarget_lane = 3\n", r":4:15: error: .* is lane 3, but the road has 3 lanes"),
        ("[traffic]\ntarget_lane = true\n", r':2:15: error: .target_lane. .* "middle" or a lane index .* got True'),
        ("[traffic]\nav_arrival_lane = -2\n", r':2:19: error: .av_arrival_lane. .* "middle" or a lane index .* got -2'),
        (
            "[road]\nlanes = 2\n[traffic]\nav_arrival_lane = 2\n",
            r":4:19: error: .av_arrival_lane. in \[traffic\] is lane 2",
        ),
        ("[traffic]\nstep_s = nan\n", r":2:10: error: 'step_s' in \[traffic\] must be a finite number, got nan"),
        ("[traffic]\nstep_s = inf\n", r":2:10: error: .* must be a finite number, got inf"),
        ("[traffic]\nstep_s = 0.00001\n", r":2:10: error: .* must be at least 0.001"),
        ("[traffic]\ncars = 100000000\n", r":2:8: error: 'cars' in \[traffic\] must be at most 10000, got 100000000"),
        ("[traffic]\ncars = 2.5\n", r":2:8: error: 'cars' in \[traffic\] must be a whole number, got 2.5"),
        ("[road]\nlength_m = 1e9\n", r":2:12: error: 'length_m' in \[road\] must be at most 200000"),
        ("[road]\nlanes = 1000\n", r":2:9: error: 'lanes' in \[road\] must be at most 10"),
        ("[road]\nlength_m = true\n", r":2:12: error: 'length_m' in \[road\] must be a number, got True"),
        ("[road]\nlength_m = " + "9" * 5000 + "\n", r":1:1: error: invalid TOML: Exceeds the limit"),
        ("[traffic]\ncars = " + "9" * 60 + "\n", r":2:8: error: .* got an integer of more than 40 digits"),
        ('[road]\nroute = "a\\" b"\n', r":2:9: error: 'route' in \[road\]: edge ids cannot hold '\"'"),
        ("traffic = 3\n", r":1:11: error: 'traffic' must be a table"),
        ("[road]\nlanes = 5\nx = \n", r":3:5: error: invalid TOML: Invalid value$"),
        ('[traffic]\ncars = "3', r":2:10: error: invalid TOML: Unterminated string$"),
        ("a = " + "[" * 5000, r":1:1: error: invalid TOML: maximum recursion depth exceeded"),
    ],
)
def test_bad_scenario_values_are_errors_at_their_line_and_column(text: str, message: str, tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"s\.toml" + message):
        load_scenario(_scenario(tmp_path, text))


def test_a_scenario_that_is_not_utf8_is_an_error_at_the_byte(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"s\.toml:3:4: error: not UTF-8: byte 0xff$"):
        load_scenario(_scenario(tmp_path, b"[traffic]\ncars = 3\n# a\xff\n"))


def test_a_huge_scenario_file_is_refused_unread(tmp_path: Path) -> None:
    path = _scenario(tmp_path, "")
    with path.open("wb") as f:
        f.truncate(50_000_000)
    with pytest.raises(UsageError, match=r"s\.toml: error: scenario larger than 1,000,000 bytes"):
        load_scenario(path)


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_a_scenario_that_is_not_a_regular_file_is_refused_unread(device: str) -> None:
    with pytest.raises(UsageError, match=f"{device}: error: cannot read scenario: not a regular file"):
        load_scenario(Path(device))


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "--seed", "1099511627776"], "argument --seed: must be from 0 to 2147483647, got 1099511627776"),
        (["run", "--seed", "-1"], "argument --seed: must be from 0 to 2147483647"),
        (["run", "--avs", "0"], "argument --avs: must be from 1 to 100, got 0"),
        (["sweep", "--avs", "0", "--db", "{db}"], "--avs: every AV count must be from 1 to 100"),
        (["sweep", "--runs", "0", "--db", "{db}"], "argument --runs: must be from 1 to 100000, got 0"),
        (["sweep", "--runs", "100001", "--db", "{db}"], "argument --runs: must be from 1 to 100000"),
        (["sweep", "--jobs", "0", "--db", "{db}"], "argument --jobs: must be from 1 to 64, got 0"),
        (["sweep", "--timeout", "0", "--db", "{db}"], "argument --timeout: must be a positive number of seconds"),
        (["sweep", "--timeout", "nan", "--db", "{db}"], "argument --timeout: must be a positive number of seconds"),
        (["sweep", "--timeout", "inf", "--db", "{db}"], "argument --timeout: must be a positive number of seconds"),
        (["sweep", "--timeout", "-5", "--db", "{db}"], "argument --timeout: must be a positive number of seconds"),
    ],
)
def test_bad_command_line_values_are_one_line_and_exit_2(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "r.sqlite"
    argv = [a.replace("{db}", str(path)) for a in argv]
    assert main([*argv, "--scenario", str(SHORT)]) == 2
    assert message in one_line_error(capsys)
    assert not path.exists()


def test_a_bad_scenario_through_the_cli_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _scenario(tmp_path, b"[traffic]\ncars = \xfe\n")
    assert main(["run", "--scenario", str(path)]) == 2
    assert one_line_error(capsys) == f"{path}:2:8: error: not UTF-8: byte 0xfe\n"


def test_the_layout_is_described_once_and_every_version_begins_with_the_one_before(tmp_path: Path) -> None:
    """The DDL, the columns the report reads and the inserts all come from one description of each table: a new
    database has exactly the described columns and types, and the columns of an older version come first, in
    order (which is what lets `mlca-sim report` read every version)."""
    ResultsDB.open_for_writing(tmp_path / "r.sqlite").close()
    with sqlite3.connect(tmp_path / "r.sqlite") as conn:
        for name, table in schema.TABLES.items():
            info = conn.execute(f"PRAGMA table_info({name})").fetchall()
            assert [(r[1], r[2], bool(r[3])) for r in info] == [(c.name, c.kind, c.required) for c in table.columns]
            assert [r[1] for r in info if r[5]] == list(table.key)  # the primary key, in order
            for version in (1, 2):
                older = table.names(version)
                assert table.names()[: len(older)] == older
    assert schema.COLUMNS_2["runs"][-1] == "bg_mean_speed_ms" and "density_veh_km_lane" in schema.COLUMNS["runs"]
