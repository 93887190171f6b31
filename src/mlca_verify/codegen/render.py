"""Jinja rendering: expression printers for Python, C and ACSL, and the template environment."""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from pathlib import Path

import jinja2

from mlca_verify import escape
from mlca_verify.codegen.data_ir import DataIR
from mlca_verify.codegen.ir import MachineIR
from mlca_verify.errors import CodegenError
from mlca_verify.layout import Layout
from mlca_verify.model import BinOp, Const, Expr, Not, StateIn, Var, as_binop, show

TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"  # shipped as package data
TEMPLATES = {"python": "python_fsm.py.j2", "c-header": "c_fsm.h.j2", "c-source": "c_fsm.c.j2"}  # kinds of targets.FILES


_PY_PREC = {"or": 3, "and": 4, "not": 5, "cmp": 6, "atom": 9}


def py_expr(expr: Expr, parent: int = 0) -> str:
    """Python over `inputs` and `state` (a `State`), with only the parentheses Python needs."""
    text, prec = _py(expr)
    return f"({text})" if prec < parent else text


def _py(expr: Expr) -> tuple[str, int]:
    if isinstance(expr, Const):
        return ("True" if expr.value else "False"), _PY_PREC["atom"]
    if isinstance(expr, Var):
        return f"inputs.{expr.name}", _PY_PREC["atom"]
    if isinstance(expr, StateIn):
        return _py_state(expr, negated=False), _PY_PREC["cmp"]
    if isinstance(expr, Not):
        if isinstance(expr.arg, StateIn):
            return _py_state(expr.arg, negated=True), _PY_PREC["cmp"]
        if isinstance(expr.arg, Not):
            return _py(expr.arg.arg)
        return f"not {py_expr(expr.arg, _PY_PREC['not'])}", _PY_PREC["not"]
    expr = as_binop(expr)
    if expr.op == "->":
        return _py(BinOp("or", Not(expr.left), expr.right))
    if expr.op == "<->":
        return f"{py_expr(expr.left, 7)} == {py_expr(expr.right, 7)}", _PY_PREC["cmp"]
    prec = _PY_PREC[expr.op]
    return f"{py_expr(expr.left, prec)} {expr.op} {py_expr(expr.right, prec)}", prec


def _py_state(expr: StateIn, negated: bool) -> str:
    if len(expr.states) == 1:
        return f"state {'!=' if negated else '=='} State.{expr.states[0]}"
    names = ", ".join(f"State.{s}" for s in expr.states)
    return f"state {'not in' if negated else 'in'} ({names})"


def _c_like(expr: Expr, macro: str, ops: dict[str, str], state: str) -> str:
    """C-like text; a state constant is `<macro>_<STATE>`, or `<macro>(<STATE>)` when `macro` ends in '('."""

    def go(e: Expr) -> str:
        if isinstance(e, Const):
            return ops["true"] if e.value else ops["false"]
        if isinstance(e, Var):
            return f"in.{e.name}"
        if isinstance(e, StateIn):
            parts = [f"({state} == {_constant(macro, s)})" for s in e.states]
            return parts[0] if len(parts) == 1 else "(" + " || ".join(parts) + ")"
        if isinstance(e, Not):
            return f"(!{go(e.arg)})"
        e = as_binop(e)
        return f"({go(e.left)} {ops[e.op]} {go(e.right)})"

    return go(expr)


def c_expr(expr: Expr, macro: str) -> str:
    """C99 over `in` (the inputs struct) and `s` (the state); `a -> b` becomes `(!a || b)`."""
    ops = {"and": "&&", "or": "||", "<->": "==", "true": "true", "false": "false"}
    return _c_like(_without_implies(expr), macro, ops, "s")


def _constant(macro: str, state: str) -> str:
    return f"{macro}{state})" if macro.endswith("(") else f"{macro}_{state}"


def c_condition(expr: Expr, macro: str) -> str:
    """A C expression wrapped in the parentheses an `if` needs."""
    text = c_expr(expr, macro)
    return text if text.startswith("(") and text.endswith(")") else f"({text})"


def _without_implies(expr: Expr) -> Expr:
    if isinstance(expr, BinOp):
        left, right = _without_implies(expr.left), _without_implies(expr.right)
        return BinOp("or", Not(left), right) if expr.op == "->" else BinOp(expr.op, left, right)
    if isinstance(expr, Not):
        return Not(_without_implies(expr.arg))
    return expr


