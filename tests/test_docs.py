"""Every command block in the docs shows what the command prints today."""

from __future__ import annotations

import csv
import re
from functools import cache
from pathlib import Path

import pytest

from scripts.refresh_comparison import rebuild
from scripts.refresh_docs import BLOCK, DOCS, run
from sim_check.cli import main as sim_main
from sim_check.report import write_report
from tests.conftest import ROOT

BLOCKS = [
    (doc.name, m.group("args"), m.group("body"))
    for doc in DOCS
    if doc.exists()
    for m in BLOCK.finditer(doc.read_text(encoding="utf-8"))
]


def test_docs_have_command_blocks() -> None:
    assert len([b for b in BLOCKS if b[0] == "findings.md"]) >= 5


@pytest.mark.parametrize(("doc", "args", "body"), BLOCKS, ids=[f"{b[0]}: {b[1]}" for b in BLOCKS])
@pytest.mark.usefixtures("at_root")
def test_block_matches_output(doc: str, args: str, body: str) -> None:
    assert run(args) == body, f"{doc} is stale: run .venv/bin/python scripts/refresh_docs.py"


COMPARISON = ROOT / "docs" / "comparison"


@pytest.mark.slow
@pytest.mark.parametrize(
    ("comparison", "name"),
    [(COMPARISON, "matrix.sqlite"), (COMPARISON / "middle", "middle.sqlite"), (COMPARISON / "exit", "exit.sqlite")],
)
def test_committed_comparison_report_is_what_the_committed_rows_give(
    comparison: Path, name: str, tmp_path: Path
) -> None:
    rebuild(tmp_path / name, comparison)
    write_report(tmp_path / name, tmp_path / "out")
    committed = (comparison / "report.md").read_text(encoding="utf-8")
    assert (tmp_path / "out" / "report.md").read_text(encoding="utf-8") == committed, (
        f"{comparison} is stale: run .venv/bin/python scripts/refresh_comparison.py on the matrix database"
    )


@pytest.mark.slow
def test_committed_v2v_channels_are_what_the_committed_rows_give(tmp_path: Path) -> None:
    """docs/comparison/v2v/channels.md is what `mlca-sim channels` makes of the three channels' committed rows."""
    dbs = []
    for label in ("off", "perfect", "lossy"):
        rebuild(tmp_path / f"{label}.sqlite", COMPARISON / "v2v" / label)
        dbs += ["--db", f"{label}={tmp_path / f'{label}.sqlite'}"]
    assert sim_main(["channels", *dbs, "--out", str(tmp_path / "out")]) == 0
    committed = (COMPARISON / "v2v" / "channels.md").read_text(encoding="utf-8")
    assert (tmp_path / "out" / "channels.md").read_text(encoding="utf-8") == committed, (
        "docs/comparison/v2v is stale: run .venv/bin/python scripts/refresh_channels.py on the channels' databases"
    )


EXPLAINED = ROOT / "docs" / "explanation" / "paper-comparison.md"
LANGUAGE = ROOT / "docs" / "reference" / "spec-language.md"
GUIDE = ROOT / "docs" / "reference" / "command-guide.md"


def test_the_explained_claims_table_is_the_reports() -> None:
    def claims(text: str) -> list[str]:
        return [line for line in text.splitlines() if re.match(r"\| C\d[ab]?: ", line)]

    report = claims((COMPARISON / "report.md").read_text(encoding="utf-8"))
    assert report and claims(EXPLAINED.read_text(encoding="utf-8")) == report


FINDINGS = ROOT / "docs" / "findings.md"
F11_HEADER = "| controller | lane changes by 20 km | wish episodes followed | travel time s | changes closer than RSS's distance |"
F11_CONTROLLERS = {
    "LC2013": "lc2013",
    "MLCA": "mlca-c",
    "MLCA-R": "mlca_r-c",
    "MLCA-T": "mlca_t-c",
    "without": "without",
}


@cache
def _av_rows(comparison: Path) -> tuple[dict[str, str], ...]:
    """The AV rows (av_metrics.csv) of a committed comparison's finished runs."""
    with (comparison / "runs.csv").open(encoding="utf-8", newline="") as f:
        done = {(r["controller"], r["avs"], r["seed"]) for r in csv.DictReader(f) if r["status"] == "done"}
    with (comparison / "av_metrics.csv").open(encoding="utf-8", newline="") as f:
        return tuple(r for r in csv.DictReader(f) if (r["controller"], r["avs"], r["seed"]) in done)


def _sum(comparison: Path, controller: str, avs: int, column: str) -> float:
    rows = [r for r in _av_rows(comparison) if r["controller"] == controller and r["avs"] == str(avs)]
    assert rows, (comparison, controller, avs)
    return sum(float(r[column]) for r in rows)


