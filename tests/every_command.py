"""One spec through every code-side command, as a user runs them: the rule random machines are held to is that
the loader (or the generator) refuses the spec in one line at its place, or every check passes.

Used by tests/test_random_machines.py (a bounded number in the suite) and bench/bench_random.py (thousands)."""

from __future__ import annotations

import contextlib
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

from mlca_verify.cli import main

CONFORM = "compile,exhaustive,sequences,frama-c-wp,cppcheck"
_AT = re.compile(r"^.+?:\d+:\d+: error: ")
# a variable leaves its declared range on some run (range:<name> is violated): the spec's fault, which WP reports
_SPEC_FAULT = "does not hold for every param in range"


@dataclass
class Outcome:
    refused: str = ""  # the one line the loader or generator refused the spec with
    failed: list[str] = field(default_factory=list)  # what failed, command by command
    spec_fault: str = ""  # conform failed for the spec's own fault only (a variable leaves its declared range)


def _run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def _refusal(code: int, err: str) -> str | None:
    """The refusal line, if the command refused the spec as the contract says (exit 2, one line, its place)."""
    lines = err.strip().splitlines()
    if code == 2 and len(lines) == 1 and _AT.match(lines[0]):
        return lines[0]
    return None


def through_every_command(spec: Path, work: Path, sequences: int = 50) -> Outcome:
    """check, gen, conform (the checks the rule names) and tests on `spec`, in `work`."""
    outcome = Outcome()
    code, _, err = _run(["check", "--quiet", str(spec)])
    if code == 2:
        outcome.refused = _refusal(code, err) or ""
        if not outcome.refused:
            outcome.failed.append(f"check: exit 2 without one located line: {err.strip()[:300]}")
        return outcome
    generated = work / "gen"
    code, _, err = _run(["gen", "--out", str(generated), str(spec)])
    if code != 0:
        outcome.refused = _refusal(code, err) or ""
        if not outcome.refused:
            outcome.failed.append(f"gen: exit {code}: {err.strip()[:300]}")
        return outcome
    argv = ["conform", "--only", CONFORM, "--sequences", str(sequences), "--generated", str(generated), str(spec)]
    code, out, err = _run(argv)
    failing = [line.strip() for line in out.splitlines() if "  FAIL  " in line]
    if code != 0 and failing and all(_SPEC_FAULT in line for line in failing):
        outcome.spec_fault = failing[0]
    elif code != 0:
        outcome.failed.append(f"conform: exit {code}: {'; '.join(failing)[:600] or err.strip()[:300]}")
    code, out, err = _run(["tests", "--no-target", "--generated", str(generated), "--out", str(work / "t"), str(spec)])
    if code != 0:
        failing = [line.strip() for line in out.splitlines() if "FAIL" in line]
        outcome.failed.append(f"tests: exit {code}: {'; '.join(failing)[:600] or err.strip()[:300]}")
    return outcome
