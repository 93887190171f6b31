"""docs/reference/commands.md is what the argument parsers say: a flag added, renamed or explained anew without
running scripts/reference.py fails here."""

from __future__ import annotations

import pytest

from mlca_verify.cli import COMMANDS
from scripts.reference import OUT, reference
from tests.conftest import ROOT


def test_the_command_reference_is_what_the_parsers_say() -> None:
    assert OUT.read_text(encoding="utf-8") == reference(), "run .venv/bin/python scripts/reference.py"


def test_the_reference_has_every_command_and_every_flag() -> None:
    text = reference()
    for name in COMMANDS:
        assert f"### `mlca-verify {name}`" in text
    for flag in ("--parametric", "--timeout-ms", "--traces", "--sequences", "--no-target", "--readings", "--ray"):
        assert f"`{flag}`" in text


def test_the_api_reference_is_what_the_package_says() -> None:
    """docs/reference/api.md has every public name with its signature and docstring; none lacks a docstring."""
    import mlca_verify
    from scripts import api_reference

    text = api_reference.render()
    assert api_reference.OUT.read_text(encoding="utf-8") == text, "run .venv/bin/python scripts/api_reference.py"
    import sim_check

    for name in mlca_verify.__all__:
        assert f"## `{name}`" in text
    for name in sim_check.__all__:
        assert f"## `sim_check.{name}`" in text
    assert api_reference.undocumented() == []
    assert (
        "load_spec(path: str | Path, compare: bool = True, confine: bool = True, network: bool = False) -> LoadedSpec"
        in text
    )


def test_the_closed_loops_example_runs(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """The example of `sim_check` that the API reference shows: one run of three AVs in SUMO, stored and read back."""
    from scripts import api_reference

    monkeypatch.chdir(ROOT)
    exec(api_reference.sim_check_example(), {})  # the project's own docstring
    status, stored = capsys.readouterr().out.splitlines()
    assert status.startswith("done 0 [") and stored == "1"


def test_every_public_name_is_what_it_says_on_every_access() -> None:
    """`mv.conform` is the function, the second time too and after its subpackage (`mlca_verify.conformance`) is
    imported: a subpackage named like the function once replaced it after the first call."""
    import subprocess
    import sys

    code = (
        "import mlca_verify as mv, mlca_verify.conformance, inspect\n"
        "names = [n for n in mv.__all__ if n != '__version__']\n"
        "first = {n: getattr(mv, n) for n in names}\n"
        "assert all(getattr(mv, n) is first[n] for n in names)\n"
        "assert not any(inspect.ismodule(v) for v in first.values())\n"
        "assert callable(mv.conform) and mv.conform.__module__ == 'mlca_verify.conformance'\n"
    )
    ran = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert ran.returncode == 0, ran.stderr
