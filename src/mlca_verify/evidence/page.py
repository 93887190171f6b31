"""The evidence page: one self-contained HTML file (inline CSS and SVG, no script, nothing fetched)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import jinja2

from mlca_verify.errors import ToolError
from mlca_verify.tools import run

TEMPLATE = Path(__file__).with_name("page.html.j2")
NETWORK_TEMPLATE = Path(__file__).with_name("network.html.j2")


def inline_svg(dot_text: str) -> str | None:
    """SVG for inlining (no XML prolog, no DOCTYPE), or None when Graphviz is not installed."""
    try:
        ran = run(["dot", "-Tsvg"], timeout=60, stdin=dot_text)
    except ToolError:
        return None
    if ran.returncode != 0:
        return None
    svg = ran.output[ran.output.index("<svg") :]
    return re.sub(r"<!--.*?-->\n?", "", svg, flags=re.DOTALL)


def anchor(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]", "-", text)


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATE.parent)),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )
    env.filters.update(anchor=anchor)
    return env


def _children(data: dict[str, Any]) -> dict[str | None, list[dict[str, Any]]]:
    children: dict[str | None, list[dict[str, Any]]] = {}
    for node in data["argument"]:
        children.setdefault(node["parent"], []).append(node)
    return children


def render_network_page(data: dict[str, Any]) -> str:
    """The page of a network's evidence (evidence.network)."""
    return _environment().get_template(NETWORK_TEMPLATE.name).render(d=data, children=_children(data))


def render_page(data: dict[str, Any]) -> str:
    env = _environment()
    svgs = {m["machine"]: inline_svg(m["dot"]) for m in data["readings"]["machines"]}
    children = _children(data)
    drawn = inline_svg(data["spec"]["dot"])
    return env.get_template(TEMPLATE.name).render(d=data, svgs=svgs, drawn=drawn, children=children)
