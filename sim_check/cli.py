"""`mlca-sim`: closed-loop runs and sweeps, and replays of lemma counterexamples. Exit 0 when every run finished
with no monitor violation (every replay as expected), 1 when a run failed or the monitor fired (a replay was not), 2
on bad input (one line on stderr), 3 on an internal error (one line; the traceback with --debug), 130 when
interrupted (mlca_verify.cli_base)."""

from __future__ import annotations

import argparse
import importlib.util
import itertools
import math
import re
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from mlca_verify import cli_base
from mlca_verify.cli_base import EXIT_INTERRUPTED, Parser, write_json
from mlca_verify.errors import MlcaError, UsageError, located
from mlca_verify.escape import terminal
from mlca_verify.files import write_atomic
from sim_check.controllers import CONTROLLERS, PAPER_MATRIX, V2V_CONTROLLERS
from sim_check.db import Plan, ResultsDB
from sim_check.radio import traffic_text
from sim_check.replay import MAX_REPLAY_POINTS
from sim_check.run_results import MARKS_KM, Job, RunResult
from sim_check.scenario import LIMITS, MAX_SEED, Scenario, load_scenario

if TYPE_CHECKING:  # SUMO and the plotting libraries are the `sim` extra: imported by the commands that use them
    from sim_check.network_replay import Scene
    from sim_check.sweep import Sweep

SIM_EXTRA = ("libsumo", "sumo", "sumolib", "numpy", "scipy", "matplotlib")

T = TypeVar("T")
MAX_RUNS = 100_000  # seeds per configuration in one sweep
MAX_JOBS = 64
MAX_AVS = int(LIMITS["avs"][1])


_bounded = cli_base.whole_number
_RAY_ADDRESS = re.compile(r"(?:ray://)?[A-Za-z0-9][A-Za-z0-9.\-]{0,252}:[0-9]{1,5}|auto")


def _ray_address(text: str) -> str:
    """An argparse type: a Ray cluster's address, host:port (or ray://host:port, or auto)."""
    if not _RAY_ADDRESS.fullmatch(text):
        raise argparse.ArgumentTypeError(f"not a Ray address (host:port): {text[:60]!r}")
    return text


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text}")
    return value


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="mlca-sim", description="Run the generated MLCA controllers closed loop in SUMO.")
    parser.add_argument(cli_base.DEBUG_FLAG, action="store_true", help="print the traceback of an internal error")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    run = sub.add_parser("run", help="one run")
    run.add_argument("--controller", default="mlca-c", choices=CONTROLLERS)
    run.add_argument("--avs", type=_bounded(1, MAX_AVS), default=None, help="number of AVs (default: the scenario's)")
    run.add_argument("--seed", type=_bounded(0, MAX_SEED), default=0, help=f"SUMO's seed, 0 to {MAX_SEED}")
    run.add_argument("--scenario", type=Path, help="scenario file (TOML; default: the paper's, sim_check/paper.toml)")
    run.add_argument("--db", type=Path, help="also store the run in this results database")
    run.add_argument("--json", type=Path, help="also write the run as JSON")
    sweep = sub.add_parser("sweep", help="many runs over worker processes into a results database")
    sweep.add_argument("--controller", help=f"comma-separated, of: {', '.join(CONTROLLERS)} (default mlca-c)")
    sweep.add_argument("--matrix", choices=["paper"], help=f"the paper's comparison: {', '.join(PAPER_MATRIX)}")
    sweep.add_argument("--avs", default="1,3", help="comma-separated AV counts (default 1,3)")
    sweep.add_argument(
        "--runs", type=_bounded(1, MAX_RUNS), default=100, help="seeds 0..RUNS-1 per configuration (default 100)"
    )
    sweep.add_argument("--jobs", type=_bounded(1, MAX_JOBS), default=2, help="worker processes (default 2)")
    sweep.add_argument("--db", type=Path, required=True, help="results database (SQLite)")
    sweep.add_argument(
        "--resume",
        action="store_true",
        help="skip the runs the database already holds and those a running sweep holds (the runs of a sweep that "
        "ends meanwhile are run too)",
    )
    sweep.add_argument("--retry-failed", action="store_true", help="with --resume: run the failed runs again")
    sweep.add_argument("--scenario", type=Path, help="scenario file (TOML; default: the paper's)")
    sweep.add_argument("--timeout", type=_seconds, default=600.0, help="seconds before a run is declared hung")
    sweep.add_argument(
        "--ray", type=_ray_address, metavar="ADDRESS", help="run on the Ray cluster at ADDRESS (host:port) instead"
    )
    report = sub.add_parser("report", help="figures and report.md beside the paper's values, from a results database")
    report.add_argument("--db", type=Path, required=True, help="results database (SQLite) written by sweep")
    report.add_argument("--out", type=Path, required=True, help="folder for the figures (PNG, SVG) and report.md")
    channels = sub.add_parser(
        "channels", help="the same controllers under several V2V channels, side by side (a database per channel)"
    )
    channels.add_argument(
        "--db",
        type=str,
        action="append",
        required=True,
        metavar="LABEL=FILE",
        help="a channel's label and the results database of its sweep (say off=off.sqlite); once per channel",
    )
    channels.add_argument("--out", type=Path, help="also write channels.md and the figure (PNG, SVG) to this folder")
    replay = sub.add_parser(
        "replay", help="a lemma's counterexample (or a point) as traffic in SUMO: RSS's worst case after the change"
    )
    replay.add_argument(
        "file",
        type=Path,
        help=f"`mlca-verify check --json` output (at most {MAX_REPLAY_POINTS} distinct points), or a TOML file with "
        "[point]",
    )
    replay.add_argument("--lemma", help="the lemma whose counterexample to replay (default: every violated one)")
    replay.add_argument("--side", choices=["left", "right"], default="left", help="the lane changed into")
    replay.add_argument(
        "--controller",
        help="drive every AV of a network's scene with this V2V controller (default: each instance's own machine)",
    )
    replay.add_argument(
        "--network",
        type=Path,
        help="drive each AV of a network's scene as this network spec's instance of its name (its machine and "
        "params): another protocol on the same scene",
    )
    replay.add_argument("--json", type=Path, help="also write the outcome as JSON")
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


