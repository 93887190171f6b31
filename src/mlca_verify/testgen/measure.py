"""The suite run and its coverage measured: the pytest module under coverage.py (statements and branches of the
generated Python), the C program built by clang with source-based coverage and MC/DC (statements, branches and
MC/DC of the generated C), and the C program on a Cortex-M4 under QEMU, compared line for line with the host."""

from __future__ import annotations

import json
import os
import re
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from mlca_verify.errors import ToolError
from mlca_verify.testgen.cobertura import cobertura_from_lcov
from mlca_verify.tools import C_FLAGS, run

CLANG = "clang-19"
PROFDATA = "llvm-profdata-19"
LLVM_COV = "llvm-cov-19"
_MCDC_WARNING = re.compile(r"^(.*?):(\d+):(\d+): warning: (.*MC/DC.*)$")
COVERAGE_FLAGS = ("-fprofile-instr-generate", "-fcoverage-mapping", "-fcoverage-mcdc", "-O0")


@dataclass
class Figure:
    covered: int
    total: int

    @property
    def percent(self) -> float:
        return 100.0 * self.covered / self.total if self.total else 100.0

    def text(self) -> str:
        return f"{self.percent:.1f}% ({self.covered}/{self.total})"


@dataclass
class Gap:
    """Something the suite leaves uncovered in the code: where, and what."""

    line: int
    what: str
    reason: str = ""  # why the suite cannot close it ("" where no reason is known)
    condition: tuple[int, int] | None = None  # an MC/DC gap's condition (from 0) and its decision's conditions


@dataclass
class Coverage:
    language: Literal["c", "python"]
    file: str
    statements: Figure
    branches: Figure
    mcdc: Figure | None  # None where the tool measures none (coverage.py)
    passed: bool
    functions: dict[str, dict[str, Figure]] = field(default_factory=dict)
    gaps: list[Gap] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what the tool says it could not measure

    @property
    def unexplained(self) -> list[Gap]:
        return [g for g in self.gaps if not g.reason]


def python_coverage(test_file: Path, module: Path, work: Path) -> Coverage:
    """The pytest module run under coverage.py with branch coverage, over the generated module alone."""
    test_file, module, work = test_file.resolve(), module.resolve(), work.resolve()
    data = work / ".coverage"
    env = {**os.environ, "COVERAGE_FILE": str(data), "PYTHONDONTWRITEBYTECODE": "1"}
    ran = run(
        [
            sys.executable,
            "-m",
            "coverage",
            "run",
            "--branch",
            f"--include={module.resolve()}",
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "-p",
            "no:randomly",
            str(test_file),
        ],
        cwd=work,
        env=env,
        timeout=600,
    )
    report = work / "coverage-python.json"
    run([sys.executable, "-m", "coverage", "json", "-q", "-o", str(report)], cwd=work, env=env)
    run(
        [sys.executable, "-m", "coverage", "xml", "-q", "-o", str(work.parent / "cobertura-python.xml")],
        cwd=work,
        env=env,
    )
    if not report.is_file():
        raise ToolError(f"error: coverage.py wrote no report:\n{ran.output[-2000:]}")
    return _python_figures(json.loads(report.read_text(encoding="utf-8")), module, ran.returncode == 0)


def _python_figures(doc: dict[str, Any], module: Path, passed: bool) -> Coverage:
    entry = next(iter(doc["files"].values()), None)
    if entry is None:
        raise ToolError(f"error: coverage.py measured nothing of {module}")
    s = entry["summary"]
    cov = Coverage(
        "python",
        module.name,
        Figure(s["covered_lines"], s["num_statements"]),
        Figure(s["covered_branches"], s["num_branches"]),
        None,
        passed,
    )
    for name, f in entry.get("functions", {}).items():
        fs = f["summary"]
        cov.functions[name or "(module)"] = {
            "statements": Figure(fs["covered_lines"], fs["num_statements"]),
            "branches": Figure(fs["covered_branches"], fs["num_branches"]),
        }
    cov.gaps += [Gap(line, "statement not run") for line in entry["missing_lines"]]
    cov.gaps += [
        Gap(a, f"branch to line {b} not taken" if b > 0 else "branch out not taken")
        for a, b in entry["missing_branches"]
    ]
    return cov


