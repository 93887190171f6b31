"""Benchmark the closed loop against plain SUMO on the same run, and the time of a 100-run sweep.

Run on demand: `.venv/bin/python bench/bench_sim.py [--runs 100] [--jobs 2] [--repeat 5] [--instructions 500]`.
Prints, side by side in one run, for the paper's scenario (20 km, 100 cars, step 0.1 s, one AV, seed 0):
- plain SUMO through libsumo, stepped from Python until the AV arrives, the AV left to SUMO's own lane changing
  (`sim_check.runner.run_plain`);
- the closed loop with MLCA-T's generated C (the need from SUMO's model, the raw signals, the decision function,
  its monitor, the metrics and SUMO's SSM device, which the plain run has too), the controller loaded beforehand
  as a sweep worker has it;
measured in REPEAT interleaved pairs (the order alternating), so that a slower spell of the machine hits both
alike: the best of each, and the median of the pairs' ratios (target: at most 1.05), split into the time inside
SUMO's step (the same simulation work on both sides) and the Python around the steps. Then the wall time of a
sweep of RUNS runs of one configuration over JOBS worker processes, beside the same runs of plain SUMO on JOBS
worker processes (target: at most 1.15 times), and RUNS runs at the best plain time above shared perfectly.

With `--instructions SECONDS`, also the instructions each side executes over the first SECONDS simulated seconds,
and the misses of a simulated L2 cache the size of this core's, counted by valgrind's callgrind (repeatable
whatever else the machine does; the start of Python and SUMO, counted alone, is subtracted from both), each for
the whole run and inside SUMO's step. It separates the work the closed loop adds from the time that work costs:
the loop between two SUMO steps evicts part of SUMO's code and data from the cache, which SUMO's next step reads
back.

`--write-docs` writes what it measured into docs/reference/generated-code.md (see figures.py).
"""

from __future__ import annotations

import argparse
import functools
import multiprocessing as mp
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from figures import ROOT, write_block
from sim_check.controllers import load_controller
from sim_check.db import ResultsDB
from sim_check.runner import SIM_LIMIT_S, run_once, run_plain
from sim_check.scenario import load_scenario
from sim_check.sweep import Sweep

CONTROLLER = "mlca_t-c"  # MLCA-T's generated C: its whole decision function on raw signals


def plain(work: Path, limit_s: float = SIM_LIMIT_S) -> tuple[float, int, int]:
    return run_plain(load_scenario(), 0, work, limit_s=limit_s)


def closed(work: Path, limit_s: float = SIM_LIMIT_S) -> tuple[float, int, int]:
    load_controller(CONTROLLER)
    start = time.perf_counter()
    result = run_once(load_scenario(), CONTROLLER, 0, work, limit_s=limit_s)
    return time.perf_counter() - start, result.sim_steps, result.vehicle_steps


class StepClock:
    """The wall time spent inside SUMO's step during a run: libsumo.simulationStep, which both runs call by name
    every step, wrapped for the duration (the wrapper costs both sides alike, well under a millisecond a run).
    The rest of a run's wall time is the Python around the steps."""

    def __init__(self) -> None:
        self.seconds = 0.0

    def __enter__(self) -> StepClock:
        import libsumo

        self._step = step = libsumo.simulationStep

        def timed(*args: float) -> None:
            start = time.perf_counter()
            step(*args)
            self.seconds += time.perf_counter() - start

        libsumo.simulationStep = timed
        return self

    def __exit__(self, *exc: object) -> None:
        import libsumo

        libsumo.simulationStep = self._step


def _plain_seed(root: Path, seed: int) -> float:
    """One plain run in a pool worker, in a folder of its own under `root`: the worker builds the network once,
    as a sweep worker does."""
    return run_plain(load_scenario(), seed, root / f"worker-{os.getpid()}")[0]


def child(mode: str, limit_s: float) -> None:
    """What one callgrind process runs: the start alone, plain SUMO or the closed loop, for `limit_s`."""
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        plain(work, 0.0)  # the start alone (and the network built for the others)
        load_controller(CONTROLLER)
        if mode == "plain":
            plain(work, limit_s)
        elif mode == "closed":
            closed(work, limit_s)


def l2_cache() -> str:
    """This machine's per-core L2 cache as valgrind's --LL option (size,ways,line size), from sysfs; valgrind
    simulates it as the last level, the one whose misses SUMO's step and the loop between steps cost each other
    (the L3 here is shared with other tenants of the host)."""
    try:
        folder = Path("/sys/devices/system/cpu/cpu0/cache/index2")
        size = folder.joinpath("size").read_text().strip()
        ways = folder.joinpath("ways_of_associativity").read_text().strip()
        line = folder.joinpath("coherency_line_size").read_text().strip()
    except OSError:
        return "524288,8,64"
    units = {"K": 1024, "M": 1024 * 1024}
    bytes_ = int(size[:-1]) * units[size[-1]] if size[-1] in units else int(size)
    return f"{bytes_},{ways},{line}"


