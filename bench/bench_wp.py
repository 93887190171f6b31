"""Frama-C WP goals and time against the size of the spec, for the generated C of machines with and without data.

Run on demand: `.venv/bin/python bench/bench_wp.py [--quick]`. The size of a spec is its states plus its
transitions, a `from = "*"` transition counted once per state it leaves. Families, each generated with
`mlca-verify gen` and proved with the same flags as `mlca-verify conform` (check frama-c-wp):
- boolean machines: the pedestrian crossing with its minimum green expanded into n states (bench_check.py);
- machines with data: a chain of n modes, each left after a timer has run (one `int` timer, a reset from
  every mode), then the pedestrian crossing with a 5 s minimum green as a timer, and MLCA-T.
For each it prints the goals, the wall time, and both per unit of size: linear growth keeps those two columns
flat. Wall times are of one run on a noisy 2-core machine; the goal counts are exact.

Then, side by side in one run, Alg. 1 and the repair: the step generated today against the boolean pipeline's
(bench/reference/boolean/, its last version), each proved with the same flags; the median of interleaved pairs.
`--write-docs` writes both tables into docs/explanation/performance.md (see figures.py).
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))

from bench_check import GREEN, crossing_expanded, crossing_timed  # noqa: E402
from figures import write_block  # noqa: E402
from mlca_verify.codegen import generate  # noqa: E402
from mlca_verify.conformance.c_tools import wp_file  # noqa: E402
from mlca_verify.conformance.generated_code import WP_FLAGS  # noqa: E402
from mlca_verify.spec import load_spec  # noqa: E402


def chain(n: int) -> str:
    """n modes in a row, each left for the next once `go` holds and the timer has reached DWELL."""
    modes = [f"M{k}" for k in range(n)]
    lines = [
        "[machine]",
        'name = "chain"',
        'initial = "M0"',
        "states = [" + ", ".join(f'"{s}"' for s in modes) + "]",
        'semantics = "first-match"',
        'otherwise = "stay"',
        "",
        "[inputs]",
        'go = { doc = "advance", cite = "bench" }',
        'stop = { doc = "back to the start", cite = "bench" }',
        "",
        "[params]",
        'DWELL = { type = "int", default = 5, range = [1, 50], unit = "step", doc = "dwell", cite = "bench" }',
        "",
        "[variables]",
        't = { type = "int", initial = 0, range = [0, 100], unit = "step", every = "min(t + 1, 100)", '
        'doc = "steps in this mode", cite = "bench" }',
        "",
        "[[transition]]",
        'id = "stop"',
        'from = "*"',
        f'to = "{modes[0]}"',
        'when = "stop"',
        'do = "t = 0"',
        'cite = "bench"',
    ]
    for k, mode in enumerate(modes):
        lines += [
            "",
            "[[transition]]",
            f'id = "advance{k}"',
            f'from = "{mode}"',
            f'to = "{modes[(k + 1) % n]}"',
            'when = "go and t >= DWELL"',
            'do = "t = 0"',
            'cite = "bench"',
        ]
    lines += ["", "[[invariant]]", 'id = "timer"', 'expr = "t <= 100"', 'cite = "bench"']
    return "\n".join(lines) + "\n"


def measure(name: str, text: str | None, work: Path, spec: Path | None = None) -> str:
    """Prove one spec's generated C; print its row and return it as a row of the docs' table."""
    if spec is None:
        spec = work / f"{name}.toml"
        spec.write_text(text or "", encoding="utf-8")
    machine = load_spec(spec, compare=False)
    m = machine.machine
    size = len(m.states) + sum(sum(1 for s in m.states if t.applies_to(s)) for t in m.transitions)
    out = work / name
    files = generate(machine, out)
    for rel, body in files.items():
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text(body, encoding="utf-8")
    c_file = next(out.rglob("*_fsm.c"))
    module = c_file.name.removesuffix("_fsm.c")
    extra = (*WP_FLAGS, "-wp-skip-fct", f"{module}_monitor")
    build = work / f"{name}_build"
    build.mkdir()
    start = time.monotonic()
    outcome = wp_file(c_file, build, extra)
    seconds = time.monotonic() - start
    data = outcome.data or {}
    proved, goals = data.get("proved", 0), data.get("goals", 0)
    kind = "data" if m.variables or m.signals or m.params else "bool"
    print(
        f"{name:<28} {kind:>4} {size:>5} {goals:>6} {proved:>6} {seconds:>8.1f}"
        f" {goals / size:>9.2f} {seconds / size:>9.3f}",
        flush=True,
    )
    cells = (f"`{name}`", kind, size, goals, proved, f"{seconds:.1f}", f"{goals / size:.2f}", f"{seconds / size:.3f}")
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _proved_in(c_file: Path, work: Path) -> tuple[int, float]:
    """The goals of one file and the seconds WP took to prove them all (it fails loudly if one is left)."""
    build = Path(tempfile.mkdtemp(dir=work))
    module = c_file.name.removesuffix("_fsm.c")
    skip = ("-wp-skip-fct", f"{module}_monitor") if f"{module}_monitor(" in c_file.read_text() else ()
    start = time.monotonic()
    outcome = wp_file(c_file, build, (*WP_FLAGS, *skip))
    seconds = time.monotonic() - start
    data = outcome.data or {}
    if not outcome.ok:
        raise SystemExit(f"{c_file}: {outcome.detail}")
    return int(data.get("goals", 0)), seconds


def against_the_boolean_pipeline(work: Path, pairs: int) -> list[str]:
    """Today's generated C and the boolean pipeline's for the shipped boolean machines, proved alternately: the
    rows of the docs' table."""
    rows = []
    print(f"\nside by side, median of {pairs} interleaved pairs")
    print(f"{'spec':<14} {'goals':>6} {'wp (s)':>8} {'old goals':>10} {'old wp (s)':>11} {'time ratio':>11}")
    for spec in ("mlca", "mlca_r"):
        ours, old = work / f"{spec}_now", work / f"{spec}_old"
        for folder, source in ((ours, ROOT / "generated" / "c"), (old, ROOT / "bench" / "reference" / "boolean")):
            folder.mkdir()
            for suffix in ("_fsm.c", "_fsm.h"):
                shutil.copy(source / f"{spec}{suffix}", folder)
        now_c, old_c = ours / f"{spec}_fsm.c", old / f"{spec}_fsm.c"
        runs = [(_proved_in(now_c, work), _proved_in(old_c, work)) for _ in range(pairs)]
        now_s = statistics.median(a[1] for a, _ in runs)
        old_s = statistics.median(b[1] for _, b in runs)
        print(f"{spec:<14} {runs[0][0][0]:>6} {now_s:>8.1f} {runs[0][1][0]:>10} {old_s:>11.1f} {now_s / old_s:>11.2f}")
        goals, old_goals = runs[0][0][0], runs[0][1][0]
        cells = (f"`spec/{spec}.toml`", goals, f"{now_s:.1f}", old_goals, f"{old_s:.1f}", f"{now_s / old_s:.2f}")
        rows.append("| " + " | ".join(str(c) for c in cells) + " |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="smaller families")
    parser.add_argument("--write-docs", action="store_true", help="write both tables into their docs page")
    args = parser.parse_args()
    expanded = (3, 6, 12) if args.quick else (3, 6, 12, 24, 48)
    chains = (2, 4, 8) if args.quick else (2, 4, 8, 16)
    head = ("spec", "kind", "size", "goals", "proved", "wp (s)", "goals/size", "s/size")
    print(f"{head[0]:<28} " + " ".join(f"{h:>{w}}" for h, w in zip(head[1:], (4, 5, 6, 6, 8, 9, 9), strict=True)))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        rows = [measure(f"crossing_expanded_{n}", crossing_expanded(n), work) for n in expanded]
        rows += [measure(f"chain_{n}", chain(n), work) for n in chains]
        rows.append(measure(f"crossing_timed_{GREEN}", crossing_timed(GREEN), work))
        rows.append(measure("mlca_t", None, work, ROOT / "spec" / "mlca_t.toml"))
        pairs = against_the_boolean_pipeline(work, 1 if args.quick else 3)
    if args.write_docs:
        by = f"bench/bench_wp.py{' --quick' if args.quick else ''} --write-docs"
        write_block("wp-size", [SIZE_HEAD, "|---|---|---|---|---|---|---|---|", *rows], by)
        write_block("wp-boolean", [PAIR_HEAD, "|---|---|---|---|---|---|", *pairs], by)


SIZE_HEAD = "| spec | kind | size | goals | proved | WP (s) | goals / size | s / size |"
PAIR_HEAD = "| spec | goals | WP (s) | boolean pipeline: goals | WP (s) | time ratio |"


if __name__ == "__main__":
    main()