def build_runner(compiler: str, flags: Sequence[str], runner: Path, generated_c: Path, exe: Path) -> str:
    """The suite's C program linked with the generated C into `exe`, by `compiler` with the project's warnings
    and `flags`; the compiler's output."""
    command = [compiler, *C_FLAGS, *flags, f"-I{generated_c.parent}", "-o", str(exe), str(runner), str(generated_c)]
    built = run(command, timeout=300)
    if built.returncode != 0:
        raise ToolError(f"error: {compiler} failed on {runner}:\n{built.output[-3000:]}")
    return built.output


def c_coverage(runner: Path, generated_c: Path, work: Path) -> Coverage:
    """The C program built with clang's source-based coverage and MC/DC, run once, and its report."""
    exe = work / "runner-coverage"
    warnings = build_runner(CLANG, ("-Wno-error", *COVERAGE_FLAGS), runner, generated_c, exe)
    raw = work / "runner.profraw"
    ran = run([str(exe)], env={**os.environ, "LLVM_PROFILE_FILE": str(raw)}, timeout=300)
    merged = work / "runner.profdata"
    run([PROFDATA, "merge", "-sparse", "-o", str(merged), str(raw)])
    exported = run([LLVM_COV, "export", str(exe), f"-instr-profile={merged}", str(generated_c)], timeout=300, stdin="")
    if exported.returncode != 0:
        raise ToolError(f"error: {LLVM_COV} export failed:\n{exported.output[-2000:]}")
    (work / "coverage-c.json").write_text(exported.output, encoding="utf-8")
    lcov = run([LLVM_COV, "export", "-format=lcov", str(exe), f"-instr-profile={merged}", str(generated_c)], stdin="")
    cobertura = cobertura_from_lcov(lcov.output, generated_c.name)
    (work.parent / "cobertura-c.xml").write_text(cobertura, encoding="utf-8")
    return _c_figures(json.loads(exported.output), generated_c, ran.returncode == 0, mcdc_notes(warnings, generated_c))


def mcdc_notes(warnings: str, generated_c: Path) -> list[str]:
    """What clang's build said it leaves out of MC/DC in the generated file, each at its line and column."""
    found = []
    for line in warnings.splitlines():
        said = _MCDC_WARNING.search(line)
        if said and Path(said.group(1)).name == generated_c.name:
            found.append(f"{generated_c.name}:{said.group(2)}:{said.group(3)}: {said.group(4)}")
    return found


def _c_figures(doc: dict[str, Any], source: Path, passed: bool, notes: list[str]) -> Coverage:
    entry = next(f for f in doc["data"][0]["files"] if Path(f["filename"]).name == source.name)
    s = entry["summary"]
    mcdc = s.get("mcdc", {"count": 0, "covered": 0})
    cov = Coverage(
        "c",
        source.name,
        Figure(s["lines"]["covered"], s["lines"]["count"]),
        Figure(s["branches"]["covered"], s["branches"]["count"]),
        Figure(mcdc["covered"], mcdc["count"]),
        passed,
        notes=sorted(set(notes)),
    )
    for f in doc["data"][0].get("functions", []):
        if not any(Path(name).name == source.name for name in f.get("filenames", [])):
            continue
        branches = f.get("branches", [])
        taken = sum((b[4] > 0) + (b[5] > 0) for b in branches)
        conditions = [c for r in f.get("mcdc_records", []) for c in r[-1]]
        cov.functions[f["name"]] = {
            "branches": Figure(taken, 2 * len(branches)),
            "mcdc": Figure(sum(conditions), len(conditions)),
        }
    for b in entry.get("branches", []):
        if b[4] == 0 or b[5] == 0:
            side = "true" if b[4] == 0 else "false"
            cov.gaps.append(Gap(b[0], f"branch at column {b[1]} never {side}"))
    for record in entry.get("mcdc_records", []):
        flags = record[-1] if isinstance(record[-1], list) else []
        for k, covered in enumerate(flags):
            if not covered:
                what = f"MC/DC condition {k + 1} of the decision at column {record[1]}"
                cov.gaps.append(Gap(record[0], what, condition=(k, len(flags))))
    return cov
