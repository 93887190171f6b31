"""Rewrite every command block in the docs with the command's current output.

A block is a fenced `text` block right after a comment `<!-- $ mlca-verify ARGS -->`. tests/test_docs.py fails
when a block differs from what the command prints; run `.venv/bin/python scripts/refresh_docs.py [DOC...]` to
refresh every doc, or the ones named.
Each command runs in a new interpreter from the repository's root, as a user runs it: what a process built
before (a test worker's other tests) cannot reach its output.
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]  # every page: a block may be on any
BLOCK = re.compile(r"(<!-- \$ mlca-verify (?P<args>[^\n]*?) -->\n```text\n)(?P<body>.*?)(```)", re.DOTALL)


def run(args: str) -> str:
    ran = subprocess.run(
        [sys.executable, "-m", "mlca_verify", *shlex.split(args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    return ran.stdout


def refresh(text: str) -> str:
    return BLOCK.sub(lambda m: m.group(1) + run(m.group("args")) + m.group(4), text)


if __name__ == "__main__":
    import os

    os.chdir(ROOT)
    chosen = [Path(a).resolve() for a in sys.argv[1:]]  # some of the docs, or all of them
    for doc in DOCS:
        if doc.exists() and (not chosen or doc in chosen):
            doc.write_text(refresh(doc.read_text(encoding="utf-8")), encoding="utf-8")
    sys.exit(0)
