"""Opening a results database and running a transaction on it: every write an immediate transaction, retried
while another process holds the lock, every failure one line naming the file."""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar
from urllib.parse import quote

from mlca_verify.errors import UsageError

T = TypeVar("T")

BUSY_TIMEOUT_S = 30.0  # how long one attempt waits for another writer's lock
WRITE_ATTEMPTS = 10  # attempts of a write before the database is declared stuck
BUSY_CODES = (sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED)


class Database(sqlite3.Connection):
    """A connection that keeps the path it was opened by, for its messages."""

    path = ""


def uri(path: Path, mode: str) -> str:
    """An SQLite URI for the file `path`, taken literally ('#', '?' and '%' in names included)."""
    return f"file:{quote(str(path.absolute()))}?mode={mode}"


def file_of(conn: sqlite3.Connection) -> str:
    return getattr(conn, "path", "") or str(conn.execute("PRAGMA database_list").fetchone()[2])


def open_file(path: Path, mode: str) -> Database:
    """A connection to `path` (`mode`: ro, rw or rwc); a folder or a file SQLite cannot open is a UsageError."""
    if path.is_dir():
        raise UsageError.at(path, "is a folder, not a results database")
    try:
        conn = sqlite3.connect(uri(path, mode), uri=True, timeout=BUSY_TIMEOUT_S, factory=Database)
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


def retrying(
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
                raise UsageError.at(file_of(conn), f"cannot {what}: {err}") from None
            time.sleep(min(1.0, 0.01 * 2**attempt))  # the busy timeout has waited already
    waited = time.monotonic() - start
    raise UsageError.at(file_of(conn), f"cannot {what}: another process kept the database locked for {waited:.0f} s")


def reading(
    conn: sqlite3.Connection, body: Callable[[sqlite3.Connection], T], what: str = "read the results database"
) -> T:
    """`body` in one read transaction: a consistent snapshot."""
    return retrying(conn, body, what, "BEGIN")
