"""The results database (SQLite): one row per run and one per AV, each run committed when it ends.

A run's rows go in one transaction, so a sweep killed at any moment leaves only whole runs behind; `--resume`
skips the (controller, AVs, seed) triples already in `runs`, so nothing is lost and nothing is run twice.

More than one process may write to one database: every write is an immediate transaction, retried while another
writer holds the lock; a run already stored is not stored again (the second writer skips it); and a sweep leases
the runs it is going to do (table `leases`, with its host, pid and the pid's start time), so that a second sweep
leaves them alone while the first one lives. Leases of a process that has died are reclaimed.

The file is marked as a results database (`PRAGMA application_id`) with the version of its layout
(`PRAGMA user_version`); anything else is refused before a run starts, and nothing is written into it.

`ResultsDB` is the one way in, for sim_check and for the evidence of mlca_verify alike: opened once per command
(`ResultsDB.open_for_writing` or `ResultsDB.open_for_reading`) in a `with` block that closes it, it stores runs,
says which are stored, leases and releases them, and answers the grouped reads of the report and the monitor
summary of the evidence. Nothing else in sim_check or mlca_verify holds SQL."""

from __future__ import annotations

import contextlib
import json
import os
import socket
import sqlite3
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar
from urllib.parse import quote

from mlca_verify.errors import UsageError
from sim_check.results import MARKS_KM, MECHANISM, SAFETY, SHADOW, STATES, Job, RunResult

T = TypeVar("T")

APPLICATION_ID = 0x4D4C4353  # "MLCS": this file is a results database of mlca-sim
SCHEMA_VERSION = 3  # 1: runs, av_metrics, violations (unmarked files); 2: the same and leases; 3: the shadow
# mode, the commands, the lane changes' safety, SSM and the density (columns after those of 2), the transitions
# fired and the wish episodes
BUSY_TIMEOUT_S = 30.0  # how long one attempt waits for another writer's lock
WRITE_ATTEMPTS = 10  # attempts of a write before the database is declared stuck
AV_COLUMNS_2 = (
    "av",
    *(f"lc_{km}km" for km in MARKS_KM),
    "collisions",
    "emergency_brakes",
    "min_time_gap_s",
    "travel_time_s",
    "mean_speed_ms",
    "arrived",
    "monitor_violations",
    "mingap_contacts",
    *MECHANISM,
    *(f"{state.lower()}_s" for state in STATES),
)
AV_COLUMNS = (*AV_COLUMNS_2, *SHADOW, *SAFETY)
RUN_COLUMNS_2 = (
    "status",
    "reason",
    "sim_steps",
    "wall_s",
    "vehicle_steps",
    "collisions",
    "monitor_violations",
    "trajectory_sha256",
    "bg_mean_speed_ms",
)
RUN_COLUMNS = (*RUN_COLUMNS_2, "density_veh_km_lane")
TRANSITION_COLUMNS = ("av", "transition", "fired")
EPISODE_COLUMNS = ("av", "start_s", "side", "reason", "urgent", "outcome", "delay_s", "state")
LEASE_COLUMNS = ("host", "pid", "started")
EXPORTED = ("runs", "av_metrics", "violations", "transitions", "episodes")  # the tables a comparison commits as CSV
SCHEMA = (
    """CREATE TABLE IF NOT EXISTS runs (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL,
    status TEXT NOT NULL, reason TEXT NOT NULL, sim_steps INTEGER, wall_s REAL, vehicle_steps INTEGER,
    collisions INTEGER, monitor_violations INTEGER, trajectory_sha256 TEXT, bg_mean_speed_ms REAL,
    density_veh_km_lane REAL, PRIMARY KEY (controller, avs, seed))""",
    f"""CREATE TABLE IF NOT EXISTS av_metrics (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    {", ".join(f"lc_{km}km INTEGER" for km in MARKS_KM)}, collisions INTEGER, emergency_brakes INTEGER,
    min_time_gap_s REAL, travel_time_s REAL, mean_speed_ms REAL, arrived INTEGER, monitor_violations INTEGER,
    mingap_contacts INTEGER, {", ".join(f"{k} REAL" for k in MECHANISM)},
    {", ".join(f"{state.lower()}_s REAL" for state in STATES)},
    {", ".join(f"{k} REAL" for k in (*SHADOW, *SAFETY))},
    PRIMARY KEY (controller, avs, seed, av))""",
    """CREATE TABLE IF NOT EXISTS transitions (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    transition TEXT NOT NULL, fired INTEGER NOT NULL, PRIMARY KEY (controller, avs, seed, av, transition))""",
    """CREATE TABLE IF NOT EXISTS episodes (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    start_s REAL NOT NULL, side INTEGER NOT NULL, reason TEXT NOT NULL, urgent INTEGER NOT NULL,
    outcome TEXT NOT NULL, delay_s REAL NOT NULL, state TEXT NOT NULL)""",
    """CREATE TABLE IF NOT EXISTS violations (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    time_s REAL, invariants TEXT, trace_json TEXT)""",
    """CREATE TABLE IF NOT EXISTS leases (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL,
    host TEXT NOT NULL, pid INTEGER NOT NULL, started TEXT NOT NULL,
    PRIMARY KEY (controller, avs, seed))""",
)
COLUMNS = {
    "runs": ("controller", "avs", "seed", *RUN_COLUMNS),
    "av_metrics": ("controller", "avs", "seed", *AV_COLUMNS),
    "leases": ("controller", "avs", "seed", *LEASE_COLUMNS),
    "transitions": ("controller", "avs", "seed", *TRANSITION_COLUMNS),
    "episodes": ("controller", "avs", "seed", *EPISODE_COLUMNS),
}
# what a database of schema 2 (or 1) has, which the report still reads
COLUMNS_2 = {
    "runs": ("controller", "avs", "seed", *RUN_COLUMNS_2),
    "av_metrics": ("controller", "avs", "seed", *AV_COLUMNS_2),
}
BUSY_CODES = (sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED)


