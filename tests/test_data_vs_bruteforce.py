"""The z3 engine on machines with data against an independent explicit-state explorer (tests/bruteforce_data.py).

Random machines are written as spec text (so the loader builds them as it builds any spec): 2-3 states, boolean
inputs, an int signal read by boolean definitions that say what they are when the sample is invalid, int params
with small ranges, int counters with clamped updates (`every` and transition `do`), an output, sometimes an
environment assumption, invariants (some over prev()), a bounded response, some of them parametric.

For every property the engine's verdict is never the opposite of the explorer's (unknown is allowed, but only
rarely); a violated invariant, range check, response or completeness has a counterexample as short as the
shortest the explorer finds, and replaying it (its params, inputs and signals) in the explorer gives the same
states, transitions, variables, definitions and outputs, and a violation at its last step and not before.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from dataclasses import replace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mlca_verify.logic import check_all
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.results import Counterexample, Result
from mlca_verify.model import Machine
from mlca_verify.spec import load_text
from tests.bruteforce_data import DataExplorer, Verdict

SETTINGS = settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
UNKNOWN_SHARE = 0.05  # at most this share of the properties may be left unknown by the engine
OPPOSITE = {"holds": "violated", "violated": "holds"}
# The engine's default limits but a shallower last BMC (60 steps by default): it runs only when k-induction and PDR
# both fail, and on these machines it finds nothing past the base case's 9 steps, so it only costs time. Every
# shortest counterexample the explorer finds must fit in it (asserted), so it hides no violation.
LIMITS = Limits(depth=20)


# --- random specs ----------------------------------------------------------------------------------------------


class Names:
    """What a random spec declares, for the expressions drawn over it."""

    def __init__(self) -> None:
        self.states: list[str] = []
        self.inputs: list[str] = []
        self.params: dict[str, tuple[int, int, int]] = {}  # name: (low, high, default)
        self.signal: tuple[int, int] = (0, 3)
        self.variables: list[str] = []
        self.bool_defs: list[str] = []
        self.outputs: list[str] = []

    @property
    def numbers(self) -> list[str]:
        """Int names a guard or an update may read."""
        return self.variables + list(self.params)


def _numeric(draw: st.DrawFn, n: Names, extra: tuple[str, ...] = ()) -> str:
    """A small int term: a variable, a param, a literal, or (in properties) a prev() or an output."""
    choices = [*n.numbers, *extra, str(draw(st.integers(0, 4)))]
    return draw(st.sampled_from(choices))


def _comparison(draw: st.DrawFn, n: Names, extra: tuple[str, ...] = ()) -> str:
    op = draw(st.sampled_from(["<", "<=", ">", ">=", "==", "!="]))
    left = _numeric(draw, n, extra)
    if draw(st.booleans()) and len(n.variables) + len(extra) > 0:
        right = draw(st.sampled_from([*n.variables, *extra])) + draw(st.sampled_from([" + 1", " - 1", ""]))
    else:
        right = _numeric(draw, n, extra)
    return f"{left} {op} {right}"


def _atom(draw: st.DrawFn, n: Names, role: str) -> str:
    """A boolean atom for a guard, an assumption of a response (no state), or an invariant or goal."""
    kinds = ["input", "compare", "valid"]
    if n.bool_defs:
        kinds.append("definition")
    extra: tuple[str, ...] = ()
    if role in ("invariant", "goal", "assume"):
        extra = tuple(f"prev({v})" for v in n.variables) + tuple(n.outputs)
        kinds.append("prev-input")
    if role in ("invariant", "goal"):
        kinds += ["state", "state", "prev-state"]
    kind = draw(st.sampled_from(kinds))
    if kind == "input":
        return draw(st.sampled_from(n.inputs))
    if kind == "definition":
        return draw(st.sampled_from(n.bool_defs))
    if kind == "valid":
        return "valid(x)"
    if kind == "prev-input":
        return f"prev({draw(st.sampled_from(n.inputs + n.bool_defs))})"
    if kind in ("state", "prev-state"):
        chosen = draw(st.lists(st.sampled_from(n.states), min_size=1, max_size=len(n.states) - 1, unique=True))
        text = f"state == {chosen[0]}" if len(chosen) == 1 else "state in {" + ", ".join(chosen) + "}"
        return f"prev({text[:5]}){text[5:]}" if kind == "prev-state" else text
    return _comparison(draw, n, extra)


def _formula(draw: st.DrawFn, n: Names, role: str, depth: int = 2) -> str:
    shape = draw(st.sampled_from(["atom", "atom", "not", "and", "or", "->"])) if depth > 0 else "atom"
    if shape == "atom":
        return _atom(draw, n, role)
    if shape == "not":
        return f"not ({_formula(draw, n, role, depth - 1)})"
    return f"({_formula(draw, n, role, depth - 1)}) {shape} ({_formula(draw, n, role, depth - 1)})"


def _invariant(draw: st.DrawFn, n: Names) -> str:
    """An invariant of a shape that often holds (a bound on a counter, its change per step, a guarded state)."""
    v = draw(st.sampled_from(n.variables))
    param = draw(st.sampled_from(list(n.params)))
    state = draw(st.sampled_from(n.states))
    return draw(
        st.sampled_from(
            [
                f"{v} >= 0",
                f"{v} <= {draw(st.integers(2, 5))}",
                f"{v} <= max({param}, {draw(st.integers(2, 5))})",
                f"{v} - prev({v}) <= 1",
                f"{v} <= {param} + {draw(st.integers(0, 2))}",
                f"{v} < {param} or state != {state}",
                f"prev({v}) >= {param} -> {v} >= {param} - 1",
                f"abs({v} - prev({v})) <= {draw(st.integers(1, 4))}",
                f"prev(state) == {state} and state != {state} -> {_formula(draw, n, 'invariant', depth=1)}",
                f"state == {state} -> {_formula(draw, n, 'invariant', depth=1)}",
                f"({_formula(draw, n, 'invariant', depth=1)}) or {v} < {param} + 2",
            ]
        )
    )


def _update(draw: st.DrawFn, n: Names, v: str) -> str:
    """A value for variable `v` that stays small: every template is clamped or bounded by a param."""
    cap = draw(st.integers(2, 5))
    other = draw(st.sampled_from(n.numbers))
    param = draw(st.sampled_from(list(n.params)))
    cond = _formula(draw, n, "guard", depth=1)
    return draw(
        st.sampled_from(
            [
                f"min({v} + 1, {cap})",
                f"min({v} + 1, {cap})",
                f"max({v} - 1, 0)",
                f"min({v} + {other}, {cap})",
                "0",
                str(draw(st.integers(0, cap))),
                f"if {cond} then {v} else 0",
                f"if {cond} then min({v} + 1, {cap}) else {v}",
                f"if {v} >= {param} then 0 else {v} + 1",
                f"abs({v} - {other})",
                f"max({v}, {other})",
                param,
            ]
        )
    )


def _table(name: str, fields: Mapping[str, object]) -> str:
    parts = []
    for key, value in fields.items():
        if isinstance(value, bool):
            text = "true" if value else "false"
        elif isinstance(value, str):
            text = f'"{value}"'
        elif isinstance(value, list):
            text = "[" + ", ".join(str(x) for x in value) + "]"
        else:
            text = str(value)
        parts.append(f"{key} = {text}")
    return f'{name} = {{ {", ".join(parts)}, doc = "d" }}'


def _definitions(draw: st.DrawFn, n: Names, param: str) -> list[str]:
    """A boolean definition over the signal, maybe another through a numeric one, maybe one without a signal."""
    near = draw(
        st.sampled_from(
            [
                f"x <= {param}",
                f"x >= {draw(st.sampled_from(n.variables))}",
                f"x + c >= {draw(st.integers(1, 5))}",
                f"x == {draw(st.integers(*n.signal))} or {n.inputs[0]}",
                f"x != {draw(st.integers(*n.signal))} and c < {param}",
                f"x > {param} + 1",
            ]
        )
    )
    definitions = [_table("near", {"expr": near, "if_invalid": draw(st.booleans())})]
    n.bool_defs.append("near")
    if draw(st.booleans()):
        gap = draw(st.sampled_from(["x - c", f"x - {param}", "max(x, c)", "x * 2"]))
        far = draw(st.sampled_from([f"gap >= {param}", f"gap < {draw(st.integers(0, 4))}", "gap == c"]))
        definitions.append(_table("gap", {"expr": gap}))
        definitions.append(_table("far", {"expr": far, "if_invalid": draw(st.booleans())}))
        n.bool_defs.append("far")
    if draw(st.booleans()):
        ready = draw(
            st.sampled_from(
                [
                    f"c >= {param} and not {n.inputs[-1]}",
                    f"valid(x) and {n.inputs[0]}",
                    f"state == {n.states[1]} or c == 0",
                    "near and c > 0",
                ]
            )
        )
        definitions.append(_table("ready", {"expr": ready}))
        n.bool_defs.append("ready")
    return definitions


def _transitions(draw: st.DrawFn, n: Names) -> list[str]:
    lines: list[str] = []
    for k in range(draw(st.integers(3, 6))):
        if draw(st.integers(0, 3)) == 0:
            source = '"*"'
        else:
            chosen = draw(st.lists(st.sampled_from(n.states), min_size=1, max_size=2, unique=True))
            source = "[" + ", ".join(f'"{s}"' for s in chosen) + "]"
        lines += [
            "[[transition]]",
            f'id = "t{k + 1}"',
            f"from = {source}",
            f'to = "{draw(st.sampled_from(n.states))}"',
            f'when = "{_formula(draw, n, "guard")}"',
        ]
        updated = draw(st.lists(st.sampled_from(n.variables), max_size=len(n.variables), unique=True))
        if updated:
            lines.append('do = "' + "; ".join(f"{v} = {_update(draw, n, v)}" for v in updated) + '"')
        lines.append("")
    return lines


def _modes(draw: st.DrawFn, pid: str) -> list[tuple[str, str]]:
    """A property once, parametric or not, or twice (`pid` with the defaults, `pid-p` for every param value)."""
    mode = draw(st.sampled_from(["false", "true", "both"]))
    return [(pid, "false"), (f"{pid}-p", "true")] if mode == "both" else [(pid, mode)]


@st.composite
def specs(draw: st.DrawFn) -> str:
    n = Names()
    n.states = [f"S{i}" for i in range(draw(st.integers(2, 3)))]
    n.inputs = ["A", "B"][: draw(st.integers(1, 2))]
    for name in ["P", "Q"][: draw(st.integers(1, 2))]:
        low = draw(st.integers(0, 2))
        high = low + draw(st.integers(1, 2))
        # the default is often the top of the range, where bounds like `c <= P` and `within = "P + 1"` are most
        # lenient: a parametric property then tends to fail for some value that the default passes
        default = draw(st.sampled_from([high, high, low, (low + high) // 2]))
        n.params[name] = (low, high, default)
    low = draw(st.integers(0, 1))
    n.signal = (low, low + draw(st.integers(1, 3)))
    n.variables = ["c", "d"][: draw(st.integers(1, 2))]
    otherwise = draw(st.sampled_from(["stay", "stay", "stay", "undefined"]))
    lines = [
        "[machine]",
        'name = "R"',
        f'initial = "{draw(st.sampled_from(n.states))}"',
        "states = [" + ", ".join(f'"{s}"' for s in n.states) + "]",
        f'otherwise = "{otherwise}"',
        "",
        "[inputs]",
        *(f'{i} = {{ doc = "d" }}' for i in n.inputs),
        "",
        "[params]",
        *(_table(p, {"type": "int", "default": d, "range": [lo, hi]}) for p, (lo, hi, d) in n.params.items()),
        "",
        "[signals]",
        _table("x", {"type": "int", "unit": "1", "range": list(n.signal)}),
        "",
    ]
    param = draw(st.sampled_from(list(n.params)))
    lines += ["[definitions]", *_definitions(draw, n, param), ""]
    lines.append("[variables]")
    for v in n.variables:
        top = draw(st.integers(2, 4))
        fields: dict[str, object] = {"type": "int", "initial": draw(st.integers(0, top)), "range": [0, top]}
        if draw(st.booleans()):
            fields["every"] = _update(draw, n, v)
        lines.append(_table(v, fields))
    lines.append("")
    if draw(st.booleans()):
        output = draw(
            st.sampled_from(
                [
                    f"if state == {n.states[1]} then c else 0",
                    f"c + {param}",
                    f"if {n.inputs[0]} then c else {n.variables[-1]}",
                    f"max(c, {param})",
                ]
            )
        )
        lines += ["[outputs]", _table("o", {"expr": output}), ""]
        n.outputs.append("o")
    if draw(st.booleans()):
        assumption = draw(
            st.sampled_from(
                [
                    f"x <= {n.signal[1]}",
                    f"valid(x) or {n.inputs[0]}",
                    f"x >= {n.signal[0]} or c > 0",
                    f"c < 3 or not {n.inputs[0]}",
                    f"not ({n.inputs[0]} and {n.inputs[-1]})",
                ]
            )
        )
        lines += ["[[assume]]", 'id = "env"', f'expr = "{assumption}"', ""]
    lines += _transitions(draw, n)
    for k in range(draw(st.integers(1, 3))):
        expr = _invariant(draw, n) if draw(st.integers(0, 2)) else _formula(draw, n, "invariant")
        for pid, parametric in _modes(draw, f"inv{k}"):
            lines += ["[[invariant]]", f'id = "{pid}"', f'expr = "{expr}"', f"parametric = {parametric}", ""]
    within = draw(st.sampled_from(["1", "2", "3", f'"{param} + 1"', f'"max({param}, 1)"', f'"{param} + 2"']))
    assume, goal = _formula(draw, n, "assume", depth=1), _formula(draw, n, "goal", depth=1)
    for pid, parametric in _modes(draw, "live0"):
        lines += [
            "[[liveness]]",
            f'id = "{pid}"',
            f'assume = "{assume}"',
            f'goal = "{goal}"',
            f"within = {within}",
            f"parametric = {parametric}",
            "",
        ]
    return "\n".join(lines)


# --- the comparison --------------------------------------------------------------------------------------------


def check_params(machine: Machine, params: Mapping[str, object], parametric: bool) -> None:
    assert set(params) == {p.name for p in machine.params}
    for p in machine.params:
        if parametric:
            assert p.range is not None and p.range[0] <= params[p.name] <= p.range[1], (p.name, params)  # type: ignore[operator]
        else:
            assert params[p.name] == p.default, (p.name, params)


def check_replay(ex: DataExplorer, prop: str, cx: Counterexample, parametric: bool) -> None:
    """The engine's counterexample, run in the explorer: the same run, bad at its last step and not before."""
    m = ex.m
    check_params(m, cx.params, parametric)
    inputs = [{**s.inputs, **s.signals} for s in cx.steps]
    records = ex.replay(cx.params, inputs, ex.check(prop))  # type: ignore[arg-type]
    for k, (step, rec) in enumerate(zip(cx.steps, records, strict=True)):
        where = f"{prop}: step {k + 1} of {len(cx.steps)} (params {cx.params}, inputs {inputs[k]})"

        def same(what: str, engine: object, explorer: object, where: str = where) -> None:
            assert engine == explorer, f"{where}: {what} {engine} in the engine's counterexample, {explorer} replayed"

        same("state", step.state, rec.state)
        assert rec.assumed, f"{where}: the environment assumption fails"
        same("definitions", step.definitions, rec.definitions)
        stuck = m.otherwise == "undefined" and step.outcome.transition is None
        if k == len(cx.steps) - 1 and stuck:  # the run ends stuck: completeness, or a response short of its goal
            assert not rec.enabled, f"{where}: {rec.transition} is enabled"
            continue
        if m.otherwise == "undefined":
            assert rec.enabled, f"{where}: no transition is enabled and otherwise = undefined"
        same("transition", (step.outcome.transition, step.outcome.next), (rec.transition, rec.next))
        same("variables", step.variables, rec.variables)
        same("outputs", step.outputs, rec.outputs)
    assert records[-1].bad, f"{prop}: the replayed counterexample does not end in a violation"
    assert not any(r.bad for r in records[:-1]), f"{prop}: the replayed counterexample is bad before its end"