def _runs(comparison: Path, controller: str, avs: int) -> int:
    return len({r["seed"] for r in _av_rows(comparison) if r["controller"] == controller and r["avs"] == str(avs)})


def _rss(comparison: Path, controller: str, avs: int) -> tuple[int, int]:
    """The lane changes by 20 km into a gap shorter than RSS's distance, and all of them."""
    return int(_sum(comparison, controller, avs, "lc_rss_unsafe")), int(_sum(comparison, controller, avs, "lc_20km"))


def _f11_row(controller: str) -> list[float | None]:
    """One AV: lane changes per run by 20 km, wish episodes followed (at once or deferred) in %, travel time s,
    changes closer than RSS's distance in %; None where the controller has no wish episodes."""
    runs = _runs(COMPARISON, controller, 1)
    rows = [r for r in _av_rows(COMPARISON) if r["controller"] == controller and r["avs"] == "1"]
    followed = None
    if all(r["wishes"] for r in rows):
        moved = sum(float(r["wishes_at_once"]) + float(r["wishes_deferred"]) for r in rows)
        followed = 100 * moved / sum(float(r["wishes"]) for r in rows)
    unsafe, changes = _rss(COMPARISON, controller, 1)
    return [changes / runs, followed, _sum(COMPARISON, controller, 1, "travel_time_s") / runs, 100 * unsafe / changes]


def _shows(cell: str, value: float | None) -> bool:
    """`cell` (thousands separated, maybe a percent sign; "-" for none) is `value` rounded to the digits it shows."""
    if cell == "-":
        return value is None
    number = cell.replace(",", "").removesuffix("%")
    digits = len(number.partition(".")[2])
    return value is not None and abs(float(number) - value) <= 0.5 * 10**-digits + 1e-9


def test_the_findings_f11_table_is_the_committed_rows() -> None:
    """F11's table of one-AV runs, row by row and cell by cell, is what docs/comparison's committed rows give (the
    rows `mlca-sim report` writes report.md from), each number rounded as the page shows it."""
    lines = FINDINGS.read_text(encoding="utf-8").splitlines()
    start = lines.index(F11_HEADER) + 2
    table = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        table.append([cell.strip() for cell in line.strip().strip("|").split("|")])
    assert sorted(row[0].split()[0] for row in table) == sorted(F11_CONTROLLERS)
    wrong = []
    for label, *cells in table:
        expected = _f11_row(F11_CONTROLLERS[label.split()[0]])
        columns = F11_HEADER.strip("|").split("|")[1:]
        wrong += [
            f"{label}, {column.strip()}: page {cell}, rows {value}"
            for column, cell, value in zip(columns, cells, expected, strict=True)
            if not _shows(cell, value)
        ]
    assert not wrong, "docs/findings.md F11 is stale:\n" + "\n".join(wrong)


def test_the_rss_counts_in_the_prose_are_the_committed_rows() -> None:
    """The changes closer than RSS's distance that F11 and the explanation quote, and MLCA-T's reduction against
    LC2013, are what the committed rows of docs/comparison (and docs/comparison/exit) give."""

    def flat(path: Path) -> str:
        return " ".join(path.read_text(encoding="utf-8").split())

    findings, explained = flat(FINDINGS), flat(EXPLAINED)
    unsafe, changes = _rss(COMPARISON, "mlca_t-c", 3)
    claim_unsafe, claim_changes = _rss(COMPARISON, "mlca_t_claim-c", 3)
    one_unsafe, one_changes = _rss(COMPARISON, "mlca_t-c", 1)
    exit_unsafe, exit_changes = _rss(COMPARISON / "exit", "mlca_t-c", 3)
    exit_one_unsafe, exit_one_changes = _rss(COMPARISON / "exit", "mlca_t-c", 1)
    assert one_unsafe == exit_one_unsafe == 0
    assert f"With three AVs {unsafe} of its {changes:,} changes end closer than RSS's distance" in findings
    assert f"None of its {one_changes:,} one-AV changes ends closer than RSS's distance; " in explained
    assert f"with three AVs {unsafe} of {changes:,} do." in explained
    assert (
        f"({claim_unsafe} of {claim_changes:,} closer than RSS's distance, against {unsafe} of {changes:,} without"
        " messages" in explained
    )
    assert (
        f"none of its {exit_one_changes:,} one-AV changes closer than RSS's distance"
        f" ({exit_unsafe} of {exit_changes:,} with three AVs)" in explained
    )

    def per_run(controller: str, avs: int, column: str) -> float:
        return _sum(COMPARISON, controller, avs, column) / _runs(COMPARISON, controller, avs)

    fewer = [100 * (1 - per_run("mlca_t-c", n, "lc_20km") / per_run("lc2013", n, "lc_20km")) for n in (1, 3)]
    longer = 100 * (per_run("mlca_t-c", 1, "travel_time_s") / per_run("lc2013", 1, "travel_time_s") - 1)
    assert (
        f"MLCA-T makes {fewer[0]:.0f}% fewer lane changes than LC2013 ({fewer[1]:.0f}% with three AVs) at"
        f" {longer:.1f}% more travel time" in findings
    )