@dataclass(frozen=True)
class Owner:
    """A process holding leases or a temporary folder: its host, pid and the pid's start time (which tells a
    reused pid apart; "" where the system does not say)."""

    host: str
    pid: int
    started: str

    @classmethod
    def me(cls) -> Owner:
        return cls(socket.gethostname(), os.getpid(), _started(os.getpid()))

    def alive(self) -> bool:
        """Whether the process still runs; one on another host cannot be checked and counts as alive."""
        if self.host != socket.gethostname():
            return True
        if self.started and _started(self.pid) != self.started:
            return False
        try:
            os.kill(self.pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True


def _started(pid: int) -> str:
    """The start time of process `pid` (Linux: field 22 of /proc/PID/stat); "" for none or a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
    except OSError:
        return ""
    after = stat[stat.rfind(")") + 2 :].split()  # the command name may hold spaces and parentheses
    return "" if len(after) < 20 or after[0] in "ZX" else after[19]


def _uri(path: Path, mode: str) -> str:
    """An SQLite URI for the file `path`, taken literally ('#', '?' and '%' in names included)."""
    return f"file:{quote(str(path.absolute()))}?mode={mode}"


class Database(sqlite3.Connection):
    """A connection that keeps the path it was opened by, for its messages."""

    path = ""


def _file(conn: sqlite3.Connection) -> str:
    return getattr(conn, "path", "") or str(conn.execute("PRAGMA database_list").fetchone()[2])


def _open(path: Path, mode: str) -> Database:
    if path.is_dir():
        raise UsageError.at(path, "is a folder, not a results database")
    try:
        conn = sqlite3.connect(_uri(path, mode), uri=True, timeout=BUSY_TIMEOUT_S, factory=Database)
    except sqlite3.Error as err:
        raise UsageError.at(path, f"cannot open the results database: {err}") from None
    conn.path = str(path)
    return conn


def _busy(err: sqlite3.Error) -> bool:
    return getattr(err, "sqlite_errorcode", 0) & 0xFF in BUSY_CODES


def _transaction(conn: sqlite3.Connection, body: Callable[[sqlite3.Connection], T], begin: str) -> T:
    conn.execute(begin)
    try:
        result = body(conn)
        conn.execute("COMMIT")
    except BaseException:
        if conn.in_transaction:
            conn.execute("ROLLBACK")
        raise
    return result


def _retrying(
    conn: sqlite3.Connection, body: Callable[[sqlite3.Connection], T], what: str, begin: str = "BEGIN IMMEDIATE"
) -> T:
    """`body` in one transaction, again while another process holds the lock; any other failure, or a lock
    held through every attempt, is one clear error."""
    start = time.monotonic()
    for attempt in range(WRITE_ATTEMPTS):
        try:
            return _transaction(conn, body, begin)
        except sqlite3.Error as err:
            if not _busy(err):
                raise UsageError.at(_file(conn), f"cannot {what}: {err}") from None
            time.sleep(min(1.0, 0.01 * 2**attempt))  # the busy timeout has waited already
    waited = time.monotonic() - start
    raise UsageError.at(_file(conn), f"cannot {what}: another process kept the database locked for {waited:.0f} s")


def _connect(path: Path) -> Database:
    conn = _open(path, "rw" if path.exists() else "rwc")
    try:
        _retrying(conn, lambda c: _prepare(c, path), "write to the results database")
    except BaseException:
        conn.close()
        raise
    return conn


def _prepare(conn: sqlite3.Connection, path: Path) -> None:
    app, version = _marks(conn)
    tables = _tables(conn)
    if not tables and app == version == 0:
        for statement in SCHEMA:
            conn.execute(statement)
        conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
        conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
    else:
        _check(conn, path, app, version, tables)
    _probe(conn)


def _marks(conn: sqlite3.Connection) -> tuple[int, int]:
    app: int = conn.execute("PRAGMA application_id").fetchone()[0]
    version: int = conn.execute("PRAGMA user_version").fetchone()[0]
    return app, version


def _tables(conn: sqlite3.Connection) -> set[str]:
    return {name for (name,) in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}


def _check(conn: sqlite3.Connection, path: Path, app: int, version: int, tables: set[str]) -> None:
    """Refuse a database this version does not write: foreign, older, newer, or with other columns."""
    if app not in (0, APPLICATION_ID) or (app == 0 and "runs" not in tables):
        names = ", ".join(sorted(tables)) or "none"
        raise UsageError.at(path, f"not a results database of mlca-sim (its tables: {names}); give a new file to --db")
    _columns(conn, path, tables & {"runs", "av_metrics"}, COLUMNS_2, prefix=True)
    version = version if app else 1
    schemas = f"results schema {version}, this one writes {SCHEMA_VERSION}"
    if version < SCHEMA_VERSION:
        raise UsageError.at(
            path,
            f"written by an older mlca-sim ({schemas}); use a new database file (mlca-sim report still reads this one)",
        )
    if version > SCHEMA_VERSION:
        raise UsageError.at(path, f"written by a newer mlca-sim ({schemas}); use that version or a new database file")
    _columns(conn, path, set(COLUMNS))


def _columns(
    conn: sqlite3.Connection,
    path: Path,
    tables: Iterable[str],
    wanted: dict[str, tuple[str, ...]] = COLUMNS,
    *,
    prefix: bool = False,
) -> None:
    """Refuse a table whose columns are not `wanted`'s, or with `prefix` (what every version has, COLUMNS_2) do
    not begin with them."""
    for table in sorted(tables):
        have = [r[1] for r in conn.execute(f"PRAGMA table_info({table})")]
        expected = list(wanted[table])
        if have[: len(expected) if prefix else None] != expected:
            missing = sorted(set(expected) - set(have))
            raise UsageError.at(
                path,
                f"table {table} has other columns than this version writes "
                f"(missing: {', '.join(missing) or 'none'}); use a new database file",
            )


def _probe(conn: sqlite3.Connection) -> None:
    """Write and take back a row: a read-only file or folder fails here, before a run is lost to it."""
    conn.execute("INSERT OR REPLACE INTO leases VALUES ('', 0, -1, '', 0, '')")
    conn.execute("DELETE FROM leases WHERE controller = '' AND seed = -1")


def _stored_keys(conn: sqlite3.Connection) -> set[Job]:
    rows = _retrying(conn, lambda c: c.execute("SELECT controller, avs, seed FROM runs").fetchall(), "read", "BEGIN")
    return {(c, a, s) for c, a, s in rows}


def _store(conn: sqlite3.Connection, r: RunResult) -> bool:
    return _retrying(conn, lambda c: _insert(c, r), f"store run {r.controller}, {r.avs} AVs, seed {r.seed}")


def _insert(conn: sqlite3.Connection, r: RunResult) -> bool:
    key = (r.controller, r.avs, r.seed)
    conn.execute("DELETE FROM leases WHERE controller = ? AND avs = ? AND seed = ?", key)
    added = conn.execute(
        f"INSERT OR IGNORE INTO runs VALUES (?, ?, ?, {', '.join('?' for _ in RUN_COLUMNS)})",
        (
            *key,
            r.status,
            r.reason,
            r.sim_steps,
            round(r.wall_s, 3),
            r.vehicle_steps,
            r.collisions,
            r.monitor_violations,
            r.trajectory_sha256,
            r.bg_mean_speed_ms,
            r.density_veh_km_lane,
        ),
    ).rowcount
    if not added:
        return False
    for m in r.metrics:
        row = m.row()
        conn.execute(
            f"INSERT INTO av_metrics VALUES (?, ?, ?, {', '.join('?' for _ in AV_COLUMNS)})",
            (*key, *(row[c] for c in AV_COLUMNS)),
        )
    for v in r.violations:
        conn.execute(
            "INSERT INTO violations VALUES (?, ?, ?, ?, ?, ?, ?)",
            (*key, v.av, v.time_s, ",".join(v.invariants), json.dumps(v.trace)),
        )
    conn.executemany(
        "INSERT INTO transitions VALUES (?, ?, ?, ?, ?, ?)",
        [(*key, m.av, tid, n) for m in r.metrics for tid, n in sorted(m.transitions.items())],
    )
    conn.executemany(
        f"INSERT INTO episodes VALUES (?, ?, ?, {', '.join('?' for _ in EPISODE_COLUMNS)})",
        [
            (*key, m.av, e.start_s, e.side, e.reason, int(e.urgent), e.outcome, e.delay_s, e.state)
            for m in r.metrics
            for e in m.episodes
        ],
    )
    return True


@dataclass
class Plan:
    """What a sweep is to do: the runs it leased, and those it leaves (stored, or leased by a live sweep)."""

    todo: list[Job] = field(default_factory=list)
    stored: int = 0  # wanted runs the database holds and keeps
    retried: int = 0  # failed runs taken out to be run again
    held: dict[int, int] = field(default_factory=dict)  # pid of a live sweep -> wanted runs it holds


def _lease(conn: sqlite3.Connection, wanted: list[Job], resume: bool, retry_failed: bool) -> Plan:
    me = Owner.me()
    return _retrying(conn, lambda c: _plan(c, wanted, me, resume, retry_failed), "lease the runs")


def _plan(conn: sqlite3.Connection, wanted: list[Job], me: Owner, resume: bool, retry_failed: bool) -> Plan:
    holders = _live_leases(conn, me)
    status = {(c, a, s): st for c, a, s, st in conn.execute("SELECT controller, avs, seed, status FROM runs")}
    plan = Plan(stored=sum(job in status for job in wanted))
    for job in wanted:
        if job in holders:
            plan.held[holders[job].pid] = plan.held.get(holders[job].pid, 0) + 1
    if not resume:
        _refuse_overlap(conn, plan)
    retry = [job for job in wanted if retry_failed and status.get(job) == "failed" and job not in holders]
    for job in retry:
        _delete_run(conn, job)
    plan.stored, plan.retried = plan.stored - len(retry), len(retry)
    plan.todo = [job for job in wanted if (job not in status or job in retry) and job not in holders]
    conn.executemany(
        "INSERT OR REPLACE INTO leases VALUES (?, ?, ?, ?, ?, ?)",
        [(*job, me.host, me.pid, me.started) for job in plan.todo],
    )
    return plan


def _live_leases(conn: sqlite3.Connection, me: Owner) -> dict[Job, Owner]:
    """Leases of other live processes; those of dead ones are deleted."""
    leases = {(c, a, s): Owner(h, p, st) for c, a, s, h, p, st in conn.execute("SELECT * FROM leases")}
    dead = {owner for owner in set(leases.values()) if owner == me or not owner.alive()}
    conn.executemany(
        "DELETE FROM leases WHERE host = ? AND pid = ? AND started = ?", [(o.host, o.pid, o.started) for o in dead]
    )
    return {job: owner for job, owner in leases.items() if owner not in dead}


def _refuse_overlap(conn: sqlite3.Connection, plan: Plan) -> None:
    parts = [f"already holds {plan.stored} of these runs"] if plan.stored else []
    if plan.held:
        pids = ", ".join(map(str, sorted(plan.held)))
        parts.append(f"{sum(plan.held.values())} of these runs are being run by another sweep (pid {pids})")
    if parts:
        raise UsageError.at(_file(conn), f"{'; '.join(parts)}; add --resume to continue")


def _delete_run(conn: sqlite3.Connection, job: Job) -> None:
    for table in ("runs", "av_metrics", "violations", "transitions", "episodes"):
        conn.execute(f"DELETE FROM {table} WHERE controller = ? AND avs = ? AND seed = ?", job)


def _release(conn: sqlite3.Connection) -> None:
    me = Owner.me()
    sql = "DELETE FROM leases WHERE host = ? AND pid = ? AND started = ?"
    with contextlib.suppress(UsageError):
        _retrying(conn, lambda c: c.execute(sql, (me.host, me.pid, me.started)), "release the leases")


def _check_readable(conn: sqlite3.Connection, path: Path) -> None:
    """Refuse a file that is not a results database of any version (for reading)."""
    tables = _retrying(conn, _tables, "read the results database", "BEGIN")
    app, _ = _marks(conn)
    if app not in (0, APPLICATION_ID) or "runs" not in tables:
        raise UsageError.at(path, "not a results database of mlca-sim")


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


@dataclass(frozen=True)
class RunStatus:
    """One stored run, finished or failed, as the report counts it."""

    controller: str
    avs: int
    status: str
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
    if "transitions" not in _tables(conn):
        return {}
    marks = ", ".join("?" for _ in controllers)
    query = (
        f"SELECT t.transition, SUM(t.fired) FROM transitions t {DONE} AND t.controller IN ({marks})"
        " GROUP BY t.transition ORDER BY t.transition"
    )
    return {tid: int(n) for tid, n in conn.execute(query, tuple(controllers))}


def _loop_rows(conn: sqlite3.Connection) -> LoopRows:
    if not {"transitions", "episodes"} <= _tables(conn):
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
    _columns(conn, path, _tables(conn) & {"runs", "av_metrics"}, COLUMNS_2, prefix=True)
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


def _table_name(table: str) -> str:
    if table not in COLUMNS and table != "violations":
        raise ValueError(f"no table {table!r} in a results database")
    return table


def _table_rows(conn: sqlite3.Connection, table: str) -> TableRows:
    width = len(conn.execute(f"PRAGMA table_info({_table_name(table)})").fetchall())
    cursor = conn.execute(f"SELECT * FROM {_table_name(table)} ORDER BY {', '.join(map(str, range(1, width + 1)))}")
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
        conn = _open(path, "ro")
        try:
            _check_readable(conn, path)
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
        return _lease(self._conn, wanted, resume, retry_failed)

    def release(self) -> None:
        """Drop the leases this process still holds (runs it did not finish); best effort, as a dead process's
        leases are reclaimed anyway."""
        _release(self._conn)

    def report_rows(self) -> ReportRows:
        """The grouped rows `mlca-sim report` draws from; a table with other columns is refused (UsageError)."""
        return _retrying(self._conn, lambda c: _report_rows(c, self.path), "read the results database", "BEGIN")

    def monitor_summary(self, controllers: Sequence[str]) -> MonitorSummary:
        """Runs, failed runs and monitor violations of the runs of `controllers`. Needs only the columns
        controller, status and monitor_violations of table runs; without them the file is refused."""
        return _retrying(
            self._conn, lambda c: _monitor_summary(c, self.path, controllers), "read the results database", "BEGIN"
        )

    def transition_counts(self, controllers: Sequence[str]) -> dict[str, int]:
        """How often each transition fired in the finished runs of `controllers` (empty for a database of schema
        2, which does not record it)."""
        return _retrying(self._conn, lambda c: _transition_counts(c, controllers), "read the results database", "BEGIN")

    def column_types(self, table: str) -> dict[str, str]:
        """The declared SQLite type of each column of `table` (to read its exported rows back)."""
        rows = self._conn.execute(f"PRAGMA table_info({_table_name(table)})").fetchall()
        return {name: kind for _, name, kind, *_ in rows}

    def add_rows(self, table: str, rows: TableRows) -> None:
        """Insert exported rows (as `table_rows` gives them) back, in one transaction: the comparison's committed
        CSV files become a database again."""
        unknown = set(rows.columns) - set(self.column_types(table))
        if unknown:
            raise UsageError.at(self.path, f"table {table} has no column {sorted(unknown)[0]!r}")
        marks = ", ".join("?" for _ in rows.columns)
        query = f"INSERT INTO {_table_name(table)} ({', '.join(rows.columns)}) VALUES ({marks})"
        _retrying(self._conn, lambda c: c.executemany(query, rows.rows), "write to the results database")

    def table_rows(self, table: str) -> TableRows:
        """Every row of `table` (runs, av_metrics, violations, transitions, episodes or leases), ordered by its
        columns from the first."""
        return _retrying(self._conn, lambda c: _table_rows(c, table), "read the results database", "BEGIN")
