"""Benchmark figures written into the docs by the benchmark that measured them, never copied by hand.

A page holds a block between `<!-- bench:NAME -->` and `<!-- /bench:NAME -->`; a benchmark run with `--write-docs`
replaces it with its table and a line saying which benchmark wrote it, on which machine and when.
tests/test_bench_figures.py checks that every block was written so and that its ratios are its own figures'.
"""

from __future__ import annotations

import datetime
import platform
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PERFORMANCE = ROOT / "docs" / "explanation" / "performance.md"
README = ROOT / "README.md"  # reports some of the figures too, in blocks of the same names


def machine() -> str:
    """The CPU's model name and core count, as /proc/cpuinfo tells them (the platform's name elsewhere)."""
    try:
        info = Path("/proc/cpuinfo").read_text(encoding="utf-8")
    except OSError:
        return platform.machine()
    models = re.findall(r"^model name\s*:\s*(.+)$", info, re.MULTILINE)
    return f"{models[0].strip()}, {len(models)} cores" if models else platform.machine()


def write_block(name: str, table: list[str], by: str, page: Path = PERFORMANCE) -> None:
    """Replace block `name` of `page`, and of the README where it reports the same figures, with `table` and a
    line naming the benchmark `by`, the machine and the date."""
    stamp = f"Written by `{by}` on {machine()}, {datetime.date.today().isoformat()}."
    block = "\n".join([*table, "", stamp, ""])
    pattern = re.compile(rf"(<!-- bench:{name} -->\n).*?(<!-- /bench:{name} -->)", re.DOTALL)
    for target in (page, README):
        text = target.read_text(encoding="utf-8")
        if not pattern.search(text):
            if target == page:
                raise SystemExit(f"{page}: no block <!-- bench:{name} -->")
            continue
        target.write_text(pattern.sub(lambda m: m.group(1) + block + m.group(2), text), encoding="utf-8")
        print(f"wrote the block {name} of {target.relative_to(ROOT)}")
