"""`mlca-sim`: closed-loop runs and sweeps. Exit 0 when every run finished with no monitor violation, 1 when a
run failed or the monitor fired, 2 on bad input (one line on stderr)."""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from mlca_verify.cli import EXIT_INTERRUPTED, Parser, write_json
from mlca_verify.errors import MlcaError, UsageError
from sim_check import db
from sim_check.controllers import CONTROLLERS, PAPER_MATRIX
from sim_check.runner import MARKS_KM, RunResult, run_once
from sim_check.scenario import load_scenario
from sim_check.sweep import RaySweep, Sweep


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="mlca-sim", description="Run the generated MLCA controllers closed loop in SUMO.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    run = sub.add_parser("run", help="one run")
    run.add_argument("--controller", default="mlca-c", choices=CONTROLLERS)
    run.add_argument("--avs", type=int, default=None, help="number of AVs (default: the scenario's)")
    run.add_argument("--seed", type=int, default=0)
    run.add_argument("--scenario", type=Path, help="scenario file (TOML; default: the paper's, sim_check/paper.toml)")
    run.add_argument("--db", type=Path, help="also store the run in this results database")
    run.add_argument("--json", type=Path, help="also write the run as JSON")
    sweep = sub.add_parser("sweep", help="many runs over worker processes into a results database")
    sweep.add_argument("--controller", help=f"comma-separated, of: {', '.join(CONTROLLERS)} (default mlca-c)")
    sweep.add_argument("--matrix", choices=["paper"],
                       help=f"the paper's comparison: {', '.join(PAPER_MATRIX)}")  # fmt: skip
    sweep.add_argument("--avs", default="1,3", help="comma-separated AV counts (default 1,3)")
    sweep.add_argument("--runs", type=int, default=100, help="seeds 0..RUNS-1 per configuration (default 100)")
    sweep.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    sweep.add_argument("--db", type=Path, required=True, help="results database (SQLite)")
    sweep.add_argument("--resume", action="store_true", help="skip the runs the database already holds")
    sweep.add_argument("--scenario", type=Path, help="scenario file (TOML; default: the paper's)")
    sweep.add_argument("--timeout", type=float, default=600.0, help="seconds before a run is declared hung")
    sweep.add_argument("--ray", metavar="ADDRESS", help="run on the Ray cluster at ADDRESS (host:port) instead")
    report = sub.add_parser("report", help="figures and report.md beside the paper's values, from a results database")
    report.add_argument("--db", type=Path, required=True, help="results database (SQLite) written by sweep")
    report.add_argument("--out", type=Path, required=True, help="folder for the figures (PNG, SVG) and report.md")
    return parser


HEADER = (
    f"{'controller':10} {'avs':>3} {'seed':>4} {'status':7} {'av':4} "
    + " ".join(f"{f'lc@{km}km':>8}" for km in MARKS_KM)
    + f" {'coll':>4} {'ebrake':>6} {'travel s':>8} {'monitor':>7}"
)


def _table(results: Sequence[RunResult]) -> str:
    lines = [HEADER]
    for r in results:
        for m in r.metrics:
            row = m.row()
            travel = "-" if row["travel_time_s"] is None else f"{row['travel_time_s']:.1f}"
            lines.append(
                f"{r.controller:10} {r.avs:>3} {r.seed:>4} {r.status:7} {m.av:4} "
                + " ".join(f"{row[f'lc_{km}km']:>8}" for km in MARKS_KM)
                + f" {row['collisions']:>4} {row['emergency_brakes']:>6} {travel:>8} {row['monitor_violations']:>7}"
            )
        if r.status != "done":
            lines.append(f"  run failed: {r.reason}")
    return "\n".join(lines)


def cmd_run(args: argparse.Namespace) -> int:
    scenario = load_scenario(args.scenario)
    if args.avs is not None:
        scenario = scenario.with_avs(args.avs)
    with tempfile.TemporaryDirectory(prefix="mlca-sim-") as work:
        result = run_once(scenario, args.controller, args.seed, Path(work))
    print(_table([result]))
    print(f"{result.sim_steps} steps, {result.vehicle_steps} vehicle-steps, {result.wall_s:.2f} s wall, "
          f"{result.collisions} collisions, {result.monitor_violations} monitor violations")  # fmt: skip
    if args.db:
        db.store(db.connect(args.db), result)
    if args.json:
        write_json(str(args.json), result.to_json())
    return 0 if result.status == "done" and not result.violations else 1


