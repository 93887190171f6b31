"""The benchmark figures on the docs pages are written by the benchmarks themselves (`--write-docs`, see
bench/figures.py), never copied by hand: each block names the benchmark that wrote it, the machine and the
date, and its ratios are its own figures' quotients."""

from __future__ import annotations

import csv
import re
import statistics
from pathlib import Path

from tests.conftest import ROOT

BLOCK = re.compile(r"<!-- bench:(?P<name>[\w-]+) -->\n(?P<body>.*?)<!-- /bench:(?P=name) -->", re.DOTALL)
STAMP = re.compile(r"^Written by `(?P<bench>bench/\w+\.py)[^`]*` on .+, \d{4}-\d{2}-\d{2}\.$", re.MULTILINE)
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
TOLERANCE = 0.002  # the table's figures are rounded to 0.01; the ratio is of the unrounded ones


def _blocks() -> list[tuple[Path, str, str]]:
    return [(p, m["name"], m["body"]) for p in PAGES for m in BLOCK.finditer(p.read_text(encoding="utf-8"))]


def _number(cell: str) -> float:
    return float(cell.strip().strip("*").removesuffix(" B").replace(",", ""))


def test_every_block_is_stamped_by_the_benchmark_that_writes_it() -> None:
    blocks = _blocks()
    assert {name for _, name, _ in blocks} >= {
        "mlca-t", "corpus", "mlca", "wp-size", "wp-boolean",
        "check-shipped", "check-sharing", "check-corpora", "check-growth", "check-data", "matrix", "formats",
        "floor", "floor-exit",
    }  # fmt: skip
    for page, name, body in blocks:
        stamp = STAMP.search(body)
        assert stamp is not None, f"{page.name}: block {name} was not written by a benchmark"
        source = (ROOT / stamp["bench"]).read_text(encoding="utf-8")
        written = re.search(rf'write_block\(\s*"{re.escape(name)}"', source)
        by_scenario = re.search(r'name = f"floor-\{.*\bwrite_block\(name', source, re.DOTALL)  # floor-NAME
        written = written or (name.startswith("floor") and by_scenario)
        assert written or f'DOCS["{name}"]' in source or f'DOCS.setdefault("{name}"' in source


Rows = list[list[str]]
BOLD = re.compile(r"\*\*([\d.]+)\*\*")


def _corpus(body: str, data: Rows) -> int:
    for cells in data:
        ins, hand_ins, ins_ratio, text, hand_text, text_ratio = (_number(c) for c in cells[1:])
        assert abs(ins / hand_ins - ins_ratio) < TOLERANCE and abs(text / hand_text - text_ratio) < TOLERANCE
    return len(data)


def _mlca_t(body: str, data: Rows) -> int:
    (gen_ins, gen_text), (hand_ins, hand_text) = [(_number(r[1]), _number(r[2])) for r in data]
    quoted = [float(q) for q in BOLD.findall(body)]
    assert abs(quoted[0] - gen_ins / hand_ins) < TOLERANCE and abs(quoted[1] - gen_text / hand_text) < TOLERANCE
    return 1


def _mlca(body: str, data: Rows) -> int:
    row = {r[0]: (_number(r[1]), _number(r[2])) for r in data}
    gen, hand = row["generated mlca_step"], [v for k, v in row.items() if k.startswith("hand")]
    quoted = [float(q) for q in BOLD.findall(body)]
    assert abs(quoted[0] - gen[0] / min(h[0] for h in hand)) < TOLERANCE
    assert abs(quoted[1] - gen[1] / min(h[1] for h in hand)) < TOLERANCE
    return 1


def _sharing(body: str, data: Rows) -> int:
    whole = [cells for cells in data if cells[3]]  # a spec's whole check, shared and one unrolling per query
    for cells in whole:
        shared, alone = _number(cells[1].removesuffix(" s")), _number(cells[2].removesuffix(" s"))
        assert abs(shared / alone - _number(cells[3])) < 0.01 + 0.005 * 2 / alone
    return len(whole)


