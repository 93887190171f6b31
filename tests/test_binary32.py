"""Reals in binary32 (`machine.reals = "binary32"`, for a Cortex-M4F's single-precision FPU): the format rounds as
C's conversion to float does; the rounding-error bounds and the replay of a run use it, so a verdict that carries
over to binary64 may not carry over to binary32; the generated C computes in float with no double in it, the
generated Python rounds each operation to binary32, and the two agree bit for bit; conform passes every check
of a corpus machine that computes in binary32, on the FPU with no helper call."""

from __future__ import annotations

import math
import os
import re
import struct
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mlca_verify.cli import main
from mlca_verify.conformance import conform
from mlca_verify.conformance.outcome import CHECKS, CheckOutcome
from mlca_verify.floats import FORMATS, shortest_single
from mlca_verify.loading import import_generated
from mlca_verify.logic.datachecks import check_data_machine
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.replay64 import Binary64
from mlca_verify.model import Arith, Num, Var
from mlca_verify.spec import load_spec
from mlca_verify.tools import C_FLAGS
from tests.conftest import ROOT

SINGLE = FORMATS["binary32"]
MOTOR = ROOT / "tests" / "machines" / "motor_limiter_1khz.toml"


def _c_float(x: float) -> float:
    """C's conversion of a double to float, as the struct module makes it (an independent rounding)."""
    try:
        return float(struct.unpack("<f", struct.pack("<f", x))[0])
    except OverflowError:
        return math.copysign(math.inf, x)


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_binary32_rounds_a_rational_as_c_rounds_a_double_to_float(x: float) -> None:
    exact = SINGLE.nearest(Fraction(x))
    assert (math.copysign(math.inf, x) if exact is None else float(exact)) == _c_float(x)


@given(st.integers(min_value=-(2**63), max_value=2**63 - 1))
def test_binary32_rounds_an_int_once(n: int) -> None:
    """Not through binary64 (which rounds an int beyond 2^53 first): the float nearest the int, ties to even."""
    near = _c_float(float(n))
    candidates = (near, *_neighbours(near))
    best = min(candidates, key=lambda v: (abs(Fraction(v) - n), struct.unpack("<i", struct.pack("<f", v))[0] & 1))
    assert Fraction(SINGLE.of(n)) == Fraction(best)


def _neighbours(v: float) -> tuple[float, ...]:
    """The binary32 values next to a nonzero binary32 `v` (one ulp away, or half one below a power of two)."""
    if v == 0:
        return ()
    ulp = math.ldexp(1.0, math.frexp(v)[1] - 24)
    near = (v - ulp, v + ulp, v - ulp / 2, v + ulp / 2)
    return tuple(x for x in near if _c_float(x) == x)


@given(st.floats(width=32, allow_nan=False, allow_infinity=False))
def test_a_binary32_literal_reads_back_as_the_same_float(x: float) -> None:
    text = shortest_single(x)
    assert "." in text or "e" in text
    assert SINGLE.nearest(Fraction(text)) == Fraction(x)


RUNG = """
[machine]
name = "Rung"
initial = "LOW"
states = ["LOW", "HIGH"]
reals = "{reals}"

[inputs]
tick = {{ doc = "a step of the ladder" }}

[variables]
n = {{ type = "int", initial = 0, range = [0, 10], doc = "the rung", every = "if tick then min(n + 1, 10) else n" }}

[definitions]
high = {{ expr = "n * 0.1 > 0.50000001", doc = "above the middle, by 1e-8" }}

[[transition]]
from = "LOW"
to = "HIGH"
when = "high"

[[invariant]]
id = "high-above-five"
expr = "state == HIGH -> n >= 6"
"""


@pytest.mark.parametrize(("reals", "caveat"), [("binary64", ""), ("binary32", "not shown for binary32: ")])
def test_a_comparison_within_binary32_rounding_is_not_shown_for_binary32(
    tmp_path: Path, reals: str, caveat: str
) -> None:
    """`n * 0.1 > 0.50000001` is 1e-8 from deciding otherwise: binary64's bound (1e-16) keeps it, binary32's
    (6e-8 of the operands) does not, so the proof over the reals carries over to binary64 only."""
    path = tmp_path / "rung.toml"
    path.write_text(RUNG.format(reals=reals), encoding="utf-8")
    result = next(r for r in check_data_machine(load_spec(path).machine, Limits()) if r.prop == "high-above-five")
    assert result.verdict == "holds"
    assert result.caveat.startswith(f"holds over the reals; {caveat}") if caveat else result.caveat == ""
    if caveat:
        assert result.caveat.endswith("n * (1 / 10) > (50000001 / 100000000) may go either way under rounding")


def test_the_replay_computes_in_the_machines_format(tmp_path: Path) -> None:
    path = tmp_path / "rung.toml"
    path.write_text(RUNG.format(reals="binary32"), encoding="utf-8")
    single = Binary64(load_spec(path).machine)
    path.write_text(RUNG.format(reals="binary64"), encoding="utf-8")
    double = Binary64(load_spec(path).machine)
    total = Arith("+", Arith("*", Var("x"), Num(Fraction(1, 10), True)), Num(Fraction(1, 3), True))
    env = {"x": 0.7}
    x32 = _c_float(0.7)
    assert single.ev(total, {"x": x32}, "LOW") == _c_float(_c_float(x32 * _c_float(0.1)) + _c_float(1 / 3))
    assert double.ev(total, env, "LOW") == 0.7 * 0.1 + 1 / 3
    assert single.real(2**60 + 2**36 + 1) == SINGLE.of(2**60 + 2**36 + 1)


