"""The package works installed, not only from this checkout: a wheel (templates as package data) installed into
a fresh virtual environment checks, generates and conforms a spec in another folder."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from tests.conftest import ROOT


def _run(command: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=600, check=False)


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The bin folder of a fresh virtual environment holding the wheel built from this checkout."""
    root = tmp_path_factory.mktemp("install")
    source = root / "source"  # a copy: building writes build/ and *.egg-info beside the sources
    for part in ("src", "sim_check"):
        shutil.copytree(ROOT / part, source / part, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    wheels = root / "wheels"
    built = _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w",
                  str(wheels), str(source)], root)  # fmt: skip
    assert built.returncode == 0, built.stderr
    venv = root / "venv"
    assert _run([sys.executable, "-m", "venv", str(venv)], root).returncode == 0
    wheel = next(wheels.glob("mlca_verify-*.whl"))
    done = _run([str(venv / "bin" / "pip"), "install", "-q", "--no-deps", "--no-index", str(wheel)], root)
    assert done.returncode == 0, done.stderr
    # the dependencies come from the development environment's site-packages, added as a plain path: its .pth
    # files (this checkout's editable install among them) are not processed, so mlca_verify is the wheel's
    site = Path(_run([str(venv / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     root).stdout.strip())  # fmt: skip
    (site / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return venv / "bin"


@pytest.mark.slow
def test_the_installed_package_is_the_wheel(installed: Path, tmp_path: Path) -> None:
    where = _run([str(installed / "python"), "-c", "import mlca_verify; print(mlca_verify.__file__)"], tmp_path)
    assert where.returncode == 0, where.stderr
    assert where.stdout.startswith(str(installed.parent)), where.stdout


@pytest.mark.slow
def test_the_installed_package_ships_the_spec_schema(installed: Path, tmp_path: Path) -> None:
    """Package data: the schema editors read, the same text as `mlca-verify schema` writes."""
    shipped = _run(
        [str(installed / "python"), "-c",
         "import importlib.resources as r; print(r.files('mlca_verify.spec').joinpath('spec.schema.json').read_text(), end='')"],
        tmp_path,
    )  # fmt: skip
    written = _run([str(installed / "mlca-verify"), "schema"], tmp_path)
    assert shipped.returncode == 0 and written.returncode == 0, shipped.stderr + written.stderr
    assert shipped.stdout == written.stdout and '"title": "mlca-verify spec"' in shipped.stdout


@pytest.mark.slow
def test_the_installed_commands_check_generate_and_conform_elsewhere(installed: Path, tmp_path: Path) -> None:
    shutil.copy(ROOT / "spec" / "mlca.toml", tmp_path / "mine.toml")
    checked = _run([str(installed / "mlca-verify"), "check", "mine.toml", "--quiet"], tmp_path)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "23 properties: 21 hold, 2 violated, 0 unknown; all as expected" in checked.stdout
    generated = _run([str(installed / "mlca-verify"), "gen", "mine.toml", "--out", "out"], tmp_path)
    assert generated.returncode == 0, generated.stderr
    assert (tmp_path / "out" / "c" / "mlca_fsm.c").read_text().count("/*@ predicate") > 5
    conformed = _run(
        [str(installed / "mlca-verify"), "conform", "mine.toml", "--generated", "out", "--only", "compile,exhaustive"],
        tmp_path,
    )
    assert conformed.returncode == 0, conformed.stdout + conformed.stderr
    assert "mine.toml: 3 of 3 checks passed" in conformed.stdout
    tested = _run(
        [str(installed / "mlca-verify"), "tests", "mine.toml", "--generated", "out", "--out", "t", "--no-coverage"],
        tmp_path,
    )
    assert tested.returncode == 0, tested.stdout + tested.stderr  # the Cortex-M4 start-up files are package data
    assert "every line as on the host" in tested.stdout


@pytest.mark.slow
def test_the_installed_simulator_runs_a_generated_controller_in_an_empty_folder(
    installed: Path, tmp_path: Path
) -> None:
    """The shipped specs and their generated code are package data: nothing is read from this checkout."""
    where = _run([str(installed / "python"), "-c", "import sim_check.package_data as d; print(d.SPECS.resolve())"],
                 tmp_path)  # fmt: skip
    assert where.returncode == 0, where.stderr
    assert where.stdout.startswith(str(installed.parent)) and not where.stdout.startswith(str(ROOT)), where.stdout
    scenario = tmp_path / "short.toml"
    shutil.copy(ROOT / "sim_check" / "scenarios" / "short.toml", scenario)
    empty = tmp_path / "empty"
    empty.mkdir()
    ran = _run([str(installed / "mlca-sim"), "run", "--controller", "mlca_t-c", "--scenario", str(scenario),
                "--json", "run.json"], empty)  # fmt: skip
    assert ran.returncode == 0, ran.stdout + ran.stderr
    run = json.loads((empty / "run.json").read_text())
    assert (run["controller"], run["status"]) == ("mlca_t-c", "done") and run["sim_steps"] > 1000
    assert sorted(p.name for p in empty.iterdir()) == ["run.json"]  # it wrote nothing else where it ran
