"""The parts of a step that compute on reals: each comparison with a real operand and each real value computed
from others is a C function of its own, so that the step's contract holds no binary64 operation and WP proves
the rest exactly; the code they compute is the code that ran before."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from mlca_verify.codegen import generate, machine_ir, write
from mlca_verify.codegen.ir import closing
from mlca_verify.codegen.rounded import parts_of, rounded_parts
from mlca_verify.conformance import conform
from mlca_verify.conformance.generated_code import binary64_goals
from mlca_verify.model import name_types, prevs_of, show
from mlca_verify.spec import load_spec
from mlca_verify.spec.expr_parser import parse_expr
from tests.conftest import ROOT

FIXTURES = ROOT / "tests" / "fixtures"
TYPES = {"x": "real", "step": "real", "n": "int", "go": "bool"}


def _parts(text: str, target: str) -> list[tuple[str, str]]:
    return [(show(e), kind) for e, kind in parts_of(parse_expr(text)[0], target, TYPES)]  # type: ignore[arg-type]


def test_comparisons_with_a_real_operand_are_parts_and_the_rest_stays() -> None:
    assert _parts("go and x > 0.25", "bool") == [("x > 0.25", "bool")]
    assert _parts("if x > 2.0 then min(n + 1, 10) else 0", "int") == [("x > 2.0", "bool")]
    assert _parts("n > 2 and (x < 1.0 or n == 3.5)", "bool") == [("x < 1.0", "bool"), ("n == 3.5", "bool")]
    assert _parts("go and n > 2", "bool") == []


def test_a_real_value_is_one_part_unless_it_is_read_as_it_is() -> None:
    assert _parts("min(x + step, 100.0)", "real") == [("min(x + step, 100.0)", "real")]
    assert _parts("n + 1", "real") == [("n + 1", "real")]  # converted inside the function
    assert _parts("x", "real") == []
    assert _parts("0.5", "real") == []
    assert _parts("-0.5", "real") == []


def test_equal_parts_are_one_function_and_know_who_reads_them() -> None:
    m = load_spec(FIXTURES / "real_unbounded.toml", compare=False).machine
    registers = [p.arg for p in prevs_of(*(i.expr for i in m.invariants))]  # no register of an output here
    parts, at = rounded_parts(m, name_types(m), (), registers)
    shown = [show(p.expr) for p in parts]
    assert len(shown) == len(set(shown))
    assert [p.kind for p in parts if show(p.expr) == "x > 2.0"] == ["bool"]
    assert any("the register prev0" in p.users for p in parts)
    assert set(at.values()) == {p.index for p in parts}
    assert not any(p.free for p in parts)  # each reads the variable x


def test_the_generated_step_reads_each_part_through_its_function(tmp_path: Path) -> None:
    spec = load_spec(FIXTURES / "real_state.toml", compare=False)
    files = generate(spec, tmp_path)
    source = files["c/ra_fsm.c"]
    # the contract's transition conditions and next-state relation hold no binary64 comparison or operation
    logic = "".join(re.findall(r"/\*@ (?:predicate|logic boolean) ra_(?:when\d|next)\(.*?\*/", source, re.S))
    assert "ra_lb64_0(c, i, p)" in logic
    assert not re.search(r"c\.x\s*[<>=]|\+ p\.step", logic), logic
    clauses = re.findall(r"@ (check )?ensures binary64: (.*)", source)
    assert len(clauses) == len(binary64_goals(machine_ir(spec, tmp_path))) == 7  # conform lists each one
    # a clause that callers assume links a boolean; one over doubles is only checked, never assumed: an ACSL
    # equality between doubles among a goal's hypotheses makes z3 bit-blast
    assert all(check or text.startswith("((\\result != 0) <==>") for check, text in clauses), clauses
    py = files["python/ra_fsm.py"]
    assert "(c.x > 0.25)" in py  # the Python is as before: one expression
    write(files, tmp_path)
    ran = subprocess.run(
        [
            "cc",
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-c",
            "-o",
            str(tmp_path / "ra.o"),
            str(tmp_path / "c/ra_fsm.c"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert ran.returncode == 0, ran.stderr


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["real_state.toml", "real_unbounded.toml"])
def test_wp_proves_the_step_of_a_machine_with_real_variables(tmp_path: Path, fixture: str) -> None:
    spec = load_spec(FIXTURES / fixture, compare=False)
    write(generate(spec, tmp_path), tmp_path)
    outcomes = conform(spec, tmp_path, ["exhaustive", "sequences", "frama-c-wp"], lambda _: None).outcomes
    assert all(o.ok for o in outcomes), [o.detail for o in outcomes if not o.ok]
    wp = next(o for o in outcomes if o.name == "frama-c-wp").data
    assert wp["proved"] == wp["goals"] > 30
    assert wp["binary64"] == binary64_goals(machine_ir(spec, tmp_path))
    assert any("_b64_" in g for g in wp["binary64"])
    certified = wp["certified"]  # the invariants over ints, proved on the step with their certificates
    assert certified["proved"] == certified["goals"] and "n-range" in certified["stated"]


@pytest.mark.slow
def test_boolean_definitions_are_terms_where_acsl_needs_one(tmp_path: Path) -> None:
    """A boolean definition as the condition of an if-then-else in an update, in a comparison of two booleans,
    and an implication inside one: Frama-C used to refuse the file ("a predicate, not a function")."""
    spec = load_spec(FIXTURES / "boolean_terms.toml", compare=False)
    write(generate(spec, tmp_path), tmp_path)
    outcomes = conform(spec, tmp_path, ["exhaustive", "frama-c-wp"], lambda _: None).outcomes
    assert all(o.ok for o in outcomes), [o.detail for o in outcomes if not o.ok]
    wp = next(o for o in outcomes if o.name == "frama-c-wp").data
    assert wp["proved"] == wp["goals"] > 30 and wp["binary64"] == []
    assert "on-only-when-hot-or-just-released" in wp["certified"]["stated"]


@pytest.mark.slow
def test_a_transition_that_completes_its_mode_is_the_chains_else(tmp_path: Path) -> None:
    """`off` from every mode when `not main_on`, then a transition on `main_on`: the code writes the second as the
    `else` of the chain (cppcheck's multiCondition and an unreachable `otherwise` branch are gone), and it is
    still the spec's step (WP, the exhaustive and the sequence checks)."""
    spec = load_spec(FIXTURES / "complement.toml", compare=False)
    files = generate(spec, tmp_path)
    write(files, tmp_path)
    source, python = files["c/cm_fsm.c"], files["python/cm_fsm.py"]
    assert "else if ((i->main_on))" not in source and "elif i.main_on" not in python
    assert source.count("enabled whenever the ones before it are not") == 2
    checks = ["exhaustive", "sequences", "cppcheck", "frama-c-wp"]
    outcomes = conform(spec, tmp_path, checks, lambda _: None).outcomes
    assert [o.name for o in outcomes if not o.ok] == [], [o.detail for o in outcomes if not o.ok]


def test_the_closing_guard_is_read_from_the_text() -> None:
    guards = [parse_expr(t)[0] for t in ("not on", "a and b", "on", "b")]
    assert closing(guards) == 2
    assert closing([parse_expr("a")[0], parse_expr("not a")[0]]) == 1  # either way round
    assert closing([parse_expr("true")[0]]) == 0
    assert closing([parse_expr("a")[0], parse_expr("not b")[0]]) is None
    assert closing([parse_expr("a or not a")[0]]) is None  # complete, but only a solver would say so


def test_a_register_of_arithmetic_over_a_real_output_reads_the_output_through_its_part(tmp_path: Path) -> None:
    """`prev(level + 1.0)` of a real output `level`: the register's part is built from what the code computes
    (the output's expression, not `o->level`), so the C compiles and no part is left unused."""
    text = (FIXTURES / "real_unbounded.toml").read_text().replace('name = "RB"', 'name = "RE"')
    text += '[outputs.level]\nexpr = "x * 2.0"\ndoc = "twice x"\n'
    text += '[[invariant]]\nid = "level-kept"\nexpr = "prev(level + 1.0) >= 0.0 or x == 0.0"\n'
    spec_path = tmp_path / "re.toml"
    spec_path.write_text(text)
    files = generate(load_spec(spec_path, compare=False), tmp_path)
    write(files, tmp_path)
    assert "o->" not in files["c/re_fsm.c"].split("re_outputs(")[0]  # no part reads the outputs struct
    ran = subprocess.run(
        [
            "cc",
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-c",
            "-o",
            str(tmp_path / "re.o"),
            str(tmp_path / "c/re_fsm.c"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert ran.returncode == 0, ran.stderr