def _csv(text: str, cast: type, what: str) -> list:  # type: ignore[type-arg]
    try:
        return [cast(x.strip()) for x in text.split(",") if x.strip()]
    except ValueError:
        raise UsageError(f"error: bad {what}: {text!r}") from None


def cmd_sweep(args: argparse.Namespace) -> int:
    if args.matrix and args.controller:
        raise UsageError("error: give either --matrix or --controller, not both")
    controllers = list(PAPER_MATRIX) if args.matrix else _csv(args.controller or "mlca-c", str, "--controller")
    unknown = [c for c in controllers if c not in CONTROLLERS]
    if unknown:
        raise UsageError(f"error: unknown controllers: {', '.join(unknown)} (known: {', '.join(CONTROLLERS)})")
    avs = _csv(args.avs, int, "--avs")
    if not controllers or not avs or args.runs < 1 or args.jobs < 1:
        raise UsageError("error: a sweep needs at least one controller, one AV count, --runs >= 1 and --jobs >= 1")
    scenario = load_scenario(args.scenario)
    wanted = list(itertools.product(controllers, avs, range(args.runs)))
    have = db.done(db.connect(args.db))
    if have & set(wanted) and not args.resume:
        raise UsageError(
            f"{args.db}: error: already holds {len(have & set(wanted))} of these runs; add --resume to continue"
        )
    todo = [job for job in wanted if job not in have]
    where = f"the Ray cluster at {args.ray}" if args.ray else f"{args.jobs} workers"
    print(f"{len(wanted)} runs wanted, {len(wanted) - len(todo)} already in {args.db}, {len(todo)} to run "
          f"on {where}", flush=True)  # fmt: skip
    counts = {"done": 0, "failed": 0, "violations": 0}

    def progress(r: RunResult) -> None:
        counts["done" if r.status == "done" else "failed"] += 1
        counts["violations"] += r.monitor_violations
        n = counts["done"] + counts["failed"]
        bar = "#" * (30 * n // max(len(todo), 1))
        sys.stderr.write(f"\r[{bar:30}] {n}/{len(todo)} runs, {counts['failed']} failed, "
                         f"{counts['violations']} monitor violations")  # fmt: skip
        sys.stderr.flush()

    try:
        if args.ray:
            RaySweep(scenario, args.db, args.ray, args.timeout).run(todo, progress)
        else:
            Sweep(scenario, args.db, args.jobs, args.timeout).run(todo, progress)
    except KeyboardInterrupt:
        stored = len(db.done(db.connect(args.db)) & set(wanted))
        print(f"\ninterrupted: {stored} of the {len(wanted)} runs wanted are stored in {args.db}; run the same "
              "command with --resume to do the rest", file=sys.stderr)  # fmt: skip
        return EXIT_INTERRUPTED
    sys.stderr.write("\n")
    summary = f"{counts['done']} runs done, {counts['failed']} failed, {counts['violations']} monitor violations"
    print(f"{summary}; results in {args.db}")
    return 0 if counts["failed"] == 0 and counts["violations"] == 0 else 1


def cmd_report(args: argparse.Namespace) -> int:
    from sim_check.report import write_report

    if not args.db.is_file():
        raise UsageError(f"{args.db}: error: no such results database")
    written = write_report(args.db, args.out)
    print(f"wrote {len(written)} files to {args.out}: {', '.join(p.name for p in written)}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = _parser().parse_args(argv)
        return {"run": cmd_run, "sweep": cmd_sweep, "report": cmd_report}[args.command](args)
    except MlcaError as err:
        print(str(err).splitlines()[0], file=sys.stderr)
        return 2


def entry() -> None:
    try:
        code = main()
    except KeyboardInterrupt:  # a single run or a report: nothing half-written is left (mlca_verify.files)
        print("\ninterrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    sys.exit(code)
