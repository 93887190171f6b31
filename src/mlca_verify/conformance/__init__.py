"""`mlca-verify conform`: prove and test that the generated code does what its spec says.

The code generator and the checks are imported when a conformance run starts, so that reading `CHECKS` (the
command line's help) costs nothing."""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mlca_verify.conformance.outcome import CHECKS, CheckOutcome, run_checks
from mlca_verify.errors import UsageError
from mlca_verify.json_types import JsonObject
from mlca_verify.layout import Layout
from mlca_verify.spec import LoadedSpec

__all__ = ["CHECKS", "CONFORM_SCHEMA", "Conformance", "conform", "up_to_date"]

CONFORM_SCHEMA = "mlca-verify.conform/1"  # the schema string of `conform --json`


@dataclass
class Conformance:
    """What `conform` found for one spec: an outcome per check, in the order they ran."""

    spec: LoadedSpec
    outcomes: list[CheckOutcome]

    @property
    def ok(self) -> bool:
        """Whether every check passed."""
        return all(o.ok for o in self.outcomes)

    def to_json(self) -> JsonObject:
        """The outcomes as `conform --json` writes them (schema mlca-verify.conform/1)."""
        return {
            "path": self.spec.path,
            "sha256": self.spec.sha256,
            "machine": self.spec.machine.name,
            "ok": self.ok,
            "checks": [o.to_json() for o in self.outcomes],
        }


def _up_to_date(spec: LoadedSpec, generated: Path, template_dir: Path | None) -> CheckOutcome:
    from mlca_verify.codegen import generate

    files = generate(spec, generated) if template_dir is None else generate(spec, generated, template_dir)
    return up_to_date(spec, files, generated)


def up_to_date(spec: LoadedSpec, files: dict[str, str], generated: Path, what: str = "spec") -> CheckOutcome:
    """Whether the `files` generated from `spec` (relative path -> text) are those in `generated`."""
    from mlca_verify.codegen import drift

    problems = [d for d in drift(files, generated) if d.path in files]
    if problems:
        listed = "; ".join(f"{d.path} {d.problem}" for d in problems)
        return CheckOutcome("up-to-date", False, f"{listed}: run `mlca-verify gen {spec.path}`")
    return CheckOutcome(
        "up-to-date", True, f"{', '.join(sorted(files))} match the {what} (sha256 {spec.sha256[:12]}...)"
    )


def _present(
    spec: LoadedSpec,
    generated: Path,
    module: str,
    template_dir: Path | None,
    report: Callable[[CheckOutcome], None],
) -> tuple[Layout, CheckOutcome]:
    """The generated files of `spec` (refused when one is missing), and whether they are up to date (reported)."""
    layout = Layout(generated.resolve(), module)
    for path in layout.missing():
        raise UsageError.at(path, f"generated file not found; run `mlca-verify gen {spec.path} --out {generated}`")
    fresh = _up_to_date(spec, generated, template_dir)
    report(fresh)
    return layout, fresh


def conform(
    spec: LoadedSpec,
    generated: Path,
    checks: list[str],
    report: Callable[[CheckOutcome], None],
    *,
    sequences: int = 200,
    template_dir: Path | None = None,
) -> Conformance:
    """Run `checks` on the code for `spec` found in `generated`; `report` sees each outcome as it lands."""
    from mlca_verify.codegen import machine_ir
    from mlca_verify.conformance.generated_code import SUITE, Subject

    ir = machine_ir(spec, generated)
    layout, fresh = _present(spec, generated, ir.module, template_dir, report)
    with tempfile.TemporaryDirectory(prefix="mlca-conform-") as build:
        subject = Subject(spec.machine, ir, layout, Path(build), sequences)
        return Conformance(spec, [fresh, *run_checks(subject, checks, SUITE, report)])
