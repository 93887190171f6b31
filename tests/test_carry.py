"""A proof holds for the code that runs, or says where it does not: ints that can leave 64 bits are `ovf:`
findings (checked against the C code under UBSan), a verdict that reads a division whose divisor can be zero is
unknown, and a verdict over the reals that rounding can overturn carries a binary64 caveat (checked against the
generated Python, which computes in binary64)."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from mlca_verify.codegen import generate, write
from mlca_verify.conformance import conform
from mlca_verify.floats import FORMATS
from mlca_verify.loading import import_generated
from mlca_verify.logic import check_all
from mlca_verify.logic.binary64 import Rounding
from mlca_verify.logic.results import Result
from mlca_verify.spec import load_spec, load_text

TIMER = """
[machine]
name = "fl"
initial = "A"
states = ["A", "BAD"]
[inputs]
go = {{ doc = "go" }}
[variables]
xv = {{ type = "real", doc = "x", initial = 0.0, range = [0.0, 1.0], every = "min(xv + {step}, 1.0)" }}
[[transition]]
from = "A"
to = "BAD"
when = "{guard}"
[[invariant]]
id = "never-bad"
expr = "state != BAD"
"""
SQUARE = """
[machine]
name = "ov"
initial = "A"
states = ["A", "B"]
[inputs]
go = {{ doc = "go" }}
[variables]
n = {{ type = "int", doc = "n", initial = 2, range = [0, {top}], every = "min(n * n, {top})" }}
[[transition]]
from = "A"
to = "B"
when = "n > 100"
"""
DIVIDE = """
[machine]
name = "dz"
initial = "A"
states = ["A", "B"]
[inputs]
go = { doc = "go" }
[variables]
xv = { type = "real", doc = "x", initial = 0.0, range = [0.0, 1.0], every = "xv" }
[[transition]]
from = "A"
to = "B"
when = "go"
[[invariant]]
id = "self"
expr = "xv / xv == xv / xv"
[[invariant]]
id = "big"
expr = "1.0 / xv > 1000000.0"
[[invariant]]
id = "plain"
expr = "xv <= 1.0"
"""


def _results(text: str) -> dict[str, Result]:
    return {r.prop: r for r in check_all(load_text(text, "m.toml"))}


def _spec(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    write(generate(load_spec(path), tmp_path / "gen"), tmp_path / "gen")
    return path


def test_a_decimal_timer_proof_says_it_is_over_the_reals_and_the_code_breaks_it(tmp_path: Path) -> None:
    text = TIMER.format(step="0.1", guard="xv > 0.25 and xv < 0.35 and xv != 0.3")
    results = _results(text)
    proof = results["never-bad"]
    assert proof.verdict == "holds"
    assert proof.caveat.startswith("holds over the reals; not shown for binary64: ")
    assert "may go either way under rounding" in proof.caveat
    _spec(tmp_path, text, "fl")
    module = import_generated(tmp_path / "gen" / "python" / "fl_fsm.py", "fl_fsm_carry")
    ctx = module.Context()
    modes = []
    for _ in range(4):
        module.step(ctx, module.Inputs(go=True))
        modes.append(int(ctx.mode))
    assert modes == [0, 0, 0, 1]  # 0.1 + 0.1 + 0.1 = 0.30000000000000004 != 0.3: the code enters BAD


def test_a_dyadic_timer_proof_carries_over_with_no_caveat() -> None:
    results = _results(TIMER.format(step="0.125", guard="xv > 0.25 and xv < 0.875 and xv != 0.5"))
    assert results["never-bad"].verdict == "violated" and results["never-bad"].caveat == ""
    results = _results(TIMER.format(step="0.125", guard="xv > 0.25 and xv < 0.375"))
    assert results["never-bad"].verdict == "holds" and results["never-bad"].caveat == ""


def test_an_int_square_that_leaves_64_bits_is_a_finding_and_ubsan_agrees(tmp_path: Path) -> None:
    text = SQUARE.format(top=10**15)
    results = _results(text)
    assert results["ovf:n"].verdict == "violated"
    assert results["ovf:n"].counterexample is not None
    steps = results["ovf:n"].counterexample.steps
    assert [s.variables["n"] for s in steps[:-1]] == [4, 16, 256, 65536, 2**32]  # then 2^64 does not fit
    seen = []
    report = conform(load_spec(_spec(tmp_path, text, "ov")), tmp_path / "gen", ["sanitizers"], seen.append)
    (outcome,) = [o for o in report.outcomes if o.name == "sanitizers"]
    assert not outcome.ok and "signed integer overflow" in outcome.detail


def test_an_int_square_that_intervals_keep_within_64_bits_has_no_check_and_ubsan_agrees(tmp_path: Path) -> None:
    text = SQUARE.format(top=3_037_000_499)  # its square is below 2^63
    assert not [p for p in _results(text) if p.startswith("ovf:")]
    report = conform(load_spec(_spec(tmp_path, text, "ov")), tmp_path / "gen", ["sanitizers"], lambda _: None)
    assert all(o.ok for o in report.outcomes if o.name == "sanitizers")


def test_a_verdict_that_reads_a_division_by_zero_is_unknown_with_the_reason() -> None:
    results = _results(DIVIDE)
    assert results["div:self"].verdict == "violated" and results["div:big"].verdict == "violated"
    for prop in ("self", "big"):
        assert results[prop].verdict == "unknown"
        assert results[prop].detail.startswith(f"not decided for the code: it depends on div:{prop}, where a divisor")
    assert results["plain"].verdict == "holds"


def test_bounded_responses_and_outputs_divide_in_their_cone_only() -> None:
    text = DIVIDE.replace(
        '[[invariant]]\nid = "self"',
        '[outputs]\nr = { type = "real", expr = "1.0 / xv", doc = "r" }\n[[invariant]]\nid = "self"',
    )
    results = _results(text)
    assert results["div:r"].verdict == "violated"
    assert results["plain"].verdict == "holds" and results["reach:B"].verdict == "holds"


@pytest.mark.parametrize(
    ("text", "exact"),
    [("0.5", True), ("0.1", False), ("3.0", True), ("0.3", False), ("1e-300", False), ("0.000244140625", True)],
)
def test_a_literal_is_exact_when_it_is_a_binary64(text: str, exact: bool) -> None:
    machine = load_text(TIMER.format(step=text, guard="go"), "m.toml")
    rounding = Rounding(machine, parametric=False)
    (variable,) = machine.variables
    assert variable.every is not None
    (step,) = [n for n in _nums(variable.every) if n != 1]
    assert (rounding.error(_num(step)) == 0) is exact
    assert FORMATS["binary64"].nearest(Fraction(text)) == Fraction(float(text))


def test_the_rounding_bound_covers_what_binary64_computes() -> None:
    machine = load_text(TIMER.format(step="0.1", guard="go"), "m.toml")
    rounding = Rounding(machine, parametric=False)
    assert "xv" not in rounding.exact_variables  # 0.1 is no binary64: the timer drifts
    (variable,) = machine.variables
    assert variable.every is not None
    bound = rounding.error(variable.every.args[0])  # type: ignore[attr-defined]
    assert bound is None  # it reads the drifting timer: no bound over unboundedly many steps
    assert Fraction(1, 2**53) == rounding.fmt.unit


def _nums(expr: object) -> list[Fraction]:
    from mlca_verify.model import Num, nodes

    return [n.value for n in nodes(expr) if isinstance(n, Num)]  # type: ignore[arg-type]


def _num(value: Fraction) -> object:
    from mlca_verify.model import Num

    return Num(value, True)


def test_the_shipped_specs_keep_their_verdicts() -> None:
    from tests.conftest import ROOT

    for name in ("mlca.toml", "mlca_r.toml", "mlca_t.toml"):
        results = check_all(load_spec(ROOT / "spec" / name).machine)
        assert all(r.ok for r in results), name
        assert not [r for r in results if r.kind == "overflow"], name
        assert all(r.verdict == "holds" for r in results if r.kind == "division"), name


def test_a_witness_replayed_in_binary64_confirms_the_run_or_shows_where_it_parts() -> None:
    from mlca_verify.logic.replay64 import follows
    from mlca_verify.logic.results import Counterexample, Outcome, Step

    machine = load_text(TIMER.format(step="0.1", guard="go and xv > 0.25 and xv < 0.35 and xv != 0.3"), "m.toml")
    stay = [Step("A", {"go": True}, Outcome(None, None, "A")) for _ in range(3)]
    real_run = Counterexample((*stay, Step("A", {"go": True}, Outcome(None, None, "A"))))
    assert not follows(machine, real_run)  # over the reals xv is 0.3 at step 4; in binary64 it is not, so t1 fires
    code_run = Counterexample((*stay, Step("A", {"go": True}, Outcome("t1", None, "BAD"))))
    assert follows(machine, code_run)
    results = _results(TIMER.format(step="0.1", guard="go and xv > 0.35"))
    assert results["reach:BAD"].verdict == "holds" and results["reach:BAD"].caveat == ""  # its witness replays