def test_the_spec_language_states_the_loaders_limits() -> None:
    """The references' limits are the loader's own numbers (a limit raised in the code and not in the text fails)."""
    from mlca_verify.spec.meaning import WITHIN_LIMIT

    text = LANGUAGE.read_text(encoding="utf-8") + GUIDE.read_text(encoding="utf-8")
    assert f"`within` is at most {WITHIN_LIMIT:,} steps" in text
    assert f"must lie in 1..{WITHIN_LIMIT:,} steps" in text
    assert "1,000 steps for" not in text and "at most 1,000 steps, and" not in text


def test_the_spec_languages_unit_mistake_is_what_check_prints(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The page's `gap.toml` (the TOML block before the `$ mlca-verify check gap.toml` block), checked: exit 2 and
    the one line the page shows."""
    from mlca_verify.cli import main

    text = LANGUAGE.read_text(encoding="utf-8")
    shown = re.search(
        r"```toml\n(?P<spec>(?:(?!```).)*?)```\n\n```text\n\$ mlca-verify check gap\.toml\n(?P<out>.*?)```", text, re.S
    )
    assert shown is not None
    (tmp_path / "gap.toml").write_text(shown["spec"], encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert main(["check", "gap.toml"]) == 2
    assert capsys.readouterr().err == shown["out"]


def test_the_engines_page_shows_the_certificate_check_gives(tmp_path: Path) -> None:
    """The certificate of MLCA-T's `deferral` on docs/explanation/engines.md is the one `check --json` reports."""
    import json

    from mlca_verify.cli import main

    out = tmp_path / "check.json"
    assert main(["check", str(ROOT / "spec" / "mlca_t.toml"), "--only", "deferral", "--quiet", "--json", str(out)]) == 0
    found = re.search(r'"certificate": "((?:[^"\\]|\\.)*)"', out.read_text(encoding="utf-8"))
    assert found is not None
    certificate = json.loads(f'"{found[1]}"')
    page = (ROOT / "docs" / "explanation" / "engines.md").read_text(encoding="utf-8")
    assert f"```text\n{certificate}\n```" in page


def test_the_tutorials_spec_excerpts_are_its_files() -> None:
    """Each TOML excerpt the tutorial shows is, line for line, part of the first version of its spec, and the
    fixed version differs from it only in the order of the transitions (and its header comment)."""
    tutorial = (ROOT / "docs" / "tutorial.md").read_text(encoding="utf-8")
    first = (ROOT / "docs" / "tutorial" / "stairwell_v1.toml").read_text(encoding="utf-8")
    fixed = (ROOT / "docs" / "tutorial" / "stairwell.toml").read_text(encoding="utf-8")
    excerpts = re.findall(r"```toml\n(.*?)```", tutorial, re.DOTALL)
    assert len(excerpts) == 4 and all(excerpt in first for excerpt in excerpts)

    def body(text: str) -> list[str]:
        return sorted(line for line in text.splitlines() if not line.startswith("#"))

    assert body(first) == body(fixed) and first.index('"dim"') < first.index('"pressed_again"')
    assert fixed.index('"pressed_again"') < fixed.index('"dim"')


def test_the_feature_table_refusals_are_the_commands(tmp_path: Path) -> None:
    """The spec language's table says that a nondeterministic reading goes through check and diagram but that
    gen, conform and tests refuse it, in one line and exit 2: so they do."""
    import subprocess
    import sys

    table = LANGUAGE.read_text(encoding="utf-8")
    row = next(line for line in table.splitlines() if line.startswith('| `semantics = "any-enabled"`'))
    assert row.count("refused") == 3
    figure = ROOT / "spec" / "paper" / "figure.toml"
    commands = [
        ["gen", str(figure), "--out", str(tmp_path / "g")],
        ["conform", str(figure), "--generated", str(tmp_path / "g")],
        ["tests", str(figure), "--out", str(tmp_path / "t"), "--generated", str(tmp_path / "g")],
    ]
    for args in commands:
        ran = subprocess.run([sys.executable, "-m", "mlca_verify", *args], capture_output=True, text=True, check=False)
        assert ran.returncode == 2 and len(ran.stderr.strip().splitlines()) == 1, (args, ran.stderr)
        assert "first-match" in ran.stderr
    drawn = subprocess.run(
        [sys.executable, "-m", "mlca_verify", "diagram", str(figure), "--format", "scxml"],
        capture_output=True,
        check=False,
    )
    assert drawn.returncode == 0
