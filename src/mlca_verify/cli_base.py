"""What every command line of the project shares: the exit codes, an argument parser whose mistakes are one-line
errors, and the guard that turns any failure into one line on stderr and an exit code, never a traceback.

Exit codes: 0 every verdict as expected, 1 a finding, 2 bad input or usage (and a file that cannot be read or
written), 3 an internal error (a bug: the traceback is printed only with `--debug`), 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import traceback
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from mlca_verify.errors import MlcaError, UsageError
from mlca_verify.escape import terminal
from mlca_verify.files import write_atomic

EXIT_OK, EXIT_FINDING, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report Ctrl-C
DEBUG_FLAG = "--debug"

Command = Callable[[argparse.Namespace], int]


class Parser(argparse.ArgumentParser):
    """argparse that raises `UsageError` (one line, exit 2) instead of printing usage and exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError.at(self.prog, f"{message}")


DEPTH_LIMIT = 1_000  # steps of a search: `check --depth` and `tests --depth` alike
TIMEOUT_LIMIT_MS = 3_600_000  # one solver query


def whole_number(low: int, high: int) -> Callable[[str], int]:
    """An argparse type: a whole number from `low` to `high`, written in digits (no exponent, no fraction)."""

    def parse(text: str) -> int:
        if not re.fullmatch(r"\s*[+-]?[0-9]{1,19}\s*", text):
            raise argparse.ArgumentTypeError(f"not a whole number: {text[:40]!r}")
        value = int(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be from {low} to {high}, got {text.strip()}")
        return value

    return parse


def write_text(path: str, text: str) -> None:
    """Write an output file whole (mlca_verify.files); a file that cannot be written is a one-line error."""
    try:
        write_atomic(Path(path), text)
    except OSError as err:
        raise UsageError.at(path, f"cannot write: {err.strerror or err}") from None


def write_json(path: str, document: object) -> None:
    """An output JSON document, indented, written whole."""
    write_text(path, json.dumps(document, indent=2, sort_keys=False) + "\n")


def _say(text: str) -> None:
    print(terminal(text.splitlines()[0] if text.strip() else text.strip()), file=sys.stderr)


def _os_error(err: OSError) -> str:
    where = f"{err.filename}: " if err.filename is not None else ""
    return f"{where}error: {err.strerror or err}"


def run_guarded(
    prog: str, parser: argparse.ArgumentParser, commands: Mapping[str, Command], argv: Sequence[str]
) -> int:
    """Parse `argv` (which may hold `--debug` anywhere) and run its command; every failure becomes one line."""
    debug = DEBUG_FLAG in argv
    try:
        args = parser.parse_args([a for a in argv if a != DEBUG_FLAG])
        return commands[args.command](args)
    except MlcaError as err:
        _say(str(err))
        return EXIT_USAGE
    except BrokenPipeError:  # the reader went away: `entry` ends quietly
        raise
    except OSError as err:  # a file or folder the user named that cannot be read or written
        _say(_os_error(err))
        return EXIT_USAGE
    except Exception as err:  # a bug of ours: one line (the traceback with --debug), never a finding's exit 1
        if debug:
            traceback.print_exc()
        _say(f"{prog}: internal error: {type(err).__name__}: {err} (run again with --debug for the traceback)")
        return EXIT_INTERNAL


def entry(main: Callable[[], int]) -> None:
    """Run `main` as a console script: a closed output pipe is not an error, Ctrl-C is exit 130."""
    try:
        code = main()
        sys.stdout.flush()
    except BrokenPipeError:  # the reader went away (`| head`): not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        code = EXIT_OK
    except KeyboardInterrupt:  # Ctrl-C: output files are written whole or not at all (mlca_verify.files)
        print("\ninterrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    sys.exit(code)