STEP_FUNCTION = "libsumo::Simulation::step(double)"
EVENTS = ("Ir", "ILmr", "DLmr", "DLmw")


def _counts(mode: str, limit_s: float, cache: str, folder: Path) -> dict[str, tuple[int, int]]:
    """Instructions and L2 misses of one callgrind run: (whole run, inside SUMO's step)."""
    out = folder / f"callgrind.{mode}"
    ran = subprocess.run(
        ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", "--cache-sim=yes", f"--LL={cache}",
         sys.executable, __file__, "--child", mode, "--instructions", str(limit_s)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    if ran.returncode != 0 or not out.exists():
        sys.exit(f"error: callgrind failed ({mode}): {ran.stderr.strip()[-500:]}")
    shown = subprocess.run(
        ["callgrind_annotate", "--inclusive=yes", f"--show={','.join(EVENTS)}", str(out)],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    totals, step = _events(shown, "PROGRAM TOTALS"), _events(shown, STEP_FUNCTION)
    ir, misses = (totals[0], sum(totals[1:])), (step[0], sum(step[1:]))
    return {"Ir": (ir[0], misses[0]), "L2": (ir[1], misses[1])}


def _events(annotated: str, name: str) -> list[int]:
    """The event counts of the line of callgrind_annotate's output that names `name` (zeros where none does)."""
    for line in annotated.splitlines():
        if line.rstrip().endswith(name) or f":{name} " in line:
            numbers = re.sub(r"\([^)]*%\)", " ", line.split(name)[0].split("???")[0]).split()
            values = [int(n.replace(",", "")) for n in numbers if re.fullmatch(r"[\d,]+", n)]
            if len(values) >= len(EVENTS):
                return values[: len(EVENTS)]
    return [0] * len(EVENTS)


def instructions(limit_s: float) -> list[str]:
    """Count both sides' instructions and L2 misses; print them, and return them as the docs write them."""
    cache = l2_cache()
    with tempfile.TemporaryDirectory() as folder, ThreadPoolExecutor(2) as pool:
        runs = {mode: pool.submit(_counts, mode, limit_s, cache, Path(folder)) for mode in ("start", "plain", "closed")}
        counts = {mode: run.result() for mode, run in runs.items()}
    print(f"over the first {limit_s:.0f} simulated s (callgrind, the start subtracted; L2 misses of a simulated "
          f"{cache.split(',')[0]}-byte {cache.split(',')[1]}-way L2, this core's):")  # fmt: skip
    lines = [
        f"Over the first {limit_s:.0f} simulated seconds (callgrind, the start subtracted; a simulated"
        f" {int(cache.split(',')[0]) // 1024} KiB, {cache.split(',')[1]}-way L2):",
        "",
        "| | plain SUMO | closed loop | ratio | inside SUMO's step: plain | closed loop | ratio |",
        "|---|---|---|---|---|---|---|",
    ]
    for event, label in (("Ir", "instructions"), ("L2", "L2 misses")):
        plain = [counts["plain"][event][k] - counts["start"][event][k] for k in (0, 1)]
        closed = [counts["closed"][event][k] - counts["start"][event][k] for k in (0, 1)]
        print(f"  {label:12}  plain SUMO {plain[0]:>14,}  closed loop {closed[0]:>14,}  "
              f"ratio {closed[0] / plain[0]:.3f};  inside SUMO's step: plain {plain[1]:>14,}  "
              f"closed {closed[1]:>14,}  ratio {closed[1] / plain[1]:.3f}")  # fmt: skip
        lines.append(f"| {label} | {plain[0]:,} | {closed[0]:,} | {closed[0] / plain[0]:.3f} | {plain[1]:,} |"
                     f" {closed[1]:,} | {closed[1] / plain[1]:.3f} |")  # fmt: skip
    print()
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument(
        "--instructions", type=float, metavar="SECONDS", help="also count instructions and L2 misses (valgrind)"
    )
    parser.add_argument("--child", choices=("start", "plain", "closed"), help=argparse.SUPPRESS)
    parser.add_argument("--write-docs", action="store_true", help="write what it measured into its docs page")
    args = parser.parse_args()
    if args.child:
        child(args.child, args.instructions)
        return
    lines = measured(args)
    if args.write_docs:
        flags = " ".join(a for a in sys.argv[1:] if a != "--write-docs")
        page = ROOT / "docs" / "reference" / "generated-code.md"
        write_block("sim", lines, f"bench/bench_sim.py {flags} --write-docs".replace("  ", " "), page)


def measured(args: argparse.Namespace) -> list[str]:
    """Run the measurements `args` ask for, print them, and return them as the docs write them."""
    lines: list[str] = []
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        plain(work, 0.0)  # the network is built once, outside the timings
        load_controller(CONTROLLER)
        labels = ("plain SUMO (libsumo)", f"closed loop, {CONTROLLER}")
        rows: dict[str, list[tuple[float, int, int]]] = {label: [] for label in labels}
        in_step: dict[str, list[float]] = {label: [] for label in labels}
        for k in range(args.repeat):
            order = (plain, closed) if k % 2 == 0 else (closed, plain)
            for measure in order:
                with StepClock() as clock:
                    rows[labels[measure is closed]].append(measure(work))
                in_step[labels[measure is closed]].append(clock.seconds)
        print(f"one 20 km run of the paper's scenario, seed 0, {args.repeat} interleaved pairs:")
        print(f"  {'':24} {'best wall s':>11} {'median s':>9} {'steps':>7} {'vehicle-steps':>14} "
              f"{'vehicle-steps/s':>16}")  # fmt: skip
        lines += ["| | best wall s | median s | steps | vehicle-steps/s |", "|---|---|---|---|---|"]
        for label, samples in rows.items():
            wall, steps, vsteps = min(samples)
            median = statistics.median(s[0] for s in samples)
            print(f"  {label:24} {wall:11.2f} {median:9.2f} {steps:7d} {vsteps:14d} {vsteps / wall:16.0f}")
            lines.append(f"| {label} | {wall:.2f} | {median:.2f} | {steps:,} | {vsteps / wall:,.0f} |")
        pairs = [c[0] / p[0] for p, c in zip(rows[labels[0]], rows[labels[1]], strict=True)]
        best_plain = min(s[0] for s in rows[labels[0]])
        print(f"  ratio closed loop / plain SUMO: median of the pairs {statistics.median(pairs):.2f} "
              f"(pairs {', '.join(f'{r:.2f}' for r in pairs)}); target: at most 1.05")  # fmt: skip
        inside = [c / p for p, c in zip(in_step[labels[0]], in_step[labels[1]], strict=True)]
        around = {
            label: statistics.median(s[0] - t for s, t in zip(rows[label], in_step[label], strict=True))
            for label in labels
        }
        print(f"  inside SUMO's step, median of the pairs' ratios: {statistics.median(inside):.3f}; around the "
              f"steps (Python), median: plain {around[labels[0]]:.3f} s, "
              f"closed loop {around[labels[1]]:.3f} s\n")  # fmt: skip
        lines += [
            "",
            f"The median of the {args.repeat} pairs' ratios closed loop / plain SUMO is"
            f" **{statistics.median(pairs):.2f}** ({min(pairs):.2f} to {max(pairs):.2f}; target: at most 1.05)."
            f" Inside SUMO's step the closed loop's run takes {statistics.median(inside):.3f} times as long (median of"
            f" the pairs); around the steps, plain SUMO spends {around[labels[0]]:.3f} s of Python a run and the"
            f" closed loop {around[labels[1]]:.3f} s.",
        ]
        if args.instructions is not None:
            lines += ["", *instructions(args.instructions)]
        if args.runs < 1:
            return lines
        start = time.perf_counter()
        with ResultsDB.open_for_writing(work / "bench.sqlite") as database:
            sweep = Sweep(load_scenario(), database, args.jobs, timeout_s=600)
            results = sweep.run([(CONTROLLER, 1, seed) for seed in range(args.runs)], lambda r: None)
        wall = time.perf_counter() - start
        failed = sum(r.status != "done" for r in results)
        start = time.perf_counter()
        with mp.get_context("spawn").Pool(args.jobs) as pool:
            pool.map(functools.partial(_plain_seed, work), range(args.runs), chunksize=1)
        plain_wall = time.perf_counter() - start
        print(f"{args.runs} runs (seeds 0..{args.runs - 1}, 1 AV) on {args.jobs} worker processes:")
        print(f"  closed loop, {CONTROLLER} (the sweep, results stored): {wall:.1f} s wall ({failed} failed)")
        print(
            f"  plain SUMO, the same runs: {plain_wall:.1f} s wall; ratio {wall / plain_wall:.2f} "
            "(target: at most 1.15)"
        )
        print(
            f"  {args.runs} runs of plain SUMO at the best single time above ({best_plain:.2f} s), perfectly "
            f"shared: {best_plain * args.runs / args.jobs:.1f} s; the paper: 6.5 hours for its 100 runs"
        )
        lines += [
            "",
            f"{args.runs} runs on {args.jobs} workers: the sweep (results stored) took {wall:.1f} s ({failed} failed),"
            f" and plain SUMO the same runs on {args.jobs} worker processes {plain_wall:.1f} s: ratio"
            f" **{wall / plain_wall:.2f}** (target: at most 1.15).",
        ]
    return lines


if __name__ == "__main__":
    main()