def _parametric(machine: Machine, prop: str) -> bool:
    return any(i.id == prop and i.parametric for i in machine.invariants) or any(
        lv.id == prop and lv.parametric for lv in machine.liveness
    )


def compare(machine: Machine, results: list[Result], tally: Counter[str]) -> None:
    """Assert the engine's `results` agree with the explorer on `machine`; count verdicts in `tally`."""
    ex = DataExplorer(machine)
    brute: dict[str, Verdict] = ex.verdicts()
    # ovf: checks are about the code's 64 bits, which the explorer does not model (tests/test_carry.py checks
    # them against the C code under UBSan)
    engine = {r.prop: r for r in results if r.kind != "overflow"}
    assert set(brute) == set(engine), (sorted(brute), sorted(engine))
    for prop, expected in brute.items():
        result = engine[prop]
        tally["properties"] += 1
        if _parametric(machine, prop):
            tally["parametric"] += 1
            at_default = ex.shortest(ex.check(prop), parametric=False)
            if (at_default.length if at_default else None) != expected.length:
                tally["parametric:differs from the defaults"] += 1
        tally[f"{result.kind}:{result.verdict}"] += 1
        if result.verdict == "unknown":
            tally["unknown"] += 1
            continue
        assert result.verdict != OPPOSITE[expected.verdict], (
            f"{prop}: the engine says {result.verdict}, brute force {expected.verdict} "
            f"(brute-force run: {expected.found})"
        )
        assert result.verdict == expected.verdict
        if expected.length is None:
            continue
        assert expected.length <= LIMITS.depth, (
            f"{prop}: a counterexample of {expected.length} steps is beyond the BMC depth"
        )
        tally["longest"] = max(tally["longest"], expected.length)
        cx = result.counterexample
        assert cx is not None, f"{prop}: violated without a counterexample"
        assert len(cx.steps) == expected.length, (
            f"{prop}: the engine's counterexample has {len(cx.steps)} steps, the shortest has {expected.length}"
            f" (brute-force run: {expected.found})"
        )
        check_replay(ex, prop, cx, _parametric(machine, prop))


