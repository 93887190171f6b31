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
from mlca_verify.network import Channel, Network, losses, timing
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


# --- a network of machines -----------------------------------------------------------------------------------


def channel_label(ch: Channel) -> str:
    """`ab: claiming -> other_claims`, then on a line of its own when it delivers and what it may lose (`1 to 2
    steps late, in any order, at most 1 lost in a row`)."""
    lost = f", {losses(ch)}" if ch.lost else ""
    return f"{ch.id}: {ch.output} -> {ch.port}\n{timing(ch)}{lost}"


def network_caption(net: Network, channels: str = "an edge between instances") -> str:
    schedule = "instances step together" if net.schedule == "synchronous" else "one instance steps at a time"
    fair = f", each within {net.fairness} steps" if net.fairness else ""
    cited = f" ({net.cite})" if net.cite else ""
    return f"{net.name}{cited}: {schedule}{fair}; {channels}: a channel (what it carries, its delay and losses)"


def network_dot(net: Network) -> str:
    """The network as DOT: a cluster per instance holding its machine's states and transitions, and each channel
    a dashed edge from its sender's cluster to its receiver's."""
    lines = [
        "digraph network {",
        "  rankdir=LR; compound=true;",
        f"  label={_dot_str(network_caption(net, 'a dashed blue edge'))}; labelloc=b; fontsize=10;",
        '  node [shape=ellipse, fontname="Helvetica"]; edge [fontname="Helvetica", fontsize=9];',
    ]
    for inst in net.instances:
        m = inst.machine
        node = {s: _dot_str(f"{inst.name}.{s}") for s in m.states}
        start = _dot_str(f"{inst.name}.__start")
        lines += [
            f"  subgraph {_dot_str('cluster_' + inst.name)} {{",
            f"    label={_dot_str(f'{inst.name}: {m.name} ({inst.spec})')}; tooltip={_dot_str(inst.cite)};",
            f'    {start} [shape=point, label=""];',
            f"    {start} -> {node[m.initial]};",
        ]
        lines += [f"    {node[s]} [label={_dot_str(s)}];" for s in m.states]
        for state, priority, t in _edges(m):
            label = _dot_str(f"{clip(_label(m, priority, t), DOT_TEXT_LIMIT - len(t.id) - 3)}\n[{t.id}]")
            lines.append(f"    {node[state]} -> {node[t.target]} [label={label}, tooltip={_dot_str(t.cite)}];")
        lines.append("  }")
    for ch in net.channels:
        sender, receiver = net.instance(ch.sender).machine, net.instance(ch.receiver).machine
        tail, head_ = _dot_str(f"{ch.sender}.{sender.initial}"), _dot_str(f"{ch.receiver}.{receiver.initial}")
        ends = f"ltail={_dot_str('cluster_' + ch.sender)}, lhead={_dot_str('cluster_' + ch.receiver)}"
        label = _dot_str(channel_label(ch))
        lines.append(
            f"  {tail} -> {head_} [{ends}, label={label}, style=dashed, color=blue, fontcolor=blue, "
            f"tooltip={_dot_str(ch.cite)}];"
        )
    lines.append("}")
    return "\n".join(lines) + "\n"


def network_mermaid(net: Network) -> str:
    """The network as a Mermaid state diagram: a composite state per instance (its states numbered, so that two
    instances of one machine do not share a name), and each channel an edge between two composites."""
    lines = ["stateDiagram-v2", f"    %% {one_line(network_caption(net))}"]
    for k, inst in enumerate(net.instances):
        m = inst.machine
        ids = {s: f"i{k}_s{j}" for j, s in enumerate(m.states)}
        lines.append(f"    state {inst.name} {{")
        lines += [f"        {ids[s]} : {s}" for s in m.states]
        lines.append(f"        [*] --> {ids[m.initial]}")
        for state, priority, t in _edges(m):
            label = _label(m, priority, t).replace("<->", "iff").replace("->", "implies").replace(":", " ")
            lines.append(f"        {ids[state]} --> {ids[t.target]}: {one_line(label)}")
        lines.append("    }")
    for ch in net.channels:
        label = one_line(channel_label(ch).replace("\n", ", ").replace("->", "to").replace(":", ""))
        lines.append(f"    {ch.sender} --> {ch.receiver}: {label}")
    return "\n".join(lines) + "\n"


def render_network(net: Network, fmt: str) -> str:
    if fmt == "scxml":
        raise Undrawable("a network has no SCXML form (its channels are not SCXML's): draw it as dot, svg or mermaid")
    return network_dot(net) if fmt == "dot" else network_mermaid(net)


__all__ = ["FORMATS", "Undrawable", "caption", "js_expr", "network_dot", "network_mermaid", "render", "render_network"]
