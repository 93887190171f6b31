"""Benchmark a three-AV run whose AVs talk to each other (each its own generated instance of the repaired V2V
protocol, spec/v2v/mlca_t_claim.toml, its claims carried by the seeded lossy radio) against plain SUMO on the
same run.

Run on demand: `.venv/bin/python bench/bench_v2v.py [--repeat 7] [--seed 0] [--controller mlca_t_claim-c]
[--scenario FILE]`. The scenario is sim_check/scenarios/v2v_lossy.toml by default (3 km, 30 cars, three AVs,
30% of the messages lost, never two in a row on a channel, read 1 to 2 steps late). It runs REPEAT interleaved
pairs (the order alternating, so that a slower spell of the machine hits both alike): plain SUMO through libsumo
stepped from Python until the AVs arrive, the AVs left to SUMO's own lane changing
(`sim_check.runner.run_plain`), and the closed loop with the controller (the need, the raw signals, the radio,
each AV's decision function and monitor, the metrics and SUMO's SSM device). Each run is a process of its own
(libsumo keeps one simulation per process), timed inside it from SUMO's start, the controller built beforehand.
Prints the best of each side and the median of the pairs' ratios (the target: at most 1.15), of the whole runs
and per SUMO step.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENARIO = ROOT / "sim_check" / "scenarios" / "v2v_lossy.toml"


def child(kind: str, controller: str, seed: int, scenario_path: Path) -> None:
    """One run in this process; prints its wall seconds (from SUMO's start) and what the radio carried."""
    from sim_check.controllers import load_controller
    from sim_check.runner import run_once, run_plain
    from sim_check.scenario import load_scenario

    scenario = load_scenario(scenario_path)
    with tempfile.TemporaryDirectory() as work:
        if kind == "plain":
            wall, steps, _ = run_plain(scenario, seed, Path(work))
            print(json.dumps({"wall": wall, "steps": steps}))
            return
        load_controller(controller)
        result = run_once(scenario, controller, seed, Path(work))
        print(json.dumps({"wall": result.wall_s, "steps": result.sim_steps, "sent": result.v2v.sent}))


def run(kind: str, controller: str, seed: int, scenario: Path) -> dict[str, float]:
    command = [sys.executable, __file__, "--child", kind, "--controller", controller, "--seed", str(seed)]
    command += ["--scenario", str(scenario)]
    done = subprocess.run(command, capture_output=True, text=True, check=True, cwd=ROOT)
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--controller", default="mlca_t_claim-c")
    parser.add_argument("--scenario", type=Path, default=SCENARIO, help="with three AVs and a [v2v] section")
    parser.add_argument("--child", choices=("plain", "closed"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.controller, args.seed, args.scenario)
        return
    plain, closed, per_step = [], [], []
    for k in range(args.repeat):
        order = ("plain", "closed") if k % 2 == 0 else ("closed", "plain")
        got = {kind: run(kind, args.controller, args.seed, args.scenario) for kind in order}
        plain.append(got["plain"]["wall"])
        closed.append(got["closed"]["wall"])
        per_step.append(
            (got["closed"]["wall"] / got["closed"]["steps"]) / (got["plain"]["wall"] / got["plain"]["steps"])
        )
        print(
            f"pair {k + 1}: plain {got['plain']['wall']:.3f} s ({got['plain']['steps']:.0f} steps), closed loop "
            f"{got['closed']['wall']:.3f} s ({got['closed']['steps']:.0f} steps, {got['closed']['sent']:.0f} messages)"
        )
    ratios = [c / p for c, p in zip(closed, plain, strict=True)]
    print(
        f"{args.controller} on {args.scenario}, seed {args.seed}, {args.repeat} interleaved pairs: "
        f"plain best {min(plain):.3f} s, closed loop best {min(closed):.3f} s; median of the pairs' ratios "
        f"{statistics.median(ratios):.3f} (target at most 1.15); per SUMO step (the AVs arrive at other steps when "
        f"SUMO's model drives them) {statistics.median(per_step):.3f}"
    )


if __name__ == "__main__":
    main()
