"""The command line: parse arguments, call the library, print, return an exit code.

Exit codes everywhere: 0 every verdict as expected, 1 a finding, 2 bad input or usage (one line on stderr),
3 an internal error (one line; the traceback with --debug), 130 interrupted (mlca_verify.cli_base).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mlca_verify import check_report, ci_formats, cli_base, network_chart, waves
from mlca_verify.cli_base import (
    DEPTH_LIMIT,
    EXIT_FINDING,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
    TIMEOUT_LIMIT_MS,
    Parser,
    whole_number,
    write_json,
    write_text,
)
from mlca_verify.conformance import CONFORM_SCHEMA
from mlca_verify.conformance.outcome import CHECKS
from mlca_verify.diagram import FORMATS
from mlca_verify.errors import Loc, ToolError, UsageError
from mlca_verify.escape import terminal
from mlca_verify.files import read_regular, write_atomic
from mlca_verify.json_types import JsonObject
from mlca_verify.logic import check_all, equivalence
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.results import Result
from mlca_verify.logic.solver import DEFAULT_TIMEOUT_MS
from mlca_verify.model import show
from mlca_verify.network_report import check_network, network_assumptions, network_json
from mlca_verify.spec import LoadedSpec, load_spec, machine_specs, names_a_network
from mlca_verify.spec.cites import uncited
from mlca_verify.spec_diff import transition_changes, verdict_changes
from mlca_verify.testgen import DEPTH
from mlca_verify.version import __version__
from mlca_verify.words import count

__all__ = ["EXIT_FINDING", "EXIT_INTERRUPTED", "EXIT_OK", "EXIT_USAGE", "Parser", "entry", "main", "write_json"]


DEPTH_ARG = whole_number(1, DEPTH_LIMIT)
TIMEOUT_ARG = whole_number(1, TIMEOUT_LIMIT_MS)


def _parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="mlca-verify",
        description="Prove state machines written as a spec, compare them, and generate their code and evidence.",
    )
    parser.add_argument("--version", action="version", version=f"mlca-verify {__version__}")
    parser.add_argument(cli_base.DEBUG_FLAG, action="store_true", help="print the traceback of an internal error")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)

    check = sub.add_parser("check", help="prove every built-in check and declared property of each spec")
    check.add_argument("specs", nargs="+", metavar="SPEC", help="spec files (TOML)")
    check.add_argument(
        "--json", metavar="FILE", help=f"also write the results as JSON (schema {check_report.CHECK_SCHEMA})"
    )
    check.add_argument(
        "--parametric",
        action="store_true",
        help="prove the properties of machines with data for every param value in its range (not only the default)",
    )
    check.add_argument(
        "--depth",
        type=DEPTH_ARG,
        default=60,
        metavar="N",
        help=f"steps BMC searches for a counterexample (1 to {DEPTH_LIMIT})",
    )
    check.add_argument("--require-cites", action="store_true", help="report every spec element that cites no source")
    check.add_argument("--only", metavar="IDS", help="comma-separated property names to report (others are hidden)")
    check.add_argument("--quiet", action="store_true", help="print only the one-line summary per spec")
    check.add_argument(
        "--timeout-ms",
        type=TIMEOUT_ARG,
        default=DEFAULT_TIMEOUT_MS,
        help="budget of each solver query: z3's resources for about this many ms, not a clock",
    )
    check.add_argument("--junit", metavar="FILE", help="also write JUnit XML: one test case per property")
    check.add_argument("--sarif", metavar="FILE", help="also write SARIF 2.1.0: findings at their spec lines")
    check.add_argument("--emit-tests", metavar="DIR", help="write a pytest and a C test replaying each violation")
    check.add_argument("--smt2", metavar="DIR", help="write each lemma's query as SMT-LIB 2 (unsat: it holds)")
    check.add_argument(
        "--traces",
        metavar="DIR",
        help="write each counterexample as CSV and as VCD (a waveform, for GTKWave); a network's also as an SVG chart",
    )
    check.add_argument("--generated", default="generated", metavar="DIR", help="generated code the tests use")
    _allow_outside(check)

    diff = sub.add_parser(
        "diff",
        help="regression gate: verdicts, transitions and behaviour that changed from OLD to NEW (of a network: "
        "its verdicts and what its channels allow)",
    )
    diff.add_argument("left", metavar="OLD", help="the spec before the change")
    diff.add_argument("right", metavar="NEW", help="the spec after the change")
    diff.add_argument(
        "--timeout-ms",
        type=TIMEOUT_ARG,
        default=DEFAULT_TIMEOUT_MS,
        help="budget of each solver query: z3's resources for about this many ms, not a clock",
    )
    _allow_outside(diff)

    gen = sub.add_parser("gen", help="generate Python and C99 code from specs (or check generated/ for drift)")
    gen.add_argument(
        "specs", nargs="*", metavar="SPEC", help="spec files (default: spec/*.toml and the networks in spec/*/)"
    )
    gen.add_argument("--out", default="generated", metavar="DIR", help="output folder (default: generated)")
    gen.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 when DIR differs from what is generated"
    )

    conform = sub.add_parser("conform", help="prove and test that the generated code implements its spec")
    conform.add_argument("specs", nargs="+", metavar="SPEC", help="spec files")
    conform.add_argument(
        "--generated", default="generated", metavar="DIR", help="where the code is (default: generated)"
    )
    conform.add_argument("--json", metavar="FILE", help=f"also write the results as JSON (schema {CONFORM_SCHEMA})")
    conform.add_argument("--only", metavar="CHECKS", help=f"comma-separated subset of: {', '.join(CHECKS)}")
    conform.add_argument(
        "--sequences", type=whole_number(1, 100_000), default=200, help="random input sequences to run (default 200)"
    )

    diagram = sub.add_parser(
        "diagram", help="draw a machine (Graphviz DOT, Mermaid, W3C SCXML, or SVG), or a network of machines"
    )
    diagram.add_argument("spec", metavar="SPEC", help="spec file")
    diagram.add_argument("--format", choices=[*FORMATS, "svg"], default="dot", help="output format (default dot)")
    diagram.add_argument("--out", metavar="FILE", help="write to FILE instead of standard output")

    _tests_parser(sub)
    _schema_parser(sub)

    evidence = sub.add_parser("evidence", help="write a self-contained safety-case bundle (evidence.json, index.html)")
    evidence.add_argument("spec", metavar="SPEC", help="the spec of the generated controller")
    evidence.add_argument("--out", required=True, metavar="DIR", help="output folder")
    _allow_outside(evidence)
    evidence.add_argument("--db", metavar="RESULTS", help="closed-loop results database (SQLite) to include")
    evidence.add_argument(
        "--no-tests", action="store_true", help="leave out the generated test suite and its coverage (faster)"
    )
    evidence.add_argument(
        "--replay", metavar="FILE", help="SUMO replays of the lemmas' counterexamples (mlca-sim replay --json)"
    )
    evidence.add_argument(
        "--generated", default="generated", metavar="DIR", help="where the code is (default: generated)"
    )
    evidence.add_argument(
        "--readings",
        nargs="*",
        metavar="SPEC",
        default=None,
        help="readings to show side by side, canonical first (default for the shipped specs: spec/mlca.toml "
        "spec/paper/*.toml; for another spec: none)",
    )
    return parser


# the reports `schema --report` writes the JSON Schema of (mlca_verify.report_schemas.REPORTS, which a test holds
# this to; that module is imported when a schema is asked for)
REPORTS = ("check", "conform", "tests", "evidence", "network-evidence")


def _schema_parser(sub: Any) -> None:
    schema = sub.add_parser(
        "schema",
        help="write the JSON Schema of the spec format, for editors that validate and complete TOML, or of a JSON "
        "report",
    )
    schema.add_argument("--out", metavar="FILE", help="write to FILE instead of standard output")
    schema.add_argument(
        "--report",
        choices=REPORTS,
        help="write the schema of this report instead: check --json, conform --json, the coverage.json of tests, "
        "evidence.json, or the evidence.json of a network",
    )


def _tests_parser(sub: Any) -> None:
    tests = sub.add_parser(
        "tests",
        help="generate requirements-based tests to MC/DC, measure their coverage of the generated code, and run "
        "them on a Cortex-M4 under QEMU",
    )
    tests.add_argument("specs", nargs="+", metavar="SPEC", help="spec files")
    tests.add_argument("--out", required=True, metavar="DIR", help="output folder (one subfolder per machine)")
    tests.add_argument("--generated", default="generated", metavar="DIR", help="where the code is (default: generated)")
    tests.add_argument(
        "--depth", type=DEPTH_ARG, default=DEPTH, help=f"the longest run searched (default {DEPTH}, 1 to {DEPTH_LIMIT})"
    )
    tests.add_argument("--no-coverage", action="store_true", help="write and run the suite, measure nothing")
    tests.add_argument("--no-target", action="store_true", help="do not run the suite on the Cortex-M4 under QEMU")


def say(*parts: object, **options: Any) -> None:
    """print, with spec text (paths, names, cites) kept to visible characters: no control sequence reaches the
    terminal; line breaks are kept."""
    print(*("\n".join(terminal(line) for line in str(part).split("\n")) for part in parts), **options)


def _allow_outside(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--allow-outside",
        action="store_true",
        help="let [[compare]] name specs outside the spec's folder tree and the working directory's",
    )


def _select(results: list[Result], only: str | None) -> list[Result]:
    if only is None:
        return results
    wanted = [w.strip() for w in only.split(",") if w.strip()]
    known = {r.prop for r in results}
    missing = [w for w in wanted if w not in known]
    if missing:
        raise UsageError(f"error: --only names unknown properties: {', '.join(missing)}")
    return [r for r in results if r.prop in wanted]


def _check(spec: LoadedSpec, timeout_ms: int, parametric: bool, limits: Limits) -> list[Result]:
    """Every verdict of a machine; a network's own properties (see `network_report.check_network`)."""
    if spec.network is None:
        return check_all(spec.machine, timeout_ms, parametric, limits)
    return check_network(spec.network, spec.machine, limits, parametric)