# --- the explorer on machines worked out by hand --------------------------------------------------------------

COUNTER = """
[machine]
name = "K"
initial = "S0"
states = ["S0", "S1", "S2"]

[inputs]
A = { doc = "d" }

[params]
P = { type = "int", default = 2, range = [1, 3], doc = "d" }

[signals]
x = { type = "int", unit = "1", range = [0, 3], doc = "d" }

[definitions]
gap = { expr = "x - c", doc = "d" }
near = { expr = "gap <= 0", if_invalid = true, doc = "d" }

[variables]
c = { type = "int", initial = 0, range = [0, 2], every = "min(c + 1, 3)", doc = "d" }

[[transition]]
id = "t1"
from = "S0"
to = "S1"
when = "A and near"
do = "c = 0"

[[transition]]
id = "t2"
from = "*"
to = "S2"
when = "c >= P"

[[invariant]]
id = "at-most-P"
expr = "c <= P"

[[invariant]]
id = "at-most-P-any"
expr = "c <= P"
parametric = true

[[invariant]]
id = "counts"
expr = "prev(c) == c - 1 or state == S1"

[[liveness]]
id = "two"
assume = "not A"
goal = "state == S2"
within = 2

[[liveness]]
id = "three"
assume = "not A"
goal = "state == S2"
within = "P + 1"
"""

