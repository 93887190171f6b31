"""The benchmark figures on the docs pages are written by the benchmarks themselves (`--write-docs`, see
bench/figures.py), never copied by hand: each block names the benchmark that wrote it, the machine and the
date, and its ratios are its own figures' quotients."""

from __future__ import annotations

import re
from pathlib import Path

from tests.conftest import ROOT

BLOCK = re.compile(r"<!-- bench:(?P<name>[\w-]+) -->\n(?P<body>.*?)<!-- /bench:(?P=name) -->", re.DOTALL)
STAMP = re.compile(r"^Written by `(?P<bench>bench/\w+\.py)[^`]*` on .+, \d{4}-\d{2}-\d{2}\.$", re.MULTILINE)
PAGES = sorted((ROOT / "docs").rglob("*.md"))
TOLERANCE = 0.002  # the table's figures are rounded to 0.01; the ratio is of the unrounded ones


def _blocks() -> list[tuple[Path, str, str]]:
    return [(p, m["name"], m["body"]) for p in PAGES for m in BLOCK.finditer(p.read_text(encoding="utf-8"))]


def _number(cell: str) -> float:
    return float(cell.strip().strip("*").removesuffix(" B").replace(",", ""))


def test_every_block_is_stamped_by_the_benchmark_that_writes_it() -> None:
    blocks = _blocks()
    assert {name for _, name, _ in blocks} >= {"mlca-t", "corpus"}
    for page, name, body in blocks:
        stamp = STAMP.search(body)
        assert stamp is not None, f"{page.name}: block {name} was not written by a benchmark"
        assert f'write_block("{name}"' in (ROOT / stamp["bench"]).read_text(encoding="utf-8")


def test_the_ratios_are_the_figures_quotients() -> None:
    checked = 0
    for _, name, body in _blocks():
        rows = [[c.strip() for c in line.strip("|").split("|")] for line in body.splitlines() if line.startswith("| ")]
        data = [r for r in rows[1:] if not set(r[0]) <= {"-"}]
        if name == "corpus":
            for cells in data:
                ins, hand_ins, ins_ratio, text, hand_text, text_ratio = (_number(c) for c in cells[1:])
                assert abs(ins / hand_ins - ins_ratio) < TOLERANCE and abs(text / hand_text - text_ratio) < TOLERANCE
                checked += 1
        elif name == "mlca-t":
            (gen_ins, gen_text), (hand_ins, hand_text) = [(_number(r[1]), _number(r[2])) for r in data]
            quoted = [float(q) for q in re.findall(r"\*\*([\d.]+)\*\*", body)]
            assert abs(quoted[0] - gen_ins / hand_ins) < TOLERANCE and abs(quoted[1] - gen_text / hand_text) < TOLERANCE
            checked += 1
    assert checked >= 4