def test_binary32_code_computes_in_float_and_python_rounds_alike(tmp_path: Path) -> None:
    assert main(["gen", "--out", str(tmp_path), str(MOTOR)]) == 0
    c = next((tmp_path / "c").glob("*.c")).read_text(encoding="utf-8")
    code = "\n".join(line for line in c.splitlines() if not line.lstrip().startswith(("*", "/*", "@")))
    assert "double" not in code
    assert re.search(r"\b0\.001f\b", code) and "static float motorlimiter_div(float a, float b)" in code
    assert "ensures binary32:" in c and "ensures binary64:" not in c
    py = import_generated(next((tmp_path / "python").glob("*.py")), "motor_binary32")
    inputs = py.Inputs(enable=True, reset=False, current=0.1, winding=20.0)
    assert inputs.current == _c_float(0.1)  # a float field holds the input rounded
    assert py._f32(1e39) == math.inf and not hasattr(py, "_f32_int")  # no int meets a real
    rung = tmp_path / "rung.toml"
    rung.write_text(RUNG.format(reals="binary32"), encoding="utf-8")
    assert main(["gen", "--out", str(tmp_path / "rung"), str(rung)]) == 0
    py = import_generated(tmp_path / "rung" / "python" / "rung_fsm.py", "rung_binary32")
    assert "_f32_int(c.n)" in (tmp_path / "rung" / "python" / "rung_fsm.py").read_text(encoding="utf-8")
    for n in (0, 7, -(2**24) - 1, 2**60 + 2**36 + 1, 2**60 + 2**36, -(2**63)):
        assert py._f32_int(n) == SINGLE.of(n), n


def _quiet(_: CheckOutcome) -> None:
    pass


HEATER = """
[machine]
name = "Heater"
initial = "OFF"
states = ["OFF", "ON"]
reals = "binary32"
[params]
SET = { type = "real", default = 20.1, range = [5.0, 30.0], unit = "degC", doc = "set point" }
[signals]
room = { type = "real", unit = "degC", range = [-20.0, 50.0], doc = "room temperature" }
[definitions]
cold = { expr = "room < SET - 0.3", if_invalid = false, doc = "below the set point" }
warm = { expr = "room > SET + 0.3", if_invalid = true, doc = "above the set point, or no valid sample" }
[outputs]
power = { type = "real", range = [0.0, 1.0], if_invalid = 0.0, expr = "if state == ON then max(min((SET - room) / 4.0, 1.0), 0.0) else 0.0", doc = "heating power" }
[[transition]]
from = "OFF"
to = "ON"
when = "cold"
[[transition]]
from = "ON"
to = "OFF"
when = "warm"
[[invariant]]
id = "never-on"
expr = "state != ON"
expect = "violated"
[[invariant]]
id = "no-power-when-off"
expr = "state == OFF -> power == 0.0"
"""


@pytest.mark.slow
def test_a_binary32_machine_passes_every_check_on_the_fpu(tmp_path: Path) -> None:
    """Every conform check of a small binary32 machine (the corpus's motor limiter, in bench/bench_corpus.py,
    takes three minutes): the exhaustive and sequence comparisons, WP, cppcheck's MISRA, the sanitizers, and
    the Cortex-M4F build on the FPU with no call out of the object."""
    spec = tmp_path / "heater.toml"
    spec.write_text(HEATER, encoding="utf-8")
    assert main(["gen", "--out", str(tmp_path), str(spec)]) == 0
    report = conform(load_spec(spec, compare=False), tmp_path, list(CHECKS), _quiet)
    failed = [(o.name, o.detail) for o in report.outcomes if not o.ok]
    assert not failed, failed
    m4 = next(o for o in report.outcomes if o.name == "cortex-m4")
    assert "binary32 on the single-precision FPU" in m4.detail and m4.data["calls"] == []


def test_a_binary32_violation_replays_as_tests_that_compile_with_float_constants(tmp_path: Path) -> None:
    """`check --emit-tests` writes a pytest and a C test replaying a violation with its params and samples: in
    binary32 the C test's constants are float constants (a double one in a float field fails -Wconversion)."""
    spec = tmp_path / "heater.toml"
    spec.write_text(HEATER, encoding="utf-8")
    generated, out = tmp_path / "gen", tmp_path / "emitted"
    assert main(["gen", "--out", str(generated), str(spec)]) == 0
    assert main(["check", str(spec), "--quiet", "--emit-tests", str(out), "--generated", str(generated)]) == 0
    test_c = out / "test_heater_never_on.c"
    assert re.search(r"\b20\.1f\b", test_c.read_text(encoding="utf-8"))
    exe = tmp_path / "never_on"
    built = subprocess.run(["gcc", *C_FLAGS, "-ffp-contract=off", f"-I{generated / 'c'}", "-o", str(exe), str(test_c)],
                           capture_output=True, text=True, check=False)  # fmt: skip
    assert built.returncode == 0, built.stderr
    assert subprocess.run([str(exe)], capture_output=True, check=False).returncode == 1  # the violation, replayed
    env = {**os.environ, "HEATER_FSM": str(generated / "python" / "heater_fsm.py")}
    pytest_cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(out / "test_heater_never_on.py")]
    assert subprocess.run(pytest_cmd, capture_output=True, check=False, env=env).returncode == 1