STUCK = """
[machine]
name = "V"
initial = "S0"
states = ["S0", "S1"]
otherwise = "undefined"

[inputs]
A = { doc = "d" }

[signals]
x = { type = "int", unit = "1", range = [0, 3], doc = "d" }

[definitions]
gap = { expr = "x + 2", doc = "d" }
high = { expr = "gap > 5", if_invalid = IF_INVALID, doc = "d" }

[[transition]]
id = "t1"
from = "S0"
to = "S1"
when = "high"

[[transition]]
id = "t2"
from = "S0"
to = "S0"
when = "A"
"""


def _summary(text: str) -> dict[str, tuple[str, int | None]]:
    return {k: (v.verdict, v.length) for k, v in DataExplorer(load_text(text, "known.toml")).verdicts().items()}


def test_explorer_known_answers() -> None:
    # c counts 1, 2, 3 (out of range at step 3); t2 fires once c >= P; prev(c) at the first step is c before it
    # (0), so `counts` first fails at step 4, when c stays at 3 in S2; with P = 1, c <= P fails at step 2; in S0 or
    # S1 without A, t2 takes at most 3 steps to reach S2 (c from 0 to 2, then t2 fires)
    assert _summary(COUNTER) == {
        "determinism": ("holds", None),
        "completeness": ("holds", None),
        "reach:S0": ("holds", None),
        "reach:S1": ("holds", None),
        "reach:S2": ("holds", None),
        "fires:t1": ("holds", None),
        "fires:t2": ("holds", None),
        "range:c": ("violated", 3),
        "at-most-P": ("violated", 3),
        "at-most-P-any": ("violated", 2),
        "counts": ("violated", 4),
        "two": ("violated", 2),
        "three": ("holds", None),
    }
    # `high` is false on every valid sample (gap is at most 5) and if_invalid on an invalid one: S1 is reached only
    # through an invalid sample; S0 without A and with a valid sample enables nothing (otherwise = undefined)
    assert _summary(STUCK.replace("IF_INVALID", "true")) == {
        "determinism": ("holds", None),
        "completeness": ("violated", 1),
        "reach:S0": ("holds", None),
        "reach:S1": ("holds", None),
        "fires:t1": ("holds", None),
        "fires:t2": ("holds", None),
    }
    assert _summary(STUCK.replace("IF_INVALID", "false")) == {
        "determinism": ("holds", None),
        "completeness": ("violated", 1),
        "reach:S0": ("holds", None),
        "reach:S1": ("violated", None),
        "fires:t1": ("violated", None),
        "fires:t2": ("holds", None),
    }


