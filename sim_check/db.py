"""The results database (SQLite): one row per run and one per AV, each run committed when it ends.

A run's rows go in one transaction, so a sweep killed at any moment leaves only whole runs behind; `--resume`
skips the (controller, AVs, seed) triples already in `runs`, so nothing is lost and nothing is run twice.

More than one process may write to one database: every write is an immediate transaction, retried while another
writer holds the lock (`transactions`); a run already stored is not stored again (the second writer skips it);
and a sweep leases the runs it is going to do (`leases`), so that a second sweep leaves them alone while the
first one lives.

The file is marked as a results database with the version of its layout (`schema`, where every table is
described once); anything else is refused before a run starts, and nothing is written into it.

`ResultsDB` is the one way in, for sim_check and for the evidence of mlca_verify alike: opened once per command
(`ResultsDB.open_for_writing` or `ResultsDB.open_for_reading`) in a `with` block that closes it, it stores runs,
says which are stored, leases and releases them, and answers the grouped reads of the report and the monitor
summary of the evidence. Nothing outside this module, `schema`, `leases` and `transactions` holds SQL."""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mlca_verify.errors import UsageError
from sim_check.leases import Plan, drop_lease, lease, probe, release
from sim_check.radio import V2V_COUNTS
from sim_check.run_results import MARKS_KM, SAFETY, SHADOW, STATES, Job, RunResult, Status
from sim_check.schema import (
    AV_METRICS,
    COLUMNS_2,
    EPISODES,
    RUN_KEY,
    RUNS,
    TRANSITIONS,
    VIOLATIONS,
    Table,
    check_columns,
    check_readable,
    prepare,
    table_name,
    tables,
)
from sim_check.transactions import Database, open_file, reading, retrying

__all__ = ["LoopRows", "MechanismTotals", "MonitorSummary", "Plan", "ReportRows", "ResultsDB", "RunTotals", "TableRows"]


def _connect(path: Path) -> Database:
    conn = open_file(path, "rw" if path.exists() else "rwc")
    try:
        retrying(conn, lambda c: _prepare(c, path), "write to the results database")
    except BaseException:
        conn.close()
        raise
    return conn


def _prepare(conn: sqlite3.Connection, path: Path) -> None:
    prepare(conn, path)
    probe(conn)


def _stored_keys(conn: sqlite3.Connection) -> set[Job]:
    rows = reading(conn, lambda c: c.execute("SELECT controller, avs, seed FROM runs").fetchall(), "read")
    return {(c, a, s) for c, a, s in rows}


def _store(conn: sqlite3.Connection, r: RunResult) -> bool:
    return retrying(conn, lambda c: _insert(c, r), f"store run {r.controller}, {r.avs} AVs, seed {r.seed}")


def _values(table: Table, row: dict[str, Any]) -> tuple[Any, ...]:
    """A row for `table.insert()`: every column's value, in the table's order (a column left out is a bug)."""
    return tuple(row[name] for name in table.names())


def _insert(conn: sqlite3.Connection, r: RunResult) -> bool:
    key = dict(zip(RUN_KEY, (r.controller, r.avs, r.seed), strict=True))
    drop_lease(conn, (r.controller, r.avs, r.seed))
    run = {
        **key,
        "status": r.status,
        "reason": r.reason,
        "sim_steps": r.sim_steps,
        "wall_s": round(r.wall_s, 3),
        "vehicle_steps": r.vehicle_steps,
        "collisions": r.collisions,
        "monitor_violations": r.monitor_violations,
        "trajectory_sha256": r.trajectory_sha256,
        "bg_mean_speed_ms": r.bg_mean_speed_ms,
        "density_veh_km_lane": r.density_veh_km_lane,
        **{f"v2v_{name}": getattr(r.v2v, name) for name in V2V_COUNTS},
    }
    if not conn.execute(RUNS.insert("INSERT OR IGNORE"), _values(RUNS, run)).rowcount:
        return False
    conn.executemany(AV_METRICS.insert(), [_values(AV_METRICS, {**key, **m.row()}) for m in r.metrics])
    violations = [
        {**key, "av": v.av, "time_s": v.time_s, "invariants": ",".join(v.invariants), "trace_json": json.dumps(v.trace)}
        for v in r.violations
    ]
    conn.executemany(VIOLATIONS.insert(), [_values(VIOLATIONS, v) for v in violations])
    fired = [
        {**key, "av": m.av, "transition": tid, "fired": n}
        for m in r.metrics
        for tid, n in sorted(m.transitions.items())
    ]
    conn.executemany(TRANSITIONS.insert(), [_values(TRANSITIONS, f) for f in fired])
    episodes = [{**key, "av": m.av, **asdict(e), "urgent": int(e.urgent)} for m in r.metrics for e in m.episodes]
    conn.executemany(EPISODES.insert(), [_values(EPISODES, e) for e in episodes])
    return True


