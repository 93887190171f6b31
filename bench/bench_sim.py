"""Benchmark the closed loop against plain SUMO on the same run, and the time of a 100-run sweep.

Run on demand: `.venv/bin/python bench/bench_sim.py [--runs 100] [--jobs 2] [--repeat 3]`. Prints, side by
side in one run, for the paper's scenario (20 km, 100 cars, step 0.1 s, one AV, seed 0):
- plain SUMO through libsumo, stepping until the AV arrives, the AV left to SUMO's own lane changing;
- the closed loop (sensing, the generated C controller, the runtime monitor, metrics), the controller loaded
  beforehand as a sweep worker has it;
their ratio (target: at most 1.1), vehicle-steps per second, and the wall time of a sweep of RUNS runs of one
configuration over JOBS worker processes (target: 100 runs in under 2 minutes).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import libsumo

from sim_check.controllers import load_controller
from sim_check.runner import run_once, sumo_args
from sim_check.scenario import build, load_scenario
from sim_check.sweep import Sweep


def plain(work: Path) -> tuple[float, int, int]:
    scenario = load_scenario()
    built = build(scenario, 0, work)
    start = time.perf_counter()
    libsumo.start(sumo_args(scenario, built.net, built.routes, 0))
    steps = vehicle_steps = 0
    arrived = False
    while not arrived:
        libsumo.simulationStep()
        steps += 1
        vehicle_steps += libsumo.vehicle.getIDCount()
        arrived = "av0" in libsumo.simulation.getArrivedIDList()
    libsumo.close()
    return time.perf_counter() - start, steps, vehicle_steps


def closed(work: Path) -> tuple[float, int, int]:
    load_controller("mlca-c")
    start = time.perf_counter()
    result = run_once(load_scenario(), "mlca-c", 0, work)
    return time.perf_counter() - start, result.sim_steps, result.vehicle_steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        rows: dict[str, list[tuple[float, int, int]]] = {"plain SUMO (libsumo)": [], "closed loop, mlca-c": []}
        for _ in range(args.repeat):  # interleaved, so that a slower spell of the machine hits both alike
            rows["plain SUMO (libsumo)"].append(plain(work))
            rows["closed loop, mlca-c"].append(closed(work))
        print(f"one 20 km run of the paper's scenario, seed 0, best of {args.repeat}:")
        print(f"  {'':24} {'wall s':>8} {'steps':>7} {'vehicle-steps':>14} {'vehicle-steps/s':>16}")
        best = {}
        for label, samples in rows.items():
            wall, steps, vsteps = min(samples)
            best[label] = wall
            print(f"  {label:24} {wall:8.2f} {steps:7d} {vsteps:14d} {vsteps / wall:16.0f}")
        ratio = best["closed loop, mlca-c"] / best["plain SUMO (libsumo)"]
        print(f"  ratio closed loop / plain SUMO: {ratio:.2f} (target: at most 1.1)\n")
        start = time.perf_counter()
        sweep = Sweep(load_scenario(), work / "bench.sqlite", args.jobs, timeout_s=600)
        results = sweep.run([("mlca-c", 1, seed) for seed in range(args.runs)], lambda r: None)
        wall = time.perf_counter() - start
        failed = sum(r.status != "done" for r in results)
        print(f"sweep: {args.runs} runs of mlca-c with 1 AV on {args.jobs} workers: {wall:.1f} s wall "
              f"({wall / args.runs:.2f} s per run), {failed} failed (target: 100 runs in under 120 s; "
              "the paper: 6.5 hours for its 100 runs)")  # fmt: skip


if __name__ == "__main__":
    main()
