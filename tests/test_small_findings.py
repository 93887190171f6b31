"""Small findings on hostile and unlucky input: replaying a `check --json` report (duplicates, too many points,
names no spec gives, a directory, deep JSON, control characters in its paths), a diagram of a spec with very long
text, and a resumed sweep whose fellow sweep died while it ran."""

from __future__ import annotations

import copy
import json
import re
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

import pytest

from mlca_verify.cli import main as verify
from mlca_verify.diagram import DOT_TEXT_LIMIT, render
from mlca_verify.spec import load_spec
from sim_check import sweep as sweep_module
from sim_check.cli import main
from sim_check.db import ResultsDB
from sim_check.replay import MAX_REPLAY_POINTS, Phase, Point, load_points
from sim_check.run_results import AvMetrics, Job, RunResult
from tests.conftest import ROOT
from tests.sim_helpers import SHORT, rows

MLCA_T = ROOT / "spec" / "mlca_t.toml"
HIGHWAY = "time-gap-rule-is-rss-safe-on-the-highway"
COUNTER = ROOT / "tests" / "corpus" / "counter.toml"


def one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# --- replay: a check --json report -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A real `check --json` report with one violated lemma (its counterexample is a point to replay)."""
    out = tmp_path_factory.mktemp("report") / "check.json"
    assert verify(["check", str(MLCA_T), "--only", HIGHWAY, "--quiet", "--json", str(out)]) == 0
    doc: dict[str, Any] = json.loads(out.read_text())
    return doc


def _with(report: dict[str, Any], results: list[dict[str, Any]], **spec: Any) -> dict[str, Any]:
    doc = copy.deepcopy(report)
    doc["specs"][0]["results"] = results
    doc["specs"][0].update(spec)
    return doc


def _violated(report: dict[str, Any]) -> dict[str, Any]:
    (result,) = [r for r in report["specs"][0]["results"] if r["verdict"] == "violated"]
    return copy.deepcopy(result)


def _write(path: Path, doc: object) -> Path:
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture
def replays(monkeypatch: pytest.MonkeyPatch) -> list[Point]:
    """SUMO's replay stood in for: every point replayed is recorded, and ends in a collision in both phases."""
    done: list[Point] = []

    def fake(point: Point, work: Path) -> list[Phase]:
        done.append(point)
        return [Phase(name, collisions=[["av", "leader"]]) for name in ("leader brakes", "AV brakes")]

    monkeypatch.setattr("sim_check.replay.replay", fake)
    return done


def test_copies_of_one_lemma_result_are_replayed_once(
    report: dict[str, Any], tmp_path: Path, replays: list[Point], capsys: pytest.CaptureFixture[str]
) -> None:
    path = _write(tmp_path / "copies.json", _with(report, [_violated(report)] * 200))
    assert len(load_points(path, None, "left")) == 1
    assert main(["replay", str(path)]) == 0
    assert len(replays) == 1
    assert "1 point(s) replayed: 1 unsafe" in capsys.readouterr().out


def test_more_distinct_points_than_the_limit_are_refused_before_sumo(
    report: dict[str, Any], tmp_path: Path, replays: list[Point], capsys: pytest.CaptureFixture[str]
) -> None:
    results = []
    for k in range(MAX_REPLAY_POINTS + 1):
        result = _violated(report)
        result["counterexample"]["steps"][0]["signals"]["v"] = 10 + k
        results.append(result)
    at_limit = _write(tmp_path / "fifty.json", _with(report, results[:MAX_REPLAY_POINTS]))
    assert len(load_points(at_limit, None, "left")) == MAX_REPLAY_POINTS
    path = _write(tmp_path / "many.json", _with(report, results))
    assert main(["replay", str(path)]) == 2
    err = one_line_error(capsys)
    assert err.startswith(f"{path}: error: {MAX_REPLAY_POINTS + 1} distinct counterexample points to replay")
    assert f"more than the {MAX_REPLAY_POINTS} one file may hold" in err
    assert replays == []


def test_a_lemma_name_longer_than_a_spec_allows_is_refused_at_once(
    report: dict[str, Any], tmp_path: Path, replays: list[Point], capsys: pytest.CaptureFixture[str]
) -> None:
    result = _violated(report)
    result["property"] = "a" * 100_000
    path = _write(tmp_path / "long.json", _with(report, [result] * 5))
    started = time.monotonic()
    assert main(["replay", str(path)]) == 2
    assert time.monotonic() - started < 5
    assert one_line_error(capsys) == f"{path}: error: lemma name of 100,000 characters: a spec allows at most 64\n"
    assert replays == []
    good = _write(tmp_path / "good.json", _with(report, [_violated(report)]))
    assert main(["replay", str(good), "--lemma", "a" * 100_000]) == 2
    assert (
        one_line_error(capsys)
        == "mlca-sim replay: error: --lemma name of 100,000 characters: a spec allows at most 64\n"
    )
    result["property"] = "not a name"
    path = _write(tmp_path / "spaced.json", _with(report, [result]))
    assert main(["replay", str(path)]) == 2
    assert "lemma name 'not a name' is not a property name" in one_line_error(capsys)
    assert replays == []