# --- reads -------------------------------------------------------------------------------------------------

REPORT_STATUSES = "SELECT controller, avs, status, monitor_violations FROM runs ORDER BY controller, avs, seed"
REPORT_FINISHED = (
    f"SELECT r.controller, r.avs, r.seed, {', '.join(f'SUM(m.lc_{km}km)' for km in MARKS_KM)},"
    " SUM(m.collisions), SUM(m.mingap_contacts), AVG(m.travel_time_s), AVG(m.mean_speed_ms), r.bg_mean_speed_ms"
    " FROM runs r JOIN av_metrics m USING (controller, avs, seed) WHERE r.status = 'done'"
    " GROUP BY r.controller, r.avs, r.seed ORDER BY r.controller, r.avs, r.seed"
)
REPORT_MECHANISM = (
    "SELECT m.controller, m.avs, COUNT(*), SUM(m.needs), SUM(m.needs_moved), SUM(m.needs_open),"
    " SUM(m.needs_deferred),"
    f" SUM(m.need_s), SUM(m.deferred_s), {', '.join(f'SUM(m.{s.lower()}_s)' for s in STATES)}"
    " FROM av_metrics m JOIN runs r USING (controller, avs, seed)"
    " WHERE r.status = 'done' AND m.needs IS NOT NULL GROUP BY m.controller, m.avs"
)
SUMMARY_COLUMNS = ("controller", "status", "monitor_violations")
# per finished run: lane changes by 20 km, collisions and SSM conflicts summed over its AVs, and what the radio
# carried (schema 4)
V2V_RUNS = (
    "SELECT r.controller, r.avs, r.seed, SUM(m.lc_20km), SUM(m.collisions), SUM(m.ssm_conflicts),"
    f" {', '.join(f'r.v2v_{name}' for name in V2V_COUNTS)}"
    " FROM runs r JOIN av_metrics m USING (controller, avs, seed) WHERE r.status = 'done'"
    " GROUP BY r.controller, r.avs, r.seed ORDER BY r.controller, r.avs, r.seed"
)


@dataclass(frozen=True)
class RunStatus:
    """One stored run, finished or failed, as the report counts it."""

    controller: str
    avs: int
    status: Status
    monitor_violations: int | None


@dataclass(frozen=True)
class RunTotals:
    """One finished run over its AVs: sums of lane changes (one per mark of MARKS_KM), collisions and minGap
    contacts; means of travel time and speed over the AVs that have one; the other traffic's mean speed."""

    controller: str
    avs: int
    seed: int
    lane_changes: tuple[int, ...]
    collisions: int
    mingap_contacts: int | None
    travel_time_s: float | None
    mean_speed_ms: float | None
    bg_mean_speed_ms: float | None


@dataclass(frozen=True)
class MechanismTotals:
    """Sums over the AVs of one (controller, AVs)'s finished runs that record the mechanism (`needs` not null);
    `state_s` has one entry per state of STATES, None where no AV has one."""

    controller: str
    avs: int
    av_count: int
    needs: int
    moved: int
    open: int
    deferred: int
    need_s: float
    deferred_s: float
    state_s: tuple[float | None, ...]


@dataclass(frozen=True)
class ReportRows:
    """What `mlca-sim report` reads, from one snapshot of the database, each list in (controller, AVs) order, and
    the closed loop's own figures."""

    statuses: list[RunStatus]
    finished: list[RunTotals]
    mechanism: list[MechanismTotals]
    loop: LoopRows