def _checked(spec: LoadedSpec, results: list[Result]) -> check_report.Checked:
    """A spec's part of the `check --json` document; a network's with what it is and its runs' messages."""
    if spec.network is None:
        return check_report.Checked(spec.path, spec.sha256, spec.machine.name, results)
    return check_report.Checked(
        spec.path, spec.sha256, spec.machine.name, results,
        network_json(spec.network), network_chart.messages_json(spec.network, results),
    )  # fmt: skip


def cmd_check(args: argparse.Namespace) -> int:
    loaded: list[LoadedSpec] = [load_spec(p, confine=not args.allow_outside, network=True) for p in args.specs]
    checked: list[tuple[LoadedSpec, list[Result]]] = []
    limits = Limits(depth=args.depth, timeout_ms=args.timeout_ms)
    missing: list[tuple[str, Loc, str]] = []
    for spec in loaded:
        if args.require_cites:
            for loc, what in uncited(spec.machine):
                say(f"{loc}: uncited {what}")
                missing.append((spec.path, loc, what))
        results = _select(_check(spec, args.timeout_ms, args.parametric, limits), args.only)
        checked.append((spec, results))
        if not args.quiet:
            assumed = [f"{a.id}: {show(a.expr)}" for a in spec.machine.assumptions]
            assumed = assumed if spec.network is None else network_assumptions(spec.network)
            charts = None if spec.network is None else network_chart.charts(spec.network, results)
            text = check_report.results_text(
                spec.path, spec.machine.name, results, spec.machine.input_names, assumed,
                reals=spec.machine.reals, charts=charts,
            )  # fmt: skip
            say(text)
        say(f"{spec.path}: {check_report.summary_text(results)}\n")
    if args.json:
        write_json(args.json, check_report.check_document([_checked(s, r) for s, r in checked]))
    for_ci = [(s.path, s.machine, r) for s, r in checked]
    if args.junit:
        write_text(args.junit, ci_formats.junit_xml(for_ci))
    if args.sarif:
        related = {
            (s.path, prop): places
            for s, r in checked
            if s.network is not None
            for prop, places in network_chart.lost_at(s.network, r).items()
        }
        write_json(args.sarif, ci_formats.sarif(for_ci, missing, related))
    if args.emit_tests:
        _emit_tests(checked, Path(args.generated), Path(args.emit_tests))
    if args.smt2:
        _write_smt2(loaded, Path(args.smt2), args.parametric, args.timeout_ms)
    if args.traces:
        _write_traces(checked, Path(args.traces))
    if missing:
        say(f"{len(missing)} spec elements cite no source (--require-cites)")
    every_ok = all(r.ok for _, results in checked for r in results)
    return EXIT_OK if every_ok and not missing else EXIT_FINDING


