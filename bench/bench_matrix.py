"""Benchmark the paper's full comparison matrix, and choose the sublane model's lateral resolution.

Run on demand:
- `.venv/bin/python bench/bench_matrix.py --runs 100 --jobs 2 --db matrix.sqlite`: every controller of
  `--matrix paper` with 1 and 3 AVs over RUNS seeds (resumable: the database keeps finished runs), printing the
  wall time of the whole matrix, the time per run of each controller, and the paper's figure for comparison
  (6.5 hours for 100 runs of one configuration; target here: the whole matrix in under 40 minutes).
- `.venv/bin/python bench/bench_matrix.py --lateral --runs 10`: the SL2015 sublane model at several lateral
  resolutions on the same seeds: wall time per run and the AV's lane changes at 20 km and collisions, against the
  finest resolution, so that the coarsest resolution whose results agree can be chosen.
- `.venv/bin/python bench/bench_matrix.py --floor --runs 100 --seeds 2 [--write-docs]`: the matrix against its
  floor on this machine, side by side in one run: every controller's closed loop and plain SUMO alone
  (`sim_check.runner.run_plain`: no sensing, controller or monitor) under the same SUMO configuration, with 1 and
  3 AVs, on SEEDS seeds, JOBS runs at once, each run timed whole; RUNS such runs of every configuration, shared
  perfectly by JOBS workers, give the matrix's time and its floor, the least time any harness could take for it
  here. `--scenario FILE` runs the matrix and its floor on another scenario; `--write-docs` writes the table into
  docs/reference/generated-code.md (block `floor`, or `floor-NAME` for the scenario file NAME.toml).
- `.venv/bin/python bench/bench_matrix.py --from-runs docs/comparison/runs.csv [--write-docs]`: the mean time per
  run of each controller, from the wall times a sweep recorded (its runs.csv), written into
  docs/reference/generated-code.md with `--write-docs` (see figures.py).
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from figures import ROOT, write_block
from sim_check.cli import main as sim_main
from sim_check.controllers import PAPER_MATRIX, SETUPS
from sim_check.db import ResultsDB
from sim_check.run_results import RunResult
from sim_check.runner import run_once, run_plain
from sim_check.scenario import load_scenario

RESOLUTIONS = (0.4, 0.8, 1.6, 3.2)


def _lateral_run(job: tuple[float, int]) -> tuple[float, int, RunResult]:
    resolution, seed = job
    setup = replace(SETUPS["sl2015"], options=("--lateral-resolution", str(resolution)))
    with tempfile.TemporaryDirectory() as work:
        return resolution, seed, run_once(load_scenario(), "sl2015", seed, Path(work), setup=setup)


def lateral(runs: int, jobs: int) -> None:
    jobs_list = [(res, seed) for seed in range(runs) for res in RESOLUTIONS]
    results: dict[float, dict[int, RunResult]] = {res: {} for res in RESOLUTIONS}
    with mp.get_context("spawn").Pool(jobs) as pool:
        for res, seed, result in pool.imap_unordered(_lateral_run, jobs_list):
            results[res][seed] = result
            print(f"  resolution {res} m, seed {seed}: {result.wall_s:.1f} s", flush=True)
    finest = RESOLUTIONS[0]
    print(f"SL2015, 1 AV, seeds 0..{runs - 1}, the paper's scenario:")
    print(f"  {'resolution m':>12} {'wall s/run':>10} {'lc@20km mean':>12} {'diff vs finest':>14} "
          f"{'AV collisions':>13} {'all collisions':>14}")  # fmt: skip
    for res in RESOLUTIONS:
        rows = [results[res][s] for s in range(runs)]
        lc = [r.metrics[0].changes_by(20) for r in rows]
        diffs = [a - results[finest][s].metrics[0].changes_by(20) for s, a in enumerate(lc)]
        print(f"  {res:12.1f} {statistics.mean(r.wall_s for r in rows):10.1f} {statistics.mean(lc):12.2f} "
              f"{statistics.mean(diffs):+14.2f} {sum(r.metrics[0].collisions for r in rows):13d} "
              f"{sum(r.collisions for r in rows):14d}")  # fmt: skip


Job = tuple[str, str, int, int, str]  # (kind "plain" or "loop", controller, AVs, seed, scenario file)


def _timed_run(job: Job) -> tuple[Job, float]:
    """One run, timed whole (its network and routes built, SUMO run, files read): plain SUMO under the controller's
    setup, or the controller's closed loop."""
    kind, controller, avs, seed, scenario_file = job
    scenario = load_scenario(Path(scenario_file) if scenario_file else None).with_avs(avs)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as work:
        if kind == "plain":
            run_plain(scenario, seed, Path(work), setup=SETUPS[controller])
        else:
            run_once(scenario, controller, seed, Path(work))
    return job, time.perf_counter() - start


