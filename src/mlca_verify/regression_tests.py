"""Counterexamples become regression tests: a pytest test against the generated Python and a C test against the
generated C, each replaying the trace and failing while the defect is there.

Only invariant, range and liveness violations of machines that have generated code are emitted (the other checks
are about the spec itself: a nondeterministic or gappy machine has no code to test). Each test can be pointed at
another machine with the same names (a repair, say): Python through the environment variable <MACHINE>_FSM (a
path to a generated module), C through another -I (the C test includes the generated `.c`, whose definitions it
reads: generate the other machine under this one's name into another folder).
"""

from __future__ import annotations

import os
from fractions import Fraction
from pathlib import Path

from mlca_verify.codegen.ir import MachineIR, build_ir
from mlca_verify.codegen.lower import REAL_CTYPES, Lowering, names_of, real_literal
from mlca_verify.codegen.render import Escaped, c_ident, render_template
from mlca_verify.files import write_atomic
from mlca_verify.floats import BY_CTYPE
from mlca_verify.layout import Layout
from mlca_verify.logic.results import Counterexample, Result
from mlca_verify.model import Liveness, Machine, Output, Variable, observer_variables, prevs_of
from mlca_verify.spec import LoadedSpec

LOOP_REPEATS = 3  # a lasso's loop is replayed this many times


def _module_path(spec: LoadedSpec, generated: Path, out: Path) -> str:
    target = Layout(generated, spec.machine.name.lower()).python
    return Path(os.path.relpath(target.resolve(), out.resolve())).as_posix()


def _value_py(value: object) -> str:
    return repr(value) if not isinstance(value, float) else real_literal(Fraction(value))


def _value_c(value: object, ctype: str) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if ctype in REAL_CTYPES and isinstance(value, int | float | Fraction):
        return real_literal(Fraction(value), BY_CTYPE[ctype])  # a float field takes a float constant
    return str(value)


def replay_tests(spec: LoadedSpec, result: Result, module_path: str) -> tuple[str, str] | None:
    """A pytest and a C test replaying a violated invariant, range check or liveness property, with every signal
    and param value of its counterexample; None for the other checks."""
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
        "observers": bool(observer_variables(m)),  # the monitor keeps them beside the context, in `g`
    }
    if result.kind == "range":
        ranged: list[Variable | Output] = [*m.variables, *m.outputs]
        element = next(e for e in ranged if f"range:{e.name}" == result.prop)
        assert element.range is not None
        kind = ir.real if element.type == "real" else "int"
        values.update(
            variable=element.name,
            # an output is read from the step's outputs, an observer from what the monitor keeps
            holder="out" if isinstance(element, Output) else "g" if element.name in observer_variables(m) else "ctx",
            low=Escaped(_value_c(element.range[0] if kind in REAL_CTYPES else int(element.range[0]), kind)),
            high=Escaped(_value_c(element.range[1] if kind in REAL_CTYPES else int(element.range[1]), kind)),
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
    return render_template("emitted_test.py.j2", **values), render_template("emitted_test.c.j2", **values)


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


def _ir(spec: LoadedSpec) -> MachineIR:
    return build_ir(spec.machine, spec.machine.name.lower(), spec.path, spec.sha256, "mlca-verify")


def emit(spec: LoadedSpec, results: list[Result], generated: Path, out: Path) -> list[Path]:
    """Write the tests for every replayable violation of `spec`; return the files written."""
    out.mkdir(parents=True, exist_ok=True)
    written = []
    module = spec.machine.name.lower()
    for result in results:
        tests = replay_tests(spec, result, _module_path(spec, generated, out))
        if tests is None:
            continue
        stem = f"test_{module}_{c_ident(result.prop)}"
        for suffix, text in zip((".py", ".c"), tests, strict=True):
            write_atomic(out / f"{stem}{suffix}", text)
            written.append(out / f"{stem}{suffix}")
    return written
