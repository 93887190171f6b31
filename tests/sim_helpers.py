"""What the closed-loop test files share: the short scenario and reading a results database's rows."""

from __future__ import annotations

from pathlib import Path

from sim_check.db import ResultsDB
from tests.conftest import ROOT

SHORT = ROOT / "sim_check" / "scenarios" / "short.toml"


def rows(db: Path, table: str, skip: tuple[str, ...] = ("wall_s",)) -> list[tuple[object, ...]]:
    """The rows of `table` ordered by their first four columns, without the columns `skip` names."""
    with ResultsDB.open_for_reading(db) as results:
        table_rows = results.table_rows(table)
    keep = [k for k, name in enumerate(table_rows.columns) if name not in skip]
    return [tuple(r[k] for k in keep) for r in table_rows.rows]