# --- the closed loop's own figures (schema 3; a database of schema 2 has none) ------------------------------

DONE = "JOIN runs r USING (controller, avs, seed) WHERE r.status = 'done'"
LOOP_QUERIES = {
    "transitions": (
        "SELECT t.controller, t.transition, SUM(t.fired),"
        " COUNT(DISTINCT CASE WHEN t.fired > 0 THEN t.seed || '/' || t.avs END) FROM transitions t"
        f" {DONE} GROUP BY t.controller, t.transition ORDER BY t.controller, MIN(t.rowid)"
    ),
    "shadow": (
        f"SELECT m.controller, m.avs, COUNT(*), {', '.join(f'SUM(m.{k})' for k in SHADOW)} FROM av_metrics m {DONE}"
        " AND m.wishes IS NOT NULL GROUP BY m.controller, m.avs ORDER BY m.controller, m.avs"
    ),
    "safety": (
        f"SELECT m.controller, m.avs, SUM(m.lc_{MARKS_KM[-1]}km), SUM(m.lc_rss_unsafe), MIN(m.lc_min_gap_lead_m),"
        " MIN(m.lc_min_gap_follow_m), SUM(m.ssm_conflicts), MIN(m.ssm_min_ttc_s), MAX(m.ssm_max_drac),"
        f" MIN(m.ssm_min_pet_s), AVG(r.density_veh_km_lane) FROM av_metrics m {DONE}"
        " AND m.lc_rss_unsafe IS NOT NULL GROUP BY m.controller, m.avs ORDER BY m.controller, m.avs"
    ),
    "wishes": (
        f"SELECT e.controller, e.side, e.urgent, e.reason, COUNT(*) FROM episodes e {DONE}"
        " GROUP BY e.controller, e.side, e.urgent, e.reason ORDER BY e.controller, e.side, e.urgent, e.reason"
    ),
}


@dataclass(frozen=True)
class LoopRows:
    """What the report shows of the closed loop beyond the paper's metrics, one list of plain rows per query of
    LOOP_QUERIES (empty for a database of schema 2): per controller each transition, the times it fired and the
    runs it fired in; per (controller, AVs) the AV runs and the shadow mode's sums (SHADOW); per (controller, AVs)
    the lane changes, those into a gap shorter than RSS's, the smallest gaps at a change, SSM's conflicts and
    extremes, the mean density; per controller the wish episodes by side, urgency and reason."""

    transitions: list[tuple[Any, ...]] = field(default_factory=list)
    shadow: list[tuple[Any, ...]] = field(default_factory=list)
    safety: list[tuple[Any, ...]] = field(default_factory=list)
    wishes: list[tuple[Any, ...]] = field(default_factory=list)


def _transition_counts(conn: sqlite3.Connection, controllers: Sequence[str]) -> dict[str, int]:
    if "transitions" not in tables(conn):
        return {}
    marks = ", ".join("?" for _ in controllers)
    query = (
        f"SELECT t.transition, SUM(t.fired) FROM transitions t {DONE} AND t.controller IN ({marks})"
        " GROUP BY t.transition ORDER BY t.transition"
    )
    return {tid: int(n) for tid, n in conn.execute(query, tuple(controllers))}


def _loop_rows(conn: sqlite3.Connection) -> LoopRows:
    if not {"transitions", "episodes"} <= tables(conn):
        return LoopRows()
    have = {r[1] for r in conn.execute("PRAGMA table_info(av_metrics)")}
    if not set(SHADOW) | set(SAFETY) <= have:
        return LoopRows()
    return LoopRows(**{name: conn.execute(query).fetchall() for name, query in LOOP_QUERIES.items()})


@dataclass(frozen=True)
class MonitorSummary:
    """The runs of some controllers: how many are stored, how many failed, and their monitor violations."""

    runs: int
    failed_runs: int
    monitor_violations: int


@dataclass(frozen=True)
class TableRows:
    """A table's column names and its rows (values as SQLite holds them), ordered by the first four columns."""

    columns: tuple[str, ...]
    rows: list[tuple[Any, ...]]


