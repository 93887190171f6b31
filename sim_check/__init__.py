"""Closed-loop simulation: the generated MLCA controllers driving autonomous vehicles in SUMO through libsumo.

Its command is `mlca-sim` (docs/reference/commands.md). The public Python API runs one closed-loop run and reads
a sweep's results:

    from pathlib import Path
    import tempfile
    import sim_check as sc

    scenario = sc.load_scenario(Path("sim_check/scenarios/short.toml")).with_avs(3)
    with tempfile.TemporaryDirectory() as work:
        run = sc.run_once(scenario, "mlca_t-c", 1, Path(work))      # a RunResult
        print(run.status, run.collisions, [m.changes_by(20) for m in run.metrics])
        with sc.ResultsDB.open_for_writing(Path(work) / "runs.sqlite") as db:
            db.store(run)                                            # as `mlca-sim sweep` stores its runs
        with sc.ResultsDB.open_for_reading(Path(work) / "runs.sqlite") as db:
            print(len(db.table_rows("runs").rows))                   # 1
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mlca_verify.lazy import lazy_exports

if TYPE_CHECKING:
    from sim_check.controllers import PAPER_MATRIX
    from sim_check.db import ResultsDB
    from sim_check.run_results import RunResult
    from sim_check.runner import run_once
    from sim_check.scenario import Scenario, load_scenario

# Imported on first use, so that `import sim_check` starts neither libsumo nor the code generator.
_HOMES = {
    "PAPER_MATRIX": "sim_check.controllers",
    "ResultsDB": "sim_check.db",
    "RunResult": "sim_check.run_results",
    "run_once": "sim_check.runner",
    "Scenario": "sim_check.scenario",
    "load_scenario": "sim_check.scenario",
}


__getattr__ = lazy_exports("sim_check", _HOMES)


__all__ = ["PAPER_MATRIX", "ResultsDB", "RunResult", "Scenario", "load_scenario", "run_once"]
