"""Every machine of the corpus (tests/machines/) through every command, as a user runs them: check, gen, conform
(all its checks), tests (on the host and, unless --no-target, the Cortex-M4 under QEMU), evidence, diagram in
every format the machine is drawn in, and diff against a copy with one more `[[assume]]` (a weakening, which diff
must call a regression). The suite takes each machine through the cheaper of these (tests/test_corpus.py,
tests/test_explicit.py); this runs them all, which takes about ten minutes a machine on 2 cores (Frama-C WP in
conform and again in evidence is most of it).

Run on demand: `.venv/bin/python bench/bench_corpus.py [NAME ...] [--no-target] [--keep DIR]`. Each command runs
in a process of its own; the table gives each command's exit code and seconds per machine, then every line a
failing command printed with FAIL or "not supported".
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from mlca_verify.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "machines"
CLI = Path(sys.executable).parent / "mlca-verify"
EXPECTED = {"diff": 1}  # the weakened copy is a regression: diff exits 1; every other command exits 0


@dataclass
class Row:
    name: str
    codes: dict[str, int] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    failing: list[str] = field(default_factory=list)


def weakened(spec: Path, work: Path) -> Path:
    """The spec with one more assumption: its first boolean input, else its first signal's validity."""
    machine = load_spec(spec).machine
    assumed = machine.inputs[0].name if machine.inputs else f"valid({machine.signals[0].name})"
    copy = work / spec.name
    copy.write_text(
        spec.read_text(encoding="utf-8") + f'\n[[assume]]\nid = "weaker"\nexpr = "{assumed}"\n', encoding="utf-8"
    )
    return copy


def commands(spec: Path, work: Path, target: bool) -> dict[str, list[str]]:
    gen = str(work / "gen")
    tests = ["tests", "--generated", gen, "--out", str(work / "tests"), str(spec)]
    return {
        "check": ["check", "--quiet", str(spec)],
        "gen": ["gen", "--out", gen, str(spec)],
        "conform": ["conform", "--generated", gen, str(spec)],
        "tests": tests if target else [*tests[:1], "--no-target", *tests[1:]],
        "evidence": ["evidence", "--no-tests", "--generated", gen, "--out", str(work / "evidence"), str(spec)],
        "diagram": ["diagram", "--format", "svg", "--out", str(work / "d.svg"), str(spec)],
        "diff": ["diff", str(spec), str(weakened(spec, work))],
    }


def through(spec: Path, work: Path, target: bool) -> Row:
    row = Row(spec.stem)
    for label, argv in commands(spec, work, target).items():
        start = time.perf_counter()
        done = subprocess.run([str(CLI), *argv], capture_output=True, text=True, cwd=ROOT, check=False)
        row.seconds[label] = time.perf_counter() - start
        row.codes[label] = done.returncode
        if done.returncode != EXPECTED.get(label, 0):
            said = [ln.strip() for ln in done.stdout.splitlines() if "FAIL" in ln or "not supported" in ln]
            row.failing += [f"{label}: {ln}" for ln in said or done.stderr.strip().splitlines()[-1:]]
        if label == "gen" and done.returncode != 0:
            break
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="machines of tests/machines/ (default: all)")
    parser.add_argument("--no-target", action="store_true", help="leave out the Cortex-M4 run of the suites")
    parser.add_argument("--keep", type=Path, default=None, help="where to write each machine's outputs")
    args = parser.parse_args()
    specs = [CORPUS / f"{n}.toml" for n in args.names] or sorted(CORPUS.glob("*.toml"))
    keep = (args.keep or Path(tempfile.mkdtemp(prefix="corpus-"))).resolve()
    labels = ["check", "gen", "conform", "tests", "evidence", "diagram", "diff"]  # the order `commands` runs them
    print(f"{'machine':<24}" + "".join(f"{label:>12}" for label in labels))
    rows = []
    for spec in specs:
        work = keep / spec.stem
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)
        row = through(spec, work, not args.no_target)
        rows.append(row)
        cells = [f"{row.codes[label]} {row.seconds[label]:6.1f}s" if label in row.codes else "-" for label in labels]
        print(f"{row.name:<24}" + "".join(f"{c:>12}" for c in cells), flush=True)
    failed = [r for r in rows if r.failing]
    print(f"\n{len(rows) - len(failed)} passed, {len(failed)} failed (outputs in {keep})")
    for r in failed:
        print(f"  {r.name}: " + "; ".join(r.failing))


if __name__ == "__main__":
    main()