def _report_rows(conn: sqlite3.Connection, path: Path) -> ReportRows:
    check_columns(conn, path, tables(conn) & {"runs", "av_metrics"}, COLUMNS_2, prefix=True)
    statuses = [RunStatus(*row) for row in conn.execute(REPORT_STATUSES)]
    finished = [_run_totals(row) for row in conn.execute(REPORT_FINISHED)]
    mechanism = [_mechanism_totals(row) for row in conn.execute(REPORT_MECHANISM)]
    return ReportRows(statuses, finished, mechanism, _loop_rows(conn))


def _run_totals(row: tuple[Any, ...]) -> RunTotals:
    controller, avs, seed, *lc, collisions, mingap, travel, speed, bg = row
    return RunTotals(controller, avs, seed, tuple(lc), collisions, mingap, travel, speed, bg)


def _mechanism_totals(row: tuple[Any, ...]) -> MechanismTotals:
    controller, avs, count, needs, moved, still, deferred, need_s, deferred_s, *state_s = row
    return MechanismTotals(controller, avs, count, needs, moved, still, deferred, need_s, deferred_s, tuple(state_s))


def _v2v_runs(conn: sqlite3.Connection, path: Path) -> list[tuple[Any, ...]]:
    have = {row[1] for row in conn.execute("PRAGMA table_info(runs)")}
    if "runs" not in tables(conn) or not {f"v2v_{name}" for name in V2V_COUNTS} <= have:
        raise UsageError.at(path, "no V2V counts in this results database (they came with schema 4); sweep again")
    return conn.execute(V2V_RUNS).fetchall()


def _v2v_totals(conn: sqlite3.Connection, controllers: Sequence[str]) -> dict[str, int]:
    have = {row[1] for row in conn.execute("PRAGMA table_info(runs)")}
    if not {f"v2v_{name}" for name in V2V_COUNTS} <= have:
        return {}
    sums = ", ".join(f"COALESCE(SUM(v2v_{name}), 0)" for name in V2V_COUNTS)
    marks = ", ".join("?" for _ in controllers)
    query = f"SELECT {sums} FROM runs WHERE status = 'done' AND controller IN ({marks})"
    totals = dict(zip(V2V_COUNTS, conn.execute(query, tuple(controllers)).fetchone(), strict=True))
    return totals if totals["sent"] else {}


def _monitor_summary(conn: sqlite3.Connection, path: Path, controllers: Sequence[str]) -> MonitorSummary:
    have = {row[1] for row in conn.execute("PRAGMA table_info(runs)")}
    missing = [column for column in SUMMARY_COLUMNS if column not in have]
    if missing:
        raise UsageError.at(path, f"not a results database of mlca-sim (table runs has no column {', '.join(missing)})")
    query = (
        "SELECT COUNT(*), COALESCE(SUM(monitor_violations), 0), COALESCE(SUM(status != 'done'), 0) FROM runs "
        f"WHERE controller IN ({', '.join('?' for _ in controllers)})"
    )
    runs, violations, failed = conn.execute(query, tuple(controllers)).fetchone()
    return MonitorSummary(runs, failed, violations)


def _table_rows(conn: sqlite3.Connection, table: str) -> TableRows:
    width = len(conn.execute(f"PRAGMA table_info({table_name(table)})").fetchall())
    cursor = conn.execute(f"SELECT * FROM {table_name(table)} ORDER BY {', '.join(map(str, range(1, width + 1)))}")
    return TableRows(tuple(d[0] for d in cursor.description), cursor.fetchall())


# --- the API -----------------------------------------------------------------------------------------------


