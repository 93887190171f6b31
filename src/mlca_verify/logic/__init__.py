"""The z3 engine: every check of a machine, and the comparison of two machines."""

from __future__ import annotations

import time

from mlca_verify.logic.boolean import Checker
from mlca_verify.logic.datachecks import check_data_machine
from mlca_verify.logic.equiv import EquivalenceResult, compare
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.results import Result
from mlca_verify.logic.solver import DEFAULT_TIMEOUT_MS
from mlca_verify.model import Machine

__all__ = ["check_all", "compare", "equivalence"]


def check_all(
    machine: Machine, timeout_ms: int = DEFAULT_TIMEOUT_MS, parametric: bool = False, limits: Limits | None = None
) -> list[Result]:
    """Built-in checks, declared invariants and liveness, and declared comparisons, in that order. A machine
    with data is decided symbolically; `parametric` proves its properties for every param value in range."""
    if machine.has_data:
        return check_data_machine(machine, limits or Limits(timeout_ms=timeout_ms), parametric)
    results = Checker(machine, timeout_ms).run_all()
    for declared in machine.comparisons:
        start = time.perf_counter()
        found = compare(machine, declared.other, timeout_ms)
        seconds = time.perf_counter() - start
        prop = f"equiv:{declared.other.name}"
        results.append(
            Result(
                prop,
                "equivalence",
                found.verdict,
                declared.expect,
                declared.cite,
                seconds,
                found.counterexample,
                found.detail,
            )
        )
    return results


def equivalence(old: Machine, new: Machine, timeout_ms: int = DEFAULT_TIMEOUT_MS) -> EquivalenceResult | None:
    """Where two machines differ, every region of it, by the boolean engine; None where either has data (such
    machines are compared by their verdicts only)."""
    if old.has_data or new.has_data:
        return None
    return compare(old, new, timeout_ms, all_regions=True)
