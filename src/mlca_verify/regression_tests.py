"""Counterexamples become regression tests: a pytest test against the generated Python and a C test against the
generated C, each replaying the trace and failing while the defect is there.

Only invariant and liveness violations of machines that have generated code are emitted (the other checks are
about the spec itself: a nondeterministic or gappy machine has no code to test). Each test can be pointed at
another machine with the same state and input names (a repair, say): Python through the environment variable
<MACHINE>_FSM (a path to a generated module), C through -DFSM_HEADER, -DFSM_PREFIX and -DFSM_MACRO.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Literal

from mlca_verify.codegen.data_ir import DataIR, build_data_ir
from mlca_verify.codegen.lower import Lowering, names_of, real_literal
from mlca_verify.codegen.render import Escaped, c_ident, render_template
from mlca_verify.files import write_atomic
from mlca_verify.layout import Layout
from mlca_verify.logic.results import Counterexample, Result
from mlca_verify.model import Expr, Liveness, Machine, Output, Variable, prevs_of, show
from mlca_verify.spec import LoadedSpec

LOOP_REPEATS = 3  # a lasso's loop is replayed this many times


@dataclass(frozen=True)
class Replay:
    """What to replay: the inputs of every step, where checking starts, and what must hold."""

    prop: str
    kind: Literal["invariant", "liveness"]
    inputs: list[dict[str, bool]]
    check_from: int  # steps before this index are the stem
    expr: Expr  # invariant: must hold after every step; liveness: the goal must hold at some checked step
    summary: str


def replay_of(machine: Machine, result: Result) -> Replay | None:
    cx = result.counterexample
    if cx is None or result.verdict != "violated" or any(s.outcome.transition is None for s in cx.steps):
        return None
    inputs = [dict(s.inputs) for s in cx.steps]
    if result.kind == "invariant":
        inv = next(i for i in machine.invariants if i.id == result.prop)
        return Replay(result.prop, "invariant", inputs, 0, inv.expr, f"{inv.id}: {show(inv.expr)} after every step")
    if result.kind != "liveness":
        return None
    live = next(p for p in machine.liveness if p.id == result.prop)
    return _liveness_replay(live, cx, inputs)


def _liveness_replay(live: Liveness, cx: Counterexample, inputs: list[dict[str, bool]]) -> Replay:
    if cx.loop_start is not None:
        stem, loop = inputs[: cx.loop_start], inputs[cx.loop_start :]
        summary = (
            f"assume {show(live.assume)} forever: {show(live.goal)} at some step of the loop ({LOOP_REPEATS} rounds)"
        )
        return Replay(live.id, "liveness", stem + loop * LOOP_REPEATS, len(stem), live.goal, summary)
    start = len(inputs) - (live.within or len(inputs))
    summary = f"assume {show(live.assume)}: {show(live.goal)} within {live.within} steps"
    return Replay(live.id, "liveness", inputs, start, live.goal, summary)


def _module_path(spec: LoadedSpec, generated: Path, out: Path) -> str:
    target = Layout(generated, spec.machine.name.lower()).python
    return Path(os.path.relpath(target.resolve(), out.resolve())).as_posix()


def _render(template: str, spec: LoadedSpec, r: Replay, **extra: object) -> str:
    m = spec.machine
    module, macro = m.name.lower(), m.name.upper()
    values = {"spec_path": spec.path, "sha256": spec.sha256, "machine": m.name, "module": module, "macro": macro}
    return render_template(template, r=r, names=m.input_names, env_var=f"{macro}_FSM", **values, **extra)


def python_test(spec: LoadedSpec, r: Replay, module_path: str) -> str:
    """A pytest module replaying `r` on the generated Python (or on the module named by `<MACHINE>_FSM`)."""
    return _render("emitted_test.py.j2", spec, r, module_path=module_path)


def c_test(spec: LoadedSpec, r: Replay) -> str:
    """A C program replaying `r` on the generated C (or on the machine named by -DFSM_HEADER and friends)."""
    return _render("emitted_test.c.j2", spec, r)


def _value_py(value: object) -> str:
    return repr(value) if not isinstance(value, float) else real_literal(Fraction(value))


def _value_c(value: object, ctype: str) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if ctype == "double" and isinstance(value, int | float | Fraction):
        return real_literal(Fraction(value))
    return str(value)


def data_tests(spec: LoadedSpec, result: Result, module_path: str) -> tuple[str, str] | None:
    """A pytest and a C test replaying a violated invariant, range check or liveness property of a machine with
    data, with every signal and param value of its counterexample; None for the other checks."""
    cx = result.counterexample
    m = spec.machine
    if cx is None or result.verdict != "violated" or result.kind not in ("invariant", "range", "liveness"):
        return None
    ir = _ir(spec)
    ctypes = {f.name: f.ctype for f in (*ir.signals, *ir.params)}
    steps: list[dict[str, object]] = [{**s.inputs, **s.signals} for s in cx.steps]
    values: dict[str, object] = {
        "spec_path": spec.path,
        "sha256": spec.sha256,
        "machine": m.name,
        "module": m.name.lower(),
        "macro": m.name.upper(),
        "prop": result.prop,
        "kind": result.kind,
        "summary": result.detail,
        "env_var": f"{m.name.upper()}_FSM",
        "module_path": module_path,
        "test_name": c_ident(result.prop),
        "params": Escaped("{" + ", ".join(f"{k!r}: {_value_py(v)}" for k, v in cx.params.items()) + "}"),
        "c_params": Escaped(", ".join(_value_c(cx.params[p.name], ctypes[p.name]) for p in m.params) or "0"),
        "index": next((k for k, inv in enumerate(m.invariants) if inv.id == result.prop), 0),
        "check_from": 0,
    }
    if result.kind == "range":
        ranged: list[Variable | Output] = [*m.variables, *m.outputs]
        element = next(e for e in ranged if f"range:{e.name}" == result.prop)
        assert element.range is not None
        kind = "double" if element.type == "real" else "int"
        values.update(
            variable=element.name,
            holder="out" if isinstance(element, Output) else "ctx",  # an output is read from the step's outputs
            low=Escaped(_value_c(element.range[0] if kind == "double" else int(element.range[0]), kind)),
            high=Escaped(_value_c(element.range[1] if kind == "double" else int(element.range[1]), kind)),
        )
    if result.kind == "liveness":
        live = next(p for p in m.liveness if p.id == result.prop)
        if prevs_of(live.assume, live.goal):
            return None  # prev() in a response is not replayed: the test would need the engine's registers
        steps = _liveness_values(values, m, live, cx, steps)
    names = [*m.input_names, *(sig.name for sig in m.signals)]
    values["steps"] = [Escaped("{" + ", ".join(f"{n!r}: {_value_py(s[n])}" for n in names) + "}") for s in steps]
    values["c_steps"] = [
        Escaped(", ".join(f".{n} = {_value_c(s[n], ctypes.get(n, 'bool'))}" for n in names)) for s in steps
    ]
    return render_template("data_emitted_test.py.j2", **values), render_template("data_emitted_test.c.j2", **values)


def _liveness_values(
    values: dict[str, object], m: Machine, live: Liveness, cx: Counterexample, steps: list[dict[str, object]]
) -> list[dict[str, object]]:
    """The assumption, goal and bound in both languages (over the context after a step, its inputs, the params
    and outputs), and the steps to replay: a lasso's loop is repeated."""
    names = names_of(m, m.name.lower(), m.name.upper())
    py, c = Lowering(names, "py"), Lowering(names, "c")
    bound = live.steps_bound
    values.update(
        assume_py=py.go(live.assume),
        goal_py=py.go(live.goal),
        assume_c=Escaped(c.go(live.assume)),
        goal_c=Escaped(c.go(live.goal)),
        bound_py=None if bound is None else py.go(bound),
        bound_c=Escaped("" if bound is None else c.go(bound)),
    )
    if cx.loop_start is None:
        return steps
    values["check_from"] = cx.loop_start
    return steps[: cx.loop_start] + steps[cx.loop_start :] * LOOP_REPEATS


def _ir(spec: LoadedSpec) -> DataIR:
    return build_data_ir(spec.machine, spec.machine.name.lower(), spec.path, spec.sha256, "mlca-verify")


def emit(spec: LoadedSpec, results: list[Result], generated: Path, out: Path) -> list[Path]:
    """Write the tests for every replayable violation of `spec`; return the files written."""
    out.mkdir(parents=True, exist_ok=True)
    written = []
    module = spec.machine.name.lower()
    for result in results:
        if spec.machine.has_data:
            tests = data_tests(spec, result, _module_path(spec, generated, out))
            if tests is not None:
                stem = f"test_{module}_{c_ident(result.prop)}"
                for suffix, text in zip((".py", ".c"), tests, strict=True):
                    write_atomic(out / f"{stem}{suffix}", text)
                    written.append(out / f"{stem}{suffix}")
            continue
        r = replay_of(spec.machine, result)
        if r is None:
            continue
        stem = f"test_{module}_{c_ident(r.prop)}"
        py = out / f"{stem}.py"
        write_atomic(py, python_test(spec, r, _module_path(spec, generated, out)))
        c = out / f"{stem}.c"
        write_atomic(c, c_test(spec, r))
        written += [py, c]
    return written
