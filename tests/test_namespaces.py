"""Spec names and the names the engine and the generated code define for themselves live apart: a spec that uses
one of them as a name gets the verdicts and the code behaviour of the same spec renamed, or is refused at load
with the reason."""

from __future__ import annotations

import random
import re
import subprocess
from pathlib import Path
from types import ModuleType

import pytest

from mlca_verify.codegen import generate, write
from mlca_verify.errors import SpecError
from mlca_verify.loading import import_generated
from mlca_verify.logic import check_all
from mlca_verify.spec import load_spec

# A machine with one element of every role; each role's name is replaced in turn by an engine or code name.
BASE = """
[machine]
name = "ns"
initial = "A"
states = ["A", "B", "C"]
[params]
pk = { type = "int", default = 3, range = [1, 4], unit = "m", doc = "a threshold" }
[inputs]
ib = { doc = "a request" }
[signals]
sg = { type = "int", unit = "m", range = [0, 9], doc = "a sample" }
[variables]
vn = { type = "int", initial = 0, range = [0, 12], every = "min(vn + 1, 12)", doc = "a counter" }
[definitions]
df = { expr = "sg > pk", doc = "a comparison" }
[outputs]
ot = { type = "int", expr = "if state == B then vn else 0", doc = "an output" }
[[transition]]
from = "A"
to = "B"
when = "ib and df and vn > 3"
[[transition]]
from = "B"
to = "C"
when = "not ib"
do = "vn = 0"
[[transition]]
from = "C"
to = "A"
when = "ib"
[[invariant]]
id = "lag"
expr = "prev(vn) <= vn or state == C"
[[invariant]]
id = "sometimes-a"
expr = "state == A"
expect = "violated"
[[liveness]]
id = "answer"
assume = "not ib"
goal = "state != B"
within = 2
[[assume]]
id = "env"
expr = "sg >= 0"
"""

ROLES = {"param": "pk", "input": "ib", "signal": "sg", "variable": "vn", "definition": "df", "output": "ot"}
# What the engine names for itself (z3 frame constants, registers, response counters, test activation literals)
# and what the generated code defines beside a spec's names (context members, helpers, ACSL logic functions,
# function arguments, placeholders for empty structs).
OWN_NAMES = [
    "mode", "first", "prev0", "prev1", "respond", "act", "shape0", "lshape0", "lprev0", "reg0", "when1", "unused",
    "c", "i", "p", "o", "n", "nxt", "out", "fired", "before", "after", "failing", "Inv", "Err", "param", "T",
]  # fmt: skip
REFUSED = {("variable", "mode"), ("variable", "first"), ("variable", "prev0"), ("variable", "prev1")}


def _renamed(role: str, name: str) -> str:
    return re.sub(rf"\b{ROLES[role]}\b", name, BASE)


Verdicts = dict[str, tuple[str, str, int | None]]


def _verdicts(path: Path, role: str, name: str) -> Verdicts:
    """Each property's verdict, detail and counterexample length, the property ids in the base's names."""
    results = check_all(load_spec(path).machine)
    return {
        r.prop.replace(f":{name}", f":{ROLES[role]}"): (
            r.verdict,
            r.detail,
            len(r.counterexample.steps) if r.counterexample else None,
        )
        for r in results
    }


def _same_words(verdicts: Verdicts, role: str, name: str) -> Verdicts:
    """The details with both names of the element written alike."""
    word = re.compile(rf"\b({name}|{ROLES[role]})\b")
    return {k: (v, word.sub("NAME", d), n) for k, (v, d, n) in verdicts.items()}


def _module(path: Path, out: Path, tag: str) -> ModuleType:
    spec = load_spec(path)
    write(generate(spec, out), out)
    subprocess.run(
        ["gcc", "-std=c99", "-Wall", "-Werror", "-c", str(out / "c" / "ns_fsm.c"), "-o", str(out / "ns.o")],
        check=True,
        capture_output=True,
    )
    return import_generated(out / "python" / "ns_fsm.py", f"ns_fsm_{tag}")


def _run(module: ModuleType, role: str, name: str) -> list[tuple[int, tuple[object, ...]]]:
    """A fixed random sequence of steps: each step's mode and outputs, with the spec's own names."""
    rng = random.Random(7)
    ctx = module.Context()
    params = module.Params(**{(name if role == "param" else "pk"): 2})
    trace = []
    for _ in range(60):
        inputs = {"ib": rng.random() < 0.5, "sg": rng.randrange(0, 10)}
        if role in ("input", "signal"):
            inputs[name] = inputs.pop(ROLES[role])
        out = module.step(ctx, module.Inputs(**inputs), params)
        trace.append((int(ctx.mode), tuple(vars(out).values())))
    return trace


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> tuple[Verdicts, list[object]]:
    folder = tmp_path_factory.mktemp("base")
    path = folder / "ns.toml"
    path.write_text(BASE)
    return _verdicts(path, "param", "pk"), list(_run(_module(path, folder / "gen", "base"), "param", "pk"))


@pytest.mark.parametrize("role", sorted(ROLES))
@pytest.mark.parametrize("name", OWN_NAMES)
def test_an_own_name_as_a_spec_name_changes_nothing_or_is_refused(
    role: str, name: str, base: tuple[Verdicts, list[object]], tmp_path: Path
) -> None:
    path = tmp_path / "ns.toml"
    path.write_text(_renamed(role, name))
    if (role, name) in REFUSED:
        with pytest.raises(SpecError, match=f"'{name}' clashes with the member '{name}' that the generated context"):
            load_spec(path)
        return
    verdicts, trace = base
    assert _same_words(_verdicts(path, role, name), role, name) == _same_words(verdicts, role, name)
    assert _run(_module(path, tmp_path / "gen", f"{role}_{name}"), role, name) == trace


def test_the_base_machine_has_every_kind_of_verdict(base: tuple[Verdicts, list[object]]) -> None:
    verdicts, trace = base
    assert verdicts["sometimes-a"][0] == "violated" and verdicts["sometimes-a"][2] is not None
    assert verdicts["lag"][0] == "holds" and verdicts["answer"][0] == "holds"
    assert verdicts["reach:C"][0] == "holds" and verdicts["fires:t3"][0] == "holds"
    assert {mode for mode, _ in trace} == {0, 1, 2}