def _floor_jobs(seeds: int, scenario_file: str) -> tuple[list[Job], dict[tuple[str, int], str]]:
    """Every controller's closed loop and, beside the first controller of each SUMO configuration, its plain run,
    seed by seed, so that both kinds share the machine alike; and the controller whose plain runs stand for each."""
    first: dict[tuple[str, tuple[str, ...], int], str] = {}  # (AV vType, options, AVs) -> its first controller
    plain_as: dict[tuple[str, int], str] = {}
    jobs: list[Job] = []
    for seed in range(seeds):
        for controller in PAPER_MATRIX:
            setup = SETUPS[controller]
            for avs in (1, 3):
                key = (setup.av_type, setup.options, avs)
                if key not in first or first[key] == controller:
                    jobs.append(("plain", controller, avs, seed, scenario_file))
                plain_as[(controller, avs)] = first.setdefault(key, controller)
                jobs.append(("loop", controller, avs, seed, scenario_file))
    return jobs, plain_as


def floor(runs: int, jobs: int, seeds: int, scenario_file: str, write_docs: bool) -> None:
    """The matrix against its floor, side by side in one run: each controller's closed loop and plain SUMO under
    its setup, on SEEDS seeds, JOBS runs at once. RUNS runs of every configuration, shared perfectly by JOBS
    workers, give the matrix's time and its floor, the least time any harness could take for it here."""
    work, plain_as = _floor_jobs(seeds, scenario_file)
    walls: dict[tuple[str, str, int], list[float]] = defaultdict(list)
    with mp.get_context("spawn").Pool(jobs) as pool:
        for (kind, controller, avs, _seed, _f), wall in pool.imap_unordered(_timed_run, work):
            walls[(kind, controller, avs)].append(wall)
    loop = {key: statistics.mean(walls[("loop", *key)]) for key in plain_as}
    plain = {key: statistics.mean(walls[("plain", c, key[1])]) for key, c in plain_as.items()}
    lines = ["| controller | closed loop, 1 AV | plain SUMO | ratio | closed loop, 3 AVs | plain SUMO | ratio |",
             "|---|---|---|---|---|---|---|"]  # fmt: skip
    for controller in PAPER_MATRIX:
        pairs = [(loop[controller, n], plain[controller, n]) for n in (1, 3)]
        cells = [f"{a:.2f} | {b:.2f} | {a / b:.2f}" for a, b in pairs]
        lines.append(f"| `{controller}` | {' | '.join(cells)} |")
    matrix_min, floor_min = (sum(t.values()) * runs / jobs / 60 for t in (loop, plain))
    scenario = f"`{scenario_file}`" if scenario_file else "the paper's scenario"
    lines += ["", f"Seconds per run, the mean of seeds 0 to {seeds - 1}, {jobs} runs at once, on {scenario}. "
              f"For {runs} runs of every configuration on {jobs} workers: the matrix {matrix_min:.1f} minutes, its "
              f"floor {floor_min:.1f} minutes of plain SUMO, matrix against floor "
              f"**{matrix_min / floor_min:.2f}**."]  # fmt: skip
    print("\n".join(lines))
    if write_docs:
        name = f"floor-{Path(scenario_file).stem}" if scenario_file else "floor"
        by = f"bench/bench_matrix.py --floor --runs {runs} --seeds {seeds} --jobs {jobs}"
        by += f" --scenario {scenario_file}" if scenario_file else ""
        write_block(name, lines, by + " --write-docs", ROOT / "docs" / "reference" / "generated-code.md")


