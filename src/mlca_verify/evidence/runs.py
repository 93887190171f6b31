"""The closed-loop runs the evidence reads: counted in a results database that `mlca-sim` writes.

The library owns the interface and never imports the simulator: an installed package registers a reader in the
entry-point group `mlca_verify.closed_loop` (sim_check registers the one for its SQLite database), and
`read_closed_loop` finds it there."""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path
from typing import Protocol

from mlca_verify.errors import UsageError
from mlca_verify.spec import LoadedSpec

READERS = "mlca_verify.closed_loop"


@dataclass(frozen=True)
class ClosedLoopRuns:
    """The closed-loop runs of one machine's generated controllers (see `loop_controllers`) in a results
    database written by `mlca-sim`, as its API counts them: the evidence takes them as data."""

    db: Path
    runs: int
    failed_runs: int
    monitor_violations: int
    transitions: dict[str, int] = field(default_factory=dict)  # times each transition fired (schema 3 and on)
    v2v: dict[str, int] = field(default_factory=dict)  # what the radio carried in those runs (schema 4 and on)


class ClosedLoopReader(Protocol):
    """What a registered reader is: the runs of the two controllers in the database at `db`."""

    def __call__(self, db: Path, controllers: tuple[str, str]) -> ClosedLoopRuns: ...


def loop_controllers(spec: LoadedSpec) -> tuple[str, str]:
    """The mlca-sim controllers that drive with the code generated from `spec`: its Python and its C."""
    module = spec.machine.name.lower()
    return f"{module}-py", f"{module}-c"


def read_closed_loop(db: Path, spec: LoadedSpec) -> ClosedLoopRuns:
    """The runs of `spec`'s controllers in the results database `db`, through the registered reader."""
    found = sorted(entry_points(group=READERS), key=lambda e: e.name)
    why = "no installed package registers a reader" if not found else ""
    reader: ClosedLoopReader | None = None
    if found:
        try:
            reader = found[0].load()
        except ImportError as err:
            why = f"it cannot be imported here: {err}"
    if reader is None:
        raise UsageError.at(
            db, f"--db needs the simulation part of mlca-verify (sim_check, with SUMO's libsumo): {why}"
        )
    return reader(db, loop_controllers(spec))
