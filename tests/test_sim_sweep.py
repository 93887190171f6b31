"""Sweeps and their results database: the same rows for the same seeds, kill and resume, Ctrl-C, hung runs, and no
files left behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from mlca_verify.errors import UsageError
from sim_check.cli import main
from tests.conftest import ROOT
from tests.sim_helpers import SHORT, rows


def stored(db: Path) -> int:
    """Runs a sweep running in another process has stored so far (none while it is still creating the file)."""
    try:
        return len(rows(db, "runs")) if db.exists() else 0
    except UsageError:  # the file exists, its tables not yet
        return 0


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


def test_a_sweep_leaves_no_files_behind(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))  # the workers' temporary files
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))  # this process's
    argv = ["sweep", "--controller", "mlca-c,lc2013", "--avs", "1", "--runs", "1", "--jobs", "2"]
    assert main([*argv, "--db", str(tmp_path / "r.sqlite"), "--scenario", str(SHORT)]) == 0
    assert len(rows(tmp_path / "r.sqlite", "runs")) == 2
    assert list(scratch.iterdir()) == []