def test_a_directory_is_not_a_replay_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", str(tmp_path)]) == 2
    assert one_line_error(capsys) == f"{tmp_path}: error: is a directory, not a report or point file\n"


@pytest.mark.parametrize("text", ["[" * 100_000, '{"a":' * 100_000], ids=["arrays", "objects"])
def test_a_deeply_nested_json_file_is_read_as_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    path = tmp_path / "deep.json"
    path.write_text(text)
    assert main(["replay", str(path)]) == 2
    err = one_line_error(capsys)
    assert err == f"{path}: error: invalid JSON: nested too deeply\n"
    assert "TOML" not in err


def test_control_characters_in_the_reports_path_forge_no_output_line(
    report: dict[str, Any], tmp_path: Path, replays: list[Point], capsys: pytest.CaptureFixture[str]
) -> None:
    forged = "FORGED 0 point(s) replayed: all as expected"
    hostile = f"spec/x.toml\n{forged}\r{forged}\u2028{forged}\x1b[2J\x85{forged}"
    result = _violated(report)
    result["expected"] = "holds"  # not as expected: the summary line lists the point's source as well
    path = _write(tmp_path / "hostile.json", _with(report, [result], path=hostile))
    assert main(["replay", str(path)]) == 1
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert len(lines) == 5  # the point, its params, two phases and the summary: nothing else
    assert not [line for line in lines if line.startswith("FORGED")]
    assert "\x1b" not in out and "\r" not in out and "\u2028" not in out and "\x85" not in out
    assert lines[0].startswith("spec/x.toml\\nFORGED 0 point(s) replayed: all as expected\\rFORGED")
    assert "not as expected: spec/x.toml\\nFORGED" in lines[-1]


# --- diagram: very long spec text ----------------------------------------------------------------------------


def _long_counter(tmp_path: Path, text: str) -> Path:
    """counter.toml with `text` as the machine's cite and doc, an input's doc and a transition's cite."""
    quoted = json.dumps(text, ensure_ascii=False)  # a JSON string of these characters is a TOML basic string
    spec = COUNTER.read_text()
    spec = spec.replace('cite = "corpus"\n', f"cite = {quoted}\ndoc = {quoted}\n", 1)
    spec = spec.replace('inc = { doc = "count up"', f"inc = {{ doc = {quoted}", 1)
    spec = spec.replace('cite = "c01"', f"cite = {quoted}", 1)
    path = tmp_path / "counter.toml"
    path.write_text(spec)
    return path


@pytest.mark.parametrize(
    "text", ["x" * 20_000, "\x1b" * 20_000, '\U0001f600\\"' * 7_000], ids=["plain", "control", "mixed"]
)
def test_a_diagram_of_a_spec_with_very_long_text_lays_out(tmp_path: Path, text: str) -> None:
    spec = _long_counter(tmp_path, text)
    dot = render(load_spec(spec, compare=False).machine, "dot")
    quoted = re.findall(r'"((?:[^"\\]|\\.)*)"', dot)
    assert quoted and max(len(q.encode()) for q in quoted) <= 10 * DOT_TEXT_LIMIT < 16_384
    assert any(q.endswith("...") for q in quoted)
    out = tmp_path / "counter.svg"
    assert verify(["diagram", str(spec), "--format", "svg", "--out", str(out)]) == 0
    svg = out.read_text()
    assert "<svg" in svg and "[t1]" in svg and "S4" in svg


# --- sweep --resume: a fellow sweep dies while this one runs ------------------------------------------------


