"""`mlca-verify tests`: generate the suite of one spec, write it, run it on the host, measure its coverage on the
generated Python and C, and run it on a Cortex-M4 under QEMU against the host's output."""

from __future__ import annotations

import json
import multiprocessing
import os
import random
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mlca_verify.codegen import machine_ir
from mlca_verify.conformance.generated_code import random_inputs
from mlca_verify.errors import ToolError, UsageError
from mlca_verify.files import write_atomic
from mlca_verify.layout import Layout
from mlca_verify.model import Machine
from mlca_verify.spec import LoadedSpec
from mlca_verify.testgen import DEPTH, target
from mlca_verify.testgen.emit import Header, c_suite, objectives_json, python_suite
from mlca_verify.testgen.explain import Reach, fill
from mlca_verify.testgen.formats import sarif
from mlca_verify.testgen.measure import Coverage, build_runner, c_coverage, python_coverage
from mlca_verify.testgen.search import Sample
from mlca_verify.testgen.suite import Suite, generate
from mlca_verify.tools import run
from mlca_verify.words import count

Say = Callable[[str], None]
TESTS_SCHEMA = "mlca-verify.tests/1"  # the schema string of coverage.json
SEQUENCE_STEPS = 2_000  # steps of the conformance sequence the C program runs on host and target


@dataclass
class TestsReport:
    spec: LoadedSpec
    suite: Suite
    folder: Path
    seconds: float
    host_passed: bool = False
    host_lines: list[str] = field(default_factory=list)
    coverage: list[Coverage] = field(default_factory=list)
    target: target.TargetRun | None = None

    @property
    def ok(self) -> bool:
        agree = self.target is None or self.target.agrees
        covered = all(c.passed and not c.unexplained for c in self.coverage)
        return self.host_passed and covered and agree


def file_names(module: str) -> dict[str, str]:
    return {"python": f"test_{module}_mcdc.py", "c": f"{module}_mcdc.c", "objectives": "objectives.json"}


def generate_fresh(machine: Machine, depth: int) -> Suite:
    """The suite found in a new interpreter: z3's models depend on every term made before in the process, so the
    same spec gives the same suite only from the same start."""
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(generate, machine, depth).result()


def conformance_sequence(spec: LoadedSpec, generated: Path, steps: int = SEQUENCE_STEPS) -> list[Sample]:
    """The first steps of `conform`'s random sequence of seed 0 (the same generator), which the C program also
    runs, host and target alike, and prints for the back-to-back comparison."""
    rng = random.Random(0)
    m = spec.machine
    ir = machine_ir(spec, generated)
    names = [i.name for i in m.inputs] + [s.name for s in m.signals]
    rows = [random_inputs(ir, rng) for _ in range(steps)]
    return [
        {n: bool(v) if k < len(m.inputs) else v for k, (n, v) in enumerate(zip(names, row, strict=True))}
        for row in rows
    ]


def write_suite(spec: LoadedSpec, suite: Suite, folder: Path, generated: Path) -> dict[str, Path]:
    module = spec.machine.name.lower()
    layout = Layout(generated, module)
    folder.mkdir(parents=True, exist_ok=True)
    relative = Path(os.path.relpath(layout.python.resolve(), folder.resolve())).as_posix()
    header = Header(spec.path, spec.sha256, relative)
    names = {k: folder / v for k, v in file_names(module).items()}
    write_atomic(names["python"], python_suite(suite, header))
    write_atomic(names["c"], c_suite(suite, header, conformance_sequence(spec, generated)))
    write_atomic(names["objectives"], objectives_json(suite, header))
    return names


def host_run(runner: Path, generated_c: Path, work: Path) -> tuple[bool, list[str]]:
    exe = work / "runner-host"
    build_runner("gcc", ("-O2", "-ffp-contract=off"), runner, generated_c, exe)
    ran = run([str(exe)], timeout=120, stdin="")
    return ran.returncode == 0, ran.output.splitlines()


