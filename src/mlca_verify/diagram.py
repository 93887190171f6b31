"""Diagrams of a machine: Graphviz DOT, Mermaid, and W3C SCXML (pure text, no I/O).

Transitions are drawn in priority order; under first-match semantics each label starts with its priority.
`from = "*"` transitions are drawn from every state. `otherwise = "stay"` is not drawn (no edge: the state
is kept); under `otherwise = "undefined"` the same absence is a gap, which the caption says. A spec's fallback
state (where generated code restarts a corrupted context), when it is not the initial state, is said in the
caption and marked on its state ("fallback").

Spec text in a DOT string (the caption's cite, an edge's label and tooltip) is clipped to DOT_TEXT_LIMIT
characters, ending in "...": Graphviz refuses a quoted string longer than 16,384 bytes.
"""

from __future__ import annotations

from mlca_verify.escape import one_line, terminal, xml_attribute
from mlca_verify.model import (
    Const,
    Expr,
    Machine,
    Not,
    StateIn,
    Transition,
    Var,
    as_binop,
    show,
)
from mlca_verify.statechart import Undrawable, head, transition_note

FORMATS = ("dot", "mermaid", "scxml")
DOT_TEXT_LIMIT = 1_000  # characters of spec text in one DOT string; escaped, at most 10 bytes each


def _edges(m: Machine) -> list[tuple[str, int, Transition]]:
    """(source state, priority within the source, transition), states in declaration order."""
    edges = []
    for state in m.states:
        for priority, t in enumerate(m.outgoing(state), start=1):
            edges.append((state, priority, t))
    return edges


def _label(m: Machine, priority: int, t: Transition) -> str:
    prefix = f"{priority}. " if m.semantics == "first-match" else ""
    updates = "; ".join(f"{u.variable} = {show(u.expr)}" for u in t.updates)
    return f"{prefix}{show(t.guard)}" + (f" / {updates}" if updates else "")


def caption(m: Machine) -> str:
    order = (
        "numbers give priority (first match fires)"
        if m.semantics == "first-match"
        else "no priority (any enabled edge may fire)"
    )
    rest = "no enabled edge: the state is kept" if m.otherwise == "stay" else "no enabled edge: undefined (a gap)"
    cited = f" ({m.cite})" if m.cite else ""
    return f"{m.name}{cited}: {order}; {rest}{_fallback_note(m)}"


def _fallback_note(m: Machine) -> str:
    """The spec's fallback state, said only when it is not the initial state (the default)."""
    if m.fallback_state == m.initial:
        return ""
    return f"; a corrupted state restarts in {m.fallback_state}"


def _dot_node_mark(m: Machine, state: str) -> str:
    return ' [xlabel="fallback"]' if _fallback_note(m) and state == m.fallback_state else ""


def to_dot(m: Machine, highlight: frozenset[tuple[str, str]] = frozenset()) -> str:
    """DOT text; edges in `highlight` ((source state, transition id) pairs) are drawn red and bold."""
    lines = [
        f"digraph {m.name} {{",
        "  rankdir=LR;",
        f"  label={_dot_str(caption(m))}; labelloc=b; fontsize=10;",
        '  node [shape=ellipse, fontname="Helvetica"]; edge [fontname="Helvetica", fontsize=9];',
        '  __start [shape=point, label=""];',
        f"  __start -> {m.initial};",
    ]
    lines += [f"  {s}{_dot_node_mark(m, s)};" for s in m.states]
    for state, priority, t in _edges(m):
        label = _dot_str(f"{clip(_label(m, priority, t), DOT_TEXT_LIMIT - len(t.id) - 3)}\n[{t.id}]")
        mark = ", color=red, fontcolor=red, penwidth=2" if (state, t.id) in highlight else ""
        lines.append(f"  {state} -> {t.target} [label={label}, tooltip={_dot_str(t.cite)}{mark}];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def clip(text: str, limit: int = DOT_TEXT_LIMIT) -> str:
    """`text` if it has at most `limit` characters, else its beginning and "..." in `limit` characters."""
    return text if len(text) <= limit else text[: max(limit - 3, 0)] + "..."


def _dot_str(text: str) -> str:
    """A DOT string (UTF-8) of at most DOT_TEXT_LIMIT characters of `text` (clipped): backslashes and quotes
    escaped, newlines as DOT's line breaks, other control characters as visible escapes; printable Unicode kept."""
    lines = (terminal(line.replace("\\", "\\\\").replace('"', '\\"')) for line in clip(text).split("\n"))
    return '"' + "\\n".join(lines) + '"'


def to_mermaid(m: Machine) -> str:
    lines = ["stateDiagram-v2", f"    %% {one_line(caption(m))}", f"    [*] --> {m.initial}"]
    for state, priority, t in _edges(m):
        label = _label(m, priority, t).replace("<->", "iff").replace("->", "implies").replace(":", " ")
        lines.append(f"    {state} --> {t.target}: {label}")
    if _fallback_note(m):
        lines.append(f"    note right of {m.fallback_state}: fallback, a corrupted state restarts here")
    return "\n".join(lines) + "\n"


def js_expr(expr: Expr) -> str:
    """An ECMAScript condition over the boolean inputs carried by the `step` event."""
    if isinstance(expr, Const):
        return "true" if expr.value else "false"
    if isinstance(expr, Var):
        return f"_event.data.{expr.name}"
    if isinstance(expr, StateIn):
        raise ValueError("guards do not mention the state")
    if isinstance(expr, Not):
        return f"!({js_expr(expr.arg)})"
    expr = as_binop(expr)
    a, b = js_expr(expr.left), js_expr(expr.right)
    return {"and": f"({a} && {b})", "or": f"({a} || {b})", "->": f"(!{a} || {b})", "<->": f"({a} === {b})"}[expr.op]


def to_scxml(m: Machine) -> str:
    """SCXML with one event, `step`, whose data holds the inputs. SCXML takes the first enabled transition in
    document order, which is first-match semantics; with no enabled transition the event changes nothing.
    A machine with data gets an ECMAScript datamodel (`statechart.to_scxml_data`)."""
    if m.has_data:
        from mlca_verify.statechart import to_scxml_data

        return to_scxml_data(m, caption(m))
    out = head(m, caption(m), f"booleans: {', '.join(m.input_names)}")
    for state in m.states:
        out.append(f"  <state id={xml_attribute(state)}>")
        for t in m.outgoing(state):
            out.append(transition_note(t))
            cond, target = xml_attribute(js_expr(t.guard)), xml_attribute(t.target)
            out.append(f'    <transition event="step" cond={cond} target={target}/>')
        out.append("  </state>")
    out.append("</scxml>")
    return "\n".join(out) + "\n"


def render(m: Machine, fmt: str) -> str:
    return {"dot": to_dot, "mermaid": to_mermaid, "scxml": to_scxml}[fmt](m)


__all__ = ["FORMATS", "Undrawable", "caption", "js_expr", "render"]