class ResultsDB:
    """An open results database, the one way in: use it in a `with` block, which closes it.

        with ResultsDB.open_for_writing(path) as results:
            if results.store(run): ...

    Every read is one transaction (a consistent snapshot), every write an immediate transaction, retried while
    another process holds the lock; failures are one-line UsageErrors naming the file."""

    def __init__(self, conn: Database, path: Path) -> None:
        self._conn = conn
        self.path = path
        self._closed = False

    @classmethod
    def open_for_writing(cls, path: Path) -> ResultsDB:
        """Open (or create) a results database for writing. A file that is not one, one of another version, or
        one that cannot be written is refused (UsageError) before anything is written into it."""
        return cls(_connect(path), path)

    @classmethod
    def open_for_reading(cls, path: Path) -> ResultsDB:
        """Open a results database of any version read-only; a file that is not one is refused (UsageError).
        Each read checks the columns it reads."""
        conn = open_file(path, "ro")
        try:
            check_readable(conn, path, reading(conn, tables))
        except BaseException:
            conn.close()
            raise
        return cls(conn, path)

    def __enter__(self) -> ResultsDB:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection; closing it twice is harmless."""
        self._conn.close()
        self._closed = True

    @property
    def closed(self) -> bool:
        """Whether the connection is closed."""
        return self._closed

    def stored_keys(self) -> set[Job]:
        """The (controller, AVs, seed) of every run stored, finished or failed."""
        return _stored_keys(self._conn)

    def store(self, run: RunResult) -> bool:
        """Write one run and its AVs in a single transaction, and drop its lease; False (and nothing written)
        when the database holds the run already, stored by another writer."""
        return _store(self._conn, run)

    def lease(self, wanted: list[Job], *, resume: bool, retry_failed: bool) -> Plan:
        """Lease the wanted runs nobody has stored or holds, for this process, in one transaction. Without
        `resume`, wanted runs already stored or held are an error; with `retry_failed`, failed runs are removed
        and leased."""
        return lease(self._conn, wanted, resume, retry_failed)

    def release(self) -> None:
        """Drop the leases this process still holds (runs it did not finish); best effort, as a dead process's
        leases are reclaimed anyway."""
        release(self._conn)

    def report_rows(self) -> ReportRows:
        """The grouped rows `mlca-sim report` draws from; a table with other columns is refused (UsageError)."""
        return reading(self._conn, lambda c: _report_rows(c, self.path))

    def monitor_summary(self, controllers: Sequence[str]) -> MonitorSummary:
        """Runs, failed runs and monitor violations of the runs of `controllers`. Needs only the columns
        controller, status and monitor_violations of table runs; without them the file is refused."""
        return reading(self._conn, lambda c: _monitor_summary(c, self.path, controllers))

    def v2v_runs(self) -> list[tuple[Any, ...]]:
        """Per finished run (controller, avs, seed, lane changes by 20 km, collisions, SSM conflicts, then the
        radio's counts in V2V_COUNTS' order); a database older than schema 4 is refused."""
        return reading(self._conn, lambda c: _v2v_runs(c, self.path))

    def v2v_totals(self, controllers: Sequence[str]) -> dict[str, int]:
        """What the radio carried in the finished runs of `controllers`, summed (V2V_COUNTS; empty for a database
        older than schema 4, or where none of them sent anything)."""
        return reading(self._conn, lambda c: _v2v_totals(c, controllers))

    def transition_counts(self, controllers: Sequence[str]) -> dict[str, int]:
        """How often each transition fired in the finished runs of `controllers` (empty for a database of schema
        2, which does not record it)."""
        return reading(self._conn, lambda c: _transition_counts(c, controllers))

    def column_types(self, table: str) -> dict[str, str]:
        """The declared SQLite type of each column of `table` (to read its exported rows back)."""
        rows = self._conn.execute(f"PRAGMA table_info({table_name(table)})").fetchall()
        return {name: kind for _, name, kind, *_ in rows}

    def add_rows(self, table: str, rows: TableRows) -> None:
        """Insert exported rows (as `table_rows` gives them) back, in one transaction: the comparison's committed
        CSV files become a database again."""
        unknown = set(rows.columns) - set(self.column_types(table))
        if unknown:
            raise UsageError.at(self.path, f"table {table} has no column {sorted(unknown)[0]!r}")
        marks = ", ".join("?" for _ in rows.columns)
        query = f"INSERT INTO {table_name(table)} ({', '.join(rows.columns)}) VALUES ({marks})"
        retrying(self._conn, lambda c: c.executemany(query, rows.rows), "write to the results database")

    def table_rows(self, table: str) -> TableRows:
        """Every row of `table` (runs, av_metrics, violations, transitions, episodes or leases), ordered by its
        columns from the first."""
        return reading(self._conn, lambda c: _table_rows(c, table))