def _write_smt2(loaded: list[LoadedSpec], out: Path, parametric: bool, timeout_ms: int) -> None:
    from mlca_verify.logic.lemmas import lemma_scripts

    scripts = {
        name: text for spec in loaded for name, text in lemma_scripts(spec.machine, parametric, timeout_ms).items()
    }
    try:
        out.mkdir(parents=True, exist_ok=True)
        for name, text in scripts.items():
            write_atomic(out / name, text)
            say(f"wrote {terminal(str(out / name))}")
    except OSError as err:
        raise UsageError.at(out, f"cannot write SMT-LIB files: {err.strerror or err}") from None


def _write_traces(checked: list[tuple[LoadedSpec, list[Result]]], out: Path) -> None:
    taken: set[str] = set()
    try:
        out.mkdir(parents=True, exist_ok=True)
        for spec, results in checked:
            for r in results:
                cx = r.counterexample
                if cx is None or not cx.steps:
                    continue
                stem = waves.file_stem(spec.machine.name, r.prop, taken)
                write_atomic(out / f"{stem}.csv", waves.trace_csv(cx))
                files = [f"{stem}.csv"]
                if not cx.point:
                    title = f"{r.prop} ({r.verdict}) of {spec.machine.name}, {len(cx.steps)} steps"
                    write_atomic(out / f"{stem}.vcd", waves.trace_vcd(spec.machine, cx, title, __version__))
                    files.append(f"{stem}.vcd")
                if spec.network is not None and not cx.point:
                    write_atomic(out / f"{stem}.svg", network_chart.chart_svg(spec.network, cx, title))
                    files.append(f"{stem}.svg")
                say(f"wrote {', '.join(terminal(str(out / f)) for f in files)}")
    except OSError as err:
        raise UsageError.at(out, f"cannot write traces: {err.strerror or err}") from None