def matrix(runs: int, jobs: int, db: Path, scenario_file: str) -> None:
    start = time.perf_counter()
    argv = ["sweep", "--matrix", "paper", "--runs", str(runs), "--jobs", str(jobs), "--db", str(db), "--resume"]
    argv += ["--scenario", scenario_file] if scenario_file else []
    code = sim_main(argv)
    wall = time.perf_counter() - start
    print(f"\nfull matrix ({len(PAPER_MATRIX)} controllers x 1 and 3 AVs x {runs} seeds) on {jobs} workers: "
          f"{wall / 60:.1f} min wall this invocation (sweep exit {code}); target under 40 min; the paper: "
          "6.5 hours for 100 runs of one configuration")  # fmt: skip
    print(f"  {'controller':12} {'avs':>3} {'runs':>5} {'mean s/run (one worker)':>24}")
    walls = _wall_times(db)
    for (controller, avs), times in sorted(walls.items()):
        print(f"  {controller:12} {avs:>3} {len(times):>5} {statistics.mean(times):24.2f}")
    total = sum(t for times in walls.values() for t in times)
    print(
        f"  sum of run times {total / 60:.1f} min, i.e. {total / 60 / jobs:.1f} min on {jobs} workers "
        "if perfectly shared"
    )


def _wall_times(db: Path) -> dict[tuple[str, int], list[float]]:
    """The wall time of every stored run, by (controller, AVs)."""
    with ResultsDB.open_for_reading(db) as results:
        table = results.table_rows("runs")
    at = {name: k for k, name in enumerate(table.columns)}
    walls: dict[tuple[str, int], list[float]] = defaultdict(list)
    for row in table.rows:
        walls[(row[at["controller"]], row[at["avs"]])].append(row[at["wall_s"]])
    return walls


def from_runs(path: Path, write_docs: bool) -> None:
    """The mean wall time per run of each controller, 1 and 3 AVs, from a sweep's recorded runs (runs.csv)."""
    walls: dict[tuple[str, int], list[float]] = defaultdict(list)
    with path.open(encoding="utf-8", newline="") as f:
        for row in csv.DictReader(f):
            if row["status"] == "done":
                walls[(row["controller"], int(row["avs"]))].append(float(row["wall_s"]))
    controllers = [c for c in PAPER_MATRIX if (c, 1) in walls or (c, 3) in walls]
    lines = ["| controller | 1 AV | 3 AVs |", "|---|---|---|"]
    for c in controllers:
        cells = [f"{statistics.mean(walls[c, n]):.2f}" if walls.get((c, n)) else "-" for n in (1, 3)]
        lines.append(f"| `{c}` | {' | '.join(cells)} |")
        print(f"  {c:12} " + "  ".join(f"{cell:>6}" for cell in cells))
    total = sum(t for times in walls.values() for t in times)
    runs = sum(len(times) for times in walls.values())
    lines += ["", f"Mean seconds per run on one worker, over the {runs:,} runs recorded in `{_shown(path)}`; the sum"
              f" of their run times is {total / 60:.1f} minutes."]  # fmt: skip
    print(lines[-1])
    if write_docs:
        page = ROOT / "docs" / "reference" / "generated-code.md"
        write_block("matrix", lines, f"bench/bench_matrix.py --from-runs {_shown(path)} --write-docs", page)


def _shown(path: Path) -> str:
    """`path` relative to the project, as the docs name it."""
    resolved = path.resolve()
    return str(resolved.relative_to(ROOT)) if resolved.is_relative_to(ROOT) else str(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--db", type=Path, default=Path("matrix.sqlite"))
    parser.add_argument("--lateral", action="store_true", help="compare the sublane model's lateral resolutions")
    parser.add_argument("--floor", action="store_true", help="the matrix's floor: plain SUMO per configuration")
    parser.add_argument("--seeds", type=int, default=2, help="seeds per configuration for --floor")
    parser.add_argument("--scenario", default="", help="scenario file of the matrix and its floor (default: paper)")
    parser.add_argument("--from-runs", type=Path, metavar="CSV", help="the mean time per run from a sweep's runs.csv")
    parser.add_argument(
        "--write-docs",
        action="store_true",
        help="with --from-runs or --floor: write the table into its page",
    )
    args = parser.parse_args()
    if args.from_runs:
        from_runs(args.from_runs, args.write_docs)
    elif args.floor:
        floor(args.runs, args.jobs, args.seeds, args.scenario, args.write_docs)
    elif args.lateral:
        lateral(args.runs, args.jobs)
    else:
        matrix(args.runs, args.jobs, args.db, args.scenario)


if __name__ == "__main__":
    main()
