"""Refresh docs/comparison/ from a results database of the full matrix
(`mlca-sim sweep --matrix paper --runs 100 --db FILE`): the report and its SVG figures, and the database's rows
as CSV (sorted, so the same runs give the same files), from which tests/test_docs.py rebuilds the database and
checks that the committed report is what `mlca-sim report` makes of it.

Usage: .venv/bin/python scripts/refresh_comparison.py matrix.sqlite [DIR]
DIR is docs/comparison by default; docs/comparison/middle holds the comparison under the paper's middle-lane goal
(a scenario with `need = "middle"`), docs/comparison/exit the one with the AVs' exit in the rightmost lane
(sim_check/scenarios/exit.toml).
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

from sim_check.db import ResultsDB
from sim_check.report import write_report
from sim_check.schema import EXPORTED

DOCS = Path(__file__).resolve().parent.parent / "docs" / "comparison"


def export(db: Path, out: Path) -> None:
    with ResultsDB.open_for_reading(db) as results:
        for table in EXPORTED:
            rows = results.table_rows(table)
            with (out / f"{table}.csv").open("w", newline="", encoding="utf-8") as f:
                writer = csv.writer(f, lineterminator="\n")
                writer.writerow(rows.columns)
                writer.writerows(rows.rows)


def main() -> None:
    db = Path(sys.argv[1])
    docs = Path(sys.argv[2]).resolve() if len(sys.argv) > 2 else DOCS
    docs.mkdir(parents=True, exist_ok=True)
    for old in docs.glob("*.svg"):
        old.unlink()
    for path in write_report(db, docs):
        if path.suffix == ".png":  # the SVGs are the committed figures; the PNGs stay out of the repository
            path.unlink()
    export(db, docs)
    print(f"refreshed {docs}")


if __name__ == "__main__":
    main()