def _emit_tests(checked: list[tuple[LoadedSpec, list[Result]]], generated: Path, out: Path) -> None:
    from mlca_verify.regression_tests import emit

    for spec, results in checked:
        if spec.machine.semantics != "first-match":
            say(f"{spec.path}: no tests emitted: a nondeterministic machine has no generated code")
            continue
        if spec.network is not None:
            say(f"{spec.path}: no tests emitted: a network's instances are tested through their own specs")
            continue
        try:
            written = emit(spec, results, generated, out)
        except OSError as err:
            raise UsageError.at(out, f"cannot write tests: {err.strerror or err}") from None
        for path in written:
            say(f"wrote {path}")


def cmd_diff(args: argparse.Namespace) -> int:
    from mlca_verify.logic.property_diff import property_changes

    old, new = (load_spec(p, confine=not args.allow_outside, network=True) for p in (args.left, args.right))
    if old.network is not None or new.network is not None:
        return _diff_networks(old, new, args.timeout_ms)
    changes = verdict_changes(check_all(old.machine, args.timeout_ms), check_all(new.machine, args.timeout_ms))
    say(f"old: {old.path} ({old.machine.name})\nnew: {new.path} ({new.machine.name})\n")
    say(check_report.regression_text(changes, transition_changes(old.machine, new.machine)))
    was, now = old.machine.fallback_state, new.machine.fallback_state
    if was != now:  # the generated code's answer to a corrupted context: no verdict speaks of it
        say(f"fallback: a context whose state names no state now restarts in {now} (was {was})\n")
    meaning = property_changes(old.machine, new.machine, args.timeout_ms)
    say(check_report.meaning_text(meaning))
    _say_equivalence(old, new, args.timeout_ms)
    regressions = [c.prop for c in changes if c.regression]
    weakened = [c.prop for c in meaning if c.regression and c.kind != "assumption" and c.prop not in regressions]
    narrowed = [
        f"{c.prop.removeprefix('[[assume]]').strip() or 'the assumptions'} allow fewer environments"
        for c in meaning
        if c.kind == "assumption" and c.regression
    ]
    return _gate(len(changes), regressions, weakened, narrowed)


