"""Counterexamples become regression tests: a pytest test against the generated Python and a C test against the
generated C, each replaying the trace and failing while the defect is there.

Only invariant and liveness violations of machines that have generated code are emitted (the other checks are
about the spec itself: a nondeterministic or gappy machine has no code to test). Each test can be pointed at
another machine with the same state and input names (a repair, say): Python through the environment variable
MLCA_FSM (a path to a generated module), C through -DFSM_HEADER, -DFSM_PREFIX and -DFSM_MACRO.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from mlca_verify.codegen.render import c_expr, c_ident, py_expr
from mlca_verify.escape import c_comment, py_comment, py_docstring
from mlca_verify.files import write_atomic
from mlca_verify.logic.results import Counterexample, Result
from mlca_verify.model import Expr, Liveness, Machine, show
from mlca_verify.spec import LoadedSpec

LOOP_REPEATS = 3  # a lasso's loop is replayed this many times


@dataclass(frozen=True)
class Replay:
    """What to replay: the inputs of every step, where checking starts, and what must hold."""

    prop: str
    kind: str
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
    target = generated / "python" / f"{spec.machine.name.lower()}_fsm.py"
    return Path(os.path.relpath(target.resolve(), out.resolve())).as_posix()


def python_test(spec: LoadedSpec, r: Replay, module_path: str) -> str:
    steps = ",\n".join(f"    {d!r}" for d in r.inputs)
    check = (
        f'        assert {r.prop!r} not in fsm.check_invariants(inputs, state), f"{r.prop} fails after step {{k + 1}}"'
        if r.kind == "invariant"
        else "        reached = reached or (k >= CHECK_FROM and goal(inputs, state, fsm.State))"
    )
    tail = (
        ""
        if r.kind == "invariant"
        else '    assert reached, "the goal is never reached: the lane change is never served"\n'
    )
    goal = (
        ""
        if r.kind == "invariant"
        else f"\n\ndef goal(inputs, state, State):  # {py_comment(show(r.expr))}\n    return {py_expr(r.expr)}\n"
    )
    return f'''"""Regression test emitted by mlca-verify from {py_docstring(spec.path)} (sha256 {spec.sha256}).

{spec.machine.name} violates {r.prop} ({r.kind}): {py_docstring(r.summary)}. This test replays the counterexample and
fails while the defect is there. MLCA_FSM=path/to/other_fsm.py replays it on another machine.
"""

import importlib.util
import os
import pathlib
import sys

DEFAULT = pathlib.Path(__file__).resolve().parent / {module_path!r}
CHECK_FROM = {r.check_from}
STEPS = [
{steps},
]


def load():
    path = pathlib.Path(os.environ.get("MLCA_FSM", DEFAULT))
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module
{goal}

def test_{c_ident(r.prop)}():
    fsm = load()
    state = fsm.INITIAL
    reached = False
    for k, values in enumerate(STEPS):
        inputs = fsm.Inputs(**values)
        state = fsm.step(state, inputs)
{check}
{tail}'''


def _c_cond(expr: Expr) -> str:
    return re.sub(r"@@_([A-Za-z0-9_]+)", r"ST(\1)", c_expr(expr, "@@"))


def c_test(spec: LoadedSpec, r: Replay) -> str:
    m = spec.machine
    names = m.input_names
    rows = ",\n".join("    {" + ", ".join("true" if d[n] else "false" for n in names) + "}" for d in r.inputs)
    assign = "\n".join(f"        in.{n} = STEPS[k][{i}];" for i, n in enumerate(names))
    if r.kind == "invariant":
        body = f'''        if (!{_c_cond(r.expr)}) {{
            printf("{r.prop} fails after step %d\\n", k + 1);
            return 1;
        }}'''
        tail = "    return 0;"
    else:
        body = f"        reached = reached || (k >= CHECK_FROM && {_c_cond(r.expr)});"
        tail = f'''    if (!reached) {{
        printf("{r.prop}: the goal is never reached\\n");
        return 1;
    }}
    return 0;'''
    module = m.name.lower()
    return f"""/* Regression test emitted by mlca-verify from {c_comment(spec.path)} (sha256 {spec.sha256}).
 * {m.name} violates {r.prop} ({r.kind}): {c_comment(r.summary)}.
 * Exit 1 while the defect is there. Build: gcc -std=c99 -I<generated/c> this.c <generated/c>/{module}_fsm.c
 * Another machine: -DFSM_HEADER='"x_fsm.h"' -DFSM_PREFIX=x_ -DFSM_MACRO=X_ */
#include <stdbool.h>
#include <stdio.h>
#ifndef FSM_HEADER
#define FSM_HEADER "{module}_fsm.h"
#define FSM_PREFIX {module}_
#define FSM_MACRO {m.name.upper()}_
#endif
#include FSM_HEADER
#define CAT2(a, b) a##b
#define CAT(a, b) CAT2(a, b)
#define FSM(x) CAT(FSM_PREFIX, x)
#define ST(x) CAT(FSM_MACRO, x)
#define CHECK_FROM {r.check_from}
#define STEP_COUNT {len(r.inputs)}

static const bool STEPS[STEP_COUNT][{len(names)}] = {{
{rows}
}};

int main(void)
{{
    int k;
    bool reached = false;
    FSM(state_t) s = ST(INITIAL);
    for (k = 0; k < STEP_COUNT; ++k) {{
        FSM(inputs_t) in;
{assign}
        s = FSM(step)(s, in);
{body}
    }}
    (void)reached;
{tail}
}}
"""


def emit(spec: LoadedSpec, results: list[Result], generated: Path, out: Path) -> list[Path]:
    """Write the tests for every replayable violation of `spec`; return the files written."""
    out.mkdir(parents=True, exist_ok=True)
    written = []
    module = spec.machine.name.lower()
    for result in results:
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
