"""The paper's comparison for real in SUMO: sensing sides, every controller of the matrix on a short scenario, and
the report produced from that small sweep with its tables checked against the database."""

from __future__ import annotations

import re
import sqlite3
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from sim_check.cli import main
from sim_check.controllers import PAPER_MATRIX, SETUPS
from sim_check.db import ResultsDB
from sim_check.paper_results import CLAIMS, LANE_FIGURES, MARKS, V2V_SUBJECT
from sim_check.reads import Reads
from sim_check.report import label, write_report
from sim_check.runner import run_once, sumo_args
from sim_check.scenario import build, load_scenario
from sim_check.sensing import _gap_ok
from tests.sim_helpers import SHORT


def _scene(tmp_path: Path, cars: list[tuple[str, int, float]]) -> Path:
    """A route file on the built-in highway's `hw` edge: every vehicle departs at 0 s at 20 m/s."""
    lines = ["<routes>", '  <vType id="car" vClass="passenger" speedDev="0"/>', '  <route id="r" edges="hw"/>']
    for vid, lane, pos in cars:
        lines.append(f'  <vehicle id="{vid}" type="car" route="r" depart="0" departLane="{lane}" '
                     f'departPos="{pos}" departSpeed="20"/>')  # fmt: skip
    path = tmp_path / "scene.rou.xml"
    path.write_text("\n".join([*lines, "</routes>"]) + "\n")
    return path


def test_sensing_reads_the_side_it_names_and_rejects_a_car_alongside(tmp_path: Path) -> None:
    import libsumo

    scenario = load_scenario(SHORT)
    built = build(scenario, 0, tmp_path)
    # the AV in lane 2; a car beside it on the left (lane 3), its front 1 m behind the AV's; the right (lane 1)
    # has a leader 60 m ahead
    routes = _scene(tmp_path, [("av0", 2, 300.0), ("beside", 3, 299.0), ("ahead", 1, 360.0)])
    libsumo.start(sumo_args(scenario, built.net, routes, 0))
    try:
        libsumo.simulationStep()
        read = Reads(libsumo)
        assert [vid for vid, _ in read.neighbours("av0", -1, leaders=True)] == ["ahead"]
        assert read.neighbours("av0", -1, leaders=False) == ()
        assert read.neighbours("av0", +1, leaders=True) == ()
        ((vid, gap),) = read.neighbours("av0", +1, leaders=False)  # the car beside: a follower, overlapping
        assert vid == "beside" and gap < 0
        speed = libsumo.vehicle.getSpeed("av0")
        assert not _gap_ok(read, "av0", +1, speed)
        assert _gap_ok(read, "av0", -1, speed)
    finally:
        libsumo.close()


@pytest.fixture(scope="module")
def matrix_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    db = tmp_path_factory.mktemp("matrix") / "matrix.sqlite"
    argv = ["sweep", "--matrix", "paper", "--runs", "2", "--jobs", "2", "--db", str(db), "--scenario", str(SHORT)]
    assert main(argv) == 0
    return db


def _records(db: Path, table: str) -> list[dict[str, Any]]:
    """The rows of `table`, each as {column: value}, read through the results database's API."""
    with ResultsDB.open_for_reading(db) as results:
        rows = results.table_rows(table)
    return [dict(zip(rows.columns, row, strict=True)) for row in rows.rows]


def _where(db: Path, table: str, controller: str, avs: int) -> list[dict[str, Any]]:
    return [r for r in _records(db, table) if r["controller"] == controller and r["avs"] == avs]


@pytest.mark.slow
def test_every_controller_of_the_paper_drives_the_short_scenario(matrix_db: Path) -> None:
    runs = _records(matrix_db, "runs")
    groups = {(r["controller"], r["avs"]) for r in runs}
    assert sorted(groups) == sorted((c, a) for c in PAPER_MATRIX for a in (1, 3))
    for controller, avs in groups:
        group = _where(matrix_db, "runs", controller, avs)
        assert [(r["status"], r["monitor_violations"]) for r in group] == [("done", 0)] * 2
    # every AV left the ramp (its acceleration lane ends, so at least one lane change) and arrived
    metrics = _records(matrix_db, "av_metrics")
    assert sorted({m["controller"] for m in metrics}) == sorted(PAPER_MATRIX)
    for controller in PAPER_MATRIX:
        mine = [m for m in metrics if m["controller"] == controller]
        assert len(mine) == 2 * (1 + 3) and all(m["lc_5km"] >= 1 and m["arrived"] == 1 for m in mine)
    # the mechanism is recorded for the machines and "without", not for the models that do not sense
    sensed = {m["controller"] for m in metrics if m["needs"] is not None}
    assert sorted(sensed) == sorted(c for c in PAPER_MATRIX if SETUPS[c].kind in ("fsm", "without"))
    # each controller drove differently from SUMO's default model on at least one run
    shas = {c: [r["trajectory_sha256"] for r in sorted(runs, key=lambda r: (r["avs"], r["seed"])) if r["controller"] == c]
            for c in PAPER_MATRIX}  # fmt: skip
    assert len({tuple(v) for v in shas.values()}) == len(PAPER_MATRIX)