def tests(
    spec: LoadedSpec,
    out: Path,
    generated: Path,
    *,
    measure: bool = True,
    on_target: bool = True,
    depth: int = DEPTH,
    say: Say = print,
) -> TestsReport:
    if spec.machine.semantics != "first-match":
        raise UsageError.at(spec.path, "tests are generated for first-match machines only, as code is")
    module = spec.machine.name.lower()
    layout = Layout(generated, module)
    missing = layout.missing()
    if missing:
        raise ToolError.at(missing[0], f"generated code not found; run `mlca-verify gen {spec.path}` first")
    start = time.perf_counter()
    suite = generate_fresh(spec.machine, depth)
    seconds = time.perf_counter() - start
    folder = out / module
    files = write_suite(spec, suite, folder, generated)
    report = TestsReport(spec, suite, folder, seconds)
    say(_generated_line(report))
    work = folder / "build"
    work.mkdir(exist_ok=True)
    report.host_passed, report.host_lines = host_run(files["c"], layout.c_source, work)
    last = report.host_lines[-1] if report.host_lines else "no output"
    say(f"  host   {'pass' if report.host_passed else 'FAIL'}  the C suite built by gcc: {last}")
    if measure:
        report.coverage.append(python_coverage(files["python"], layout.python, work))
        report.coverage.append(c_coverage(files["c"], layout.c_source, work))
        closed = [case.state for case in machine_ir(spec, generated).cases if case.closes]
        reach = Reach(suite.depth, suite.unvisited, closed)
        for c, source in zip(report.coverage, (layout.python, layout.c_source), strict=True):
            fill(c.gaps, source.read_text(encoding="utf-8"), spec.machine, suite.pairs, reach=reach)
            say(_coverage_line(c))
    if on_target:
        report.target = target.run_on_target(files["c"], layout.c_source, work, report.host_lines)
        say(target.summary_line(report.target))
    write_atomic(folder / "coverage.json", json.dumps(report_json(report), indent=1, sort_keys=True) + "\n")
    measured = (
        [(_shown(layout.python), report.coverage[0]), (_shown(layout.c_source), report.coverage[1])] if measure else []
    )
    log = sarif(spec.path, suite.pairs, measured)
    write_atomic(folder / "uncovered.sarif", json.dumps(log, indent=1, sort_keys=True) + "\n")
    return report


def _shown(path: Path) -> str:
    """A path as the reports name it: relative to the working directory when it lies below it."""
    try:
        return path.resolve().relative_to(Path.cwd().resolve()).as_posix()
    except ValueError:
        return path.as_posix()


def _generated_line(r: TestsReport) -> str:
    s = r.suite
    covered = len(s.pairs) - len(s.uncovered)
    return (
        f"  suite  {len(s.cases)} runs ({sum(len(c.inputs) for c in s.cases)} steps), {len(s.monitor)} monitor "
        f"calls, {len(s.params)} params checks: {covered} of {len(s.pairs)} conditions paired (MC/DC), "
        f"{len(s.uncovered)} without a pair, each with z3's reason"
    )


def _coverage_line(c: Coverage) -> str:
    mcdc = f", MC/DC {c.mcdc.text()}" if c.mcdc is not None else ""
    status = "pass" if c.passed and not c.unexplained else "FAIL"
    gaps = f"; {len(c.gaps)} gaps, {len(c.unexplained)} without a reason" if c.gaps else ""
    left = f"; {count(len(c.notes), 'expression')} left out of MC/DC by clang" if c.notes else ""
    figures = f"statements {c.statements.text()}, branches {c.branches.text()}{mcdc}{gaps}{left}"
    return f"  {c.language:<6} {status}  {c.file}: {figures}"


def report_json(r: TestsReport) -> dict[str, Any]:
    s = r.suite
    return {
        "schema": TESTS_SCHEMA,
        "spec": r.spec.path,
        "sha256": r.spec.sha256,
        "machine": s.machine.name,
        "seconds": round(r.seconds, 3),
        "runs": len(s.cases),
        "steps": sum(len(c.inputs) for c in s.cases),
        "monitor_calls": len(s.monitor),
        "params_checks": len(s.params),
        "objectives": len(s.pairs),
        "paired": len(s.pairs) - len(s.uncovered),
        "exceptions": [
            {"objective": p.objective.id, "condition": p.objective.label, "reason": p.reason} for p in s.uncovered
        ],
        "host": {"passed": r.host_passed, "last": r.host_lines[-1] if r.host_lines else ""},
        "coverage": [_coverage_json(c) for c in r.coverage],
        "target": None if r.target is None else r.target.to_json(),
    }


def _coverage_json(c: Coverage) -> dict[str, Any]:
    def fig(f: Any) -> dict[str, Any] | None:
        return None if f is None else {"covered": f.covered, "total": f.total, "percent": round(f.percent, 2)}

    return {
        "language": c.language,
        "file": c.file,
        "passed": c.passed,
        "statements": fig(c.statements),
        "branches": fig(c.branches),
        "mcdc": fig(c.mcdc),
        "functions": {n: {k: fig(v) for k, v in f.items()} for n, f in sorted(c.functions.items())},
        "gaps": [{"line": g.line, "what": g.what, "reason": g.reason} for g in c.gaps],
        "notes": c.notes,
    }
