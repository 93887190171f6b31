"""What changed between two versions of a network, by meaning (pure): its channels' semantics and its schedule,
which every verdict of the network assumes, and its instances.

Each change to what the network assumes of its environment is judged as the set of runs it allows: a channel
that may lose fewer messages in a row, or be late by fewer steps, or must keep an order it need not keep before,
allows fewer runs (narrowed): every guarantee then covers fewer environments, a regression whatever the
verdicts say. One that allows more (widened) strengthens every guarantee. A change that neither narrows nor
widens (a channel rewired, a delay moved, a schedule changed, a channel added into or removed from a port) is
treated as a narrowing: the guarantees now speak of other environments.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from mlca_verify.model import show_number
from mlca_verify.network import Channel, Instance, Network, losses, qualified, timing

Relation = Literal["narrowed", "widened", "changed"]


@dataclass(frozen=True)
class NetworkChange:
    what: str  # "channel ab", "schedule", "instance A"
    old: str
    new: str
    relation: Relation | None  # None: not an assumption (an instance's spec or params): its verdicts say

    @property
    def regression(self) -> bool:
        """Every guarantee now covers fewer (or other) environments."""
        return self.relation in ("narrowed", "changed")


def delivery(ch: Channel) -> str:
    """A channel's ends and semantics in words: `A.x to B.y, 1 to 2 steps late, in order; at most 1 lost in a row`."""
    return f"{qualified(ch.sender, ch.output)} to {qualified(ch.receiver, ch.port)}, {timing(ch)}; {losses(ch)}"


def _runs_within(inner: Channel, outer: Channel) -> bool:
    """Every run `inner` allows, `outer` allows: ages within, losses within, and an order kept where `outer`
    keeps one (a single age keeps every order)."""
    ages = outer.delay <= inner.delay and inner.latest <= outer.latest
    single = inner.latest == inner.delay
    order = outer.order == "any" or inner.order == "fifo" or single
    once = single or inner.duplicate == outer.duplicate  # reading nothing, or the message before: no subset
    return ages and order and once and inner.lost <= outer.lost


def _channel(old: Channel, new: Channel) -> NetworkChange | None:
    was, now = delivery(old), delivery(new)
    if was == now:
        return None
    ends = (old.sender, old.output, old.receiver, old.port) == (new.sender, new.output, new.receiver, new.port)
    narrower, wider = _runs_within(new, old), _runs_within(old, new)
    relation: Relation = "changed" if not ends or narrower == wider else ("narrowed" if narrower else "widened")
    return NetworkChange(f"channel {old.id}", was, now, relation)


def _fairness(net: Network) -> str:
    if net.schedule == "synchronous":
        return "synchronous"
    return "interleaved" + (f", each within {net.fairness} steps" if net.fairness else ", no fairness bound")


def _schedule(old: Network, new: Network) -> NetworkChange | None:
    was, now = _fairness(old), _fairness(new)
    if was == now:
        return None
    relation: Relation = "changed"
    if old.schedule == new.schedule == "interleaved":
        bound_old, bound_new = old.fairness or 10**9, new.fairness or 10**9
        relation = "narrowed" if bound_new < bound_old else "widened"
    return NetworkChange("schedule", was, now, relation)


def network_changes(old: Network, new: Network) -> list[NetworkChange]:
    """The schedule, each channel (matched by id) and each instance (by name) that changed, in that order."""
    changes = [c for c in (_schedule(old, new),) if c is not None]
    after = {c.id: c for c in new.channels}
    before = {c.id: c for c in old.channels}
    for ch in old.channels:
        if ch.id not in after:
            changes.append(NetworkChange(f"channel {ch.id}", delivery(ch), "removed", "changed"))
        elif (found := _channel(ch, after[ch.id])) is not None:
            changes.append(found)
    changes += [
        NetworkChange(f"channel {c.id}", "-", delivery(c), "changed") for c in new.channels if c.id not in before
    ]
    now = {i.name: i for i in new.instances}
    for inst in old.instances:
        other = now.get(inst.name)
        if other is None:
            changes.append(NetworkChange(f"instance {inst.name}", inst.spec, "removed", "changed"))
        elif (inst.spec, inst.machine) != (other.spec, other.machine):
            changes.append(NetworkChange(f"instance {inst.name}", _instance(inst), _instance(other), None))
    was = {i.name for i in old.instances}
    changes += [NetworkChange(f"instance {i.name}", "-", i.spec, "changed") for i in new.instances if i.name not in was]
    return changes


def _instance(inst: Instance) -> str:
    params = ", ".join(f"{p.name} = {show_number(p.default, p.type == 'real')}" for p in inst.machine.params)
    return f"{inst.spec} ({inst.machine.name}{'; ' + params if params else ''})"


LABELS = {
    "narrowed": "fewer environments: every guarantee is weaker (a regression)",
    "widened": "more environments: every guarantee is stronger",
    "changed": "other environments, neither fewer nor more (a regression)",
    None: "its machine changed: the verdicts say what it does",
}


def network_changes_text(changes: list[NetworkChange]) -> str:
    """The changes, each with what it means for the guarantees."""
    if not changes:
        return "network: schedule, channels and instances unchanged\n"
    lines = ["network (what every verdict assumes, compared by the runs it allows):"]
    for c in changes:
        lines += [f"  {c.what}: {LABELS[c.relation]}", f"    old: {c.old}", f"    new: {c.new}"]
    return "\n".join([*lines, ""])
