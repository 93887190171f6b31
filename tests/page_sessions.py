"""A docs page's terminal session, run: a `text` block whose lines starting with `$ ` are commands of the two
CLIs (joined by `&&`) and whose other lines are what they print. Each command runs in the repository's root, as
the page shows it, with the report file it names (`check.json`) kept in a temporary folder."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from mlca_verify.cli import main as verify
from sim_check.cli import main as sim_main
from tests.conftest import ROOT

SESSION = re.compile(r"```text\n(\$ .*?)```", re.DOTALL)
MAINS = {"mlca-verify": verify, "mlca-sim": sim_main}


def sessions(page: Path, starting: str) -> list[list[tuple[str, str]]]:
    """The page's sessions whose first command starts with `starting`, each as (command, its output) pairs."""
    found = []
    for block in SESSION.findall(page.read_text(encoding="utf-8")):
        pairs = [
            (part.split("\n", 1)[0], part.split("\n", 1)[1] if "\n" in part else "")
            for part in re.split(r"^\$ ", block, flags=re.MULTILINE)
            if part
        ]
        if pairs[0][0].startswith(starting):
            found.append(pairs)
    return found


def run_session(pairs: list[tuple[str, str]], work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Run each command of the session and compare what it prints with the page; exit codes as `&&` needs them."""
    for command, shown in pairs:
        steps = command.split(" && ")
        for k, step in enumerate(steps):
            args = [str(work / a) if a == "check.json" else a for a in shlex.split(step)]
            with pytest.MonkeyPatch.context() as patch:
                patch.chdir(ROOT)
                code = MAINS[args[0]](args[1:])
            assert code == 0 or k == len(steps) - 1, f"{step}: exit {code}"
        printed = capsys.readouterr().out.replace(str(work) + "/", "")
        assert printed == shown, f"$ {command}"