def require_extra(command: str) -> None:
    """Refuse, with what to install, a command whose simulation dependencies (the `sim` extra) are missing."""
    missing = [name for name in SIM_EXTRA if importlib.util.find_spec(name) is None]
    if missing:
        raise UsageError(
            f"error: mlca-sim {command} needs the simulation extra, missing {', '.join(missing)}: "
            "pip install 'mlca-verify[sim]'"
        )


def cmd_run(args: argparse.Namespace) -> int:
    require_extra("run")
    scenario = load_scenario(args.scenario)
    if args.avs is not None:
        scenario = scenario.with_avs(args.avs)
    if not args.db:
        return _run(args, scenario, None)
    with ResultsDB.open_for_writing(args.db) as results:  # a database that cannot take the run is refused first
        if (args.controller, scenario.traffic.avs, args.seed) in results.stored_keys():
            raise UsageError.at(
                args.db,
                f"already holds this run ({args.controller}, "
                f"{scenario.traffic.avs} AVs, seed {args.seed}); give another --db",
            )
        return _run(args, scenario, results)


def _run(args: argparse.Namespace, scenario: Scenario, results: ResultsDB | None) -> int:
    """One run, printed, stored in `results` (if any) and written as JSON (if asked)."""
    from sim_check.runner import run_once

    with tempfile.TemporaryDirectory(prefix="mlca-sim-") as work:
        result = run_once(scenario, args.controller, args.seed, Path(work))
    print(_table([result]))
    print(
        f"{result.sim_steps} steps, {result.vehicle_steps} vehicle-steps, {result.wall_s:.2f} s wall, "
        f"{result.collisions} collisions, {result.monitor_violations} monitor violations"
    )
    if args.controller in V2V_CONTROLLERS:
        print(f"V2V: {traffic_text(result.v2v, scenario.v2v)}")
    if results and not results.store(result):
        print(f"{args.db}: another process stored this run meanwhile; not stored again", file=sys.stderr)
    if args.json:
        write_json(str(args.json), result.to_json())
    return 0 if result.status == "done" and not result.violations else 1


def _csv(text: str, cast: Callable[[str], T], what: str) -> list[T]:
    """The distinct comma-separated values of `text`, in their order."""
    try:
        return list(dict.fromkeys(cast(x.strip()) for x in text.split(",") if x.strip()))
    except ValueError:
        raise UsageError(f"error: bad {what}: {text!r}") from None


def _wanted(args: argparse.Namespace) -> list[Job]:
    if args.matrix and args.controller:
        raise UsageError("error: give either --matrix or --controller, not both")
    if args.retry_failed and not args.resume:
        raise UsageError("error: --retry-failed goes with --resume")
    controllers = list(PAPER_MATRIX) if args.matrix else _csv(args.controller or "mlca-c", str, "--controller")
    unknown = [c for c in controllers if c not in CONTROLLERS]
    if unknown:
        raise UsageError(f"error: unknown controllers: {', '.join(unknown)} (known: {', '.join(CONTROLLERS)})")
    avs = _csv(args.avs, int, "--avs")
    if not controllers or not avs:
        raise UsageError("error: a sweep needs at least one controller and one AV count")
    if not all(1 <= n <= MAX_AVS for n in avs):
        raise UsageError(f"error: --avs: every AV count must be from 1 to {MAX_AVS}, got {args.avs!r}")
    return list(itertools.product(controllers, avs, range(args.runs)))


