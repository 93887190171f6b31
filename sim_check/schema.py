"""The layout of a results database, described once: each table is a list of typed columns with the schema
version that added it, and the DDL, the column lists, the inserts and the checks of a file's layout all come from
that description.

Versions: 1 had runs, av_metrics and violations (files not marked); 2 added the leases and the marks
(`PRAGMA application_id`, `PRAGMA user_version`); 3 added the shadow mode, the commands, the lane changes'
safety, SSM and the density (columns after those of 2), the transitions fired and the wish episodes. This version
writes only its own layout; `mlca-sim report` still reads every earlier one (the columns of 2 come first)."""

from __future__ import annotations

import sqlite3
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from mlca_verify.errors import UsageError
from sim_check.radio import V2V_COUNTS
from sim_check.run_results import CLAIM_STATES, MARKS_KM, MECHANISM, SAFETY, SHADOW, STATES

APPLICATION_ID = 0x4D4C4353  # "MLCS": this file is a results database of mlca-sim
SCHEMA_VERSION = 4

SqlType = Literal["TEXT", "INTEGER", "REAL"]


@dataclass(frozen=True)
class Column:
    name: str
    kind: SqlType
    required: bool = False  # NOT NULL
    since: int = 1  # the schema version that added it

    def ddl(self) -> str:
        return f"{self.name} {self.kind}{' NOT NULL' if self.required else ''}"


@dataclass(frozen=True)
class Table:
    """A table: its columns in order, and its primary key (none: rows may repeat)."""

    name: str
    columns: tuple[Column, ...]
    key: tuple[str, ...] = ()
    since: int = 1

    def names(self, version: int = SCHEMA_VERSION) -> tuple[str, ...]:
        """The columns a database of schema `version` has, in order."""
        return tuple(c.name for c in self.columns if c.since <= version)

    def ddl(self) -> str:
        parts = [c.ddl() for c in self.columns]
        if self.key:
            parts.append(f"PRIMARY KEY ({', '.join(self.key)})")
        return f"CREATE TABLE IF NOT EXISTS {self.name} ({', '.join(parts)})"

    def insert(self, verb: str = "INSERT") -> str:
        """An insert of one row, every column given, in order."""
        marks = ", ".join("?" for _ in self.columns)
        return f"{verb} INTO {self.name} ({', '.join(self.names())}) VALUES ({marks})"


def _cols(kind: SqlType, *names: str, required: bool = False, since: int = 1) -> tuple[Column, ...]:
    return tuple(Column(n, kind, required, since) for n in names)


RUN_KEY = ("controller", "avs", "seed")
_KEY = (*_cols("TEXT", "controller", required=True), *_cols("INTEGER", "avs", "seed", required=True))
_AV = _cols("TEXT", "av", required=True)

RUNS = Table(
    "runs",
    (
        *_KEY,
        *_cols("TEXT", "status", "reason", required=True),
        *_cols("INTEGER", "sim_steps"),
        *_cols("REAL", "wall_s"),
        *_cols("INTEGER", "vehicle_steps", "collisions", "monitor_violations"),
        *_cols("TEXT", "trajectory_sha256"),
        *_cols("REAL", "bg_mean_speed_ms"),
        *_cols("REAL", "density_veh_km_lane", since=3),
        *_cols("INTEGER", *(f"v2v_{name}" for name in V2V_COUNTS), since=4),
    ),
    RUN_KEY,
)
AV_METRICS = Table(
    "av_metrics",
    (
        *_KEY,
        *_AV,
        *_cols("INTEGER", *(f"lc_{km}km" for km in MARKS_KM), "collisions", "emergency_brakes"),
        *_cols("REAL", "min_time_gap_s", "travel_time_s", "mean_speed_ms"),
        *_cols("INTEGER", "arrived", "monitor_violations", "mingap_contacts"),
        *_cols("REAL", *MECHANISM, *(f"{state.lower()}_s" for state in STATES)),
        *_cols("REAL", *SHADOW, *SAFETY, since=3),
        *_cols("REAL", *(f"{state.lower()}_s" for state in CLAIM_STATES), since=4),
    ),
    (*RUN_KEY, "av"),
)
TRANSITIONS = Table(
    "transitions",
    (*_KEY, *_AV, *_cols("TEXT", "transition", required=True), *_cols("INTEGER", "fired", required=True)),
    (*RUN_KEY, "av", "transition"),
    since=3,
)
EPISODES = Table(
    "episodes",
    (
        *_KEY,
        *_AV,
        *_cols("REAL", "start_s", required=True),
        *_cols("INTEGER", "side", required=True),
        *_cols("TEXT", "reason", required=True),
        *_cols("INTEGER", "urgent", required=True),
        *_cols("TEXT", "outcome", required=True),
        *_cols("REAL", "delay_s", required=True),
        *_cols("TEXT", "state", required=True),
    ),
    since=3,
)
VIOLATIONS = Table("violations", (*_KEY, *_AV, *_cols("REAL", "time_s"), *_cols("TEXT", "invariants", "trace_json")))
LEASES = Table(
    "leases",
    (
        *_KEY,
        *_cols("TEXT", "host", required=True),
        *_cols("INTEGER", "pid", required=True),
        *_cols("TEXT", "started", required=True),
    ),
    RUN_KEY,
    since=2,
)
TABLES = {t.name: t for t in (RUNS, AV_METRICS, TRANSITIONS, EPISODES, VIOLATIONS, LEASES)}
RUN_TABLES = ("runs", "av_metrics", "violations", "transitions", "episodes")  # a run's rows, in these tables
EXPORTED = RUN_TABLES  # the tables a comparison commits as CSV
SCHEMA = tuple(t.ddl() for t in TABLES.values())
COLUMNS = {name: t.names() for name, t in TABLES.items() if name != "violations"}
# what a database of schema 2 (or 1) has, which the report still reads: the columns every version begins with
COLUMNS_2 = {name: TABLES[name].names(2) for name in ("runs", "av_metrics")}