def _table(report: str, heading: str) -> list[list[str]]:
    section = report.split(f"## {heading}", 1)[1].split("\n## ", 1)[0]
    header = ("| controller", "| claim")
    rows = [line for line in section.splitlines() if line.startswith("| ") and not line.startswith(header)]
    return [[cell.strip() for cell in row.strip("|").split("|")] for row in rows]


def _check_loop_sections(db: Path, report: str) -> None:
    """The report's transition coverage, shadow mode and safety tables against the database's rows."""
    fired: Counter[tuple[str, str]] = Counter()
    for r in _records(db, "transitions"):
        fired[(label(r["controller"]), r["transition"])] += r["fired"]
    machine, seen = "", 0
    for line in report.split("## Transition coverage", 1)[1].split("\n## ", 1)[0].splitlines():
        if line.startswith("**"):
            machine = line[2:].split("**")[0]
        elif line.startswith("| `"):
            cells = [c.strip() for c in line.strip("|").split("|")]
            assert int(cells[2]) == fired[(machine, cells[0].strip("`"))], (machine, cells)
            seen += 1
    assert seen == len(fired) > 0
    with ResultsDB.open_for_reading(db) as results:  # what the evidence of MLCA-T reads
        counts = results.transition_counts(("mlca_t-py", "mlca_t-c"))
    assert counts == {tid: n for (name, tid), n in fired.items() if name == "MLCA-T"}
    assert counts["urgent_left"] >= 2 * (1 + 3)  # every AV merged: an urgent need to the left, taken
    for name, avs, av_runs, wishes, *_ in (r for r in _table(report, "Shadow mode") if len(r) == 10):
        group = _where(db, "av_metrics", {label(c): c for c in SETUPS}[name], int(avs))
        assert (int(av_runs), int(wishes)) == (len(group), sum(m["wishes"] for m in group))
        assert int(wishes) == len(_where(db, "episodes", group[0]["controller"], int(avs)))
    rows = _table(report, "Safety beside collisions")
    assert len(rows) == 2 * len(PAPER_MATRIX)
    for name, avs, changes, unsafe, *_ in rows:
        group = _where(db, "av_metrics", {label(c): c for c in SETUPS}[name], int(avs))
        assert int(changes) == sum(m["lc_20km"] for m in group)
        assert int(unsafe.split()[0]) == sum(m["lc_rss_unsafe"] for m in group)
        if name == "MLCA-T":
            assert unsafe.startswith("0 ")  # MLCA-T changes lane only into gaps that are safe by RSS