def _gate(changed: int, regressions: list[str], weakened: list[str], narrowed: list[str]) -> int:
    """The regression gate's last lines and exit code: properties that no longer hold, properties that guarantee
    less, and assumptions (each said as what narrowed) that allow fewer environments."""
    if regressions:
        say(f"\n{count(len(regressions), 'regression')}: {', '.join(regressions)} held before and no longer hold")
    lead = "" if regressions else "\n"
    if weakened:
        verb = "guarantees" if len(weakened) == 1 else "guarantee"
        say(f"{lead}{len(weakened)} weakened: {', '.join(weakened)} now {verb} less than before (a regression)")
        lead = ""
    for what in narrowed:
        say(f"{lead}assumptions narrowed: {what}, so every guarantee is weaker (a regression)")
        lead = ""
    if regressions or weakened or narrowed:
        return EXIT_FINDING
    say(f"\nno regression: every property that held before still holds ({count(changed, 'verdict')} changed)")
    return EXIT_OK


def _diff_networks(old: LoadedSpec, new: LoadedSpec, timeout_ms: int) -> int:
    """Two versions of a network: its own verdicts, what it assumes (schedule, channels) by the runs each allows,
    its instances, and its properties by meaning."""
    from mlca_verify.logic.property_diff import property_changes
    from mlca_verify.network_diff import network_changes, network_changes_text

    if old.network is None or new.network is None:
        machine = old if old.network is None else new
        raise UsageError.at(Path(machine.path), "a machine spec: `diff` compares a network with a network")
    limits = Limits(timeout_ms=timeout_ms)
    before, after = (check_network(s.network, s.machine, limits) for s in (old, new) if s.network is not None)
    changes = verdict_changes(before, after)
    say(f"old: {old.path} ({old.machine.name})\nnew: {new.path} ({new.machine.name})\n")
    say(check_report.regression_text(changes, None))
    assumed = network_changes(old.network, new.network)
    say(network_changes_text(assumed))
    meaning = property_changes(old.machine, new.machine, timeout_ms, assumptions=False)
    say(check_report.meaning_text(meaning))
    regressions = [c.prop for c in changes if c.regression]
    weakened = [c.prop for c in meaning if c.regression and c.prop not in regressions]
    narrowed = [c.what for c in assumed if c.regression]
    said = [f"{', '.join(narrowed)} allow fewer or other environments"] if narrowed else []
    return _gate(len(changes), regressions, weakened, said)


def _say_equivalence(old: LoadedSpec, new: LoadedSpec, timeout_ms: int) -> None:
    found = equivalence(old.machine, new.machine, timeout_ms)
    if found is None:
        say("equivalence: not compared (machines with data are compared by their verdicts only)")
        return
    names = old.machine.input_names + tuple(n for n in new.machine.input_names if n not in old.machine.input_names)
    say(check_report.diff_text(old.machine.name, new.machine.name, found, names))


