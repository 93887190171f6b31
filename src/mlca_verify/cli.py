"""The command line: parse arguments, call the library, print, return an exit code.

Exit codes everywhere: 0 every verdict as expected, 1 a finding, 2 bad input or usage (one line on stderr).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from mlca_verify import __version__, report
from mlca_verify.errors import MlcaError, UsageError
from mlca_verify.logic import check_all, compare
from mlca_verify.logic.results import Result
from mlca_verify.logic.solver import DEFAULT_TIMEOUT_MS
from mlca_verify.spec import LoadedSpec, load_spec

EXIT_OK, EXIT_FINDING, EXIT_USAGE = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(f"{self.prog}: error: {message}")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="mlca-verify", description="Prove, compare and generate the MLCA lane-change machine.")
    parser.add_argument("--version", action="version", version=f"mlca-verify {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    check = sub.add_parser("check", help="prove every built-in check and declared property of each spec")
    check.add_argument("specs", nargs="+", metavar="SPEC", help="spec files (TOML)")
    check.add_argument("--json", metavar="FILE", help="also write the results as JSON (schema mlca-verify.check/1)")
    check.add_argument("--only", metavar="IDS", help="comma-separated property names to report (others are hidden)")
    check.add_argument("--quiet", action="store_true", help="print only the one-line summary per spec")
    check.add_argument("--timeout-ms", type=int, default=DEFAULT_TIMEOUT_MS, help="timeout of each solver query")

    diff = sub.add_parser("diff", help="where two machines behave differently, and the shortest sequence showing it")
    diff.add_argument("left", metavar="A", help="first spec")
    diff.add_argument("right", metavar="B", help="second spec")
    diff.add_argument("--timeout-ms", type=int, default=DEFAULT_TIMEOUT_MS, help="timeout of each solver query")
    return parser


def _write_json(path: str, document: object) -> None:
    try:
        Path(path).write_text(json.dumps(document, indent=2, sort_keys=False) + "\n", encoding="utf-8")
    except OSError as err:
        raise UsageError(f"{path}: error: cannot write: {err.strerror or err}") from None


def _select(results: list[Result], only: str | None) -> list[Result]:
    if only is None:
        return results
    wanted = [w.strip() for w in only.split(",") if w.strip()]
    known = {r.prop for r in results}
    missing = [w for w in wanted if w not in known]
    if missing:
        raise UsageError(f"error: --only names unknown properties: {', '.join(missing)}")
    return [r for r in results if r.prop in wanted]


def cmd_check(args: argparse.Namespace) -> int:
    loaded: list[LoadedSpec] = [load_spec(p) for p in args.specs]
    outcomes = []
    all_ok = True
    for spec in loaded:
        results = _select(check_all(spec.machine, args.timeout_ms), args.only)
        all_ok &= all(r.ok for r in results)
        outcomes.append((spec.path, spec.sha256, spec.machine.name, results))
        if not args.quiet:
            print(report.results_text(spec.path, spec.machine.name, results, spec.machine.input_names))
        print(f"{spec.path}: {report.summary_text(results)}\n")
    if args.json:
        _write_json(args.json, report.check_document(outcomes))
    return EXIT_OK if all_ok else EXIT_FINDING


def cmd_diff(args: argparse.Namespace) -> int:
    left, right = load_spec(args.left, compare=False), load_spec(args.right, compare=False)
    found = compare(left.machine, right.machine, args.timeout_ms, all_regions=True)
    names = left.machine.input_names + tuple(n for n in right.machine.input_names if n not in left.machine.input_names)
    print(report.diff_text(left.machine.name, right.machine.name, found, names))
    return {"holds": EXIT_OK, "violated": EXIT_FINDING, "unknown": EXIT_FINDING}[found.verdict]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; return the exit code. User mistakes print one line on stderr and return 2."""
    try:
        args = _parser().parse_args(argv)
        command = {"check": cmd_check, "diff": cmd_diff}[args.command]
        return command(args)
    except MlcaError as err:
        print(str(err).splitlines()[0], file=sys.stderr)
        return EXIT_USAGE


def entry() -> None:
    sys.exit(main())
