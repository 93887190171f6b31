"""The results database (SQLite): one row per run and one per AV, each run committed when it ends.

A run's rows go in one transaction, so a sweep killed at any moment leaves only whole runs behind; `--resume`
skips the (controller, AVs, seed) triples already in `runs`, so nothing is lost and nothing is run twice.

More than one process may write to one database: every write is an immediate transaction, retried while another
writer holds the lock; a run already stored is not stored again (the second writer skips it); and a sweep leases
the runs it is going to do (table `leases`, with its host, pid and the pid's start time), so that a second sweep
leaves them alone while the first one lives. Leases of a process that has died are reclaimed.

The file is marked as a results database (`PRAGMA application_id`) with the version of its layout
(`PRAGMA user_version`); anything else is refused before a run starts, and nothing is written into it."""

from __future__ import annotations

import contextlib
import json
import os
import socket
import sqlite3
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar
from urllib.parse import quote

from mlca_verify.errors import UsageError
from sim_check.runner import MARKS_KM, MECHANISM, STATES, RunResult

T = TypeVar("T")
Job = tuple[str, int, int]  # controller, AVs, seed

APPLICATION_ID = 0x4D4C4353  # "MLCS": this file is a results database of mlca-sim
SCHEMA_VERSION = 2  # 1: runs, av_metrics, violations (unmarked files); 2: the same and leases
BUSY_TIMEOUT_S = 30.0  # how long one attempt waits for another writer's lock
WRITE_ATTEMPTS = 10  # attempts of a write before the database is declared stuck
AV_COLUMNS = ("av", *(f"lc_{km}km" for km in MARKS_KM), "collisions", "emergency_brakes", "min_time_gap_s",
              "travel_time_s", "mean_speed_ms", "arrived", "monitor_violations", "mingap_contacts", *MECHANISM,
              *(f"{state.lower()}_s" for state in STATES))  # fmt: skip
RUN_COLUMNS = ("status", "reason", "sim_steps", "wall_s", "vehicle_steps", "collisions", "monitor_violations",
               "trajectory_sha256", "bg_mean_speed_ms")  # fmt: skip
LEASE_COLUMNS = ("host", "pid", "started")
SCHEMA = (
    """CREATE TABLE IF NOT EXISTS runs (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL,
    status TEXT NOT NULL, reason TEXT NOT NULL, sim_steps INTEGER, wall_s REAL, vehicle_steps INTEGER,
    collisions INTEGER, monitor_violations INTEGER, trajectory_sha256 TEXT, bg_mean_speed_ms REAL,
    PRIMARY KEY (controller, avs, seed))""",
    f"""CREATE TABLE IF NOT EXISTS av_metrics (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    {", ".join(f"lc_{km}km INTEGER" for km in MARKS_KM)}, collisions INTEGER, emergency_brakes INTEGER,
    min_time_gap_s REAL, travel_time_s REAL, mean_speed_ms REAL, arrived INTEGER, monitor_violations INTEGER,
    mingap_contacts INTEGER, {", ".join(f"{k} REAL" for k in MECHANISM)},
    {", ".join(f"{state.lower()}_s REAL" for state in STATES)},
    PRIMARY KEY (controller, avs, seed, av))""",
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


def uri(path: Path, mode: str) -> str:
    """An SQLite URI for the file `path`, taken literally ('#', '?' and '%' in names included)."""
    return f"file:{quote(str(path.absolute()))}?mode={mode}"


class Database(sqlite3.Connection):
    """A connection that keeps the path it was opened by, for its messages."""

    path = ""


def _file(conn: sqlite3.Connection) -> str:
    return getattr(conn, "path", "") or str(conn.execute("PRAGMA database_list").fetchone()[2])


def _open(path: Path, mode: str) -> Database:
    if path.is_dir():
        raise UsageError(f"{path}: error: is a folder, not a results database")
    try:
        conn = sqlite3.connect(uri(path, mode), uri=True, timeout=BUSY_TIMEOUT_S, factory=Database)
    except sqlite3.Error as err:
        raise UsageError(f"{path}: error: cannot open the results database: {err}") from None
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
                raise UsageError(f"{_file(conn)}: error: cannot {what}: {err}") from None
            time.sleep(min(1.0, 0.01 * 2**attempt))  # the busy timeout has waited already
    waited = time.monotonic() - start
    raise UsageError(f"{_file(conn)}: error: cannot {what}: another process kept the database locked for "
                     f"{waited:.0f} s")  # fmt: skip


def connect(path: Path) -> sqlite3.Connection:
    """Open (or create) a results database for writing. A file that is not one, one of another version, or one
    that cannot be written is refused (UsageError) before anything is written into it."""
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
        raise UsageError(f"{path}: error: not a results database of mlca-sim (its tables: {names}); "
                         "give a new file to --db")  # fmt: skip
    _columns(conn, path, tables & {"runs", "av_metrics"})
    version = version if app else 1
    schemas = f"results schema {version}, this one writes {SCHEMA_VERSION}"
    if version < SCHEMA_VERSION:
        raise UsageError(f"{path}: error: written by an older mlca-sim ({schemas}); use a new database file "
                         "(mlca-sim report still reads this one)")  # fmt: skip
    if version > SCHEMA_VERSION:
        raise UsageError(f"{path}: error: written by a newer mlca-sim ({schemas}); use that version or a new "
                         "database file")  # fmt: skip
    _columns(conn, path, set(COLUMNS))


def _columns(conn: sqlite3.Connection, path: Path, tables: Iterable[str]) -> None:
    for table in sorted(tables):
        have = [r[1] for r in conn.execute(f"PRAGMA table_info({table})")]
        if have != list(COLUMNS[table]):
            missing = sorted(set(COLUMNS[table]) - set(have))
            raise UsageError(f"{path}: error: table {table} has other columns than this version writes "
                             f"(missing: {', '.join(missing) or 'none'}); use a new database file")  # fmt: skip


def _probe(conn: sqlite3.Connection) -> None:
    """Write and take back a row: a read-only file or folder fails here, before a run is lost to it."""
    conn.execute("INSERT OR REPLACE INTO leases VALUES ('', 0, -1, '', 0, '')")
    conn.execute("DELETE FROM leases WHERE controller = '' AND seed = -1")


def done(conn: sqlite3.Connection) -> set[Job]:
    """The runs stored, finished or failed."""
    rows = _retrying(conn, lambda c: c.execute("SELECT controller, avs, seed FROM runs").fetchall(), "read", "BEGIN")
    return {(c, a, s) for c, a, s in rows}


def store(conn: sqlite3.Connection, r: RunResult) -> bool:
    """Write one run and its AVs in a single transaction, and drop its lease; False (and nothing written) when
    the database holds the run already, stored by another writer."""
    return _retrying(conn, lambda c: _insert(c, r), f"store run {r.controller}, {r.avs} AVs, seed {r.seed}")


def _insert(conn: sqlite3.Connection, r: RunResult) -> bool:
    key = (r.controller, r.avs, r.seed)
    conn.execute("DELETE FROM leases WHERE controller = ? AND avs = ? AND seed = ?", key)
    added = conn.execute(
        f"INSERT OR IGNORE INTO runs VALUES (?, ?, ?, {', '.join('?' for _ in RUN_COLUMNS)})",
        (*key, r.status, r.reason, r.sim_steps, round(r.wall_s, 3), r.vehicle_steps, r.collisions,
         r.monitor_violations, r.trajectory_sha256, r.bg_mean_speed_ms),
    ).rowcount  # fmt: skip
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
            (*key, v["av"], v["time_s"], ",".join(v["invariants"]), json.dumps(v["trace"])),
        )
    return True


