"""The JSON Schemas of the reports (`mlca_verify.report_schemas`, shipped as mlca_verify/schemas/*.schema.json and
written by `mlca-verify schema --report NAME`): the shipped files are what the module builds, real reports of
check, conform, tests and evidence validate against them, and a report broken on purpose does not."""

from __future__ import annotations

import copy
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from mlca_verify import cli
from mlca_verify.cli import main
from mlca_verify.report_schemas import REPORTS, file_name, report_schema, schema_text
from scripts.report_schemas import OUT, files
from tests.conftest import ROOT

MLCA, MLCA_T = "spec/mlca.toml", "spec/mlca_t.toml"
SMALL = ROOT / "tests" / "machines" / "bus_door.toml"  # a machine without data, quick to conform and test

Doc = dict[str, Any]


def validator(report: str) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(report_schema(report), format_checker=jsonschema.FormatChecker())


def errors(report: str, doc: Doc) -> list[str]:
    return [f"{list(e.absolute_path)}: {e.message}" for e in validator(report).iter_errors(doc)]


def refused(report: str, doc: Doc, *breaks: Callable[[Doc], None]) -> None:
    """Each change of `doc` on its own makes a document the schema refuses."""
    assert errors(report, doc) == []
    for change in breaks:
        broken = copy.deepcopy(doc)
        change(broken)
        assert errors(report, broken), change.__doc__ or change


@pytest.fixture(scope="module")
def at_root_module() -> Iterator[None]:
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(ROOT)
        yield


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("generated")
    assert main(["gen", "--out", str(out), str(SMALL)]) == 0
    return out


# --- the schemas themselves -------------------------------------------------------------------------------------


def test_the_shipped_schemas_are_the_ones_the_module_builds() -> None:
    built = files()
    for path, text in built.items():
        assert path.read_text(encoding="utf-8") == text, "run .venv/bin/python scripts/report_schemas.py"
    assert sorted(p.name for p in OUT.glob("*.json")) == sorted(p.name for p in built)
    assert sorted(p.name for p in built) == [
        "check-3.schema.json", "conform-1.schema.json", "evidence-1.schema.json", "network-evidence-1.schema.json",
        "tests-1.schema.json",
    ]  # fmt: skip
    for report in REPORTS:
        schema = report_schema(report)
        jsonschema.Draft202012Validator.check_schema(schema)
        assert schema["$id"].endswith("/" + file_name(report))
        assert schema["properties"]["schema"]["const"] == REPORTS[report]