# --- a file's layout -----------------------------------------------------------------------------------------


def marks(conn: sqlite3.Connection) -> tuple[int, int]:
    """The file's application id and schema version (0 and 0 for a new or unmarked file)."""
    app: int = conn.execute("PRAGMA application_id").fetchone()[0]
    version: int = conn.execute("PRAGMA user_version").fetchone()[0]
    return app, version


def tables(conn: sqlite3.Connection) -> set[str]:
    return {name for (name,) in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}


def create(conn: sqlite3.Connection) -> None:
    """Lay out an empty file as a database of this version, and mark it."""
    for statement in SCHEMA:
        conn.execute(statement)
    conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
    conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")


def prepare(conn: sqlite3.Connection, path: Path) -> None:
    """A new file becomes a database of this version; any other must be one already (else UsageError)."""
    app, version = marks(conn)
    found = tables(conn)
    if not found and app == version == 0:
        create(conn)
    else:
        check_writable(conn, path, app, version, found)


def check_writable(conn: sqlite3.Connection, path: Path, app: int, version: int, found: set[str]) -> None:
    """Refuse a database this version does not write: foreign, older, newer, or with other columns."""
    if app not in (0, APPLICATION_ID) or (app == 0 and "runs" not in found):
        names = ", ".join(sorted(found)) or "none"
        raise UsageError.at(path, f"not a results database of mlca-sim (its tables: {names}); give a new file to --db")
    check_columns(conn, path, found & {"runs", "av_metrics"}, COLUMNS_2, prefix=True)
    version = version if app else 1
    schemas = f"results schema {version}, this one writes {SCHEMA_VERSION}"
    if version < SCHEMA_VERSION:
        raise UsageError.at(
            path,
            f"written by an older mlca-sim ({schemas}); use a new database file (mlca-sim report still reads this one)",
        )
    if version > SCHEMA_VERSION:
        raise UsageError.at(path, f"written by a newer mlca-sim ({schemas}); use that version or a new database file")
    check_columns(conn, path, set(COLUMNS))


def check_readable(conn: sqlite3.Connection, path: Path, found: set[str]) -> None:
    """Refuse a file that is not a results database of any version (for reading)."""
    app, _ = marks(conn)
    if app not in (0, APPLICATION_ID) or "runs" not in found:
        raise UsageError.at(path, "not a results database of mlca-sim")


def check_columns(
    conn: sqlite3.Connection,
    path: Path,
    names: Iterable[str],
    wanted: dict[str, tuple[str, ...]] = COLUMNS,
    *,
    prefix: bool = False,
) -> None:
    """Refuse a table whose columns are not `wanted`'s, or with `prefix` (what every version has, COLUMNS_2) do
    not begin with them."""
    for table in sorted(names):
        have = [r[1] for r in conn.execute(f"PRAGMA table_info({table})")]
        expected = list(wanted[table])
        if have[: len(expected) if prefix else None] != expected:
            missing = sorted(set(expected) - set(have))
            raise UsageError.at(
                path,
                f"table {table} has other columns than this version writes "
                f"(missing: {', '.join(missing) or 'none'}); use a new database file",
            )


def table_name(table: str) -> str:
    """`table`, when it is one of a results database's (its name then goes into SQL); else ValueError."""
    if table not in TABLES:
        raise ValueError(f"no table {table!r} in a results database")
    return table