@pytest.mark.slow
def test_report_tables_match_the_database(matrix_db: Path, tmp_path: Path) -> None:
    written = write_report(matrix_db, tmp_path / "a")
    again = write_report(matrix_db, tmp_path / "b")
    assert [p.read_bytes() for p in written] == [p.read_bytes() for p in again]  # byte-identical
    names = {p.name for p in written}
    for stem in ("fig2_lc2017_mobil", "fig3_idm_continuous", "fig4_mlca_without", "fig5_collisions", "fig6_cost"):
        assert {f"{stem}.png", f"{stem}.svg"} <= names
        assert (tmp_path / "a" / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert "<svg" in (tmp_path / "a" / f"{stem}.svg").read_text()
    report = (tmp_path / "a" / "report.md").read_text()
    by_label = {label(c): c for c in SETUPS}
    checked = 0
    for heading in ("Lane changes: LC2017", "Lane changes: IDM/LC", "Lane changes: MLCA"):
        for name, avs, km, _paper, measured, runs in _table(report, heading):
            mean = float(measured.split()[0])
            group = _where(matrix_db, "av_metrics", by_label[name], int(avs))
            per_seed = [sum(m[f"lc_{km}km"] for m in group if m["seed"] == seed) for seed in {m["seed"] for m in group}]
            assert mean == pytest.approx(sum(per_seed) / len(per_seed), abs=0.005) and runs == "2"
            checked += 1
    assert checked == len(MARKS) * 2 * sum(len(f.series) + len(f.extra) for f in LANE_FIGURES)
    for name, avs, _paper, contact, mingap, _runs in _table(report, "Collisions"):
        group = _where(matrix_db, "av_metrics", by_label[name], int(avs))
        assert float(contact.split()[0]) == pytest.approx(100.0 * sum(m["collisions"] for m in group) / 2, abs=0.05)
        assert float(mingap.split()[0]) == pytest.approx(100.0 * sum(m["mingap_contacts"] for m in group) / 2, abs=0.05)
    for name, avs, av_runs, episodes, _moved, _deferred, never, *_ in _table(report, "Mechanism"):
        group = _where(matrix_db, "av_metrics", by_label[name], int(avs))
        expected = (len(group), sum(m["needs"] for m in group), sum(m["needs_open"] for m in group))
        assert (int(av_runs), int(episodes), int(never.split()[0])) == expected
    _check_loop_sections(matrix_db, report)
    claims = _table(report, "Claims")
    lane_claims = [c for c in CLAIMS if c.kind == "reduction" and c.metric == "lc"]
    with_v2v = sum(3 in c.avs for c in lane_claims)  # judged again on MLCA with V2V, which the matrix runs
    assert len(claims) == sum(len(c.avs) if c in lane_claims else 1 for c in CLAIMS) + with_v2v
    v2v_rows = [row for row in claims if row[2] == f"3 AVs, 20 km, with V2V (`{V2V_SUBJECT}`)"]
    assert len(v2v_rows) == with_v2v
    c3b = next(row for row in v2v_rows if row[0].startswith("C3b"))
    per_run = {
        c: [sum(m["lc_20km"] for m in group if m["seed"] == seed) for seed in (0, 1)]
        for c in (V2V_SUBJECT, "without")
        for group in [_where(matrix_db, "av_metrics", c, 3)]
    }
    reduction = 100.0 * (1 - sum(per_run[V2V_SUBJECT]) / sum(per_run["without"]))
    assert float(c3b[4].split("%")[0]) == pytest.approx(reduction, abs=0.5)
    assert all(re.fullmatch(r"\*\*(reproduced|not reproduced|not comparable)\*\*", row[3]) for row in claims)


def test_report_and_matrix_usage_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", "--db", str(tmp_path / "none.sqlite"), "--out", str(tmp_path)]) == 2
    assert "no such results database" in capsys.readouterr().err
    argv = ["sweep", "--matrix", "paper", "--controller", "mlca-c", "--db", str(tmp_path / "x.sqlite")]
    assert main(argv) == 2
    assert "either --matrix or --controller" in capsys.readouterr().err
    old = tmp_path / "old.sqlite"
    with sqlite3.connect(old) as conn:
        conn.execute("CREATE TABLE runs (controller TEXT, avs INTEGER, seed INTEGER, status TEXT)")
    assert main(["sweep", "--controller", "mlca-c", "--runs", "1", "--db", str(old)]) == 2
    err = capsys.readouterr().err
    assert "table runs has other columns" in err and "use a new database file" in err


def test_a_models_vehicle_type_and_options_reach_sumo(tmp_path: Path) -> None:
    scenario = load_scenario(SHORT)
    built = build(scenario, 0, tmp_path, SETUPS["idm-lc"].av_type)
    (av_type,) = [line for line in built.routes.read_text().splitlines() if '<vType id="av"' in line]
    assert 'carFollowModel="IDM"' in av_type
    args = sumo_args(scenario, built.net, built.routes, 0, SETUPS["sl2015"].options)
    assert args[-2:] == ["--lateral-resolution", "3.2"]


@pytest.mark.slow
def test_dk2008_drives_the_short_scenario(tmp_path: Path) -> None:
    result = run_once(load_scenario(SHORT).with_avs(3), "dk2008", 1, tmp_path)
    assert result.status == "done"
    assert all(m.row()["arrived"] and m.row()["lc_5km"] >= 1 for m in result.metrics)
