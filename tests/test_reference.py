"""docs/reference/commands.md is what the argument parsers say: a flag added, renamed or explained anew without
running scripts/reference.py fails here."""

from __future__ import annotations

from mlca_verify.cli import COMMANDS
from scripts.reference import OUT, reference


def test_the_command_reference_is_what_the_parsers_say() -> None:
    assert OUT.read_text(encoding="utf-8") == reference(), "run .venv/bin/python scripts/reference.py"


def test_the_reference_has_every_command_and_every_flag() -> None:
    text = reference()
    for name in COMMANDS:
        assert f"### `mlca-verify {name}`" in text
    for flag in ("--parametric", "--timeout-ms", "--traces", "--sequences", "--no-target", "--readings", "--ray"):
        assert f"`{flag}`" in text
