"""Traces as CSV and VCD: read back by Python's csv module and by pyvcd's tokenizer (a published VCD reader that
shares no code with the writer), every value at every step equal to the counterexample's."""

from __future__ import annotations

import csv
import io
from fractions import Fraction
from pathlib import Path

import pytest
from vcd.reader import TokenKind, tokenize

from mlca_verify import waves
from mlca_verify.cli import main
from mlca_verify.logic import check_all
from mlca_verify.logic.results import Counterexample, Number
from mlca_verify.model import Machine
from mlca_verify.spec import load_spec
from tests.conftest import ROOT

SPECS = ["tests/machines/pump_debounce_1khz.toml", "tests/machines/acc_modes_50hz.toml", "spec/mlca.toml"]


def _traces(path: str) -> tuple[Machine, list[tuple[str, Counterexample]]]:
    m = load_spec(ROOT / path).machine
    found = [(r.prop, r.counterexample) for r in check_all(m) if r.counterexample is not None]
    return m, [(p, cx) for p, cx in found if cx.steps and not cx.point]


def _read_vcd(text: str) -> tuple[str, dict[int, dict[str, Number | str]]]:
    """The timescale, and each time's full valuation by scoped name (values carried over between changes)."""
    names: dict[str, str] = {}
    scopes: list[str] = []
    scale = ""
    now: dict[str, Number | str] = {}
    times: dict[int, dict[str, Number | str]] = {}
    time = None
    for token in tokenize(io.BytesIO(text.encode())):
        if token.kind is TokenKind.SCOPE:
            scopes.append(token.data.ident)
        elif token.kind is TokenKind.UPSCOPE:
            scopes.pop()
        elif token.kind is TokenKind.TIMESCALE:
            scale = f"{int(token.data.magnitude)} {token.data.unit.value}"
        elif token.kind is TokenKind.VAR:
            names[token.data.id_code] = ".".join([*scopes[1:], token.data.reference])
        elif token.kind is TokenKind.CHANGE_TIME:
            if time is not None:
                times[time] = dict(now)
            time = token.data
        elif token.kind in (TokenKind.CHANGE_SCALAR, TokenKind.CHANGE_VECTOR, TokenKind.CHANGE_REAL):
            now[names[token.data.id_code]] = token.data.value
    assert time is not None
    times[time] = dict(now)
    return scale, times


def _at(times: dict[int, dict[str, Number | str]], t: int) -> dict[str, Number | str]:
    """The valuation at time t: that of the last change at or before it (a dump writes changes only)."""
    return times[max(x for x in times if x <= t)]


def _same(vcd_value: Number | str, value: Number) -> bool:
    if isinstance(value, bool):
        return vcd_value == ("1" if value else "0")
    if isinstance(value, float):
        return vcd_value == value
    width = 2**64
    return int(vcd_value) % width == value % width


@pytest.mark.parametrize("path", SPECS)
def test_the_vcd_holds_every_value_of_every_step(path: str) -> None:
    m, traces = _traces(path)
    assert traces
    scale, ticks = waves.timescale(m.step_s)
    for prop, cx in traces:
        read_scale, times = _read_vcd(waves.trace_vcd(m, cx, prop, "test"))
        assert read_scale == scale
        for k, step in enumerate(cx.steps):
            at = _at(times, k * ticks)
            assert [s for s in m.states if at[f"state.{s}"] == "1"] == [step.state], (prop, k)
            fired = [t.id for t in m.transitions if at[f"fired.{t.id}"] == "1"]
            assert fired == ([step.outcome.transition] if step.outcome.transition else []), (prop, k)
            groups = {"in": step.inputs, "signal": step.signals, "def": step.definitions}
            groups |= {"var": step.variables, "out": step.outputs}
            for group, values in groups.items():
                for name, value in values.items():
                    assert _same(at[f"{group}.{name}"], value), (prop, k, name)
            assert at["loop"] == ("1" if cx.loop_start is not None and k >= cx.loop_start else "0")
        end = _at(times, len(cx.steps) * ticks)
        assert [s for s in m.states if end[f"state.{s}"] == "1"] == [cx.steps[-1].outcome.next]


