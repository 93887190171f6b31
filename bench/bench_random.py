"""Random machines through every code-side command, thousands at a time: the suite's rule (the loader or the
generator refuses the spec in one line at its place, or gen, compile, the exhaustive and sequence comparisons,
Frama-C WP, cppcheck and the generated test suite all pass) on many more draws than the suite makes.

Run on demand: `.venv/bin/python bench/bench_random.py [--count N] [--seed S] [--kind data|bool|both]
[--keep DIR]`. It runs tests/test_random_machines.py under pytest as a survey (each machine's outcome written to
a JSON-lines file instead of asserted; every machine and what each command said kept under DIR), then counts the
machines refused, passed, failed for the spec's own fault and failed, and groups the failures by what failed. A
machine takes 10 s to about a minute (Frama-C WP is most of it): 1,000 take several hours on 2 cores.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def failure_class(line: str) -> str:
    """What failed, without the numbers and places that differ from one machine to the next."""
    text = re.sub(r"\w+_fsm\.[ch]:\d+:\d+", "FILE:L:C", line)
    text = re.sub(r"\d+(\.\d+)?%?", "N", text)
    return text[:150]


def survey(count: int, seed: int, kind: str, keep: Path) -> list[dict[str, object]]:
    log = keep / "outcomes.jsonl"
    log.unlink(missing_ok=True)
    env = {
        **os.environ,
        "RANDOM_SURVEY": str(log),
        "RANDOM_COUNT": str(count),
        "RANDOM_SEED": str(seed),
        "RANDOM_KIND": kind,
        "RANDOM_KEEP": str(keep),
    }
    test = "tests/test_random_machines.py::test_random_machines_pass_every_command"
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", test]
    subprocess.run(command, check=False, cwd=ROOT, env=env)
    return [json.loads(line) for line in log.read_text(encoding="utf-8").splitlines()] if log.exists() else []


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--kind", choices=["data", "bool", "both"], default="both")
    parser.add_argument("--keep", type=Path, default=None, help="where to write each machine (default: a temp dir)")
    args = parser.parse_args()
    keep = (args.keep or Path(tempfile.mkdtemp(prefix="random-machines-"))).resolve()
    keep.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    outcomes = survey(args.count, args.seed, args.kind, keep)
    counts: collections.Counter[str] = collections.Counter()
    classes: collections.Counter[str] = collections.Counter()
    for o in outcomes:
        failed = [str(x) for x in o["failed"]]  # type: ignore[attr-defined]
        verdict = "failed" if failed else "refused" if o["refused"] else "spec-fault" if o["spec_fault"] else "passed"
        counts[verdict] += 1
        classes.update(failure_class(line) for line in failed)
    minutes = (time.perf_counter() - start) / 60
    said = ", ".join(f"{counts[v]} {v}" for v in ("passed", "refused", "spec-fault", "failed"))
    print(f"\n{len(outcomes)} machines ({args.kind}, seed {args.seed}) in {minutes:.1f} min: {said}; kept in {keep}")
    for cls, n in classes.most_common():
        print(f"  {n:5}  {cls}")


if __name__ == "__main__":
    main()
