"""Every spec in the guides (docs/guides/*.md, each fenced `toml` block a whole machine) loads, and every one of
its verdicts is the one it expects, none unknown: a guide's pattern cannot go stale as the language grows."""

from __future__ import annotations

import re
import shlex

import pytest
import yaml

from mlca_verify import cli
from mlca_verify.logic import check_all
from mlca_verify.spec import load_text
from tests.conftest import ROOT

BLOCK = re.compile(r"```toml\n(.*?)```", re.DOTALL)
SPECS = [
    pytest.param(text, id=f"{path.stem}-{n}")
    for path in sorted((ROOT / "docs" / "guides").glob("*.md"))
    for n, text in enumerate(BLOCK.findall(path.read_text(encoding="utf-8")))
    if "[network]" not in text  # a network names its instances' files: tests/test_network.py checks the guide's
]


def test_the_guides_hold_specs() -> None:
    assert len(SPECS) >= 5


@pytest.mark.parametrize("text", SPECS)
def test_each_pattern_is_decided_as_it_expects(text: str) -> None:
    results = check_all(load_text(text, "<guide>"))
    assert [r.prop for r in results if not r.ok] == []
    assert [r.prop for r in results if r.verdict == "unknown"] == []


def test_a_pattern_that_is_wrong_is_caught() -> None:
    """The observer saturated at its bound's largest value (the mistake the guide warns about) is violated."""
    observer = next(p.values[0] for p in SPECS if 'name = "Observer"' in str(p.values[0]))
    wrong = str(observer).replace("min(need_age + 1, 31)", "min(need_age + 1, 30)")
    results = {r.prop: r for r in check_all(load_text(wrong, "<guide>"))}
    found = results["moves-only-after-T"]
    assert found.verdict == "violated" and found.counterexample is not None
    assert len(found.counterexample.steps) == 31


def test_the_readme_is_short_and_starts_with_the_two_commands() -> None:
    """The README says what the toolkit is, gives the two commands and an example, and links the rest."""
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 200
    assert (
        lines[2:6] == ["```sh", *lines[3:5], "```"] and "scripts/main.sh" in lines[3] and "scripts/test.sh" in lines[4]
    )


def test_every_guide_is_linked_from_the_readme() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for path in (ROOT / "docs" / "guides").glob("*.md"):
        assert f"docs/guides/{path.name}" in readme, path.name


YAML_BLOCK = re.compile(r"```yaml\n(.*?)```", re.DOTALL)


def _commands(node: object) -> list[str]:
    """Every `mlca-verify` command line in a parsed CI file (its run steps and scripts)."""
    if isinstance(node, dict):
        return [c for value in node.values() for c in _commands(value)]
    if isinstance(node, list):
        return [c for value in node for c in _commands(value)]
    if isinstance(node, str):
        return [line.split("mlca-verify", 1)[1] for line in node.splitlines() if "bin/mlca-verify " in line]
    return []


def test_the_ci_jobs_parse_and_every_command_in_them_is_accepted() -> None:
    text = (ROOT / "docs" / "guides" / "ci-gate.md").read_text(encoding="utf-8")
    jobs = [yaml.safe_load(block) for block in YAML_BLOCK.findall(text)]
    assert len(jobs) == 2
    commands = [c for job in jobs for c in _commands(job)]
    assert len(commands) == 6
    for command in commands:
        args = cli._parser().parse_args(shlex.split(command))  # a usage error raises
        assert args.command in ("check", "gen", "diff")


def test_the_documentation_index_links_every_page_and_only_pages_that_exist() -> None:
    docs = ROOT / "docs"
    index = (docs / "README.md").read_text(encoding="utf-8")
    linked = set(re.findall(r"\]\(([^)#]+)\)", index))
    for target in linked:
        assert (docs / target).resolve().is_file(), target
    pages = [p.relative_to(docs).as_posix() for p in docs.glob("*.md")] + [
        p.relative_to(docs).as_posix()
        for folder in ("guides", "reference", "explanation")
        for p in (docs / folder).glob("*.md")
    ]
    for page in pages:
        assert page == "README.md" or page in linked, f"docs/README.md does not link {page}"