def acsl_expr(expr: Expr, macro: str, state: str = "s") -> str:
    """An ACSL predicate over `in` and the state variable."""
    ops = {"and": "&&", "or": "||", "->": "==>", "<->": "<==>", "true": "\\true", "false": "\\false"}
    return _c_like(expr, macro, ops, state)


def c_ident(text: str) -> str:
    """A C identifier fragment from a property or transition id (which may hold '-' or '.')."""
    return re.sub(r"[^A-Za-z0-9_]", "_", text)


class Escaped(str):
    """Text a filter made safe for the place it is written (the template environment accepts it as it is)."""


_RAW_SAFE = re.compile(r"[\x20-\x7e]*")
_RAW_HAZARDS = ("*/", "/*", '"', "'", "\\", "??")


def _plain(text: str) -> bool:
    return _RAW_SAFE.fullmatch(text) is not None and not any(hazard in text for hazard in _RAW_HAZARDS)


def _finalize(value: object) -> object:
    """Every `{{ ... }}` passes here: filtered text goes through; other text must be plain printable ASCII with
    no quote, backslash or comment delimiter, so spec text cannot reach a template unescaped by mistake."""
    if isinstance(value, str) and not isinstance(value, Escaped) and not _plain(value):
        raise CodegenError(f"error: unescaped text {value[:40]!r} reached a template: it needs an escaping filter")
    return value


def _escaping(function: Callable[..., str]) -> Callable[..., Escaped]:
    return lambda *args: Escaped(function(*args))


def environment(template_dir: Path = TEMPLATE_DIR) -> jinja2.Environment:
    if not template_dir.is_dir():
        raise CodegenError.at(template_dir, "template directory not found")
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(template_dir)),
        finalize=_finalize,
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters.update(negate=Not, show=show, cid=c_ident, composed=Escaped)  # composed: a macro's own output
    code: dict[str, Callable[..., str]] = {
        "py": py_expr,
        "c": c_expr,
        "ccond": c_condition,
        "acsl": acsl_expr,
    }  # validated names and operators
    text: dict[str, Callable[..., str]] = {
        "ccomment": escape.c_comment,
        "cstr": escape.c_string,
        "pycomment": escape.py_comment,
        "pydoc": escape.py_docstring,
        "pystr": escape.py_string,
        "pyrepr": repr,  # a Python literal of validated names and bools
        "cstrlit": lambda text: f'"{escape.c_string(text)}"',
        # a cite in parentheses after the text it cites, or nothing when the spec gives none
        "ccite": lambda text: f" ({escape.c_comment(text)})" if text else "",
        "pycite": lambda text: f" ({escape.py_comment(text)})" if text else "",
        "pydoccite": lambda text: f" ({escape.py_docstring(text)})" if text else "",
    }
    env.filters.update({name: _escaping(function) for name, function in {**code, **text}.items()})
    return env


def render(ir: MachineIR, template_dir: Path = TEMPLATE_DIR) -> dict[str, str]:
    """Every generated file of one machine: relative path -> text."""
    layout = Layout(Path(), ir.module)
    return {layout.relative(kind): _render_in(template_dir, name, {"m": ir}) for kind, name in TEMPLATES.items()}


DATA_TEMPLATES = {"python": "data_python.py.j2", "c-header": "data_c.h.j2", "c-source": "data_c.c.j2"}
CERTIFIED_TEMPLATE = "data_certified.c.j2"  # the proof file `conform` writes: invariants with their certificates
DATA_SHARED = ("data_acsl.j2",)  # macros the data templates import


def render_data(ir: DataIR, template_dir: Path = TEMPLATE_DIR) -> dict[str, str]:
    """Every generated file of one machine with data: relative path -> text."""
    layout = Layout(Path(), ir.module)
    return {layout.relative(kind): _render_in(template_dir, name, {"m": ir}) for kind, name in DATA_TEMPLATES.items()}


def render_template(name: str, **values: object) -> str:
    """One shipped template rendered with `values` (spec text in them passes the environment's filters)."""
    return _render_in(TEMPLATE_DIR, name, values)


def _render_in(template_dir: Path, name: str, values: Mapping[str, object]) -> str:
    try:
        return environment(template_dir).get_template(name).render(**values)
    except jinja2.TemplateError as err:
        where = f"{template_dir / name}:{getattr(err, 'lineno', None) or 1}"
        raise CodegenError.at(where, f"template failed: {err}") from None
