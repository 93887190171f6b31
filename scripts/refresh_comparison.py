"""Refresh docs/comparison/ from a results database of the full matrix
(`mlca-sim sweep --matrix paper --runs 100 --db FILE`): the report and its SVG figures, and the database's rows
as CSV (sorted, so the same runs give the same files), from which tests/test_docs.py rebuilds the database and
checks that the committed report is what `mlca-sim report` makes of it.

Usage: .venv/bin/python scripts/refresh_comparison.py matrix.sqlite [DIR]
DIR is docs/comparison by default; docs/comparison/middle holds the comparison under the paper's middle-lane goal
(a scenario with `need = "middle"`), docs/comparison/exit the one with the AVs' exit in the rightmost lane
(sim_check/scenarios/exit.toml).

       .venv/bin/python scripts/refresh_comparison.py --rows DIR matrix.sqlite [--drop CONTROLLER:AVS,...]
writes the committed rows of DIR back into a new results database, without the runs of the configurations named
(say, `mlca-c:3` after a change to how three MLCA AVs decide); `mlca-sim sweep --matrix paper --runs 100 --resume
--db matrix.sqlite` (with the DIR's scenario) then runs those again, and the controllers added to the matrix since.
"""

from __future__ import annotations

import csv
import sys
from collections.abc import Callable
from pathlib import Path

from sim_check.db import ResultsDB, TableRows
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


CASTS: dict[str, Callable[[str], object]] = {
    "TEXT": str,
    "INTEGER": lambda v: None if v == "" else int(v),
    "REAL": lambda v: None if v == "" else float(v),
}


def rebuild(db: Path, rows: Path, drop: frozenset[tuple[str, int]] = frozenset()) -> None:
    """The committed CSV rows of `rows` back into a results database of this version's schema, but for the runs
    of the (controller, AVs) configurations in `drop`."""
    with ResultsDB.open_for_writing(db) as results:
        for table in EXPORTED:
            types = results.column_types(table)
            with (rows / f"{table}.csv").open(newline="", encoding="utf-8") as f:
                reader = csv.reader(f)
                header = next(reader)
                cast = [CASTS[types[name]] for name in header]
                kept = [row for row in reader if (row[0], int(row[1])) not in drop]
            results.add_rows(
                table, TableRows(tuple(header), [tuple(c(v) for c, v in zip(cast, row, strict=True)) for row in kept])
            )


def _drops(text: str) -> frozenset[tuple[str, int]]:
    pairs = (item.rsplit(":", 1) for item in text.split(",") if item)
    return frozenset((controller, int(avs)) for controller, avs in pairs)


def main() -> None:
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    if sys.argv[1] == "--rows":
        drop = _drops(sys.argv[5]) if len(sys.argv) > 5 and sys.argv[4] == "--drop" else frozenset()
        rebuild(Path(sys.argv[3]), Path(sys.argv[2]), drop)
        print(f"wrote {sys.argv[3]} from {sys.argv[2]}, without {', '.join(sorted(f'{c}:{a}' for c, a in drop))}")
        return
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
