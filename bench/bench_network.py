"""Benchmark `check` on networks: the repaired V2V protocol of spec/v2v, from 2 to 8 AVs.

Run on demand: `.venv/bin/python bench/bench_network.py [--max N] [--whole-max N] [--reps N] [--write-docs]`.
For each number of AVs, a network of spec/v2v/mlca_t_claim.toml instances around one gap (A, with priority, and
every second AV after it in the lane right of the gap, the others in the lane left of it), every AV hearing every
other's claims over a channel that loses at most one message in a row and delivers it one or two steps late. It
prints the flat machine's size, then the time of `one-into-the-gap` for A and B decided on their part of the
network (every other AV's claims anything at any step: the proof that holds for any number of AVs) and, up to
`--whole-max` AVs, on the whole flat machine, each the median of `--reps` interleaved repetitions; then the time
of each property of the shipped three-AV network.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from figures import write_block  # run as a script: bench/ is on the path
from mlca_verify.logic.datachecks import check_declared
from mlca_verify.logic.induction import Limits
from mlca_verify.network import Network, flatten
from mlca_verify.network_report import check_network
from mlca_verify.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
V2V = ROOT / "spec" / "v2v"
LIMITS = Limits(timeout_ms=60_000)


def avs(n: int) -> Network:
    """`n` AVs of the repaired protocol around one gap, every claim heard by every other AV, and A and B's
    `one-into-the-gap` (the shipped network's first property)."""
    shipped = load_spec(V2V / "gap_repaired.toml", network=True).network
    assert shipped is not None
    a, b = shipped.instance("A"), shipped.instance("B")
    names = [chr(ord("A") + k) for k in range(n)]
    right = {name for k, name in enumerate(names) if k % 2 == 0}  # A, C, E, G: right of the gap, moving left
    instances = [replace(a if name == "A" else b, name=name) for name in names]
    template = shipped.channels[0]
    channels = [
        replace(
            template,
            id=f"{s.lower()}_to_{r.lower()}",
            sender=s,
            output="claims_left" if s in right else "claims_right",
            receiver=r,
            port="heard_left" if r in right else "heard_right",
        )
        for s in names
        for r in names
        if s != r
    ]
    return replace(
        shipped,
        name=f"Gap{n}",
        instances=tuple(instances),
        channels=tuple(channels),
        invariants=shipped.invariants[:1],
        liveness=(),
    )


def _timed(decide: Callable[[], str]) -> tuple[float, str]:
    start = time.perf_counter()
    verdict = decide()
    return time.perf_counter() - start, verdict


def _on_part(net: Network) -> str:
    (result,) = check_network(net, flatten(net), LIMITS)
    return result.verdict if "alone" in result.detail else f"{result.verdict} (whole)"


def _on_whole(net: Network) -> str:
    (result,) = check_declared(flatten(net), LIMITS, {net.invariants[0].id})
    return result.verdict


def growth(most: int, whole_most: int, reps: int) -> list[str]:
    lines = [
        "| AVs | channels | flat variables | on A and B's part | on the whole network |",
        "|---:|---:|---:|---|---|",
    ]
    for n in range(2, most + 1):
        net = avs(n)
        part_times, whole_times = [], []
        part_verdict = whole_verdict = ""
        for _ in range(reps):  # interleaved: part, whole, part, whole, ...
            seconds, part_verdict = _timed(lambda net=net: _on_part(net))
            part_times.append(seconds)
            if n <= whole_most:
                seconds, whole_verdict = _timed(lambda net=net: _on_whole(net))
                whole_times.append(seconds)
        whole = f"{statistics.median(whole_times):.1f} s, {whole_verdict}" if whole_times else "not run"
        size = len(flatten(net).variables)
        lines.append(
            f"| {n} | {len(net.channels)} | {size} | {statistics.median(part_times):.1f} s, {part_verdict} | {whole} |"
        )
        print(lines[-1], flush=True)
    return lines


def shipped() -> list[str]:
    loaded = load_spec(V2V / "gap_repaired.toml", network=True)
    assert loaded.network is not None
    lines = ["| property of spec/v2v/gap_repaired.toml | verdict | seconds | decided |", "|---|---|---:|---|"]
    for r in check_network(loaded.network, loaded.machine, Limits()):
        where = r.detail.rpartition("; on ")[2].removesuffix(", whatever the others send")
        where = where if "alone" in r.detail else "whole"
        lines.append(f"| {r.prop} | {r.verdict} | {r.seconds:.1f} | {where} |")
        print(lines[-1], flush=True)
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max", type=int, default=8, help="the most AVs (default 8)")
    parser.add_argument("--whole-max", type=int, default=4, help="the most AVs decided on the whole (default 4)")
    parser.add_argument("--reps", type=int, default=1, help="interleaved repetitions of each timing (default 1)")
    parser.add_argument("--write-docs", action="store_true", help="write the tables into the docs' performance page")
    args = parser.parse_args()
    print("one-into-the-gap for A and B, by the number of AVs:")
    table = growth(args.max, args.whole_max, args.reps)
    print("the shipped three-AV network:")
    three = shipped()
    if args.write_docs:
        by = f"bench/bench_network.py --max {args.max} --whole-max {args.whole_max} --reps {args.reps}"
        write_block("network-growth", table, by)
        write_block("network-shipped", three, by)


if __name__ == "__main__":
    main()
