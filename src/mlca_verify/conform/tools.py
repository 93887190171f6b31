"""External tools: find them, run them with a timeout, and say clearly what is missing."""

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
    command: Sequence[str], timeout: float = 300, cwd: Path | None = None, env: dict[str, str] | None = None
) -> Ran:
    """Run a tool; a missing tool or a hang is a `ToolError`, a non-zero exit is for the caller to judge."""
    require(command[0])
    try:
        done = subprocess.run(
            list(command),
            cwd=cwd,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise ToolError(f"error: {command[0]} did not finish within {timeout:.0f} s") from None
    return Ran(tuple(command), done.returncode, done.stdout)
