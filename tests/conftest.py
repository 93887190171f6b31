"""What several test files share: the repository's root and running a test from it."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def at_root(monkeypatch: pytest.MonkeyPatch) -> None:
    """Run the test from the repository's root, as the commands are run, and return to where it was after."""
    monkeypatch.chdir(ROOT)