def test_explorer_replays_a_run() -> None:
    machine = load_text(COUNTER, "known.toml")
    ex = DataExplorer(machine)
    runs = [{"A": False, "x": 0}, {"A": True, "x": 9}, {"A": False, "x": 1}, {"A": False, "x": 1}]
    records = ex.replay({"P": 2}, runs, ex.check("counts"))
    assert [(r.state, r.transition, r.next, r.variables["c"]) for r in records] == [
        ("S0", None, "S0", 1),
        ("S0", "t1", "S1", 0),  # x = 9 is invalid: near takes if_invalid (true)
        ("S1", None, "S1", 1),
        ("S1", None, "S1", 2),
    ]
    assert records[1].definitions == {"gap": 8, "near": True}
    assert not any(r.bad for r in records)


@pytest.mark.slow
@pytest.mark.parametrize("engines", ["explicit first", "symbolic alone"])
def test_engine_agrees_with_bruteforce_on_data_machines(engines: str) -> None:
    """The engine as `check` runs it (the explicit-state search first), and its symbolic engines alone."""
    tally: Counter[str] = Counter()
    limits = LIMITS if engines == "explicit first" else replace(LIMITS, steps=0)

    @SETTINGS
    @given(specs())
    def run(text: str) -> None:
        machine = load_text(text, "random.toml")
        compare(machine, check_all(machine, limits=limits), tally)

    run()
    assert tally["properties"] > 0
    share = tally["unknown"] / tally["properties"]
    assert share <= UNKNOWN_SHARE, f"{tally['unknown']} of {tally['properties']} properties unknown: {dict(tally)}"
    print(dict(sorted(tally.items())))