def _matrix(body: str, data: Rows) -> int:
    """The means of the wall times the sweep recorded."""
    walls: dict[tuple[str, int], list[float]] = {}
    with (ROOT / "docs" / "comparison" / "runs.csv").open(encoding="utf-8", newline="") as f:
        for run in csv.DictReader(f):
            walls.setdefault((run["controller"], int(run["avs"])), []).append(float(run["wall_s"]))
    for cells in data:
        means = [round(statistics.mean(walls[cells[0].strip("`"), n]), 2) for n in (1, 3)]
        assert [_number(c) for c in cells[1:3]] == means
    return len(data)


def _wp_boolean(body: str, data: Rows) -> int:
    for cells in data:
        now, old, ratio = _number(cells[2]), _number(cells[4]), _number(cells[5])
        assert abs(now / old - ratio) < 0.006 + 0.05 / old + 0.05 * now / old**2  # the times are rounded to 0.1 s
    return len(data)


def _wp_size(body: str, data: Rows) -> int:
    for cells in data:
        size, goals, proved, seconds = (_number(c) for c in cells[2:6])
        assert goals == proved and abs(goals / size - _number(cells[6])) < 0.01
        assert abs(seconds / size - _number(cells[7])) < 0.001 + 0.05 / size  # seconds rounded to 0.1
    return len(data)


def _formats(body: str, data: Rows) -> int:
    sizes = {cells[0]: _number(cells[2]) for cells in data}
    (quoted,) = [float(q) for q in BOLD.findall(body)]
    assert abs(quoted - sizes["binary32"] / sizes["binary64"]) < TOLERANCE
    return len(data)


def _floor(body: str, data: Rows) -> int:
    """Each ratio is its row's closed loop over plain SUMO, and the matrix against its floor is the sums' quotient."""
    loop = plain = 0.0
    for cells in data:
        for a, b, ratio in (cells[1:4], cells[4:7]):
            assert abs(_number(a) / _number(b) - _number(ratio)) < 0.006 + 0.005 * 2 / _number(b)
            loop, plain = loop + _number(a), plain + _number(b)
    (quoted,) = [float(q) for q in BOLD.findall(body)]
    assert abs(quoted - loop / plain) < 0.006
    return len(data)


CHECKS = {
    "floor": _floor,
    "floor-exit": _floor,
    "formats": _formats,
    "corpus": _corpus,
    "mlca-t": _mlca_t,
    "mlca": _mlca,
    "check-sharing": _sharing,
    "matrix": _matrix,
    "wp-boolean": _wp_boolean,
    "wp-size": _wp_size,
}


def test_the_ratios_are_the_figures_quotients() -> None:
    checked = 0
    for _, name, body in _blocks():
        rows = [[c.strip() for c in line.strip("|").split("|")] for line in body.splitlines() if line.startswith("| ")]
        data = [r for r in rows[1:] if not set(r[0]) <= {"-"}]
        if name in CHECKS:
            checked += CHECKS[name](body, data)
    assert checked >= 31


def test_the_readme_reports_the_code_figures_of_the_performance_page() -> None:
    """The README's blocks are the performance page's, written by the same run, and its sentence on the targets
    says which steps meet them (at most 1.3 for the corpus machines, 1.0 for MLCA-T, on both ratios)."""
    readme = {name: body for page, name, body in _blocks() if page.name == "README.md"}
    performance = {name: body for page, name, body in _blocks() if page.name == "performance.md"}
    assert set(readme) == {"corpus", "mlca-t"} and all(readme[n] == performance[n] for n in readme)
    corpus_met = all(float(q) <= 1.3 for q in BOLD.findall(readme["corpus"]))
    mlca_t_met = all(float(q) <= 1.0 for q in BOLD.findall(readme["mlca-t"]))
    text = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    said = re.search(
        r"which the pump, the thermostat and the flasher (meet|do not meet) and MLCA-T (does not|does)", text
    )
    assert said is not None and (said[1] == "meet") == corpus_met and (said[2] == "does") == mlca_t_met
