"""A proof must hold for the code that runs: the engine's verdicts on random machines with data against runs of the
generated Python (binary64 or binary32 reals, IEEE division). Every invariant and range check the engine proves without a
caveat holds at every step of random runs of the code at the params' defaults, and every counterexample the engine
reports without a caveat, replayed in the code, fails at its last step. The machines are those of
test_data_vs_bruteforce (int counters, an int signal read by definitions, params), without their environment
assumptions (random runs do not keep to them), and machines with a real timer that counts in decimal steps and
guards that compare it with decimals (the classes where reals and binary64 part), in either format: a verdict the
engine carries over to binary32 must hold for the generated Python's binary32 too."""

from __future__ import annotations

import itertools
import os
import random
import re
from pathlib import Path
from types import ModuleType

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mlca_verify.codegen import generate, write
from mlca_verify.errors import CodegenError
from mlca_verify.loading import import_generated
from mlca_verify.logic import check_all
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.results import Result
from mlca_verify.model import Machine
from mlca_verify.spec import load_spec
from tests.test_data_vs_bruteforce import specs

# random machines, in two classes: 200 in the suite; more on demand (CODE_VS_PROOFS_MACHINES=5000 .venv/bin/pytest
# tests/test_code_vs_proofs.py; an int machine takes about 0.6 s here)
MACHINES = int(os.environ.get("CODE_VS_PROOFS_MACHINES", "200"))
RUNS, STEPS = 4, 25
LIMITS = Limits(depth=20)
SETTINGS = settings(
    max_examples=MACHINES // 2,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.function_scoped_fixture],
)
_COUNT = itertools.count()


@st.composite
def real_timers(draw: st.DrawFn) -> str:
    """A real timer counting in a decimal step, and guards comparing it with decimals (exact or not in binary64 or
    binary32)."""
    reals = draw(st.sampled_from(["binary64", "binary32"]))
    step = draw(st.sampled_from(["0.1", "0.2", "0.25", "0.3", "0.5", "0.7"]))
    low, high = sorted(
        draw(st.lists(st.sampled_from(["0.2", "0.25", "0.3", "0.5", "0.6", "0.9", "1.0"]), min_size=2, max_size=2))
    )
    skip = draw(st.sampled_from(["0.3", "0.6", "0.5", "0.9"]))
    guard = draw(st.sampled_from([f"t > {low} and t < {high} and t != {skip}", f"t == {skip}", f"t >= {high}"]))
    return f"""
[machine]
name = "R"
initial = "A"
states = ["A", "BAD"]
reals = "{reals}"
[inputs]
go = {{ doc = "go" }}
[variables]
t = {{ type = "real", initial = 0.0, range = [0.0, 2.0], every = "min(t + {step}, 2.0)", doc = "a timer" }}
[[transition]]
from = "A"
to = "BAD"
when = "go and {guard}"
[[invariant]]
id = "never-bad"
expr = "state != BAD"
"""


def _without_assumptions(text: str) -> str:
    return re.sub(r"\[\[assume\]\]\nid = \"env\"\nexpr = \"[^\"]*\"\n", "", text)


def _loaded(text: str, folder: Path) -> tuple[Machine, ModuleType]:
    path = folder / "r.toml"
    path.write_text(text)
    spec = load_spec(path)
    write(generate(spec, folder / "gen"), folder / "gen")
    return spec.machine, import_generated(folder / "gen" / "python" / "r_fsm.py", f"r_fsm_{next(_COUNT)}")


def _inputs(module: ModuleType, machine: Machine, values: dict[str, object]) -> object:
    return module.Inputs(
        **{i.name: values[i.name] for i in machine.inputs}, **{s.name: values[s.name] for s in machine.signals}
    )


def _random_values(machine: Machine, rng: random.Random) -> dict[str, object]:
    values: dict[str, object] = {i.name: rng.random() < 0.5 for i in machine.inputs}
    for s in machine.signals:
        low, high = (int(b) for b in s.range)
        values[s.name] = rng.randint(low - 1, high + 1)
    return values


def _step(module: ModuleType, ctx: object, inputs: object, *seen: object) -> tuple[list[str], object]:
    """One step and the monitor after it; `seen` holds the observers the monitor keeps, where the machine has."""
    before = module.Context(**vars(ctx))
    out = module.step(ctx, inputs)
    return module.monitor(before, ctx, inputs, module.DEFAULT_PARAMS, out, *seen), out


def _trusted(results: list[Result]) -> dict[str, Result]:
    return {r.prop: r for r in results if not r.caveat and r.proof is not None and not r.proof.parametric}


def _runs_keep_the_proofs(machine: Machine, module: ModuleType, results: dict[str, Result]) -> None:
    proved = {p for p, r in results.items() if r.verdict == "holds" and r.kind == "invariant"}
    ranges = {v for v in machine.variables if v.range is not None and results.get(f"range:{v.name}")}
    rng = random.Random(len(machine.states) * 7919 + len(machine.transitions))
    for _ in range(RUNS):
        ctx, seen = module.Context(), _observers(module)
        for k in range(STEPS):
            inputs = _inputs(module, machine, _random_values(machine, rng))
            if machine.otherwise == "undefined" and module._fired(ctx, inputs, module.DEFAULT_PARAMS) == 0:
                break  # no transition enabled: the spec leaves the step undefined, the engine has no such run
            failing, _ = _step(module, ctx, inputs, *seen)
            assert not proved & set(failing), (k, failing)
            for v in ranges:
                if results[f"range:{v.name}"].verdict == "holds":
                    holder = seen[0] if seen and hasattr(seen[0], v.name) else ctx  # an observer: the monitor's
                    assert v.range[0] <= getattr(holder, v.name) <= v.range[1]


def _observers(module: ModuleType) -> tuple[object, ...]:
    """The observers the module's monitor keeps beside the context (none where it has none)."""
    return (module.Observers(),) if hasattr(module, "Observers") else ()


def _counterexamples_replay(machine: Machine, module: ModuleType, results: dict[str, Result]) -> None:
    for prop, r in results.items():
        if r.kind != "invariant" or r.verdict != "violated" or r.counterexample is None or r.counterexample.params:
            continue
        ctx, seen = module.Context(), _observers(module)
        failing: list[str] = []
        for step in r.counterexample.steps:
            failing, _ = _step(module, ctx, _inputs(module, machine, {**step.inputs, **step.signals}), *seen)
        assert prop in failing, prop


def _differ(text: str, folder: Path) -> None:
    try:
        machine, module = _loaded(text, folder)
    except CodegenError as refused:  # a step with no transition enabled is reachable: the engine shows one
        machine = load_spec(folder / "r.toml").machine
        assert "no transition enabled" in str(refused) and machine.otherwise == "undefined"
        (completeness,) = [r for r in check_all(machine, limits=LIMITS) if r.prop == "completeness"]
        assert completeness.verdict != "holds"
        return
    results = _trusted(check_all(machine, limits=LIMITS))
    _runs_keep_the_proofs(machine, module, results)
    _counterexamples_replay(machine, module, results)


@SETTINGS
@given(specs())
def test_the_generated_code_keeps_every_proof_of_random_int_machines(tmp_path_factory: object, text: str) -> None:
    _differ(_without_assumptions(text), tmp_path_factory.mktemp("int"))  # type: ignore[attr-defined]


@SETTINGS
@given(real_timers())
def test_the_generated_code_keeps_every_proof_of_random_real_timers(tmp_path_factory: object, text: str) -> None:
    _differ(text, tmp_path_factory.mktemp("real"))  # type: ignore[attr-defined]
