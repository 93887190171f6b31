"""A network's counterexample as a message sequence chart (pure): each instance's steps side by side, and every
message a channel carried, with where it was read and where it was lost.

A message is what a channel's sender held after a step (`sent`): for a boolean output, only a true one (a claim,
a request; a false one is silence, read as nothing when lost); for a signal, every value. At each later step the
channel delivers the message of the age the trace chose (its `delay`, or the signal `<channel>~age`); the
receiver reads it (`heard`) unless the input `<channel>~lost` is true at that step (`lost`). A message may be
read more than once (a late channel in order may deliver the same one again) or never (`in flight` when the
trace ends); what is sent after the last step is left out (but on an immediate channel, where it is read in
that step). The chart reads the trace that
`network_report.network_trace` tells, so it shares nothing with the flattening but the names of the channels'
inputs and signals.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mlca_verify.check_report import number_text
from mlca_verify.errors import Loc
from mlca_verify.escape import terminal, xml_markup, xml_text
from mlca_verify.json_types import JsonObject
from mlca_verify.logic.results import Counterexample, Number, Result
from mlca_verify.network import Channel, Network, qualified

COLUMN = 24  # the narrowest column of an instance


@dataclass(frozen=True)
class Message:
    channel: str
    sent: int  # the step after which the sender held it (1: after the first step)
    value: Number
    heard: tuple[int, ...]  # the steps at which the receiver read it
    lost: tuple[int, ...]  # the steps at which it was to be read and was lost

    def to_json(self) -> JsonObject:
        return {
            "channel": self.channel,
            "sent": self.sent,
            "value": self.value,
            "heard": list(self.heard),
            "lost": list(self.lost),
        }


def messages(net: Network, cx: Counterexample) -> list[Message]:
    """Every message of `cx` (told in the network's words), channel by channel, in the order sent."""
    found = []
    for ch in net.channels:
        sent = [{**step.variables, **step.outputs}.get(qualified(ch.sender, ch.output)) for step in cx.steps]
        reads: dict[int, tuple[list[int], list[int]]] = {k: ([], []) for k in range(1, len(cx.steps) + 1)}
        for j, step in enumerate(cx.steps, start=1):
            age = int(step.signals.get(f"{ch.id}~age", ch.delay)) if ch.latest > ch.delay else ch.delay
            if j - 1 < age:
                continue  # nothing sent that long ago yet
            heard, lost = reads[j - age]
            (lost if step.inputs.get(f"{ch.id}~lost", False) else heard).append(j)
        readable = sent if ch.delay == 0 else sent[:-1]  # what is sent after the last step is read by none but
        for k, value in enumerate(readable, start=1):  # an immediate channel's receiver
            if value is None or (_boolean(net, ch) and not value):
                continue
            heard, lost = reads[k]
            number = int(value) if isinstance(value, bool) else value  # a boolean as 0 or 1
            found.append(Message(ch.id, k, number, tuple(heard), tuple(lost)))
    return found


def _boolean(net: Network, ch: Channel) -> bool:
    output = next(o for o in net.instance(ch.sender).machine.outputs if o.name == ch.output)
    return output.type == "bool"


def messages_json(net: Network, results: Sequence[Result]) -> dict[str, list[JsonObject]]:
    """The messages of each run a result shows, by property, as `check --json` writes them."""
    return {
        r.prop: [m.to_json() for m in messages(net, r.counterexample)]
        for r in results
        if r.counterexample is not None and r.counterexample.steps and not r.counterexample.point
    }


def lost_at(net: Network, results: Sequence[Result]) -> dict[str, list[tuple[Loc, str]]]:
    """Each channel that lost a message of a result's run, at the channel's place, by property."""
    found: dict[str, list[tuple[Loc, str]]] = {}
    for r in results:
        if r.counterexample is None or r.counterexample.point:
            continue
        for m in messages(net, r.counterexample):
            for j in m.lost:
                text = f"channel {m.channel}: the message sent after step {m.sent} is lost at step {j}"
                found.setdefault(r.prop, []).append((net_channel(net, m.channel).loc, text))
    return found


def charts(net: Network, results: Sequence[Result]) -> dict[str, str]:
    """The chart of each run a result shows (not a lemma's valuation), by property."""
    return {
        r.prop: chart_text(net, r.counterexample)
        for r in results
        if r.counterexample is not None and r.counterexample.steps and not r.counterexample.point
    }


def chart_text(net: Network, cx: Counterexample, indent: str = "    ") -> str:
    """The chart: a row of each instance's state (and its change) per step, and under the step a line per message
    sent after it, an arrow from its sender's column to its receiver's, with its fate."""
    names = [i.name for i in net.instances]
    column = {n: k for k, n in enumerate(names)}
    moves = [_moves(step.state, step.outcome.next or step.state, names) for step in cx.steps]
    width = max([COLUMN, *(len(m) + 2 for row in moves for m in row)])
    by_step: dict[int, list[Message]] = {}
    for m in messages(net, cx):
        by_step.setdefault(m.sent, []).append(m)
    lines = [
        indent + "step  " + "".join(terminal(n).ljust(width) for n in names).rstrip(),
        indent + "----  " + "".join(("-" * (width - 2)).ljust(width) for _ in names).rstrip(),
    ]
    for k, row in enumerate(moves, start=1):
        lines.append(indent + str(k).ljust(6) + "".join(terminal(m).ljust(width) for m in row).rstrip())
        for m in by_step.get(k, []):
            ch = net_channel(net, m.channel)
            arrow = _arrow(_label(net, ch, m), column[ch.sender], column[ch.receiver], width)
            lines.append(indent + " " * 6 + arrow + "  " + _fate(m))
    return "\n".join(lines)


def net_channel(net: Network, cid: str) -> Channel:
    return next(c for c in net.channels if c.id == cid)


def _moves(before: str, after: str, names: Sequence[str]) -> list[str]:
    """Each instance's state, `A -> B` where the step changed it (`A:KEEP B:CLAIM` as the trace tells modes)."""
    was, now = _modes(before), _modes(after)
    return [was.get(n, "?") if was.get(n) == now.get(n) else f"{was.get(n, '?')} -> {now.get(n, '?')}" for n in names]


def _modes(text: str) -> dict[str, str]:
    return dict(part.split(":", 1) for part in text.split() if ":" in part)


def _label(net: Network, ch: Channel, m: Message) -> str:
    return ch.id if _boolean(net, ch) else f"{ch.id} = {number_text(m.value)}"


def _arrow(label: str, sender: int, receiver: int, width: int) -> str:
    """`|-- label ---->` from the sender's column to the receiver's, or `<---- label --|` leftwards."""
    low, high = min(sender, receiver), max(sender, receiver)
    span = max((high - low) * width - 1, len(label) + 8)
    body = f" {terminal(label)} "
    if sender < receiver:
        text = "|--" + body + "-" * (span - len(body) - 4) + ">"
    else:
        text = "<" + "-" * (span - len(body) - 4) + body + "--|"
    return " " * (low * width) + text


def _fate(m: Message) -> str:
    said = [f"read at step {j}" for j in m.heard] + [f"lost at step {j}" for j in m.lost]
    merged = sorted(said, key=lambda s: int(s.rsplit(" ", 1)[1]))
    return ", ".join(merged) if merged else "in flight when the trace ends"


# --- as SVG --------------------------------------------------------------------------------------------

LANE, ROW, TOP, LEFT = 190, 46, 70, 60  # a lifeline's width, a step's height, the header's height, the step column


def chart_svg(net: Network, cx: Counterexample, title: str) -> str:
    """The chart as an SVG drawing: a lifeline per instance, each step's state on it, and each message an arrow
    from its sender's lifeline, after the step it was sent, to its receiver's at each step it was read (solid) or
    lost (dashed, ending in a cross); one in flight when the run ends runs dotted to the bottom edge."""
    names = [i.name for i in net.instances]
    x = {n: LEFT + LANE * k + LANE // 2 for k, n in enumerate(names)}
    height = TOP + ROW * (len(cx.steps) + 1)
    width = LEFT + LANE * len(names)
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">',
        f"<title>{_text(title)}</title>",
        '<defs><marker id="head" markerWidth="8" markerHeight="8" refX="7" refY="4" orient="auto">'
        '<path d="M0,0 L8,4 L0,8 z"/></marker></defs>',
        f'<text x="8" y="18" font-weight="bold">{_text(title)}</text>',
    ]
    for n in names:
        out.append(f'<rect x="{x[n] - 60}" y="28" width="120" height="24" fill="#eef" stroke="#446"/>')
        out.append(f'<text x="{x[n]}" y="44" text-anchor="middle">{_text(n)}</text>')
        out.append(f'<line x1="{x[n]}" y1="52" x2="{x[n]}" y2="{height - 8}" stroke="#889"/>')
    for k, step in enumerate(cx.steps, start=1):
        y = _row(k)
        out.append(f'<text x="8" y="{y + 4}">step {k}</text>')
        was, now = _modes(step.state), _modes(step.outcome.next or step.state)
        for n in names:
            label = now.get(n, "?") if was.get(n) == now.get(n) else f"{was.get(n, '?')} → {now.get(n, '?')}"
            out.append(
                f'<text x="{x[n]}" y="{y + 4}" text-anchor="middle" fill="#000" stroke="#fff" stroke-width="3" '
                f'paint-order="stroke">{_text(label)}</text>'
            )
    for m in messages(net, cx):
        ch = net_channel(net, m.channel)
        out += _arrows(ch, m, x, height, _label(net, ch, m))
    out.append("</svg>")
    return "\n".join(out) + "\n"


def _row(step: int) -> int:
    return TOP + ROW * step - ROW // 2


def _arrows(ch: Channel, m: Message, x: dict[str, int], height: int, label: str) -> list[str]:
    x1, y1 = x[ch.sender], _row(m.sent) + 10
    drawn = []
    for j in m.heard:
        drawn.append(_arrow_svg((x1, y1), (x[ch.receiver], _row(j) - 10), "", label))
    for j in m.lost:
        x2, y2 = (x1 + 2 * x[ch.receiver]) // 3, (y1 + 2 * (_row(j) - 10)) // 3  # two thirds of the way
        drawn.append(_arrow_svg((x1, y1), (x2, y2), ' stroke-dasharray="5,3"', label, head=False))
        drawn.append(f'<path d="M{x2 - 5},{y2 - 5} L{x2 + 5},{y2 + 5} M{x2 - 5},{y2 + 5} L{x2 + 5},{y2 - 5}" '
                     'stroke="#c00" stroke-width="2"/>')  # fmt: skip
    if not m.heard and not m.lost:
        drawn.append(_arrow_svg((x1, y1), (x[ch.receiver], height - 8), ' stroke-dasharray="1,3"', label))
    return drawn


def _arrow_svg(start: tuple[int, int], end: tuple[int, int], style: str, label: str, *, head: bool = True) -> str:
    (x1, y1), (x2, y2) = start, end
    marker = ' marker-end="url(#head)"' if head else ""
    mid_x, mid_y = (x1 + x2) // 2, (y1 + y2) // 2 - 4
    return (
        f'<line x1="{x1}" y1="{y1}" x2="{x2}" y2="{y2}" stroke="#235"{style}{marker}/>'
        f'<text x="{mid_x}" y="{mid_y}" text-anchor="middle" font-size="11" fill="#235">{_text(label)}</text>'
    )


def _text(text: str) -> str:
    return xml_markup(xml_text(text))
