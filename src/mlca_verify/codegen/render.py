"""Jinja rendering: the template environment, whose filters escape every text that reaches a template."""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from pathlib import Path

import jinja2

from mlca_verify import escape
from mlca_verify.codegen.frames import FRAME_BYTES, FRAME_TEMPLATES, FRAME_VERSION, FramesIR, frame_files
from mlca_verify.codegen.ir import MachineIR
from mlca_verify.errors import CodegenError
from mlca_verify.layout import Layout

TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"  # shipped as package data


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
    env.filters.update(cid=c_ident, composed=Escaped)  # composed: a macro's own output
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
    env.filters.update({name: _escaping(function) for name, function in text.items()})
    return env


TEMPLATES = {"python": "python_fsm.py.j2", "c-header": "c_fsm.h.j2", "c-source": "c_fsm.c.j2"}
CERTIFIED_TEMPLATE = "certified.c.j2"  # the proof file `conform` writes: invariants with their certificates
SHARED_TEMPLATES = ("acsl.j2",)  # macros the templates import


def render(ir: MachineIR, template_dir: Path = TEMPLATE_DIR) -> dict[str, str]:
    """Every generated file of one machine: relative path -> text."""
    layout = Layout(Path(), ir.module)
    return {layout.relative(kind): _render_in(template_dir, name, {"m": ir}) for kind, name in TEMPLATES.items()}


def render_frames(f: FramesIR, template_dir: Path = TEMPLATE_DIR) -> dict[str, str]:
    """Every generated frame file of one network: relative path -> text."""
    paths = frame_files(f.module)
    values = {"f": f, "frame_bytes": FRAME_BYTES, "version": FRAME_VERSION}
    return {paths[kind]: _render_in(template_dir, name, values) for kind, name in FRAME_TEMPLATES.items()}


def render_template(name: str, **values: object) -> str:
    """One shipped template rendered with `values` (spec text in them passes the environment's filters)."""
    return _render_in(TEMPLATE_DIR, name, values)


def _render_in(template_dir: Path, name: str, values: Mapping[str, object]) -> str:
    try:
        return environment(template_dir).get_template(name).render(**values)
    except jinja2.TemplateError as err:
        where = f"{template_dir / name}:{getattr(err, 'lineno', None) or 1}"
        raise CodegenError.at(where, f"template failed: {err}") from None
