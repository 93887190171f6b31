"""Leases: a sweep marks the runs it is going to do (table `leases`: the run, and the host, pid and start time
of the process), so that a second sweep on the same database leaves them alone while the first one lives. The
leases of a process that has died are reclaimed."""

from __future__ import annotations

import contextlib
import os
import socket
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path

from mlca_verify.errors import UsageError
from sim_check.run_results import Job
from sim_check.schema import LEASES, RUN_TABLES
from sim_check.transactions import file_of, retrying


@dataclass(frozen=True)
class Owner:
    """A process holding leases or a temporary folder: its host, pid and the pid's start time (which tells a
    reused pid apart; "" where the system does not say)."""

    host: str
    pid: int
    started: str

    @classmethod
    def me(cls) -> Owner:
        return cls(socket.gethostname(), os.getpid(), started_time(os.getpid()))

    def alive(self) -> bool:
        """Whether the process still runs; one on another host cannot be checked and counts as alive."""
        if self.host != socket.gethostname():
            return True
        if self.started and started_time(self.pid) != self.started:
            return False
        try:
            os.kill(self.pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True


def started_time(pid: int) -> str:
    """The start time of process `pid` (Linux: field 22 of /proc/PID/stat); "" for none or a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
    except OSError:
        return ""
    after = stat[stat.rfind(")") + 2 :].split()  # the command name may hold spaces and parentheses
    return "" if len(after) < 20 or after[0] in "ZX" else after[19]


@dataclass
class Plan:
    """What a sweep is to do: the runs it leased, and those it leaves (stored, or leased by a live sweep)."""

    todo: list[Job] = field(default_factory=list)
    stored: int = 0  # wanted runs the database holds and keeps
    retried: int = 0  # failed runs taken out to be run again
    held: dict[int, int] = field(default_factory=dict)  # pid of a live sweep -> wanted runs it holds


def lease(conn: sqlite3.Connection, wanted: list[Job], resume: bool, retry_failed: bool) -> Plan:
    """Lease, in one transaction, the wanted runs nobody has stored or holds (see `ResultsDB.lease`)."""
    me = Owner.me()
    return retrying(conn, lambda c: _plan(c, wanted, me, resume, retry_failed), "lease the runs")


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
    conn.executemany(LEASES.insert("INSERT OR REPLACE"), [(*job, me.host, me.pid, me.started) for job in plan.todo])
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
        raise UsageError.at(file_of(conn), f"{'; '.join(parts)}; add --resume to continue")


def _delete_run(conn: sqlite3.Connection, job: Job) -> None:
    for table in RUN_TABLES:
        conn.execute(f"DELETE FROM {table} WHERE controller = ? AND avs = ? AND seed = ?", job)


def drop_lease(conn: sqlite3.Connection, job: Job) -> None:
    """Within a transaction: the run `job` is stored, so its lease goes."""
    conn.execute("DELETE FROM leases WHERE controller = ? AND avs = ? AND seed = ?", job)


def release(conn: sqlite3.Connection) -> None:
    """Drop the leases this process still holds; best effort (a dead process's leases are reclaimed anyway)."""
    me = Owner.me()
    sql = "DELETE FROM leases WHERE host = ? AND pid = ? AND started = ?"
    with contextlib.suppress(UsageError):
        retrying(conn, lambda c: c.execute(sql, (me.host, me.pid, me.started)), "release the leases")


def probe(conn: sqlite3.Connection) -> None:
    """Write and take back a lease: a read-only file or folder fails here, before a run is lost to it."""
    conn.execute(LEASES.insert("INSERT OR REPLACE"), ("", 0, -1, "", 0, ""))
    conn.execute("DELETE FROM leases WHERE controller = '' AND seed = -1")