@dataclass
class Plan:
    """What a sweep is to do: the runs it leased, and those it leaves (stored, or leased by a live sweep)."""

    todo: list[Job] = field(default_factory=list)
    stored: int = 0  # wanted runs the database holds and keeps
    retried: int = 0  # failed runs taken out to be run again
    held: dict[int, int] = field(default_factory=dict)  # pid of a live sweep -> wanted runs it holds


def lease(conn: sqlite3.Connection, wanted: list[Job], *, resume: bool, retry_failed: bool) -> Plan:
    """Lease the wanted runs nobody has stored or holds, for this process, in one transaction. Without `resume`,
    wanted runs already stored or held are an error; with `retry_failed`, failed runs are removed and leased."""
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
    conn.executemany("INSERT OR REPLACE INTO leases VALUES (?, ?, ?, ?, ?, ?)",
                     [(*job, me.host, me.pid, me.started) for job in plan.todo])  # fmt: skip
    return plan


def _live_leases(conn: sqlite3.Connection, me: Owner) -> dict[Job, Owner]:
    """Leases of other live processes; those of dead ones are deleted."""
    leases = {(c, a, s): Owner(h, p, st) for c, a, s, h, p, st in conn.execute("SELECT * FROM leases")}
    dead = {owner for owner in set(leases.values()) if owner == me or not owner.alive()}
    conn.executemany("DELETE FROM leases WHERE host = ? AND pid = ? AND started = ?",
                     [(o.host, o.pid, o.started) for o in dead])  # fmt: skip
    return {job: owner for job, owner in leases.items() if owner not in dead}


def _refuse_overlap(conn: sqlite3.Connection, plan: Plan) -> None:
    parts = [f"already holds {plan.stored} of these runs"] if plan.stored else []
    if plan.held:
        pids = ", ".join(map(str, sorted(plan.held)))
        parts.append(f"{sum(plan.held.values())} of these runs are being run by another sweep (pid {pids})")
    if parts:
        raise UsageError(f"{_file(conn)}: error: {'; '.join(parts)}; add --resume to continue")


def _delete_run(conn: sqlite3.Connection, job: Job) -> None:
    for table in ("runs", "av_metrics", "violations"):
        conn.execute(f"DELETE FROM {table} WHERE controller = ? AND avs = ? AND seed = ?", job)


def release(conn: sqlite3.Connection) -> None:
    """Drop the leases this process still holds (runs it did not finish); best effort, as a dead process's
    leases are reclaimed anyway."""
    me = Owner.me()
    sql = "DELETE FROM leases WHERE host = ? AND pid = ? AND started = ?"
    with contextlib.suppress(UsageError):
        _retrying(conn, lambda c: c.execute(sql, (me.host, me.pid, me.started)), "release the leases")


def readable(path: Path) -> Path:
    """Check that `path` is a results database of any version (for reading); return it."""
    conn = _open(path, "ro")
    try:
        tables = _retrying(conn, _tables, "read the results database", "BEGIN")
        app, _ = _marks(conn)
        if app not in (0, APPLICATION_ID) or "runs" not in tables:
            raise UsageError(f"{path}: error: not a results database of mlca-sim")
        _columns(conn, path, tables & {"runs", "av_metrics"})
    finally:
        conn.close()
    return path
