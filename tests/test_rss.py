"""The RSS lemma template (docs/lemmas/rss_longitudinal.toml) against Intel's ad-rss-lib: its `rss_gap`, as the
engine evaluates it (z3) and as the brute-force evaluator does (exact fractions, no code shared with the
engine), equals ad-rss-lib's safe longitudinal distance (same direction) to 1 mm on a grid of speeds and params;
and its lemmas have their expected verdicts (a one-response-time gap is not RSS-safe)."""

from __future__ import annotations

import itertools
from fractions import Fraction
from pathlib import Path

import pytest
import z3

from mlca_verify.evidence.adrss import ad_rss_gap
from mlca_verify.logic import check_all
from mlca_verify.logic.symbolic import StepInputs, System, Valuation, python_value, value_of
from mlca_verify.model import Var
from mlca_verify.spec import load_spec
from tests.bruteforce_data import Point, ev
from tests.conftest import ROOT

TEMPLATE = ROOT / "docs" / "lemmas" / "rss_longitudinal.toml"
MLCA_T = ROOT / "spec" / "mlca_t.toml"
PARAM_NAMES = ("RHO", "ACCEL_MAX", "BRAKE_MIN", "BRAKE_MAX")
SPEEDS = (0.0, 2.5, 13.9, 30.0, 41.7, 70.0)
PARAMS = (  # RHO, ACCEL_MAX, BRAKE_MIN, BRAKE_MAX: ad-rss-lib's defaults, then others within the ranges
    (1.0, 3.5, 4.0, 8.0),
    (0.5, 2.0, 3.0, 9.0),
    (2.0, 1.0, 6.0, 10.0),
    (0.2, 0.0, 8.0, 8.0),
)


def test_the_template_equals_ad_rss_lib_to_a_millimetre() -> None:
    machine = load_spec(TEMPLATE).machine
    system = System(machine)
    names = ("RHO", "ACCEL_MAX", "BRAKE_MIN", "BRAKE_MAX")
    compared = 0
    for params, v_rear, v_front in itertools.product(PARAMS, SPEEDS, SPEEDS):
        exact = {n: Fraction(p) for n, p in zip(names, params, strict=True)}
        samples = {"v_rear": Fraction(v_rear), "v_front": Fraction(v_front), "gap": Fraction(0), "t": Fraction(0)}
        signals = {k: value_of(x, "real") for k, x in samples.items()}
        valuation = Valuation(
            z3.IntVal(0),
            {},
            StepInputs({"N": z3.BoolVal(False)}, signals, {}),
            {k: value_of(x, "real") for k, x in exact.items()},
        )
        engine = python_value(z3.simplify(system.ev(Var("rss_gap"), valuation)))
        brute = ev(Var("rss_gap"), Point(machine, "IDLE", {}, {**samples, "N": False}, exact))
        reference = ad_rss_gap(v_rear, v_front, params)
        assert abs(float(engine) - reference) <= 1e-3, (v_rear, v_front, params, engine, reference)
        assert abs(float(brute) - reference) <= 1e-3, (v_rear, v_front, params, brute, reference)
        compared += 1
    assert compared == len(PARAMS) * len(SPEEDS) ** 2
    assert ad_rss_gap(30.0, 30.0, PARAMS[0]) == pytest.approx(115.78125)  # "about 116 m" at 30 m/s


def test_the_template_lemmas_have_their_expected_verdicts() -> None:
    results = {r.prop: r for r in check_all(load_spec(TEMPLATE).machine) if r.kind == "lemma"}
    assert {k: r.verdict for k, r in results.items()} == {
        "front-braking-only-helps": "holds",
        "rss-gap-is-collision-free": "holds",
        "time-gap-rule-is-rss-safe": "violated",
    }
    cx = results["time-gap-rule-is-rss-safe"].counterexample
    assert cx is not None
    values = cx.steps[0].definitions
    assert values["time_gap_rule"] and not values["rss_safe"]


def test_the_motion_lemma_fails_when_the_distance_is_short(tmp_path: Path) -> None:
    text = TEMPLATE.read_text()
    short = text.replace('rss_safe = { expr = "gap >= rss_gap"', 'rss_safe = { expr = "gap >= 0.9 * rss_gap"')
    assert short != text
    (tmp_path / "short.toml").write_text(short)
    results = {r.prop: r for r in check_all(load_spec(tmp_path / "short.toml").machine) if r.kind == "lemma"}
    motion = results["rss-gap-is-collision-free"]
    assert motion.verdict == "violated" and motion.counterexample is not None
    values = motion.counterexample.steps[0].definitions
    assert values["rear_travel"] > motion.counterexample.steps[0].signals["gap"] + values["front_travel"]


