"""The spec's certificates as ACSL: the engine's SMT-LIB text read back over the generated C's context, and what
cannot be read (a symbol the context does not hold, malformed text) left out with the reason."""

from __future__ import annotations

from pathlib import Path

import pytest

from mlca_verify.codegen import machine_ir
from mlca_verify.codegen.acsl import AcslLowering, context_free
from mlca_verify.codegen.certified import Proved, Untranslatable, assumed_text, certify, parse, ranges
from mlca_verify.codegen.render import render_template
from mlca_verify.conformance.c_tools import wp_file
from mlca_verify.conformance.generated_code import WP_FLAGS
from mlca_verify.spec import load_spec
from tests.conftest import ROOT

MACHINE = load_spec(ROOT / "spec" / "mlca_t.toml", compare=False).machine
LOWERING = AcslLowering.of(MACHINE, "mlca_t", "MLCA_T")
DEFERRAL = (
    "(let ((a!1 (not (<= (+ need_age@p0 (* (- 1) waited@p0)) (- 1)))))"
    " (and (or (not !prev0@p0) (not (>= !mode@p0 2))) (or (not !first@p0) (not (>= !mode@p0 1))) a!1"
    " (not (<= need_age@p0 (- 1)))))"
)


def test_a_pdr_certificate_reads_over_the_c_context() -> None:
    """The engine's own constants read as the context's members (the mode) or the proof's ghost ones (a register
    the code does not keep, since it reads the context alone, and with no kept register the first-step flag; an
    observer, which the monitor keeps: MLCA-T's need_age)."""
    stated, left = certify(MACHINE, LOWERING, [Proved("deferral", DEFERRAL)])
    assert left == []
    (x,) = stated
    assert x.certificate == (
        "(((!(g.prev0 != 0)) || (!(c.mode >= 2))) && ((!(g.first != 0)) || (!(c.mode >= 1)))"
        " && (!((g.obs.need_age + ((-1) * c.waited)) <= (-1))) && (!(g.obs.need_age <= (-1))))"
    )
    # prev(state in {IDLE, WAITING}): over the context before the step, or at the first step over that same one
    assert (
        "\\at(gp->first, Pre) != 0) ? mlca_t_lprev0(\\at(*cp, Pre), i, p) : (\\at(gp->prev0, Pre) != 0)" in x.invariant
    )
    assert x.invariant.endswith("|| (g.need_age > p.T_MIN))")  # an implication; g is gp->obs there


def test_definitions_without_context_take_only_inputs_and_params() -> None:
    over_samples = {d.name for d in MACHINE.definitions} - {"W"}  # W reads the timer
    assert context_free(MACHINE) == over_samples and "L" in over_samples
    stated, _ = certify(MACHINE, LOWERING, [Proved("A3", "true")])
    assert "mlca_t_l_L(i, p)" in stated[0].invariant


def test_a_symbol_outside_the_context_leaves_the_invariant_out() -> None:
    stated, left = certify(MACHINE, LOWERING, [Proved("A1", "(>= respond@p0 1)"), Proved("A2", "true")])
    assert [x.id for x in stated] == ["A2"]
    assert left == [("A1", "symbol 'respond@p0' is not in the C context")]


@pytest.mark.parametrize("text", ["(and true", "and true)", "(", "((and) x)", "(frobnicate 1 2)", "(not)"])
def test_malformed_certificates_are_refused_not_crashed(text: str) -> None:
    stated, left = certify(MACHINE, LOWERING, [Proved("A1", text)])
    assert stated == [] and len(left) == 1


def test_a_huge_certificate_is_refused() -> None:
    with pytest.raises(Untranslatable):
        parse("(and " + "true " * 200_000 + ")")


def test_ranges_of_variables_and_params() -> None:
    text = ranges(MACHINE, "cp", "pp", pointer=True)
    assert "0 <= cp->waited <= 1000" in text and "1 <= pp->T_MIN <= 100" in text and "TIME_GAP" not in text
    assert "cp" not in ranges(MACHINE, None, "p", pointer=False)


@pytest.mark.slow
def test_wp_needs_the_certificate(tmp_path: Path) -> None:
    """With the engine's certificate WP proves the deferral on the step; with a weaker one (the timer and the
    observer no longer related) it cannot: the proof rests on the certificate, not on the invariant alone."""
    spec = load_spec(ROOT / "spec" / "mlca_t.toml", compare=False)
    ir = machine_ir(spec, ROOT / "generated")

    def proved_with(certificate: str) -> bool:
        stated, _ = certify(MACHINE, LOWERING, [Proved("deferral", certificate)])
        source = tmp_path / "mlca_t_certified.c"
        source.write_text(
            render_template(
                "certified.c.j2",
                m=ir,
                source=str(ROOT / "generated" / "c" / "mlca_t_fsm.c"),
                certified=stated,
                in_range=ranges(MACHINE, "cp", "pp", pointer=True, g="gp"),
                params_in_range=ranges(MACHINE, None, "p", pointer=False),
                assumed=assumed_text(MACHINE, LOWERING),
            )
        )
        fcts = (*WP_FLAGS, "-wp-fct", "mlca_t_step_certified")  # as conform runs it
        return wp_file(source, tmp_path, fcts).ok

    assert proved_with(DEFERRAL)
    assert not proved_with("(not (<= need_age@p0 (- 1)))")
