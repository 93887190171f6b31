"""The results database (SQLite): one row per run and one per AV, each run committed when it ends.

A run's rows go in one transaction, so a sweep killed at any moment leaves only whole runs behind; `--resume`
skips the (controller, AVs, seed) triples already in `runs`, so nothing is lost and nothing is run twice."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

from mlca_verify.errors import UsageError
from sim_check.runner import MARKS_KM, MECHANISM, STATES, RunResult

SCHEMA = f"""
CREATE TABLE IF NOT EXISTS runs (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL,
    status TEXT NOT NULL, reason TEXT NOT NULL, sim_steps INTEGER, wall_s REAL, vehicle_steps INTEGER,
    collisions INTEGER, monitor_violations INTEGER, trajectory_sha256 TEXT, bg_mean_speed_ms REAL,
    PRIMARY KEY (controller, avs, seed));
CREATE TABLE IF NOT EXISTS av_metrics (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    {", ".join(f"lc_{km}km INTEGER" for km in MARKS_KM)}, collisions INTEGER, emergency_brakes INTEGER,
    min_time_gap_s REAL, travel_time_s REAL, mean_speed_ms REAL, arrived INTEGER, monitor_violations INTEGER,
    mingap_contacts INTEGER, {", ".join(f"{k} REAL" for k in MECHANISM)},
    {", ".join(f"{state.lower()}_s REAL" for state in STATES)},
    PRIMARY KEY (controller, avs, seed, av));
CREATE TABLE IF NOT EXISTS violations (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    time_s REAL, invariants TEXT, trace_json TEXT);
"""
AV_COLUMNS = ("av", *(f"lc_{km}km" for km in MARKS_KM), "collisions", "emergency_brakes", "min_time_gap_s",
              "travel_time_s", "mean_speed_ms", "arrived", "monitor_violations", "mingap_contacts", *MECHANISM,
              *(f"{state.lower()}_s" for state in STATES))  # fmt: skip
RUN_COLUMNS = ("status", "reason", "sim_steps", "wall_s", "vehicle_steps", "collisions", "monitor_violations",
               "trajectory_sha256", "bg_mean_speed_ms")  # fmt: skip


def connect(path: Path) -> sqlite3.Connection:
    """Open (or create) a results database; one written with other columns is refused, not mixed."""
    try:
        conn = sqlite3.connect(path, timeout=60)
        conn.executescript(SCHEMA)
        have = {table: [r[1] for r in conn.execute(f"PRAGMA table_info({table})")] for table in ("runs", "av_metrics")}
    except sqlite3.Error as err:
        raise UsageError(f"{path}: error: not a results database: {err}") from None
    want = {
        "runs": ["controller", "avs", "seed", *RUN_COLUMNS],
        "av_metrics": ["controller", "avs", "seed", *AV_COLUMNS],
    }
    for table, columns in want.items():
        if have[table] != columns:
            missing = sorted(set(columns) - set(have[table]))
            raise UsageError(f"{path}: error: table {table} has other columns than this version writes "
                             f"(missing: {', '.join(missing) or 'none'}); use a new database file")  # fmt: skip
    return conn


def done(conn: sqlite3.Connection) -> set[tuple[str, int, int]]:
    return {(c, a, s) for c, a, s in conn.execute("SELECT controller, avs, seed FROM runs")}


def store(conn: sqlite3.Connection, r: RunResult) -> None:
    """Write one run and its AVs in a single transaction."""
    key = (r.controller, r.avs, r.seed)
    with conn:
        conn.execute(
            f"INSERT INTO runs VALUES (?, ?, ?, {', '.join('?' for _ in RUN_COLUMNS)})",
            (*key, r.status, r.reason, r.sim_steps, round(r.wall_s, 3), r.vehicle_steps, r.collisions,
             r.monitor_violations, r.trajectory_sha256, r.bg_mean_speed_ms),
        )  # fmt: skip
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
