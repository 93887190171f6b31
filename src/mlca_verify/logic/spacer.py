"""Spacer (z3's PDR for constrained Horn clauses) in a z3 process of its own.

In the calling process, Spacer's search depends on the process's history, not only on the query: the same clauses,
rebuilt from the same text in a fresh z3 context, took 0.3 s after one sequence of earlier checks and 2.3 s after
another (MLCA-T's `no-livelock`), so on a budget a proof could come out in one command and unknown in the next.
The z3 binary of the same release as the z3 module, given the clauses as SMT-LIB text on its standard input,
starts from nothing every time: the same clauses and budget give the same answer whatever ran before."""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from typing import Literal

import z3

from mlca_verify.errors import ToolError
from mlca_verify.logic.solver import GUARD, GUARD_MIN_MS, RESOURCE_PER_MS, RLIMIT_MAX
from mlca_verify.tools import run

Answer = Literal["sat", "unsat", "unknown"]
OPTIONS = (  # Spacer with global guidance, and every argument of the invariant kept (no slicing, no inlining)
    "fp.engine=spacer",
    "fp.xform.slice=false",
    "fp.xform.inline_linear=false",
    "fp.xform.inline_eager=false",
    "fp.spacer.global=true",
)


@functools.cache
def binary() -> str:
    """The z3 command-line solver installed with the z3 module (z3-solver puts it beside the interpreter), of the
    same release as the module."""
    found = Path(sys.executable).parent / "z3"
    if not found.is_file():
        raise ToolError(f"error: z3's command-line solver not found at {found}; reinstall z3-solver")
    version = run([str(found), "--version"], timeout=60).output.split()
    if z3.get_version_string() not in version:
        raise ToolError(f"error: {found} is not z3 {z3.get_version_string()} ({' '.join(version)})")
    return str(found)


def solve(clauses: str, query: str, timeout_ms: int) -> tuple[Answer, str]:
    """Ask whether `query` (a relation of `clauses`) is derivable, on z3's resource budget for `timeout_ms`: the
    answer, and after it what z3 printed (the invariant, for unsat; why it stopped, for unknown)."""
    rlimit = min(timeout_ms * RESOURCE_PER_MS, RLIMIT_MAX)
    guard_s = max(timeout_ms * GUARD, GUARD_MIN_MS) / 1000
    text = f"{clauses}\n(query {query} :print-certificate true)\n"
    try:
        output = run([binary(), *OPTIONS, f"rlimit={rlimit}", "-in"], timeout=guard_s, stdin=text).output
    except ToolError as err:
        return "unknown", str(err)
    lines = output.strip().splitlines()
    errors = [line for line in lines if line.startswith("(error")]
    if errors:  # z3 goes on after an error, without the clause it could not read: never take its answer then
        return "unknown", _one_line(errors)
    answers: dict[str, Answer] = {"sat": "sat", "unsat": "unsat", "unknown": "unknown"}
    for n, line in enumerate(lines):
        said = answers.get(line.strip())
        if said is not None:
            return said, "\n".join(lines[n + 1 :]) if said != "unknown" else _one_line(lines[:n])
    return "unknown", _one_line(lines)


def _one_line(lines: list[str]) -> str:
    """What z3 said before giving up, on one line (a reason is printed in a table's detail)."""
    said = "; ".join(line.strip() for line in lines if line.strip())
    return said if len(said) <= 300 else said[:297] + "..."


def invariant(printed: str, relation: z3.FuncDeclRef, frame: list[z3.ExprRef]) -> z3.BoolRef | None:
    """The invariant Spacer printed for `relation`, over the constants of `frame` (its arguments in order); None
    when the text does not define it."""
    ctx = relation.ctx
    others = {"Err": z3.Function("Err", z3.BoolSort(ctx))}
    try:
        parsed = z3.parse_smt2_string(f"(assert {printed})", decls={relation.name(): relation, **others}, ctx=ctx)
    except z3.Z3Exception:
        return None
    todo: list[z3.ExprRef] = list(parsed)
    while todo:
        f = todo.pop()
        if z3.is_and(f):
            todo += f.children()
        elif z3.is_quantifier(f) and f.is_forall():
            found = _defined(f, relation, frame)
            if found is not None:
                return found
    return None


def _defined(quantified: z3.QuantifierRef, relation: z3.FuncDeclRef, frame: list[z3.ExprRef]) -> z3.BoolRef | None:
    """`forall args. Inv(args) = body` (or `Inv(args)`, or `not Inv(args)`) as `body` over `frame`."""
    body = quantified.body()
    if z3.is_app_of(body, z3.Z3_OP_EQ) and _applies(body.arg(0), relation):
        app, definition = body.arg(0), body.arg(1)
    elif _applies(body, relation):
        app, definition = body, z3.BoolVal(True, relation.ctx)
    elif z3.is_not(body) and _applies(body.arg(0), relation):
        app, definition = body.arg(0), z3.BoolVal(False, relation.ctx)
    else:
        return None
    values: list[z3.ExprRef] = [frame[0]] * quantified.num_vars()
    for position in range(app.num_args()):
        values[z3.get_var_index(app.arg(position))] = frame[position]
    found: z3.BoolRef = z3.substitute_vars(definition, *values)
    return found


def _applies(term: z3.ExprRef, relation: z3.FuncDeclRef) -> bool:
    return z3.is_app(term) and term.decl().eq(relation) and all(z3.is_var(a) for a in term.children())
