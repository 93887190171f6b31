"""External tools: find them, run them with a timeout, and say clearly what is missing; build a shared library."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from mlca_verify.errors import ToolError

SETUP_HINT = "run `bash scripts/setup.sh`, which installs it"
C_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wconversion")


@dataclass(frozen=True)
class Ran:
    command: tuple[str, ...]
    returncode: int
    output: str  # stdout and stderr together


def require(tool: str) -> str:
    path = shutil.which(tool)
    if path is None:
        raise ToolError(f"error: {tool} not found; {SETUP_HINT}")
    return path


def run(
    command: Sequence[str],
    timeout: float = 300,
    cwd: Path | None = None,
    env: dict[str, str] | None = None,
    stdin: str | None = None,
) -> Ran:
    """Run a tool; a missing tool or a hang is a `ToolError`, a non-zero exit is for the caller to judge.

    Without `stdin` the output is stdout and stderr together; with it (a filter such as `dot`), stdout alone
    unless the tool fails."""
    require(command[0])
    try:
        done = subprocess.run(
            list(command),
            cwd=cwd,
            env=env,
            input=stdin,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT if stdin is None else subprocess.PIPE,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise ToolError(f"error: {command[0]} did not finish within {timeout:.0f} s") from None
    output = done.stdout if done.returncode == 0 or stdin is None else done.stdout + (done.stderr or "")
    return Ran(tuple(command), done.returncode, output)


def build_shared(c_file: Path, out: Path, extra: tuple[str, ...] = ()) -> Ran:
    """Compile `c_file` (and any sources in `extra`) into the shared library `out`, with the project's warnings
    as errors."""
    return run(["gcc", *C_FLAGS, *extra, "-O2", "-shared", "-fPIC", "-o", str(out), str(c_file)], timeout=120)
