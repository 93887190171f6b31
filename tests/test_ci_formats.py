"""CI formats: the check JSON, JUnit XML and SARIF against their schemas, and emitted regression tests run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import jsonschema
import pytest
from junitparser import Failure, JUnitXml

from mlca_verify.cli import main
from tests.conftest import ROOT

SCHEMAS = Path(__file__).parent / "schemas"
SPECS = ["spec/mlca.toml", "spec/mlca_r.toml", "spec/paper/figure.toml", "spec/paper/prose.toml"]


pytestmark = pytest.mark.usefixtures("at_root")


@pytest.fixture(scope="module")
def outputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("ci")
    files = {"json": folder / "check.json", "junit": folder / "check.xml", "sarif": folder / "check.sarif"}
    with pytest.MonkeyPatch.context() as mp:  # a module's fixture runs before at_root: its own chdir, undone
        mp.chdir(ROOT)
        argv = ["check", *SPECS, "--quiet", "--json", str(files["json"]), "--junit", str(files["junit"])]
        assert main([*argv, "--sarif", str(files["sarif"])]) == 0
    return files


def schema(name: str) -> dict[str, object]:
    return json.loads((SCHEMAS / name).read_text())


def test_check_json_matches_its_schema(outputs: dict[str, Path]) -> None:
    shipped = Path(__file__).parent.parent / "src" / "mlca_verify" / "schemas" / "check-3.schema.json"
    jsonschema.validate(json.loads(outputs["json"].read_text()), json.loads(shipped.read_text()))


def test_sarif_matches_the_schema_and_points_at_spec_lines(outputs: dict[str, Path]) -> None:
    log = json.loads(outputs["sarif"].read_text())
    jsonschema.validate(log, schema("sarif-2.1.0-core.schema.json"), format_checker=jsonschema.FormatChecker())
    results = log["runs"][0]["results"]
    by_name = {r["locations"][0]["logicalLocations"][0]["fullyQualifiedName"]: r for r in results}
    gap = by_name["MLCA.gap-taken"]
    region = gap["locations"][0]["physicalLocation"]
    assert region["artifactLocation"]["uri"] == "spec/mlca.toml"
    line = (ROOT / "spec/mlca.toml").read_text().splitlines()[region["region"]["startLine"] - 1]
    assert line == "[[liveness]]"
    assert gap["level"] == "note" and gap["suppressions"][0]["kind"] == "inSource"
    fires = by_name["MLCA_figure.determinism"]
    assert fires["locations"][0]["physicalLocation"]["region"]["startLine"] == 7  # [machine]
    assert all(r["level"] == "note" for r in results)  # every finding is expected: nothing new


def test_unexpected_verdict_is_an_error_in_sarif_and_a_failure_in_junit(tmp_path: Path) -> None:
    text = (ROOT / "spec/mlca.toml").read_text().replace('expect = "violated"', 'expect = "holds"', 1)
    spec = tmp_path / "mlca.toml"
    spec.write_text(text)
    sarif, junit = tmp_path / "s.sarif", tmp_path / "j.xml"
    assert main(["check", str(spec), "--quiet", "--sarif", str(sarif), "--junit", str(junit)]) == 1
    levels = {
        r["locations"][0]["logicalLocations"][0]["name"]: r["level"]
        for r in json.loads(sarif.read_text())["runs"][0]["results"]
    }
    assert levels["gap-taken"] == "error" and levels["left-gap-taken-left"] == "note"
    failed = [
        case
        for suite in JUnitXml.fromfile(str(junit))
        for case in suite
        if any(isinstance(x, Failure) for x in case.result)
    ]
    assert [case.name for case in failed] == ["gap-taken"]
    assert "loop->" in failed[0].result[0].text


def test_junit_has_one_test_case_per_property(outputs: dict[str, Path]) -> None:
    xml = JUnitXml.fromfile(str(outputs["junit"]))
    doc = json.loads(outputs["json"].read_text())
    suites = list(xml)
    assert [s.name for s in suites] == SPECS
    for suite, spec in zip(suites, doc["specs"], strict=True):
        assert [case.name for case in suite] == [r["property"] for r in spec["results"]]
        assert suite.tests == len(spec["results"]) and suite.failures == 0


def _generate(specs: list[str], out: Path) -> None:
    assert main(["gen", *specs, "--out", str(out)]) == 0


@pytest.mark.parametrize(
    ("spec", "repaired", "expected"),
    [
        ("spec/mlca.toml", "spec/mlca_r.toml", {"gap_taken", "left_gap_taken_left"}),
        ("tests/corpus/counter.toml", None, {"below_four", "counts_to_four_in_3", "reaches_S2"}),
        ("tests/corpus/shadowed.toml", None, {"c_needs_b"}),
    ],
)
def test_emitted_tests_fail_on_the_defect_and_pass_on_the_repair(
    spec: str, repaired: str | None, expected: set[str], tmp_path: Path
) -> None:
    generated = tmp_path / "generated"
    _generate([spec] + ([repaired] if repaired else []), generated)
    out = tmp_path / "emitted"
    assert main(["check", spec, "--quiet", "--emit-tests", str(out), "--generated", str(generated)]) == 0
    module = Path(spec).stem.lower()
    stems = {p.stem.removeprefix(f"test_{module}_") for p in out.glob("*.py")}
    assert stems == expected
    assert {p.stem for p in out.glob("*.c")} == {p.stem for p in out.glob("*.py")}
    pytest_cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", str(out)]
    run = subprocess.run(pytest_cmd, capture_output=True, text=True, check=False, cwd=tmp_path)
    assert f"{len(expected)} failed" in run.stdout, run.stdout
    c_dir = generated / "c"
    build = ["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wconversion", "-ffp-contract=off"]
    for test in sorted(out.glob("*.c")):  # each includes the generated .c, whose definitions it reads
        exe = tmp_path / test.stem
        subprocess.run([*build, f"-I{c_dir}", "-o", str(exe), str(test)], check=True)
        assert subprocess.run([str(exe)], capture_output=True, check=False).returncode == 1, test.name
    if repaired is None:
        return
    env = dict(os.environ, MLCA_FSM=str(generated / "python" / "mlca_r_fsm.py"))
    run = subprocess.run(pytest_cmd, capture_output=True, text=True, check=False, cwd=tmp_path, env=env)
    assert f"{len(expected)} passed" in run.stdout, run.stdout
    # the C replays on the repair through another -I: its code generated under the buggy machine's name
    renamed = tmp_path / "renamed" / "mlca.toml"
    renamed.parent.mkdir()
    renamed.write_text(Path(repaired).read_text().replace('name = "MLCA_R"', 'name = "MLCA"', 1))
    _generate([str(renamed)], tmp_path / "renamed" / "generated")
    for test in sorted(out.glob("*.c")):
        exe = tmp_path / f"{test.stem}_r"
        subprocess.run([*build, f"-I{tmp_path / 'renamed' / 'generated' / 'c'}", "-o", str(exe), str(test)], check=True)
        assert subprocess.run([str(exe)], check=False).returncode == 0, test.name
