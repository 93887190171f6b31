"""Every command block in the docs shows what the command prints today."""

from __future__ import annotations

import pytest

from scripts.refresh_docs import BLOCK, DOCS, ROOT, run

BLOCKS = [
    (doc.name, m.group("args"), m.group("body"))
    for doc in DOCS
    if doc.exists()
    for m in BLOCK.finditer(doc.read_text(encoding="utf-8"))
]


def test_docs_have_command_blocks() -> None:
    assert len([b for b in BLOCKS if b[0] == "findings.md"]) >= 5


@pytest.mark.parametrize(("doc", "args", "body"), BLOCKS, ids=[f"{b[0]}: {b[1]}" for b in BLOCKS])
def test_block_matches_output(doc: str, args: str, body: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    assert run(args) == body, f"{doc} is stale: run .venv/bin/python scripts/refresh_docs.py"
