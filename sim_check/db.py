"""The results database (SQLite): one row per run and one per AV, each run committed when it ends.

A run's rows go in one transaction, so a sweep killed at any moment leaves only whole runs behind; `--resume`
skips the (controller, AVs, seed) triples already in `runs`, so nothing is lost and nothing is run twice."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

from sim_check.runner import MARKS_KM, RunResult

SCHEMA = f"""
CREATE TABLE IF NOT EXISTS runs (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL,
    status TEXT NOT NULL, reason TEXT NOT NULL, sim_steps INTEGER, wall_s REAL, vehicle_steps INTEGER,
    collisions INTEGER, monitor_violations INTEGER, trajectory_sha256 TEXT,
    PRIMARY KEY (controller, avs, seed));
CREATE TABLE IF NOT EXISTS av_metrics (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    {", ".join(f"lc_{km}km INTEGER" for km in MARKS_KM)}, collisions INTEGER, emergency_brakes INTEGER,
    min_time_gap_s REAL, travel_time_s REAL, mean_speed_ms REAL, arrived INTEGER, monitor_violations INTEGER,
    PRIMARY KEY (controller, avs, seed, av));
CREATE TABLE IF NOT EXISTS violations (
    controller TEXT NOT NULL, avs INTEGER NOT NULL, seed INTEGER NOT NULL, av TEXT NOT NULL,
    time_s REAL, invariants TEXT, trace_json TEXT);
"""
AV_COLUMNS = ("av", *(f"lc_{km}km" for km in MARKS_KM), "collisions", "emergency_brakes", "min_time_gap_s",
              "travel_time_s", "mean_speed_ms", "arrived", "monitor_violations")  # fmt: skip


def connect(path: Path) -> sqlite3.Connection:
    conn = sqlite3.connect(path, timeout=60)
    conn.executescript(SCHEMA)
    return conn


def done(conn: sqlite3.Connection) -> set[tuple[str, int, int]]:
    return {(c, a, s) for c, a, s in conn.execute("SELECT controller, avs, seed FROM runs")}


def store(conn: sqlite3.Connection, r: RunResult) -> None:
    """Write one run and its AVs in a single transaction."""
    key = (r.controller, r.avs, r.seed)
    with conn:
        conn.execute(
            "INSERT INTO runs VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (*key, r.status, r.reason, r.sim_steps, round(r.wall_s, 3), r.vehicle_steps, r.collisions,
             r.monitor_violations, r.trajectory_sha256),
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
