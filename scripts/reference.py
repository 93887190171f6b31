"""Write docs/reference/commands.md, the reference of every command and flag, from the argument parsers themselves.

tests/test_reference.py fails when the committed file differs from what the parsers give; run
`.venv/bin/python scripts/reference.py` to rewrite it after changing a command.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "reference" / "commands.md"

INTRO = """# Commands

Every command and flag of `mlca-verify` and `mlca-sim`, generated from their argument parsers by
`scripts/reference.py` (a test fails when this file and the parsers differ).

Exit codes, the same for every command: 0 when everything is as expected; 1 on a finding (a verdict other than
expected, a failed check, drift); 2 on a usage error, a spec error or a missing tool, with one line on standard
error saying what and where (a spec's file, line and column); 3 on an internal error, whose traceback `--debug`
prints; 130 when interrupted (Ctrl-C), after saying what was kept.
"""


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _name(action: argparse.Action) -> str:
    if not action.option_strings:
        many = {"+": " (one or more)", "*": " (any number)"}.get(str(action.nargs), "")
        return f"`{action.metavar or action.dest}`{many}"
    flags = ", ".join(f"`{o}`" for o in action.option_strings)
    if action.nargs == 0:
        return flags
    shown = action.metavar or ("CHOICE" if action.choices else action.dest.upper())
    return f"{flags} `{shown}`" + (" ..." if action.nargs in ("+", "*") else "")


def _default(action: argparse.Action) -> str:
    if action.nargs == 0 or action.default in (None, argparse.SUPPRESS) or action.required:
        return "required" if action.required and action.option_strings else ""
    return f"`{action.default}`"


def _arguments(parser: argparse.ArgumentParser) -> list[str]:
    rows = ["| argument | default | meaning |", "|---|---|---|"]
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        meaning = [_cell(action.help or "")]
        if action.choices:
            meaning.append(f"one of {', '.join(f'`{c}`' for c in action.choices)}")
        rows.append(f"| {_name(action)} | {_default(action)} | {'; '.join(m for m in meaning if m)} |")
    return rows


def _commands(program: str, parser: argparse.ArgumentParser) -> list[str]:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {a.dest: a.help or "" for a in sub._choices_actions}
    lines = [f"## `{program}`", "", _cell(parser.description or ""), ""]
    top = [a for a in parser._actions if a.option_strings and not isinstance(a, argparse._HelpAction)]
    if top:
        lines += ["Before the command:", "", *_arguments_of(top), ""]
    for name, command in sub.choices.items():
        usage = " ".join(command.format_usage().split()).removeprefix("usage: ")
        lines += [f"### `{program} {name}`", "", f"{_cell(helps.get(name, ''))}.", "", f"`{usage}`", ""]
        lines += [*_arguments(command), ""]
    return lines


def _arguments_of(actions: list[argparse.Action]) -> list[str]:
    holder = argparse.ArgumentParser(add_help=False)
    holder._actions = actions
    return _arguments(holder)


def reference() -> str:
    """The whole reference, as the parsers say it today."""
    from mlca_verify.cli import _parser as verify_parser
    from sim_check.cli import _parser as sim_parser

    lines = [INTRO]
    lines += _commands("mlca-verify", verify_parser())
    lines += _commands("mlca-sim", sim_parser())
    return "\n".join(lines).rstrip() + "\n"


if __name__ == "__main__":
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(reference(), encoding="utf-8")
    print(f"wrote {OUT.relative_to(ROOT)}")
    sys.exit(0)