def _default_specs() -> list[str]:
    found = sorted(str(p) for p in Path("spec").glob("*.toml"))
    if not found:
        raise UsageError("error: no SPEC given and no spec/*.toml here")
    return found


def _default_gen_specs() -> list[str]:
    """What `gen` generates with no SPEC: the machines of spec/*.toml and the networks in spec/'s folders (their
    instances' machines)."""
    return _default_specs() + sorted(str(p) for p in Path("spec").glob("*/*.toml") if names_a_network(p))


def _machines_of(loaded: list[LoadedSpec]) -> list[LoadedSpec]:
    """The machine specs the loaded specs stand for: each machine spec, and for a network spec each of its
    instances' machine specs, once (instances share their machine's code, each with a context of its own)."""
    found: dict[Path, LoadedSpec] = {}
    for spec in loaded:
        for machine in machine_specs(spec):
            found.setdefault(Path(machine.path).resolve(), machine)
    return list(found.values())


def writable_folder(folder: Path) -> None:
    """Refuse, before any long work, an output folder that cannot be created or written."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UsageError.at(folder, f"cannot create the output folder: {err.strerror or err}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError.at(folder, "the output folder is not writable")


def cmd_gen(args: argparse.Namespace) -> int:
    from mlca_verify.codegen import drift, foreign, generate, generate_frames, write

    out = Path(args.out)
    files: dict[str, str] = {}
    loaded = [load_spec(p, compare=False, network=True) for p in args.specs or _default_gen_specs()]
    generated = [(spec, generate(spec, out)) for spec in _machines_of(loaded)]
    networks = [(net, generate_frames(net, out)) for net in loaded if net.network is not None]
    for spec, new in generated + networks:
        if clash := sorted(set(new) & set(files)):
            raise UsageError.at(
                spec.path,
                f"its code would replace {out / clash[0]}, generated from another spec "
                "given here: two machines of one name need separate --out folders",
            )
        files.update(new)
    if args.check:
        problems = drift(files, out)
        for d in problems:
            say(f"{out / d.path}: {d.problem}")
        if problems:
            say(f"{len(problems)} generated files out of date: run `mlca-verify gen` and commit the result")
            return EXIT_FINDING
        say(f"{len(files)} generated files up to date in {out}/")
        return EXIT_OK
    writable_folder(out)
    if taken := foreign(files, out):
        rel, other = taken[0]
        raise UsageError.at(
            out / rel,
            f"holds the code generated from {other}; refusing to replace it with "
            "another spec's (delete it if the spec moved; two machines of one name need separate "
            "--out folders)",
        )
    for path, changed in write(files, out):
        say(f"{'wrote' if changed else 'unchanged'} {path}")
    return EXIT_OK


def _say_unexpected(spec: LoadedSpec) -> None:
    """Say first when the spec itself has a verdict other than expected: the proofs of the code (WP, which assumes
    every expected invariant) then fail because of the spec, not because of the generated code."""
    unexpected = [r.prop for r in check_all(spec.machine) if not r.ok]
    if unexpected:
        listed = ", ".join(unexpected[:5]) + (", ..." if len(unexpected) > 5 else "")
        say(
            f"  note: the spec has {len(unexpected)} unexpected verdicts ({listed}; see `mlca-verify check`): "
            "a failing check below may come from the spec, not from the generated code"
        )


def cmd_conform(args: argparse.Namespace) -> int:
    from mlca_verify.conformance import conform
    from mlca_verify.conformance.outcome import CheckOutcome

    names = list(CHECKS) if args.only is None else [n.strip() for n in args.only.split(",") if n.strip()]
    unknown = [n for n in names if n not in CHECKS]
    if unknown:
        raise UsageError(f"error: --only names unknown checks: {', '.join(unknown)} (known: {', '.join(CHECKS)})")
    names = [n for n in CHECKS if n in names]  # a set, run in the order the checks build on each other
    specs = _machines_of([load_spec(p, compare=False, network=True) for p in args.specs])  # a network: its machines
    results = []
    for spec in specs:
        say(f"{spec.path} ({spec.machine.name})")
        _say_unexpected(spec)
        width = max(len(n) for n in ["up-to-date", *names])

        def show(outcome: CheckOutcome, width: int = width) -> None:
            lines = outcome.detail.splitlines() or [""]
            status = "skip" if outcome.data.get("skipped") else "pass" if outcome.ok else "FAIL"
            say(f"  {outcome.name.ljust(width)}  {status}  {lines[0]}", flush=True)
            for line in lines[1:]:
                say(f"  {'':{width}}        {line}")

        results.append(conform(spec, Path(args.generated), names, show, sequences=args.sequences))
        ran = [o for o in results[-1].outcomes if not o.data.get("skipped")]
        skipped = len(results[-1].outcomes) - len(ran)
        note = f" ({skipped} not run)" if skipped else ""
        say(f"{spec.path}: {sum(o.ok for o in ran)} of {len(ran)} checks passed{note}\n")
    if args.json:
        write_json(args.json, {"schema": CONFORM_SCHEMA, "specs": [r.to_json() for r in results]})
    return EXIT_OK if all(r.ok for r in results) else EXIT_FINDING


def svg_of(dot_text: str) -> str:
    """Lay a DOT graph out as SVG with Graphviz."""
    from mlca_verify.tools import run

    ran = run(["dot", "-Tsvg"], timeout=60, stdin=dot_text)
    if ran.returncode != 0:
        raise ToolError(f"error: dot failed: {ran.output.strip()}")
    return ran.output


def cmd_tests(args: argparse.Namespace) -> int:
    from mlca_verify.testgen.command import tests as run_tests

    specs = [load_spec(p, compare=False) for p in args.specs]
    ok = True
    for spec in specs:
        say(f"{spec.path} ({spec.machine.name})", flush=True)
        report = run_tests(
            spec,
            Path(args.out),
            Path(args.generated),
            measure=not args.no_coverage,
            on_target=not args.no_target,
            depth=args.depth,
            say=lambda line: say(line, flush=True),
        )
        say(f"{spec.path}: {'every check passed' if report.ok else 'a check failed'}; written to {report.folder}\n")
        ok = ok and report.ok
    return EXIT_OK if ok else EXIT_FINDING


def _emit(text: str, out: str | None) -> None:
    """A command's document: to `out` when given, else to standard output."""
    if out:
        write_text(out, text)
    else:
        sys.stdout.write(text)


