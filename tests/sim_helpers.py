"""What the closed-loop test files share: the short scenario and reading a results database's rows."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from sim_check.db import ResultsDB
from tests.conftest import ROOT

SHORT = ROOT / "sim_check" / "scenarios" / "short.toml"


def rows(db: Path, table: str, skip: tuple[str, ...] = ("wall_s",)) -> list[tuple[object, ...]]:
    """The rows of `table` ordered by their first four columns, without the columns `skip` names."""
    with ResultsDB.open_for_reading(db) as results:
        table_rows = results.table_rows(table)
    keep = [k for k, name in enumerate(table_rows.columns) if name not in skip]
    return [tuple(r[k] for k in keep) for r in table_rows.rows]


def in_mode(ctrl: Any, mode: int) -> Any:
    """A new context of a controller whose context is its mode alone, in `mode`: the Python's object, or the C's
    bytes (the mode is the context's first member, a C enum: an int)."""
    ctx = ctrl.context()
    if isinstance(ctx, bytearray):
        ctx[0:4] = mode.to_bytes(4, sys.byteorder)
    else:
        ctx.mode = mode
    return ctx
