"""The results database's reader for the evidence (`mlca-verify evidence --db`): registered in the entry-point
group `mlca_verify.closed_loop`, so that the library reads closed-loop runs without importing the simulator."""

from __future__ import annotations

from pathlib import Path

from mlca_verify.evidence.runs import ClosedLoopRuns
from sim_check.db import ResultsDB


def closed_loop_runs(db: Path, controllers: tuple[str, str]) -> ClosedLoopRuns:
    """The runs of the two controllers (Python and C of one machine) in the results database at `db`."""
    with ResultsDB.open_for_reading(db) as results:
        summary = results.monitor_summary(controllers)
        fired = results.transition_counts(controllers)
        v2v = results.v2v_totals(controllers)
    return ClosedLoopRuns(db, summary.runs, summary.failed_runs, summary.monitor_violations, fired, v2v)