def test_the_command_writes_each_reports_schema(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert tuple(REPORTS) == cli.REPORTS
    for report in REPORTS:
        assert main(["schema", "--report", report]) == 0
        assert capsys.readouterr().out == schema_text(report)
    assert main(["schema", "--report", "evidence", "--out", str(tmp_path / "e.json")]) == 0
    assert (tmp_path / "e.json").read_text(encoding="utf-8") == schema_text("evidence")
    assert main(["schema", "--report", "diff"]) == 2
    assert "invalid choice: 'diff'" in capsys.readouterr().err


def test_every_key_is_described() -> None:
    """A property of every object in every schema says what it is (but in the conditions that pick a check's
    data by its name, which describe nothing)."""

    def walk(node: Any, where: str) -> Iterator[str]:
        if isinstance(node, dict):
            for key, value in (node.get("properties") or {}).items():
                if "description" not in value:
                    yield f"{where}.{key}"
            for key, value in node.items():
                if key not in ("if", "then", "else"):
                    yield from walk(value, f"{where}/{key}")
        elif isinstance(node, list):
            for k, value in enumerate(node):
                yield from walk(value, f"{where}[{k}]")

    assert [m for report in REPORTS for m in walk(report_schema(report), report)] == []


# --- check --json --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def check_reports(tmp_path_factory: pytest.TempPathFactory, at_root_module: None) -> dict[str, Doc]:
    out = tmp_path_factory.mktemp("check")
    found = {}
    for spec, expected in ((MLCA_T, 0), (MLCA, 0)):
        report = out / f"{Path(spec).stem}.json"
        assert main(["check", spec, "--quiet", "--json", str(report)]) == expected
        found[spec] = json.loads(report.read_text(encoding="utf-8"))
    return found


def test_check_reports_of_a_machine_with_data_and_a_boolean_one_validate(check_reports: dict[str, Doc]) -> None:
    for doc in check_reports.values():
        assert errors("check", doc) == []
    data = check_reports[MLCA_T]["specs"][0]["results"]
    assert any("proof" in r for r in data) and any("caveat" in r for r in data)
    traces = [r["counterexample"] for r in data if r["counterexample"]]
    assert any(cx.get("point") for cx in traces) and any("params" in cx for cx in traces)
    assert any("signals" in step for cx in traces for step in cx["steps"])
    boolean = check_reports[MLCA]["specs"][0]["results"]
    assert any(r["counterexample"] and r["counterexample"]["steps"] for r in boolean)
    assert not any("proof" in r for r in boolean)


def test_the_check_schema_refuses_a_broken_report(check_reports: dict[str, Doc]) -> None:
    doc = check_reports[MLCA_T]
    proved = next(k for k, r in enumerate(doc["specs"][0]["results"]) if "proof" in r)
    traced = next(k for k, r in enumerate(doc["specs"][0]["results"]) if r["counterexample"])

    def result(d: Doc, k: int) -> Doc:
        found: Doc = d["specs"][0]["results"][k]
        return found

    def no_ok(d: Doc) -> None:
        """a result without its required ok"""
        del result(d, 0)["ok"]

    def unknown_kind(d: Doc) -> None:
        """a kind the engine does not have"""
        result(d, 0)["kind"] = "safety"

    def wrong_verdict(d: Doc) -> None:
        """a verdict that is none of holds, violated, unknown"""
        result(d, 0)["verdict"] = "proved"

    def unknown_engine(d: Doc) -> None:
        """an engine the engine does not have"""
        result(d, proved)["proof"]["engine"] = "ic3"

    def extra_step_key(d: Doc) -> None:
        """a step with a key the writer never writes"""
        result(d, traced)["counterexample"]["steps"][0]["comment"] = "x"

    def signal_as_text(d: Doc) -> None:
        """a signal's value that is not a number"""
        result(d, traced)["counterexample"]["steps"][0]["signals"] = {"v": "fast"}

    def other_schema(d: Doc) -> None:
        """another schema string"""
        d["schema"] = "mlca-verify.check/1"

    refused("check", doc, no_ok, unknown_kind, wrong_verdict, unknown_engine, extra_step_key, signal_as_text)
    refused("check", doc, other_schema)


# --- conform --json ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def conform_report(generated: Path, tmp_path_factory: pytest.TempPathFactory) -> Doc:
    report = tmp_path_factory.mktemp("conform") / "conform.json"
    argv = ["conform", str(SMALL), "--generated", str(generated), "--only", "compile,exhaustive", "--json", str(report)]
    assert main(argv) == 0
    doc: Doc = json.loads(report.read_text(encoding="utf-8"))
    return doc


def test_a_conform_report_validates_and_the_schema_refuses_a_broken_one(conform_report: Doc) -> None:
    checks = conform_report["specs"][0]["checks"]
    assert [c["name"] for c in checks] == ["up-to-date", "compile", "exhaustive"]

    def unknown_check(d: Doc) -> None:
        """a check conform does not run"""
        d["specs"][0]["checks"][1]["name"] = "lint"

    def half_the_figures(d: Doc) -> None:
        """the exhaustive check's steps without its restarts"""
        del d["specs"][0]["checks"][2]["data"]["restarts"]

    def another_checks_data(d: Doc) -> None:
        """data the compile check never writes"""
        d["specs"][0]["checks"][1]["data"] = {"findings": []}

    def no_sha256(d: Doc) -> None:
        """a spec without its hash"""
        del d["specs"][0]["sha256"]

    refused("conform", conform_report, unknown_check, half_the_figures, another_checks_data, no_sha256)


# --- tests: coverage.json ------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tests_report(generated: Path, tmp_path_factory: pytest.TempPathFactory) -> Doc:
    out = tmp_path_factory.mktemp("tests")
    assert main(["tests", "--no-target", "--generated", str(generated), "--out", str(out), str(SMALL)]) == 0
    (report,) = out.glob("*/coverage.json")
    doc: Doc = json.loads(report.read_text(encoding="utf-8"))
    return doc


def test_a_tests_report_validates_and_the_schema_refuses_a_broken_one(tests_report: Doc) -> None:
    assert tests_report["target"] is None and [c["language"] for c in tests_report["coverage"]] == ["python", "c"]

    def no_paired(d: Doc) -> None:
        """a report without the conditions paired"""
        del d["paired"]

    def another_language(d: Doc) -> None:
        """coverage of a language the code is not generated in"""
        d["coverage"][0]["language"] = "rust"

    def statements_as_text(d: Doc) -> None:
        """a figure that is not a figure"""
        d["coverage"][0]["statements"] = "100%"

    def gap_without_reason(d: Doc) -> None:
        """a gap without its reason key"""
        d["coverage"][1]["gaps"] = [{"line": 3, "what": "branch"}]

    refused("tests", tests_report, no_paired, another_language, statements_as_text, gap_without_reason)


# --- the evidence bundle --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def bundle(generated: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The evidence of the small machine, with its generated suite (run on the Cortex-M4 under QEMU too)."""
    out = tmp_path_factory.mktemp("evidence") / "bundle"
    assert main(["evidence", str(SMALL), "--generated", str(generated), "--out", str(out)]) == 0
    return out


def test_an_evidence_bundle_validates_and_the_schema_refuses_a_broken_one(bundle: Path) -> None:
    doc = json.loads((bundle / "evidence.json").read_text(encoding="utf-8"))
    assert [c["name"] for c in doc["conformance"]][-1] == "sanitizers" and doc["test_coverage"]["target"]
    (suite,) = (bundle / "tests").glob("*/coverage.json")  # the suite's own report, with the target's run
    assert errors("tests", json.loads(suite.read_text(encoding="utf-8"))) == []

    def no_argument(d: Doc) -> None:
        """a bundle without its argument"""
        del d["argument"]

    def claim_node(d: Doc) -> None:
        """a node of a type GSN has not here"""
        d["argument"][0]["type"] = "claim"

    def undeveloped_with_runs(d: Doc) -> None:
        """runs counted where no database was given"""
        d["closed_loop"]["runs"] = 3

    def wp_goals_as_text(d: Doc) -> None:
        """Frama-C's goal count as text"""
        next(c for c in d["conformance"] if c["name"] == "frama-c-wp")["data"]["goals"] = "all"

    def timed_test_coverage(d: Doc) -> None:
        """a duration in the deterministic bundle"""
        d["test_coverage"]["seconds"] = 1.0

    def not_a_time(d: Doc) -> None:
        """a timestamp that is not one"""
        d["generated_at"] = "yesterday"

    breaks = (no_argument, claim_node, undeveloped_with_runs, wp_goals_as_text, timed_test_coverage, not_a_time)
    refused("evidence", doc, *breaks)