class _Fake:
    """A sweep that stands in for the SUMO workers: it stores a finished run for each job through the database,
    as a sweep does, except those `drop` names; `during` is called once, while the first plan runs."""

    during: ClassVar[Callable[[], None]] = staticmethod(lambda: None)
    drop: ClassVar[frozenset[Job]] = frozenset()
    plans: ClassVar[list[list[Job]]] = []

    def __init__(self, scenario: object, database: ResultsDB, jobs_n: int, timeout_s: float) -> None:
        self.database = database
        self.skipped: list[Job] = []

    def run(self, todo: list[Job], progress: Callable[[RunResult], None]) -> list[RunResult]:
        type(self).plans.append(list(todo))
        if len(type(self).plans) == 1:
            type(self).during()
        finished = []
        for controller, avs, seed in todo:
            if (controller, avs, seed) in type(self).drop:
                continue
            result = RunResult(controller, avs, seed, status="done", metrics=[AvMetrics("av0")])
            if not self.database.store(result):
                self.skipped.append((controller, avs, seed))
            finished.append(result)
            progress(result)
        self.database.release()
        return finished


LEASER = """
import sys, time
from pathlib import Path
from sim_check.db import ResultsDB
results = ResultsDB.open_for_writing(Path(sys.argv[1]))
results.lease([("mlca-c", 1, s) for s in (1, 2)], resume=True, retry_failed=False)
print("leased", flush=True)
time.sleep(600)
"""


def _fellow_sweep(db: Path) -> subprocess.Popen[str]:
    """Another writer of `db` that leases seeds 1 and 2 through the database's API, and then runs nothing."""
    other = subprocess.Popen([sys.executable, "-c", LEASER, str(db)], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    assert other.stdout is not None and other.stdout.readline() == "leased\n"
    return other


def _kill(other: subprocess.Popen[str]) -> None:
    other.kill()
    other.wait()


@pytest.fixture
def fake_sweep(monkeypatch: pytest.MonkeyPatch) -> type[_Fake]:
    monkeypatch.setattr(sweep_module, "Sweep", _Fake)
    monkeypatch.setattr(_Fake, "plans", [])
    return _Fake


SWEEP = ["sweep", "--avs", "1", "--runs", "3", "--jobs", "1", "--scenario", str(SHORT), "--resume"]


def test_resume_runs_the_runs_a_sweep_that_died_meanwhile_left(
    tmp_path: Path, fake_sweep: type[_Fake], monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "r.sqlite"
    with ResultsDB.open_for_writing(db):
        pass
    other = _fellow_sweep(db)
    try:
        monkeypatch.setattr(fake_sweep, "during", staticmethod(lambda: _kill(other)))  # it dies holding its leases
        assert main([*SWEEP, "--db", str(db)]) == 0
    finally:
        _kill(other)
    assert fake_sweep.plans == [[("mlca-c", 1, 0)], [("mlca-c", 1, 1), ("mlca-c", 1, 2)]]
    assert sorted(r[2] for r in rows(db, "runs")) == [0, 1, 2]
    assert rows(db, "leases") == []
    out = capsys.readouterr().out
    assert "2 runs left unfinished by a sweep that ended meanwhile: running them too" in out
    assert "3 runs done, 0 failed, 0 monitor violations" in out


def test_resume_that_cannot_store_a_run_exits_non_zero_saying_how_many_are_missing(
    tmp_path: Path, fake_sweep: type[_Fake], monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "r.sqlite"
    monkeypatch.setattr(fake_sweep, "drop", frozenset({("mlca-c", 1, 1)}))  # a run that ends with no result stored
    assert main([*SWEEP, "--db", str(db)]) == 1
    assert fake_sweep.plans == [[("mlca-c", 1, 0), ("mlca-c", 1, 1), ("mlca-c", 1, 2)]]  # not run over and over
    err = capsys.readouterr().err
    assert f"{db}: error: 1 of the 3 runs wanted are missing" in err
    assert rows(db, "leases") == []


def test_resume_leaves_the_runs_of_a_live_sweep_to_it(
    tmp_path: Path, fake_sweep: type[_Fake], capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "r.sqlite"
    with ResultsDB.open_for_writing(db):
        pass
    other = _fellow_sweep(db)
    try:
        assert main([*SWEEP, "--db", str(db)]) == 0
        assert fake_sweep.plans == [[("mlca-c", 1, 0)]]
        assert f"2 runs wanted are left to the sweep running as pid {other.pid}" in capsys.readouterr().out
    finally:
        _kill(other)


@pytest.mark.parametrize(
    "argv",
    [
        ["check", "{dir}"],
        ["gen", "{dir}", "--out", "{tmp}/g"],
        ["evidence", "spec/mlca_t.toml", "--out", "{tmp}/e", "--replay", "{dir}"],
    ],
)
def test_a_directory_given_for_a_file_says_so_in_one_line(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(ROOT)
    folder = tmp_path / "folder.toml"
    folder.mkdir()
    assert verify([a.format(dir=folder, tmp=tmp_path) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{folder}: error: cannot read ") and err.endswith(": a directory"), err
    assert len(err.splitlines()) == 1
