"""Refresh docs/comparison/v2v/ from the results databases of the three V2V channels: each database's rows as CSV
under v2v/<label>/ (sorted, as scripts/refresh_comparison.py writes them), and channels.md and channels.svg as
`mlca-sim channels` writes them; tests/test_docs.py rebuilds the databases from the rows and checks that the
committed channels.md is what the command makes of them.

Usage: .venv/bin/python scripts/refresh_channels.py off=off.sqlite perfect=perfect.sqlite lossy=lossy.sqlite
(the sweeps of docs/guides/closed-loop.md, on sim_check/scenarios/paper_v2v_*.toml).
"""

from __future__ import annotations

import sys
from pathlib import Path

from refresh_comparison import DOCS, export  # run as a script: its folder is on the path
from sim_check.cli import main as sim_main

V2V = DOCS / "v2v"


def main() -> None:
    given = [arg.split("=", 1) for arg in sys.argv[1:]]
    for label, db in given:
        (V2V / label).mkdir(parents=True, exist_ok=True)
        export(Path(db), V2V / label)
    code = sim_main(["channels", *(a for label, db in given for a in ("--db", f"{label}={db}")), "--out", str(V2V)])
    (V2V / "channels.png").unlink(missing_ok=True)  # the SVG is the committed figure
    print(f"refreshed {V2V}" if code == 0 else "mlca-sim channels failed")
    sys.exit(code)


if __name__ == "__main__":
    main()