def cmd_diagram(args: argparse.Namespace) -> int:
    from mlca_verify.diagram import Undrawable, render_network
    from mlca_verify.diagram import render as render_diagram

    loaded = load_spec(args.spec, compare=False, network=True)
    net = loaded.network

    def draw(fmt: str) -> str:
        return render_diagram(loaded.machine, fmt) if net is None else render_network(net, fmt)

    try:
        text = svg_of(draw("dot")) if args.format == "svg" else draw(args.format)
    except Undrawable as err:
        raise UsageError.at(args.spec, str(err)) from None
    _emit(text, args.out)
    return EXIT_OK


def cmd_schema(args: argparse.Namespace) -> int:
    if args.report is None:
        from mlca_verify.spec.schema import schema_text

        _emit(schema_text(), args.out)
    else:
        from mlca_verify.report_schemas import schema_text as report_schema_text

        _emit(report_schema_text(args.report), args.out)
    return EXIT_OK


def default_readings(spec: Path) -> list[str]:
    """The readings shown beside a spec when none are given: for a spec in the same folder as spec/mlca.toml (the
    shipped machines), the paper's three readings; for any other spec, none (another machine's diagrams do not
    belong in its safety case)."""
    canonical = Path("spec") / "mlca.toml"
    if not canonical.is_file() or spec.resolve().parent != canonical.resolve().parent:
        return []
    return [str(canonical), *sorted(str(p) for p in (canonical.parent / "paper").glob("*.toml"))]


