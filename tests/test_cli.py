"""The CLI contract: exit codes, the JSON report, --only, and diff."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from mlca_verify import cli
from mlca_verify.cli import main
from tests.conftest import ROOT

SHIPPED = ["spec/mlca.toml", "spec/mlca_r.toml", "spec/paper/figure.toml", "spec/paper/prose.toml"]
KINDS = {"determinism", "completeness", "reachability", "dead-transition", "invariant", "liveness", "equivalence"}


pytestmark = pytest.mark.usefixtures("at_root")


def test_check_shipped_specs_writes_every_result(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out.json"
    assert main(["check", *SHIPPED, "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["schema"] == "mlca-verify.check/3"
    assert [s["path"] for s in doc["specs"]] == SHIPPED
    for spec in doc["specs"]:
        assert len(spec["sha256"]) == 64
        assert spec["results"], spec["path"]
        for r in spec["results"]:
            assert set(r) == {
                "property",
                "kind",
                "verdict",
                "expected",
                "ok",
                "cite",
                "seconds",
                "detail",
                "counterexample",
            }
            assert r["kind"] in KINDS and r["verdict"] in {"holds", "violated", "unknown"}
            assert r["ok"] is True
            if r["verdict"] == "violated" and r["kind"] not in ("reachability", "dead-transition"):
                cx = r["counterexample"]
                assert cx["steps"] and set(cx) == {"steps", "loop_start"}
                assert {"state", "inputs", "transition", "cite", "next"} <= set(cx["steps"][0])
    text = capsys.readouterr().out
    assert "all as expected" in text and "repeat forever" in text


def test_json_counts_every_declared_property(tmp_path: Path) -> None:
    from mlca_verify.spec import load_spec

    machine = load_spec(ROOT / "spec/mlca.toml").machine
    expected = 2 + len(machine.states) + len(machine.transitions) + len(machine.invariants) + len(machine.liveness)
    out = tmp_path / "count.json"
    assert main(["check", "spec/mlca.toml", "--json", str(out), "--quiet"]) == 0
    assert len(json.loads(out.read_text())["specs"][0]["results"]) == expected


def test_unexpected_verdict_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = (ROOT / "spec/mlca.toml").read_text().replace('expect = "violated"', 'expect = "holds"', 1)
    spec = tmp_path / "mlca.toml"
    spec.write_text(text)
    assert main(["check", str(spec)]) == 1
    assert "not as expected: gap-taken" in capsys.readouterr().out


def test_only_filters_and_rejects_unknown_names(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", "spec/mlca.toml", "--only", "A2,gap-taken"]) == 0
    out = capsys.readouterr().out
    assert "2 properties" in out and "A3" not in out
    assert main(["check", "spec/mlca.toml", "--only", "A9"]) == 2
    assert "unknown properties: A9" in capsys.readouterr().err


def test_diff_is_a_regression_gate(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diff", "spec/mlca.toml", "spec/mlca_r.toml"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "gap-taken violated holds fixed" in out
    assert "wait_left added -" in out and "wait_exit removed WAITING -> IDLE when N and (L or R)" in out
    assert "WAITING N and L wait_exit -> IDLE wait_left -> MOVING_LEFT 1100 1010" in out
    assert out.endswith("no regression: every property that held before still holds (10 verdicts changed)")
    assert main(["diff", "spec/mlca_r.toml", "spec/mlca.toml"]) == 1
    out = " ".join(capsys.readouterr().out.split())
    assert "gap-taken holds violated REGRESSION" in out
    assert "5 regressions: no-move-without-gap, gap-taken, left-gap-taken-left," in out


def test_diff_of_equivalent_machines(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diff", "tests/corpus/pingpong_twin.toml", "tests/corpus/pingpong.toml"]) == 0
    out = capsys.readouterr().out
    assert "are equivalent" in out and "transitions (matched by id):" in out


def test_removing_a_declared_property_that_held_is_a_regression(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (ROOT / "spec/mlca.toml").read_text()
    start = text.index('[[invariant]]\nid = "A4"')
    end = text.index("[[invariant]]", start + 5)
    (tmp_path / "mlca.toml").write_text(text[:start] + text[end:])
    assert main(["diff", "spec/mlca.toml", str(tmp_path / "mlca.toml")]) == 1
    out = " ".join(capsys.readouterr().out.split())
    assert "A4 holds - REGRESSION (removed)" in out and "1 regression: A4 held before" in out


def test_console_script_runs_as_a_process() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "mlca_verify", "check", "spec/mlca_r.toml", "--quiet"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "all as expected" in done.stdout


def test_unwritable_json_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", "spec/mlca.toml", "--json", "/nonexistent/dir/out.json", "--quiet"]) == 2
    assert capsys.readouterr().err.startswith("/nonexistent/dir/out.json: error: cannot write")


def _broken(args: object) -> int:
    raise ZeroDivisionError("a bug")


def test_an_internal_error_is_one_line_and_exit_3(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(cli.COMMANDS, "check", _broken)
    assert cli.main(["check", "spec/mlca.toml"]) == 3
    err = capsys.readouterr().err
    assert err.splitlines() == [
        "mlca-verify: internal error: ZeroDivisionError: a bug (run again with --debug for the traceback)"
    ]


def test_debug_prints_the_traceback_of_an_internal_error(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(cli.COMMANDS, "check", _broken)
    assert cli.main(["check", "spec/mlca.toml", "--debug"]) == 3
    err = capsys.readouterr().err
    assert err.startswith("Traceback (most recent call last):")
    assert "ZeroDivisionError: a bug" in err


def test_an_unwritable_output_folder_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder\n")
    assert cli.main(["gen", str(ROOT / "spec" / "mlca.toml"), "--out", str(blocker / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1
    assert "Not a directory" in err
    assert "Traceback" not in err


def test_an_error_message_cannot_carry_terminal_control_characters(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "x.toml"
    spec.write_text((ROOT / "spec" / "mlca.toml").read_text().replace('initial = "IDLE"', 'initial = "\\u001b[2J"'))
    assert cli.main(["check", str(spec)]) == 2
    err = capsys.readouterr().err
    assert "\x1b" not in err
    assert "initial state '\\x1b[2J' is not a state" in err


def test_gen_refuses_to_replace_another_specs_code(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("mine.toml", "copy.toml"):
        (tmp_path / name).write_text((ROOT / "spec" / "mlca.toml").read_text())
    out = tmp_path / "generated"
    assert main(["gen", str(tmp_path / "mine.toml"), "--out", str(out)]) == 0
    before = (out / "c" / "mlca_fsm.c").read_text()
    assert main(["gen", str(tmp_path / "copy.toml"), "--out", str(out)]) == 2
    assert "holds the code generated from mine.toml" in capsys.readouterr().err
    assert (out / "c" / "mlca_fsm.c").read_text() == before
    assert main(["gen", str(tmp_path / "mine.toml"), str(tmp_path / "copy.toml"), "--out", str(tmp_path / "two")]) == 2
    assert "two machines of one name need separate --out folders" in capsys.readouterr().err


def test_conform_says_first_that_the_spec_has_unexpected_verdicts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "u.toml"
    spec.write_text((ROOT / "spec" / "mlca.toml").read_text().replace('expect = "violated"', 'expect = "holds"'))
    assert main(["gen", str(spec), "--out", str(tmp_path / "g")]) == 0
    capsys.readouterr()
    main(["conform", str(spec), "--generated", str(tmp_path / "g"), "--only", "compile"])
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith("  note: the spec has 2 unexpected verdicts (gap-taken, left-gap-taken-left;")


def test_another_machines_evidence_shows_no_mlca_readings(tmp_path: Path) -> None:
    (tmp_path / "acc.toml").write_text("")
    assert cli.default_readings(tmp_path / "acc.toml") == []
    assert cli.default_readings(ROOT / "spec" / "mlca_r.toml") == [
        "spec/mlca.toml",
        "spec/paper/figure.toml",
        "spec/paper/prose.toml",
    ]


def test_a_closed_output_pipe_ends_quietly_with_exit_0() -> None:
    specs = ["spec/mlca.toml"] * 20
    done = subprocess.run(
        f"{sys.executable} -m mlca_verify check {' '.join(specs)} | head -c 10 > /dev/null; echo ${{PIPESTATUS[0]}}",
        shell=True,
        executable="/bin/bash",
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.stdout.strip() == "0", done.stderr
    assert "Traceback" not in done.stderr and "error" not in done.stderr


def test_a_spec_path_with_control_characters_is_printed_escaped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "e\x1b[31mvil.toml"
    spec.write_text((ROOT / "spec" / "mlca.toml").read_text())
    assert main(["check", str(spec), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "e\\x1b[31mvil.toml" in out


def test_gen_replaces_a_generated_file_that_is_not_utf8(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "g"
    assert main(["gen", "spec/mlca.toml", "--out", str(out)]) == 0
    (out / "python" / "mlca_fsm.py").write_bytes(b"\xff\xfe broken")
    assert main(["gen", "spec/mlca.toml", "--out", str(out), "--check"]) == 1
    assert main(["gen", "spec/mlca.toml", "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out


def test_evidence_takes_allow_outside() -> None:
    args = cli._parser().parse_args(["evidence", "spec/mlca_r.toml", "--out", "x", "--allow-outside"])
    assert args.allow_outside


def test_the_command_line_loads_only_what_check_runs() -> None:
    """`check` never needs the code generator, Jinja, conformance, evidence or the test generator: importing the
    command line leaves them unloaded (they cost `check` a fifth of a second when they were imported up front)."""
    heavy = ["jinja2", "mlca_verify.codegen", "mlca_verify.conformance.generated_code", "mlca_verify.evidence"]
    heavy += ["mlca_verify.testgen.suite", "xml.sax.saxutils", "hypothesis"]
    probe = f"import sys, mlca_verify.cli; print([m for m in {heavy!r} if m in sys.modules])"
    loaded = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "[]"