def _mlca_t_value(name: str, samples: dict[str, float], params: dict[str, Fraction] | None = None) -> Fraction:
    """A definition of MLCA-T by the brute-force evaluator (exact), at the defaults unless params are given."""
    machine = load_spec(MLCA_T).machine
    values = {p.name: Fraction(p.default) for p in machine.params} | (params or {})
    signals = {s.name: Fraction(0) for s in machine.signals} | {k: Fraction(x) for k, x in samples.items()}
    point = Point(machine, "IDLE", {"waited": 0, "need_age": 0}, {**signals, "N": False, "U": False}, values)
    value = ev(Var(name), point)
    assert isinstance(value, Fraction | int)
    return Fraction(value)


def test_mlca_t_states_rss_as_ad_rss_lib_computes_it() -> None:
    """The RSS distances MLCA-T's lemmas compare L with, on both sides, against ad-rss-lib."""
    for params, v, v_other in itertools.product(PARAMS, SPEEDS[::2], SPEEDS[1::2]):
        exact = dict(zip(PARAM_NAMES, map(Fraction, params), strict=True))
        for side in ("left", "right"):
            lead = _mlca_t_value(f"rss_lead_{side}", {"v": v, f"v_lead_{side}": v_other}, exact)
            follow = _mlca_t_value(f"rss_follow_{side}", {"v": v, f"v_follow_{side}": v_other}, exact)
            assert abs(float(lead) - ad_rss_gap(v, v_other, params)) <= 1e-3
            assert abs(float(follow) - ad_rss_gap(v_other, v, params)) <= 1e-3


def cost_rows() -> list[str]:
    """docs/findings.md F10: the smallest gaps the old rule and MLCA-T's L accept, at the defaults."""
    rows = []
    for text in ("5", "10", "20", "25", "30", "36.1"):
        v = Fraction(text)
        lead = max(
            Fraction(3), _mlca_t_value("reach_av", {"v": v}) - _mlca_t_value("stop_lead_left", {"v_lead_left": v})
        )
        follow = max(
            Fraction(3),
            _mlca_t_value("reach_follow_left", {"v_follow_left": v + 5}) - _mlca_t_value("stop_av", {"v": v}),
        )
        assert abs(float(lead) - ad_rss_gap(float(v), float(v), PARAMS[0])) <= 1e-3
        assert abs(float(follow) - ad_rss_gap(float(v + 5), float(v), PARAMS[0])) <= 1e-3
        old_lead = max(Fraction(3), v)  # 1 s at the AV's speed, 3 m
        old_follow = max(Fraction(3), v + 5, Fraction(5 * 5, 2 * 4))  # 1 s at its speed, 3 m, 4 m/s^2 to keep it
        km_h = v * Fraction(18, 5)
        rows.append(
            f"| {text} ({float(km_h):.0f}) | {float(old_lead):.1f} | {float(lead):.1f} | {float(lead / old_lead):.2f}"
            f" | {float(old_follow):.1f} | {float(follow):.1f} | {float(follow / old_follow):.2f} |"
        )
    return rows


def test_the_cost_table_of_the_findings_is_what_l_accepts() -> None:
    findings = (ROOT / "docs" / "findings.md").read_text()
    for row in cost_rows():
        assert row in findings, row
    # and L accepts exactly from that gap on: a millimetre less is refused
    on_the_edge = {"v": 30.0, "v_lead_left": 30.0, "gap_lead_left": 115.78125, "v_follow_left": 0.0}
    assert _mlca_t_value("L", {**on_the_edge, "gap_follow_left": 1000.0})
    assert not _mlca_t_value("L", {**on_the_edge, "gap_lead_left": 115.78, "gap_follow_left": 1000.0})


def test_mlca_t_lemmas_hold_for_its_rule_and_fail_for_the_old_one() -> None:
    results = {r.prop: r for r in check_all(load_spec(MLCA_T).machine) if r.kind == "lemma"}
    assert {k: r.verdict for k, r in results.items()} == {
        "L-is-rss-safe": "holds",
        "R-is-rss-safe": "holds",
        "time-gap-rule-is-rss-safe": "violated",
        "time-gap-rule-is-rss-safe-on-the-highway": "violated",
    }
    cx = results["time-gap-rule-is-rss-safe-on-the-highway"].counterexample
    assert cx is not None
    step = cx.steps[0]
    assert min(step.signals["v"], step.signals["v_lead_left"], step.signals["v_follow_left"]) >= 25
    assert step.signals["gap_lead_left"] < step.definitions["rss_lead_left"] or (
        step.signals["gap_follow_left"] < step.definitions["rss_follow_left"]
    )