def cmd_evidence(args: argparse.Namespace) -> int:
    from mlca_verify.evidence import collect, read_closed_loop, write_bundle
    from mlca_verify.evidence import now as evidence_now

    readings = default_readings(Path(args.spec)) if args.readings is None else args.readings
    db = Path(args.db) if args.db else None
    if db is not None and not db.is_file():
        raise UsageError.at(db, "results database not found")
    writable_folder(Path(args.out))
    spec = load_spec(args.spec, confine=not args.allow_outside, network=True)
    if spec.network is not None:
        return _network_evidence(spec, args, db)
    parts = ("proofs", "conformance (Frama-C WP takes up to a minute)")
    extra = (("a test suite", not args.no_tests), ("readings", bool(readings)), ("closed-loop runs", db is not None))
    work = ", ".join((*parts, *(name for name, given in extra if given)))
    say(f"collecting evidence for {args.spec}: {work}", flush=True)
    runs = None
    if db is not None:  # read through the results database's reader, before the long work starts
        runs = read_closed_loop(db, spec)
    replay = _replay(Path(args.replay)) if args.replay else None
    tests_out = None if args.no_tests else Path(args.out) / "tests"
    ev = collect(spec, readings, Path(args.generated), runs, evidence_now(), replay=replay, tests_out=tests_out)
    for path in write_bundle(ev, Path(args.out)):
        say(f"wrote {path}")
    say("every claim supported" if ev.ok else "a claim is not supported: see the argument in index.html")
    return EXIT_OK if ev.ok else EXIT_FINDING


def _network_evidence(spec: LoadedSpec, args: argparse.Namespace, db: Path | None) -> int:
    """A network's bundle: its goals, each vehicle's, the channels, each machine's code, the closed loop of that
    code (--db) and the replays of network counterexamples (--replay)."""
    from mlca_verify.evidence import now as evidence_now
    from mlca_verify.evidence import read_closed_loop
    from mlca_verify.evidence.network import collect_network, write_network_bundle

    if args.readings:
        raise UsageError("error: --readings is for a machine spec; a network's readings are its machines' own")
    machines = machine_specs(spec)
    say(
        f"collecting evidence for {args.spec}: the network's proofs, {len(machines)} machine(s)' proofs and code",
        flush=True,
    )
    runs = None if db is None else [read_closed_loop(db, m) for m in machines]
    replay = _replay(Path(args.replay)) if args.replay else None
    ev = collect_network(spec, Path(args.generated), runs, evidence_now(), replay=replay)
    for path in write_network_bundle(ev, Path(args.out)):
        say(f"wrote {path}")
    say("every claim supported" if ev.ok else "a claim is not supported: see the argument in index.html")
    return EXIT_OK if ev.ok else EXIT_FINDING


MAX_REPLAY_BYTES = 16 << 20


def _no_constant(name: str) -> object:
    raise ValueError(f"{name} is not a number here")


def _replay(path: Path) -> JsonObject:
    """The replay document given to `evidence --replay`, read and its shape checked before the long work."""
    from mlca_verify.evidence import check_replay

    data = read_regular(path, MAX_REPLAY_BYTES, "replay file")
    try:
        return check_replay(json.loads(data.decode("utf-8"), parse_constant=_no_constant), str(path))
    except (ValueError, RecursionError) as err:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        raise UsageError.at(path, f"{str(err).splitlines()[0] or type(err).__name__}") from None


COMMANDS = {
    "check": cmd_check,
    "diff": cmd_diff,
    "gen": cmd_gen,
    "conform": cmd_conform,
    "diagram": cmd_diagram,
    "evidence": cmd_evidence,
    "tests": cmd_tests,
    "schema": cmd_schema,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; return the exit code. Every failure prints one line on stderr (see `cli_base`)."""
    return cli_base.run_guarded("mlca-verify", _parser(), COMMANDS, sys.argv[1:] if argv is None else argv)


def entry() -> None:
    cli_base.entry(main)
