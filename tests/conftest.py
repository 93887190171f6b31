"""What several test files share: the repository's root and running a test from it."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def at_root(monkeypatch: pytest.MonkeyPatch) -> None:
    """Run the test from the repository's root, as the commands are run, and return to where it was after."""
    monkeypatch.chdir(ROOT)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the groups
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Tests that share a module-scoped fixture run on one worker (`pytest -n 2 --dist loadgroup`), so the
    fixture, often minutes of proofs or simulation, is built once and not once per worker."""
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        if info is None:
            continue
        shared = sorted(
            name
            for name, defs in info.name2fixturedefs.items()
            if defs and defs[-1].scope == "module" and defs[-1].baseid.startswith("tests")
        )
        if shared:
            item.add_marker(pytest.mark.xdist_group(f"{item.module.__name__}:{shared[0]}"))