def _planned(args: argparse.Namespace, wanted: list[Job], plan: Plan) -> str:
    where = f"the Ray cluster at {args.ray}" if args.ray else f"{args.jobs} workers"
    line = f"{len(wanted)} runs wanted, {plan.stored} already in {args.db}, {len(plan.todo)} to run on {where}"
    if plan.retried:
        line += f" ({plan.retried} failed ones again)"
    if plan.held:
        pids = ", ".join(map(str, sorted(plan.held)))
        line += f"; {sum(plan.held.values())} left to the sweep running as pid {pids}"
    return line


class Progress:
    """A sweep's progress bar (stderr) and counts."""

    def __init__(self, total: int) -> None:
        self.total = total
        self.counts = {"done": 0, "failed": 0, "violations": 0}

    def __call__(self, r: RunResult) -> None:
        self.counts["done" if r.status == "done" else "failed"] += 1
        self.counts["violations"] += r.monitor_violations
        n = self.counts["done"] + self.counts["failed"]
        bar = "#" * (30 * n // max(self.total, 1))
        sys.stderr.write(
            f"\r[{bar:30}] {n}/{self.total} runs, {self.counts['failed']} failed, "
            f"{self.counts['violations']} monitor violations"
        )
        sys.stderr.flush()

    def end(self) -> None:
        """End the bar's line, if it was drawn."""
        if self.counts["done"] + self.counts["failed"]:
            sys.stderr.write("\n")

    def summary(self) -> str:
        c = self.counts
        return f"{c['done']} runs done, {c['failed']} failed, {c['violations']} monitor violations"


def _sweep(args: argparse.Namespace, scenario: Scenario, results: ResultsDB) -> Sweep:
    from sim_check.sweep import RaySweep, Sweep

    try:
        if args.ray:
            return RaySweep(scenario, results, args.ray, args.timeout)
        return Sweep(scenario, results, args.jobs, args.timeout)
    except BaseException:
        results.release()
        raise


def cmd_sweep(args: argparse.Namespace) -> int:
    require_extra("sweep")
    wanted = _wanted(args)
    scenario = load_scenario(args.scenario)
    with ResultsDB.open_for_writing(args.db) as results:  # this process's one connection: it stores every run
        plan = results.lease(wanted, resume=args.resume, retry_failed=args.retry_failed)
        sweep = _sweep(args, scenario, results)
        print(_planned(args, wanted, plan), flush=True)
        return _run_sweep(args, lambda: _sweep(args, scenario, results), sweep, plan, wanted)


def _run_sweep(
    args: argparse.Namespace, another: Callable[[], Sweep], sweep: Sweep, plan: Plan, wanted: list[Job]
) -> int:
    """Run the plan; then lease again, and run what another sweep left when it ended meanwhile (its leases are
    reclaimed), until every wanted run is stored or held by a live sweep. A wanted run that is neither (one this
    sweep ran, yet not stored) is missing: exit 1."""
    progress = Progress(len(plan.todo))
    tried: set[Job] = set()
    skipped = 0
    while True:
        tried.update(plan.todo)
        try:
            sweep.run(plan.todo, progress)
        except KeyboardInterrupt:
            stored = len(sweep.database.stored_keys() & set(wanted))
            print(
                f"\ninterrupted: {stored} of the {len(wanted)} runs wanted are stored in {args.db}; run the same "
                "command with --resume to do the rest",
                file=sys.stderr,
            )
            return EXIT_INTERRUPTED
        except MlcaError:  # the database failed: the error goes on a line of its own
            progress.end()
            raise
        skipped += len(sweep.skipped)
        plan = sweep.database.lease(wanted, resume=True, retry_failed=False)
        left = [job for job in plan.todo if job not in tried]
        if not left:
            sweep.database.release()
            break
        progress.end()
        print(f"{len(left)} runs left unfinished by a sweep that ended meanwhile: running them too", flush=True)
        progress.total += len(left)
        plan.todo = left
        sweep = another()
    progress.end()
    summary = progress.summary()
    if skipped:
        summary += f", {skipped} stored by another process first (not stored again)"
    print(f"{summary}; results in {args.db}")
    missing = len(set(wanted) - sweep.database.stored_keys()) - sum(plan.held.values())
    if missing > 0:
        print(
            located(
                args.db,
                f"{missing} of the {len(wanted)} runs wanted are missing (neither stored nor held by a running "
                "sweep); run the same command with --resume",
            ),
            file=sys.stderr,
        )
        return 1
    if plan.held:
        pids = ", ".join(map(str, sorted(plan.held)))
        print(f"{sum(plan.held.values())} runs wanted are left to the sweep running as pid {pids}")
    return 0 if progress.counts["failed"] == 0 and progress.counts["violations"] == 0 else 1


def cmd_report(args: argparse.Namespace) -> int:
    require_extra("report")
    from sim_check.report import write_report

    if not args.db.is_file():
        raise UsageError.at(args.db, "no such results database")
    written = write_report(args.db, args.out)  # read (or refused) before anything is written
    print(f"wrote {len(written)} files to {args.out}: {', '.join(p.name for p in written)}")
    return 0


def cmd_channels(args: argparse.Namespace) -> int:
    from sim_check import channels

    given = [channels.labelled(text) for text in args.db]
    channels.check_labels([label for label, _ in given])
    read: list[channels.Channel] = []
    for label, path in given:  # every database read (or refused) before anything is written
        if not path.is_file():
            raise UsageError.at(path, "no such results database")
        with ResultsDB.open_for_reading(path) as results:
            read.append(channels.Channel(label, results.v2v_runs()))
    table = channels.rows(read)
    for line in channels.text(table).splitlines():
        print(terminal(line))
    if args.out is not None:
        require_extra("report")
        args.out.mkdir(parents=True, exist_ok=True)
        sources = [(label, path.name) for label, path in given]
        write_atomic(args.out / "channels.md", channels.markdown(table, sources))
        written = ["channels.md", *(p.name for p in channels.figure(table, args.out))]
        print(f"wrote {len(written)} files to {args.out}: {', '.join(written)}")
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    from sim_check.network_replay import load_scenes, network_drivers
    from sim_check.replay import as_json, describe, load_points, outcome, read_replay_file

    if args.controller is not None and args.controller not in V2V_CONTROLLERS:
        raise UsageError(f"error: --controller must be a V2V controller ({', '.join(V2V_CONTROLLERS)})")
    if args.controller is not None and args.network is not None:
        raise UsageError("error: give --controller or --network, not both")
    drivers = None if args.network is None else network_drivers(args.network)
    scenes = load_scenes(args.file, read_replay_file(args.file), args.controller, drivers)  # read before SUMO starts
    points = [] if scenes and args.lemma is None else load_points(args.file, args.lemma, args.side)
    require_extra("replay")
    from sim_check.replay import replay

    outcomes = []
    with tempfile.TemporaryDirectory(prefix="mlca-sim-") as work:
        for k, point in enumerate(points):
            phases = replay(point, Path(work) / str(k))
            print("\n".join(terminal(line) for line in describe(point, phases).splitlines()))
            outcomes.append((point, phases))
        networks = _replay_scenes(scenes, Path(work) / "scenes")
    unsafe = sum(outcome(phases) == "unsafe" for _, phases in outcomes)
    unexpected = [p.source for p, phases in outcomes if outcome(phases) != p.expect]
    if points:
        print(
            f"{len(outcomes)} point(s) replayed: {unsafe} unsafe (a collision, or braking beyond a declared limit); "
            + (
                terminal(f"{len(unexpected)} not as expected: {', '.join(unexpected)}")
                if unexpected
                else "all as expected"
            )
        )
    if args.json:
        doc: dict[str, object] = {"schema": "mlca-sim.replay/1", "points": [as_json(*o) for o in outcomes]}
        if networks:
            doc["networks"] = networks
        write_json(str(args.json), doc)
    return 1 if unexpected or any(n["expected"] not in (None, n["outcome"]) for n in networks) else 0


def _replay_scenes(scenes: list[Scene], work: Path) -> list[dict[str, Any]]:
    """Each network counterexample's scene driven in SUMO, printed; their JSON."""
    from sim_check.network_replay import as_json, describe, run_scene

    done = []
    for k, scene in enumerate(scenes):
        run = run_scene(scene, work / str(k))
        print("\n".join(terminal(line) for line in describe(scene, run).splitlines()))
        done.append(as_json(scene, run))
    if scenes:
        conflicts = sum(d["outcome"] == "conflict" for d in done)
        missed = [d["source"] for d in done if d["expected"] not in (None, d["outcome"])]
        said = (
            f"{len(missed)} violation(s) not shown in traffic: {', '.join(missed)}"
            if missed
            else "each violation driven by its own machines shows in traffic"
        )
        print(
            f"{len(done)} network scene(s) replayed: {conflicts} with a conflict (two AVs into one gap, or a "
            f"collision); {terminal(said)}"
        )
    return done


COMMANDS = {"run": cmd_run, "sweep": cmd_sweep, "report": cmd_report, "channels": cmd_channels, "replay": cmd_replay}


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; return the exit code. Every failure prints one line on stderr (mlca_verify.cli_base)."""
    return cli_base.run_guarded("mlca-sim", _parser(), COMMANDS, sys.argv[1:] if argv is None else argv)


def entry() -> None:
    cli_base.entry(main)