def _csv_same(text: str, value: object) -> bool:
    """A CSV cell holds the value: a float as its shortest repr (which reads back as the same double)."""
    if isinstance(value, float):
        return float(text) == value
    return Fraction(text) == Fraction(value)  # type: ignore[arg-type]


@pytest.mark.parametrize("path", SPECS)
def test_the_csv_has_a_row_per_step_with_its_values(path: str) -> None:
    _, traces = _traces(path)
    for prop, cx in traces:
        rows = list(csv.DictReader(io.StringIO(waves.trace_csv(cx))))
        assert len(rows) == len(cx.steps), prop
        for k, (row, step) in enumerate(zip(rows, cx.steps, strict=True)):
            assert (row["step"], row["state"], row["next"]) == (str(k + 1), step.state, step.outcome.next)
            assert row["transition"] == (step.outcome.transition or "")
            for name, value in {**step.variables, **step.outputs}.items():
                column = f"var.{name}" if name in step.variables else f"out.{name}"
                assert _csv_same(row[column], value), (prop, k, name)
            for name, value in cx.params.items():
                assert _csv_same(row[f"param.{name}"], value)


def test_a_lasso_marks_its_loop() -> None:
    _, traces = _traces("spec/mlca.toml")
    lassos = [(p, cx) for p, cx in traces if cx.loop_start is not None]
    assert lassos, "mlca.toml has a violated liveness property"
    for _, cx in lassos:
        rows = list(csv.DictReader(io.StringIO(waves.trace_csv(cx))))
        assert [r["loop"] for r in rows] == ["1" if k >= cx.loop_start else "0" for k in range(len(rows))]


def test_file_stems_are_safe_and_unique() -> None:
    taken: set[str] = set()
    assert waves.file_stem("M", "reach:IDLE", taken) == "M.reach_IDLE"
    assert waves.file_stem("M", "reach/IDLE", taken) == "M.reach_IDLE.2"
    assert waves.file_stem("M", "REACH:idle", taken) == "M.REACH_idle.3"  # a case-blind file system
    hostile = waves.file_stem("..", "../../etc/passwd $(rm -rf) x", taken)
    assert "/" not in hostile and " " not in hostile and not hostile.startswith(".")
    assert len(waves.file_stem("M", "x" * 1000, taken)) <= waves.FILE_LIMIT


def test_the_timescale_fits_the_step() -> None:
    assert waves.timescale(Fraction(1, 10)) == ("1 ms", 100)
    assert waves.timescale(Fraction(1, 1000)) == ("1 ms", 1)
    assert waves.timescale(Fraction(1)) == ("1 s", 1)
    assert waves.timescale(Fraction(1, 50)) == ("1 ms", 20)
    assert waves.timescale(None) == ("1 s", 1)
    assert waves.timescale(Fraction(1, 3)) == ("1 ns", 333333333)


def test_check_writes_the_traces(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "traces"
    code = main(["check", "--quiet", "--traces", str(out), str(ROOT / "tests/machines/pump_debounce_1khz.toml")])
    assert code == 0
    said = capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == [
        "PumpDebounce.cool-restarts.csv",
        "PumpDebounce.cool-restarts.vcd",
        "PumpDebounce.never-trips.csv",
        "PumpDebounce.never-trips.vcd",
    ]
    assert f"wrote {out / 'PumpDebounce.never-trips.csv'}, {out / 'PumpDebounce.never-trips.vcd'}" in said


def test_an_unwritable_trace_folder_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("", encoding="utf-8")
    code = main(["check", "--quiet", "--traces", str(blocker), str(ROOT / "tests/machines/pump_debounce_1khz.toml")])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot write traces" in err[0]
